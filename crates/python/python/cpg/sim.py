"""The HOAP-2 walking in MuJoCo: a gait played at 1 kHz, with balance feedback.

``python -m cpg.sim`` (also ``cpg-sim``) loads the package's physical HOAP-2
(``cpg.hoap2_mjcf()``), plays a walk in it and prints what happened::

    cpg retarget -s 35.asf -m 35_01.amc --steps 120 -o walk.csv
    python -m cpg.sim --trajectory walk.csv --seconds 60 --push-every-s 5 --push-mps 0.2 --json

The walk is either a trajectory (``cpg retarget``'s CSV: time_s and one
``JOINT_rad`` column per joint, played by linear interpolation) or a trained
model (``--model``, its channels named after the robot's joints, generated
at the control rate). The controller is an outer loop around it, once per
1-ms physics step (it runs in Rust, ``cpg_robot::control``, on MjData's
own arrays; Python only calls it and MuJoCo):

* **attitude feedback** from the simulated IMU (``imu_quat``, ``imu_gyro``):
  the trunk's pitch and roll and their rates, as offsets on the ankles
  (ankle strategy) and the hips (hip strategy) of both legs, and the
  trunk's heading as an offset on both hip yaws (steering),
  ``offset = -(kp * angle + kd * rate)``, each gain in ``Gains``;
* **contact feedback** (``lleg_touch``, ``rleg_touch``): the gait's clock
  waits while a swing foot that should have landed has not (at most
  ``max_wait_s`` per step), and jumps ahead to the touch-down when it lands
  early: phase resetting at touch-down, as Nakanishi et al. (2004) do for a
  CPG learnt from demonstration;
* every command moved by at most 5 rad/s x the step (MuJoCo has no joint
  speed limit) and kept within the servo's range.

A push changes the trunk's velocity by ``--push-mps`` over 0.1 s: a force
``M * v / 0.1`` on the trunk (M the whole robot's mass) through
``xfrc_applied``; with ``--push-phase random`` each push comes at a time
drawn uniformly from the first half of its interval (``--seed``), so that
it meets the gait at any phase once the interval is two strides or more.

The world (``World``): the floor tilted by ``--slope-deg`` about the
``--slope-axis`` (pitch: the walking direction goes uphill for a positive
angle; roll: the left side up), its friction ``--friction``; and the IMU as
a real one reads, relative to gravity (``cpg_robot::imu``): noise, a tilt
bias, a drifting heading and a latency. The JSON's ``world`` says which. The robot has fallen when the trunk drops below 60 % of its
standing height or tilts beyond 45 degrees.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from typing import Optional

import numpy as np

PUSH_S = 0.1
#: The longest run simulated, s.
MAX_SECONDS = 86_400.0
#: The largest push, m/s (ten times what the robot walks at).
MAX_PUSH_MPS = 5.0
DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}
#: The steepest floor, degrees.
MAX_SLOPE_DEG = 30.0
#: The IMU's bounds (``cpg_robot::imu``): latency, ms, and any bias, noise or drift, degrees.
MAX_IMU_LATENCY_MS = 1000.0
MAX_IMU_FAULT_DEG = 90.0


@dataclasses.dataclass
class World:
    """What the robot walks in beyond its own body: the floor and the IMU's faults (0: none).

    ``slope_deg`` tilts the floor about ``slope_axis`` (``pitch``: uphill
    ahead for a positive angle; ``roll``: the left side up); ``friction`` is
    the floor's sliding friction (``None``: the scene's); the IMU reports
    its roll or pitch (``imu_bias_axis``) off by ``imu_bias_deg``, its
    heading drifting by ``imu_yaw_drift_deg_s``, each reading with Gaussian
    noise of ``imu_noise_deg`` (degrees; its rates the same number in °/s)
    and ``imu_latency_ms`` late; ``seed`` draws the noise and random push times."""

    slope_deg: float = 0.0
    slope_axis: str = "pitch"
    friction: Optional[float] = None
    imu_noise_deg: float = 0.0
    imu_bias_deg: float = 0.0
    imu_bias_axis: str = "roll"
    imu_yaw_drift_deg_s: float = 0.0
    imu_latency_ms: float = 0.0
    seed: int = 0

    def check(self) -> None:
        """Raises ValueError naming the first setting outside its range."""
        from ._cli import check_finite

        check_finite(**{k: v for k, v in dataclasses.asdict(self).items() if isinstance(v, float)})
        if not abs(self.slope_deg) <= MAX_SLOPE_DEG:
            raise ValueError(f"slope {self.slope_deg}°: expected within ±{MAX_SLOPE_DEG:g}°")
        if self.slope_axis not in ("pitch", "roll"):
            raise ValueError(f"slope axis {self.slope_axis!r}: expected pitch or roll")
        if self.imu_bias_axis not in ("pitch", "roll"):
            raise ValueError(f"IMU bias axis {self.imu_bias_axis!r}: expected pitch or roll")
        if self.friction is not None and not (0.01 <= self.friction <= 10):
            raise ValueError(f"friction {self.friction}: expected 0.01 to 10")
        if not 0 <= self.imu_noise_deg <= MAX_IMU_FAULT_DEG:
            raise ValueError(f"IMU noise {self.imu_noise_deg}°: expected 0 to {MAX_IMU_FAULT_DEG:g}°")
        for name in ("imu_bias_deg", "imu_yaw_drift_deg_s"):
            if not abs(getattr(self, name)) <= MAX_IMU_FAULT_DEG:
                raise ValueError(f"{name} = {getattr(self, name)}: expected within ±{MAX_IMU_FAULT_DEG:g}")
        if not 0 <= self.imu_latency_ms <= MAX_IMU_LATENCY_MS:
            raise ValueError(f"IMU latency {self.imu_latency_ms} ms: expected 0 to {MAX_IMU_LATENCY_MS:g} ms")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or not 0 <= self.seed < 2**63:
            raise ValueError(f"seed {self.seed!r}: expected a whole number from 0 to 2^63 - 1")

    def imu_json(self) -> str:
        """The IMU's faults as ``cpg_robot::imu::ImuFaults`` reads them."""
        bias = {"bias_roll_deg": 0.0, "bias_pitch_deg": 0.0}
        bias[f"bias_{self.imu_bias_axis}_deg"] = float(self.imu_bias_deg)
        return json.dumps(dict(
            noise_deg=float(self.imu_noise_deg), yaw_drift_deg_s=float(self.imu_yaw_drift_deg_s),
            latency_ms=float(self.imu_latency_ms), seed=int(self.seed), **bias,
        ))


@dataclasses.dataclass
class Gains:
    """Feedback gains (rad per rad, rad per rad/s; 0: none)."""

    ankle_pitch_kp: float = 0.0
    ankle_pitch_kd: float = 0.0
    ankle_roll_kp: float = 0.0
    ankle_roll_kd: float = 0.0
    hip_pitch_kp: float = 0.0
    hip_roll_kp: float = 0.0
    hip_yaw_kp: float = 0.0
    phase_reset: bool = False
    max_wait_s: float = 0.1

    @classmethod
    def from_json(cls, text: str) -> "Gains":
        """Gains from a JSON object: known names only, finite numbers, ``phase_reset`` true or false."""
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise ValueError(f"gains: not JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
        if not isinstance(d, dict):
            raise ValueError(f"gains: expected a JSON object of names and numbers, found {type(d).__name__}")
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = set(d) - set(fields)
        if unknown:
            raise ValueError(f"unknown gains {sorted(unknown)}; known: {list(fields)}")
        for k, v in d.items():
            if k == "phase_reset":
                if not isinstance(v, bool):
                    raise ValueError(f"gains: phase_reset = {v!r}: expected true or false")
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"gains: {k} = {v!r}: expected a finite number")
        if "max_wait_s" in d and not 0 <= d["max_wait_s"] <= 10:
            raise ValueError(f"gains: max_wait_s = {d['max_wait_s']}: expected 0 to 10 s")
        return cls(**d)


def read_trajectory(path: str):
    """(times_s, joint names, angles frames x joints) of a ``cpg retarget`` CSV, and its support column if any.
    The file is read within a bound (``cpg._cli.MAX_TEXT_BYTES``)."""
    import io

    from ._cli import read_text

    text = read_text(path)
    header = text.split("\n", 1)[0].strip().split(",")
    if not header or header[0] != "time_s":
        raise ValueError(f"{path}: line 1: expected a header starting with time_s, found {header[:1]}")
    cols = [k for k, h in enumerate(header) if h.endswith("_rad")]
    if not cols:
        raise ValueError(f"{path}: line 1: no JOINT_rad column")
    if not text.split("\n", 1)[1:] or not text.split("\n", 1)[1].strip():
        raise ValueError(f"{path}: line 2: no rows after the header (expected at least 2)")
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # numpy's warnings about the text are errors of the file
            data = np.genfromtxt(io.StringIO(text), delimiter=",", skip_header=1, usecols=[0, *cols], dtype=float)
    except (ValueError, UserWarning) as e:
        raise ValueError(f"{path}: {e}") from None
    data = np.atleast_2d(data)
    if data.shape[0] < 2 or not np.all(np.isfinite(data)):
        bad = int(np.argwhere(~np.isfinite(data))[0][0]) + 2 if not np.all(np.isfinite(data)) else 2
        raise ValueError(f"{path}: line {bad}: expected finite numbers in every column (and at least 2 rows)")
    t = data[:, 0]
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"{path}: time_s must increase")
    support = None
    if "support" in header:
        k = header.index("support")
        support = np.genfromtxt(io.StringIO(text), delimiter=",", skip_header=1, usecols=[k], dtype=str)
    return t, [header[k][: -len("_rad")] for k in cols], data[:, 1:], support


class Diverged(ValueError):
    """The physics became unstable (MuJoCo found a non-finite or huge acceleration)."""


def simulate(
    times_s,
    joints,
    angles_rad,
    support=None,
    *,
    seconds: Optional[float] = None,
    gains: Gains = Gains(),
    push_every_s: float = 0.0,
    push_mps: float = 0.0,
    push_direction: str = "all",
    tempo: float = 1.0,
    tempo_at_s: float = 0.0,
    record_every: int = 0,
    cpg_model=None,
    handover_s: Optional[float] = None,
    cpg_controls: Optional[dict] = None,
    tempo_ramp_s: float = 3.0,
    stop_at_s: Optional[float] = None,
    stop_ramp_s: float = 2.0,
    robot: str = "hoap2",
    push_phase: str = "fixed",
    world: World = World(),
    start: str = "plan",
    start_at_s: float = 2.0,
    start_ramp_s: float = 2.0,
):
    """Plays a walk in a robot's MuJoCo scene (``robot``: a built-in name,
    ``hoap2``, or a robot's folder with its ``robot.toml``, which names the
    scene, its trunk and sensors and its legs); returns the run's measures (a dict).

    With ``cpg_model`` (a trained ``cpg.Model`` whose channels are ``JOINT.rx`` in
    degrees), the walk's trajectory gives the start (standing, the first
    steps) and the joints the model does not drive; from ``handover_s`` on
    (default: the trajectory's 10th left touch-down) the model's generator
    drives, stepped inside the loop at its own rate, its phase matched to
    the trajectory's at the hand-over. A model with control inputs gets
    ``cpg_controls`` (by name; default: its first teacher's setting); when one
    of them is ``u_tempo``, a tempo change is that input times the tempo (the
    CPG's own tempo input), reached by a cosine ramp of ``tempo_ramp_s``;
    otherwise the generator's clock runs faster. With ``stop_at_s``, a model
    with a ``u_walk`` input is told to stop there: ``u_walk`` falls to 0 by a
    cosine ramp of ``stop_ramp_s`` (its training blends last 2 s), and the
    run reports how far the trunk moved from 3 s after the ramp to the end
    (``moved_after_stop_m``). ``world`` tilts the floor, sets its friction and
    gives the IMU its faults (:class:`World`); ``push_phase`` ``random`` draws
    each push's time within the first half of its interval (``world.seed``).

    ``start="standing"`` needs a model with a ``u_walk`` input: the model
    drives from the first step, no plan and no hand-over. Its generator is
    first run 10 s with ``u_walk`` at 0 (standing), the robot starts in the
    pose it then holds, and ``u_walk`` rises to its setting by a cosine ramp
    of ``start_ramp_s`` from ``start_at_s``: the walk starts from standing.
    The trajectory then only gives the joints the model does not drive
    (:func:`standing_plan` gives the robot's home pose)."""
    import mujoco

    # MuJoCo's warnings (an unstable simulation) are collected for the error
    # that reports them, not printed or written to MUJOCO_LOG.TXT in the working directory.
    seen: list = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(seen.append)
    try:
        return _simulate(
            seen, times_s, joints, angles_rad, support, seconds=seconds, gains=gains, push_every_s=push_every_s,
            push_mps=push_mps, push_direction=push_direction, tempo=tempo, tempo_at_s=tempo_at_s,
            record_every=record_every, cpg_model=cpg_model, handover_s=handover_s, cpg_controls=cpg_controls,
            tempo_ramp_s=tempo_ramp_s, stop_at_s=stop_at_s, stop_ramp_s=stop_ramp_s, robot=robot,
            push_phase=push_phase, world=world, start=start, start_at_s=start_at_s, start_ramp_s=start_ramp_s,
        )
    finally:
        mujoco.set_mju_user_warning(previous)


def _simulate(
    warnings_seen: list,
    times_s,
    joints,
    angles_rad,
    support=None,
    *,
    seconds: Optional[float] = None,
    gains: Gains = Gains(),
    push_every_s: float = 0.0,
    push_mps: float = 0.0,
    push_direction: str = "all",
    tempo: float = 1.0,
    tempo_at_s: float = 0.0,
    record_every: int = 0,
    cpg_model=None,
    handover_s: Optional[float] = None,
    cpg_controls: Optional[dict] = None,
    tempo_ramp_s: float = 3.0,
    stop_at_s: Optional[float] = None,
    stop_ramp_s: float = 2.0,
    robot: str = "hoap2",
    push_phase: str = "fixed",
    world: World = World(),
    start: str = "plan",
    start_at_s: float = 2.0,
    start_ramp_s: float = 2.0,
):
    """The body of :func:`simulate`; MuJoCo's warnings go to ``warnings_seen``."""
    import mujoco

    from ._cli import check_finite

    check_finite(
        seconds=seconds,
        push_every_s=push_every_s,
        push_mps=push_mps,
        tempo=tempo,
        tempo_at_s=tempo_at_s,
        handover_s=handover_s,
        tempo_ramp_s=tempo_ramp_s,
        stop_at_s=stop_at_s,
        stop_ramp_s=stop_ramp_s,
        start_at_s=start_at_s,
        start_ramp_s=start_ramp_s,
    )
    if start not in ("plan", "standing"):
        raise ValueError(f"start {start!r}: expected plan or standing")
    standing = start == "standing"
    if standing and (cpg_model is None or "u_walk" not in cpg_model.controls):
        raise ValueError("start='standing' needs a model with a u_walk input (it starts the walk)")
    if not (0 <= start_at_s <= MAX_SECONDS and 0 <= start_ramp_s <= 60):
        raise ValueError(f"start at {start_at_s} s over {start_ramp_s} s: expected 0 s or later, a ramp of 0 to 60 s")
    if seconds is not None and not (0 < seconds <= MAX_SECONDS):
        raise ValueError(f"seconds = {seconds}: expected more than 0 and at most {MAX_SECONDS:g}")
    if push_every_s < 0 or not (0 <= push_mps <= MAX_PUSH_MPS):
        raise ValueError(f"push every {push_every_s} s of {push_mps} m/s: expected every ≥ 0 s, 0 to {MAX_PUSH_MPS:g} m/s")
    if push_direction != "all" and push_direction not in DIRECTIONS:
        raise ValueError(f"push direction {push_direction!r}: expected one of {[*DIRECTIONS, 'all']}")
    if not (0.25 <= tempo <= 4.0):
        raise ValueError(f"tempo {tempo}: expected 0.25–4")
    if push_phase not in ("fixed", "random"):
        raise ValueError(f"push phase {push_phase!r}: expected fixed or random")
    if not isinstance(world, World):
        raise ValueError(f"world: expected a cpg.sim.World, found {type(world).__name__}")
    world.check()
    import cpg

    scene = cpg._cpg._robot_scene(robot)
    model = _scene_model(scene, world)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    dt = model.opt.timestep
    try:
        act = np.array([model.actuator(j).id for j in joints])
    except KeyError as e:
        raise ValueError(f"the walk names a joint the {scene['title']} has no servo for: {e}") from None
    lo, hi = model.actuator_ctrlrange[act, 0], model.actuator_ctrlrange[act, 1]
    qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in joints])
    duration = float(times_s[-1] - times_s[0])
    total = duration if seconds is None else float(seconds)
    clock_t = np.ascontiguousarray(times_s - times_s[0], dtype=float)
    angles_rad = np.ascontiguousarray(angles_rad, dtype=float)
    first = angles_rad[0]
    data.qpos[qadr] = first
    data.ctrl[act] = first
    mujoco.mj_forward(model, data)
    trunk = model.body(scene["trunk"]).id
    mass = float(np.sum(model.body_mass))
    touch_adr = [model.sensor(name).adr[0] for name in scene["touch"]]
    start_xyz = data.xpos[trunk].copy()
    stand_z = start_xyz[2]
    # Touch-down times of the plan: where support turns from single to double.
    landings = []
    if support is not None and len(support) == len(clock_t):
        for k in range(1, len(support)):
            if support[k] == "double" and support[k - 1] in ("left", "right"):
                landings.append((float(clock_t[k]), 1 if support[k - 1] == "left" else 0))  # the foot that swung
    # The controller (cpg._cpg._WalkLoop, cpg_robot::control): before each
    # step it reads the sensors and writes data.ctrl, after it counts the
    # servos' torque and work, on MjData's own arrays.
    setup = dict(
        clock_s=clock_t,
        angles_rad=angles_rad,
        joints=list(joints),
        landings=landings,
        act=[int(a) for a in act],
        lo=[float(v) for v in lo],
        hi=[float(v) for v in hi],
        gains_json=json.dumps(dataclasses.asdict(gains)),
        mass_kg=mass,
        dt_s=dt,
        tempo=float(tempo),
        tempo_at_s=float(tempo_at_s),
        sensordata=data.sensordata,
        ctrl=data.ctrl,
        force=data.actuator_force,
        velocity=data.actuator_velocity,
        quat_adr=int(model.sensor(scene["imu_quat"]).adr[0]),
        gyro_adr=int(model.sensor(scene["imu_gyro"]).adr[0]),
        touch_adr=[int(a) for a in touch_adr],
        imu_json=world.imu_json(),
    )
    if cpg_model is not None:
        ctl_names = list(cpg_model.controls)
        base = dict(zip(ctl_names, cpg_model.teachers[0]["controls"])) if ctl_names else {}
        unknown = set(cpg_controls or {}) - set(ctl_names)
        if unknown:
            raise ValueError(f"controls {sorted(unknown)} are not the model's inputs {ctl_names}")
        base.update(cpg_controls or {})
        if stop_at_s is not None and "u_walk" not in ctl_names:
            raise ValueError(f"stop_at_s needs a model with a u_walk input; its inputs are {ctl_names}")
        schedule = dict(
            base=[float(base[c]) for c in ctl_names],
            tempo_input=ctl_names.index("u_tempo") if "u_tempo" in ctl_names else None,
            walk_input=ctl_names.index("u_walk") if "u_walk" in ctl_names else None,
            tempo_ramp_s=float(tempo_ramp_s),
            stop_at_s=None if stop_at_s is None else float(stop_at_s),
            stop_ramp_s=float(stop_ramp_s),
            start_at_s=float(start_at_s) if standing else None,
            start_ramp_s=float(start_ramp_s),
        )
        u0 = cpg._cpg._controls_at(0.0, tempo=float(tempo), tempo_at_s=float(tempo_at_s), **schedule)
        if standing:
            gen, drive, rate, first_rad = _standing_generator(cpg_model, joints, u0)
            handover_s = 0.0
            # The robot starts in the pose the generator stands in.
            data.qpos[qadr[drive]] = first_rad
            data.ctrl[act[drive]] = first_rad
            mujoco.mj_forward(model, data)
            start_xyz = data.xpos[trunk].copy()
        else:
            gen, drive, rate, first_rad, handover_s = _generator_for(cpg_model, joints, clock_t, angles_rad, support, handover_s, u0 or None)
        setup.update(
            generator=gen,
            drive=[int(k) for k in drive],
            rate_hz=rate,
            handover_s=float(handover_s),
            first_rad=[float(v) for v in first_rad],
            **schedule,
        )
    loop = cpg._cpg._WalkLoop(**setup, robot=str(robot))
    fall_z, fall_up = 0.6 * stand_z, math.cos(math.radians(45))  # below 60 % of its height, tilted beyond 45°
    pushes_total = pushes_survived = 0
    push_left = 0.0
    push_force = np.zeros(3)
    draws = np.random.default_rng(world.seed)
    # Each push's time: the start of its interval, or (random phase) within the first half of it.
    jitter = (lambda: float(draws.uniform(0.0, 0.5 * push_every_s))) if push_phase == "random" else (lambda: 0.0)
    slot = push_every_s
    next_push = slot + jitter() if push_every_s > 0 else math.inf
    dirs = list(DIRECTIONS) if push_direction == "all" else [push_direction]
    pending = None  # (time it began, steps to survive)
    fell_at = None
    path = []
    contacts = []
    poses = []  # t, the trunk's position and orientation (w, x, y, z), every servoed joint's angle
    pose_joints = [model.actuator(k).name for k in range(model.nu)]
    all_q = np.array([model.jnt_qposadr[model.joint(j).id] for j in pose_joints])
    n = int(round(total / dt))
    trunk_z = data.xpos[trunk][2:]  # views: MjData's arrays stay where they are
    trunk_up = data.xmat[trunk][8:]
    pushing = False
    settled_at = None if stop_at_s is None else stop_at_s + stop_ramp_s + 3.0
    settled_xy = None  # where the trunk was once the stop had settled
    control, measure, mj_step = loop.control, loop.measure, mujoco.mj_step
    # MuJoCo counts the steps whose accelerations were not finite (and resets the state
    # when it finds one): such a run is unstable, whatever the trunk's height says.
    bad_acc = data.warning[mujoco.mjtWarning.mjWARN_BADQACC]
    step = -1
    for step in range(n):
        t = step * dt
        recording = record_every and step % record_every == 0
        if recording:
            touch = data.sensordata[touch_adr]  # the soles' forces as the controller reads them
        control(t)
        # Pushes.
        if t >= next_push and push_left <= 0:
            dx, dy = DIRECTIONS[dirs[pushes_total % len(dirs)]]
            push_force = np.array([dx, dy, 0.0]) * mass * push_mps / PUSH_S
            push_left = PUSH_S
            pushing = False  # a new force to apply, even right after the last push
            pushes_total += 1
            pending = t
            slot += push_every_s
            next_push = slot + jitter()
        if pushing != (push_left > 0):
            pushing = push_left > 0
            data.xfrc_applied[trunk, :3] = push_force if pushing else 0.0
        push_left -= dt
        mj_step(model, data)
        measure()
        if bad_acc.number:
            said = f" (MuJoCo: {warnings_seen[0].split('. Time')[0]})" if warnings_seen else ""
            raise Diverged(
                f"the simulation became unstable at {t + dt:.3f} s: a non-finite or huge acceleration{said}; "
                "its measures would mean nothing"
            )
        if trunk_z[0] < fall_z or trunk_up[0] < fall_up:
            fell_at = t + dt
            break
        if pending is not None and t - pending >= min(2.0, push_every_s):
            pushes_survived += 1
            pending = None
        if settled_xy is None and settled_at is not None and t >= settled_at:
            settled_xy = data.xpos[trunk][:2].copy()
        if recording:
            path.append([t, *map(float, data.xpos[trunk])])
            contacts.append([t, float(touch[0]), float(touch[1])])
            poses.append([t, *map(float, data.xpos[trunk]), *map(float, data.xquat[trunk]), *map(float, data.qpos[all_q])])
    steps_run = step + 1
    if not (np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))):
        raise Diverged(f"the simulation's state stopped being finite by {steps_run * dt:.3f} s")
    end = data.xpos[trunk] - start_xyz
    m = data.xmat[trunk].reshape(3, 3)
    heading = math.degrees(math.atan2(m[1, 0], m[0, 0]))
    distance = float(math.hypot(end[0], end[1]))
    upright = steps_run * dt if fell_at is None else fell_at
    leg_m = scene["leg_m"]
    out = {
        "seconds": total,
        "upright_s": upright,
        "fell": fell_at is not None,
        "forward_m": float(end[0]),
        "lateral_m": float(end[1]),
        "heading_deg": heading,
        "speed_m_s": float(end[0]) / upright if upright > 0 else 0.0,
        "speed_leg_lengths_s": float(end[0]) / upright / leg_m if upright > 0 else 0.0,
        "max_torque_nm": float(max(loop.torque_peak)),
        "cost_of_transport": loop.work_j / (mass * 9.81 * distance) if distance > 1e-3 else None,
        "pushes_survived": pushes_survived,
        "pushes_total": pushes_total,
        "gait_clock_s": loop.clock_s,
        "push_phase": push_phase,
        "world": dataclasses.asdict(world),
    }
    out["start"] = start
    if standing:
        out["start_at_s"] = float(start_at_s)
    if cpg_model is not None:
        out["handover_s"] = float(handover_s)
    if stop_at_s is not None:
        out["stop_at_s"] = float(stop_at_s)
        moved = None if settled_xy is None else float(np.hypot(*(data.xpos[trunk][:2] - settled_xy)))
        out["moved_after_stop_m"] = moved
    if record_every:
        out["trunk_path"] = path
        out["contacts_n"] = contacts
        out["pose_joints"] = pose_joints
        out["poses"] = poses
    return out


def _scene_model(scene, world: World):
    """The robot's MuJoCo model, its floor tilted and given its friction as
    ``world`` asks (through ``mujoco.MjSpec``; an unchanged floor loads the
    scene as it is)."""
    import mujoco

    if world.slope_deg == 0 and world.friction is None:
        if scene["mjcf_path"] is not None:
            return mujoco.MjModel.from_xml_path(str(scene["mjcf_path"]))
        return mujoco.MjModel.from_xml_string(scene["mjcf"])
    if scene["mjcf_path"] is not None:
        spec = mujoco.MjSpec.from_file(str(scene["mjcf_path"]))
    else:
        spec = mujoco.MjSpec.from_string(scene["mjcf"])
    floor = spec.geom("floor")
    if floor is None:
        raise ValueError(f"the {scene['title']}'s scene has no geom named 'floor' to tilt or to give a friction")
    half = math.radians(world.slope_deg) / 2
    # Pitch: about -y, the floor ahead (+x) rising for a positive angle; roll: about x, the left (+y) side up.
    axis = (0.0, -1.0, 0.0) if world.slope_axis == "pitch" else (1.0, 0.0, 0.0)
    floor.quat = [math.cos(half), *(math.sin(half) * a for a in axis)]
    if world.friction is not None:
        floor.friction[0] = float(world.friction)
        # MuJoCo takes the larger friction of two touching geoms unless one has the higher priority.
        floor.priority = 1 + max(g.priority for g in spec.geoms)
    return spec.compile()


def fit_walk(times_s, joints, angles_rad, support, *, seed: int = 1, neurons: int = 600, stride_index: int = 20):
    """A CPG of the walk's steady stride: every joint that moves (legs and
    arms), one stride (left touch-down to left touch-down) looped 12 times,
    trained as E6 is (teacher noise 0.1, orbit validation with a push)."""
    import cpg

    if support is None:
        raise ValueError("the trajectory has no support column: give cpg retarget's CSV")
    strikes = [k for k in range(1, len(support)) if support[k] == "double" and support[k - 1] == "right"]
    if len(strikes) < stride_index + 2:
        raise ValueError(f"the walk has {len(strikes)} left touch-downs; fitting needs {stride_index + 2} (more --steps)")
    a, b = strikes[stride_index], strikes[stride_index + 1]
    drive = [k for k, j in enumerate(joints) if np.ptp(angles_rad[:, k]) > 1e-6]
    rate = 1.0 / float(times_s[1] - times_s[0])
    y = np.degrees(np.tile(angles_rad[a:b][:, drive], (12, 1)))
    config = {
        "reservoir": {"n_neurons": int(neurons), "feedback": {"fraction": 0.65, "scale": 0.11}},
        "training": {
            "washout": 200,
            "noise_variance": 0,
            "noise_draws": 1,
            "penalty_log10": {"start": 4, "step": 0.1, "stop": -5},
            "teacher_noise": 0.1,
            "score": "orbit",
            "prefer_larger_within": 1,
            "orbit": {"stay_s": 10, "settle_s": 6.5, "push": {"at_s": 1.3, "hold_s": 0.1, "above_max": 1}},
        },
    }
    return cpg.fit(y, rate_hz=rate, channels=[joints[k] + ".rx" for k in drive], seed=int(seed), config=config)


def _driven_joints(model, joints):
    """The index in ``joints`` of each of the model's channels (``JOINT.rx``)."""
    names = [c[:-3] if c.endswith(".rx") else c for c in model.channels]
    missing = [n for n in names if n not in joints]
    if missing:
        raise ValueError(f"the model's channels {missing} are not joints of the walk (expected JOINT.rx channels)")
    return np.array([joints.index(n) for n in names])


def _generator_for(model, joints, clock_t, angles_rad, support, handover_s, controls=None):
    """The model's generator, stepped to the phase that matches the trajectory at the hand-over
    (``controls``: its control values, held)."""
    drive = _driven_joints(model, joints)
    rate = float(model.rate_hz)
    if handover_s is None:
        strikes = [clock_t[k] for k in range(1, len(clock_t)) if support is not None and support[k] == "double" and support[k - 1] == "right"]
        handover_s = strikes[9] if len(strikes) > 9 else float(clock_t[len(clock_t) // 2])
    k = int(np.searchsorted(clock_t, handover_s))
    want = angles_rad[min(k, len(clock_t) - 1), drive]
    u = controls if controls else None
    probe = model.generator()
    steps = int(round(4.0 * rate))  # a few strides: the generator's own rhythm
    ys = np.radians(np.asarray([probe.step(u) for _ in range(steps)], dtype=float))
    best = int(np.argmin(np.sum((ys[steps // 2 :] - want) ** 2, axis=1))) + steps // 2
    gen = model.generator()
    for _ in range(best):
        gen.step(u)
    first = np.radians(np.asarray(gen.step(u), dtype=float))
    return gen, drive, rate, first, handover_s


def _standing_generator(model, joints, controls):
    """The model's generator after 10 s at ``controls`` (its walk input at 0:
    standing), the joints it drives, its rate and the pose it holds (rad)."""
    drive = _driven_joints(model, joints)
    rate = float(model.rate_hz)
    gen = model.generator()
    for _ in range(int(round(10.0 * rate))):
        gen.step(controls)
    first = np.radians(np.asarray(gen.step(controls), dtype=float))
    return gen, drive, rate, first


def standing_plan(robot: str = "hoap2", seconds: float = 1.0):
    """A 'walk' that stands in the robot's home pose (its scene's ``home``
    keyframe): (times_s, joints, angles_rad, support) as :func:`read_trajectory`
    gives them, for ``simulate(..., start="standing")`` without a trajectory."""
    import mujoco

    import cpg

    scene = cpg._cpg._robot_scene(robot)
    model = _scene_model(scene, World())
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    joints = [model.actuator(k).name for k in range(model.nu)]
    pose = np.array([data.qpos[model.jnt_qposadr[model.joint(j).id]] for j in joints], dtype=float)
    return np.array([0.0, float(seconds)]), joints, np.vstack([pose, pose]), None


def main(argv=None) -> int:
    from ._cli import check_output, number, read_text, run, whole, write_output, MAX_JSON_BYTES

    p = argparse.ArgumentParser(prog="cpg-sim", description=__doc__.split("\n\n")[0])
    p.add_argument("--trajectory", help="a walk as `cpg retarget` writes it (CSV); with --model, the start (required unless --start standing)")
    p.add_argument("--model", help="a trained model (channels JOINT.rx, degrees) that drives after the hand-over")
    p.add_argument("--handover-s", type=number(0.0), help="when the model takes over (default: the 10th left touch-down)")
    p.add_argument("--start", default="plan", choices=["plan", "standing"], help="plan: the trajectory's walk, then the model from the hand-over; standing: the model from the first step, standing until --start-at-s, then walking (its u_walk input ramped up over 2 s)")
    p.add_argument("--start-at-s", type=number(0.0, MAX_SECONDS), default=2.0, help="with --start standing: when the walk starts, s")
    p.add_argument("--seconds", type=number(0.0, MAX_SECONDS, lo_open=True), help="how long to simulate (default: the walk's length; 60 s from standing without a trajectory)")
    p.add_argument("--push-every-s", type=number(0.0), default=0.0, help="push the trunk every T s (0: never)")
    p.add_argument("--push-mps", type=number(0.0, MAX_PUSH_MPS), default=0.2, help="each push's change of the trunk's velocity, m/s")
    p.add_argument("--push-direction", default="all", choices=[*DIRECTIONS, "all"], help="all: in turn")
    p.add_argument("--push-phase", default="fixed", choices=["fixed", "random"], help="fixed: every --push-every-s; random: at a time drawn within the first half of each interval (--seed)")
    p.add_argument("--slope-deg", type=number(-MAX_SLOPE_DEG, MAX_SLOPE_DEG), default=0.0, help="tilt the floor by this many degrees (pitch: uphill ahead when positive; roll: left side up)")
    p.add_argument("--slope-axis", default="pitch", choices=["pitch", "roll"], help="the axis the floor tilts about")
    p.add_argument("--friction", type=number(0.01, 10.0), help="the floor's sliding friction (default: the scene's)")
    p.add_argument("--imu-noise-deg", type=number(0.0, MAX_IMU_FAULT_DEG), default=0.0, help="Gaussian noise on each IMU reading's angles, degrees (its rates: the same in °/s)")
    p.add_argument("--imu-bias-deg", type=number(-MAX_IMU_FAULT_DEG, MAX_IMU_FAULT_DEG), default=0.0, help="a constant error of the IMU's roll or pitch (--imu-bias-axis), degrees")
    p.add_argument("--imu-bias-axis", default="roll", choices=["roll", "pitch"], help="which angle --imu-bias-deg offsets")
    p.add_argument("--imu-yaw-drift-deg-s", type=number(-MAX_IMU_FAULT_DEG, MAX_IMU_FAULT_DEG), default=0.0, help="how fast the IMU's heading drifts, degrees per second")
    p.add_argument("--imu-latency-ms", type=number(0.0, MAX_IMU_LATENCY_MS), default=0.0, help="how late each IMU reading reaches the controller, ms")
    p.add_argument("--seed", type=whole(0, 2**63 - 1), default=0, help="the draw of the disturbances: IMU noise, random push times (0 to 2^63 - 1)")
    p.add_argument("--tempo", type=number(0.25, 4.0), default=1.0, help="the gait's speed factor from --tempo-at-s on (0.25–4)")
    p.add_argument("--tempo-at-s", type=number(0.0), default=0.0, help="when the tempo changes, s")
    p.add_argument("--stop-at-s", type=number(0.0), help="tell the model to stop here (its u_walk input to 0 over 2 s) and stand")
    p.add_argument("--robot", default="hoap2", help="the robot: a built-in name (hoap2) or a robot's folder with its robot.toml")
    p.add_argument("--gains", help="feedback gains as JSON (see cpg.sim.Gains), or @FILE (default: the robot's shipped gains, its robot.toml's `gains`, with --model; none without)")
    p.add_argument("--no-gains", action="store_true", help="no feedback at all, even with --model")
    p.add_argument("--json", action="store_true", help="print the measures as JSON")
    p.add_argument("-o", "--output", help="write the measures (with the trunk path, contacts and body poses at 50 Hz; `cpg view --sim` shows them) as JSON here (- for standard output)")
    a = p.parse_args(argv)

    def body() -> int:
        # Everything that can be checked is checked before the simulation.
        check_output(a.output)
        gains, gains_from = Gains(), "none"
        if a.gains and a.no_gains:
            raise ValueError("--gains and --no-gains: give one")
        if a.gains:
            text = read_text(a.gains[1:], MAX_JSON_BYTES) if a.gains.startswith("@") else a.gains
            gains, gains_from = Gains.from_json(text), "--gains"
        elif a.model and not a.no_gains:
            import cpg

            shipped = cpg._cpg._robot_scene(a.robot)["gains_json"]
            if shipped is not None:
                gains, gains_from = Gains.from_json(shipped), "the robot's"
        world = World(
            slope_deg=a.slope_deg, slope_axis=a.slope_axis, friction=a.friction, imu_noise_deg=a.imu_noise_deg,
            imu_bias_deg=a.imu_bias_deg, imu_bias_axis=a.imu_bias_axis, imu_yaw_drift_deg_s=a.imu_yaw_drift_deg_s,
            imu_latency_ms=a.imu_latency_ms, seed=a.seed,
        )
        world.check()
        if a.start == "standing" and not a.model:
            raise ValueError("--start standing needs --model (a model with a u_walk input)")
        if a.trajectory is None and a.start != "standing":
            raise ValueError("--trajectory is required unless --start standing")
        if a.trajectory is None:
            t, joints, q, support = standing_plan(a.robot)
            if a.seconds is None:
                a.seconds = 60.0  # a standing start has no trajectory's length to default to
        else:
            t, joints, q, support = read_trajectory(a.trajectory)
        model = None
        if a.model:
            import cpg

            model = cpg.load(a.model)
        r = simulate(
            t,
            joints,
            q,
            support,
            seconds=a.seconds,
            gains=gains,
            push_every_s=a.push_every_s,
            push_mps=a.push_mps,
            push_direction=a.push_direction,
            tempo=a.tempo,
            tempo_at_s=a.tempo_at_s,
            record_every=20 if a.output else 0,
            cpg_model=model,
            handover_s=a.handover_s,
            stop_at_s=a.stop_at_s,
            robot=a.robot,
            push_phase=a.push_phase,
            world=world,
            start=a.start,
            start_at_s=a.start_at_s,
        )
        r["gains_from"] = gains_from
        if a.output:
            write_output(a.output, json.dumps(r))
        summary = {k: v for k, v in r.items() if k not in ("trunk_path", "contacts_n", "pose_joints", "poses")}
        if a.json:
            print(json.dumps(summary, indent=2))
        else:
            state = f"fell after {r['upright_s']:.2f} s" if r["fell"] else f"upright for {r['upright_s']:.1f} s"
            print(
                f"{state}; {r['forward_m']:+.2f} m forward, {r['lateral_m']:+.2f} m sideways, heading {r['heading_deg']:+.1f}°; "
                f"largest torque {r['max_torque_nm']:.2f} N·m; pushes survived {r['pushes_survived']} of {r['pushes_total']}"
            )
            if r.get("moved_after_stop_m") is not None:
                print(f"stopped at {r['stop_at_s']:.1f} s; the trunk moved {r['moved_after_stop_m'] * 1000:.0f} mm from 3 s after the stop to the end")
        return 0

    return run("cpg-sim", body)


if __name__ == "__main__":
    sys.exit(main())

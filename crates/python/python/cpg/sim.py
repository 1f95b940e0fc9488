"""The HOAP-2 walking in MuJoCo: a gait played at 1 kHz, with balance feedback.

``python -m cpg.sim`` (also ``cpg-sim``) loads the package's physical HOAP-2
(``cpg.hoap2_mjcf()``), plays a walk in it and prints what happened::

    cpg retarget -s 35.asf -m 35_01.amc --steps 120 -o walk.csv
    python -m cpg.sim --trajectory walk.csv --seconds 60 --push-every-s 5 --push-mps 0.2 --json

The walk is either a trajectory (``cpg retarget``'s CSV: time_s and one
``JOINT_rad`` column per joint, played by linear interpolation) or a trained
model (``--model``, its channels named after the robot's joints, generated
at the control rate). The controller is an outer loop around it, once per
1-ms physics step:

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
``xfrc_applied``. The robot has fallen when the trunk drops below 60 % of its
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

SPEED_LIMIT_RAD_S = 5.0
PUSH_S = 0.1
DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}


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
        d = json.loads(text)
        unknown = set(d) - {f.name for f in dataclasses.fields(cls)}
        if unknown:
            raise ValueError(f"unknown gains {sorted(unknown)}; known: {[f.name for f in dataclasses.fields(cls)]}")
        return cls(**d)


def read_trajectory(path: str):
    """(times_s, joint names, angles frames x joints) of a ``cpg retarget`` CSV, and its support column if any."""
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
    if not header or header[0] != "time_s":
        raise ValueError(f"{path}: line 1: expected a header starting with time_s, found {header[:1]}")
    cols = [k for k, h in enumerate(header) if h.endswith("_rad")]
    if not cols:
        raise ValueError(f"{path}: line 1: no JOINT_rad column")
    data = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=[0, *cols], dtype=float, max_rows=2_000_000)
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
        support = np.genfromtxt(path, delimiter=",", skip_header=1, usecols=[k], dtype=str, max_rows=2_000_000)
    return t, [header[k][: -len("_rad")] for k in cols], data[:, 1:], support


def _tilt(quat):
    w, x, y, z = quat  # Python floats: their arithmetic is the same IEEE double, faster than numpy scalars'
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


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
):
    """Plays a walk in the HOAP-2 model; returns the run's measures (a dict).

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
    (``moved_after_stop_m``)."""
    import mujoco

    if push_direction != "all" and push_direction not in DIRECTIONS:
        raise ValueError(f"push direction {push_direction!r}: expected one of {[*DIRECTIONS, 'all']}")
    if not (0.25 <= tempo <= 4.0):
        raise ValueError(f"tempo {tempo}: expected 0.25–4")
    import cpg

    model = mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    dt = model.opt.timestep
    try:
        act = np.array([model.actuator(j).id for j in joints])
    except KeyError as e:
        raise ValueError(f"the walk names a joint the HOAP-2 has no servo for: {e}") from None
    lo, hi = model.actuator_ctrlrange[act, 0], model.actuator_ctrlrange[act, 1]
    qadr = np.array([model.jnt_qposadr[model.joint(j).id] for j in joints])
    idx = {j: k for k, j in enumerate(joints)}
    # The joints each attitude gain moves, left then right (those the walk drives).
    fed = {
        n: np.array([idx[f"{side}leg_joint_{k}"] for side in "lr" if f"{side}leg_joint_{k}" in idx], dtype=int)
        for n, k in (("hip_yaw", 1), ("hip_roll", 2), ("hip_pitch", 3), ("ankle_pitch", 5), ("ankle_roll", 6))
    }
    groups = ("ankle_pitch", "ankle_roll", "hip_pitch", "hip_roll", "hip_yaw")
    fed_joints = np.concatenate([fed[g] for g in groups])
    fed_group = np.concatenate([np.full(len(fed[g]), k) for k, g in enumerate(groups)])
    terms = np.zeros(len(groups))
    # The servos in the walk's joint order: a slice when it is MuJoCo's own.
    ctrl_all = np.array_equal(act, np.arange(len(act))) and len(act) == model.nu
    duration = float(times_s[-1] - times_s[0])
    total = duration if seconds is None else float(seconds)
    # Commands at the physics rate from the gait's clock (linear interpolation per joint).
    clock_t = times_s - times_s[0]
    uniform = np.allclose(np.diff(clock_t), clock_t[1] - clock_t[0], rtol=1e-6, atol=1e-9)
    rate_hz = 1.0 / (clock_t[1] - clock_t[0])
    last = len(clock_t) - 1

    def frame_at(c):
        if not uniform:
            return np.array([np.interp(c, clock_t, angles_rad[:, k]) for k in range(len(joints))])
        x = min(max(c * rate_hz, 0.0), float(last))
        i = min(int(x), last - 1)
        f = x - i
        return angles_rad[i] * (1.0 - f) + angles_rad[i + 1] * f

    first = frame_at(0.0)
    held = (math.nan, first)  # the last clock read and its frame (the clock stops after the hand-over)
    data.qpos[qadr] = first
    data.ctrl[act] = first
    mujoco.mj_forward(model, data)
    trunk = model.body("trunk").id
    mass = float(np.sum(model.body_mass))
    quat_adr = model.sensor("imu_quat").adr[0]
    gyro_adr = model.sensor("imu_gyro").adr[0]
    touch_adr = [model.sensor("lleg_touch").adr[0], model.sensor("rleg_touch").adr[0]]
    start = data.xpos[trunk].copy()
    stand_z = start[2]
    # Touch-down times of the plan: where support turns from single to double.
    landings = []
    if support is not None and len(support) == len(clock_t):
        for k in range(1, len(support)):
            if support[k] == "double" and support[k - 1] in ("left", "right"):
                landings.append((clock_t[k], 1 if support[k - 1] == "left" else 0))  # the foot that swung
    gen = None
    ctl_names = list(cpg_model.controls) if cpg_model is not None else []
    tempo_by_input = "u_tempo" in ctl_names
    if cpg_model is not None:
        base = dict(zip(ctl_names, cpg_model.teachers[0]["controls"])) if ctl_names else {}
        unknown = set(cpg_controls or {}) - set(ctl_names)
        if unknown:
            raise ValueError(f"controls {sorted(unknown)} are not the model's inputs {ctl_names}")
        base.update(cpg_controls or {})
        if stop_at_s is not None and "u_walk" not in ctl_names:
            raise ValueError(f"stop_at_s needs a model with a u_walk input; its inputs are {ctl_names}")

        def controls_at(t):
            u = dict(base)
            if tempo_by_input and t >= tempo_at_s:
                # A cosine ramp to the new tempo, as the model was validated with.
                s = 1.0 if tempo_ramp_s <= 0 else min(1.0, (t - tempo_at_s) / tempo_ramp_s)
                w = 0.5 - 0.5 * math.cos(math.pi * s)
                u["u_tempo"] = base["u_tempo"] * (1.0 + (tempo - 1.0) * w)
            if stop_at_s is not None and t >= stop_at_s:
                s = 1.0 if stop_ramp_s <= 0 else min(1.0, (t - stop_at_s) / stop_ramp_s)
                u["u_walk"] = base["u_walk"] * (0.5 + 0.5 * math.cos(math.pi * s))
            return [float(u[n]) for n in ctl_names]

        gen, drive, gen_rate, gen_prev, gen_next, gen_due, handover_s = _generator_for(
            cpg_model, joints, clock_t, angles_rad, support, handover_s, controls_at(0.0)
        )
    land_k = 0
    clock = 0.0
    waited = 0.0
    cmd = first.copy()
    fall_z, fall_up = 0.6 * stand_z, math.cos(math.radians(45))  # below 60 % of its height, tilted beyond 45°
    work_j = 0.0
    pushes_total = pushes_survived = 0
    push_left = 0.0
    push_force = np.zeros(3)
    next_push = push_every_s if push_every_s > 0 else math.inf
    dirs = list(DIRECTIONS) if push_direction == "all" else [push_direction]
    pending = None  # (time it began, steps to survive)
    fell_at = None
    path = []
    contacts = []
    poses = []  # t, the trunk's position and orientation (w, x, y, z), every servoed joint's angle
    pose_joints = [model.actuator(k).name for k in range(model.nu)]
    all_q = np.array([model.jnt_qposadr[model.joint(j).id] for j in pose_joints])
    n = int(round(total / dt))
    clock_end = float(clock_t[-1])
    f_abs = np.zeros(model.nu)
    torque_peak = np.zeros(model.nu)  # each servo's largest |torque| so far
    trunk_z = data.xpos[trunk][2:]  # views: MjData's arrays stay where they are
    trunk_up = data.xmat[trunk][8:]
    pushing = False
    settled_at = None if stop_at_s is None else stop_at_s + stop_ramp_s + 3.0
    settled_xy = None  # where the trunk was once the stop had settled
    for step in range(n):
        t = step * dt
        rate = tempo if t >= tempo_at_s else 1.0
        # Contact feedback on the gait's clock.
        sensed = data.sensordata
        recording = record_every and step % record_every == 0
        touch = sensed[touch_adr] if gains.phase_reset or recording else None
        advance = dt * rate
        if gains.phase_reset and land_k < len(landings):
            t_land, foot = landings[land_k]
            loaded = touch[foot] > 0.2 * mass * 9.81
            if clock + advance >= t_land and not loaded and waited < gains.max_wait_s:
                advance = max(0.0, t_land - clock)
                waited += dt
            elif loaded and t_land - clock < 0.15 * rate and clock < t_land:
                advance = t_land - clock  # landed early: jump to the touch-down
        clock = min(clock + advance, clock_end)
        while land_k < len(landings) and clock >= landings[land_k][0]:
            land_k += 1
            waited = 0.0
        if clock != held[0]:
            held = (clock, frame_at(clock))
        target = held[1].copy()
        if gen is not None and t >= handover_s:
            # The generator steps inside the loop; between its steps the command is interpolated.
            g_rate = gen_rate if tempo_by_input else gen_rate * rate
            while gen_due <= t:
                gen_prev = gen_next
                gen_next = np.radians(np.asarray(gen.step(controls_at(t) if ctl_names else None), dtype=float))
                gen_due += 1.0 / g_rate
            f = 1.0 - (gen_due - t) * g_rate
            target[drive] = gen_prev * (1.0 - f) + gen_next * f
            clock = min(clock, handover_s)
        # Attitude feedback from the IMU.
        roll, pitch, yaw = _tilt(sensed[quat_adr : quat_adr + 4].tolist())
        wx, wy = sensed[gyro_adr : gyro_adr + 2].tolist()
        # Each fed joint takes one group's term (the groups' joints are
        # distinct), subtracted in one indexed operation.
        terms[0] = gains.ankle_pitch_kp * pitch + gains.ankle_pitch_kd * wy
        terms[1] = gains.ankle_roll_kp * roll + gains.ankle_roll_kd * wx
        terms[2] = gains.hip_pitch_kp * pitch
        terms[3] = gains.hip_roll_kp * roll
        terms[4] = gains.hip_yaw_kp * yaw
        target[fed_joints] -= terms[fed_group]
        # The ufuncs in place: np.clip's wrapper costs more than the work here.
        step_max = SPEED_LIMIT_RAD_S * dt
        delta = target - cmd
        np.minimum(delta, step_max, out=delta)
        np.maximum(delta, -step_max, out=delta)
        cmd += delta
        np.minimum(cmd, hi, out=cmd)
        np.maximum(cmd, lo, out=cmd)
        if ctrl_all:
            data.ctrl[:] = cmd
        else:
            data.ctrl[act] = cmd
        # Pushes.
        if t >= next_push and push_left <= 0:
            dx, dy = DIRECTIONS[dirs[pushes_total % len(dirs)]]
            push_force = np.array([dx, dy, 0.0]) * mass * push_mps / PUSH_S
            push_left = PUSH_S
            pushing = False  # a new force to apply, even right after the last push
            pushes_total += 1
            pending = t
            next_push += push_every_s
        if pushing != (push_left > 0):
            pushing = push_left > 0
            data.xfrc_applied[trunk, :3] = push_force if pushing else 0.0
        push_left -= dt
        mujoco.mj_step(model, data)
        # |f·v| = |f|·|v| exactly; the ufuncs' reduce skips ndarray.max's and sum's wrappers.
        np.abs(data.actuator_force, out=f_abs)
        np.maximum(torque_peak, f_abs, out=torque_peak)
        work_j += float(np.add.reduce(f_abs * np.abs(data.actuator_velocity))) * dt
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
    steps_run = step + 1 if n else 0
    end = data.xpos[trunk] - start
    m = data.xmat[trunk].reshape(3, 3)
    heading = math.degrees(math.atan2(m[1, 0], m[0, 0]))
    distance = float(math.hypot(end[0], end[1]))
    upright = steps_run * dt if fell_at is None else fell_at
    leg_m = 0.2355
    out = {
        "seconds": total,
        "upright_s": upright,
        "fell": fell_at is not None,
        "forward_m": float(end[0]),
        "lateral_m": float(end[1]),
        "heading_deg": heading,
        "speed_m_s": float(end[0]) / upright if upright > 0 else 0.0,
        "speed_leg_lengths_s": float(end[0]) / upright / leg_m if upright > 0 else 0.0,
        "max_torque_nm": float(torque_peak.max()),
        "cost_of_transport": work_j / (mass * 9.81 * distance) if distance > 1e-3 else None,
        "pushes_survived": pushes_survived,
        "pushes_total": pushes_total,
        "gait_clock_s": clock,
    }
    if gen is not None:
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


def _generator_for(model, joints, clock_t, angles_rad, support, handover_s, controls=None):
    """The model's generator, stepped to the phase that matches the trajectory at the hand-over
    (``controls``: its control values, held)."""
    names = [c[:-3] if c.endswith(".rx") else c for c in model.channels]
    missing = [n for n in names if n not in joints]
    if missing:
        raise ValueError(f"the model's channels {missing} are not joints of the walk (expected JOINT.rx channels)")
    drive = np.array([joints.index(n) for n in names])
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
    return gen, drive, rate, first, first, handover_s, handover_s


def _umask() -> int:
    """The process's file-creation mask (read by setting it back)."""
    import os

    m = os.umask(0)
    os.umask(m)
    return m


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="cpg-sim", description=__doc__.split("\n\n")[0])
    p.add_argument("--trajectory", required=True, help="a walk as `cpg retarget` writes it (CSV); with --model, the start")
    p.add_argument("--model", help="a trained model (channels JOINT.rx, degrees) that drives after the hand-over")
    p.add_argument("--handover-s", type=float, help="when the model takes over (default: the 10th left touch-down)")
    p.add_argument("--seconds", type=float, help="how long to simulate (default: the walk's length)")
    p.add_argument("--push-every-s", type=float, default=0.0, help="push the trunk every T s (0: never)")
    p.add_argument("--push-mps", type=float, default=0.2, help="each push's change of the trunk's velocity, m/s")
    p.add_argument("--push-direction", default="all", choices=[*DIRECTIONS, "all"], help="all: in turn")
    p.add_argument("--tempo", type=float, default=1.0, help="the gait's speed factor from --tempo-at-s on")
    p.add_argument("--tempo-at-s", type=float, default=0.0, help="when the tempo changes, s")
    p.add_argument("--stop-at-s", type=float, help="tell the model to stop here (its u_walk input to 0 over 2 s) and stand")
    p.add_argument("--gains", help="feedback gains as JSON (see cpg.sim.Gains), or @FILE")
    p.add_argument("--json", action="store_true", help="print the measures as JSON")
    p.add_argument("-o", "--output", help="write the measures (with the trunk path, contacts and body poses at 50 Hz; `cpg view --sim` shows them) as JSON here")
    a = p.parse_args(argv)
    try:
        gains = Gains()
        if a.gains:
            text = open(a.gains[1:], encoding="utf-8").read() if a.gains.startswith("@") else a.gains
            gains = Gains.from_json(text)
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
        )
    except Exception as e:  # cpg.CpgError, OSError, ValueError: one message, exit 2
        if isinstance(e, KeyboardInterrupt):
            raise
        print(f"cpg-sim: {e}", file=sys.stderr)
        return 2
    if a.output:
        import os
        import tempfile

        d = os.path.dirname(os.path.abspath(a.output))
        fd, tmp = tempfile.mkstemp(dir=d, prefix=".cpg-sim-")
        with os.fdopen(fd, "w") as f:
            json.dump(r, f)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, a.output)
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


if __name__ == "__main__":
    sys.exit(main())

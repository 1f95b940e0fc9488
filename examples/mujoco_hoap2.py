#!/usr/bin/env python3
"""The HOAP-2 in MuJoCo, driven by a trained CPG at the simulator's rate.

The project's physical HOAP-2 (``cpg.hoap2_mjcf()``, assets/hoap2/hoap2.xml,
built from the URDF as docs/hoap2-model.md derives: a box per link, the
soles of the real size, a position servo on each of the 25 joints within the
URDF's effort) is loaded into MuJoCo. A trained model is run by
``cpg.Model.stream(rate_hz=1/timestep, robot=True)``: one tick per physics
step, the CPG's channels mapped onto the joints within their position,
velocity and acceleration limits. Two runs:

1. trunk held fixed in the air: how well the joints track the commands, and
   the largest actuator torque against its limit;
2. free on the floor, from the model's first pose standing: how far and how
   long the robot walks before it falls (trunk below 60 % of its standing
   height or tilted beyond 45°).

This is the paper's "future work" (stable walking of a humanoid): it measures
how far the paper's joint-angle copy gets; it does not promise that it
walks. The servo gains are ours (the sources give none); change them with
--kp and --kv. Joints the model does not drive (waist, neck) hold the home
crouch's command.

    pip install ./crates/python mujoco
    python examples/mujoco_hoap2.py                     # trains examples/walk22.toml
    python examples/mujoco_hoap2.py --model models/walk22.cpg --fixed-s 5 --free-s 10 --json
"""

import argparse
import json
import math
import pathlib
import sys

import numpy as np

import cpg

ROOT = pathlib.Path(__file__).resolve().parent.parent


LEG_BITS = 2 | 4  # the MJCF's contype bits of the left and right leg


def build(joints, timestep_s, kp, kv, free, leg_contacts=True):
    """The project's MuJoCo HOAP-2 (``cpg.hoap2_mjcf()``), the servos' gains
    set to kp, kv; the trunk free on the floor or held 0.6 m up; with
    leg_contacts False the legs pass through each other."""
    import mujoco

    spec = mujoco.MjSpec.from_string(cpg.hoap2_mjcf())
    spec.option.timestep = timestep_s
    if not leg_contacts:
        for g in spec.geoms:
            g.conaffinity &= ~LEG_BITS
    if not free:
        trunk = spec.body("trunk")
        spec.delete(trunk.first_joint())
        spec.delete(spec.key("home"))
        trunk.pos = [0, 0, 0.6]
    for a in spec.actuators:
        a.set_to_position(kp=kp, kv=kv)
    model = spec.compile()
    missing = [j for j in joints if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, j) < 0]
    if missing:
        raise SystemExit(f"the model's joints {missing} have no servo in cpg.hoap2_mjcf()")
    effort = {
        mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, k): float(model.actuator_forcerange[k][1])
        for k in range(model.nu)
    }
    return model, effort


def run(stream, model, effort, seconds, free):
    """Runs one phase; returns its measures."""
    import mujoco

    data = mujoco.MjData(model)
    if free:
        mujoco.mj_resetDataKeyframe(model, data, 0)  # standing in the home crouch
    joints = stream.columns
    qadr = [model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in joints]
    act = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in joints]
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "trunk")
    first = stream.tick()
    for k, q in zip(qadr, first):
        data.qpos[k] = q
    data.ctrl[act] = first
    if free:
        # Standing: the lowest point of the feet on the floor.
        mujoco.mj_kinematics(model, data)
        mujoco.mj_collision(model, data)
        low = min(
            data.geom_xpos[g][2] - np.abs(data.geom_xmat[g].reshape(3, 3)).dot(model.geom_size[g])[2]
            for g in range(model.ngeom)
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and model.geom_conaffinity[g] & 1
        )
        data.qpos[2] -= low - 0.001
    mujoco.mj_forward(model, data)
    start = data.xpos[trunk].copy()
    stand_z = start[2]
    n = int(round(seconds / model.opt.timestep))
    err_sq = np.zeros(len(joints))
    err_max = np.zeros(len(joints))
    torque_max = np.zeros(len(joints))
    saturated = np.zeros(len(joints), dtype=int)
    fell_at = None
    legs_touching = 0
    step = 0
    cmd = first
    for step in range(n):
        data.ctrl[act] = cmd
        mujoco.mj_step(model, data)
        q = data.qpos[qadr]
        e = np.abs(q - cmd)
        err_sq += e * e
        err_max = np.maximum(err_max, e)
        f = np.abs(data.actuator_force[act])
        torque_max = np.maximum(torque_max, f)
        saturated += f >= np.array([effort[j] for j in joints]) * 0.999
        legs_touching += any(
            model.geom_contype[c.geom1] & LEG_BITS and model.geom_contype[c.geom2] & LEG_BITS
            for c in data.contact[: data.ncon]
        )
        cmd = stream.tick()
        if free:
            up_z = data.xmat[trunk].reshape(3, 3)[2, 2]
            if data.xpos[trunk][2] < 0.6 * stand_z or up_z < math.cos(math.radians(45)):
                fell_at = (step + 1) * model.opt.timestep
                break
    steps = step + 1
    moved = data.xpos[trunk] - start
    out = {
        "seconds": steps * model.opt.timestep,
        "legs_touching_share": legs_touching / steps,
        "joints": [
            {
                "joint": j,
                "rms_error_deg": math.degrees(math.sqrt(err_sq[k] / steps)),
                "max_error_deg": math.degrees(err_max[k]),
                "max_torque_nm": float(torque_max[k]),
                "torque_limit_nm": effort[j],
                "saturated_share": float(saturated[k]) / steps,
            }
            for k, j in enumerate(joints)
        ],
    }
    if free:
        out.update(
            {
                "fell_after_s": fell_at,
                "forward_m": float(moved[0]),
                "sideways_m": float(moved[1]),
                "standing_height_m": float(stand_z),
            }
        )
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", help="a model file (default: train examples/walk22.toml)")
    p.add_argument("--fixed-s", type=float, default=5.0, help="seconds with the trunk held fixed")
    p.add_argument("--free-s", type=float, default=10.0, help="longest run free on the floor, seconds")
    p.add_argument("--timestep-s", type=float, default=0.001, help="physics step (the CPG ticks at its inverse)")
    p.add_argument("--kp", type=float, default=50.0, help="servo stiffness, N·m/rad (ours; the MJCF's)")
    p.add_argument("--kv", type=float, default=0.5, help="servo damping, N·m·s/rad (ours; the MJCF's)")
    p.add_argument(
        "--leg-contacts",
        choices=("on", "off"),
        default="on",
        help="whether the legs collide with each other (off: the servos' tracking alone)",
    )
    p.add_argument("--json", action="store_true", help="print the measures as JSON")
    a = p.parse_args(argv)
    model = cpg.load(a.model) if a.model else cpg.train(str(ROOT / "examples" / "walk22.toml"))
    results = {
        "model": repr(model),
        "kp": a.kp,
        "kv": a.kv,
        "timestep_s": a.timestep_s,
        "leg_contacts": a.leg_contacts,
    }
    for phase, seconds, free in (("fixed", a.fixed_s, False), ("free", a.free_s, True)):
        stream = model.stream(rate_hz=1.0 / a.timestep_s, robot=True)
        mj, effort = build(stream.columns, a.timestep_s, a.kp, a.kv, free, a.leg_contacts == "on")
        results[phase] = run(stream, mj, effort, seconds, free)
    if a.json:
        print(json.dumps(results, indent=2))
        return 0
    print(results["model"])
    f = results["fixed"]
    print(f"trunk fixed, {f['seconds']:.1f} s at {1 / a.timestep_s:.0f} Hz (kp {a.kp} N·m/rad, kv {a.kv} N·m·s/rad):")
    print(f"{'joint':<14} {'rms err':>8} {'max err':>8} {'max torque':>11} {'limit':>6} {'saturated':>9}")
    for j in f["joints"]:
        print(
            f"{j['joint']:<14} {j['rms_error_deg']:>7.2f}° {j['max_error_deg']:>7.2f}° "
            f"{j['max_torque_nm']:>8.2f} N·m {j['torque_limit_nm']:>5.1f} {100 * j['saturated_share']:>8.1f}%"
        )
    print(f"the legs touch each other in {100 * f['legs_touching_share']:.1f}% of the steps")
    w = results["free"]
    worst = max(w["joints"], key=lambda j: j["max_torque_nm"])
    if w["fell_after_s"] is None:
        print(f"free on the floor: still up after {w['seconds']:.2f} s", end="")
    else:
        print(f"free on the floor: fell after {w['fell_after_s']:.2f} s", end="")
    print(
        f", {w['forward_m']:+.3f} m forward, {w['sideways_m']:+.3f} m sideways; "
        f"largest torque {worst['max_torque_nm']:.2f} of {worst['torque_limit_nm']} N·m ({worst['joint']})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

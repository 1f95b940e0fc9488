#!/usr/bin/env python3
"""The HOAP-2 in MuJoCo, driven by a trained CPG at the simulator's rate.

The project's URDF (assets/hoap2/hoap2.urdf) is loaded into MuJoCo with
collision shapes added (capsules along the links, the foot boxes of the
reference), a position actuator on every mapped joint with the URDF's effort
limit as its force range, and a floor. A trained model is run by
``cpg.Model.stream(rate_hz=1/timestep, robot=True)``: one tick per physics
step, the CPG's channels mapped onto the joints within their position,
velocity and acceleration limits. Two runs:

1. trunk held fixed in the air: how well the joints track the commands, and
   the largest actuator torque against its limit;
2. free on the floor, from the model's first pose standing: how far and how
   long the robot walks before it falls (trunk below 60 % of its standing
   height or tilted beyond 45°).

This is the paper's "future work" (stable walking of a humanoid): it measures
how far the learnt gait gets; it does not promise that it walks. The servo
gains are ours (the sources give none); change them with --kp and --kv.

    pip install ./crates/python mujoco
    python examples/mujoco_hoap2.py                     # trains examples/walk22.toml
    python examples/mujoco_hoap2.py --model models/walk22.cpg --fixed-s 5 --free-s 10 --json
"""

import argparse
import json
import math
import pathlib
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np

import cpg

ROOT = pathlib.Path(__file__).resolve().parent.parent
URDF = ROOT / "assets" / "hoap2" / "hoap2.urdf"
# The foot collision box of the reference: 0.095 × 0.065 × 0.039 m, centred
# 0.01 m forward of and 0.015 m below the ankle (shared/reference/hoap2-joints.md).
FOOT_HALF_M = (0.0475, 0.0325, 0.0195)
FOOT_CENTRE_M = (0.01, 0.0, -0.015)
LIMB_RADIUS_M = 0.015


def efforts(urdf_text):
    """The effort limit (N·m) of every revolute joint of the URDF."""
    out = {}
    for j in ET.fromstring(urdf_text).iter("joint"):
        limit = j.find("limit")
        if j.get("type") == "revolute" and limit is not None:
            out[j.get("name")] = float(limit.get("effort"))
    return out


def build(urdf_text, joints, timestep_s, kp, kv, free):
    """The MuJoCo model: the URDF, collision shapes, actuators, a floor; the trunk free or held 0.6 m up."""
    import mujoco

    # Keep the root link as a body of its own (MuJoCo would merge it into the world).
    text = re.sub(r"(<robot[^>]*>)", r'\1<mujoco><compiler fusestatic="false"/></mujoco>', urdf_text, count=1)
    spec = mujoco.MjSpec.from_string(text)
    spec.option.timestep = timestep_s
    floor = spec.worldbody.add_geom()
    floor.type = mujoco.mjtGeom.mjGEOM_PLANE
    floor.size = [10, 10, 0.1]
    floor.friction = [1.0, 0.005, 0.0001]
    trunk = spec.worldbody.first_body()
    if free:
        trunk.add_freejoint()
    else:
        trunk.pos = [0, 0, 0.6]

    def shape(body, **kw):
        g = body.add_geom(**kw)
        # Robot shapes touch the floor, not each other.
        g.contype, g.conaffinity = 2, 1
        g.density = 0  # the URDF's inertials are the masses
        return g

    # A capsule from each body's origin to each child's, a box for each foot.
    for body in spec.bodies:
        if body.name == "world":
            continue
        for child in body.bodies:
            p = np.asarray(child.pos, dtype=float)
            if np.linalg.norm(p) > 1e-6:
                shape(body, type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *p], size=[LIMB_RADIUS_M, 0, 0])
        if body.name in ("lleg_link6", "rleg_link6"):
            shape(body, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(FOOT_CENTRE_M), size=list(FOOT_HALF_M))
    effort = efforts(urdf_text)
    for j in spec.joints:
        j.armature = 0.005
        j.damping = [0.05, 0, 0]  # linear damping (MuJoCo 4 also takes quadratic and cubic terms)
    for name in joints:
        a = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        a.set_to_position(kp=kp, kv=kv)
        a.forcelimited = True
        a.forcerange = [-effort[name], effort[name]]
    model = spec.compile()
    return model, effort


def run(stream, model, effort, seconds, free):
    """Runs one phase; returns its measures."""
    import mujoco

    data = mujoco.MjData(model)
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
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX
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
    p.add_argument("--kp", type=float, default=30.0, help="actuator stiffness, N·m/rad (ours)")
    p.add_argument("--kv", type=float, default=0.5, help="actuator damping, N·m·s/rad (ours)")
    p.add_argument("--json", action="store_true", help="print the measures as JSON")
    a = p.parse_args(argv)
    model = cpg.load(a.model) if a.model else cpg.train(str(ROOT / "examples" / "walk22.toml"))
    urdf_text = URDF.read_text()
    results = {"model": repr(model), "kp": a.kp, "kv": a.kv, "timestep_s": a.timestep_s}
    for phase, seconds, free in (("fixed", a.fixed_s, False), ("free", a.free_s, True)):
        stream = model.stream(rate_hz=1.0 / a.timestep_s, robot=True)
        mj, effort = build(urdf_text, stream.columns, a.timestep_s, a.kp, a.kv, free)
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

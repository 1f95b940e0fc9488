"""The physical HOAP-2 stands: the package's MJCF, nothing added, 30 s in
its home crouch with constant commands."""

import math

import numpy as np
import pytest

import cpg

mujoco = pytest.importorskip("mujoco")


def tilt_deg(quat):
    """The angle between the trunk's up axis and the world's, degrees."""
    w, x, y, z = quat
    up_z = 1.0 - 2.0 * (x * x + y * y)
    return math.degrees(math.acos(max(-1.0, min(1.0, up_z))))


def test_the_hoap2_stands_30_s_in_its_home_crouch():
    model = mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    assert model.nu == 25 and model.opt.timestep == 0.001
    held = data.ctrl.copy()
    mujoco.mj_forward(model, data)
    trunk = model.body("trunk").id
    soles = [model.geom(n).id for n in ("lleg_sole", "rleg_sole")]
    start = data.xpos[trunk].copy()
    sole_start = data.geom_xpos[soles].copy()
    quat = model.sensor("imu_quat")
    touch = [model.sensor(n) for n in ("lleg_touch", "rleg_touch")]
    tilt_max = torque_max = 0.0
    at_5_s = None
    steps = int(round(30.0 / model.opt.timestep))
    for step in range(steps):
        data.ctrl[:] = held
        mujoco.mj_step(model, data)
        q = data.sensordata[quat.adr[0] : quat.adr[0] + 4]
        tilt_max = max(tilt_max, tilt_deg(q))
        torque_max = max(torque_max, float(np.max(np.abs(data.actuator_force))))
        if step + 1 == 5000:
            at_5_s = data.xpos[trunk].copy()
    end = data.xpos[trunk]
    assert tilt_max < 5.0, f"the trunk tilted {tilt_max:.2f}°"
    assert abs(end[2] - start[2]) < 0.01, f"the trunk sank {start[2] - end[2]:.4f} m"
    assert np.linalg.norm(end[:2] - start[:2]) < 0.01, f"the trunk moved {end[:2] - start[:2]} m"
    # Settled: it does not creep once the first seconds' sag is over.
    assert np.linalg.norm(end - at_5_s) < 0.001, f"moved {end - at_5_s} m between 5 and 30 s"
    slid = np.linalg.norm(data.geom_xpos[soles][:, :2] - sole_start[:, :2], axis=1)
    assert np.all(slid < 0.002), f"the soles slid {slid} m"
    assert torque_max <= 9.0 + 1e-9, f"a servo gave {torque_max:.2f} N·m"
    # Both feet carry the body: about half its weight each.
    weight_n = 9.81 * float(np.sum(model.body_mass))
    for t in touch:
        f = float(data.sensordata[t.adr[0]])
        assert 0.3 * weight_n < f < 0.7 * weight_n, f"{t.name}: {f:.1f} N of {weight_n:.1f} N"


def test_the_mjcf_servos_are_the_urdf_limits():
    model = mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())
    joints = {j["name"]: j for j in cpg.robot_joints()}
    assert set(joints) == {model.actuator(k).name for k in range(model.nu)}
    for k in range(model.nu):
        a = model.actuator(k)
        j = joints[a.name]
        assert tuple(a.forcerange) == (-9.0, 9.0)
        assert abs(a.ctrlrange[0] - j["lower_rad"]) < 1e-5 and abs(a.ctrlrange[1] - j["upper_rad"]) < 1e-5
    assert abs(float(np.sum(model.body_mass)) - 7.15989) < 1e-4

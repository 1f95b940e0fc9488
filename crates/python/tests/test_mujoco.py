"""The MuJoCo example, short: the HOAP-2 tracks the CPG with the trunk held, then stands free."""

import importlib.util
import json
import math

from conftest import ROOT


def example():
    spec = importlib.util.spec_from_file_location("mujoco_hoap2", ROOT / "examples" / "mujoco_hoap2.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_hoap2_runs_in_mujoco(capsys):
    # The servos' tracking alone: the legs pass through each other.
    assert example().main(["--fixed-s", "2", "--free-s", "2", "--leg-contacts", "off", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    fixed, free = r["fixed"], r["free"]
    assert abs(fixed["seconds"] - 2.0) < 1e-9 and len(fixed["joints"]) == 22
    for j in fixed["joints"]:
        # The servos follow: a few degrees at most with the trunk held, never beyond the torque limit.
        assert j["rms_error_deg"] < 5.0, j
        assert j["max_torque_nm"] <= j["torque_limit_nm"] + 1e-9, j
    assert fixed["legs_touching_share"] == 0.0
    assert free["standing_height_m"] > 0.2
    assert free["fell_after_s"] is None or 0 < free["fell_after_s"] <= 2.0
    assert all(math.isfinite(free[k]) for k in ("forward_m", "sideways_m"))


def test_the_joint_angle_copy_makes_the_feet_collide(capsys):
    # The human's feet pass close to the midline; the HOAP-2's 65-mm feet on
    # hips 78 mm apart cannot follow without touching: measured, not hidden.
    assert example().main(["--fixed-s", "2", "--free-s", "0.1", "--json"]) == 0
    fixed = json.loads(capsys.readouterr().out)["fixed"]
    assert 0.0 < fixed["legs_touching_share"] <= 1.0

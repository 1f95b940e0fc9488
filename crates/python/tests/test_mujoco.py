"""The MuJoCo example, short: the HOAP-2 tracks the CPG with the trunk held, then stands free."""

import importlib.util
import json
import math

from conftest import ROOT


def test_the_hoap2_runs_in_mujoco(capsys):
    spec = importlib.util.spec_from_file_location("mujoco_hoap2", ROOT / "examples" / "mujoco_hoap2.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["--fixed-s", "2", "--free-s", "2", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    fixed, free = r["fixed"], r["free"]
    assert abs(fixed["seconds"] - 2.0) < 1e-9 and len(fixed["joints"]) == 22
    for j in fixed["joints"]:
        # The servos follow: a few degrees at most with the trunk held, never beyond the torque limit.
        assert j["rms_error_deg"] < 5.0, j
        assert j["max_torque_nm"] <= j["torque_limit_nm"] + 1e-9, j
    assert free["standing_height_m"] > 0.2
    assert free["fell_after_s"] is None or 0 < free["fell_after_s"] <= 2.0
    assert all(math.isfinite(free[k]) for k in ("forward_m", "sideways_m"))

"""The cpg package on numpy arrays: motions, training, generation, evaluation, HOAP-2."""

import subprocess
import threading

import numpy as np
import pytest

import cpg
from conftest import ROOT, cmu, cpg_binary


def test_motions_read_from_amc_and_bvh_agree(walk, tmp_path):
    assert walk.values.shape == (358, 62) and walk.values.dtype == np.float64
    assert walk.channels[:3] == ["root.tx", "root.ty", "root.tz"] and walk.rate_hz == 120.0
    points, names = walk.forward_kinematics()
    assert points.shape == (358, 31, 3) and names[0] == "root"
    # AMC → BVH → forward kinematics: the same markers (here, the left knee: the end of lfemur).
    path = tmp_path / "35_01.bvh"
    walk.save(path)
    again = cpg.read_motion(path)
    assert again.format.startswith("bvh (10") and again.n_frames == 358
    p2, n2 = again.forward_kinematics()
    k1, k2 = names.index("lfemur"), n2.index("lfemur")
    assert np.abs(points[:, k1] - p2[:, k2]).max() < 1e-4
    with pytest.raises(cpg.CpgError, match="give its ASF skeleton"):
        cpg.read_motion(cmu("35_01.amc"))
    with pytest.raises(cpg.CpgError, match="No such file"):
        cpg.read_motion(tmp_path / "missing.bvh")


def test_fit_checks_shapes_at_once():
    with pytest.raises(cpg.CpgError, match="shape \\(2, 3, 4\\).*fit_segments"):
        cpg.fit(np.zeros((2, 3, 4)), 120.0)
    with pytest.raises(cpg.CpgError, match="channels: 2 names for 1 columns"):
        cpg.fit(np.zeros((100, 1)), 120.0, channels=["a", "b"])
    with pytest.raises(cpg.CpgError, match="segments\\[1\\] has 2 channels"):
        cpg.fit_segments([np.zeros((100, 1)), np.zeros((100, 2))], rate_hz=120.0)
    bad = np.zeros((100, 1))
    bad[7, 0] = np.nan
    with pytest.raises(cpg.CpgError, match="frame 7, channel 0 \\(y0\\) is NaN"):
        cpg.fit(bad, 120.0)
    with pytest.raises(cpg.CpgError, match="expected one value per control input \\(several segments: fit_segments\\)"):
        cpg.fit(np.zeros((100, 1)), 120.0, controls=[[1.0], [0.0]])
    with pytest.raises(cpg.CpgError, match="2 settings for 1 segments"):
        cpg.fit_segments([np.zeros((100, 1))], 120.0, controls=[[1.0], [0.0]])
    with pytest.raises(cpg.CpgError, match="`reservoir.n_neurons` 1000000000; expected 1 ..= 20000"):
        cpg.fit(np.sin(np.arange(600) / 20.0)[:, None], 120.0, config={"reservoir": {"n_neurons": 10**9}})
    # A ValueError, for code that catches those.
    assert issubclass(cpg.CpgError, ValueError)


def test_a_fitted_model_generates_steps_streams_and_keeps_its_rhythm(femur_model):
    m = femur_model
    assert m.channels == ["hip_deg"] and m.controls == [] and m.rate_hz == 120.0
    y = m.generate(1200)
    assert y.shape == (1200, 1) and np.isfinite(y).all()
    teacher = m.teachers[0]
    lo, hi = teacher["cycle"].min(), teacher["cycle"].max()
    assert lo - 5 < y.min() and y.max() < hi + 5, "the free run stays on the taught range (degrees)"
    # Step by step, the same numbers; into a given array too.
    g = m.generator()
    first = np.array([g.step()[0] for _ in range(5)])
    assert np.array_equal(first, y[:5, 0])
    out = np.empty(1)
    assert g.step(out=out) is out and out[0] == y[5, 0]
    # A stream at 1 kHz passes through the model's steps.
    s = m.stream(1000.0)
    ticks = np.array([s.tick()[0] for _ in range(1000)])
    assert abs(ticks[0] - y[0, 0]) < 1e-12 and abs(s.time_s - 1.0) < 1e-12
    # Judged like `cpg evaluate`.
    (j,) = m.evaluate(seconds=120.0)
    assert j["stability"]["accurate"] and j["stability"]["converged"], j["stability"]
    assert j["recovery"]["orbit_s"] is not None and j["recovery"]["orbit_s"] < 2.0


def test_models_round_trip_through_files_and_bytes(femur_model, tmp_path):
    path = tmp_path / "m.cpg"
    femur_model.save(path)
    back = cpg.load(path)
    assert back.to_bytes() == femur_model.to_bytes() == path.read_bytes()
    assert np.array_equal(back.generate(50), femur_model.generate(50))
    damaged = bytearray(path.read_bytes())
    damaged[-100] ^= 0xFF
    with pytest.raises(cpg.CpgError):
        cpg.Model.from_bytes(bytes(damaged), "damaged.cpg")


def test_train_from_a_dict_equals_train_from_its_file():
    import tomllib

    path = ROOT / "experiments" / "e1.toml"
    with open(path, "rb") as f:
        d = tomllib.load(f)
    # Relative paths of a dict are against the working directory.
    d["data"]["skeleton"] = str(ROOT / "data" / "cmu35" / "35.asf")
    d["data"]["segments"][0]["motion"] = str(ROOT / "data" / "cmu35" / "35_01.amc")
    d["output"]["model"] = "e1.cpg"
    d["data"]["skeleton"] = str(cmu("35.asf"))
    d["data"]["segments"][0]["motion"] = str(cmu("35_01.amc"))
    from_dict = cpg.train(d)
    from_file = cpg.train(path)
    assert np.array_equal(from_dict.generate(500), from_file.generate(500))
    d["training"]["penalty_log10"] = [1, -8]
    with pytest.raises(cpg.CpgError, match="`training.penalty_log10`.*start, step, stop"):
        cpg.train(d)


def test_the_same_seed_gives_the_same_bits_as_cpg_train(tmp_path):
    out = tmp_path / "cli.cpg"
    r = subprocess.run(
        [str(cpg_binary()), "train", "-c", str(ROOT / "experiments" / "e1.toml"), "-o", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    assert cpg.train(ROOT / "experiments" / "e1.toml").to_bytes() == out.read_bytes()


def test_hoap2_commands_keep_every_limit():
    model = cpg.train(ROOT / "examples" / "walk22.toml")
    t = model.hoap2(3.0, rate_hz=500.0)
    assert t["positions_rad"].shape == (1500, 22) and len(t["joints"]) == 22
    limits = {j["name"]: j for j in cpg.robot_joints()}
    for k, name in enumerate(t["joints"]):
        q = t["positions_rad"][:, k]
        assert limits[name]["lower_rad"] - 1e-12 <= q.min() and q.max() <= limits[name]["upper_rad"] + 1e-12
        assert np.abs(t["velocities_rad_s"][:, k]).max() <= limits[name]["velocity_rad_s"] + 1e-9
        assert np.abs(t["accelerations_rad_s2"][:, k]).max() <= 100.0 + 1e-6
    s = model.stream(1000.0, robot=True)
    assert s.columns == t["joints"] and s.tick().shape == (22,)
    # A legs-only model drives the legs through the legs map.
    with pytest.raises(cpg.CpgError, match="the joint map also needs"):
        cpg.fit(np.sin(np.arange(600) / 20.0)[:, None], 120.0, channels=["lfemur.rx"]).hoap2(1.0)
    assert "hoap2" in cpg.hoap2_urdf()


def test_long_work_releases_the_gil(walk):
    """While a model trains in a thread, this thread keeps running: it is never
    blocked for more than half of the training (holding the GIL would block it
    for all of it)."""
    import time

    y = walk.select(["lfemur.rx", "rfemur.rx"]).values
    span = []

    def work():
        t0 = time.perf_counter()
        cpg.fit(y, 120.0, config={"reservoir": {"n_neurons": 600}})
        span.append((t0, time.perf_counter()))

    t = threading.Thread(target=work)
    t.start()
    beats = []
    while t.is_alive():
        beats.append(time.perf_counter())
    t.join()
    (t0, t1) = span[0]
    inside = [b for b in beats if t0 <= b <= t1]
    edges = [t0] + inside + [t1]
    longest = max(b - a for a, b in zip(edges, edges[1:]))
    assert longest < 0.5 * (t1 - t0), f"blocked {longest:.3f} s of a {t1 - t0:.3f} s training"

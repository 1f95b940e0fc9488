"""The HOAP-2 walking in MuJoCo on a CPG learnt from its retargeted gait:
a 10-s closed loop with one reservoir seed, the gain search on Optuna with
two workers, and cpg-sim's errors."""

import json
import subprocess
import sys

import pytest

from conftest import ROOT, cmu, cpg_binary

mujoco = pytest.importorskip("mujoco")

from cpg.sim import Gains, fit_walk, read_trajectory, simulate  # noqa: E402

GAINS = ROOT / "assets" / "hoap2" / "feedback-gains.json"


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk") / "walk.csv"
    trials = []
    for i in range(1, 7):
        trials += ["-m", str(cmu(f"35_0{i}.amc"))]
    r = subprocess.run(
        [str(cpg_binary()), "retarget", "-s", str(cmu("35.asf")), *trials, "--steps", "24",
         "--lift-scale", "0.7", "--double-support-share", "0.2", "-o", str(out)],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr
    return out


def test_a_cpg_walks_the_robot_10_s_in_closed_loop(walk):
    w = read_trajectory(str(walk))
    model = fit_walk(*w, seed=1, neurons=600, stride_index=4)
    gains = Gains.from_json(GAINS.read_text())
    # The CPG takes over at the 3rd left touch-down and drives to 10 s.
    strikes = [w[0][k] for k in range(1, len(w[3])) if w[3][k] == "double" and w[3][k - 1] == "right"]
    r = simulate(*w, seconds=10.0, gains=gains, cpg_model=model, handover_s=strikes[2])
    assert not r["fell"] and r["upright_s"] == pytest.approx(10.0), r
    assert r["forward_m"] > 0.3, r
    assert abs(r["heading_deg"]) < 15.0, r
    assert r["max_torque_nm"] <= 9.0 + 1e-9, r


def test_the_gain_search_runs_on_optuna_with_two_workers(walk, tmp_path):
    pytest.importorskip("optuna")
    db = tmp_path / "gains.db"
    best = tmp_path / "best.json"
    r = subprocess.run(
        [sys.executable, "-m", "cpg.sim_search", "--trajectory", str(walk), "--storage", f"sqlite:///{db}",
         "--trials", "2", "--workers", "2", "--seconds", "2", "-o", str(best)],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["trials"] == 4, out  # two trials from each of the two worker processes, one database
    Gains.from_json(best.read_text())


def test_cpg_sim_says_what_is_wrong(walk, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,1\n")
    cases = [
        (["--trajectory", str(bad)], "line 1"),
        (["--trajectory", str(walk), "--gains", '{"knee_kp": 1}'], "unknown gains"),
        (["--trajectory", str(walk), "--tempo", "9"], "tempo"),
        (["--start", "standing"], "--start standing needs --model"),
        (["--seconds", "1"], "--trajectory is required"),
    ]
    cases.append((["--trajectory", str(walk), "--gains", "{}", "--no-gains"], "give one"))
    for args, words in cases:
        r = subprocess.run([sys.executable, "-m", "cpg.sim", *args], capture_output=True, text=True)
        assert r.returncode == 2 and words in r.stderr, (args, r.stderr)
    r = subprocess.run([sys.executable, "-m", "cpg.sim", "--trajectory", str(walk), "--seconds", "2", "--json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    for k in ("upright_s", "fell", "forward_m", "lateral_m", "heading_deg", "max_torque_nm",
              "pushes_survived", "pushes_total"):
        assert k in out


def test_the_walk_cpg_of_the_experiment_takes_a_tempo_change_and_stops_by_its_inputs(walk):
    """experiments/hoap2-walk.toml's CPG (the robot's walk at three tempos and
    its standing pose, a tempo and a walk input) drives the robot from the
    10th left touch-down, changes tempo by its input, and stops and stands
    when told, as the report's walking section runs it."""
    import cpg

    model = cpg.train(str(ROOT / "experiments" / "hoap2-walk.toml"), seed=1)
    assert model.controls == ["u_tempo", "u_walk"], model.controls
    w = read_trajectory(str(walk))
    gains = Gains.from_json(GAINS.read_text())
    r = simulate(*w, seconds=22.0, gains=gains, cpg_model=model, tempo=1.1, tempo_at_s=16.0)
    assert not r["fell"] and r["upright_s"] == pytest.approx(22.0), r
    assert r["forward_m"] > 0.8, r
    # Told to stop at 14 s (u_walk to 0 over 2 s), it stands: from 19 s to the
    # end the trunk moves less than a tenth of what walking covers (~0.06 m/s).
    r = simulate(*w, seconds=26.0, gains=gains, cpg_model=model, stop_at_s=14.0)
    assert not r["fell"] and r["stop_at_s"] == 14.0, r
    assert r["moved_after_stop_m"] < 0.1 * 0.06 * (26.0 - 19.0), r
    with pytest.raises(ValueError, match="u_walk"):
        simulate(*w, seconds=1.0, cpg_model=fit_walk(*w, seed=1, neurons=50, stride_index=4), stop_at_s=0.5)
    # From standing, no plan and no hand-over: the model drives from the first step, stands
    # until 2 s, then walks by its u_walk input; the home pose stands in for a trajectory.
    from cpg.sim import standing_plan

    home = standing_plan("hoap2")
    assert home[2].shape == (2, len(home[1])) and home[3] is None
    r = simulate(*home, seconds=20.0, gains=gains, cpg_model=model, start="standing")
    assert r["start"] == "standing" and r["handover_s"] == 0.0 and r["start_at_s"] == 2.0, r
    assert not r["fell"] and r["forward_m"] > 0.5 and abs(r["heading_deg"]) < 15.0, r
    # Told to walk only at 15 s, it has not walked by 14 s (walking covers about 0.8 m in 14 s).
    # It is not still either: the trunk creeps about 1.4 mm/s (backwards, 20 mm here), which the
    # balance layer of issue 46 is to remove; this bound says only that it stands.
    r = simulate(*home, seconds=14.0, gains=gains, cpg_model=model, start="standing", start_at_s=15.0)
    assert not r["fell"] and abs(r["forward_m"]) < 0.05, r
    with pytest.raises(ValueError, match="u_walk"):
        simulate(*w, seconds=1.0, cpg_model=fit_walk(*w, seed=1, neurons=50, stride_index=4), start="standing")
    with pytest.raises(ValueError, match="start"):
        simulate(*home, seconds=1.0, cpg_model=model, start="running")
    # The seed replaces the configuration's: another seed, another reservoir.
    assert cpg.train(str(ROOT / "experiments" / "hoap2-walk.toml"), seed=2).to_bytes() != model.to_bytes()


def test_a_robot_is_its_folder_in_the_simulator_too(walk, tmp_path):
    # The HOAP-2's folder copied elsewhere walks exactly as the built-in robot:
    # the scene, its trunk, sensors and leg length come from the folder's robot.toml.
    import shutil

    import cpg

    folder = tmp_path / "my-robot"
    shutil.copytree(ROOT / "assets" / "hoap2", folder)
    scene = cpg._cpg._robot_scene(str(folder))
    assert scene["trunk"] == "trunk" and scene["touch"] == ["lleg_touch", "rleg_touch"]
    assert scene["leg_m"] == 0.2355 and scene["mjcf_path"] is not None
    w = read_trajectory(str(walk))
    built_in = simulate(*w, seconds=2.0)
    from_folder = simulate(*w, seconds=2.0, robot=str(folder))
    assert from_folder == built_in
    with pytest.raises(Exception, match="robot 'hopa2'.*did you mean 'hoap2'"):
        simulate(*w, seconds=1.0, robot="hopa2")


def test_the_world_reaches_the_run_and_the_json_says_what_it_was(walk):
    """The floor's slope and friction and the IMU's faults change the run,
    the same seed gives the same run, and the JSON echoes the world; a
    default World is the simulator's old run, bit for bit."""
    from cpg.sim import World

    w = read_trajectory(str(walk))
    gains = Gains.from_json(GAINS.read_text())
    base = simulate(*w, seconds=3.0, gains=gains)
    assert simulate(*w, seconds=3.0, gains=gains, world=World()) == base
    assert base["world"] == {**vars(World())} and base["push_phase"] == "fixed"
    for world in (
        World(slope_deg=3.0),
        World(slope_deg=-3.0, slope_axis="roll"),
        World(friction=0.3),
        World(imu_bias_deg=2.0),
        World(imu_yaw_drift_deg_s=2.0),
        World(imu_latency_ms=40.0),
        World(imu_noise_deg=1.0, seed=3),
    ):
        r = simulate(*w, seconds=3.0, gains=gains, world=world)
        assert r["world"] == vars(world), r["world"]
        moved = (r["forward_m"], r["lateral_m"], r["heading_deg"]) != (base["forward_m"], base["lateral_m"], base["heading_deg"])
        assert moved, f"{world} changed nothing"
    noisy = World(imu_noise_deg=1.0, seed=3)
    assert simulate(*w, seconds=3.0, gains=gains, world=noisy) == simulate(*w, seconds=3.0, gains=gains, world=noisy)
    other = simulate(*w, seconds=3.0, gains=gains, world=World(imu_noise_deg=1.0, seed=4))
    assert other["forward_m"] != simulate(*w, seconds=3.0, gains=gains, world=noisy)["forward_m"]
    # Random push times: as many pushes, at other times, the same for the same seed.
    kw = dict(seconds=6.0, gains=gains, push_every_s=2.0, push_mps=0.05)
    fixed = simulate(*w, **kw)
    rand = simulate(*w, **kw, push_phase="random", world=World(seed=5))
    assert rand["pushes_total"] == fixed["pushes_total"] == 2, (rand, fixed)
    assert rand["forward_m"] != fixed["forward_m"]
    assert simulate(*w, **kw, push_phase="random", world=World(seed=5)) == rand
    for bad, words in (
        (World(slope_deg=45.0), "slope"),
        (World(slope_axis="yaw"), "slope axis"),
        (World(friction=0.0), "friction"),
        (World(imu_latency_ms=5000.0), "latency"),
        (World(imu_noise_deg=float("nan")), "imu_noise_deg"),
        (World(seed=-1), "seed"),
    ):
        with pytest.raises(ValueError, match=words):
            simulate(*w, seconds=1.0, world=bad)
    with pytest.raises(ValueError, match="push phase"):
        simulate(*w, seconds=1.0, push_phase="sometimes")


def test_cpg_sim_takes_the_world_from_its_options(walk):
    r = subprocess.run(
        [sys.executable, "-m", "cpg.sim", "--trajectory", str(walk), "--seconds", "1", "--json", "--slope-deg", "2",
         "--slope-axis", "roll", "--friction", "0.5", "--imu-noise-deg", "0.5", "--imu-bias-deg", "1",
         "--imu-bias-axis", "pitch", "--imu-yaw-drift-deg-s", "0.2", "--imu-latency-ms", "20", "--seed", "7",
         "--push-phase", "random"],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["world"] == dict(slope_deg=2.0, slope_axis="roll", friction=0.5, imu_noise_deg=0.5, imu_bias_deg=1.0,
                                imu_bias_axis="pitch", imu_yaw_drift_deg_s=0.2, imu_latency_ms=20.0, seed=7), out
    assert out["push_phase"] == "random"
    for args, words in (
        (["--slope-deg", "40"], "--slope-deg"),
        (["--slope-axis", "yaw"], "--slope-axis"),
        (["--imu-latency-ms", "5000"], "--imu-latency-ms"),
        (["--imu-noise-deg", "-1"], "--imu-noise-deg"),
        (["--seed", "-1"], "--seed"),
        (["--friction", "nan"], "--friction"),
    ):
        r = subprocess.run([sys.executable, "-m", "cpg.sim", "--trajectory", str(walk), "--seconds", "1", *args],
                           capture_output=True, text=True)
        assert r.returncode == 2 and words in r.stderr and "Traceback" not in r.stderr, (args, r.stderr)


def test_a_model_alone_walks_from_standing_with_the_robots_shipped_gains(tmp_path):
    """`cpg-sim --model M --start standing` alone: no trajectory, no gains
    option; the robot's robot.toml names its gains and cpg-sim uses them."""
    import cpg

    scene = cpg._cpg._robot_scene("hoap2")
    assert Gains.from_json(scene["gains_json"]) == Gains.from_json(GAINS.read_text())
    model = tmp_path / "walk.cpg"
    cpg.train(str(ROOT / "experiments" / "hoap2-walk.toml"), seed=3).save(str(model))
    runs = {}
    for extra in ([], ["--no-gains"]):
        r = subprocess.run(
            [sys.executable, "-m", "cpg.sim", "--model", str(model), "--start", "standing", "--seconds", "15", "--json", *extra],
            capture_output=True, text=True,
        )
        assert r.returncode == 0, r.stderr
        runs[tuple(extra)] = json.loads(r.stdout)
    shipped = runs[()]
    assert shipped["gains_from"] == "the robot's" and shipped["start"] == "standing", shipped
    assert not shipped["fell"] and shipped["forward_m"] > 0.4, shipped
    assert runs[("--no-gains",)]["gains_from"] == "none"
    assert runs[("--no-gains",)] != {**shipped, "gains_from": "none"}, "the gains change the run"

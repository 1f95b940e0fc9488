"""The third hardening audit, as a new user meets the package: the
simulator's command line (outputs, bounded reads, non-finite options, a
diverged simulation, Ctrl-C), work that stops at Ctrl-C, values NumPy hands
over (integers, float32 tables, byte buffers), a refused unstable model, and
what a first session runs into (help, names, hints, progress)."""

import inspect
import os
import pathlib
import signal
import stat
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import cpg
from conftest import ROOT, cmu, cpg_binary


def sine(n=600, channels=1):
    t = np.arange(n) / 20.0
    return np.column_stack([np.sin(t + k) for k in range(channels)])


def sim(*args, timeout=120, module="cpg.sim"):
    p = subprocess.run([sys.executable, "-m", module, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


@pytest.fixture(scope="module")
def walk_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk") / "walk.csv"
    r = subprocess.run(
        [str(cpg_binary()), "retarget", "-s", str(cmu("35.asf")), "-m", str(cmu("35_01.amc")), "-m", str(cmu("35_02.amc")),
         "--steps", "24", "--lift-scale", "0.7", "--double-support-share", "0.2", "-o", str(out)],
        capture_output=True, text=True,
    )
    assert r.returncode == 0, r.stderr
    return out


# --- cpg-sim -------------------------------------------------------------


def test_cpg_sim_writes_a_fifo_in_place_and_a_symlink_s_target(walk_csv, tmp_path):
    pytest.importorskip("mujoco")
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, encoding="utf-8").read()))
    reader.start()
    rc, _, err = sim("--trajectory", walk_csv, "--seconds", "0.2", "-o", fifo)
    reader.join(timeout=60)
    assert rc == 0, err
    assert stat.S_ISFIFO(os.stat(fifo).st_mode), "the FIFO was replaced by a file"
    assert got and '"upright_s"' in got[0]
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    rc, _, err = sim("--trajectory", walk_csv, "--seconds", "0.2", "-o", link)
    assert rc == 0, err
    assert link.is_symlink() and '"upright_s"' in target.read_text()
    rc, out, err = sim("--trajectory", walk_csv, "--seconds", "0.2", "-o", "-")
    assert rc == 0 and '"upright_s"' in out, err


def test_cpg_sim_checks_its_output_before_simulating_and_leaves_nothing(walk_csv, tmp_path):
    # An hour of simulation: a failure that came after it would never return within the timeout.
    for out, words in [
        (tmp_path / "missing" / "x.json", "does not exist"),
        (tmp_path, "is a directory"),
    ]:
        rc, _, err = sim("--trajectory", walk_csv, "--seconds", "3600", "-o", out, timeout=60)
        assert rc == 2 and words in err and "Traceback" not in err, err
    assert not (tmp_path / "missing").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], list(tmp_path.iterdir())


def test_cpg_sim_reads_within_bounds(walk_csv):
    rc, _, err = sim("--trajectory", "/dev/zero", "--seconds", "1")
    assert rc == 2 and "larger than" in err and "Traceback" not in err, err
    rc, _, err = sim("--trajectory", walk_csv, "--seconds", "1", "--gains", "@/dev/zero")
    assert rc == 2 and "larger than 1048576 bytes" in err, err
    rc, _, err = sim("--trajectory", walk_csv, "--seconds", "1", "--gains", '{"ankle_pitch_kp": NaN}')
    assert rc == 2 and "ankle_pitch_kp" in err and "finite" in err, err


@pytest.mark.parametrize(
    "args, option",
    [
        (["--push-mps", "nan"], "--push-mps"),
        (["--push-mps", "inf"], "--push-mps"),
        (["--seconds=-1"], "--seconds"),
        (["--seconds", "nan"], "--seconds"),
        (["--tempo-at-s=-inf"], "--tempo-at-s"),
        (["--push-every-s", "1e999"], "--push-every-s"),
    ],
)
def test_cpg_sim_refuses_options_that_are_not_finite_numbers_in_range(walk_csv, args, option):
    rc, out, err = sim("--trajectory", walk_csv, *args)
    assert rc == 2 and option in err and "expected a finite number" in err, err
    assert "Traceback" not in err and "upright" not in out


def test_a_diverged_simulation_is_said_to_be_one(walk_csv, monkeypatch, tmp_path):
    mujoco = pytest.importorskip("mujoco")
    monkeypatch.chdir(tmp_path)
    from cpg.sim import Diverged, read_trajectory, simulate

    real = mujoco.mj_step

    def unstable(m, d):
        if d.time > 0.3:
            d.xfrc_applied[1, :3] = np.nan  # what a NaN push did: MuJoCo resets the state and warns
        real(m, d)

    monkeypatch.setattr(mujoco, "mj_step", unstable)
    with pytest.raises(Diverged, match=r"unstable at 0\.30.*MuJoCo: Nan, Inf or huge value in QACC"):
        simulate(*read_trajectory(str(walk_csv)), seconds=1.0)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists(), "MuJoCo's warning went into the error, not a log file"
    assert mujoco.get_mju_user_warning() is None, "the handler is put back"
    with pytest.raises(ValueError, match="push_mps = nan"):
        simulate(*read_trajectory(str(walk_csv)), seconds=1.0, push_mps=float("nan"))


def test_ctrl_c_ends_cpg_sim_without_a_traceback(walk_csv):
    pytest.importorskip("mujoco")
    p = subprocess.Popen(
        [sys.executable, "-m", "cpg.sim", "--trajectory", str(walk_csv), "--seconds", "3600"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    time.sleep(3.0)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130 and "cpg-sim: interrupted" in err and "Traceback" not in err, err


def test_the_gain_search_names_a_missing_model_before_any_worker(walk_csv, tmp_path):
    pytest.importorskip("optuna")
    rc, _, err = sim(
        "--trajectory", walk_csv, "--storage", f"sqlite:///{tmp_path / 'g.db'}", "--model", tmp_path / "none.cpg",
        module="cpg.sim_search",
    )
    assert rc == 2 and "none.cpg" in err and "Traceback" not in err, err


# --- work that stops at Ctrl-C ----------------------------------------------


@pytest.mark.parametrize(
    "call",
    [
        "m.evaluate(seconds=86400)",
        "cpg.fit(y, 120.0, config={'reservoir': {'n_neurons': 1500}, 'training': {'orbit': {'stay_s': 600, 'settle_s': 590}}})",
        "cpg.train(cfg)",
    ],
)
def test_ctrl_c_stops_the_work_not_only_the_call(femur_model, tmp_path, call):
    path = tmp_path / "m.cpg"
    femur_model.save(path)
    cfg = ROOT / "experiments" / "e6.toml"
    code = f"""
        import cpg, os, time, numpy as np
        m = cpg.load({str(path)!r})
        y = np.sin(np.arange(20000) / 20.0)
        cfg = {str(cfg)!r}
        def workers():
            n = 0
            for t in os.listdir('/proc/self/task'):
                try:
                    n += open(f'/proc/self/task/{{t}}/comm').read().strip() == 'cpg-work'
                except OSError:
                    pass
            return n
        print("ready", flush=True)
        try:
            {call}
            print("finished", flush=True)
        except KeyboardInterrupt:
            t0 = time.monotonic()
            while workers() and time.monotonic() - t0 < 20:
                time.sleep(0.05)
            print("interrupted", workers(), round(time.monotonic() - t0, 2), flush=True)
    """
    p = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    time.sleep(2.0)
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=120)
    words = out.split()
    assert words[0] == "interrupted", out
    assert words[1] == "0", f"the work thread still ran {words[2]} s after the interrupt: {out}"


def test_a_large_asf_is_refused_at_its_bound(tmp_path):
    asf = tmp_path / "big.asf"
    lines = [":version 1.10", ":name big", ":units", "  mass 1.0", "  length 0.45", "  angle deg", ":root",
             "  order TX TY TZ RX RY RZ", "  axis XYZ", "  position 0 0 0", "  orientation 0 0 0", ":bonedata"]
    for i in range(100_000):
        lines += ["  begin", f"    id {i + 1}", f"    name b{i}", "    direction 0 1 0", "    length 1",
                  "    axis 0 0 0 XYZ", "  end"]
    asf.write_text("\n".join(lines) + "\n")
    with pytest.raises(cpg.CpgError, match="big.asf:70013.*at most 10000 bones"):
        cpg.read_motion(cmu("35_01.amc"), skeleton=asf)


# --- values NumPy hands over -------------------------------------------------


@pytest.fixture(scope="module")
def two_gaits():
    return cpg.fit_segments(
        [sine(800), 1.5 * sine(800)], 120.0, controls=[[1.0, 0.0], [0.0, 1.0]],
        config={"reservoir": {"n_neurons": 40}}, allow_unstable=True,
    )


def test_numpy_integers_are_integers(femur_model):
    assert femur_model.generate(np.int64(10)).shape == (10, 1)
    assert femur_model.generate(np.uint16(3), threads=np.int32(1)).shape == (3, 1)
    m = cpg.fit(sine(), 120.0, seed=np.int64(3), config={"reservoir": {"n_neurons": np.int64(30)}}, allow_unstable=True)
    assert m.n_neurons == 30
    with pytest.raises(TypeError, match="steps: expected an integer"):
        femur_model.generate(np.float64(10.0))
    with pytest.raises(TypeError):
        femur_model.generate(np.bool_(True))


def test_control_tables_of_any_dtype_or_lists(two_gaits):
    f64 = two_gaits.generate(5, np.ones((5, 2)))
    assert np.array_equal(two_gaits.generate(5, np.ones((5, 2), np.float32)), f64)
    assert np.array_equal(two_gaits.generate(5, [[1.0, 1.0]] * 5), f64)
    assert np.array_equal(two_gaits.generate(5, np.array([1, 1], np.int8)), f64)
    with pytest.raises(cpg.CpgError, match="an array of 5 × 3; expected steps × 2"):
        two_gaits.generate(5, np.ones((5, 3), np.float32))


def test_a_model_from_any_byte_buffer(femur_model):
    b = femur_model.to_bytes()
    for data in (bytearray(b), memoryview(b), np.frombuffer(b, np.uint8)):
        assert cpg.Model.from_bytes(data).to_bytes() == b
    with pytest.raises(TypeError, match="expected bytes, a bytearray or a buffer"):
        cpg.Model.from_bytes("not bytes")


def test_a_dict_needs_no_output_section():
    m = cpg.train({
        "data": {"skeleton": str(cmu("35.asf")), "channels": ["lfemur.rx"], "loop_cycles": 1,
                 "segments": [{"motion": str(cmu("35_01.amc"))}]},
        "reservoir": {"n_neurons": 100},
        "training": {"teacher_noise": 0.1, "score": "orbit", "orbit": {"stay_s": 10, "settle_s": 6.5}},
    })
    assert m.channels == ["lfemur.rx"]


def test_a_long_output_name_is_saved(femur_model, tmp_path):
    path = tmp_path / ("m" * 246 + ".cpg")
    femur_model.save(path)
    assert cpg.load(path).to_bytes() == femur_model.to_bytes()


def test_a_read_only_out_array_takes_no_step():
    m = cpg.fit(sine(600, 2), 120.0, config={"reservoir": {"n_neurons": 40}}, allow_unstable=True)
    g = m.generator()
    out = np.zeros(2)
    out.flags.writeable = False
    with pytest.raises(cpg.CpgError, match="read-only.*no step was taken"):
        g.step(out=out)
    assert g.steps == 0
    with pytest.raises(cpg.CpgError, match="contiguous"):
        g.step(out=np.zeros(4)[::2])
    assert g.steps == 0
    out = np.zeros(2)
    assert g.step(out=out) is out and g.steps == 1


def test_an_unstable_model_is_refused_as_the_command_line_refuses_it():
    # The paper's protocol (no [training]) does not hold this walk's rhythm: cpg train refuses it.
    cfg = {"data": {"skeleton": str(cmu("35.asf")), "channels": ["lfemur.rx"],
                    "segments": [{"motion": str(cmu("35_01.amc"))}]}}
    with pytest.raises(cpg.CpgError, match="worse than 1 .*free run does not follow the teacher.*allow_unstable=True"):
        cpg.train(cfg)
    with pytest.warns(UserWarning, match="worse than 1 .*returned anyway"):
        m = cpg.train(cfg, allow_unstable=True)
    assert m.validation_score > 1


# --- a first session ------------------------------------------------------------


def test_fit_s_help_names_every_argument_and_rate_hz_is_required():
    sig = inspect.signature(cpg.fit)
    assert sig.parameters["rate_hz"].default is inspect.Parameter.empty
    assert sig.parameters["y"].default is inspect.Parameter.empty
    for name in sig.parameters:
        assert f"`{name}`" in cpg.fit.__doc__, name
    for name in inspect.signature(cpg.fit_segments).parameters:
        assert name in cpg.fit_segments.__doc__, name


def test_one_recording_takes_one_control_setting(two_gaits):
    m = cpg.fit(sine(800), 120.0, controls=[1.0], control_names=["u_walk"], config={"reservoir": {"n_neurons": 40}},
                allow_unstable=True)
    assert m.controls == ["u_walk"] and m.teachers[0]["controls"] == [1.0]


def test_a_table_s_column_names_name_the_channels():
    class Frame:  # what a pandas DataFrame offers: columns and __array__
        columns = ["hip", "knee"]

        def __array__(self, dtype=None, copy=None):
            return sine(600, 2)

    m = cpg.fit(Frame(), 120.0, config={"reservoir": {"n_neurons": 40}}, allow_unstable=True)
    assert m.channels == ["hip", "knee"]


def test_errors_name_the_key_as_the_user_wrote_it_not_an_internal_line():
    with pytest.raises(cpg.CpgError) as e:
        cpg.fit(sine(), 120.0, config={"training": {"washout": -5}})
    assert str(e.value).startswith("config: `training.washout`") and "<fit>" not in str(e.value), e.value
    with pytest.raises(cpg.CpgError) as e:
        cpg.fit(sine(), 120.0, config={"training": {"washot": 5}})
    assert "`training.washot` unknown field" in str(e.value) and ":25" not in str(e.value), e.value


def test_a_misspelt_name_gets_the_closest(walk, two_gaits):
    with pytest.raises(cpg.CpgError, match=r"unknown channel 'lfemr.rx' \(did you mean 'lfemur.rx'\?\)"):
        walk.select(["lfemr.rx"])


def test_long_work_shows_progress_on_a_terminal_only(femur_model, tmp_path):
    path = tmp_path / "m.cpg"
    femur_model.save(path)
    code = f"import cpg; cpg.load({str(path)!r}).evaluate(seconds=7200)"
    # Not a terminal: nothing but what the work prints.
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "evaluate [" not in p.stderr, p.stderr
    # A terminal: a bar with the share done.
    import pty

    main, child = pty.openpty()
    q = subprocess.Popen([sys.executable, "-c", code], stdin=child, stdout=child, stderr=child)
    os.close(child)
    seen = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:
            break
        if not chunk:
            break
        seen += chunk
    q.wait(timeout=300)
    os.close(main)
    text = seen.decode("utf-8", "replace")
    assert q.returncode == 0, text
    assert "evaluate [" in text and "%" in text, text


# --- found beyond the audit's list ----------------------------------------------


def test_beyond_the_list_paths_said_once_maps_hinted_generators_taken(femur_model, tmp_path):
    with pytest.raises(cpg.CpgError) as e:
        femur_model.save(tmp_path)
    assert str(e.value).count(str(tmp_path)) == 1, e.value
    with pytest.raises(cpg.CpgError, match=r"map 'lgs' \(did you mean 'legs'\?\): neither a built-in map \(hoap2, legs\)"):
        femur_model.stream(rate_hz=100, robot=True, map="lgs")
    m = cpg.fit_segments((s for s in [sine(600), sine(600)]), 120.0, config={"reservoir": {"n_neurons": 30}},
                         allow_unstable=True)
    assert [t["label"] for t in m.teachers] == ["segments[0]", "segments[1]"]


def test_a_trajectory_with_only_a_header_says_so(tmp_path):
    bare = tmp_path / "bare.csv"
    bare.write_text("time_s,lleg_joint_1_rad\n")
    rc, _, err = sim("--trajectory", bare, "--seconds", "1")
    assert rc == 2 and "no rows after the header" in err and "Warning" not in err, err

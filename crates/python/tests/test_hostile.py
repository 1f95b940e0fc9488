"""The second hardening audit: each input that once crashed the interpreter,
overflowed, ignored Ctrl-C, saved an unloadable model, lost an error across
processes, destroyed a file or filled the memory now gives a clear error (a
``CpgError``, ``ValueError`` or ``TypeError``) or does the right thing."""

import concurrent.futures
import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import cpg


def run_python(code, timeout=120):
    """Runs `code` in a fresh interpreter: (returncode, stdout, stderr)."""
    p = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=timeout
    )
    return p.returncode, p.stdout, p.stderr


@pytest.fixture(scope="module")
def model(walk):
    return cpg.fit(walk.select(["lfemur.rx"]).values, walk.rate_hz, config={"reservoir": {"n_neurons": 100}})


def sine(n=600, channels=1):
    t = np.arange(n) / 20.0
    return np.column_stack([np.sin(t + k) for k in range(channels)])


@pytest.mark.parametrize(
    "build",
    [
        "d = {}; d['x'] = d",
        "d = {'data': []}; d['data'].append(d['data'])",
        "d = {}\nx = d\nfor _ in range(20000):\n    x['a'] = {}\n    x = x['a']",
    ],
)
def test_a_cyclic_or_endlessly_deep_config_is_an_error_not_a_crash(build):
    code = f"import cpg\n{build}\ntry:\n    cpg.train(d)\nexcept cpg.CpgError as e:\n    print('CpgError:', e)\n"
    rc, out, err = run_python(code)
    assert rc == 0, f"the interpreter died ({rc}): {err}"
    assert "CpgError:" in out and ("contains itself" in out or "levels deep" in out), out


def test_integer_arguments_are_checked_not_overflowed(model):
    for bad in (-1, 10**30, 0):
        with pytest.raises(cpg.CpgError, match="steps = .*expected a whole number from 1"):
            model.generate(bad)
    with pytest.raises(TypeError, match="steps: expected an integer"):
        model.generate(1.5)
    with pytest.raises(cpg.CpgError, match="seed = -1: expected a whole number from 0 to 18446744073709551615"):
        cpg.fit(sine(), 120.0, seed=-1)
    with pytest.raises(cpg.CpgError, match=r"seed = 1000000000000000000000.*"):
        cpg.fit(sine(), 120.0, seed=10**21)
    # 2**63 is a valid 64-bit seed, not a negative number.
    m = cpg.fit(sine(), 120.0, seed=2**63, config={"reservoir": {"n_neurons": 20}})
    assert m.generate(10).shape == (10, 1)


def test_sizes_are_bounded_before_any_work():
    with pytest.raises(cpg.CpgError, match="segments: 10000 arrays; expected 1 to 1000"):
        cpg.fit_segments([sine(100)] * 10000, rate_hz=120.0)
    with pytest.raises(cpg.CpgError, match="training sequence would have 2200000 samples"):
        cpg.fit_segments([sine(100)] * 1000, rate_hz=120.0, config={"data": {"repeats": 1, "morph_s": 0, "samples_per_segment": 2200}})


def test_ctrl_c_stops_a_long_free_run_at_once(tmp_path, femur_model):
    path = tmp_path / "m.cpg"
    femur_model.save(path)
    code = f"""
        import cpg, sys, time
        m = cpg.load({str(path)!r})
        print("ready", flush=True)
        try:
            m.generate(30_000_000, threads=1)
            print("finished")
        except KeyboardInterrupt:
            print("interrupted", time.monotonic(), flush=True)
    """
    p = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    # Long enough on the fastest machine (30 M steps take seconds), short
    # enough to be well inside the run when the signal comes.
    time.sleep(0.3)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert out.startswith("interrupted"), out
    assert float(out.split()[1]) - sent < 0.5, f"KeyboardInterrupt {float(out.split()[1]) - sent:.2f} s after the signal"


@pytest.mark.parametrize("name", ["a,b\nc", "", "x" * 200, 'say "hi"', "tab\there"])
def test_a_name_no_model_file_can_hold_is_refused_when_it_enters(name):
    with pytest.raises(cpg.CpgError, match=r"channels\[0\]: channel or control name"):
        cpg.fit(sine(), 120.0, channels=[name])
    with pytest.raises(cpg.CpgError, match=r"control_names\[0\]"):
        cpg.fit_segments([sine(), sine()], rate_hz=120.0, controls=[[0.0], [1.0]], control_names=[name])


def test_a_good_model_is_not_destroyed_by_a_failed_save(tmp_path, model):
    path = tmp_path / "m.cpg"
    model.save(path)
    good = path.read_bytes()
    with pytest.raises(cpg.CpgError, match="does not exist"):
        model.save(tmp_path / "missing" / "m.cpg")
    assert not (tmp_path / "missing").exists(), "a directory was created"
    assert path.read_bytes() == good


def _raise_in_worker(_):
    raise cpg.CpgError("from a worker")


def _generate_in_worker(m):
    return m.generate(50)


def test_errors_models_and_generators_cross_processes(model):
    e = pickle.loads(pickle.dumps(cpg.CpgError("a message")))
    assert isinstance(e, cpg.CpgError) and str(e) == "a message"
    with concurrent.futures.ProcessPoolExecutor(max_workers=1) as ex:
        with pytest.raises(cpg.CpgError, match="from a worker"):
            ex.submit(_raise_in_worker, 0).result()
        y = ex.submit(_generate_in_worker, model).result()
    assert np.array_equal(y, model.generate(50))
    m2 = pickle.loads(pickle.dumps(model))
    assert m2.to_bytes() == model.to_bytes()
    g = model.generator()
    for _ in range(137):
        g.step()
    g2 = pickle.loads(pickle.dumps(g))
    assert g2.steps == 137
    for _ in range(200):
        assert np.array_equal(g.step(), g2.step())


def test_motion_save_never_leaves_half_a_file(tmp_path):
    """On a full disk (here: a file-size limit) the old motion stays whole."""
    from conftest import cmu

    path = tmp_path / "walk.amc"
    code = f"""
        import cpg, resource, signal
        walk = cpg.read_motion({str(cmu("35_01.amc"))!r}, skeleton={str(cmu("35.asf"))!r})
        small = walk.select(["lfemur.rx"])
        walk.save({str(path)!r})
        good = open({str(path)!r}, "rb").read()
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (len(good) // 2, resource.RLIM_INFINITY))
        try:
            walk.save({str(path)!r})
            print("saved")
        except cpg.CpgError as e:
            print("refused", e)
        print("intact" if open({str(path)!r}, "rb").read() == good else "destroyed")
    """
    rc, out, err = run_python(code)
    assert rc == 0, err
    assert "refused" in out and "intact" in out, out
    assert [p.name for p in tmp_path.iterdir()] == ["walk.amc"], "a temporary file was left behind"


@pytest.mark.parametrize(
    "call", ['cpg.train("/dev/zero")', 'cpg.load("/dev/zero")', 'cpg.load("/dev/urandom")', 'cpg.train("/dev/urandom")']
)
def test_endless_files_are_refused_at_their_bound(call):
    code = f"""
        import cpg, resource
        try:
            {call}
        except cpg.CpgError as e:
            print("CpgError:", e)
        print("peak_mib", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    """
    rc, out, err = run_python(code)
    assert rc == 0, err
    assert "CpgError:" in out, out
    peak = float(out.split("peak_mib")[1])
    assert peak < 300, f"{call} took {peak:.0f} MiB before refusing"


def test_rates_are_bounded_where_they_enter():
    from conftest import cmu

    for bad in (1e12, float("nan"), 0.0):
        with pytest.raises(cpg.CpgError, match="rate_hz = .*expected 1 to 100000 Hz"):
            cpg.read_motion(cmu("35_01.amc"), skeleton=cmu("35.asf"), rate_hz=bad)
        with pytest.raises(cpg.CpgError, match="rate_hz = .*expected 1 to 100000 Hz"):
            cpg.map_hoap2(np.zeros((10, 1)), ["lfemur.rx"], bad)


def test_huge_values_are_refused_with_the_users_own_names():
    y = sine() * 1e306
    with pytest.raises(cpg.CpgError, match=r"channel 0 \(hip\) is .*within ±1000000"):
        cpg.fit(y, 120.0, channels=["hip"])


def test_fit_takes_anything_numpy_reads_and_a_list_of_lists_is_one_segment():
    base = sine(600)
    small = {"reservoir": {"n_neurons": 20}}
    ref = cpg.fit(base, 120.0, config=small).generate(40)
    for y in (base.tolist(), base[:, 0]):
        assert np.array_equal(cpg.fit(y, 120.0, config=small).generate(40), ref), type(y)
    f32 = base.astype(np.float32)
    assert np.array_equal(
        cpg.fit(f32, 120.0, config=small).generate(40), cpg.fit(f32.astype(np.float64), 120.0, config=small).generate(40)
    )

    class Wrapped:
        def __array__(self, dtype=None, copy=None):
            return base

    assert np.array_equal(cpg.fit(Wrapped(), 120.0, config=small).generate(40), ref)
    ints = (base * 1000).round().astype(np.int64)
    assert cpg.fit(ints, 120.0, config=small).channels == ["y0"]
    with pytest.raises(cpg.CpgError, match="y: expected numbers"):
        cpg.fit([["a", "b"]], 120.0)


def test_steps_and_ticks_take_lists_and_out_says_what_it_needs(model):
    g = model.generator()
    a = g.step()
    with pytest.raises(TypeError, match=r"out: expected a float64 array of shape \(1,\), got a float32 array"):
        g.step(out=np.zeros(1, dtype=np.float32))
    with pytest.raises(cpg.CpgError, match=r"out: expected a float64 array of shape \(1,\)"):
        g.step(out=np.zeros(2))
    out = np.zeros(1)
    assert g.step(out=out) is out
    g.reset()
    assert np.array_equal(g.step(), a) and g.steps == 1 and not g.diverged
    s = model.stream(240.0)
    assert s.tick().shape == (1,)
    with pytest.raises(cpg.CpgError, match="control: 1 value"):
        s.tick([1.0])


def test_controls_take_lists_and_float32(walk):
    y = [walk.select(["lfemur.rx"]).values] * 2
    m = cpg.fit_segments(y, rate_hz=120.0, controls=[[1.0, 0.0], [0.0, 1.0]], config={"reservoir": {"n_neurons": 30}})
    g1, g2 = m.generator(), m.generator()
    for _ in range(20):
        assert np.array_equal(g1.step([1, 0]), g2.step(np.array([1.0, 0.0], dtype=np.float32)))


def test_help_shows_the_real_defaults_and_motions_are_built_from_arrays():
    sig = cpg.Model.stream.__text_signature__
    assert "acceleration_rad_s2=100.0" in sig and "Ellipsis" not in sig, sig
    assert cpg.DEFAULT_ACCELERATION_RAD_S2 == 100.0
    m = cpg.Motion(np.zeros((5, 2)), ["lfemur.rx", "rfemur.rx"], 120.0)
    assert m.n_frames == 5 and m.channels == ["lfemur.rx", "rfemur.rx"] and m.format == "arrays"
    with pytest.raises(cpg.CpgError, match="not a channel name"):
        cpg.Motion(np.zeros((5, 1)), ["hip"], 120.0)


def test_the_split_over_two_cores_gives_the_same_bits(model):
    assert np.array_equal(model.generate(2000, threads=1), model.generate(2000, threads=2))


def test_the_extension_carries_no_debug_information():
    path = cpg._cpg.__file__
    size = os.path.getsize(path)
    assert size < 20 << 20, f"{path}: {size / 2**20:.0f} MiB"

"""E1 of wyffels & Schrauwen (2009) with ReservoirPy, timed phase by phase.

Called by `cargo xtask bench --vs-reservoirpy` through reservoirpy_e1.sh. It
reads the exact E1 data cpg prepares (a JSON file: the z-scored teacher, the
warm-up and validation sequences and the paper's settings), runs the same
pipeline with ReservoirPy's public nodes, and prints its timings and results as
one JSON object on standard output.

The pipeline, as the paper describes it: a 300-neuron leaky reservoir (leak
0.3, density 0.5, spectral radius 1, bias U[0, 0.1]) whose only input is its own
output fed back (weights +-0.05 to every neuron; in ReservoirPy 0.4 feedback is
an input column of Win); teacher forcing over the training sequence; a ridge
readout for every penalty of the grid; each validated by a 500-step free run
with Gaussian state noise after the leaky update, averaged over the draws; the
best one retrained and run freely for 100,000 steps without noise.
"""

import json
import resource
import sys
import time

import numpy as np
import reservoirpy
from reservoirpy.nodes import Reservoir, Ridge


def main():
    cfg = json.load(open(sys.argv[1]))
    n = cfg["n_neurons"]
    train = np.asarray(cfg["train"], dtype=float).reshape(-1, 1)
    warmup = np.asarray(cfg["warmup"], dtype=float).reshape(-1, 1)
    target = np.asarray(cfg["validation"], dtype=float).reshape(-1, 1)
    washout = cfg["washout"]
    penalties = cfg["penalties"]
    sigma = np.sqrt(cfg["noise_variance"])
    draws = cfg["noise_draws"]
    steps = cfg["free_run_steps"]
    rng = np.random.default_rng(cfg["seed"])

    t_all = time.perf_counter()
    t = time.perf_counter()
    win = np.where(rng.random((n, 1)) < 0.5, -1.0, 1.0) * cfg["feedback_scale"]
    bias = rng.uniform(0.0, 0.1, size=n)
    res = Reservoir(
        n,
        lr=cfg["leak_rate"],
        sr=cfg["spectral_radius"],
        rc_connectivity=cfg["connectivity"],
        Win=win,
        bias=bias,
        seed=cfg["seed"],
    )
    res.initialize(train[:1])
    init_s = time.perf_counter() - t

    # Teacher forcing: the input at step t is the teacher at t - 1.
    t = time.perf_counter()
    states = res.run(train[:-1])
    x_fit, y_fit = states[washout:], train[1 + washout :]
    harvest_s = time.perf_counter() - t

    noises = [np.random.default_rng(1000 + r).standard_normal((len(target), n)) * sigma for r in range(draws)]
    var = float(np.var(target))

    def free_run(readout, start, first, k, noise=None):
        res.state = {"out": start.copy()}
        y = first
        out = np.empty(k)
        for i in range(k):
            s = res.step(y)
            if noise is not None:
                s = s + noise[i]
                res.state = {"out": s}
            y = readout.step(s)
            out[i] = y[0]
        return out

    # The state at the end of the warm-up, where every validation starts.
    res.reset()
    res.run(warmup[:-1])
    x0 = res.state["out"].copy()
    first = warmup[-1]

    t = time.perf_counter()
    ridge_s = 0.0
    scores = []
    for lam in penalties:
        r0 = time.perf_counter()
        readout = Ridge(ridge=lam).fit(x_fit, y_fit)
        ridge_s += time.perf_counter() - r0
        errs = []
        for noise in noises:
            y = free_run(readout, x0, first, len(target), noise)
            errs.append(float(np.mean((y - target[:, 0]) ** 2)) / var if np.all(np.isfinite(y)) else np.inf)
        scores.append(float(np.mean(errs)))
    sweep_s = time.perf_counter() - t
    best = int(np.argmin(scores))

    t = time.perf_counter()
    readout = Ridge(ridge=penalties[best]).fit(x_fit, y_fit)
    retrain_s = time.perf_counter() - t

    t = time.perf_counter()
    y = free_run(readout, x0, first, steps)
    if cfg.get("csv"):
        np.savetxt(cfg["csv"], y, fmt="%.9g", header="lfemur.rx (normalised)", comments="")
    free_run_s = time.perf_counter() - t
    total_s = time.perf_counter() - t_all

    # The same free run written directly in numpy: the floor of a Python loop
    # (left out when only the pipeline is timed).
    numpy_step_s = None
    if cfg.get("numpy_floor", True):
        numpy_step_s = numpy_floor(res, readout, cfg, x0, first, steps)
    print(
        json.dumps(
            {
                "versions": {"reservoirpy": reservoirpy.__version__, "numpy": np.__version__},
                "init_s": init_s,
                "harvest_s": harvest_s,
                "sweep_s": sweep_s,
                "ridge_s": ridge_s,
                "retrain_s": retrain_s,
                "free_run_s": free_run_s,
                "total_s": total_s,
                "numpy_step_s": numpy_step_s,
                "chosen_penalty": penalties[best],
                "first500_nmse": float(np.mean((y[: len(target)] - target[:, 0]) ** 2)) / var,
                "free_run": y[-1200:].tolist(),
                "peak_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
            }
        )
    )


def numpy_floor(res, readout, cfg, x0, first, steps):
    w, wfb, b = res.W, res.Win[:, 0], res.bias
    wout, rb, a = readout.Wout[:, 0], float(np.ravel(readout.bias)[0]), cfg["leak_rate"]
    wd = w.toarray() if hasattr(w, "toarray") else np.asarray(w)
    x, yy = x0.copy(), float(first[0])
    k = min(steps, 20000)
    t = time.perf_counter()
    for _ in range(k):
        x = (1 - a) * x + a * np.tanh(wd @ x + wfb * yy + b)
        yy = float(wout @ x + rb)
    return (time.perf_counter() - t) / k


if __name__ == "__main__":
    main()

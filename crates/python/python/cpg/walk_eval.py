"""Walking in physics, over reservoir seeds: the paper's joint-angle copy and
the retargeted walk played open loop, and the CPG learnt from the retargeted
walk without feedback and with the searched gains, each on flat ground, with
pushes, with a tempo change, and (a CPG with a walk input) told to stop.

``python -m cpg.walk_eval --trajectory walk.csv --config experiments/hoap2-walk.toml --gains gains.json --seeds 10 -o walking.json``

With ``--config`` each seed's CPG is trained from that configuration (``cpg
train``'s, its reservoir seed replaced), otherwise from the trajectory's
steady stride (``cpg.sim.fit_walk``). ``--copy`` adds the paper's protocol: a
model's output mapped joint by joint onto the robot (``cpg hoap2``'s CSV),
played from the standing pose. The JSON holds every run's measures; the
first seed's runs with feedback also hold the trunk's path and the soles'
contact forces at 50 Hz.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor

from cpg._cli import MAX_JSON_BYTES, check_output, read_text, run, write_output, number, whole
from cpg.sim import Gains, fit_walk, read_trajectory, simulate

#: Every 20th physics step (50 Hz) of the recorded runs.
RECORD_EVERY = 20


def _conditions(walk, seconds, push_every_s, push_mps, tempo, tempo_ramp_s, stop_ramp_s, **kw):
    """The runs of a row: flat, pushed, a tempo change half-way, and (a CPG
    with a walk input) told to stop half-way."""
    out = {
        "flat": simulate(*walk, seconds=seconds, **kw),
        "pushes": simulate(*walk, seconds=seconds, push_every_s=push_every_s, push_mps=push_mps, **kw),
        "tempo": simulate(*walk, seconds=seconds, tempo=tempo, tempo_at_s=seconds / 2, tempo_ramp_s=tempo_ramp_s, **kw),
    }
    model = kw.get("cpg_model")
    if model is not None and "u_walk" in list(model.controls):
        out["stop"] = simulate(*walk, seconds=seconds, stop_at_s=seconds / 2, stop_ramp_s=stop_ramp_s, **kw)
    return out


def _one(job):
    trajectory, config, seed, gains_json, a = job
    import cpg

    walk = read_trajectory(trajectory)
    gains = Gains.from_json(gains_json)
    t0 = time.perf_counter()
    if config:
        model = cpg.train(config, seed=seed)
    else:
        model = fit_walk(*walk, seed=seed, neurons=a["neurons"])
    fit_s = time.perf_counter() - t0
    # Judged as every model is: a long free run and the paper's push at each tempo it was taught.
    judged = model.evaluate(seconds=a["judge_s"])
    rows = {}
    for name, g in (("cpg", Gains()), ("cpg+feedback", gains)):
        record = RECORD_EVERY if (seed == a["first_seed"] and name == "cpg+feedback") else 0
        rows[name] = _conditions(
            walk,
            a["seconds"],
            a["push_every_s"],
            a["push_mps"],
            a["tempo"],
            a["tempo_ramp_s"],
            a["stop_ramp_s"],
            gains=g,
            cpg_model=model,
            record_every=record,
        )
    return seed, fit_s, repr(model), judged, rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m cpg.walk_eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--trajectory", required=True, help="the retargeted walk (cpg retarget's CSV): the start of every run")
    p.add_argument("--config", help="a cpg train configuration of the walk's CPG (e.g. experiments/hoap2-walk.toml)")
    p.add_argument("--copy", help="the paper's joint-angle copy as joint commands (cpg hoap2's CSV)")
    p.add_argument("--gains", required=True, help="JSON file of cpg.sim.Gains (cpg.sim_search -o)")
    p.add_argument("--seeds", type=whole(1, 1000), default=10)
    p.add_argument("--first-seed", type=whole(0, 2**63), default=1)
    p.add_argument("--seconds", type=number(1.0, 3600.0), default=60.0)
    p.add_argument("--push-every-s", type=number(0.0), default=5.0)
    p.add_argument("--push-mps", type=number(0.0, 5.0), default=0.2)
    p.add_argument("--tempo", type=number(0.25, 4.0), default=1.1, help="the tempo change half-way through the third run")
    p.add_argument("--tempo-ramp-s", type=number(0.0, 60.0), default=3.0, help="seconds of the tempo change's cosine ramp")
    p.add_argument("--stop-ramp-s", type=number(0.0, 60.0), default=3.0, help="seconds of the stop's cosine ramp (u_walk to 0)")
    p.add_argument("--neurons", type=whole(10, 10_000), default=600, help="without --config: the fitted CPG's size")
    p.add_argument("--judge-s", type=number(1.0, 86_400.0), default=900.0, help="each CPG's free run at each tempo it was taught, judged")
    p.add_argument("--workers", type=whole(1, 256), default=2)
    p.add_argument("-o", "--output", required=True, help="the runs' measures as JSON (- for standard output)")
    a = p.parse_args(argv)
    return run("cpg.walk_eval", lambda: _evaluate(a))


def _evaluate(a) -> int:
    check_output(a.output)
    gains_json = read_text(a.gains, MAX_JSON_BYTES)
    gains = Gains.from_json(gains_json)
    walk = read_trajectory(a.trajectory)
    copy = read_trajectory(a.copy) if a.copy else None
    if a.config:
        read_text(a.config, MAX_JSON_BYTES)  # readable before the workers start (each trains from it)
    opts = {
        "seconds": a.seconds,
        "push_every_s": a.push_every_s,
        "push_mps": a.push_mps,
        "tempo": a.tempo,
        "tempo_ramp_s": a.tempo_ramp_s,
        "stop_ramp_s": a.stop_ramp_s,
        "neurons": a.neurons,
        "first_seed": a.first_seed,
        "judge_s": a.judge_s,
    }
    out = {
        "trajectory": a.trajectory,
        "config": a.config,
        "copy": a.copy,
        "gains": json.loads(gains_json),
        **opts,
    }
    cond = lambda w, **kw: _conditions(w, a.seconds, a.push_every_s, a.push_mps, a.tempo, a.tempo_ramp_s, a.stop_ramp_s, **kw)  # noqa: E731
    t0 = time.perf_counter()
    if copy is not None:
        out["copy_run"] = cond(copy)
    out["open_loop"] = cond(walk)
    out["open_loop+feedback"] = cond(walk, gains=gains)
    jobs = [(a.trajectory, a.config, s, gains_json, opts) for s in range(a.first_seed, a.first_seed + a.seeds)]
    with ProcessPoolExecutor(a.workers) as pool:
        out["seeds"] = [
            {"seed": s, "fit_s": f, "model": m, "judged": j, **rows} for s, f, m, j, rows in pool.map(_one, jobs)
        ]
    out["wall_s"] = time.perf_counter() - t0
    write_output(a.output, json.dumps(out, indent=1))
    for row in ("cpg", "cpg+feedback"):
        for c in ("flat", "pushes", "tempo", "stop"):
            rs = [s[row][c] for s in out["seeds"] if c in s[row]]
            if not rs:
                continue
            up = sum(not r["fell"] for r in rs)
            fwd = sorted(r["forward_m"] for r in rs)
            pushes = sum(r["pushes_survived"] for r in rs), sum(r["pushes_total"] for r in rs)
            print(
                f"{row:<13} {c:<7} upright {up}/{len(rs)}; forward {fwd[0]:.2f}–{fwd[-1]:.2f} m; "
                f"heading up to {max(abs(r['heading_deg']) for r in rs):.1f}°; pushes {pushes[0]}/{pushes[1]}",
                file=sys.stderr if a.output == "-" else sys.stdout,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Walking in physics, over reservoir seeds: the retargeted walk played open
loop, the CPG learnt from it without feedback and with the searched gains,
each 60 s on flat ground, with pushes, and with a tempo change.

``python -m cpg.walk_eval --trajectory walk.csv --gains gains.json --seeds 10 -o walking.json``
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor

from cpg.sim import Gains, fit_walk, read_trajectory, simulate


def _one(job):
    trajectory, seed, gains_json, seconds, neurons = job
    import cpg

    walk = read_trajectory(trajectory)
    gains = Gains.from_json(gains_json)
    t0 = time.perf_counter()
    model = fit_walk(*walk, seed=seed, neurons=neurons)
    fit_s = time.perf_counter() - t0
    rows = {}
    for name, m, g in (("cpg", model, Gains()), ("cpg+feedback", model, gains)):
        rows[name] = {
            "flat": simulate(*walk, seconds=seconds, gains=g, cpg_model=m),
            "pushes": simulate(*walk, seconds=seconds, gains=g, cpg_model=m, push_every_s=5.0, push_mps=0.2),
            "tempo": simulate(*walk, seconds=seconds, gains=g, cpg_model=m, tempo=1.1, tempo_at_s=seconds / 2),
        }
    return seed, fit_s, repr(model), rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m cpg.walk_eval", description=__doc__.split("\n\n")[0])
    p.add_argument("--trajectory", required=True)
    p.add_argument("--gains", required=True, help="JSON file of cpg.sim.Gains (cpg.sim_search -o)")
    p.add_argument("--seeds", type=int, default=10)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--neurons", type=int, default=600)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args(argv)
    gains_json = open(a.gains, encoding="utf-8").read()
    walk = read_trajectory(a.trajectory)
    gains = Gains.from_json(gains_json)
    out = {"trajectory": a.trajectory, "gains": json.loads(gains_json), "seconds": a.seconds, "neurons": a.neurons}
    out["open_loop"] = {
        "flat": simulate(*walk, seconds=a.seconds),
        "pushes": simulate(*walk, seconds=a.seconds, push_every_s=5.0, push_mps=0.2),
        "tempo": simulate(*walk, seconds=a.seconds, tempo=1.1, tempo_at_s=a.seconds / 2),
    }
    out["open_loop+feedback"] = {
        "flat": simulate(*walk, seconds=a.seconds, gains=gains),
        "pushes": simulate(*walk, seconds=a.seconds, gains=gains, push_every_s=5.0, push_mps=0.2),
        "tempo": simulate(*walk, seconds=a.seconds, gains=gains, tempo=1.1, tempo_at_s=a.seconds / 2),
    }
    jobs = [(a.trajectory, s, gains_json, a.seconds, a.neurons) for s in range(1, a.seeds + 1)]
    with ProcessPoolExecutor(a.workers) as pool:
        out["seeds"] = [
            {"seed": s, "fit_s": f, "model": m, **rows} for s, f, m, rows in pool.map(_one, jobs)
        ]
    with open(a.output, "w", encoding="utf-8") as f:
        json.dump(out, f, indent=1)
    for row in ("cpg", "cpg+feedback"):
        for cond in ("flat", "pushes", "tempo"):
            rs = [s[row][cond] for s in out["seeds"]]
            up = sum(not r["fell"] for r in rs)
            fwd = sorted(r["forward_m"] for r in rs)
            pushes = sum(r["pushes_survived"] for r in rs), sum(r["pushes_total"] for r in rs)
            print(f"{row:<13} {cond:<7} upright {up}/{len(rs)}; forward {fwd[0]:.2f}–{fwd[-1]:.2f} m; "
                  f"heading up to {max(abs(r['heading_deg']) for r in rs):.1f}°; pushes {pushes[0]}/{pushes[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

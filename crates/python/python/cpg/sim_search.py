"""Search the HOAP-2's feedback gains with a walking objective, on Optuna.

``python -m cpg.sim_search --trajectory walk.csv --storage sqlite:///gains.db --trials 200 --workers 2``

Every trial simulates the walk with one set of ``cpg.sim.Gains`` (20 s on
flat ground; 20 s with a 0.2 m/s push every 5 s, the directions in turn;
with ``--model``, the CPG drives after the hand-over and a third run changes
the tempo by ``--tempo`` half-way; several ``--model`` options, one per
reservoir seed, are all run) and scores ``upright share + pushes survived
share + forward progress share - |heading| / 30°`` per run, each share over
what the run could reach, averaged over the runs. The study
lives in Optuna's database storage: the same command run on more machines
against one database (``--storage postgresql://...``) searches together, and
``--workers N`` starts N worker processes here. Seeded: worker k samples with
seed + k. Prints the best gains as JSON (``cpg-sim --gains``), and writes them
with ``-o``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys

from cpg.sim import Gains, read_trajectory, simulate

SPACE = {
    "ankle_pitch_kp": (-1.5, 1.5),
    "ankle_pitch_kd": (-0.1, 0.1),
    "ankle_roll_kp": (-1.5, 1.5),
    "ankle_roll_kd": (-0.1, 0.1),
    "hip_pitch_kp": (-1.5, 1.5),
    "hip_roll_kp": (-1.5, 1.5),
    "hip_yaw_kp": (-1.5, 1.5),
}


def score(walk, gains: Gains, seconds: float, planned_speed_m_s: float, model=None, tempo: float = 1.1) -> tuple[float, list]:
    """The objective of one set of gains, and the runs it came from."""
    runs = [
        simulate(*walk, seconds=seconds, gains=gains, cpg_model=model),
        simulate(*walk, seconds=seconds, gains=gains, push_every_s=5.0, push_mps=0.2, cpg_model=model),
    ]
    if model is not None and tempo != 1.0:
        runs.append(simulate(*walk, seconds=seconds, gains=gains, cpg_model=model, tempo=tempo, tempo_at_s=seconds / 2))
    s = 0.0
    for r in runs:
        s += r["upright_s"] / seconds
        if r["pushes_total"]:
            s += r["pushes_survived"] / r["pushes_total"]
        s += max(0.0, min(1.0, r["forward_m"] / (planned_speed_m_s * seconds)))
        s -= min(1.0, abs(r["heading_deg"]) / 30.0)
    return s / len(runs), runs


def planned_speed(path: str) -> float:
    """The walk's planned speed: its trunk's advance (``trunk_x_m``) over its duration, m/s."""
    import numpy as np

    import io

    from cpg._cli import read_text

    text = read_text(path)
    header = text.split("\n", 1)[0].strip().split(",")
    if "trunk_x_m" not in header:
        raise ValueError(f"{path}: line 1: no trunk_x_m column (give cpg retarget's CSV)")
    d = np.atleast_2d(np.genfromtxt(io.StringIO(text), delimiter=",", skip_header=1, usecols=[0, header.index("trunk_x_m")]))
    return max(1e-3, float(d[-1, 1] - d[0, 1]) / float(d[-1, 0] - d[0, 0]))


def _worker(args):
    import optuna

    trajectory, storage, name, trials, seconds, seed, model_paths, tempo = args
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    walk = read_trajectory(trajectory)
    import cpg

    models = [cpg.load(p) for p in model_paths] or [None]
    speed = planned_speed(trajectory)
    study = optuna.load_study(study_name=name, storage=storage, sampler=optuna.samplers.TPESampler(seed=seed))

    def objective(trial):
        g = Gains(
            **{k: trial.suggest_float(k, lo, hi) for k, (lo, hi) in SPACE.items()},
            phase_reset=trial.suggest_categorical("phase_reset", [False, True]),
        )
        scored = [score(walk, g, seconds, speed, m, tempo) for m in models]
        value = sum(v for v, _ in scored) / len(scored)
        runs = [r for _, rs in scored for r in rs]
        trial.set_user_attr("runs", [{k: v for k, v in r.items()} for r in runs])
        return value

    study.optimize(objective, n_trials=trials)


def main(argv=None) -> int:
    from cpg._cli import MAX_JSON_BYTES, check_output, number, read_text, run, whole, write_output

    p = argparse.ArgumentParser(prog="python -m cpg.sim_search", description=__doc__.split("\n\n")[0])
    p.add_argument("--trajectory", required=True, help="the walk (cpg retarget's CSV)")
    p.add_argument("--storage", required=True, help="Optuna storage URL, e.g. sqlite:///gains.db")
    p.add_argument("--study", default="hoap2-feedback", help="the study's name in the storage")
    p.add_argument("--trials", type=whole(1, 100_000), default=100, help="trials per worker")
    p.add_argument("--workers", type=whole(1, 256), default=2, help="worker processes on this machine")
    p.add_argument("--seconds", type=number(1.0, 3600.0), default=20.0, help="seconds per simulated run")
    p.add_argument("--seed", type=whole(0, 2**32 - 1), default=1, help="worker k samples with seed + k")
    p.add_argument(
        "--model",
        action="append",
        default=[],
        help="a trained CPG of the walk (channels JOINT.rx) that drives after the hand-over (repeat: one per seed)",
    )
    p.add_argument("--tempo", type=number(0.25, 4.0), default=1.1, help="with --model: the tempo change of the third run")
    p.add_argument(
        "--start-from",
        action="append",
        default=[],
        help="gains (JSON of cpg.sim.Gains) the study tries first (repeat for several)",
    )
    p.add_argument("-o", "--output", help="write the best gains (JSON) here (- for standard output)")
    a = p.parse_args(argv)

    def body() -> int:
        try:
            import optuna
        except ImportError:
            raise ValueError("cpg.sim_search needs optuna: pip install optuna") from None
        # Every input is read and checked here, before a worker starts.
        check_output(a.output)
        read_trajectory(a.trajectory)
        planned_speed(a.trajectory)
        import cpg

        for path in a.model:
            cpg.load(path)
        starts = [Gains.from_json(read_text(path, MAX_JSON_BYTES)) for path in a.start_from]
        study = optuna.create_study(study_name=a.study, storage=a.storage, direction="maximize", load_if_exists=True)
        for g in starts:
            study.enqueue_trial({k: getattr(g, k) for k in [*SPACE, "phase_reset"]})
        jobs = [
            (a.trajectory, a.storage, a.study, a.trials, a.seconds, a.seed + k, a.model, a.tempo) for k in range(a.workers)
        ]
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(a.workers) as pool:
            pool.map(_worker, jobs)
        study = optuna.load_study(study_name=a.study, storage=a.storage)
        best = study.best_trial
        gains = {k: v for k, v in best.params.items()}
        out = {"gains": gains, "score": best.value, "trials": len(study.trials), "runs": best.user_attrs.get("runs")}
        if a.output:
            write_output(a.output, json.dumps(gains, indent=2) + "\n")
        print(json.dumps(out, indent=2), file=sys.stderr if a.output == "-" else sys.stdout)
        return 0

    return run("cpg.sim_search", body)


if __name__ == "__main__":
    sys.exit(main())

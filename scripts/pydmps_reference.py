"""Reference rollouts of pydmps 0.2's rhythmic DMP for crates/dmp/tests/pydmps.rs.

Prints JSON: for each case the demonstration, the settings, pydmps's goal and
weights, and its rollout over one and over two periods. A second table gives
the relative RMSE (RMSE / std) of one-period rollouts of sin(2π·k·s) with k
cycles in the window, as in shared/research/methods.md §3.6.
"""
import json
import sys

import numpy as np
import pydmps
import pydmps.dmp_rhythmic


def demo(t_demo, d):
    s = np.linspace(0.0, 1.0, t_demo)
    cols = [np.sin(2 * np.pi * s) + 0.3 * np.sin(4 * np.pi * s + 1.0),
            0.5 * np.cos(2 * np.pi * s) + 0.2 * s]
    return np.array(cols[:d])


def case(name, t_demo, d, n_bfs, dt):
    y_des = demo(t_demo, d)
    dmp = pydmps.dmp_rhythmic.DMPs_rhythmic(n_dmps=d, n_bfs=n_bfs, dt=dt)
    dmp.imitate_path(y_des=y_des)
    one, _, _ = dmp.rollout()
    two, _, _ = dmp.rollout(timesteps=2 * dmp.timesteps)
    fast, _, _ = dmp.rollout(tau=2.0)
    return {
        "name": name, "n_dofs": d, "n_basis": n_bfs, "dt": dt,
        "demo": y_des.T.flatten().tolist(),
        "timesteps": dmp.timesteps,
        "goal": dmp.goal.tolist(), "weights": dmp.w.flatten().tolist(),
        "rollout_one_period": one.flatten().tolist(),
        "rollout_two_periods": two.flatten().tolist(),
        "rollout_tau_2": fast.flatten().tolist(),
    }


def cycles_table():
    rows = []
    t_demo = 1300
    s = np.linspace(0.0, 1.0, t_demo)
    for k in [1, 2, 3, 5, 10]:
        y = np.sin(2 * np.pi * k * s)
        dmp = pydmps.dmp_rhythmic.DMPs_rhythmic(n_dmps=1, n_bfs=100, dt=2 * np.pi / t_demo)
        path = dmp.imitate_path(y_des=y.reshape(1, -1))
        out, _, _ = dmp.rollout()
        n = min(out.shape[0], path.shape[1])
        err = out[:n, 0] - path[0, :n]
        rows.append({"cycles": k, "rel_rmse": float(np.sqrt(np.mean(err ** 2)) / np.std(path[0, :n]))})
    return rows


json.dump({
    "pydmps_version": "0.2",
    "numpy_version": np.__version__,
    "cases": [case("two_dofs_one_step_per_sample", 150, 2, 100, 2 * np.pi / 150),
              case("default_dt", 200, 1, 50, 0.01)],
    "cycles_100_basis": cycles_table(),
}, sys.stdout)

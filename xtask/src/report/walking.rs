//! Walking in physics: the simulations run in the Python package (MuJoCo),
//! driven from here with a configuration's `[experiment.test.walking]`;
//! `cpg_lab::experiment::walking` judges what they measured.

use std::path::Path;

use anyhow::{Context, bail};
use cpg_lab::Config;
use cpg_lab::config::ExperimentTest;
use cpg_lab::experiment::walking::{WalkEval, WalkingResult, judge};

use crate::process::cmd;

/// Runs configuration `c`'s walking test in the scratch directory `work` and judges it.
pub fn run(work: &Path, c: &Config, quick: bool, threads: usize) -> anyhow::Result<WalkingResult> {
    let Some(e) = &c.experiment else { bail!("{}: no [experiment]", c.source.display()) };
    let ExperimentTest::Walking(t) = &e.test else { bail!("{}: not a walking experiment", c.source.display()) };
    let py = crate::python::install().context("installing the Python package the simulations run in")?;
    let cpg_bin = crate::release_binary("cpg");
    let cpg = cpg_bin.display().to_string();
    let w = |name: &str| work.join(name).display().to_string();
    let path = |p: &Path| p.display().to_string();
    plan_start_walk(&cpg_bin, c, t.start_steps, &work.join("walk.csv"))?;
    let seconds = if quick { t.quick_run_s } else { t.run_s }.to_string();
    let seeds = if quick { e.quick_seeds.min(e.seeds) } else { e.seeds }.to_string();
    let judge_s = if quick { t.quick_judge_s } else { t.judge_s }.to_string();
    let first = c.reservoir.seed.to_string();
    let workers = threads.max(1).to_string();
    let mut eval: Vec<String> = [
        "-m",
        "cpg.walk_eval",
        "--trajectory",
        &w("walk.csv"),
        "--config",
        &path(&c.source),
        "--gains",
        &path(&t.gains),
        "--seeds",
        &seeds,
        "--first-seed",
        &first,
        "--seconds",
        &seconds,
        "--push-every-s",
        &t.push_every_s.to_string(),
        "--push-mps",
        &t.push_mps.to_string(),
        "--tempo",
        &t.tempo.to_string(),
        "--tempo-ramp-s",
        &t.tempo_ramp_s.to_string(),
        "--stop-ramp-s",
        &t.stop_ramp_s.to_string(),
        "--judge-s",
        &judge_s,
        "--workers",
        &workers,
        "-o",
        &w("walking.json"),
    ]
    .iter()
    .map(|s| (*s).to_owned())
    .collect();
    // The paper's protocol: a model's output copied joint by joint onto the robot.
    if let Some(copy) = &t.copy_config {
        cmd(&cpg, &["train", "--config", &path(copy), "-o", &w("copy.cpg")], &[])?;
        cmd(
            &cpg,
            &["hoap2", "--model", &w("copy.cpg"), "--seconds", &seconds, "--rate-hz", "200", "-o", &w("copy.csv")],
            &[],
        )?;
        eval.extend(["--copy".into(), w("copy.csv")]);
    }
    cmd(&py.display().to_string(), &eval.iter().map(String::as_str).collect::<Vec<_>>(), &[])?;
    let out = work.join("walking.json");
    let text = std::fs::read_to_string(&out).with_context(|| format!("reading {}", out.display()))?;
    Ok(judge(c, WalkEval::from_json(&text, &out)?)?)
}

/// Plans the walk the simulated runs start from into `out`: `cpg retarget`
/// (the binary `cpg`)
/// on configuration `c`'s `[data.retarget]` trials with its settings, for
/// `steps` steps (longer than the loop the CPG learns).
pub fn plan_start_walk(cpg: &Path, c: &Config, steps: usize, out: &Path) -> anyhow::Result<()> {
    let Some(r) = &c.data.retarget else {
        bail!("{}: a walking experiment learns a [data.retarget] walk", c.source.display())
    };
    let path = |p: &Path| p.display().to_string();
    let mut args: Vec<String> = vec!["retarget".into()];
    if let Some(s) = &c.data.skeleton {
        args.extend(["-s".into(), path(s)]);
    }
    for trial in &r.trials {
        args.extend(["-m".into(), path(trial)]);
    }
    args.extend([
        "--steps".into(),
        steps.to_string(),
        "--step-scale".into(),
        r.step_scale.to_string(),
        "--lift-scale".into(),
        r.lift_scale.to_string(),
        "--arm-scale".into(),
        r.arm_scale.to_string(),
        "--plan-rate-hz".into(),
        c.data.rate_hz.to_string(),
        "--rate-hz".into(),
        r.trial_rate_hz.to_string(),
    ]);
    if let Some(d) = r.double_support_share {
        args.extend(["--double-support-share".into(), d.to_string()]);
    }
    args.extend(["-o".into(), path(out)]);
    cmd(&path(cpg), &args.iter().map(String::as_str).collect::<Vec<_>>(), &[])
}

//! `cpg generate` and the free run shared by `cpg hoap2` and `cpg evaluate`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use cpg_mocap::{Channel, Motion, Skeleton, write_amc};
use cpg_reservoir::{Generator, TrainedCpg};

use crate::output::write_atomic;

/// How the control inputs evolve during a run.
pub enum Controls {
    /// The same values every step.
    Constant(Vec<f64>),
    /// One row per step from a CSV file; the last row is held.
    Table(Vec<Vec<f64>>),
}

impl Controls {
    /// From `--control 1,0` or `--control-file u.csv` (header: the model's control names).
    pub fn from_args(model: &TrainedCpg, values: Option<&str>, file: Option<&Path>) -> anyhow::Result<Controls> {
        let u = model.controls.len();
        match (values, file) {
            (Some(_), Some(_)) => bail!("give either --control or --control-file, not both"),
            (Some(v), None) => {
                let vals: Vec<f64> = v
                    .split(',')
                    .map(|s| s.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
                    .collect::<Option<_>>()
                    .with_context(|| format!("--control '{v}': expected {u} comma-separated numbers"))?;
                if vals.len() != u {
                    bail!(
                        "--control has {} values; the model's control inputs are [{}]",
                        vals.len(),
                        model.controls.join(", ")
                    );
                }
                Ok(Controls::Constant(vals))
            }
            (None, Some(f)) => {
                let text = std::fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
                let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
                let (_, head) = lines.next().with_context(|| format!("{}: empty file", f.display()))?;
                let names: Vec<&str> = head.split(',').map(str::trim).collect();
                if names != model.controls {
                    bail!(
                        "{}:1: header [{}], the model's control inputs are [{}]",
                        f.display(),
                        names.join(", "),
                        model.controls.join(", ")
                    );
                }
                let mut rows = Vec::new();
                for (i, l) in lines {
                    let row: Vec<f64> = l
                        .split(',')
                        .map(|s| s.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
                        .collect::<Option<_>>()
                        .with_context(|| format!("{}:{}: expected {u} finite numbers", f.display(), i + 1))?;
                    if row.len() != u {
                        bail!("{}:{}: {} values, expected {u}", f.display(), i + 1, row.len());
                    }
                    rows.push(row);
                }
                if rows.is_empty() {
                    bail!("{}: no rows after the header", f.display());
                }
                Ok(Controls::Table(rows))
            }
            (None, None) if u == 0 => Ok(Controls::Constant(Vec::new())),
            (None, None) => {
                bail!("the model has control inputs [{}]: give --control or --control-file", model.controls.join(", "))
            }
        }
    }

    pub fn at(&self, step: usize) -> &[f64] {
        match self {
            Controls::Constant(v) => v,
            Controls::Table(rows) => &rows[step.min(rows.len() - 1)],
        }
    }
}

/// Free-runs `n` steps; frame-major outputs in the training units.
pub fn free_run(model: &TrainedCpg, n: usize, controls: &Controls) -> anyhow::Result<Vec<f64>> {
    let mut g = Generator::new(model);
    let mut out = Vec::with_capacity(n * model.outputs.len());
    for k in 0..n {
        out.extend_from_slice(g.step(controls.at(k))?);
    }
    Ok(out)
}

fn unit_suffix(name: &str) -> &'static str {
    if name.ends_with(".rx") || name.ends_with(".ry") || name.ends_with(".rz") { "_deg" } else { "" }
}

#[allow(clippy::too_many_arguments)]
pub fn run(
    model: &Path,
    seconds: f64,
    control: Option<&str>,
    control_file: Option<&Path>,
    format: &str,
    skeleton: Option<&PathBuf>,
    output: &Path,
) -> anyhow::Result<()> {
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    if !(seconds.is_finite() && seconds > 0.0) {
        bail!("--seconds {seconds}: expected a positive duration");
    }
    let n = (seconds * rate).round() as usize;
    let controls = Controls::from_args(&m, control, control_file)?;
    let y = free_run(&m, n, &controls)?;
    let d = m.outputs.len();
    match format {
        "csv" => write_atomic(output, |w| {
            write!(w, "time_s")?;
            for o in &m.outputs {
                write!(w, ",{}{}", o.name, unit_suffix(&o.name))?;
            }
            writeln!(w)?;
            for k in 0..n {
                write!(w, "{:.6}", k as f64 / rate)?;
                for v in &y[k * d..(k + 1) * d] {
                    write!(w, ",{v:.6}")?;
                }
                writeln!(w)?;
            }
            Ok(())
        })?,
        "amc" => {
            let sk =
                skeleton.context("--format amc needs --skeleton FILE.asf (the skeleton the channels belong to)")?;
            let sk = Skeleton::from_file(sk)?;
            let channels: Vec<Channel> = m
                .outputs
                .iter()
                .map(|o| {
                    Channel::parse(&o.name)
                        .with_context(|| format!("output '{}' is not a mocap channel (bone.dof)", o.name))
                })
                .collect::<anyhow::Result<_>>()?;
            let motion = Motion::new(channels, y, rate)?;
            let text = write_amc(&sk, &motion)?;
            write_atomic(output, |w| Ok(w.write_all(text.as_bytes())?))?;
        }
        other => bail!("--format {other}: expected csv or amc"),
    }
    eprintln!("wrote {n} frames ({seconds} s at {rate} Hz) of {d} channel(s) to {}", output.display());
    Ok(())
}

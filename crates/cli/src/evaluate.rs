//! `cpg evaluate`: long-run stability (E2) and perturbation recovery (E3) of a model.

use std::path::Path;

use anyhow::{Context, bail};
use cpg_mocap::cycle::{align_to_cycle, estimate_period, half_range};
use cpg_reservoir::{Generator, TrainedCpg};

use crate::generate::Controls;

/// Metrics of one model.
#[derive(Debug)]
pub struct Stability {
    pub steps: usize,
    pub period_end: f64,
    pub period_teacher: f64,
    pub half_range_end: Vec<f64>,
    pub half_range_teacher: Vec<f64>,
    pub end_nmse: f64,
    pub recovery_s: Option<f64>,
    pub phase_shift_cycles: f64,
    pub clamp_value: f64,
}

/// Recovery threshold: RMS distance to the teacher's orbit, in teacher standard deviations.
pub const RECOVERY_THRESHOLD: f64 = 0.25;

pub fn measure(m: &TrainedCpg, controls: &Controls, steps: usize) -> anyhow::Result<Stability> {
    let cycle = m.reference_cycle.as_ref().context("the model has no reference cycle (it was not trained on a looped periodic signal), so there is nothing to compare its rhythm with")?;
    let d = m.outputs.len();
    let rate = m.provenance.sample_rate_hz;
    let p = cycle.len() / d;
    let col = |x: &[f64], c: usize| -> Vec<f64> { x.iter().skip(c).step_by(d).copied().collect() };
    // E2: a long free run; the last 10 s against the teacher's cycle.
    let mut g = Generator::new(m);
    let mut y = Vec::with_capacity(steps * d);
    for k in 0..steps {
        g.step(controls.at(k))?;
        y.extend_from_slice(g.normalised_output());
    }
    let tail = ((10.0 * rate) as usize).max(3 * p).min(steps);
    let end = &y[(steps - tail) * d..];
    let first = col(end, 0);
    let period_end = estimate_period(&first, (p / 2).max(2), (2 * p).min(tail / 2)).unwrap_or(f64::NAN);
    let (_, end_nmse) = align_to_cycle(end, cycle, d);

    // E3: after 2 s, the fed-back output is held at an outlier for 50 ms.
    let start = (2.0 * rate) as usize;
    let hold = ((0.05 * rate).round() as usize).max(1);
    let after = 40 * p;
    let cmax = cycle.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let clamp_value = cmax + 2.0;
    let clamp = vec![clamp_value; d];
    let mut free = Generator::new(m);
    let mut hit = Generator::new(m);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for k in 0..start + hold + after {
        let u = controls.at(k);
        free.step(u)?;
        a.extend_from_slice(free.normalised_output());
        if (start..start + hold).contains(&k) {
            hit.step_clamped(u, &clamp)?;
        } else {
            hit.step(u)?;
        }
        b.extend_from_slice(hit.normalised_output());
    }
    let release = start + hold;
    // Recovered once the distance to the orbit stays under the threshold for a whole cycle.
    let o = cpg_compare::perturb::outcome(&a, &b, d, cycle, release, RECOVERY_THRESHOLD, 1.0 / rate)?;
    let (recovery_s, shift) = (o.recovery_s, o.phase_shift_cycles);
    Ok(Stability {
        steps,
        period_end,
        period_teacher: p as f64,
        half_range_end: (0..d).map(|c| half_range(&col(end, c))).collect(),
        half_range_teacher: (0..d).map(|c| half_range(&col(cycle, c))).collect(),
        end_nmse,
        recovery_s,
        phase_shift_cycles: shift,
        clamp_value,
    })
}

pub fn run(model: &Path, seconds: f64, control: Option<&str>, control_file: Option<&Path>) -> anyhow::Result<()> {
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    if !(seconds.is_finite() && seconds > 1.0) {
        bail!("--seconds {seconds}: expected more than 1 s");
    }
    let controls = Controls::from_args(&m, control, control_file)?;
    let s = measure(&m, &controls, (seconds * rate) as usize)?;
    println!("{}: {} steps ({seconds} s) of free run", model.display(), s.steps);
    println!(
        "  period at the end: {:.2} frames (teacher {:.0}: {:+.2} %)",
        s.period_end,
        s.period_teacher,
        100.0 * (s.period_end / s.period_teacher - 1.0)
    );
    for (k, o) in m.outputs.iter().enumerate() {
        println!(
            "  {}: half range at the end {:.3}, teacher {:.3} ({:+.1} %)",
            o.name,
            s.half_range_end[k],
            s.half_range_teacher[k],
            100.0 * (s.half_range_end[k] / s.half_range_teacher[k] - 1.0)
        );
    }
    println!("  phase-aligned NMSE of the last 10 s: {:.4}", s.end_nmse);
    let stable = (s.period_end / s.period_teacher - 1.0).abs() < 0.01
        && s.half_range_end.iter().zip(&s.half_range_teacher).all(|(a, b)| (a / b - 1.0).abs() < 0.05);
    println!("  stable (period within 1 %, every amplitude within 5 %): {}", if stable { "yes" } else { "no" });
    match s.recovery_s {
        Some(r) => println!(
            "  perturbation (output held at {:.2} σ for 50 ms after 2 s): back within {RECOVERY_THRESHOLD} σ of the orbit after {r:.3} s; phase shift {:+.3} cycles",
            s.clamp_value, s.phase_shift_cycles
        ),
        None => println!("  perturbation: did not return within {RECOVERY_THRESHOLD} σ of the orbit in 40 cycles"),
    }
    Ok(())
}

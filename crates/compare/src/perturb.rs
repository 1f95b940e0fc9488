//! What a generator does after an outside force held its outputs away from
//! the rhythm: the E3 protocol of wyffels & Schrauwen (2009), applied to any
//! [`PatternGenerator`].

use cpg_mocap::cycle::{lag, orbit_distance, settling_index};

use crate::generator::PatternGenerator;
use crate::{Error, Result};

/// The outcome of one perturbation.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// Time from the release until the output stays within `threshold` of the
    /// rhythm's orbit for a whole cycle, seconds (`None`: not within the run).
    pub recovery_s: Option<f64>,
    /// Time from the release until the output stays within `threshold` of the
    /// unperturbed twin itself (same phase) for a whole cycle, seconds
    /// (`None`: it never rejoins, e.g. because its phase moved).
    pub rejoin_s: Option<f64>,
    /// Phase of the perturbed run relative to an unperturbed twin, long after
    /// the release, in cycles (positive: behind).
    pub phase_shift_cycles: f64,
    /// The perturbed run (first output coordinate), for figures.
    pub perturbed: Vec<f64>,
    /// The unperturbed twin (first output coordinate).
    pub free: Vec<f64>,
}

/// A perturbation: from step `at`, for `hold` steps, the outputs are held at `held`.
#[derive(Debug, Clone, Copy)]
pub struct Push<'a> {
    /// The held output values (one per output, output units).
    pub held: &'a [f64],
    /// First held step.
    pub at: usize,
    /// Number of held steps.
    pub hold: usize,
    /// Steps run after the release (at least 4 cycles).
    pub after: usize,
    /// Recovered when the orbit distance (in standard deviations of the cycle) stays below this.
    pub threshold: f64,
}

/// Runs `g` and an unperturbed twin (a clone in the same state) side by
/// side and applies `push` to `g`. The orbit is `cycle` (one period, `p × D`,
/// in output units) and distances are in units of its standard deviation.
pub fn respond<G: PatternGenerator + Clone>(g: &G, cycle: &[f64], push: Push<'_>) -> Result<Response> {
    let Push { held, at, hold, after, threshold } = push;
    let d = g.n_outputs();
    if held.len() != d {
        return Err(Error::Data(format!("{} held values for a generator with {d} outputs", held.len())));
    }
    let (mut free, mut hit) = (g.clone(), g.clone());
    let total = at + hold + after;
    let (mut a, mut b) = (vec![0.0; total * d], vec![0.0; total * d]);
    for (k, (fa, fb)) in a.chunks_exact_mut(d).zip(b.chunks_exact_mut(d)).enumerate() {
        free.step(fa)?;
        if (at..at + hold).contains(&k) { hit.step_held(held, fb)? } else { hit.step(fb)? }
    }
    outcome(&a, &b, d, cycle, at + hold, threshold, g.dt_s())
}

/// Measures a perturbed run `b` against its unperturbed twin `a` (both
/// `T × d`, frame-major, steps of `dt_s`) from the step `release` on, when the
/// perturbation ended: how a perturbation of any kind (a hold, a kick of the
/// state) was answered. At least 4 cycles must follow the release.
pub fn outcome(
    a: &[f64],
    b: &[f64],
    d: usize,
    cycle: &[f64],
    release: usize,
    threshold: f64,
    dt_s: f64,
) -> Result<Response> {
    if d == 0 || a.len() != b.len() || !a.len().is_multiple_of(d) || cycle.is_empty() || !cycle.len().is_multiple_of(d)
    {
        return Err(Error::Data(format!(
            "runs of {} and {} values and a cycle of {} values are not frames of {d} outputs",
            a.len(),
            b.len(),
            cycle.len()
        )));
    }
    let p = cycle.len() / d;
    let after = (a.len() / d).saturating_sub(release);
    if after < 4 * p {
        return Err(Error::Parameter(format!("{after} steps after the release are fewer than 4 cycles of {p}")));
    }
    let dist = orbit_distance(b, cycle, d, (p / 4).max(2));
    let recovery_s = settling_index(&dist, release, threshold, p).map(|k| (k - release) as f64 * dt_s);
    let sd = {
        let m = cycle.iter().sum::<f64>() / cycle.len() as f64;
        (cycle.iter().map(|v| (v - m).powi(2)).sum::<f64>() / cycle.len() as f64).sqrt().max(f64::MIN_POSITIVE)
    };
    let twin: Vec<f64> = a
        .chunks_exact(d)
        .zip(b.chunks_exact(d))
        .map(|(fa, fb)| (fa.iter().zip(fb).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / d as f64).sqrt() / sd)
        .collect();
    let rejoin_s = settling_index(&twin, release, threshold, p).map(|k| (k - release) as f64 * dt_s);
    let col = |x: &[f64], from: usize| -> Vec<f64> { x.iter().skip(from * d).step_by(d).copied().collect() };
    let tail = release + (after - 2 * p).min(after / 2);
    let shift = lag(&col(a, tail), &col(b, tail), p / 2 + 1) / p as f64;
    Ok(Response { recovery_s, rejoin_s, phase_shift_cycles: shift, perturbed: col(b, 0), free: col(a, 0) })
}

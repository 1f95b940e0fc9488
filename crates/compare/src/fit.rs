//! The centralized fitting recipe shared by every comparison, the segmented
//! fit glued by the switching module, and the Table 1 layout of the paper.
//!
//! Recipe *(chosen where methods.md §1.4 leaves it open)*: frequencies are
//! searched on a few control coordinates over a grid from 0.05 to 2.5 Hz
//! (40 values for one or two centers, 16 for three: 560 combinations), refined
//! by golden section, then transferred to every coordinate; satellites use
//! the RBF basis with `b = √(N^(1/M))` (the grid side's square root, so
//! neighbouring bumps overlap about equally for every `M` and `N`).

use cpg_centralized::{Basis, CentralizedNet, Switched, search_frequencies};
use rayon::prelude::*;

use crate::measures::{Errors, errors};
use crate::{Error, Result};

/// A network size: `M` centers and `N` satellites.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Spec {
    /// Number of centers (oscillators), `M`.
    pub centers: usize,
    /// Number of satellites (basis functions), `N`.
    pub satellites: usize,
}

impl Spec {
    /// `M` centers and `N` satellites.
    pub const fn new(centers: usize, satellites: usize) -> Spec {
        Spec { centers, satellites }
    }

    /// The RBF width parameter of the recipe, `b = √(N^(1/M))`.
    pub fn width(&self) -> f64 {
        (self.satellites as f64).powf(1.0 / self.centers.max(1) as f64).sqrt()
    }

    /// Free parameters per coordinate for AICc: `N` weights, a bias and the `M` frequencies.
    pub fn parameters(&self) -> usize {
        self.satellites + 1 + self.centers
    }
}

/// The rows of the paper's Table 1.
pub const TABLE1_SPECS: [Spec; 6] =
    [Spec::new(1, 100), Spec::new(2, 25), Spec::new(2, 50), Spec::new(2, 100), Spec::new(3, 25), Spec::new(3, 100)];

/// The paper's Table 1 (CMU 86_01, "integral relative accuracy", lower is better), row by row as [`TABLE1_SPECS`].
pub const TABLE1_PAPER: [[f64; 4]; 6] = [
    [0.2133, 0.0827, 0.423, 0.0749],
    [0.1207, 0.0486, 0.0405, 0.076],
    [0.0351, 0.0089, 0.0084, 0.0586],
    [0.0189, 0.0068, 0.0029, 0.0299],
    [0.0832, 0.0253, 0.0297, 0.0685],
    [0.0133, 0.0063, 0.0031, 0.0071],
];

/// The paper's segment boundaries for 86_01 (1-based frames).
pub const TABLE1_BOUNDARIES: [usize; 5] = [1, 1300, 2000, 3000, 4500];

/// The recipe's frequency grid for `M` centers, Hz.
pub fn frequency_grid_hz(centers: usize) -> Vec<f64> {
    let n = if centers >= 3 { 16 } else { 40 };
    (0..n).map(|k| 0.05 + 2.45 * k as f64 / (n - 1) as f64).collect()
}

/// Fits one network to `x` (`T × D` at `rate_hz`) with the recipe: frequencies
/// searched on the coordinates `control`, then one solve for all coordinates.
pub fn fit(x: &[f64], d: usize, rate_hz: f64, spec: Spec, control: &[usize]) -> Result<CentralizedNet> {
    if d == 0 || x.is_empty() || !x.len().is_multiple_of(d) {
        return Err(Error::Data(format!("{} values are not frames of {d} coordinates", x.len())));
    }
    if control.is_empty() || control.iter().any(|&c| c >= d) {
        return Err(Error::Parameter(format!("control coordinates {control:?} must be a non-empty subset of 0..{d}")));
    }
    let t = x.len() / d;
    let sub: Vec<f64> = (0..t).flat_map(|k| control.iter().map(move |&c| x[k * d + c])).collect();
    let basis = Basis::Rbf { b: spec.width() };
    let grid = frequency_grid_hz(spec.centers);
    let w = search_frequencies(spec.centers, &grid, spec.satellites, basis, &sub, control.len(), rate_hz)?;
    Ok(CentralizedNet::fit(w, spec.satellites, basis, x, d, rate_hz)?)
}

/// A segmented fit: one network per segment, glued by the switching module.
#[derive(Debug, Clone)]
pub struct Segmented {
    /// The glued networks.
    pub switched: Switched,
    /// The glued output, frame-major like the data.
    pub output: Vec<f64>,
    /// Measures of the glued output on each segment.
    pub per_segment: Vec<Errors>,
    /// Measures over the whole sequence.
    pub whole: Errors,
    /// Largest frame-to-frame movement of any point of the glued output within
    /// ±10 frames of an inner boundary, mm.
    pub worst_jump_mm: f64,
    /// The same for the data, mm (for scale: the data's own largest step there).
    pub data_jump_mm: f64,
}

/// Largest frame-to-frame step of any point within ±10 frames of each boundary.
fn worst_step(y: &[f64], d: usize, inner: &[usize]) -> f64 {
    let t = y.len() / d;
    let mut worst: f64 = 0.0;
    for &b in inner {
        for k in b.saturating_sub(10).max(1)..(b + 10).min(t) {
            for p in 0..d / 3 {
                let s: f64 = (0..3).map(|c| (y[k * d + 3 * p + c] - y[(k - 1) * d + 3 * p + c]).powi(2)).sum();
                worst = worst.max(s.sqrt());
            }
        }
    }
    worst
}

/// Fits `spec` on every segment `[starts[m], starts[m + 1])` (0-based frames;
/// the last value is the end) and glues the networks with windows of
/// steepness `beta` (1/s) centred on the boundaries.
pub fn segmented(
    x: &[f64],
    d: usize,
    rate_hz: f64,
    starts: &[usize],
    spec: Spec,
    control: &[usize],
    beta: f64,
) -> Result<Segmented> {
    let t = if d > 0 && x.len().is_multiple_of(d) { x.len() / d } else { 0 };
    if t == 0 || starts.len() < 2 || starts.windows(2).any(|w| w[1] <= w[0]) || starts[starts.len() - 1] > t {
        return Err(Error::Parameter(format!(
            "segment boundaries {starts:?} must increase and lie within the {t} frames of the data"
        )));
    }
    if !(beta.is_finite() && beta > 0.0) {
        return Err(Error::Parameter(format!("window steepness {beta}/s must be positive")));
    }
    let nets = (0..starts.len() - 1)
        .map(|m| fit(&x[starts[m] * d..starts[m + 1] * d], d, rate_hz, spec, control))
        .collect::<Result<Vec<_>>>()?;
    let switched = Switched { boundaries_s: starts.iter().map(|&s| s as f64 / rate_hz).collect(), beta, nets };
    let (s0, s1) = (starts[0], starts[starts.len() - 1]);
    let data = &x[s0 * d..s1 * d];
    // The switched network's clock starts at time 0, the first frame of the data.
    let output = switched.generate(s1, rate_hz).split_off(s0 * d);
    let per_segment = (0..starts.len() - 1)
        .map(|m| {
            let (a, b) = ((starts[m] - s0) * d, (starts[m + 1] - s0) * d);
            errors(&data[a..b], &output[a..b], d)
        })
        .collect::<Result<Vec<_>>>()?;
    let inner: Vec<usize> = starts[1..starts.len() - 1].iter().map(|s| s - s0).collect();
    Ok(Segmented {
        whole: errors(data, &output, d)?,
        worst_jump_mm: worst_step(&output, d, &inner),
        data_jump_mm: worst_step(data, d, &inner),
        per_segment,
        switched,
        output,
    })
}

/// Converts the paper's 1-based boundaries (`[1, 1300, 2000, 3000, 4500]`:
/// segments 1–1299, 1300–1999, …, 3000–4500) into 0-based segment starts with
/// the end last (`[0, 1299, 1999, 2999, 4500]`).
pub fn starts_from_paper(boundaries: &[usize]) -> Result<Vec<usize>> {
    if boundaries.len() < 2 || boundaries.contains(&0) {
        return Err(Error::Parameter(format!("1-based boundaries {boundaries:?}: need at least two, all ≥ 1")));
    }
    let n = boundaries.len();
    Ok(boundaries.iter().enumerate().map(|(k, &b)| if k + 1 == n { b } else { b - 1 }).collect())
}

/// The Table 1 experiment: every spec fitted segment by segment (specs in
/// parallel; the results do not depend on the thread count).
pub fn table1(
    x: &[f64],
    d: usize,
    rate_hz: f64,
    starts: &[usize],
    specs: &[Spec],
    control: &[usize],
    beta: f64,
) -> Result<Vec<Segmented>> {
    specs.par_iter().map(|&s| segmented(x, d, rate_hz, starts, s, control, beta)).collect()
}

//! Error measures between data `x` and a model `y`, both `T × D` frame-major
//! with `D = 3P` coordinates of `P` points in mm.
//!
//! The paper's formulas are not readable (methods.md §1.8); ours are:
//!
//! - mean 3-D error: `(1/TP) Σ_k Σ_p ‖x_p(k) − y_p(k)‖`, in mm (Figures 15–16);
//! - relative integral error, L1: for each coordinate
//!   `Σ_k |x(k) − y(k)| / Σ_k |x(k) − x̄|`, with `x̄` the coordinate's mean over
//!   the window, then averaged over coordinates (Table 1's "integral relative
//!   accuracy"); the L2 variant uses squares under square roots;
//! - ErrABS: for each coordinate `(1/T) Σ_k |x(k) − y(k)|` in mm, averaged over coordinates.
//!
//! A coordinate that does not move (`Σ|x − x̄| = 0`) is left out of the
//! relative errors.

use crate::{Error, Result};

/// The error measures of one comparison.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Errors {
    /// Mean 3-D distance over points and frames, mm.
    pub mean_mm: f64,
    /// Relative integral error (L1), mean over coordinates.
    pub rel_l1: f64,
    /// Relative integral error (L2), mean over coordinates.
    pub rel_l2: f64,
    /// ErrABS: mean absolute error over frames, mean over coordinates, mm.
    pub err_abs_mm: f64,
}

fn check(x: &[f64], y: &[f64], d: usize) -> Result<usize> {
    if d == 0 || !d.is_multiple_of(3) {
        return Err(Error::Data(format!("{d} coordinates are not points of 3")));
    }
    if x.is_empty() || !x.len().is_multiple_of(d) || x.len() != y.len() {
        return Err(Error::Data(format!(
            "data ({} values) and model ({} values) must be the same whole number of {d}-coordinate frames",
            x.len(),
            y.len()
        )));
    }
    if let Some(k) = x.iter().chain(y).position(|v| !v.is_finite()) {
        let which = if k < x.len() { "data" } else { "model" };
        let k = k % x.len();
        return Err(Error::Data(format!("{which} value at frame {}, coordinate {} is not finite", k / d, k % d)));
    }
    Ok(x.len() / d)
}

/// Sums over the frames of coordinate `c`: `Σ|e|`, `Σ|x − x̄|`, `Σe²`, `Σ(x − x̄)²` with `e = x − y`.
fn sums(x: &[f64], y: &[f64], d: usize, t: usize, c: usize) -> [f64; 4] {
    let m = (0..t).map(|k| x[k * d + c]).sum::<f64>() / t as f64;
    let mut s = [0.0; 4];
    for k in 0..t {
        let e = x[k * d + c] - y[k * d + c];
        let v = x[k * d + c] - m;
        s[0] += e.abs();
        s[1] += v.abs();
        s[2] += e * e;
        s[3] += v * v;
    }
    s
}

/// Relative L1 error of each coordinate (`NaN` for a coordinate that does not move).
pub fn per_coordinate(x: &[f64], y: &[f64], d: usize) -> Result<Vec<f64>> {
    let t = check(x, y, d)?;
    Ok((0..d)
        .map(|c| {
            let [n1, d1, _, _] = sums(x, y, d, t, c);
            if d1 > 0.0 { n1 / d1 } else { f64::NAN }
        })
        .collect())
}

/// All measures of `y` against `x`.
pub fn errors(x: &[f64], y: &[f64], d: usize) -> Result<Errors> {
    let t = check(x, y, d)?;
    let dist: f64 = x.chunks_exact(3).zip(y.chunks_exact(3)).map(|(a, b)| point_distance(a, b)).sum();
    let (mut l1, mut l2, mut abs, mut moving) = (0.0, 0.0, 0.0, 0usize);
    for c in 0..d {
        let [n1, d1, n2, d2] = sums(x, y, d, t, c);
        abs += n1 / t as f64;
        if d1 > 0.0 {
            l1 += n1 / d1;
            l2 += (n2 / d2).sqrt();
            moving += 1;
        }
    }
    let moving = moving.max(1) as f64;
    Ok(Errors {
        mean_mm: dist / (t * d / 3) as f64,
        rel_l1: l1 / moving,
        rel_l2: l2 / moving,
        err_abs_mm: abs / d as f64,
    })
}

fn point_distance(a: &[f64], b: &[f64]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Phase alignment: the offset `s ∈ 0..=max_offset` for which the model
/// frames `y_long[s..s + T]` are closest to `x` (`T` frames) in mean 3-D
/// distance, and the measures at that offset. `y_long` must hold at least
/// `T + max_offset` frames.
pub fn align(y_long: &[f64], x: &[f64], d: usize, max_offset: usize) -> Result<(usize, Errors)> {
    let t = check(x, x, d)?;
    if y_long.len() < (t + max_offset) * d {
        return Err(Error::Data(format!(
            "the model run has {} frames, alignment needs {} + {max_offset}",
            y_long.len() / d,
            t
        )));
    }
    let mut best = (0, f64::INFINITY);
    for s in 0..=max_offset {
        let y = &y_long[s * d..(s + t) * d];
        let mut dist = 0.0;
        for (a, b) in x.chunks_exact(3).zip(y.chunks_exact(3)) {
            dist += point_distance(a, b);
            if dist >= best.1 {
                break;
            }
        }
        if dist < best.1 {
            best = (s, dist);
        }
    }
    Ok((best.0, errors(x, &y_long[best.0 * d..(best.0 + t) * d], d)?))
}

//! Ridge regression with an unpenalised bias.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatRef, Par, Side};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::fixed::{Tridiagonal, at_b, padded};

/// A linear readout `y = W·x + b`: `weights` is `n_outputs × n_features`, row-major.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Readout {
    /// Number of features (the length of `x`).
    pub n_features: usize,
    /// Row-major `n_outputs × n_features` weights.
    pub weights: Vec<f64>,
    /// One bias per output.
    pub bias: Vec<f64>,
}

impl Readout {
    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.bias.len()
    }

    /// Applies the readout to one feature vector.
    ///
    /// # Panics
    /// When `x.len() != n_features` or `out.len() != n_outputs()`.
    #[track_caller]
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        assert_eq!(x.len(), self.n_features, "feature vector length");
        assert_eq!(out.len(), self.bias.len(), "output length");
        for (o, (row, b)) in out.iter_mut().zip(self.weights.chunks_exact(self.n_features).zip(&self.bias)) {
            *o = b + row.iter().zip(x).map(|(w, v)| w * v).sum::<f64>();
        }
    }

    /// Euclidean norm of the weights (bias excluded).
    pub fn weight_norm(&self) -> f64 {
        self.weights.iter().map(|w| w * w).sum::<f64>().sqrt()
    }
}

fn check_finite(m: MatRef<'_, f64>, what: &'static str) -> Result<()> {
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if !m[(i, j)].is_finite() {
                return Err(Error::NonFinite { what, row: i, col: j });
            }
        }
    }
    Ok(())
}

fn column_means(m: MatRef<'_, f64>) -> Vec<f64> {
    (0..m.ncols()).map(|j| (0..m.nrows()).map(|i| m[(i, j)]).sum::<f64>() / m.nrows() as f64).collect()
}

/// The centred normal equations of a least-squares problem: `X̃ᵀX̃`, `X̃ᵀỸ`
/// and the column means that centred it.
struct Centred {
    gram: Mat<f64>,
    xty: Mat<f64>,
    x_mean: Vec<f64>,
    y_mean: Vec<f64>,
}

fn check_shapes(x: MatRef<'_, f64>, y: MatRef<'_, f64>) -> Result<()> {
    if x.nrows() != y.nrows() {
        return Err(Error::Shape(format!("{} feature rows but {} target rows", x.nrows(), y.nrows())));
    }
    if x.nrows() < 2 || x.ncols() == 0 || y.ncols() == 0 {
        return Err(Error::Shape(format!(
            "need at least 2 samples, 1 feature and 1 target; got {}×{} and {}×{}",
            x.nrows(),
            x.ncols(),
            y.nrows(),
            y.ncols()
        )));
    }
    check_finite(x, "feature matrix")?;
    check_finite(y, "target matrix")
}

fn centred(x: MatRef<'_, f64>, y: MatRef<'_, f64>) -> Result<Centred> {
    check_shapes(x, y)?;
    let x_mean = column_means(x);
    let y_mean = column_means(y);
    let xc = Mat::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)] - x_mean[j]);
    let yc = Mat::from_fn(y.nrows(), y.ncols(), |i, j| y[(i, j)] - y_mean[j]);
    let n = x.ncols();
    let mut gram = Mat::<f64>::zeros(n, n);
    matmul(gram.as_mut(), Accum::Replace, xc.transpose(), xc.as_ref(), 1.0, Par::Seq);
    let mut xty = Mat::<f64>::zeros(n, y.ncols());
    matmul(xty.as_mut(), Accum::Replace, xc.transpose(), yc.as_ref(), 1.0, Par::Seq);
    Ok(Centred { gram, xty, x_mean, y_mean })
}

/// The readout for centred weights `w` (`N × D`): the bias makes the fit exact in the mean.
fn readout(w: MatRef<'_, f64>, x_mean: &[f64], y_mean: &[f64]) -> Readout {
    let (n, d) = (w.nrows(), w.ncols());
    let mut weights = Vec::with_capacity(n * d);
    let mut bias = Vec::with_capacity(d);
    for j in 0..d {
        let mut b = y_mean[j];
        for i in 0..n {
            weights.push(w[(i, j)]);
            b -= x_mean[i] * w[(i, j)];
        }
        bias.push(b);
    }
    Readout { n_features: n, weights, bias }
}

/// The data of a ridge problem, factorised once for every penalty.
///
/// With `X̃ = X − mean(X)` and `Ỹ = Y − mean(Y)`, the Gram matrix
/// `X̃ᵀX̃ = Q·T·Qᵀ` is reduced once to tridiagonal form by Householder
/// reflections. For a penalty `λ`, `W = Q·(T + λI)⁻¹·QᵀX̃ᵀỸ` minimises
/// `‖X̃W − Ỹ‖² + λ‖W‖²`, and the bias `b = mean(Y) − mean(X)·W` makes the fit
/// exact in the mean, so the bias is not penalised.
///
/// Every step runs in a fixed order ([`crate::fixed`]): the same data give
/// the same bits on every machine, whatever its instruction set or caches.
#[derive(Debug, Clone)]
pub struct RidgePath {
    tri: Tridiagonal,
    /// `Qᵀ X̃ᵀ Ỹ`, row-major `n_features × n_outputs`.
    projected: Vec<f64>,
    x_mean: Vec<f64>,
    y_mean: Vec<f64>,
    n_samples: usize,
}

/// `m` centred and laid out row-major with its width padded: (values, padded width).
fn centred_rows(m: MatRef<'_, f64>, mean: &[f64]) -> (Vec<f64>, usize) {
    let w = padded(m.ncols());
    let mut out = vec![0.0; m.nrows() * w];
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out[i * w + j] = m[(i, j)] - mean[j];
        }
    }
    (out, w)
}

impl RidgePath {
    /// Factorises the problem for features `x` (`T × N`) and targets `y` (`T × D`).
    pub fn new(x: MatRef<'_, f64>, y: MatRef<'_, f64>) -> Result<RidgePath> {
        check_shapes(x, y)?;
        let x_mean = column_means(x);
        let y_mean = column_means(y);
        let (t, n, d) = (x.nrows(), x.ncols(), y.ncols());
        let (a, na) = centred_rows(x, &x_mean);
        let (b, nb) = centred_rows(y, &y_mean);
        let gram = at_b(&a, na, n, &a, na, t, true);
        let xty = at_b(&a, na, n, &b, nb, t, false);
        let mut square = vec![0.0; n * n];
        for i in 0..n {
            square[i * n..(i + 1) * n].copy_from_slice(&gram[i * na..i * na + n]);
        }
        let mut projected = vec![0.0; n * d];
        for i in 0..n {
            projected[i * d..(i + 1) * d].copy_from_slice(&xty[i * nb..i * nb + d]);
        }
        let tri = Tridiagonal::new(square, n);
        tri.apply_qt(&mut projected, d);
        Ok(RidgePath { tri, projected, x_mean, y_mean, n_samples: t })
    }

    /// Number of features.
    pub fn n_features(&self) -> usize {
        self.x_mean.len()
    }

    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.y_mean.len()
    }

    /// Number of samples the path was built from.
    pub fn n_samples(&self) -> usize {
        self.n_samples
    }

    /// The largest eigenvalue of the centred Gram matrix (a scale for penalties).
    pub fn largest_gram_eigenvalue(&self) -> f64 {
        self.tri.largest_eigenvalue()
    }

    /// The readout for one penalty.
    pub fn solve(&self, penalty: f64) -> Result<Readout> {
        if !(penalty.is_finite() && penalty >= 0.0) {
            return Err(Error::InvalidPenalty(penalty));
        }
        let (n, d) = (self.n_features(), self.n_outputs());
        let mut z = self.projected.clone();
        self.tri.solve_shifted(penalty, &mut z, d);
        self.tri.apply_q(&mut z, d);
        let mut weights = Vec::with_capacity(n * d);
        let mut bias = Vec::with_capacity(d);
        for j in 0..d {
            let mut b = self.y_mean[j];
            for i in 0..n {
                let w = z[i * d + j];
                weights.push(w);
                b = (-self.x_mean[i]).mul_add(w, b);
            }
            bias.push(b);
        }
        Ok(Readout { n_features: n, weights, bias })
    }
}

/// Ridge regression solved directly, `(X̃ᵀX̃ + λI) W = X̃ᵀỸ` by a Cholesky
/// factorisation: one factorisation per penalty. For checking [`RidgePath`]
/// and for one-off fits.
pub fn ridge_direct(x: MatRef<'_, f64>, y: MatRef<'_, f64>, penalty: f64) -> Result<Readout> {
    if !(penalty.is_finite() && penalty > 0.0) {
        return Err(Error::InvalidPenalty(penalty));
    }
    let Centred { mut gram, xty, x_mean, y_mean } = centred(x, y)?;
    for k in 0..gram.nrows() {
        gram[(k, k)] += penalty;
    }
    let llt = gram.llt(Side::Lower).map_err(|_| Error::Decomposition)?;
    let w = faer::linalg::solvers::Solve::solve(&llt, xty.as_ref());
    Ok(readout(w.as_ref(), &x_mean, &y_mean))
}

/// Below this variance (normalised units²) a channel does not move: its
/// squared error counts in its own units, not divided by a variance of ~0.
pub const STILL_VARIANCE: f64 = 1e-12;

/// Normalised mean squared error: for each output the mean squared error
/// divided by the target's (population) variance, averaged over outputs; an
/// output whose target does not move (variance below [`STILL_VARIANCE`])
/// adds its mean squared error itself. `prediction` and `target` are row-major `T × n_outputs`.
///
/// Returns `f64::INFINITY` when the prediction holds a non-finite value.
///
/// # Panics
/// When the lengths differ or are not a multiple of `n_outputs`.
#[track_caller]
pub fn nmse(prediction: &[f64], target: &[f64], n_outputs: usize) -> f64 {
    assert_eq!(prediction.len(), target.len(), "prediction and target lengths");
    assert!(n_outputs > 0 && target.len().is_multiple_of(n_outputs), "length not a multiple of n_outputs");
    let t = target.len() / n_outputs;
    let mut total = 0.0;
    for j in 0..n_outputs {
        let col = || target.iter().skip(j).step_by(n_outputs);
        let mean = col().sum::<f64>() / t as f64;
        let var = col().map(|v| (v - mean) * (v - mean)).sum::<f64>() / t as f64;
        let mse = prediction.iter().skip(j).step_by(n_outputs).zip(col()).map(|(p, v)| (p - v) * (p - v)).sum::<f64>()
            / t as f64;
        if !mse.is_finite() {
            return f64::INFINITY;
        }
        total += if var < STILL_VARIANCE { mse } else { mse / var };
    }
    total / n_outputs as f64
}

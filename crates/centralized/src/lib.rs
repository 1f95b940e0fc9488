//! # cpg-centralized
//!
//! Centralized networks after Vakulenko, Radulescu, Morozov & Weber (2017):
//! a few *centers*, phase oscillators with their own frequencies, drive many
//! *satellites*, radial basis functions of the centers' phases, whose linear
//! combination is the output. Only the paper's headings, captions and Table 1
//! survive; the method is reconstructed in `shared/research/methods.md` §1,
//! and every choice below that the sources do not state is marked *(chosen)*.
//!
//! - Centers: `φ_m(t) = ω_m·t` (phase form), or [`HopfCenters`], the Hopf normal
//!   form with the same limit cycle, as an option. *(chosen: zero initial phases, which the satellite grid makes redundant)*
//! - Satellites, RBF basis: `Φ_j(φ) = Π_m exp(b²·(cos(φ_m − φ̄_jm) − 1))`, the
//!   torus form of `exp(−b²|q − q̄_j|²/2)` for `q` on unit circles. Alternatives
//!   of the paper: harmonic `cos(b·j·φ)` and polynomial `φ^(j−1)` (of the first center).
//! - Output: `x_i = Σ_j c_ij Φ_j + c_i0`, all coordinates in one least-squares
//!   solve (ridge with a tiny penalty for conditioning, via cpg-regression).
//! - Satellite centres: a regular grid on the M-torus when N is a perfect M-th
//!   power, else the phase vectors of N equally spaced frames *(chosen)*.
//! - Frequencies: searched on a few coordinates over a grid and refined
//!   (golden section per center), then reused for all coordinates *(the
//!   abstract's "learned from a few markers and transferred")*.
//! - Switching module: a clock hub `z = t` and one sigmoid window per segment,
//!   `s_m = σ(β(z − T_{m−1})) − σ(β(z − T_m))`, gluing per-segment networks.
//! - AICc: `n·ln(RSS/n) + 2k + 2k(k+1)/(n − k − 1)` with `n` = samples of one
//!   coordinate and `k = N + 1 + M` *(chosen; the paper's convention is unknown)*.

use std::f64::consts::PI;

use cpg_regression::{Readout, RidgePath, exp_det};
use faer::Mat;

/// What can go wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A parameter out of range.
    #[error("invalid parameter: {0}")]
    Parameter(String),
    /// Data of the wrong shape or not finite.
    #[error("invalid data: {0}")]
    Data(String),
    /// The least-squares fit failed.
    #[error(transparent)]
    Regression(#[from] cpg_regression::Error),
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The satellites' basis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Basis {
    /// Radial basis functions on the torus, width parameter `b`.
    Rbf {
        /// `b` in `exp(b²(cos Δ − 1))`.
        b: f64,
    },
    /// `cos(b·j·φ_1)` for `j = 1 … N` (first center only).
    Harmonic {
        /// Frequency multiplier.
        b: f64,
    },
    /// `(φ_1 / T_span)^(j−1)`, scaled to [0, 1] over the fitted span (first center only).
    Polynomial,
}

/// A fitted centralized network for `D` output coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct CentralizedNet {
    /// Angular frequency of each center, rad/s.
    pub omega_rad_s: Vec<f64>,
    /// Satellite centres, `N × M` phases (RBF basis), row-major.
    pub centres: Vec<f64>,
    /// The basis.
    pub basis: Basis,
    /// Number of satellites.
    pub n_satellites: usize,
    /// Duration the network was fitted on, seconds (used by the polynomial basis).
    pub span_s: f64,
    /// Linear output layer.
    pub readout: Readout,
    /// `cos` and `sin` of every centre phase (RBF basis): the satellites are
    /// then sums of products, `cos(φ − φ̄) = cos φ cos φ̄ + sin φ sin φ̄`.
    trig: Vec<(f64, f64)>,
}

fn check_data(x: &[f64], d: usize) -> Result<usize> {
    if d == 0 || x.is_empty() || !x.len().is_multiple_of(d) {
        return Err(Error::Data(format!("{} values are not frames of {d} coordinates", x.len())));
    }
    if let Some(k) = x.iter().position(|v| !v.is_finite()) {
        return Err(Error::Data(format!("value {k} is not finite")));
    }
    Ok(x.len() / d)
}

/// Satellite centres *(chosen)*: a grid on the torus when `n` is a perfect
/// `M`-th power, otherwise the center phases at `n` equally spaced times of the span.
pub fn satellite_centres(n: usize, omega_rad_s: &[f64], span_s: f64) -> Vec<f64> {
    let m = omega_rad_s.len();
    let side = (n as f64).powf(1.0 / m as f64).round() as usize;
    if side.pow(m as u32) == n {
        let mut out = Vec::with_capacity(n * m);
        for j in 0..n {
            let mut r = j;
            for _ in 0..m {
                out.push(2.0 * PI * (r % side) as f64 / side as f64);
                r /= side;
            }
        }
        out
    } else {
        (0..n)
            .flat_map(|j| {
                let t = span_s * j as f64 / n as f64;
                omega_rad_s.iter().map(move |w| (w * t).rem_euclid(2.0 * PI))
            })
            .collect()
    }
}

impl CentralizedNet {
    /// Satellite activities at time `t_s` into `out` (length N), with the
    /// phase-form centers `φ_m = ω_m·t`.
    pub fn satellites(&self, t_s: f64, out: &mut [f64]) {
        let w = &self.omega_rad_s;
        self.satellites_with(|m| w[m] * t_s, t_s, out);
    }

    /// Satellite activities for given center phases (rad, one per center),
    /// e.g. from [`HopfCenters`]. The polynomial basis, a function of time,
    /// reads the time as `φ_1 / ω_1`.
    pub fn satellites_at_phases(&self, phases: &[f64], out: &mut [f64]) {
        let t_s = if self.omega_rad_s[0] != 0.0 { phases[0] / self.omega_rad_s[0] } else { 0.0 };
        self.satellites_with(|m| phases[m], t_s, out);
    }

    fn satellites_with(&self, phase: impl Fn(usize) -> f64, t_s: f64, out: &mut [f64]) {
        let m = self.omega_rad_s.len();
        match self.basis {
            Basis::Rbf { b } => {
                let b2 = b * b;
                let mut cs = [(0.0, 0.0); 8];
                let many;
                let cs: &[(f64, f64)] = if m <= 8 {
                    for (k, c) in cs.iter_mut().take(m).enumerate() {
                        *c = phase(k).sin_cos();
                    }
                    &cs[..m]
                } else {
                    many = (0..m).map(|k| phase(k).sin_cos()).collect::<Vec<_>>();
                    &many
                };
                rbf_row(b2, cs, &self.trig, out);
            }
            Basis::Harmonic { b } => {
                let phi = phase(0);
                for (j, o) in out.iter_mut().enumerate() {
                    *o = (b * (j + 1) as f64 * phi).cos();
                }
            }
            Basis::Polynomial => {
                let s = t_s / self.span_s.max(f64::MIN_POSITIVE);
                let mut p = 1.0;
                for o in out.iter_mut() {
                    *o = p;
                    p *= s;
                }
            }
        }
    }

    /// Fits the output layer for given frequencies: `x` holds `T × D` samples at `rate_hz`.
    pub fn fit(
        omega_rad_s: Vec<f64>,
        n_satellites: usize,
        basis: Basis,
        x: &[f64],
        d: usize,
        rate_hz: f64,
    ) -> Result<CentralizedNet> {
        Ok(CentralizedNet::fit_design(omega_rad_s, n_satellites, basis, x, d, rate_hz)?.0)
    }

    /// [`fit`](Self::fit) and the residual sum of squares of the fit against
    /// `x`, from the same design matrix (what [`rss`](Self::rss) would
    /// recompute by generating the whole output again).
    pub fn fit_rss(
        omega_rad_s: Vec<f64>,
        n_satellites: usize,
        basis: Basis,
        x: &[f64],
        d: usize,
        rate_hz: f64,
    ) -> Result<(CentralizedNet, f64)> {
        let (net, a) = CentralizedNet::fit_design(omega_rad_s, n_satellites, basis, x, d, rate_hz)?;
        let t = x.len() / d;
        let r = &net.readout;
        let mut rss = 0.0;
        let mut row = vec![0.0; n_satellites];
        let mut y = vec![0.0; d];
        for k in 0..t {
            for (j, v) in row.iter_mut().enumerate() {
                *v = a[(k, j)];
            }
            r.apply(&row, &mut y);
            rss += y.iter().zip(&x[k * d..(k + 1) * d]).map(|(p, q)| (p - q) * (p - q)).sum::<f64>();
        }
        Ok((net, rss))
    }

    fn fit_design(
        omega_rad_s: Vec<f64>,
        n_satellites: usize,
        basis: Basis,
        x: &[f64],
        d: usize,
        rate_hz: f64,
    ) -> Result<(CentralizedNet, Mat<f64>)> {
        let t = check_data(x, d)?;
        if omega_rad_s.is_empty() || omega_rad_s.iter().any(|w| !w.is_finite()) || n_satellites == 0 {
            return Err(Error::Parameter("need at least one finite center frequency and one satellite".into()));
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::Parameter(format!("rate {rate_hz} Hz must be positive")));
        }
        let span_s = t as f64 / rate_hz;
        let centres = satellite_centres(n_satellites, &omega_rad_s, span_s);
        let mut net = CentralizedNet {
            trig: centres.iter().map(|c| c.sin_cos()).collect(),
            centres,
            omega_rad_s,
            basis,
            n_satellites,
            span_s,
            readout: Readout { n_features: n_satellites, weights: vec![0.0; n_satellites * d], bias: vec![0.0; d] },
        };
        let mut row = vec![0.0; n_satellites];
        let mut a = Mat::<f64>::zeros(t, n_satellites);
        for k in 0..t {
            net.satellites(k as f64 / rate_hz, &mut row);
            for (j, v) in row.iter().enumerate() {
                a[(k, j)] = *v;
            }
        }
        let y = Mat::from_fn(t, d, |k, i| x[k * d + i]);
        let path = RidgePath::new(a.as_ref(), y.as_ref())?;
        // A tiny penalty only for conditioning: relative 1e-10 of the largest Gram eigenvalue.
        let top = path.largest_gram_eigenvalue();
        net.readout = path.solve(1e-10 * top.max(1e-300))?;
        Ok((net, a))
    }

    /// The output at time `t_s` into `out` (length D); `sat` is scratch of length N.
    pub fn output(&self, t_s: f64, sat: &mut [f64], out: &mut [f64]) {
        self.satellites(t_s, sat);
        self.readout.apply(sat, out);
    }

    /// Outputs at `T` frames of `rate_hz` from time 0, frame-major.
    pub fn generate(&self, t: usize, rate_hz: f64) -> Vec<f64> {
        let d = self.readout.n_outputs();
        let mut sat = vec![0.0; self.n_satellites];
        let mut y = vec![0.0; d];
        let mut out = Vec::with_capacity(t * d);
        for k in 0..t {
            self.output(k as f64 / rate_hz, &mut sat, &mut y);
            out.extend_from_slice(&y);
        }
        out
    }

    /// Residual sum of squares against `x` (`T × D`) at `rate_hz`.
    pub fn rss(&self, x: &[f64], rate_hz: f64) -> f64 {
        let d = self.readout.n_outputs();
        let g = self.generate(x.len() / d, rate_hz);
        g.iter().zip(x).map(|(a, b)| (a - b).powi(2)).sum()
    }
}

/// One row of RBF satellites: `out[j] = exp(b²·Σ_m (cos φ_m cos φ̄_jm + sin φ_m sin φ̄_jm − 1))`,
/// with `cs[m] = (sin φ_m, cos φ_m)` and `trig[j·M + m] = (sin φ̄_jm, cos φ̄_jm)`.
#[inline]
fn rbf_row(b2: f64, cs: &[(f64, f64)], trig: &[(f64, f64)], out: &mut [f64]) {
    let m = cs.len();
    for (o, tr) in out.iter_mut().zip(trig.chunks_exact(m)) {
        let mut e = 0.0;
        for ((s, c), (ts, tc)) in cs.iter().zip(tr) {
            e += (c * tc + s * ts) - 1.0;
        }
        *o = exp_det(b2 * e);
    }
}

/// AICc of a fit with residual sum of squares `rss` over `n` samples and `k`
/// free parameters: `n·ln(RSS/n) + 2k + 2k(k+1)/(n − k − 1)` (infinite when `n ≤ k + 1`).
pub fn aicc(rss: f64, n: usize, k: usize) -> f64 {
    if n <= k + 1 || rss <= 0.0 {
        return f64::INFINITY;
    }
    let n = n as f64;
    let k = k as f64;
    n * (rss / n).ln() + 2.0 * k + 2.0 * k * (k + 1.0) / (n - k - 1.0)
}

/// Searches center frequencies (Hz) on the coordinates `x` (`T × D`, a few
/// markers): every combination of `M` frequencies from `grid_hz` is fitted and
/// scored by its residual, the best is refined one center at a time by golden
/// section within ±half a grid step, and the frequencies are returned in rad/s.
pub fn search_frequencies(
    m: usize,
    grid_hz: &[f64],
    n_satellites: usize,
    basis: Basis,
    x: &[f64],
    d: usize,
    rate_hz: f64,
) -> Result<Vec<f64>> {
    if m == 0 || grid_hz.len() < m {
        return Err(Error::Parameter(format!(
            "need M ≥ 1 and at least M grid frequencies (M = {m}, grid {})",
            grid_hz.len()
        )));
    }
    let score = |f: &[f64]| -> f64 {
        let w: Vec<f64> = f.iter().map(|h| 2.0 * PI * h).collect();
        CentralizedNet::fit_rss(w, n_satellites, basis, x, d, rate_hz).map(|(_, rss)| rss).unwrap_or(f64::INFINITY)
    };
    // Combinations without repetition, in increasing order.
    let mut best = (f64::INFINITY, vec![grid_hz[0]; m]);
    let mut idx: Vec<usize> = (0..m).collect();
    loop {
        let f: Vec<f64> = idx.iter().map(|&i| grid_hz[i]).collect();
        let s = score(&f);
        if s < best.0 {
            best = (s, f);
        }
        // next combination
        let mut k = m;
        while k > 0 && idx[k - 1] == grid_hz.len() - m + k - 1 {
            k -= 1;
        }
        if k == 0 {
            break;
        }
        idx[k - 1] += 1;
        for j in k..m {
            idx[j] = idx[j - 1] + 1;
        }
    }
    let step = if grid_hz.len() > 1 { (grid_hz[1] - grid_hz[0]).abs() } else { grid_hz[0] * 0.1 };
    let mut f = best.1;
    for c in 0..m {
        let (mut lo, mut hi) = ((f[c] - step / 2.0).max(0.0), f[c] + step / 2.0);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..20 {
            let a = hi - g * (hi - lo);
            let b = lo + g * (hi - lo);
            let mut fa = f.clone();
            fa[c] = a;
            let mut fb = f.clone();
            fb[c] = b;
            if score(&fa) < score(&fb) { hi = b } else { lo = a }
        }
        f[c] = 0.5 * (lo + hi);
    }
    Ok(f.iter().map(|h| 2.0 * PI * h).collect())
}

/// Centers in the Hopf normal form, `ż_m = (1 − |z_m|²)·z_m + i·ω_m·z_m`,
/// the option beside the phase form: on the unit circle both give
/// `φ_m = ω_m·t`, but a Hopf center pushed off its cycle returns to it
/// (radially at rate 2/s) while keeping the phase it was pushed to.
/// Advanced in closed form; allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub struct HopfCenters {
    /// Angular frequency of each center, rad/s.
    pub omega_rad_s: Vec<f64>,
    /// Center states `(Re z, Im z)`.
    pub z: Vec<[f64; 2]>,
    /// Unwrapped phases (rad), tracked so that phases grow without bound like `ω·t`.
    unwrapped: Vec<f64>,
}

impl HopfCenters {
    /// Centers on their cycles at phase 0.
    pub fn new(omega_rad_s: Vec<f64>) -> HopfCenters {
        let m = omega_rad_s.len();
        HopfCenters { omega_rad_s, z: vec![[1.0, 0.0]; m], unwrapped: vec![0.0; m] }
    }

    /// Advances every center by `dt_s`, exactly: in polar form the normal
    /// form separates into `ṙ = r(1 − r²)`, solved by
    /// `r(t) = (1 + (1/r₀² − 1)·e^(−2t))^(−1/2)`, and `φ̇ = ω`.
    pub fn advance(&mut self, dt_s: f64) {
        let decay = (-2.0 * dt_s).exp();
        for ((z, &w), u) in self.z.iter_mut().zip(&self.omega_rad_s).zip(self.unwrapped.iter_mut()) {
            let r2 = z[0] * z[0] + z[1] * z[1];
            let r = if r2 > 0.0 { (1.0 / (1.0 + (1.0 / r2 - 1.0) * decay)).sqrt() } else { 0.0 };
            *u += w * dt_s;
            if r2 > 0.0 {
                let (sin, cos) = (z[1].atan2(z[0]) + w * dt_s).sin_cos();
                *z = [r * cos, r * sin];
            }
        }
    }

    /// Moves center `m` to `z` (a perturbation); its phase is kept continuous.
    pub fn set_state(&mut self, m: usize, z: [f64; 2]) {
        if let (Some(old), Some(u)) = (self.z.get_mut(m), self.unwrapped.get_mut(m)) {
            let turn = (z[1].atan2(z[0]) - old[1].atan2(old[0]) + PI).rem_euclid(2.0 * PI) - PI;
            *u += turn;
            *old = z;
        }
    }

    /// The unwrapped phases into `out` (one per center).
    pub fn phases(&self, out: &mut [f64]) {
        out.copy_from_slice(&self.unwrapped);
    }

    /// Distance of each center from its unit cycle, `| |z| − 1 |`, largest.
    pub fn off_cycle(&self) -> f64 {
        self.z.iter().map(|z| ((z[0] * z[0] + z[1] * z[1]).sqrt() - 1.0).abs()).fold(0.0, f64::max)
    }
}

/// The switching module: a clock hub and one sigmoid window per segment,
/// gluing networks fitted on consecutive segments `[T_{m−1}, T_m)` (seconds).
#[derive(Debug, Clone, PartialEq)]
pub struct Switched {
    /// Segment boundaries in seconds, `M + 1` increasing values.
    pub boundaries_s: Vec<f64>,
    /// Steepness β of the windows, 1/s.
    pub beta: f64,
    /// One network per segment, each with its own time origin at the segment start.
    pub nets: Vec<CentralizedNet>,
}

fn sigmoid(u: f64) -> f64 {
    1.0 / (1.0 + (-u).exp())
}

impl Switched {
    /// Window weights of every segment at time `t_s`.
    pub fn windows(&self, t_s: f64, out: &mut [f64]) {
        for (m, o) in out.iter_mut().enumerate() {
            let (a, b) = (self.boundaries_s[m], self.boundaries_s[m + 1]);
            let first = if m == 0 { 1.0 } else { sigmoid(self.beta * (t_s - a)) };
            let last = if m + 1 == self.nets.len() { 0.0 } else { sigmoid(self.beta * (t_s - b)) };
            *o = first - last;
        }
    }

    /// Largest satellite count of the glued networks (the scratch size [`Switched::output`] needs).
    pub fn max_satellites(&self) -> usize {
        self.nets.iter().map(|n| n.n_satellites).max().unwrap_or(0)
    }

    /// The glued output at `t_s` into `out` (length D). Scratch: `w` one value
    /// per segment, `sat` at least [`Switched::max_satellites`], `y` length D.
    /// Allocates nothing.
    pub fn output(&self, t_s: f64, w: &mut [f64], sat: &mut [f64], y: &mut [f64], out: &mut [f64]) {
        self.windows(t_s, w);
        out.iter_mut().for_each(|v| *v = 0.0);
        for (m, net) in self.nets.iter().enumerate() {
            if w[m].abs() < 1e-12 {
                continue;
            }
            net.output(t_s - self.boundaries_s[m], &mut sat[..net.n_satellites], y);
            for (o, v) in out.iter_mut().zip(y.iter()) {
                *o += w[m] * v;
            }
        }
    }

    /// The glued output at `T` frames of `rate_hz`, frame-major.
    pub fn generate(&self, t: usize, rate_hz: f64) -> Vec<f64> {
        let d = self.nets.first().map_or(0, |n| n.readout.n_outputs());
        let mut w = vec![0.0; self.nets.len()];
        let mut sat = vec![0.0; self.max_satellites()];
        let mut y = vec![0.0; d];
        let mut out = vec![0.0; t * d];
        for (k, o) in out.chunks_exact_mut(d.max(1)).enumerate() {
            self.output(k as f64 / rate_hz, &mut w, &mut sat, &mut y, o);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_matches_the_standard_library() {
        let mut worst: f64 = 0.0;
        for i in -750_000..=709_000 {
            let x = i as f64 * 1e-3;
            let want = x.exp();
            let got = exp_det(x);
            if want > 1e-300 {
                worst = worst.max(((got - want) / want).abs());
            } else {
                assert!(got < 1e-290, "{x}: {got}");
            }
        }
        assert!(worst < 4e-16, "relative error {worst}");
        assert_eq!(exp_det(0.0), 1.0);
        assert!(exp_det(f64::NAN).is_nan());
    }
}

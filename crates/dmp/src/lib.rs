//! # cpg-dmp
//!
//! Rhythmic dynamic movement primitives (Schaal's DMPs) computed exactly as
//! the Python package pydmps 0.2 computes them, so that results can be
//! compared with the literature that used it (Vakulenko et al. 2017):
//!
//! - canonical phase `x ← x + τ·dt/(1 + error)`, starting at 1;
//! - basis `ψ_b(x) = exp(h·(cos(x − c_b) − 1))`, centres `c_b = 2π·b/n` for
//!   `b = 0 … n−1`, width `h = n`;
//! - forcing term `f = Σ ψ_b w_b / Σ ψ_b`;
//! - transformation `ÿ = τ·(a_y·(b_y·(g − y) − ẏ/τ) + f)`, then
//!   `ẏ += ÿ·τ·dt·ec`, `y += ẏ·dt·ec` with `ec = 1/(1 + error)`; `a_y = 25`, `b_y = a_y/4`;
//! - imitation: the whole demonstration is one period (sample `j` at phase
//!   `2π·j/(T−1)`), resampled linearly at `t·dt` for `t < ⌊2π/dt⌋`; velocities and
//!   accelerations by forward differences with a leading 0; the goal is the
//!   mid-range `(min + max)/2` (nudged by 1e-4 when it equals the start); each
//!   weight is the ψ-weighted average of the target forcing term.
//!
//! Every degree of freedom is an independent DMP sharing the phase.

use std::f64::consts::PI;

/// Bad input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A parameter out of range.
    #[error("invalid parameter: {0}")]
    Parameter(String),
    /// A demonstration of the wrong shape or with non-finite values.
    #[error("invalid demonstration: {0}")]
    Demonstration(String),
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Settings of a rhythmic DMP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DmpConfig {
    /// Number of basis functions per degree of freedom.
    pub n_basis: usize,
    /// Integration step (pydmps default 0.01; one period is `2π` of phase).
    pub dt: f64,
    /// Gain `a_y` (pydmps: 25).
    pub ay: f64,
    /// Gain `b_y` (pydmps: `a_y / 4`).
    pub by: f64,
}

impl DmpConfig {
    /// pydmps 0.2's defaults with `n_basis` basis functions and step `dt`.
    pub fn pydmps(n_basis: usize, dt: f64) -> DmpConfig {
        DmpConfig { n_basis, dt, ay: 25.0, by: 25.0 / 4.0 }
    }

    fn check(&self) -> Result<()> {
        if self.n_basis == 0 {
            return Err(Error::Parameter("n_basis must be at least 1".into()));
        }
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt < 2.0 * PI) {
            return Err(Error::Parameter(format!("dt {} must be in (0, 2π)", self.dt)));
        }
        if !(self.ay.is_finite() && self.by.is_finite()) {
            return Err(Error::Parameter("gains must be finite".into()));
        }
        Ok(())
    }

    /// Steps in one period: `⌊2π/dt⌋`.
    pub fn timesteps(&self) -> usize {
        (2.0 * PI / self.dt) as usize
    }
}

/// A learnt rhythmic DMP for `n_dofs` degrees of freedom, with its state.
#[derive(Debug, Clone, PartialEq)]
pub struct RhythmicDmp {
    config: DmpConfig,
    n_dofs: usize,
    centres: Vec<f64>,
    /// `n_dofs × n_basis`, row-major.
    weights: Vec<f64>,
    goal: Vec<f64>,
    y0: Vec<f64>,
    x: f64,
    y: Vec<f64>,
    dy: Vec<f64>,
    psi: Vec<f64>,
}

impl RhythmicDmp {
    /// Learns from one demonstration (frame-major, `T × n_dofs`), which is
    /// taken to be exactly one period.
    pub fn imitate(config: DmpConfig, demo: &[f64], n_dofs: usize) -> Result<RhythmicDmp> {
        config.check()?;
        if n_dofs == 0 || !demo.len().is_multiple_of(n_dofs) || demo.len() / n_dofs < 2 {
            return Err(Error::Demonstration(format!("{} values are not at least 2 frames of {n_dofs}", demo.len())));
        }
        if let Some(k) = demo.iter().position(|v| !v.is_finite()) {
            return Err(Error::Demonstration(format!("value {k} is not finite")));
        }
        let t_demo = demo.len() / n_dofs;
        let n = config.n_basis;
        let centres: Vec<f64> = (0..n).map(|b| 2.0 * PI * b as f64 / n as f64).collect();
        let steps = config.timesteps();
        let dt = config.dt;
        // Phase of each step, accumulated as the canonical system does.
        let mut xs = Vec::with_capacity(steps);
        let mut x = 1.0;
        for _ in 0..steps {
            xs.push(x);
            x += dt;
        }
        let spacing = 2.0 * PI / (t_demo - 1) as f64;
        let mut weights = vec![0.0; n_dofs * n];
        let mut goal = vec![0.0; n_dofs];
        let mut y0 = vec![0.0; n_dofs];
        let mut path = vec![0.0; steps];
        for d in 0..n_dofs {
            let col: Vec<f64> = demo.iter().skip(d).step_by(n_dofs).copied().collect();
            y0[d] = col[0];
            let lo = col.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = col.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            goal[d] = 0.5 * (lo + hi);
            if y0[d] == goal[d] {
                goal[d] += 1e-4;
            }
            for (t, p) in path.iter_mut().enumerate() {
                let q = t as f64 * dt;
                let j = ((q / spacing) as usize).min(t_demo - 2);
                let a = j as f64 * spacing;
                *p = col[j] + (q - a) / spacing * (col[j + 1] - col[j]);
            }
            // Forward differences with a leading zero, twice, then the target forcing term.
            let mut f_target = vec![0.0; steps];
            let mut prev_dy = 0.0;
            for t in 0..steps {
                let dy = if t == 0 { 0.0 } else { (path[t] - path[t - 1]) / dt };
                let ddy = if t == 0 { 0.0 } else { (dy - prev_dy) / dt };
                f_target[t] = ddy - config.ay * (config.by * (goal[d] - path[t]) - dy);
                prev_dy = dy;
            }
            for (b, c) in centres.iter().enumerate() {
                let (mut num, mut den) = (0.0, 0.0);
                for (x, f) in xs.iter().zip(&f_target) {
                    let psi = (n as f64 * ((x - c).cos() - 1.0)).exp();
                    num += psi * f;
                    den += psi;
                }
                weights[d * n + b] = num / (den + 1e-10);
            }
        }
        Ok(RhythmicDmp {
            config,
            n_dofs,
            centres,
            weights,
            y: y0.clone(),
            goal,
            y0,
            x: 1.0,
            dy: vec![0.0; n_dofs],
            psi: vec![0.0; n],
        })
    }

    /// Settings.
    pub fn config(&self) -> &DmpConfig {
        &self.config
    }

    /// Goal (mid-range) per degree of freedom.
    pub fn goal(&self) -> &[f64] {
        &self.goal
    }

    /// Weights, `n_dofs × n_basis`, row-major.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// Number of degrees of freedom.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Back to the start: `y = y0`, `ẏ = 0`, phase 1.
    pub fn reset(&mut self) {
        self.y.copy_from_slice(&self.y0);
        self.dy.iter_mut().for_each(|v| *v = 0.0);
        self.x = 1.0;
    }

    /// The current phase.
    pub fn phase(&self) -> f64 {
        self.x
    }

    /// Moves the phase (a perturbation of the clock, or a restart mid-cycle).
    pub fn set_phase(&mut self, x: f64) {
        self.x = x;
    }

    /// Holds the system at positions `y` with zero velocity (an outside force
    /// that grabs the limb); the phase is untouched. Values beyond
    /// [`RhythmicDmp::n_dofs`] are ignored.
    pub fn hold(&mut self, y: &[f64]) {
        for ((s, v), t) in self.y.iter_mut().zip(self.dy.iter_mut()).zip(y) {
            *s = *t;
            *v = 0.0;
        }
    }

    /// One step with tempo `tau` (> 1 is faster) and error coupling `error`
    /// (≥ 0 slows the phase down); returns the positions. Allocates nothing.
    pub fn step(&mut self, tau: f64, error: f64) -> &[f64] {
        let ec = 1.0 / (1.0 + error);
        let dt = self.config.dt;
        self.x += ec * tau * dt;
        let n = self.config.n_basis as f64;
        let mut sum = 0.0;
        for (p, c) in self.psi.iter_mut().zip(&self.centres) {
            *p = (n * ((self.x - c).cos() - 1.0)).exp();
            sum += *p;
        }
        let nb = self.config.n_basis;
        for d in 0..self.n_dofs {
            let w = &self.weights[d * nb..(d + 1) * nb];
            let f = self.psi.iter().zip(w).map(|(p, w)| p * w).sum::<f64>() / sum;
            let ddy = (self.config.ay * (self.config.by * (self.goal[d] - self.y[d]) - self.dy[d] / tau) + f) * tau;
            self.dy[d] += ddy * tau * dt * ec;
            self.y[d] += self.dy[d] * dt * ec;
        }
        &self.y
    }

    /// Resets and runs `steps` steps (default: one period at tempo `tau`,
    /// `⌊timesteps/τ⌋`); returns the positions, frame-major.
    pub fn rollout(&mut self, steps: Option<usize>, tau: f64) -> Vec<f64> {
        self.reset();
        let steps = steps.unwrap_or((self.config.timesteps() as f64 / tau) as usize);
        let mut out = Vec::with_capacity(steps * self.n_dofs);
        for _ in 0..steps {
            let y = self.step(tau, 0.0);
            out.extend_from_slice(y);
        }
        out
    }
}

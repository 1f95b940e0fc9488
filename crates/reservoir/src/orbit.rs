//! Distance of a generated window to a teacher's periodic orbit, at the best
//! phase: the validation score that does not reward damping.
//!
//! The NMSE of a free run against its teacher, step by step, charges a phase
//! slip as heavily as a lost rhythm, so under noise it prefers outputs that
//! shrink towards the mean. This score first finds the phase at which the
//! teacher's cycle fits the window best, then measures what is left:
//! amplitude, shape and period errors.
//!
//! A score is only as long-sighted as the run it scores: a readout whose
//! rhythm decays over minutes can look perfect for a few seconds. Either the
//! validation run is long compared with such a decay, or it contains a push
//! (a [`Hold`](crate::Hold)): a weakly attracting orbit recovers slowly, and
//! the scored window after the push shows it.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Below this variance (normalised units²) a teacher's channel does not move
/// (the regression's rule, so the one-step NMSE and the orbit score agree).
pub use cpg_regression::STILL_VARIANCE;

/// A stretch of a validation run that should be on one teacher's orbit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrbitStay {
    /// The step after the last scored one.
    pub end: usize,
    /// Number of steps scored, ending at `end`.
    pub window: usize,
    /// One period of the teacher, frame-major `p × D`, in normalised units.
    pub cycle: Vec<f64>,
    /// Teacher frames per generated step: 1 for the motion as recorded, `u`
    /// for the cycle played `u` times as fast.
    pub rate: f64,
}

impl OrbitStay {
    /// Frames in the teacher cycle.
    pub fn period(&self, d: usize) -> usize {
        self.cycle.len() / d.max(1)
    }

    pub(crate) fn check(&self, d: usize, steps: usize) -> Result<()> {
        let p = self.period(d);
        if d == 0 || p < 1 || self.cycle.len() != p * d || self.cycle.iter().any(|v| !v.is_finite()) {
            return Err(Error::Settings(format!(
                "an orbit stay needs a cycle (or a posture) of whole frames of {d} values"
            )));
        }
        if !(self.rate.is_finite() && self.rate > 0.0) {
            return Err(Error::Settings(format!("an orbit stay's rate {} must be > 0", self.rate)));
        }
        if self.window == 0 || self.window > self.end || self.end > steps {
            return Err(Error::Settings(format!(
                "an orbit stay scores steps {}..{}, outside the {steps}-step validation run",
                self.end.saturating_sub(self.window),
                self.end
            )));
        }
        Ok(())
    }
}

/// The cycle at a fractional frame position, by linear interpolation, wrapping.
#[inline]
fn at(cycle: &[f64], p: usize, d: usize, pos: f64, c: usize) -> f64 {
    let q = pos.rem_euclid(p as f64);
    let i0 = (q.floor() as usize).min(p - 1);
    let i1 = (i0 + 1) % p;
    let t = q - i0 as f64;
    let (a, b) = (cycle[i0 * d + c], cycle[i1 * d + c]);
    a + t * (b - a)
}

/// NMSE of `window` (`stay.window × d`, frame-major) against the teacher
/// cycle played at `stay.rate`, minimised over the start phase (searched on
/// a grid of half a teacher frame). Each channel's error is divided by its
/// variance over the cycle; the result is the mean over channels. A channel
/// that does not move in the cycle (every channel of a one-frame posture)
/// has no variance to divide by: its error counts in the signal's own
/// (normalised) units. Non-finite windows score `+∞`.
pub fn orbit_nmse(window: &[f64], stay: &OrbitStay, d: usize) -> f64 {
    let p = stay.period(d);
    let t = window.len() / d.max(1);
    if p < 1 || t == 0 || window.iter().any(|v| !v.is_finite()) {
        return f64::INFINITY;
    }
    let inv_var: Vec<f64> = (0..d)
        .map(|c| {
            let m = (0..p).map(|k| stay.cycle[k * d + c]).sum::<f64>() / p as f64;
            let v = (0..p).map(|k| (stay.cycle[k * d + c] - m).powi(2)).sum::<f64>() / p as f64;
            if v < STILL_VARIANCE { 1.0 } else { 1.0 / v }
        })
        .collect();
    let norm = (t * d) as f64;
    let mut best = f64::INFINITY;
    for s in 0..2 * p {
        let phase = s as f64 * 0.5;
        let mut e = 0.0;
        'frames: for k in 0..t {
            let pos = phase + k as f64 * stay.rate;
            for c in 0..d {
                let diff = window[k * d + c] - at(&stay.cycle, p, d, pos, c);
                e += diff * diff * inv_var[c];
            }
            if e >= best * norm {
                break 'frames;
            }
        }
        best = best.min(e / norm);
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(n: usize, period: f64, phase: f64, amp: f64) -> Vec<f64> {
        (0..n).map(|k| amp * (2.0 * std::f64::consts::PI * k as f64 / period + phase).sin()).collect()
    }

    #[test]
    fn phase_does_not_count_amplitude_does() {
        let cycle = sine(100, 100.0, 0.0, 1.0);
        let stay = OrbitStay { end: 300, window: 300, cycle: cycle.clone(), rate: 1.0 };
        assert!(orbit_nmse(&sine(300, 100.0, 1.234, 1.0), &stay, 1) < 1e-3);
        // 10 % damping costs (0.1)² of the variance.
        let damped = orbit_nmse(&sine(300, 100.0, 0.7, 0.9), &stay, 1);
        assert!((damped - 0.01).abs() < 2e-3, "{damped}");
        // A 3 % period error over three cycles does not fit any one phase.
        assert!(orbit_nmse(&sine(300, 103.0, 0.0, 1.0), &stay, 1) > 0.01);
        assert_eq!(orbit_nmse(&[f64::NAN; 300], &stay, 1), f64::INFINITY);
    }

    #[test]
    fn a_posture_is_scored_in_the_signals_own_units() {
        let stay = OrbitStay { end: 50, window: 50, cycle: vec![0.5, -1.0], rate: 1.0 };
        assert!(stay.check(2, 50).is_ok(), "one frame is a posture");
        let held: Vec<f64> = [0.5, -1.0].repeat(50);
        assert_eq!(orbit_nmse(&held, &stay, 2), 0.0);
        // 0.1 off on one of two channels: 0.01 / 2.
        let off: Vec<f64> = [0.6, -1.0].repeat(50);
        assert!((orbit_nmse(&off, &stay, 2) - 0.005).abs() < 1e-12);
        // A slow swing around the posture costs its mean square.
        let swing: Vec<f64> = (0..50).flat_map(|k| [0.5 + 0.2 * (k as f64 * 0.3).sin(), -1.0]).collect();
        assert!(orbit_nmse(&swing, &stay, 2) > 0.005);
    }

    #[test]
    fn rate_plays_the_cycle_faster() {
        let cycle = sine(120, 120.0, 0.0, 1.0);
        let stay = OrbitStay { end: 100, window: 100, cycle, rate: 4.0 };
        assert!(orbit_nmse(&sine(100, 30.0, 0.4, 1.0), &stay, 1) < 1e-3);
        assert!(orbit_nmse(&sine(100, 120.0, 0.4, 1.0), &stay, 1) > 0.5);
    }
}

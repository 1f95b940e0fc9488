//! Penalty grids and the parallel sweep.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Candidate penalties, in the order they are scored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PenaltyGrid {
    penalties: Vec<f64>,
}

impl PenaltyGrid {
    /// A grid from explicit values (each finite and >= 0).
    pub fn new(penalties: Vec<f64>) -> Result<PenaltyGrid> {
        if penalties.is_empty() {
            return Err(Error::InvalidGrid("no penalties".into()));
        }
        if let Some(&p) = penalties.iter().find(|p| !(p.is_finite() && **p >= 0.0)) {
            return Err(Error::InvalidPenalty(p));
        }
        Ok(PenaltyGrid { penalties })
    }

    /// Most values in a grid.
    pub const MAX_LEN: usize = 100_000;

    /// `10^e` for `e` from `start` down to `stop` in steps of `step` (the
    /// Matlab range `10.^(start:-step:stop)`). When `start` and `step` are
    /// decimals with at most 9 digits after the point, every exponent is
    /// computed exactly as an integer over a power of ten (`1 − 3·0.1` is
    /// `7/10`, not `0.7000000000000001`), so the same range written anywhere
    /// gives the same bits.
    pub fn log10_range(start: f64, step: f64, stop: f64) -> Result<PenaltyGrid> {
        if !(start.is_finite() && stop.is_finite() && step.is_finite() && step > 0.0 && start >= stop) {
            return Err(Error::InvalidGrid(format!("10^({start} : -{step} : {stop})")));
        }
        let n = ((start - stop) / step + 1e-9).floor() + 1.0;
        if n > Self::MAX_LEN as f64 {
            return Err(Error::InvalidGrid(format!(
                "10^({start} : -{step} : {stop}) has {n} values; at most {}",
                Self::MAX_LEN
            )));
        }
        let n = n as usize;
        let scale = (0..=9).map(|e| 10f64.powi(e)).find(|s| {
            let is_int = |v: f64| (v * s - (v * s).round()).abs() <= 1e-9 * (v * s).abs().max(1.0);
            is_int(start) && is_int(step)
        });
        let exponent = |k: usize| match scale {
            Some(s) => ((start * s).round() - k as f64 * (step * s).round()) / s,
            None => start - k as f64 * step,
        };
        PenaltyGrid::new((0..n).map(|k| 10f64.powf(exponent(k))).collect())
    }

    /// The grid of wyffels & Schrauwen (2009): `10^(1 : −0.1 : −8)`, 91 values from 10 to 1e-8.
    pub fn wyffels_2009() -> PenaltyGrid {
        PenaltyGrid { penalties: (0..=90).map(|k| 10f64.powf((10 - k) as f64 / 10.0)).collect() }
    }

    /// The penalties.
    pub fn values(&self) -> &[f64] {
        &self.penalties
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.penalties.len()
    }

    /// Whether the grid is empty (never, for a constructed grid).
    pub fn is_empty(&self) -> bool {
        self.penalties.is_empty()
    }
}

/// Scores every candidate in parallel; `score(index, penalty)`. Results come
/// back in candidate order.
pub fn sweep<S: Send>(grid: &PenaltyGrid, score: impl Fn(usize, f64) -> S + Sync) -> Vec<S> {
    grid.penalties.par_iter().enumerate().map(|(i, &p)| score(i, p)).collect()
}

/// Scores `n_items` items in contiguous chunks of at most `chunk_len`, the
/// chunks in parallel: `score(start..end)` must return one score per item of
/// its range. Results come back in item order. Batching lets a scorer advance
/// many candidates together (one matrix product per step) while the chunks
/// keep every core busy; with a deterministic scorer whose per-item result does
/// not depend on which chunk the item is in, the output does not depend on the
/// thread count or the chunk length.
///
/// # Panics
/// When `score` returns the wrong number of scores for a chunk.
pub fn sweep_chunked<S: Send>(
    n_items: usize,
    chunk_len: usize,
    score: impl Fn(std::ops::Range<usize>) -> Vec<S> + Sync,
) -> Vec<S> {
    let chunk_len = chunk_len.max(1);
    let starts: Vec<usize> = (0..n_items).step_by(chunk_len).collect();
    let parts: Vec<Vec<S>> = starts
        .par_iter()
        .map(|&s| {
            let r = s..(s + chunk_len).min(n_items);
            let len = r.len();
            let out = score(r);
            assert_eq!(out.len(), len, "scorer returned {} scores for {len} items", out.len());
            out
        })
        .collect();
    parts.into_iter().flatten().collect()
}

//! Many free runs per pass over the weights.
//!
//! A free run's cost is one product `Ŵ·x` per step. Runs whose reservoirs
//! share `Ŵ` (the recurrent weights at spectral radius 1: same size,
//! connectivity, precision and seed) advance together: one matrix-matrix
//! product per step for all of them, which keeps the multiply-add units busy
//! where a single run waits for `Ŵ` to arrive from memory. What else differs
//! between the runs is free: the readout, spectral radius, leak rate,
//! feedback and input scaling, biases, start state, controls, pushes and
//! noise. So the seeds' noise draws, the control settings, a pushed run and
//! its unperturbed twin, and tuning candidates that differ only in such
//! scalars cost one pass over `Ŵ` per step between them.
//!
//! Each run's outputs are bit-identical to a [`Generator`](crate::Generator)
//! stepping the same model with the same controls, hold and noise, whatever
//! the other runs, their number, their order and the thread count.

use rayon::prelude::*;

use crate::config::Precision;
use crate::engine::{
    Column, ControlSource, Dynamics, Hold, NoiseSource, Observer, ReadoutR, Shared, run_columns, run_split,
};
use crate::error::{Error, Result};
use crate::kernel::SimdDot;
use crate::model::TrainedCpg;

pub use crate::controls::Controls;

/// One free run from a model's start state.
#[derive(Clone, Copy)]
pub struct Run<'a> {
    /// The model.
    pub model: &'a TrainedCpg,
    /// Its control values over time (as many as the model has control inputs).
    pub controls: &'a dyn Controls,
    /// Steps to run.
    pub steps: usize,
    /// Fed-back outputs held at the given normalised values for a while (a
    /// push), as [`Generator::step_clamped`](crate::Generator::step_clamped) does.
    pub hold: Option<&'a Hold>,
    /// Gaussian state noise (variance, seed) after every update, as
    /// [`Generator::set_state_noise`](crate::Generator::set_state_noise) adds it.
    pub noise: Option<(f64, u64)>,
}

impl<'a> Run<'a> {
    /// `steps` steps of `model` under `controls`, no push, no noise.
    pub fn new(model: &'a TrainedCpg, controls: &'a dyn Controls, steps: usize) -> Run<'a> {
        Run { model, controls, steps, hold: None, noise: None }
    }

    fn check(&self) -> Result<()> {
        let d = self.model.outputs.len();
        if let Some(h) = self.hold
            && (h.values.len() != d || h.values.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::Shape(format!("a hold needs {d} finite values")));
        }
        if let Some((v, _)) = self.noise
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(Error::Settings(format!("noise variance {v} must be >= 0")));
        }
        Ok(())
    }
}

/// Runs every run and returns each one's outputs in normalised units
/// (`steps × D`, what [`Generator::normalised_output`](crate::Generator::normalised_output)
/// gives), or [`Error::Diverged`] for a run whose output stopped being finite.
///
/// Runs that share `Ŵ` go into one batch; a batch's runs are split into
/// `threads` contiguous parts that run in parallel (each part streams `Ŵ`
/// through its own core's caches). A batch of one long noise-free run is
/// split by rows instead, and so are the long noise-free runs of a batch of
/// fewer than four: two threads each compute half of every step and
/// exchange their halves of the state. Outputs do not depend on `threads`.
pub fn free_runs(runs: &[Run<'_>], threads: usize) -> Vec<Result<Vec<f64>>> {
    let mut out: Vec<Result<Vec<f64>>> = runs.iter().map(|r| r.check().map(|()| Vec::new())).collect();
    // Group by shared Ŵ, in order of first appearance.
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (i, r) in runs.iter().enumerate() {
        if out[i].is_err() {
            continue;
        }
        let res = &r.model.reservoir;
        match groups.iter_mut().find(|g| {
            let other = &runs[g[0]].model.reservoir;
            std::ptr::eq(other, res) || other.shares_w_with(res)
        }) {
            Some(g) => g.push(i),
            None => groups.push(vec![i]),
        }
    }
    for g in groups {
        let members: Vec<Run<'_>> = g.iter().map(|&i| runs[i]).collect();
        let results = match members[0].model.reservoir.config().precision {
            Precision::F32 => batch::<f32>(&members, threads),
            Precision::F64 => batch::<f64>(&members, threads),
        };
        for (i, r) in g.into_iter().zip(results) {
            out[i] = r;
        }
    }
    out
}

/// Writes a column's outputs as `f64` and stops it when they are not finite.
struct Recorder<'a> {
    out: &'a mut [f64],
    d: usize,
    diverged: Option<usize>,
}

impl<R: SimdDot> Observer<R> for Recorder<'_> {
    fn see(&mut self, step: usize, y: &[R]) -> bool {
        let dst = &mut self.out[step * self.d..(step + 1) * self.d];
        for (o, v) in dst.iter_mut().zip(y) {
            *o = v.to_f64();
        }
        if dst.iter().all(|v| v.is_finite()) {
            true
        } else {
            self.diverged = Some(step);
            false
        }
    }
}

fn batch<R: SimdDot>(runs: &[Run<'_>], threads: usize) -> Vec<Result<Vec<f64>>> {
    let shared = Shared::<R>::new(&runs[0].model.reservoir);
    // One dynamics and readout per distinct model.
    let mut models: Vec<&TrainedCpg> = Vec::new();
    let index: Vec<usize> = runs
        .iter()
        .map(|r| match models.iter().position(|m| std::ptr::eq(*m, r.model)) {
            Some(k) => k,
            None => {
                models.push(r.model);
                models.len() - 1
            }
        })
        .collect();
    let parts: Vec<(Dynamics<R>, ReadoutR<R>, Vec<R>)> = models
        .iter()
        .map(|m| {
            let x0 = m.start_state.iter().map(|&v| R::from_f64(v)).collect();
            (Dynamics::new(&m.reservoir), ReadoutR::new(&m.readout), x0)
        })
        .collect();
    let columns: Vec<Column<'_, R>> = runs
        .iter()
        .zip(&index)
        .map(|(r, &k)| Column {
            dynamics: &parts[k].0,
            readout: &parts[k].1,
            x0: &parts[k].2,
            noise: match r.noise {
                Some((v, seed)) if v > 0.0 => NoiseSource::Drawn { seed, sigma: v.sqrt() },
                _ => NoiseSource::Off,
            },
            controls: ControlSource::Fn(r.controls),
            holds: r.hold.map(std::slice::from_ref).unwrap_or(&[]),
        })
        .collect();
    let d = shared.d;
    let mut outputs: Vec<Vec<f64>> = runs.iter().map(|r| vec![0.0; r.steps * d]).collect();
    let mut recorders: Vec<Recorder<'_>> =
        outputs.iter_mut().map(|o| Recorder { out: o.as_mut_slice(), d, diverged: None }).collect();
    // Columns of different lengths run to the longest; each records only its own steps.
    let mut bounded: Vec<Bounded<'_, '_>> =
        recorders.iter_mut().zip(runs).map(|(rec, r)| Bounded { rec, steps: r.steps }).collect();
    // Fewer than four runs are too few to keep both cores busy with columns
    // of their own: long noise-free ones go faster split by rows over two
    // cores, all of them in one pass over Ŵ per step.
    let split: Vec<bool> = columns
        .iter()
        .zip(runs)
        .map(|(c, r)| {
            threads >= 2 && columns.len() < 4 && matches!(c.noise, NoiseSource::Off) && split_pays(shared.n, r.steps)
        })
        .collect();
    let mut split_cols = Vec::new();
    let mut split_obs = Vec::new();
    let mut rest_cols = Vec::new();
    let mut rest_obs = Vec::new();
    for ((col, obs), sp) in columns.iter().zip(bounded.iter_mut()).zip(&split) {
        if *sp {
            split_cols.push(*col);
            split_obs.push(obs);
        } else {
            rest_cols.push(*col);
            rest_obs.push(obs);
        }
    }
    if !split_cols.is_empty() {
        let s = split_obs.iter().map(|o| o.steps).max().unwrap_or(0);
        run_split(&shared, &split_cols, &mut split_obs, s);
    }
    let per = rest_cols.len().div_ceil(threads.max(1)).max(1);
    let parts: Vec<(&[Column<'_, R>], &mut [&mut Bounded<'_, '_>])> =
        rest_cols.chunks(per).zip(rest_obs.chunks_mut(per)).collect();
    let run = |(cols, obs): (&[Column<'_, R>], &mut [&mut Bounded<'_, '_>])| {
        let s = obs.iter().map(|o| o.steps).max().unwrap_or(0);
        run_columns(&shared, cols, obs, s)
    };
    if parts.len() > 1 {
        parts.into_par_iter().for_each(run);
    } else {
        parts.into_iter().for_each(run);
    }
    drop(bounded);
    if crate::watch::requested() {
        return runs.iter().map(|_| Err(Error::Cancelled)).collect();
    }
    let diverged: Vec<Option<usize>> = recorders.iter().map(|r| r.diverged).collect();
    outputs
        .into_iter()
        .zip(diverged)
        .map(|(o, dv)| match dv {
            Some(step) => Err(Error::Diverged { what: "output", step: step as u64 }),
            None => Ok(o),
        })
        .collect()
}

/// Whether one run is worth splitting over two cores: the exchange after
/// every step costs about as much as a product of 100 neurons.
pub(crate) fn split_pays(n: usize, steps: usize) -> bool {
    n >= 200 && steps >= 1000
}

/// A recorder that stops its column after its own number of steps.
struct Bounded<'a, 'b> {
    rec: &'a mut Recorder<'b>,
    steps: usize,
}

impl<R: SimdDot> Observer<R> for Bounded<'_, '_> {
    fn see(&mut self, step: usize, y: &[R]) -> bool {
        step < self.steps && self.rec.see(step, y) && step + 1 < self.steps
    }
}

impl<R: SimdDot> Observer<R> for &mut Bounded<'_, '_> {
    fn see(&mut self, step: usize, y: &[R]) -> bool {
        (**self).see(step, y)
    }
}

//! FORCE learning (Sussillo & Abbott 2009, Neuron 63:544): the readout
//! learnt online by recursive least squares while the reservoir runs on its
//! own fed-back output, beside the batch ridge readout of [`train`](crate::train).
//!
//! From the zero state the teacher is fed back for `washout` steps (no
//! learning; again at the start of every further pass, so that the state
//! meets the sequence where it starts). Then at each step the network's own output is fed back, the
//! state advances, and every `every` steps the readout `w` (with a bias) is
//! corrected towards the next teacher sample by one RLS step on the inverse
//! correlation estimate `P`, which starts at `I / α`:
//!
//! ```text
//! r = [x; 1],  k = P r / (1 + rᵀ P r),  P ← P − k (P r)ᵀ,  w ← w − (w r − target) kᵀ
//! ```
//!
//! `α` plays the part of the ridge penalty: a grid of them gives candidate
//! readouts, validated and chosen exactly as the ridge penalties are.

use cpg_regression::Readout;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use serde::{Deserialize, Serialize};

use crate::config::Precision;
use crate::engine::Engine;
use crate::error::{Error, Result};
use crate::kernel::SimdDot;
use crate::reservoir::Reservoir;
use crate::train::{Candidate, Sequence, TrainSettings, Training, TrainingData, check_washout, choose, validate_in};

/// How FORCE learns (a configuration's `[training.force]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ForceSettings {
    /// RLS corrections every this many steps (1: every step).
    pub every: usize,
    /// Passes over the training sequence (the readout and `P` carry over; each
    /// pass starts with the teacher fed back through the washout).
    pub passes: usize,
}

impl Default for ForceSettings {
    fn default() -> Self {
        ForceSettings { every: 2, passes: 1 }
    }
}

/// Trains the readout of `reservoir` by FORCE, one candidate per value of
/// `settings.penalties` taken as `α` (`P` starts at `I / α`), each validated
/// as [`train_on`](crate::train_on) validates the ridge candidates, the
/// chosen one by the same rule. The bits do not depend on `threads`.
pub fn train_force_on(
    reservoir: &Reservoir,
    data: &TrainingData,
    settings: &TrainSettings,
    force: &ForceSettings,
    threads: usize,
) -> Result<Training> {
    match reservoir.config().precision {
        Precision::F32 => force_in::<f32>(reservoir, data, settings, force, threads),
        Precision::F64 => force_in::<f64>(reservoir, data, settings, force, threads),
    }
}

fn force_in<R: SimdDot>(
    reservoir: &Reservoir,
    data: &TrainingData,
    settings: &TrainSettings,
    force: &ForceSettings,
    threads: usize,
) -> Result<Training> {
    let engine = Engine::<R>::new(reservoir);
    settings.check_noise()?;
    if force.every == 0 || force.passes == 0 || force.passes > 100 {
        return Err(Error::Settings(format!(
            "FORCE needs every >= 1 and 1 to 100 passes (every {}, passes {})",
            force.every, force.passes
        )));
    }
    let alphas = settings.penalties.values();
    if let Some(a) = alphas.iter().find(|a| !(a.is_finite() && **a > 0.0)) {
        return Err(Error::Settings(format!("FORCE's α {a} must be positive")));
    }
    let mut candidates = Vec::with_capacity(alphas.len());
    let mut train_nmse = Vec::with_capacity(alphas.len());
    for &alpha in alphas {
        let (readout, e) = learn(&engine, &data.train, settings.washout, alpha, force)?;
        candidates.push(Candidate { penalty: alpha, readout });
        train_nmse.push(e);
    }
    let (curve, x0) = validate_in(&engine, &candidates, data, settings, threads)?;
    let chosen = choose(&curve, settings)?;
    let nmse = train_nmse[chosen];
    let Candidate { penalty, readout } =
        candidates.into_iter().nth(chosen).ok_or(Error::Settings("no candidate α".into()))?;
    Ok(Training { readout, penalty, curve, start_state: x0, train_nmse: nmse })
}

/// One FORCE run with `P(0) = I / alpha`: the readout it ends with and the
/// NMSE of its outputs (before each correction) over the last pass (a
/// channel that never moves counted in its own units, as ridge's is).
fn learn<R: SimdDot>(
    engine: &Engine<R>,
    seq: &Sequence,
    washout: usize,
    alpha: f64,
    force: &ForceSettings,
) -> Result<(Readout, f64)> {
    let (n, np, d, u) = (engine.shared.n, engine.shared.np, engine.shared.d, engine.shared.u);
    let t = seq.check("training sequence", d, u)?;
    check_washout(washout, t)?;
    let f = n + 1;
    let mut p = Mat::<f64>::zeros(f, f);
    for i in 0..f {
        p[(i, i)] = 1.0 / alpha;
    }
    let mut w = Mat::<f64>::zeros(d, f);
    let mut r = Mat::<f64>::zeros(f, 1);
    let mut pr = Mat::<f64>::zeros(f, 1);
    let mut x = vec![R::ZERO; np];
    let mut z = seq.outputs[..d].to_vec();
    let mut fed = vec![0.0; d];
    // The last pass's outputs before each correction, and their targets.
    let (mut said, mut meant) = (Vec::new(), Vec::new());
    let watch = crate::watch::current();
    for pass in 0..force.passes {
        let last = pass + 1 == force.passes;
        for k in 0..t - 1 {
            if crate::watch::stop_at(&watch, k, 1) {
                return Err(Error::Cancelled);
            }
            // The fed-back output: the teacher through the first washout, the network's own after it.
            fed.copy_from_slice(if k < washout { &seq.outputs[k * d..(k + 1) * d] } else { &z });
            engine.teacher_force(&mut x, &fed, &seq.controls[k * u..(k + 1) * u], |_, _| {});
            for (i, v) in x[..n].iter().enumerate() {
                r[(i, 0)] = v.to_f64();
            }
            r[(n, 0)] = 1.0;
            let target = &seq.outputs[(k + 1) * d..(k + 2) * d];
            for (c, zc) in z.iter_mut().enumerate() {
                *zc = (0..f).map(|i| w[(c, i)] * r[(i, 0)]).sum();
            }
            if k < washout {
                continue;
            }
            if last {
                said.extend_from_slice(&z);
                meant.extend_from_slice(target);
            }
            if k % force.every != 0 {
                continue;
            }
            matmul(pr.as_mut(), Accum::Replace, p.as_ref(), r.as_ref(), 1.0, Par::Seq);
            let rpr: f64 = (0..f).map(|i| r[(i, 0)] * pr[(i, 0)]).sum();
            let c = 1.0 / (1.0 + rpr);
            matmul(p.as_mut(), Accum::Add, pr.as_ref(), pr.transpose(), -c, Par::Seq);
            for (ci, zc) in z.iter_mut().enumerate() {
                let e = *zc - target[ci];
                for i in 0..f {
                    w[(ci, i)] -= c * e * pr[(i, 0)];
                }
                // The corrected output is what is fed back next.
                *zc = (0..f).map(|i| w[(ci, i)] * r[(i, 0)]).sum();
            }
            if z.iter().any(|v| !v.is_finite()) {
                return Err(Error::Diverged { what: "FORCE's output", step: k as u64 });
            }
        }
    }
    let nmse = if said.is_empty() { f64::NAN } else { cpg_regression::nmse(&said, &meant, d) };
    let weights = (0..d).flat_map(|c| (0..n).map(move |i| (c, i))).map(|(c, i)| w[(c, i)]).collect();
    let bias = (0..d).map(|c| w[(c, n)]).collect();
    Ok((Readout { n_features: n, weights, bias }, nmse))
}

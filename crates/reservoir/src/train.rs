//! Training a CPG: teacher-forced harvesting, ridge regression for every
//! penalty, validation of every candidate in noisy free run, choice of the best.

use cpg_regression::{PenaltyGrid, Readout, RidgePath, nmse, sweep, sweep_chunked};
use faer::Mat;
use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::config::Precision;
use crate::engine::{Engine, ReadoutR};
use crate::error::{Error, Result};
use crate::kernel::SimdDot;
use crate::reservoir::{Reservoir, rng};

/// Signals over time: outputs (`T × D`) and control inputs (`T × U`), frame-major.
/// Outputs are in the units the network sees (normally z-scored).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Sequence {
    /// `T × D` output values.
    pub outputs: Vec<f64>,
    /// `T × U` control values (empty when U = 0).
    pub controls: Vec<f64>,
}

impl Sequence {
    /// A sequence with no control inputs.
    pub fn outputs_only(outputs: Vec<f64>) -> Sequence {
        Sequence { outputs, controls: Vec::new() }
    }

    /// Number of samples, given D.
    pub fn len(&self, n_outputs: usize) -> usize {
        self.outputs.len() / n_outputs.max(1)
    }

    fn check(&self, what: &'static str, d: usize, u: usize) -> Result<usize> {
        if d == 0 || !self.outputs.len().is_multiple_of(d) {
            return Err(Error::Shape(format!("{what}: {} output values do not form rows of {d}", self.outputs.len())));
        }
        let t = self.outputs.len() / d;
        if self.controls.len() != t * u {
            return Err(Error::Shape(format!(
                "{what}: {} control values, expected {t} samples × {u} inputs = {}",
                self.controls.len(),
                t * u
            )));
        }
        for (vals, cols) in [(&self.outputs, d), (&self.controls, u)] {
            if let Some(k) = vals.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFiniteInput { what, sample: k / cols, column: k % cols });
            }
        }
        Ok(t)
    }
}

/// Data for training and validation.
///
/// The readout is trained on the states harvested while `train` is fed by
/// teacher forcing (after discarding `washout` steps). Each candidate readout
/// is validated by teacher-forcing `warmup` from the zero state and then
/// running freely, with state noise, over `validation`, whose outputs are the
/// targets and whose controls drive the network. For a periodic signal,
/// `warmup` is the training sequence and `validation` its continuation; the
/// state at the end of `warmup` is also where generation starts.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingData {
    /// Teacher-forced training sequence.
    pub train: Sequence,
    /// Teacher-forced warm-up before the validation free run.
    pub warmup: Sequence,
    /// Targets and controls of the validation free run.
    pub validation: Sequence,
}

/// How to train.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainSettings {
    /// Initial teacher-forced steps whose states are discarded.
    pub washout: usize,
    /// Candidate ridge penalties.
    pub penalties: PenaltyGrid,
    /// Variance of the Gaussian noise added to every state during validation (paper: 0.001).
    pub noise_variance: f64,
    /// Noise realisations each candidate is validated with; the same ones for every candidate.
    pub n_noise_draws: usize,
    /// Seed of the validation noise.
    pub noise_seed: u64,
}

impl TrainSettings {
    /// The paper's validation: the 91-value grid, noise variance 0.001; we add
    /// a washout of 200 steps and average 5 noise draws (one draw makes the
    /// validation curve jump between neighbouring penalties).
    pub fn wyffels_schrauwen_2009() -> TrainSettings {
        TrainSettings {
            washout: 200,
            penalties: PenaltyGrid::wyffels_2009(),
            noise_variance: 1e-3,
            n_noise_draws: 5,
            noise_seed: 1,
        }
    }

    /// The validation-noise settings are usable. (The washout is checked by
    /// [`harvest`], which knows the sequence length.)
    fn check_noise(&self) -> Result<()> {
        if !(self.noise_variance.is_finite() && self.noise_variance >= 0.0) {
            return Err(Error::Settings(format!("noise variance {} must be >= 0", self.noise_variance)));
        }
        if self.n_noise_draws == 0 {
            return Err(Error::Settings("at least one noise draw is needed".into()));
        }
        Ok(())
    }
}

/// One candidate penalty and how it validated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationPoint {
    /// The ridge penalty.
    pub penalty: f64,
    /// Free-run NMSE averaged over the noise draws (infinite if the run diverged).
    pub nmse: f64,
    /// Free-run NMSE of each draw.
    pub nmse_per_draw: Vec<f64>,
}

/// The outcome of training: the readout and how it was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct Training {
    /// The chosen readout.
    pub readout: Readout,
    /// Index of the chosen penalty in the grid.
    pub chosen: usize,
    /// Every candidate, in grid order.
    pub curve: Vec<ValidationPoint>,
    /// State after the warm-up: where generation starts.
    pub start_state: Vec<f64>,
    /// One-step (teacher-forced) NMSE of the chosen readout on the training states.
    pub train_nmse: f64,
}

/// Runs `seq` through the reservoir by teacher forcing from the state `x0`
/// (length N) and returns the state after each sample, frame-major (`T × N`).
pub fn teacher_forced_states(reservoir: &Reservoir, x0: &[f64], seq: &Sequence) -> Result<Vec<f64>> {
    match reservoir.config().precision {
        Precision::F32 => states_in::<f32>(reservoir, x0, seq),
        Precision::F64 => states_in::<f64>(reservoir, x0, seq),
    }
}

fn states_in<R: SimdDot>(reservoir: &Reservoir, x0: &[f64], seq: &Sequence) -> Result<Vec<f64>> {
    let engine = Engine::<R>::new(reservoir);
    let t = seq.check("sequence", engine.d, engine.u)?;
    if x0.len() != engine.n {
        return Err(Error::Shape(format!(
            "start state has {} values, the reservoir has {} neurons",
            x0.len(),
            engine.n
        )));
    }
    let mut x: Vec<R> = x0.iter().map(|&v| R::from_f64(v)).collect();
    let mut out = Vec::with_capacity(t * engine.n);
    engine.teacher_force(&mut x, &seq.outputs, &seq.controls, |_, s| out.extend(s.iter().map(|v| v.to_f64())));
    Ok(out)
}

/// Trains the readout of `reservoir` on `data`: harvest, all penalties from
/// one factorisation, each validated in noisy free run, the best chosen
/// (ties go to the larger penalty). With the same reservoir, data and settings
/// the result is identical whatever the number of threads.
pub fn train(reservoir: &Reservoir, data: &TrainingData, settings: &TrainSettings) -> Result<Training> {
    match reservoir.config().precision {
        Precision::F32 => train_in::<f32>(reservoir, data, settings),
        Precision::F64 => train_in::<f64>(reservoir, data, settings),
    }
}

/// Teacher-forced states and their targets, washout removed: row `i` of
/// `states` (the state after feeding sample `washout + i`) should predict row
/// `i` of `targets` (sample `washout + i + 1`).
#[derive(Debug, Clone)]
pub struct Harvest {
    /// `rows × N` states.
    pub states: Mat<f64>,
    /// `rows × D` targets.
    pub targets: Mat<f64>,
}

/// Harvests the training states of `seq` by teacher forcing from the zero state.
pub fn harvest(reservoir: &Reservoir, seq: &Sequence, washout: usize) -> Result<Harvest> {
    match reservoir.config().precision {
        Precision::F32 => harvest_in::<f32>(&Engine::new(reservoir), seq, washout),
        Precision::F64 => harvest_in::<f64>(&Engine::new(reservoir), seq, washout),
    }
}

fn harvest_in<R: SimdDot>(engine: &Engine<R>, seq: &Sequence, washout: usize) -> Result<Harvest> {
    let (n, d, u) = (engine.n, engine.d, engine.u);
    let t = seq.check("training sequence", d, u)?;
    if washout + 2 > t {
        return Err(Error::Settings(format!(
            "washout of {washout} steps leaves fewer than 2 of the {t} training samples"
        )));
    }
    let rows = t - 1 - washout;
    let mut states = Mat::<f64>::zeros(rows, n);
    let mut x = vec![R::ZERO; n];
    engine.teacher_force(&mut x, &seq.outputs[..(t - 1) * d], &seq.controls[..(t - 1) * u], |k, s| {
        if k >= washout {
            for (j, v) in s.iter().enumerate() {
                states[(k - washout, j)] = v.to_f64();
            }
        }
    });
    let targets = Mat::from_fn(rows, d, |i, j| seq.outputs[(i + washout + 1) * d + j]);
    Ok(Harvest { states, targets })
}

/// Scores candidate readouts: each runs freely from the state reached by
/// teacher-forcing `warmup`, with the settings' state noise, over
/// `validation`; the score is the NMSE against `validation.outputs`,
/// averaged over the noise draws (the same draws for every candidate). All
/// candidates and draws advance together in batches spread over the cores.
/// Returns the scores in candidate order and the start state.
pub fn validate(
    reservoir: &Reservoir,
    readouts: &[Readout],
    warmup: &Sequence,
    validation: &Sequence,
    settings: &TrainSettings,
) -> Result<(Vec<ValidationPoint>, Vec<f64>)> {
    match reservoir.config().precision {
        Precision::F32 => validate_in::<f32>(&Engine::new(reservoir), readouts, warmup, validation, settings),
        Precision::F64 => validate_in::<f64>(&Engine::new(reservoir), readouts, warmup, validation, settings),
    }
}

fn validate_in<R: SimdDot>(
    engine: &Engine<R>,
    readouts: &[Readout],
    warmup: &Sequence,
    validation: &Sequence,
    settings: &TrainSettings,
) -> Result<(Vec<ValidationPoint>, Vec<f64>)> {
    let (n, d, u) = (engine.n, engine.d, engine.u);
    warmup.check("warm-up sequence", d, u)?;
    let steps = validation.check("validation sequence", d, u)?;
    if steps == 0 {
        return Err(Error::Settings("the validation sequence is empty".into()));
    }
    if let Some(r) = readouts.iter().find(|r| r.n_features != n || r.bias.len() != d || r.weights.len() != n * d) {
        return Err(Error::Shape(format!(
            "a readout is {}×{}, the reservoir needs {d}×{n}",
            r.bias.len(),
            r.n_features
        )));
    }
    settings.check_noise()?;
    let readouts_r: Vec<ReadoutR<R>> = readouts.iter().map(ReadoutR::new).collect();
    let mut x0 = vec![R::ZERO; n];
    engine.teacher_force(&mut x0, &warmup.outputs, &warmup.controls, |_, _| {});

    // Common random numbers: draw r is the same sequence for every candidate.
    let sigma = settings.noise_variance.sqrt();
    let noises: Vec<Vec<R>> = (0..settings.n_noise_draws)
        .map(|r| {
            let mut g = rng(settings.noise_seed, 1_000 + r as u64);
            (0..steps * n).map(|_| R::from_f64(sigma * g.sample::<f64, _>(StandardNormal))).collect()
        })
        .collect();
    let var: Vec<f64> = (0..d)
        .map(|j| {
            let col: Vec<f64> = validation.outputs.iter().skip(j).step_by(d).copied().collect();
            let m = col.iter().sum::<f64>() / steps as f64;
            (col.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / steps as f64).max(f64::MIN_POSITIVE)
        })
        .collect();
    let draws = settings.n_noise_draws;
    let n_cols = readouts.len() * draws;
    let chunk = n_cols.div_ceil(rayon::current_num_threads()).div_ceil(4) * 4;
    let column_nmse: Vec<f64> = sweep_chunked(n_cols, chunk, |cols| {
        let rs: Vec<&ReadoutR<R>> = cols.clone().map(|c| &readouts_r[c / draws]).collect();
        let zs: Vec<Option<&[R]>> = cols.clone().map(|c| (sigma > 0.0).then(|| noises[c % draws].as_slice())).collect();
        engine
            .free_run_batch(&x0, &rs, &zs, &validation.outputs, &validation.controls)
            .into_iter()
            .map(|sse| sse.iter().zip(&var).map(|(e, v)| e / (steps as f64 * v)).sum::<f64>() / d as f64)
            .collect()
    });
    let curve = readouts
        .iter()
        .enumerate()
        .map(|(i, _)| {
            let per: Vec<f64> = column_nmse[i * draws..(i + 1) * draws].to_vec();
            let nmse =
                if per.iter().all(|v| v.is_finite()) { per.iter().sum::<f64>() / draws as f64 } else { f64::INFINITY };
            ValidationPoint { penalty: f64::NAN, nmse, nmse_per_draw: per }
        })
        .collect();
    Ok((curve, x0.iter().map(|v| v.to_f64()).collect()))
}

fn train_in<R: SimdDot>(reservoir: &Reservoir, data: &TrainingData, settings: &TrainSettings) -> Result<Training> {
    let engine = Engine::<R>::new(reservoir);
    // Settings first: the harvest and the factorisation are the expensive part.
    settings.check_noise()?;
    let Harvest { states, targets } = harvest_in(&engine, &data.train, settings.washout)?;
    let (rows, n, d) = (states.nrows(), engine.n, engine.d);
    let path = RidgePath::new(states.as_ref(), targets.as_ref())?;
    let grid = &settings.penalties;
    let readouts: Vec<Readout> = sweep(grid, |_, p| path.solve(p)).into_iter().collect::<Result<_, _>>()?;
    let (mut curve, x0) = validate_in(&engine, &readouts, &data.warmup, &data.validation, settings)?;
    for (p, &penalty) in curve.iter_mut().zip(grid.values()) {
        p.penalty = penalty;
    }
    let chosen = (0..curve.len()).fold(0, |best, i| if curve[i].nmse < curve[best].nmse { i } else { best });
    if !curve[chosen].nmse.is_finite() {
        return Err(Error::Settings("every candidate penalty diverged in validation".into()));
    }
    let readout = readouts[chosen].clone();
    let mut pred = vec![0.0; rows * d];
    let mut row = vec![0.0; n];
    for (i, out) in pred.chunks_exact_mut(d).enumerate() {
        for (j, r) in row.iter_mut().enumerate() {
            *r = states[(i, j)];
        }
        readout.apply(&row, out);
    }
    let target: Vec<f64> = (0..rows).flat_map(|i| (0..d).map(move |j| (i, j))).map(|(i, j)| targets[(i, j)]).collect();
    let train_nmse = nmse(&pred, &target, d);
    Ok(Training { readout, chosen, curve, start_state: x0, train_nmse })
}

//! Training a CPG: teacher-forced harvesting, ridge regression for every
//! penalty, validation of every candidate in noisy free run, choice of the best.

use cpg_regression::{PenaltyGrid, Readout, RidgePath, nmse, sweep, sweep_chunked};
use faer::Mat;
use rand::RngExt;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::config::Precision;
use crate::engine::{Column, ControlSource, Engine, Hold, NoiseSource, ReadoutR, Shared, run_columns};
use crate::error::{Error, Result};
use crate::kernel::SimdDot;
use crate::orbit::{OrbitStay, orbit_nmse};
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

    pub(crate) fn check(&self, what: &'static str, d: usize, u: usize) -> Result<usize> {
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
    /// How each candidate's validation free run is scored, and the pushes it receives.
    pub scoring: Scoring,
}

impl TrainingData {
    /// Data scored the paper's way: NMSE against `validation.outputs`, no pushes.
    pub fn nmse(train: Sequence, warmup: Sequence, validation: Sequence) -> TrainingData {
        TrainingData { train, warmup, validation, scoring: Scoring::default() }
    }
}

/// What makes a validation free run good.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum Score {
    /// The paper's: mean squared error against the validation targets, divided
    /// by their variance, averaged over the outputs (NMSE), step by step.
    #[default]
    Nmse,
    /// Distance to the teacher's orbit: for each stay, the NMSE of its last
    /// frames against the teacher cycle at the best phase (see
    /// [`orbit_nmse`](crate::orbit_nmse)), averaged over the stays. Phase
    /// slips cost nothing; damping, distortion and period errors do.
    Orbit(Vec<OrbitStay>),
}

/// The score of the validation free run, and the pushes applied during it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Scoring {
    /// The score.
    pub score: Score,
    /// Outputs held during the validation run (normalised units).
    pub holds: Vec<Hold>,
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
    /// Standard deviation of Gaussian noise added to the fed-back teacher
    /// while the training states are harvested (0: none). The targets stay
    /// clean, so the readout learns to steer states near the orbit back onto
    /// it (Jaeger's trick for stable output feedback). Seeded by `noise_seed`.
    #[serde(default)]
    pub teacher_noise: f64,
    /// Choose the largest penalty whose score is at most `(1 + this) ×` the
    /// best score, rather than the best itself (0: the best; ties go to the
    /// larger penalty). Like the one-standard-error rule of cross-validation,
    /// it prefers the more regularised readout when it is nearly as good:
    /// small penalties next to the grid's divergent end are fragile.
    #[serde(default)]
    pub prefer_larger_within: f64,
    /// Rounds of training on the network's own output ([`SelfFed`]; none by default).
    #[serde(default)]
    pub self_fed: SelfFed,
}

/// Training on the network's own output, after the "data as demonstrator"
/// of Venkatraman, Hebert & Bagnell (2015): once a readout is chosen, the
/// training sequence is run again with stretches of `free_steps` in which
/// the network is fed its own output, each after `forced_steps` of teacher
/// forcing that bring it back to the teacher (both fed with the teacher
/// noise). The states of the free stretches, paired with the teacher's next
/// samples, are added to the harvest, so the readout also learns to correct
/// the errors it makes itself, which teacher noise only imitates; every
/// penalty is solved again and validated, and the round repeats `rounds`
/// times. A free stretch ends early when an output strays more than
/// [`SelfFed::MAX_STRAY`] from the teacher.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SelfFed {
    /// Rounds (0: off).
    pub rounds: usize,
    /// Steps of each free stretch.
    pub free_steps: usize,
    /// Steps of teacher forcing before each free stretch.
    pub forced_steps: usize,
}

impl SelfFed {
    /// How far (normalised units) an output may stray from the teacher before
    /// its free stretch ends: beyond it the state leaves what the readout can
    /// be taught to bring back in one step.
    pub const MAX_STRAY: f64 = 1.0;

    fn check(&self) -> Result<()> {
        if self.rounds > 10 || (self.rounds > 0 && (self.free_steps == 0 || self.forced_steps == 0)) {
            return Err(Error::Settings(format!(
                "training on the own output needs 0 to 10 rounds, each with free and forced steps of at least 1 (rounds {}, free {}, forced {})",
                self.rounds, self.free_steps, self.forced_steps
            )));
        }
        Ok(())
    }
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
            teacher_noise: 0.0,
            prefer_larger_within: 0.0,
            self_fed: SelfFed::default(),
        }
    }

    /// The validation-noise settings are usable. (The washout is checked by
    /// [`harvest`], which knows the sequence length.)
    pub(crate) fn check_noise(&self) -> Result<()> {
        if !(self.noise_variance.is_finite() && self.noise_variance >= 0.0) {
            return Err(Error::Settings(format!("noise variance {} must be >= 0", self.noise_variance)));
        }
        if self.n_noise_draws == 0 {
            return Err(Error::Settings("at least one noise draw is needed".into()));
        }
        if !(self.teacher_noise.is_finite() && self.teacher_noise >= 0.0) {
            return Err(Error::Settings(format!("teacher noise {} must be >= 0", self.teacher_noise)));
        }
        if !(self.prefer_larger_within.is_finite() && self.prefer_larger_within >= 0.0) {
            return Err(Error::Settings(format!("prefer_larger_within {} must be >= 0", self.prefer_larger_within)));
        }
        self.self_fed.check()
    }
}

/// A readout and the penalty it was solved with.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The ridge penalty.
    pub penalty: f64,
    /// The readout.
    pub readout: Readout,
}

/// One candidate penalty and how it validated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidationPoint {
    /// The ridge penalty.
    pub penalty: f64,
    /// The validation score averaged over the noise draws (infinite if a run
    /// diverged): the free-run NMSE, or the orbit score (see [`Score`]).
    pub nmse: f64,
    /// The score of each draw.
    pub nmse_per_draw: Vec<f64>,
}

/// The outcome of training: the readout and how it was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct Training {
    /// The chosen readout.
    pub readout: Readout,
    /// The penalty it was solved with.
    pub penalty: f64,
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
    let (n, d, u) = (engine.shared.n, engine.shared.d, engine.shared.u);
    let t = seq.check("sequence", d, u)?;
    if x0.len() != n {
        return Err(Error::Shape(format!("start state has {} values, the reservoir has {n} neurons", x0.len())));
    }
    let mut x = engine.state(x0);
    let x = x.as_mut_slice();
    let mut out = Vec::with_capacity(t * n);
    engine.teacher_force(x, &seq.outputs, &seq.controls, |_, s| out.extend(s.iter().map(|v| v.to_f64())));
    crate::watch::check()?;
    Ok(out)
}

/// Trains the readout of `reservoir` on `data`: harvest, all penalties from
/// one factorisation, each validated in noisy free run, the best chosen
/// (ties go to the larger penalty). With the same reservoir, data and settings
/// the result is identical whatever the number of threads. On one thread;
/// [`train_on`] spreads the validation over several.
pub fn train(reservoir: &Reservoir, data: &TrainingData, settings: &TrainSettings) -> Result<Training> {
    train_on(reservoir, data, settings, 1)
}

/// [`train`] with the validation's candidates split into `threads` groups
/// that run in parallel (on the caller's rayon pool); the bits do not depend on it.
pub fn train_on(
    reservoir: &Reservoir,
    data: &TrainingData,
    settings: &TrainSettings,
    threads: usize,
) -> Result<Training> {
    match reservoir.config().precision {
        Precision::F32 => train_in::<f32>(reservoir, data, settings, threads),
        Precision::F64 => train_in::<f64>(reservoir, data, settings, threads),
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

/// A washout that leaves at least 2 of the `t` training samples.
pub(crate) fn check_washout(washout: usize, t: usize) -> Result<()> {
    if washout + 2 > t {
        return Err(Error::Settings(format!(
            "washout of {washout} steps leaves fewer than 2 of the {t} training samples"
        )));
    }
    Ok(())
}

/// Harvests the training states of `seq` by teacher forcing from the zero state.
pub fn harvest(reservoir: &Reservoir, seq: &Sequence, washout: usize) -> Result<Harvest> {
    match reservoir.config().precision {
        Precision::F32 => harvest_in::<f32>(&Engine::new(reservoir), seq, washout, None),
        Precision::F64 => harvest_in::<f64>(&Engine::new(reservoir), seq, washout, None),
    }
}

/// `noise`: (standard deviation, seed) of the noise on the fed-back teacher.
fn harvest_in<R: SimdDot>(
    engine: &Engine<R>,
    seq: &Sequence,
    washout: usize,
    noise: Option<(f64, u64)>,
) -> Result<Harvest> {
    let (n, d, u) = (engine.shared.n, engine.shared.d, engine.shared.u);
    let t = seq.check("training sequence", d, u)?;
    check_washout(washout, t)?;
    let rows = t - 1 - washout;
    let mut states = Mat::<f64>::zeros(rows, n);
    let mut x = vec![R::ZERO; engine.shared.np];
    let noisy;
    let fed: &[f64] = match noise {
        Some((sigma, seed)) if sigma > 0.0 => {
            let mut g = rng(seed, 2_000);
            noisy = seq.outputs[..(t - 1) * d]
                .iter()
                .map(|v| v + sigma * g.sample::<f64, _>(StandardNormal))
                .collect::<Vec<_>>();
            &noisy
        }
        _ => &seq.outputs[..(t - 1) * d],
    };
    engine.teacher_force(&mut x, fed, &seq.controls[..(t - 1) * u], |k, s| {
        if k >= washout {
            for (j, v) in s.iter().enumerate() {
                states[(k - washout, j)] = v.to_f64();
            }
        }
    });
    crate::watch::check()?;
    let targets = Mat::from_fn(rows, d, |i, j| seq.outputs[(i + washout + 1) * d + j]);
    Ok(Harvest { states, targets })
}

/// Scores candidate readouts: each runs freely from the state reached by
/// teacher-forcing `data.warmup`, with the settings' state noise and the
/// scoring's holds, driven by `data.validation.controls`, and is scored as
/// `data.scoring` says, averaged over the noise draws (the same draws for
/// every candidate). All candidates and draws advance together in
/// `threads` batches run in parallel. Returns the scores in candidate order
/// and the start state.
pub fn validate(
    reservoir: &Reservoir,
    candidates: &[Candidate],
    data: &TrainingData,
    settings: &TrainSettings,
    threads: usize,
) -> Result<(Vec<ValidationPoint>, Vec<f64>)> {
    match reservoir.config().precision {
        Precision::F32 => validate_in::<f32>(&Engine::new(reservoir), candidates, data, settings, threads),
        Precision::F64 => validate_in::<f64>(&Engine::new(reservoir), candidates, data, settings, threads),
    }
}

fn check_scoring(scoring: &Scoring, steps: usize, d: usize) -> Result<()> {
    for h in &scoring.holds {
        if h.values.len() != d || h.values.iter().any(|v| !v.is_finite()) || h.from.saturating_add(h.len) > steps {
            return Err(Error::Settings(format!(
                "a hold at steps {}..{} needs {d} finite values inside the {steps}-step validation run",
                h.from,
                h.from.saturating_add(h.len)
            )));
        }
    }
    if let Score::Orbit(stays) = &scoring.score {
        if stays.is_empty() {
            return Err(Error::Settings("an orbit score needs at least one stay".into()));
        }
        for s in stays {
            s.check(d, steps)?;
        }
    }
    Ok(())
}

pub(crate) fn validate_in<R: SimdDot>(
    engine: &Engine<R>,
    candidates: &[Candidate],
    data: &TrainingData,
    settings: &TrainSettings,
    threads: usize,
) -> Result<(Vec<ValidationPoint>, Vec<f64>)> {
    let (n, np, d, u) = (engine.shared.n, engine.shared.np, engine.shared.d, engine.shared.u);
    let (warmup, validation) = (&data.warmup, &data.validation);
    warmup.check("warm-up sequence", d, u)?;
    let steps = validation.check("validation sequence", d, u)?;
    if steps == 0 {
        return Err(Error::Settings("the validation sequence is empty".into()));
    }
    if let Some(c) = candidates
        .iter()
        .find(|c| c.readout.n_features != n || c.readout.bias.len() != d || c.readout.weights.len() != n * d)
    {
        return Err(Error::Shape(format!(
            "a readout is {}×{}, the reservoir needs {d}×{n}",
            c.readout.bias.len(),
            c.readout.n_features
        )));
    }
    settings.check_noise()?;
    check_scoring(&data.scoring, steps, d)?;
    let readouts_r: Vec<ReadoutR<R>> = candidates.iter().map(|c| ReadoutR::new(&c.readout)).collect();
    let mut x0 = vec![R::ZERO; np];
    engine.teacher_force(&mut x0, &warmup.outputs, &warmup.controls, |_, _| {});
    crate::watch::check()?;

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
    let n_cols = candidates.len() * draws;
    let chunk = n_cols.div_ceil(threads.max(1)).div_ceil(4) * 4;
    let holds = &data.scoring.holds;
    let column_score: Vec<f64> = sweep_chunked(n_cols, chunk, |cols| {
        let columns: Vec<Column<'_, R>> = cols
            .clone()
            .map(|c| Column {
                dynamics: &engine.dynamics,
                readout: &readouts_r[c / draws],
                x0: &x0[..n],
                noise: if sigma > 0.0 { NoiseSource::Table(&noises[c % draws]) } else { NoiseSource::Off },
                controls: ControlSource::Table(&validation.controls),
                holds,
            })
            .collect();
        match &data.scoring.score {
            Score::Nmse => score_nmse(&engine.shared, &columns, &validation.outputs, &var, steps),
            Score::Orbit(stays) => score_orbit(&engine.shared, &columns, stays, steps, d),
        }
    });
    crate::watch::check()?;
    let curve = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let per: Vec<f64> = column_score[i * draws..(i + 1) * draws].to_vec();
            let nmse =
                if per.iter().all(|v| v.is_finite()) { per.iter().sum::<f64>() / draws as f64 } else { f64::INFINITY };
            ValidationPoint { penalty: c.penalty, nmse, nmse_per_draw: per }
        })
        .collect();
    Ok((curve, x0[..n].iter().map(|v| v.to_f64()).collect()))
}

/// The NMSE of every column's free run against the validation targets,
/// averaged over the outputs (an output's error divided by its variance).
fn score_nmse<R: SimdDot>(
    shared: &Shared<R>,
    columns: &[Column<'_, R>],
    target: &[f64],
    var: &[f64],
    steps: usize,
) -> Vec<f64> {
    let (k, d) = (columns.len(), var.len());
    let mut sse = vec![0.0; k * d];
    let mut sinks: Vec<_> = sse
        .chunks_exact_mut(d)
        .map(|e| {
            move |s: usize, y: &[R]| {
                for ((e, yk), t) in e.iter_mut().zip(y).zip(&target[s * d..(s + 1) * d]) {
                    let diff = yk.to_f64() - t;
                    *e += diff * diff;
                    if !e.is_finite() {
                        *e = f64::INFINITY;
                    }
                }
                true
            }
        })
        .collect();
    run_columns(shared, columns, &mut sinks, steps);
    drop(sinks);
    sse.chunks_exact(d)
        .map(|e| e.iter().zip(var).map(|(e, v)| e / (steps as f64 * v)).sum::<f64>() / d as f64)
        .collect()
}

/// The orbit score of every column's free run: its scored windows, each
/// against its stay's cycle at the best phase, averaged over the stays.
fn score_orbit<R: SimdDot>(
    shared: &Shared<R>,
    columns: &[Column<'_, R>],
    stays: &[OrbitStay],
    steps: usize,
    d: usize,
) -> Vec<f64> {
    let k = columns.len();
    // Only the scored windows are kept.
    let windows: Vec<(usize, usize)> = stays.iter().map(|s| (s.end - s.window, s.end)).collect();
    let per_col: usize = windows.iter().map(|(a, b)| b - a).sum::<usize>() * d;
    let mut kept = vec![f64::NAN; k * per_col];
    let mut finite = vec![true; k];
    let windows = &windows;
    let mut sinks: Vec<_> = kept
        .chunks_exact_mut(per_col.max(1))
        .zip(finite.iter_mut())
        .map(|(kept, finite)| {
            move |s: usize, y: &[R]| {
                if y.iter().any(|v| !v.finite()) {
                    *finite = false;
                    return false;
                }
                let mut off = 0;
                for &(a, b) in windows {
                    if (a..b).contains(&s) {
                        let dst = off + (s - a) * d;
                        for (o, v) in kept[dst..dst + d].iter_mut().zip(y) {
                            *o = v.to_f64();
                        }
                    }
                    off += (b - a) * d;
                }
                true
            }
        })
        .collect();
    run_columns(shared, columns, &mut sinks, steps);
    drop(sinks);
    (0..k)
        .map(|c| {
            if !finite[c] {
                return f64::INFINITY;
            }
            let mut off = 0;
            let mut total = 0.0;
            for (stay, &(a, b)) in stays.iter().zip(windows) {
                let len = (b - a) * d;
                total += orbit_nmse(&kept[c * per_col + off..c * per_col + off + len], stay, d);
                off += len;
            }
            total / stays.len() as f64
        })
        .collect()
}

/// Every penalty solved on `states` and `targets`, validated, and the choice.
type Fitted = (Vec<Candidate>, Vec<ValidationPoint>, Vec<f64>, usize);

fn fit<R: SimdDot>(
    engine: &Engine<R>,
    states: &Mat<f64>,
    targets: &Mat<f64>,
    data: &TrainingData,
    settings: &TrainSettings,
    threads: usize,
) -> Result<Fitted> {
    let path = RidgePath::new(states.as_ref(), targets.as_ref())?;
    let candidates: Vec<Candidate> =
        sweep(&settings.penalties, |_, penalty| path.solve(penalty).map(|readout| Candidate { penalty, readout }))
            .into_iter()
            .collect::<Result<_, _>>()?;
    let (curve, x0) = validate_in(engine, &candidates, data, settings, threads)?;
    let chosen = choose(&curve, settings)?;
    Ok((candidates, curve, x0, chosen))
}

fn stack(a: &Mat<f64>, b: &Mat<f64>) -> Mat<f64> {
    let ra = a.nrows();
    Mat::from_fn(ra + b.nrows(), a.ncols(), |i, j| if i < ra { a[(i, j)] } else { b[(i - ra, j)] })
}

/// One round of [`SelfFed`]: the training sequence run with stretches fed
/// by `readout`'s own output, the states of those stretches and the
/// teacher's next samples. The teacher noise is drawn from its own stream per round.
fn self_fed_in<R: SimdDot>(
    engine: &Engine<R>,
    seq: &Sequence,
    settings: &TrainSettings,
    readout: &Readout,
    round: u64,
) -> Result<Harvest> {
    let (n, d, u) = (engine.shared.n, engine.shared.d, engine.shared.u);
    let t = seq.check("training sequence", d, u)?;
    let (washout, sf) = (settings.washout, settings.self_fed);
    check_washout(washout, t)?;
    let cycle = sf.forced_steps + sf.free_steps;
    let mut g = rng(settings.noise_seed, 2_000 + round);
    let sigma = settings.teacher_noise;
    let mut row = vec![0.0; n];
    let mut own = vec![0.0; d];
    // Whether the current step is fed by the network, and whether this free stretch has strayed.
    let fed_own = std::cell::Cell::new(false);
    let mut strayed = false;
    let mut kept: Vec<f64> = Vec::new();
    let mut at: Vec<usize> = Vec::new();
    let mut x = vec![R::ZERO; engine.shared.np];
    engine.drive(
        &mut x,
        &seq.controls[..(t - 1) * u],
        t - 1,
        |k, x, fed| {
            let teacher = &seq.outputs[k * d..(k + 1) * d];
            let free = k >= washout && (k - washout) % cycle >= sf.forced_steps;
            if !free {
                strayed = false;
            }
            fed_own.set(false);
            if free && !strayed {
                for (r, v) in row.iter_mut().zip(x) {
                    *r = v.to_f64();
                }
                readout.apply(&row, &mut own);
                strayed =
                    own.iter().zip(teacher).any(|(a, b)| (a - b).abs().is_nan() || (a - b).abs() > SelfFed::MAX_STRAY);
                fed_own.set(!strayed);
            }
            let source = if fed_own.get() { &own[..] } else { teacher };
            for (f, v) in fed.iter_mut().zip(source) {
                *f = if sigma > 0.0 { v + sigma * g.sample::<f64, _>(StandardNormal) } else { *v };
            }
        },
        |k, s| {
            if fed_own.get() {
                kept.extend(s.iter().map(|v| v.to_f64()));
                at.push(k);
            }
        },
    );
    crate::watch::check()?;
    let states = Mat::from_fn(at.len(), n, |i, j| kept[i * n + j]);
    let targets = Mat::from_fn(at.len(), d, |i, j| seq.outputs[(at[i] + 1) * d + j]);
    Ok(Harvest { states, targets })
}

/// The candidate validation chooses: the best score, or the largest penalty
/// scoring within `(1 + prefer_larger_within) ×` it (ties to the larger).
pub(crate) fn choose(curve: &[ValidationPoint], settings: &TrainSettings) -> Result<usize> {
    let best = curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min);
    if !best.is_finite() {
        return Err(Error::AllDiverged { candidates: curve.len() });
    }
    let limit = best * (1.0 + settings.prefer_larger_within);
    (0..curve.len())
        .filter(|&i| curve[i].nmse <= limit)
        .fold(None, |b: Option<usize>, i| match b {
            Some(b) if curve[b].penalty >= curve[i].penalty => Some(b),
            _ => Some(i),
        })
        .ok_or_else(|| Error::Settings("no candidate penalty".into()))
}

fn train_in<R: SimdDot>(
    reservoir: &Reservoir,
    data: &TrainingData,
    settings: &TrainSettings,
    threads: usize,
) -> Result<Training> {
    let engine = Engine::<R>::new(reservoir);
    // Settings first: the harvest and the factorisation are the expensive part.
    settings.check_noise()?;
    let noise = (settings.teacher_noise, settings.noise_seed);
    let Harvest { mut states, mut targets } = harvest_in(&engine, &data.train, settings.washout, Some(noise))?;
    let (mut candidates, mut curve, mut x0, mut chosen) = fit(&engine, &states, &targets, data, settings, threads)?;
    for round in 0..settings.self_fed.rounds {
        let more = self_fed_in(&engine, &data.train, settings, &candidates[chosen].readout, round as u64 + 1)?;
        states = stack(&states, &more.states);
        targets = stack(&targets, &more.targets);
        (candidates, curve, x0, chosen) = fit(&engine, &states, &targets, data, settings, threads)?;
    }
    let (rows, n, d) = (states.nrows(), engine.shared.n, engine.shared.d);
    let Candidate { penalty, readout } =
        candidates.into_iter().nth(chosen).ok_or(Error::Settings("no candidate penalties".into()))?;
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
    Ok(Training { readout, penalty, curve, start_state: x0, train_nmse })
}

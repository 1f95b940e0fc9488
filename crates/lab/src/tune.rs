//! `cpg tune`: a seeded random search over the settings the paper calls "not
//! critical" (spectral radius, leak rate, feedback and input scaling, teacher
//! noise, how the penalty is validated), each candidate judged by what users
//! need from a CPG: long free runs that keep the teacher's period, amplitude
//! and shape, and recover from the paper's push, on several reservoir seeds.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::config::{Config, OrbitSection, PushSection};
use crate::error::{Error, Result};
use crate::experiment::Progress;
use crate::measure::push_for;
use crate::measure::{AMPLITUDE_TOLERANCE, PERIOD_TOLERANCE, Push, RunSpec, free_runs_each, recovery, stability};
use crate::prepare::{Prepared, prepare};
use crate::schedule::ControlSchedule;
use crate::train::train_prepared;
use cpg_reservoir::TrainedCpg;

/// Most candidates of one search.
pub const MAX_BUDGET: usize = 10_000;

/// How a search runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TuneSettings {
    /// Candidates drawn (the starting configuration is evaluated too).
    pub budget: usize,
    /// Reservoir seeds each candidate is trained with.
    pub seeds: u64,
    /// Length of each judged free run, seconds.
    pub long_run_s: f64,
    /// Variance of the state noise during the judged runs (a mild robustness test).
    pub noise_variance: f64,
    /// Seed of the search.
    pub search_seed: u64,
    /// Threads the search runs on (its own pool; the results do not depend on it).
    pub threads: usize,
}

impl Default for TuneSettings {
    fn default() -> Self {
        TuneSettings { budget: 24, seeds: 3, long_run_s: 300.0, noise_variance: 1e-7, search_seed: 1, threads: 1 }
    }
}

/// The settings a candidate changes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Knobs {
    /// Spectral radius of W.
    pub spectral_radius: f64,
    /// Leak rate.
    pub leak_rate: f64,
    /// Feedback scale.
    pub feedback_scale: f64,
    /// Factor on every control input's scale.
    pub input_factor: f64,
    /// Noise on the fed-back teacher while harvesting.
    pub teacher_noise: f64,
    /// `nmse` or `orbit`.
    pub score: crate::config::ScoreKind,
    /// Validation noise (with `nmse`).
    pub noise_variance: f64,
    /// The selection rule's tolerance.
    pub prefer_larger_within: f64,
}

/// How one seed of a candidate did, on its worst teacher.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeedScore {
    /// The reservoir seed.
    pub seed: u64,
    /// Every teacher's run accurate and converged, and back on the orbit after the push.
    pub passed: bool,
    /// Worst relative period error (`None`: a run decayed or lost its rhythm).
    pub period_error: Option<f64>,
    /// Worst relative amplitude error.
    pub amplitude_error: f64,
    /// Worst phase-aligned NMSE of the last window.
    pub end_nmse: f64,
    /// Slowest recovery from the push, seconds (`None`: never).
    pub recovery_s: Option<f64>,
    /// The cost: period and amplitude errors in units of their tolerances,
    /// the shape error in hundredths of NMSE, the recovery time in seconds
    /// (10 when there is none); a decayed run costs 100.
    pub cost: f64,
}

/// One candidate of the search.
#[derive(Debug, Clone, Serialize)]
pub struct TunedCandidate {
    /// 0 for the starting configuration, then the draws in order.
    pub index: usize,
    /// Its settings.
    pub knobs: Knobs,
    /// Per seed.
    pub seeds: Vec<SeedScore>,
    /// Seeds that passed.
    pub passed: usize,
    /// Mean cost over the seeds.
    pub mean_cost: f64,
    /// Lowest and highest cost over the seeds.
    pub cost_range: (f64, f64),
    /// The candidate as a configuration.
    #[serde(skip)]
    pub config: Config,
}

/// The outcome of a search: every candidate, best first.
#[derive(Debug, Clone, Serialize)]
pub struct TuneResult {
    /// How the search ran.
    pub settings: TuneSettings,
    /// Candidates sorted by seeds passed (most first), then mean cost.
    pub candidates: Vec<TunedCandidate>,
}

impl TuneResult {
    /// The best candidate.
    pub fn best(&self) -> Option<&TunedCandidate> {
        self.candidates.first()
    }
}

/// The search's draws: ChaCha8 from `rand_chacha`, whose stream is fixed for a
/// seed on every platform and version, so a search is the same everywhere.
struct Draws(ChaCha8Rng);

impl Draws {
    fn unit(&mut self) -> f64 {
        self.0.random::<f64>()
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.unit()).exp()
    }
}

fn knobs_of(c: &Config) -> Knobs {
    let r = &c.reservoir;
    Knobs {
        spectral_radius: r.spectral_radius.unwrap_or(1.0),
        leak_rate: r.leak_rate.unwrap_or(0.3),
        feedback_scale: r.feedback.map_or(0.05, |f| f.scale),
        input_factor: 1.0,
        teacher_noise: c.training.teacher_noise,
        score: c.training.score,
        noise_variance: c.training.noise_variance,
        prefer_larger_within: c.training.prefer_larger_within,
    }
}

fn draw(g: &mut Draws) -> Knobs {
    let orbit = g.unit() < 0.5;
    Knobs {
        spectral_radius: g.uniform(0.7, 1.2),
        leak_rate: g.log_uniform(0.1, 1.0),
        feedback_scale: g.log_uniform(0.02, 0.5),
        input_factor: g.log_uniform(0.5, 2.0),
        teacher_noise: if g.unit() < 0.5 { 0.0 } else { g.log_uniform(0.01, 0.3) },
        score: if orbit { crate::config::ScoreKind::Orbit } else { crate::config::ScoreKind::Nmse },
        noise_variance: if orbit { 0.0 } else { g.log_uniform(1e-7, 1e-3) },
        prefer_larger_within: if g.unit() < 0.5 { 0.0 } else { 1.0 },
    }
}

/// `base` with the settings of `k`.
pub fn apply(base: &Config, k: &Knobs) -> Config {
    let mut c = base.clone();
    let r = &mut c.reservoir;
    r.spectral_radius = Some(k.spectral_radius);
    r.leak_rate = Some(k.leak_rate);
    let fb = r.feedback.get_or_insert(cpg_reservoir::Coupling::new(1.0, 0.05));
    fb.scale = k.feedback_scale;
    if let Some(inputs) = &mut r.inputs {
        for i in inputs {
            i.scale *= k.input_factor;
        }
    } else if !base.data.controls.is_empty() {
        r.inputs = Some(vec![cpg_reservoir::Coupling::new(0.5, 0.2 * k.input_factor); base.data.controls.len()]);
    }
    let t = &mut c.training;
    t.teacher_noise = k.teacher_noise;
    t.prefer_larger_within = k.prefer_larger_within;
    t.score = k.score;
    if k.score == crate::config::ScoreKind::Orbit {
        t.noise_variance = 0.0;
        t.noise_draws = 1;
        t.orbit.get_or_insert(OrbitSection {
            stay_s: 10.0,
            ramp_s: 1.0,
            settle_s: 6.5,
            sequence: None,
            rates: None,
            push: Some(PushSection::default()),
        });
    } else {
        t.noise_variance = k.noise_variance;
        t.orbit = None;
    }
    c
}

fn failed(seed: u64) -> SeedScore {
    SeedScore {
        seed,
        passed: false,
        period_error: None,
        amplitude_error: f64::INFINITY,
        end_nmse: f64::INFINITY,
        recovery_s: None,
        cost: 100.0,
    }
}

/// Judges models trained on one seed, at every teacher's control setting:
/// all their runs (a long noisy one, a pushed one and its clean twin per
/// teacher) advance together, one pass over the shared reservoir per step.
/// `None` is a candidate whose every penalty diverged.
fn judge(models: &[Option<TrainedCpg>], seed: u64, rate: f64, s: &TuneSettings) -> Result<Vec<SeedScore>> {
    let n = (s.long_run_s * rate).round() as usize;
    struct Plan<'a> {
        m: &'a TrainedCpg,
        k: usize,
        ctl: ControlSchedule,
        push: Push,
        short: usize,
    }
    let mut plans = Vec::new();
    for m in models.iter().flatten() {
        if m.teachers.is_empty() {
            return Err(Error::Unusable("cpg tune needs a looped (periodic) segment to judge the rhythm".into()));
        }
        let d = m.outputs.len();
        if let Some(t) = m.teachers.iter().find(|t| t.is_posture(d)) {
            return Err(Error::Unusable(format!(
                "cpg tune judges rhythms; '{}' is a posture (stand = true): tune a configuration without it",
                t.label
            )));
        }
        for (k, t) in m.teachers.iter().enumerate() {
            let push = push_for(&PushSection::default(), t, d, rate);
            let release = push.at + push.len;
            let after = (40 * (t.cycle.len() / d)).min(n.saturating_sub(release));
            plans.push(Plan { m, k, ctl: ControlSchedule::Constant(t.controls.clone()), push, short: release + after });
        }
    }
    let mut specs = Vec::with_capacity(3 * plans.len());
    for p in &plans {
        let noise = (s.noise_variance > 0.0).then_some((s.noise_variance, seed * 1000 + p.k as u64));
        specs.push(RunSpec { model: p.m, controls: &p.ctl, steps: n, push: None, noise });
        specs.push(RunSpec { model: p.m, controls: &p.ctl, steps: p.short, push: Some(&p.push), noise: None });
        specs.push(RunSpec { model: p.m, controls: &p.ctl, steps: p.short, push: None, noise: None });
    }
    let mut runs = free_runs_each(&specs, s.threads)?.into_iter();
    let mut plans = plans.iter().peekable();
    let mut out = Vec::with_capacity(models.len());
    for m in models {
        let Some(m) = m else {
            out.push(failed(seed));
            continue;
        };
        let d = m.outputs.len();
        let mut worst = SeedScore {
            seed,
            passed: true,
            period_error: Some(0.0),
            amplitude_error: 0.0,
            end_nmse: 0.0,
            recovery_s: Some(0.0),
            cost: 0.0,
        };
        let mut diverged = false;
        while let Some(p) = plans.next_if(|p| std::ptr::eq(p.m, m)) {
            let t = &m.teachers[p.k];
            let (y, pushed, clean) = match (runs.next(), runs.next(), runs.next()) {
                (Some(Ok(y)), Some(Ok(pushed)), Some(Ok(clean))) => (y, pushed, clean),
                _ => {
                    diverged = true;
                    continue;
                }
            };
            let st = stability(&y, d, t, 0, rate);
            let rec = recovery(&clean, &pushed, d, &t.cycle, p.push.at + p.push.len, rate)?;
            let amp = (0..d).map(|c| (st.amplitude_ratio(c) - 1.0).abs()).fold(0.0, f64::max);
            let per = st.period_error().map(f64::abs);
            let cost = match (per, st.decayed_at_s) {
                (Some(pe), None) => {
                    pe / PERIOD_TOLERANCE
                        + amp / AMPLITUDE_TOLERANCE
                        + st.end.aligned_nmse / 0.01
                        + rec.orbit_s.unwrap_or(10.0)
                }
                _ => 100.0,
            };
            worst.passed &= st.accurate && st.converged && rec.orbit_s.is_some();
            worst.period_error = match (worst.period_error, per) {
                (Some(a), Some(b)) => Some(a.max(b)),
                _ => None,
            };
            worst.amplitude_error = worst.amplitude_error.max(amp);
            worst.end_nmse = worst.end_nmse.max(st.end.aligned_nmse);
            worst.recovery_s = match (worst.recovery_s, rec.orbit_s) {
                (Some(a), Some(b)) => Some(a.max(b)),
                _ => None,
            };
            worst.cost = worst.cost.max(cost);
        }
        out.push(if diverged { failed(seed) } else { worst });
    }
    Ok(out)
}

/// Trains and judges every candidate on every seed: seed by seed, the
/// candidates are trained in parallel and then judged together (they differ
/// only in scalars, so they share the seed's reservoir weights).
fn evaluate(
    jobs: Vec<(usize, Knobs, Config)>,
    s: &TuneSettings,
    progress: &dyn Progress,
) -> Result<Vec<TunedCandidate>> {
    let prepared: Vec<Prepared> = jobs.par_iter().map(|(_, _, c)| prepare(c)).collect::<Result<_>>()?;
    let rate = jobs.first().map_or(120.0, |(_, _, c)| c.data.rate_hz);
    let mut scores: Vec<Vec<SeedScore>> = vec![Vec::with_capacity(s.seeds as usize); jobs.len()];
    progress.start("seeds × candidates", s.seeds * jobs.len() as u64);
    for k in 0..s.seeds {
        let models: Vec<Option<TrainedCpg>> = jobs
            .par_iter()
            .zip(&prepared)
            .map(|((_, _, c), p)| {
                let m = match train_prepared(c, p, c.reservoir.seed + k, s.threads) {
                    Ok(m) => Ok(Some(m)),
                    // A candidate whose every penalty diverges is a bad candidate, not an error.
                    Err(Error::Reservoir(cpg_reservoir::Error::AllDiverged { .. })) => Ok(None),
                    Err(e) => Err(e),
                };
                progress.tick();
                m
            })
            .collect::<Result<_>>()?;
        let seed = jobs.first().map_or(k, |(_, _, c)| c.reservoir.seed + k);
        for (all, one) in scores.iter_mut().zip(judge(&models, seed, rate, s)?) {
            all.push(one);
        }
    }
    progress.finish();
    Ok(jobs
        .into_iter()
        .zip(scores)
        .map(|((index, knobs, config), seeds)| {
            let mean_cost = seeds.iter().map(|x| x.cost).sum::<f64>() / seeds.len() as f64;
            let cost_range =
                seeds.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x.cost), b.max(x.cost)));
            let passed = seeds.iter().filter(|x| x.passed).count();
            TunedCandidate { index, knobs, seeds, passed, mean_cost, cost_range, config }
        })
        .collect())
}

/// Searches `budget` random candidates around `base` (which is evaluated too).
/// Candidates run in parallel; the result does not depend on the thread count.
pub fn tune(base: &Config, s: &TuneSettings, progress: &dyn Progress) -> Result<TuneResult> {
    crate::in_pool(s.threads, || tune_here(base, s, progress))
}

fn tune_here(base: &Config, s: &TuneSettings, progress: &dyn Progress) -> Result<TuneResult> {
    if s.budget > MAX_BUDGET || s.seeds == 0 || s.seeds > 100 {
        return Err(Error::Bound(format!(
            "a search of {} candidates × {} seeds: at most {MAX_BUDGET} × 100",
            s.budget, s.seeds
        )));
    }
    if !(s.long_run_s.is_finite() && (10.0..=3600.0).contains(&s.long_run_s)) {
        return Err(Error::Bound(format!("judged runs of {} s: expected 10 to 3600 s", s.long_run_s)));
    }
    prepare(base)?; // the data must be usable before anything runs
    let mut g = Draws(ChaCha8Rng::seed_from_u64(s.search_seed));
    let mut jobs = vec![(0, knobs_of(base), base.clone())];
    for i in 1..=s.budget {
        let k = draw(&mut g);
        jobs.push((i, k.clone(), apply(base, &k)));
    }
    let mut candidates = evaluate(jobs, s, progress)?;
    candidates
        .sort_by(|a, b| b.passed.cmp(&a.passed).then(a.mean_cost.total_cmp(&b.mean_cost)).then(a.index.cmp(&b.index)));
    Ok(TuneResult { settings: s.clone(), candidates })
}

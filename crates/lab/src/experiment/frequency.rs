//! E4: frequency modulation by a control input (wyffels & Schrauwen 2009, Fig. 3).

mod section;

use rayon::prelude::*;
use serde::Serialize;

use cpg_reservoir::Teacher;

use super::claim::{self, Claim, Measure, Source, Verdict};
use super::{Header, Judged, Options, Progress, SeedModel, header, seeds, train_seeds, verdict_over};
use crate::config::{Config, FrequencySection};
use crate::error::{Error, Result};
use crate::measure::{TeacherShape, column, free_run, rhythm};
use crate::schedule::ControlSchedule;
use crate::stats::Proportion;

/// Largest relative frequency error at a plateau for the verdict.
pub const FREQUENCY_TOLERANCE: f64 = 0.05;
/// Largest relative amplitude error at a plateau for the verdict.
pub const AMPLITUDE_TOLERANCE: f64 = 0.25;
/// The rule of the E4 verdict, as printed beside it.
pub const RULE: &str = "at every plateau u, and on every held stretch of the paper's Fig. 3 schedule, over its second half: the frequency within 5 % of u·f0 and the amplitude (half range) within 25 % of the teacher's";

/// One plateau of one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plateau {
    /// The control value.
    pub u: f64,
    /// The judged window, seconds from the start of the run.
    pub window_s: [f64; 2],
    /// The teacher played `u` times as fast, Hz.
    pub target_hz: f64,
    /// Measured frequency, Hz (`None`: decayed or no rhythm).
    pub measured_hz: Option<f64>,
    /// Half range over the teacher's.
    pub amplitude_ratio: f64,
    /// NMSE against the teacher at rate `u`, best phase.
    pub aligned_nmse: f64,
    /// Within both tolerances.
    pub passed: bool,
    /// A tolerance decided it by less than the report prints (3 decimals of
    /// the frequency ratio, 2 of the amplitude ratio).
    pub at_limit: bool,
}

impl Plateau {
    /// Measured over target frequency (0 when the output decayed or showed no rhythm).
    pub fn frequency_ratio(&self) -> f64 {
        self.measured_hz.map_or(0.0, |h| h / self.target_hz)
    }
}

/// One seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrequencySeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// Each plateau.
    pub plateaus: Vec<Plateau>,
    /// Every plateau and every held stretch of the figure schedule passed.
    pub passed: bool,
    /// A plateau or stretch that decided it was at the limit.
    pub at_limit: bool,
    /// The held stretches of the paper's figure schedule, judged the same way.
    pub figure: Vec<Plateau>,
}

/// Traces of the first seed (normalised output of channel 0, control).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fig3 {
    /// The plateau test: output.
    pub plateau_output: Vec<f64>,
    /// The plateau test: control.
    pub plateau_control: Vec<f64>,
    /// The paper's figure schedule: output.
    pub figure_output: Vec<f64>,
    /// The paper's figure schedule: control.
    pub figure_control: Vec<f64>,
}

/// E4 over seeds.
#[derive(Debug, Clone, Serialize)]
pub struct FrequencyResult {
    /// What was run.
    pub header: Header,
    /// The teacher's frequency at u = 1, Hz.
    pub f0_hz: f64,
    /// The teacher's half range (normalised, channel 0).
    pub teacher_amplitude: f64,
    /// Plateau values.
    pub plateaus: Vec<f64>,
    /// Seconds per plateau.
    pub hold_s: f64,
    /// Seconds of ramp between plateaus.
    pub ramp_s: f64,
    /// Per seed, in seed order.
    pub seeds: Vec<FrequencySeed>,
    /// The claim E4, measured ([`FrequencyResult::summarise`]).
    pub claims: Vec<Claim>,
    /// The section's other aggregates.
    pub table: Vec<Measure>,
    /// Figure traces of the first seed.
    #[serde(skip)]
    pub fig3: Fig3,
}

/// Fraction of seeds that must pass every plateau.
pub const SEED_FRACTION: f64 = 0.8;

impl FrequencyResult {
    /// Seeds that passed every plateau.
    pub fn n_passed(&self) -> usize {
        self.seeds.iter().filter(|s| s.passed).count()
    }

    /// E4: the frequency follows the control over the whole range.
    pub fn verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| Judged { passed: s.passed, at_limit: s.at_limit }).collect();
        verdict_over(&j, SEED_FRACTION, RULE_OVER_SEEDS)
    }

    /// Fills [`FrequencyResult::claims`] and [`FrequencyResult::table`] from the seeds.
    pub fn summarise(&mut self) {
        let h = &self.header;
        self.claims = vec![Claim {
            experiment: "E4".into(),
            claim: format!(
                "the frequency follows one control input over {}–{}× the recorded one",
                self.plateaus.iter().copied().fold(f64::INFINITY, f64::min),
                self.plateaus.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            ),
            sources: vec![Source::Quote(claim::SIX_TIMES), Source::Quote(claim::SMOOTH_CHANGE)],
            protocol: h.protocol.to_string(),
            differs: h.differs.iter().map(|d| d.describe()).collect(),
            measured: vec![Measure::count(
                "seeds within 5 % of u·f0 and 25 % of the amplitude at every plateau and on the paper's schedule",
                Proportion::count(self.seeds.iter().map(|s| s.passed)),
            )],
            verdict: self.verdict(),
        }];
        let mut table = Vec::new();
        for (k, &u) in self.plateaus.iter().enumerate() {
            let fr: Vec<f64> = self.seeds.iter().map(|s| s.plateaus[k].frequency_ratio()).collect();
            let am: Vec<f64> = self.seeds.iter().map(|s| s.plateaus[k].amplitude_ratio).collect();
            table.push(Measure::spread(format!("u = {u}: frequency / (u·f0)"), &fr, "", 3));
            table.push(Measure::spread(format!("u = {u}: amplitude / teacher's"), &am, "", 2));
        }
        let n_fig = self.seeds.first().map_or(0, |s| s.figure.len());
        for k in 0..n_fig {
            let w = &self.seeds[0].figure[k];
            let at = format!("Fig. 3 schedule, u = {} from {:.1} to {:.1} s", w.u, w.window_s[0], w.window_s[1]);
            table.push(Measure::count(
                format!("{at}: seeds passing"),
                Proportion::count(self.seeds.iter().map(|s| s.figure[k].passed)),
            ));
            let fr: Vec<f64> = self.seeds.iter().map(|s| s.figure[k].frequency_ratio()).collect();
            let am: Vec<f64> = self.seeds.iter().map(|s| s.figure[k].amplitude_ratio).collect();
            table.push(Measure::spread(format!("{at}: frequency / (u·f0)"), &fr, "", 3));
            table.push(Measure::spread(format!("{at}: amplitude / teacher's"), &am, "", 2));
        }
        let models: Vec<&SeedModel> = self.seeds.iter().map(|s| &s.model).collect();
        table.extend(super::penalty_rows(&models, &mut self.header));
        self.table = table;
    }
}

/// The rule of the E4 verdict over seeds.
pub const RULE_OVER_SEEDS: &str = "at least 80 % of the seeds pass every plateau and every held stretch of the paper's schedule, each judged over its second half: the frequency within 5 % of u·f0 and the amplitude (half range) within 25 % of the teacher's";

/// What a window is judged against: the teacher at u = 1, its half range, f0 and the sample rate.
struct Reference<'a> {
    base: &'a Teacher,
    amp: f64,
    f0: f64,
    rate: f64,
}

/// Judges the window `[a, b)` (steps) of `y` (`d` channels) at control value `u`.
fn judge(y: &[f64], d: usize, (a, b): (usize, usize), u: f64, r0: &Reference<'_>) -> Plateau {
    let Reference { base, amp, f0, rate } = *r0;
    let w = &y[a * d..b * d];
    let t_u = Teacher { rate: u, controls: vec![u], ..base.clone() };
    let r = rhythm(w, d, &t_u, 0);
    let measured_hz = r.period_steps.map(|ps| rate / ps);
    let amplitude_ratio = r.amplitude[0] / amp;
    let target_hz = u * f0;
    let passed = measured_hz.is_some_and(|h| (h / target_hz - 1.0).abs() < FREQUENCY_TOLERANCE)
        && (amplitude_ratio - 1.0).abs() < AMPLITUDE_TOLERANCE;
    let at_limit = measured_hz
        .is_some_and(|h| crate::stats::at_limit((h / target_hz - 1.0).abs(), FREQUENCY_TOLERANCE, 3))
        || crate::stats::at_limit((amplitude_ratio - 1.0).abs(), AMPLITUDE_TOLERANCE, 2);
    Plateau {
        u,
        window_s: [a as f64 / rate, b as f64 / rate],
        target_hz,
        measured_hz,
        amplitude_ratio,
        aligned_nmse: r.aligned_nmse,
        passed,
        at_limit,
    }
}

/// The held stretches (two knots with the same value, at least 2 s apart) of a knot schedule: (from, to, u), seconds.
fn holds(knots: &[[f64; 2]]) -> Vec<(f64, f64, f64)> {
    knots
        .windows(2)
        .filter(|w| w[0][1] == w[1][1] && w[1][0] - w[0][0] >= 2.0)
        .map(|w| (w[0][0], w[1][0], w[0][1]))
        .collect()
}

/// Runs E4 on configuration `c`.
pub fn run(c: &Config, f: &FrequencySection, opts: Options, progress: &dyn Progress) -> Result<FrequencyResult> {
    let seeds = seeds(c, opts)?;
    if c.data.controls.len() != 1 {
        return Err(c.error("data.controls", "a frequency experiment has exactly one control input"));
    }
    if f.plateaus.is_empty() {
        return Err(c.error("experiment.test.frequency.plateaus", "is empty"));
    }
    let (prep, models) = train_seeds(c, &seeds, opts.threads, progress)?;
    let rate = c.data.rate_hz;
    let d = prep.outputs.len();
    let base = prep.teachers.first().ok_or_else(|| Error::Unusable("E4 needs a looped (periodic) segment".into()))?;
    let base = Teacher { rate: 1.0, controls: vec![1.0], ..base.clone() };
    let p = base.cycle.len() / d;
    let f0 = rate / p as f64;
    let schedule = ControlSchedule::plateaus(&f.plateaus, f.hold_s, f.ramp_s);
    let hold = (f.hold_s * rate).round() as usize;
    let ramp = (f.ramp_s * rate).round() as usize;
    let n = f.plateaus.len() * hold + (f.plateaus.len() - 1) * ramp;
    let figure = ControlSchedule::Knots(f.figure.iter().map(|[t, v]| (*t, vec![*v])).collect());
    figure.check(1)?;
    let n_fig = (f.figure.last().map_or(0.0, |k| k[0]) * rate).round() as usize;
    let shape = TeacherShape::of(&base, d);
    progress.start("plateau runs", seeds.len() as u64);
    let per_seed: Result<Vec<(FrequencySeed, Option<Fig3>)>> = seeds
        .par_iter()
        .zip(&models)
        .enumerate()
        .map(|(i, (&seed, m))| {
            let y = free_run(m, &schedule, n, None)?;
            let r0 = Reference { base: &base, amp: shape.amplitude[0], f0, rate };
            let plateaus: Vec<Plateau> = f
                .plateaus
                .iter()
                .enumerate()
                .map(|(k, &u)| {
                    let start = k * (hold + ramp);
                    judge(&y, d, (start + hold / 2, start + hold), u, &r0)
                })
                .collect();
            let yf = free_run(m, &figure, n_fig, None)?;
            let figure_windows: Vec<Plateau> = holds(&f.figure)
                .into_iter()
                .map(|(a, b, u)| {
                    let (a, b) = (((a + b) / 2.0 * rate) as usize, ((b * rate) as usize).min(n_fig));
                    judge(&yf, d, (a, b), u, &r0)
                })
                .collect();
            let fig = (i == 0).then(|| Fig3 {
                plateau_output: column(&y, d, 0),
                plateau_control: schedule.rows(n, rate),
                figure_output: column(&yf, d, 0),
                figure_control: figure.rows(n_fig, rate),
            });
            progress.tick();
            let passed = plateaus.iter().chain(&figure_windows).all(|p: &Plateau| p.passed);
            // At the limit when the deciding windows were: for a pass, any of
            // them; for a failure, when every failing window was.
            let all: Vec<&Plateau> = plateaus.iter().chain(&figure_windows).collect();
            let at_limit = if passed {
                all.iter().any(|p| p.at_limit)
            } else {
                all.iter().filter(|p| !p.passed).all(|p| p.at_limit)
            };
            Ok((
                FrequencySeed { model: SeedModel::of(m, seed), plateaus, passed, at_limit, figure: figure_windows },
                fig,
            ))
        })
        .collect();
    progress.finish();
    let per_seed = per_seed?;
    let fig3 = per_seed.iter().find_map(|(_, f)| f.clone()).unwrap_or_default();
    let mut r = FrequencyResult {
        header: header(c, &prep, models[0].reservoir.n_neurons())?,
        f0_hz: f0,
        teacher_amplitude: shape.amplitude[0],
        plateaus: f.plateaus.clone(),
        hold_s: f.hold_s,
        ramp_s: f.ramp_s,
        seeds: per_seed.into_iter().map(|(s, _)| s).collect(),
        claims: Vec::new(),
        table: Vec::new(),
        fig3,
    };
    r.summarise();
    Ok(r)
}

impl super::Experiment for FrequencyResult {
    fn figure(&self) -> &'static str {
        "Fig. 3"
    }
    super::common_accessors!();
    fn passed(&self) -> (usize, usize) {
        (self.seeds.iter().filter(|s| s.passed).count(), self.seeds.len())
    }
    fn target(&self) -> &'static str {
        "every plateau passed"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        section::frequency(&mut s, all, ctx);
        Ok(s)
    }
}

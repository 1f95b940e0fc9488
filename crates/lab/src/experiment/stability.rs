//! E1–E3: the learnt pattern, its long-run stability and its recovery from a
//! push (wyffels & Schrauwen 2009, Fig. 2).

mod section;

use rayon::prelude::*;
use serde::Serialize;

use cpg_mocap::cycle::align_to_cycle;
use cpg_reservoir::{Teacher, TrainedCpg};

use super::claim::{self, Claim, Measure, Source, Verdict};
use super::{Judged, Options, Progress, SeedModel, header, seeds, train_seeds, verdict_over};
use crate::config::{Config, StabilitySection};
use crate::error::{Error, Result};
use crate::measure::{Recovery, Stability, column, free_run, push_for, recovery, stability};
use crate::schedule::ControlSchedule;

/// The rule of a seed's E2 verdict, as printed beside it.
pub const RULE: &str = "accurate: at the end of the run the period is within 1 % of the teacher's and every amplitude (half range) within 5 %";
/// Decimals the report prints of a period in frames and of an amplitude ratio.
const PERIOD_DIGITS: usize = 2;
const AMPLITUDE_DIGITS: usize = 3;
/// Largest median NMSE of the first free-run samples for the E1 verdict
/// (for a sinusoid a pure phase slip φ costs 2(1 − cos φ): 0.1 allows about 18°).
pub const E1_NMSE_LIMIT: f64 = 0.1;
/// Fraction of seeds that must be accurate (E2) or recover (E3).
pub const SEED_FRACTION: f64 = 0.9;

/// One seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StabilitySeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// NMSE of the first free-run samples against the teacher's continuation, step by step.
    pub first_nmse: f64,
    /// The long run.
    pub stability: Stability,
    /// Whether the long run is accurate, and whether by a margin the report can show.
    pub accurate: Judged,
    /// The push.
    pub recovery: Recovery,
}

/// A long run's accuracy (see [`crate::measure`]) and whether a period or
/// an amplitude decided it by less than the report prints.
pub fn accuracy(st: &Stability) -> Judged {
    let t = &st.teacher;
    let near_period = st.end.period_steps.is_some_and(|p| {
        crate::stats::at_limit(
            (p - t.period_steps).abs(),
            crate::measure::PERIOD_TOLERANCE * t.period_steps,
            PERIOD_DIGITS,
        )
    });
    let near_amp = st.end.amplitude.iter().zip(&t.amplitude).any(|(a, b)| {
        crate::stats::at_limit((a / b - 1.0).abs(), crate::measure::AMPLITUDE_TOLERANCE, AMPLITUDE_DIGITS)
    });
    Judged { passed: st.accurate, at_limit: near_period || near_amp }
}

/// The push as applied.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PushInfo {
    /// When, seconds.
    pub at_s: f64,
    /// How long, seconds (a whole number of steps).
    pub hold_s: f64,
    /// Held steps.
    pub hold_steps: usize,
    /// Standard deviations above the cycle's maximum.
    pub above_max: f64,
    /// Held value of each channel, normalised units.
    pub held: Vec<f64>,
    /// Held value of each channel, in the channel's units.
    pub held_units: Vec<f64>,
}

/// Traces of the first seed for Fig. 2 (channel 0, in its units).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fig2 {
    /// The first free-run samples.
    pub first_model: Vec<f64>,
    /// The teacher over the same samples.
    pub first_teacher: Vec<f64>,
    /// The end of the long run.
    pub end_model: Vec<f64>,
    /// The teacher at its best phase over the same samples.
    pub end_teacher: Vec<f64>,
    /// Time of the first end sample, seconds.
    pub end_start_s: f64,
    /// The run with the push.
    pub pushed: Vec<f64>,
    /// Its unperturbed twin.
    pub free: Vec<f64>,
}

/// E1–E3 over seeds.
#[derive(Debug, Clone, Serialize)]
pub struct StabilityResult {
    /// What was run.
    pub header: super::Header,
    /// The channel the verdicts and figures use.
    pub channel: String,
    /// Long-run length, seconds.
    pub long_run_s: f64,
    /// Samples compared step by step at the start.
    pub first_samples: usize,
    /// The push.
    pub push: PushInfo,
    /// The teacher.
    pub teacher: Teacher,
    /// Per seed, in seed order.
    pub seeds: Vec<StabilitySeed>,
    /// The claims E1, E2 and E3, measured ([`StabilityResult::summarise`]).
    pub claims: Vec<Claim>,
    /// The section's other aggregates.
    pub table: Vec<Measure>,
    /// Figure traces of the first seed.
    #[serde(skip)]
    pub fig2: Fig2,
}

impl StabilityResult {
    /// Median NMSE of the first free-run samples over the seeds.
    pub fn median_first_nmse(&self) -> f64 {
        crate::stats::median(&self.seeds.iter().map(|s| s.first_nmse).collect::<Vec<_>>())
    }

    /// Seeds accurate at the end of the long run.
    pub fn n_accurate(&self) -> usize {
        self.seeds.iter().filter(|s| s.stability.accurate).count()
    }

    /// Seeds whose rhythm no longer changes (whether or not it is the teacher's).
    pub fn n_converged(&self) -> usize {
        self.seeds.iter().filter(|s| s.stability.converged).count()
    }

    /// Seeds back on the teacher's orbit for good after the push.
    pub fn n_recovered(&self) -> usize {
        self.seeds.iter().filter(|s| recovered(s)).count()
    }

    /// E1: the pattern is learnt.
    pub fn e1_verdict(&self) -> Verdict {
        let m = self.median_first_nmse();
        Verdict::new(
            m < E1_NMSE_LIMIT,
            crate::stats::at_limit(m, E1_NMSE_LIMIT, 4),
            format!(
                "the median over seeds of the NMSE of the first {} free-run samples against the teacher is below {E1_NMSE_LIMIT} (a sinusoid slipped by 18° in phase scores 0.1)",
                self.first_samples
            ),
        )
    }

    /// E2: stable over the long run.
    pub fn e2_verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| s.accurate).collect();
        verdict_over(
            &j,
            SEED_FRACTION,
            format!(
                "at least 90 % of the seeds accurate at the end of the {:.0}-s run: the period within 1 % of the teacher's and every amplitude (half range) within 5 %",
                self.long_run_s
            ),
        )
    }

    /// E3: recovery from the push, onto the orbit the seed's own unpushed
    /// run keeps (recovery as such; the teacher's orbit beside it measures
    /// E2's accuracy as much as recovery).
    pub fn e3_verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| Judged { passed: recovered(s), at_limit: false }).collect();
        verdict_over(
            &j,
            SEED_FRACTION,
            "at least 90 % of the seeds back for good on the orbit their own unpushed run keeps (its last period), a rhythm (a run that decays has none to return to): within 0.25 σ over quarter-period windows from some time after the release until the end of the 40 cycles that follow it",
        )
    }

    /// Which seeds failed which part of the recovery, in words.
    fn recovery_failures(&self) -> String {
        let list = |f: &dyn Fn(&StabilitySeed) -> bool| -> String {
            let v: Vec<String> = self.seeds.iter().filter(|s| f(s)).map(|s| s.model.seed.to_string()).collect();
            if v.is_empty() { "none".into() } else { v.join(", ") }
        };
        format!(
            "not back on their own orbit: {}; decayed (no rhythm to return to): {}; not back on the teacher's orbit: {}, of which the unpushed run itself ends off it: {}",
            list(&|s| s.recovery.own_orbit_s.is_none()),
            list(&|s| s.stability.decayed_at_s.is_some()),
            list(&|s| s.recovery.orbit_s.is_none()),
            list(&|s| s.recovery.orbit_s.is_none() && !s.recovery.unpushed_on_orbit)
        )
    }

    /// Fills [`StabilityResult::claims`] and [`StabilityResult::table`] from the seeds.
    pub fn summarise(&mut self) {
        let h = &self.header;
        let n = self.seeds.len();
        let differs: Vec<String> = h.differs.iter().map(|d| d.describe()).collect();
        let claim =
            |experiment: &str, claim: String, q: claim::Quote, measured: Vec<Measure>, verdict: Verdict| Claim {
                experiment: experiment.into(),
                claim,
                sources: vec![Source::Quote(q)],
                protocol: h.protocol.to_string(),
                differs: differs.clone(),
                measured,
                verdict,
            };
        let first: Vec<f64> = self.seeds.iter().map(|s| s.first_nmse).collect();
        let back: Vec<f64> =
            self.seeds.iter().filter(|s| recovered(s)).filter_map(|s| s.recovery.own_orbit_s).collect();
        let twin: Vec<f64> = self.seeds.iter().filter_map(|s| s.recovery.twin_s).collect();
        self.claims = vec![
            claim(
                "E1",
                format!("the femur pattern is learnt (the first {} samples of free run)", self.first_samples),
                claim::LITTLE_DIFFERENCE,
                vec![Measure::spread(
                    format!("NMSE of the first {} free-run samples over {n} seeds", self.first_samples),
                    &first,
                    "",
                    4,
                )],
                self.e1_verdict(),
            ),
            claim(
                "E2",
                format!("stable after {:.0} s of free run", self.long_run_s),
                claim::AFTER_900_S,
                vec![
                    Measure::count(
                        format!("seeds accurate after {:.0} s", self.long_run_s),
                        crate::stats::Proportion::count(self.seeds.iter().map(|s| s.stability.accurate)),
                    ),
                    Measure::count(
                        "seeds converged (the rhythm no longer changes, accurate or not)",
                        crate::stats::Proportion::count(self.seeds.iter().map(|s| s.stability.converged)),
                    ),
                ],
                self.e2_verdict(),
            ),
            claim(
                "E3",
                format!("recovers from a {:.0}-ms push", 1000.0 * self.push.hold_s),
                claim::RECOVERS_WELL,
                vec![
                    Measure::count(
                        "seeds back for good on the rhythm their own unpushed run keeps",
                        crate::stats::Proportion::count(self.seeds.iter().map(recovered)),
                    ),
                    Measure::spread("time from the release until back on it (seeds that are)", &back, "s", 2),
                    Measure::count(
                        "seeds back on the teacher's orbit for good",
                        crate::stats::Proportion::count(self.seeds.iter().map(|s| s.recovery.orbit_s.is_some())),
                    ),
                    Measure::count(
                        "seeds whose unpushed run itself ends on the teacher's orbit",
                        crate::stats::Proportion::count(self.seeds.iter().map(|s| s.recovery.unpushed_on_orbit)),
                    ),
                    Measure::text("which seeds failed", self.recovery_failures()),
                ],
                self.e3_verdict(),
            ),
        ];
        self.table = vec![
            Measure::count(
                "seeds back on the unperturbed twin (in phase) for good",
                crate::stats::Proportion::count(self.seeds.iter().map(|s| s.recovery.twin_s.is_some())),
            ),
            Measure::spread("time until back on the twin (seeds that are)", &twin, "s", 2),
        ];
        let models: Vec<&SeedModel> = self.seeds.iter().map(|s| &s.model).collect();
        self.table.extend(super::penalty_rows(&models, &mut self.header));
    }
}

fn to_units(m: &TrainedCpg, c: usize, z: &[f64]) -> Vec<f64> {
    let o = &m.outputs[c];
    z.iter().map(|v| o.to_units(*v)).collect()
}

/// The teacher continued from the end of a warm-up of `warmup_len` frames: `n` frames.
pub fn continuation(t: &Teacher, d: usize, warmup_len: usize, n: usize) -> Vec<f64> {
    let p = t.cycle.len() / d;
    (0..n)
        .flat_map(|k| {
            let pos = (warmup_len + k) as f64 * t.rate;
            let f = (pos.round() as usize) % p;
            t.cycle[f * d..(f + 1) * d].to_vec()
        })
        .collect()
}

/// NMSE of `y` against `target` (both `t × d`), each channel divided by the
/// target's variance, averaged: [`cpg_regression::nmse`], the one definition.
pub use cpg_regression::nmse;

/// Whether a seed recovered from the push: back for good on the orbit its
/// unpushed run keeps, and that run a rhythm (not decayed).
fn recovered(s: &StabilitySeed) -> bool {
    s.recovery.own_orbit_s.is_some() && s.stability.decayed_at_s.is_none()
}

/// Runs E1–E3 on configuration `c`.
pub fn run(c: &Config, s: &StabilitySection, opts: Options, progress: &dyn Progress) -> Result<StabilityResult> {
    let seeds = seeds(c, opts)?;
    let (prep, models) = train_seeds(c, &seeds, opts.threads, progress)?;
    let rate = c.data.rate_hz;
    let long_s = if opts.quick { s.quick_long_run_s } else { s.long_run_s };
    let long = (long_s * rate).round() as usize;
    let teacher = prep
        .teachers
        .first()
        .cloned()
        .ok_or_else(|| Error::Unusable("E1–E3 need a looped (periodic) segment".into()))?;
    let d = prep.outputs.len();
    let p = teacher.cycle.len() / d;
    let push = push_for(&s.push, &teacher, d, rate);
    let release = push.at + push.len;
    let after = 40 * p;
    if long < release + after || long < s.first_samples {
        return Err(c.error(
            "experiment.test.stability.long_run_s",
            format!(
                "{long_s} s is shorter than the push and 40 cycles after it ({} s)",
                (release + after) as f64 / rate
            ),
        ));
    }
    let warmup_len = prep.data.warmup.len(d);
    let controls = ControlSchedule::Constant(teacher.controls.clone());
    let reference = 0;
    progress.start("long free runs", seeds.len() as u64);
    let per_seed: Result<Vec<(StabilitySeed, Option<Fig2>)>> = seeds
        .par_iter()
        .zip(&models)
        .enumerate()
        .map(|(i, (&seed, m))| {
            let y = free_run(m, &controls, long, None)?;
            let first = &y[..s.first_samples * d];
            let first_teacher = continuation(&teacher, d, warmup_len, s.first_samples);
            let st = stability(&y, d, &teacher, reference, rate);
            let pushed = free_run(m, &controls, release + after, Some(&push))?;
            let rec = recovery(&y[..(release + after) * d], &pushed, d, &teacher.cycle, release, rate)?;
            let fig = (i == 0).then(|| {
                let tail = &y[(long - 500.min(long)) * d..];
                let tail0 = column(tail, d, 0);
                let cyc0 = column(&teacher.cycle, d, 0);
                let (shift, _) = align_to_cycle(&tail0, &cyc0, 1);
                let end_teacher: Vec<f64> = (0..tail0.len()).map(|k| cyc0[(shift + k) % cyc0.len()]).collect();
                let span = (10 * rate as usize).min(release + after);
                // While held, the output is the held value (the paper's "output was forced").
                let mut pushed0 = to_units(m, 0, &column(&pushed[..span * d], d, 0));
                let held0 = m.outputs[0].to_units(push.values[0]);
                for v in pushed0.iter_mut().skip(push.at).take(push.len) {
                    *v = held0;
                }
                Fig2 {
                    first_model: to_units(m, 0, &column(first, d, 0)),
                    first_teacher: to_units(m, 0, &column(&first_teacher, d, 0)),
                    end_model: to_units(m, 0, &tail0),
                    end_teacher: to_units(m, 0, &end_teacher),
                    end_start_s: (long - tail0.len()) as f64 / rate,
                    pushed: pushed0,
                    free: to_units(m, 0, &column(&y[..span * d], d, 0)),
                }
            });
            progress.tick();
            Ok((
                StabilitySeed {
                    model: SeedModel::of(m, seed),
                    first_nmse: nmse(first, &first_teacher, d),
                    accurate: accuracy(&st),
                    stability: st,
                    recovery: rec,
                },
                fig,
            ))
        })
        .collect();
    progress.finish();
    let per_seed = per_seed?;
    let m0 = &models[0];
    let held_units = push.values.iter().zip(&m0.outputs).map(|(v, o)| o.to_units(*v)).collect();
    let fig2 = per_seed.iter().find_map(|(_, f)| f.clone()).unwrap_or_default();
    let mut r = StabilityResult {
        header: header(c, &prep, m0.reservoir.n_neurons())?,
        channel: m0.outputs[0].name.clone(),
        long_run_s: long as f64 / rate,
        first_samples: s.first_samples,
        push: PushInfo {
            at_s: push.at as f64 / rate,
            hold_s: push.len as f64 / rate,
            hold_steps: push.len,
            above_max: s.push.above_max,
            held: push.values.clone(),
            held_units,
        },
        teacher,
        seeds: per_seed.into_iter().map(|(s, _)| s).collect(),
        claims: Vec::new(),
        table: Vec::new(),
        fig2,
    };
    r.summarise();
    Ok(r)
}

impl super::Experiment for StabilityResult {
    fn figure(&self) -> &'static str {
        "Fig. 2"
    }
    super::common_accessors!();
    fn passed(&self) -> (usize, usize) {
        (self.seeds.iter().filter(|s| s.stability.accurate).count(), self.seeds.len())
    }
    fn target(&self) -> &'static str {
        "accurate after the long run"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        section::stability(&mut s, all, ctx);
        Ok(s)
    }
}

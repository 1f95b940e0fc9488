//! The conditions a configuration's validation runs under and those its
//! test uses, read from the file, so that the report can show that the
//! penalty was chosen on conditions the verdict does not use (a verdict is
//! evidence only then) and a test can check it for every experiment.
//!
//! Two conditions are *shared* when they are of one kind and:
//!
//! - pushes: their start, their length or their height is the same;
//! - plateaus (a continuous control held): the same value;
//! - switches (a change of the controls): the same time or the same ramp;
//! - noise: the same seed, both with noise;
//! - windows (a stretch of a free run from the trained state, with no push
//!   or switch before it, scored against the teacher; a validation window may
//!   carry state noise, the paper's): they overlap;
//! - physics runs: the same length; pushes of the robot: the same interval or
//!   the same size;
//! - seeds: a seed in common (a quantity chosen by hand on a seed the test runs).
//!
//! Besides validation, a configuration names the quantities chosen outside
//! it (`[[experiment.tuned]]`: by hand on some seeds, or by a search on some
//! runs); their conditions are compared with the test's the same way.

use serde::Serialize;

use crate::config::{Config, ExperimentTest, PushSection};
use crate::error::Result;

/// One condition of a validation run or of a test.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Condition {
    /// The fed-back output held at the teacher's maximum + `above_max` σ.
    Push {
        /// Start, seconds from the start of the run.
        at_s: f64,
        /// Length, seconds (whole steps).
        hold_s: f64,
        /// Height above the cycle's maximum, standard deviations.
        above_max: f64,
    },
    /// A continuous control held at one value.
    Plateau {
        /// The value.
        u: f64,
        /// For how long, seconds.
        hold_s: f64,
    },
    /// The controls change.
    Switch {
        /// When the change starts, seconds.
        at_s: f64,
        /// The cosine ramp, seconds (0: abrupt).
        ramp_s: f64,
    },
    /// Gaussian state noise.
    Noise {
        /// Variance.
        variance: f64,
        /// Seed of the draws.
        seed: u64,
    },
    /// A stretch of a free run from the trained state, scored.
    Window {
        /// Start, seconds.
        from_s: f64,
        /// End, seconds.
        to_s: f64,
        /// With state noise (the paper's validation run).
        #[serde(default)]
        noisy: bool,
    },
    /// A run of the robot in physics on flat ground.
    Run {
        /// Its length, seconds.
        seconds: f64,
    },
    /// Pushes of the robot's trunk.
    Pushes {
        /// Seconds between them.
        every_s: f64,
        /// Each one's change of the trunk's velocity, m/s.
        mps: f64,
    },
    /// Reservoir seeds.
    Seeds {
        /// The seeds.
        seeds: Vec<u64>,
    },
}

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

impl Condition {
    /// Whether `self` (of validation) and `other` (of a test) are shared, by the module's rule.
    pub fn shared_with(&self, other: &Condition) -> bool {
        use Condition::*;
        match (self, other) {
            (Push { at_s: a, hold_s: h, above_max: m }, Push { at_s: b, hold_s: k, above_max: n }) => {
                same(*a, *b) || same(*h, *k) || same(*m, *n)
            }
            (Plateau { u: a, .. }, Plateau { u: b, .. }) => same(*a, *b),
            (Switch { at_s: a, ramp_s: r }, Switch { at_s: b, ramp_s: s }) => same(*a, *b) || same(*r, *s),
            (Noise { variance: v, seed: a }, Noise { variance: w, seed: b }) => *v > 0.0 && *w > 0.0 && a == b,
            (Window { from_s: a, to_s: b, .. }, Window { from_s: c, to_s: d, .. }) => a < d && c < b,
            (Run { seconds: a }, Run { seconds: b }) => same(*a, *b),
            (Pushes { every_s: a, mps: m }, Pushes { every_s: b, mps: n }) => same(*a, *b) || same(*m, *n),
            (Seeds { seeds: a }, Seeds { seeds: b }) => a.iter().any(|s| b.contains(s)),
            _ => false,
        }
    }

    /// The condition in words.
    pub fn describe(&self) -> String {
        match self {
            Condition::Push { at_s, hold_s, above_max } => {
                format!("a push at {at_s} s, held {} ms at the maximum {above_max:+} σ", ms(*hold_s))
            }
            Condition::Plateau { u, hold_s } => format!("u = {u} held {hold_s} s"),
            Condition::Switch { at_s, ramp_s } => {
                if *ramp_s == 0.0 {
                    format!("an abrupt switch at {at_s} s")
                } else {
                    format!("a switch at {at_s} s with a {ramp_s}-s ramp")
                }
            }
            Condition::Noise { variance, seed } => format!("state noise of variance {variance} (seed {seed})"),
            Condition::Window { from_s, to_s, noisy: false } => {
                format!("the clean free run scored from {from_s:.2} to {to_s:.2} s")
            }
            Condition::Window { from_s, to_s, noisy: true } => {
                format!("the free run with state noise scored from {from_s:.2} to {to_s:.2} s")
            }
            Condition::Run { seconds } => format!("{seconds} s on flat ground"),
            Condition::Pushes { every_s, mps } => format!("pushes of {mps} m/s every {every_s} s"),
            Condition::Seeds { seeds } => match seeds.as_slice() {
                [one] => format!("seed {one}"),
                [a, .., b] if seeds.windows(2).all(|w| w[1] == w[0] + 1) => format!("seeds {a}–{b}"),
                _ => format!("seeds {}", seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")),
            },
        }
    }
}

fn ms(s: f64) -> String {
    format!("{:.0}", s * 1000.0)
}

/// A quantity chosen outside validation and the conditions it was chosen on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tuned {
    /// What was chosen (a configuration key).
    pub key: String,
    /// How, in words.
    pub how: String,
    /// What it was chosen on.
    pub on: Vec<Condition>,
}

/// What validation used, what the quantities chosen outside it were chosen on, and what the test uses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Conditions {
    /// Of the validation run that chose the penalty.
    pub validation: Vec<Condition>,
    /// Of the quantities chosen outside validation.
    #[serde(default)]
    pub tuned: Vec<Tuned>,
    /// Of the experiment's test.
    pub test: Vec<Condition>,
}

impl Conditions {
    /// Every (validation or tuning, test) pair that the module's rule calls shared.
    pub fn shared(&self) -> Vec<(Condition, Condition)> {
        let mut out = Vec::new();
        for v in self.validation.iter().chain(self.tuned.iter().flat_map(|t| &t.on)) {
            for t in &self.test {
                if v.shared_with(t) {
                    out.push((v.clone(), t.clone()));
                }
            }
        }
        out
    }
}

/// The conditions a `[[experiment.tuned]]` entry names.
fn tuned(t: &crate::config::TunedSection) -> Tuned {
    let mut on = Vec::new();
    if !t.seeds.is_empty() {
        on.push(Condition::Seeds { seeds: t.seeds.clone() });
    }
    if let Some(s) = t.run_s {
        on.push(Condition::Run { seconds: s });
        if let Some(f) = t.tempo.filter(|f| *f != 1.0) {
            on.push(Condition::Switch { at_s: s / 2.0, ramp_s: t.tempo_ramp_s.unwrap_or(0.0) });
            on.push(Condition::Plateau { u: f, hold_s: s / 2.0 });
        }
    }
    if let (Some(every_s), Some(mps)) = (t.push_every_s, t.push_mps) {
        on.push(Condition::Pushes { every_s, mps });
    }
    Tuned { key: t.key.clone(), how: t.how.clone(), on }
}

fn round_to_step(s: f64, rate: f64) -> f64 {
    (s * rate).round() / rate
}

fn push(p: &PushSection, offset_s: f64, rate: f64) -> Condition {
    Condition::Push {
        at_s: round_to_step(offset_s + p.at_s, rate),
        hold_s: ((p.hold_s * rate).round().max(1.0)) / rate,
        above_max: p.above_max,
    }
}

/// The conditions of configuration `c` (which must have an `[experiment]` section).
pub fn conditions(c: &Config) -> Result<Conditions> {
    let e = super::section(c)?;
    let validation = validation_conditions(c);
    let test = test_conditions(c, e);
    Ok(Conditions { validation, tuned: e.tuned.iter().map(tuned).collect(), test })
}

/// What `c`'s validation runs under.
fn validation_conditions(c: &Config) -> Vec<Condition> {
    let rate = c.data.rate_hz;
    let t = &c.training;
    let mut validation = Vec::new();
    if t.noise_variance > 0.0 {
        validation.push(Condition::Noise { variance: t.noise_variance, seed: t.noise_seed });
    }
    match (t.score, &t.orbit) {
        (crate::config::ScoreKind::Orbit, Some(o)) => {
            // Stays as `prepare` lays them out: a ramp before each stay whose
            // controls differ from the previous ones (the first from the
            // warm-up's, which end on the first segment's or the tempo's).
            // The sequence names teachers, as training reads it: a group of trials is one.
            let teachers = c.data.teacher_segments();
            let n_stays = o
                .sequence
                .as_ref()
                .map_or_else(|| o.rates.as_ref().map_or(teachers.len().max(tempo_teachers(c)), Vec::len), Vec::len);
            let sequence: Vec<usize> = o.sequence.clone().unwrap_or_else(|| (0..n_stays).collect());
            let setting = |k: usize| -> Vec<f64> {
                match (&o.rates, &c.data.tempo) {
                    (Some(r), _) => vec![r.get(k).copied().unwrap_or(f64::NAN)],
                    (None, Some(tp)) => vec![tp.teachers.get(k).copied().unwrap_or(f64::NAN)],
                    (None, None) => teachers
                        .get(k)
                        .and_then(|&i| c.data.segments.get(i))
                        .map(|s| s.controls.clone())
                        .unwrap_or_default(),
                }
            };
            let mut clock = 0.0;
            // With a tempo the warm-up ends on a drifting rate, so the first stay is ramped to.
            let mut prev: Option<Vec<f64>> = match &c.data.tempo {
                Some(_) => Some(vec![f64::NAN]),
                None => c.data.segments.first().map(|s| s.controls.clone()),
            };
            for (i, &k) in sequence.iter().enumerate() {
                let now = setting(k);
                let ramp = prev.as_ref().is_some_and(|p| *p != now) && o.ramp_s > 0.0;
                if i > 0 || prev.as_ref().is_some_and(|p| *p != now) {
                    validation.push(Condition::Switch { at_s: round_to_step(clock, rate), ramp_s: o.ramp_s });
                }
                if ramp {
                    clock += o.ramp_s;
                }
                if c.data.tempo.is_some() {
                    validation.push(Condition::Plateau { u: now[0], hold_s: o.stay_s });
                }
                if i == 0 {
                    if let Some(p) = &o.push {
                        validation.push(push(p, clock, rate));
                    } else if !ramp && t.noise_variance == 0.0 {
                        validation.push(Condition::Window {
                            from_s: clock + o.settle_s,
                            to_s: clock + o.stay_s,
                            noisy: false,
                        });
                    }
                }
                clock += o.stay_s;
                prev = Some(now);
            }
        }
        _ => {
            // The paper's validation: a free run from the trained state, with or without noise.
            validation.push(Condition::Window {
                from_s: 0.0,
                to_s: t.validation_samples as f64 / rate,
                noisy: t.noise_variance > 0.0,
            });
        }
    }
    validation
}

/// What `c`'s test uses.
fn test_conditions(c: &Config, e: &crate::config::ExperimentSection) -> Vec<Condition> {
    let rate = c.data.rate_hz;
    let mut test = Vec::new();
    match &e.test {
        ExperimentTest::Stability(s) => {
            test.push(push(&s.push, 0.0, rate));
            test.push(Condition::Window { from_s: 0.0, to_s: s.first_samples as f64 / rate, noisy: false });
        }
        ExperimentTest::Frequency(f) => {
            let mut clock = 0.0;
            for (k, &u) in f.plateaus.iter().enumerate() {
                if k > 0 {
                    test.push(Condition::Switch { at_s: clock, ramp_s: f.ramp_s });
                    clock += f.ramp_s;
                }
                test.push(Condition::Plateau { u, hold_s: f.hold_s });
                clock += f.hold_s;
            }
            for w in f.figure.windows(2) {
                let ([t0, u0], [t1, u1]) = (w[0], w[1]);
                if u0 == u1 {
                    test.push(Condition::Plateau { u: u0, hold_s: t1 - t0 });
                } else {
                    test.push(Condition::Switch { at_s: t0, ramp_s: t1 - t0 });
                }
            }
        }
        ExperimentTest::Gaits(g) => {
            for &at in &g.switch_at_s {
                test.push(Condition::Switch { at_s: at, ramp_s: g.ramp_s });
                test.push(Condition::Switch { at_s: at, ramp_s: 0.0 });
            }
            test.push(Condition::Window {
                from_s: (g.switch_at_s[0] - super::gaits::GAIT_WINDOW_S).max(0.0),
                to_s: g.switch_at_s[0],
                noisy: false,
            });
        }
        ExperimentTest::Coupling(_) => test.push(Condition::Window { from_s: 0.0, to_s: 10.0, noisy: false }),
        ExperimentTest::Walking(w) => {
            // The tempo input held at 1, then ramped to the new tempo half-way.
            let half = w.run_s / 2.0;
            test.push(Condition::Run { seconds: w.run_s });
            test.push(Condition::Pushes { every_s: w.push_every_s, mps: w.push_mps });
            test.push(Condition::Plateau { u: 1.0, hold_s: half });
            test.push(Condition::Switch { at_s: half, ramp_s: w.tempo_ramp_s });
            test.push(Condition::Plateau { u: w.tempo, hold_s: half - w.tempo_ramp_s });
            if c.data.controls.iter().any(|u| u == "u_walk") {
                // A fourth run: the walk input ramped to 0 half-way (a stop).
                test.push(Condition::Switch { at_s: half, ramp_s: w.stop_ramp_s });
            }
        }
        ExperimentTest::WholeBody(b) => {
            // The switching run's switches, and the stretches the long runs are judged on.
            let mut clock = b.stay_s;
            for _ in 1..b.sequence.len() {
                test.push(Condition::Switch { at_s: round_to_step(clock, rate), ramp_s: b.ramp_s });
                clock += b.ramp_s + b.stay_s;
            }
            test.push(Condition::Window { from_s: b.run_s - b.stand_s, to_s: b.run_s, noisy: false });
            test.push(Condition::Window { from_s: b.run_s - crate::measure::WINDOW_S, to_s: b.run_s, noisy: false });
        }
    }
    // The seeds the test runs, against those a quantity was chosen on by hand.
    let first = c.reservoir.seed;
    test.push(Condition::Seeds { seeds: (first..first + e.seeds).collect() });
    test
}

fn tempo_teachers(c: &Config) -> usize {
    c.data.tempo.as_ref().map_or(0, |t| t.teachers.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_conditions_follow_the_rule() {
        let p = |a, h, m| Condition::Push { at_s: a, hold_s: h, above_max: m };
        assert!(p(2.0, 0.05, 2.0).shared_with(&p(2.0, 0.1, 1.0)));
        assert!(p(1.3, 0.05, 1.0).shared_with(&p(2.0, 0.05, 2.0)));
        assert!(!p(1.3, 0.1, 1.0).shared_with(&p(2.0, 0.05, 2.0)));
        let s = |a, r| Condition::Switch { at_s: a, ramp_s: r };
        assert!(s(5.0, 1.0).shared_with(&s(8.0, 1.0)));
        assert!(!s(5.0, 2.0).shared_with(&s(8.0, 1.0)));
        let u = |u| Condition::Plateau { u, hold_s: 5.0 };
        assert!(u(2.0).shared_with(&u(2.0)) && !u(2.5).shared_with(&u(2.0)));
        let w = |a, b| Condition::Window { from_s: a, to_s: b, noisy: false };
        assert!(w(0.0, 4.0).shared_with(&w(3.0, 6.0)) && !w(6.5, 10.0).shared_with(&w(0.0, 4.2)));
        let n = |v, s| Condition::Noise { variance: v, seed: s };
        assert!(n(1e-3, 1).shared_with(&n(1e-5, 1)) && !n(1e-3, 1).shared_with(&n(1e-3, 2)));
        assert!(!p(2.0, 0.05, 2.0).shared_with(&u(2.0)));
    }
}

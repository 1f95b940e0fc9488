//! E5: switching between two learnt gaits with two control inputs
//! (wyffels & Schrauwen 2009, Fig. 4).

mod section;

use rayon::prelude::*;
use serde::Serialize;

use super::claim::{self, Claim, Measure, Source, Verdict};
use super::{Header, Judged, Options, Progress, SeedModel, header, seeds, train_seeds, verdict_over};
use crate::config::{Config, GaitsSection};
use crate::error::Result;
use crate::measure::{TeacherShape, column, free_run, max_step, rhythm, settle_on_orbit};
use crate::schedule::ControlSchedule;
use crate::stats::{Proportion, at_limit};

/// Largest relative period error of a gait for the verdict.
pub const PERIOD_TOLERANCE: f64 = 0.02;
/// Largest relative amplitude error of a gait for the verdict.
pub const AMPLITUDE_TOLERANCE: f64 = 0.25;
/// A smooth switch must settle on the new gait's orbit within this time, seconds.
pub const SETTLE_S: f64 = 2.0;
/// Seconds after the start of a switch over which its jumps are measured.
pub const SWITCH_WINDOW_S: f64 = 2.0;
/// Seconds before a switch (and before the end) over which a gait is judged.
pub const GAIT_WINDOW_S: f64 = 3.0;
/// The rule of the E5 verdict, as printed beside it.
pub const RULE: &str = "both gaits (3 s windows before each switch and before the end) within 2 % of their teacher's period and 25 % of its amplitude; both smooth switches back on the new gait's orbit within 2 s of their start; no step-to-step change in the 2 s after a smooth switch larger than the largest in the two teacher cycles";

/// A gait window of one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GaitWindow {
    /// The teacher it is judged against.
    pub teacher: String,
    /// Measured period, steps (`None`: decayed).
    pub period_steps: Option<f64>,
    /// Teacher period, steps.
    pub teacher_period_steps: f64,
    /// Worst channel's half range over the teacher's.
    pub amplitude_ratio: f64,
    /// Within both tolerances.
    pub passed: bool,
    /// A tolerance decided it by less than the report prints (3 decimals of
    /// the period ratio, 2 of the amplitude ratio).
    pub at_limit: bool,
}

/// One seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GaitsSeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// First gait, before the first switch.
    pub first: GaitWindow,
    /// Second gait, before the switch back.
    pub second: GaitWindow,
    /// First gait again, at the end.
    pub first_again: GaitWindow,
    /// Seconds from the start of each smooth switch until on the new gait's orbit.
    pub settle_s: [Option<f64>; 2],
    /// Largest step in the 2 s after each smooth switch.
    pub max_jump_smooth: f64,
    /// The same for the abrupt switch.
    pub max_jump_abrupt: f64,
    /// Every part of the rule held.
    pub passed: bool,
    /// A comparison that decided it was closer than the report prints.
    pub at_limit: bool,
}

/// Traces of the first seed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fig4 {
    /// Each teacher's cycle tiled over 3 s (channel 0, normalised).
    pub teachers: Vec<(String, Vec<f64>)>,
    /// The smooth switch run.
    pub smooth: Vec<f64>,
    /// The abrupt switch run.
    pub abrupt: Vec<f64>,
    /// The second control during the smooth run.
    pub smooth_control: Vec<f64>,
    /// The second control during the abrupt run.
    pub abrupt_control: Vec<f64>,
}

/// E5 over seeds.
#[derive(Debug, Clone, Serialize)]
pub struct GaitsResult {
    /// What was run.
    pub header: Header,
    /// The two teachers.
    pub teachers: Vec<TeacherShape>,
    /// Largest step-to-step change in the teacher cycles.
    pub data_step: f64,
    /// Switch times, seconds.
    pub switch_at_s: [f64; 2],
    /// Smooth ramp, seconds.
    pub ramp_s: f64,
    /// Test length, seconds.
    pub run_s: f64,
    /// Per seed.
    pub seeds: Vec<GaitsSeed>,
    /// The claims of E5, measured ([`GaitsResult::summarise`]).
    pub claims: Vec<Claim>,
    /// The section's other aggregates.
    pub table: Vec<Measure>,
    /// Every seed's smooth switching run (channel 0, normalised), for the figure of all seeds.
    #[serde(skip)]
    pub smooth_runs: Vec<Vec<f64>>,
    /// Figure traces of the first seed.
    #[serde(skip)]
    pub fig4: Fig4,
    /// The first seed's smooth switching run: teacher, model and (when the
    /// configuration names a robot) the robot, for `cpg_view`.
    #[serde(skip)]
    pub view: Option<cpg_view::Scene>,
}

/// Fraction of seeds that must pass.
pub const SEED_FRACTION: f64 = 0.8;

/// A gait window holds a rhythm when it has a period and at least this
/// share of its teacher's amplitude (the worst channel's half range).
pub const RHYTHM_AMPLITUDE: f64 = 0.5;

/// Whether a gait window holds a rhythm (see [`RHYTHM_AMPLITUDE`]).
fn has_rhythm(w: &GaitWindow) -> bool {
    w.period_steps.is_some() && w.amplitude_ratio >= RHYTHM_AMPLITUDE
}

impl GaitsResult {
    /// Seeds that passed.
    pub fn n_passed(&self) -> usize {
        self.seeds.iter().filter(|s| s.passed).count()
    }

    /// E5: both gaits and both smooth switches.
    pub fn verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| Judged { passed: s.passed, at_limit: s.at_limit }).collect();
        verdict_over(&j, SEED_FRACTION, format!("at least 80 % of the seeds pass: {RULE}"))
    }

    /// The abrupt switches spike: the median largest step after an abrupt
    /// switch is larger than the data's largest step.
    pub fn spike_verdict(&self) -> Verdict {
        let rule = format!(
            "the median over seeds of the largest step-to-step change in the 2 s after an abrupt switch is larger than the largest in the two teacher cycles (a rule for a generator with both gaits: it does not apply when fewer than half the seeds hold a rhythm before the switches, a period and at least {RHYTHM_AMPLITUDE} of the teacher's amplitude)"
        );
        let with_rhythm = self.seeds.iter().filter(|s| has_rhythm(&s.first) && has_rhythm(&s.second)).count();
        if 2 * with_rhythm < self.seeds.len() {
            let amp = crate::stats::median(
                &self.seeds.iter().map(|s| s.first.amplitude_ratio.min(s.second.amplitude_ratio)).collect::<Vec<_>>(),
            );
            return Verdict::not_applicable(
                format!(
                    "no rhythm: {with_rhythm} of {} seeds hold both gaits before the switches (median amplitude {amp:.2} of the teacher's), so there is no gait to switch from",
                    self.seeds.len()
                ),
                rule,
            );
        }
        let m = crate::stats::median(&self.seeds.iter().map(|s| s.max_jump_abrupt).collect::<Vec<_>>());
        Verdict::new(m > self.data_step, at_limit(m, self.data_step, 3), rule)
    }

    /// Fills [`GaitsResult::claims`] and [`GaitsResult::table`] from the seeds.
    pub fn summarise(&mut self) {
        let h = &self.header;
        let differs: Vec<String> = h.differs.iter().map(|d| d.describe()).collect();
        let col = |f: &dyn Fn(&GaitsSeed) -> f64| self.seeds.iter().map(f).collect::<Vec<f64>>();
        let settle = |k: usize| col(&|s| s.settle_s[k].unwrap_or(f64::NAN));
        self.claims = vec![
            Claim {
                experiment: "E5".into(),
                claim: "walk and run, switched smoothly both ways by two inputs".into(),
                sources: vec![Source::Quote(claim::NO_TRANSITION_EXAMPLES)],
                protocol: h.protocol.to_string(),
                differs: differs.clone(),
                measured: vec![
                    Measure::count(
                        "seeds passing both gaits and both smooth switches",
                        Proportion::count(self.seeds.iter().map(|s| s.passed)),
                    ),
                    Measure::spread("settling after the first switch (seeds that settle)", &settle(0), "s", 2),
                    Measure::spread("settling after the switch back (seeds that settle)", &settle(1), "s", 2),
                    Measure::spread("largest step after a smooth switch", &col(&|s| s.max_jump_smooth), "z", 3),
                    Measure::number("largest step in the two teacher cycles", self.data_step, "z", 3),
                ],
                verdict: self.verdict(),
            },
            Claim {
                experiment: "E5".into(),
                claim: "abrupt switches give spikes".into(),
                sources: vec![Source::Quote(claim::SPIKES)],
                protocol: h.protocol.to_string(),
                differs,
                measured: vec![
                    Measure::spread("largest step after an abrupt switch", &col(&|s| s.max_jump_abrupt), "z", 3),
                    Measure::number("largest step in the two teacher cycles", self.data_step, "z", 3),
                ],
                verdict: self.spike_verdict(),
            },
        ];
        let ratio = |w: &GaitWindow| w.period_steps.map_or(0.0, |p| p / w.teacher_period_steps);
        let mut table = Vec::new();
        for (name, pick) in [
            ("first gait", (|s: &GaitsSeed| s.first.clone()) as fn(&GaitsSeed) -> GaitWindow),
            ("second gait", |s: &GaitsSeed| s.second.clone()),
            ("first gait again", |s: &GaitsSeed| s.first_again.clone()),
        ] {
            table.push(Measure::spread(format!("{name}: period / teacher's"), &col(&|s| ratio(&pick(s))), "", 3));
            table.push(Measure::spread(
                format!("{name}: amplitude / teacher's"),
                &col(&|s| pick(s).amplitude_ratio),
                "",
                2,
            ));
        }
        let models: Vec<&SeedModel> = self.seeds.iter().map(|s| &s.model).collect();
        table.extend(super::penalty_rows(&models, &mut self.header));
        self.table = table;
    }
}

/// The last control input of a schedule over `n` steps.
fn last_control(s: &ControlSchedule, n: usize, rate: f64) -> Vec<f64> {
    let u = s.width();
    if u == 0 { Vec::new() } else { column(&s.rows(n, rate), u, u - 1) }
}

/// What judging a seed's switching runs needs: the two gaits, the test's
/// schedules and sizes.
struct Switching<'a> {
    teachers: [&'a cpg_reservoir::Teacher; 2],
    shapes: [TeacherShape; 2],
    smooth: ControlSchedule,
    abrupt: ControlSchedule,
    g: &'a GaitsSection,
    rate: f64,
    d: usize,
    n: usize,
    /// The largest frame-to-frame step of the teachers' cycles.
    data_step: f64,
}

impl<'a> Switching<'a> {
    fn new(c: &Config, g: &'a GaitsSection, prep: &'a crate::prepare::Prepared) -> Result<Switching<'a>> {
        if prep.teachers.len() != 2 {
            return Err(
                c.error("data.segments", format!("E5 needs two looped gaits; there are {}", prep.teachers.len()))
            );
        }
        let rate = c.data.rate_hz;
        let d = prep.outputs.len();
        let (ta, tb) = (&prep.teachers[0], &prep.teachers[1]);
        let [s1, s2] = g.switch_at_s;
        if !(0.0 < s1 && s1 + g.ramp_s < s2 && s2 + g.ramp_s < g.run_s && s1 >= GAIT_WINDOW_S) {
            return Err(c.error(
                "experiment.test.gaits",
                "needs 3 s <= first switch < second switch < run_s, with room for the ramps",
            ));
        }
        let knots = |ramp: f64| {
            ControlSchedule::Knots(vec![
                (0.0, ta.controls.clone()),
                (s1, ta.controls.clone()),
                (s1 + ramp, tb.controls.clone()),
                (s2, tb.controls.clone()),
                (s2 + ramp, ta.controls.clone()),
            ])
        };
        let tiled = |t: &cpg_reservoir::Teacher| cpg_mocap::cycle::tile(&t.cycle, d, t.cycle.len() / d + 1, 0);
        Ok(Switching {
            teachers: [ta, tb],
            shapes: [TeacherShape::of(ta, d), TeacherShape::of(tb, d)],
            smooth: knots(g.ramp_s),
            abrupt: knots(0.0),
            g,
            rate,
            d,
            n: (g.run_s * rate).round() as usize,
            data_step: max_step(&tiled(ta), d).max(max_step(&tiled(tb), d)),
        })
    }

    /// The step at `s` seconds, within the run.
    fn at(&self, s: f64) -> usize {
        ((s * self.rate).round() as usize).min(self.n)
    }

    /// The rhythm of `y` in the window ending at `end_s`, against gait `k`.
    fn window(&self, y: &[f64], end_s: f64, k: usize) -> GaitWindow {
        let d = self.d;
        let w = &y[self.at(end_s - GAIT_WINDOW_S) * d..self.at(end_s) * d];
        let r = rhythm(w, d, self.teachers[k], 0);
        let sh = &self.shapes[k];
        let amplitude_ratio = r
            .amplitude
            .iter()
            .zip(&sh.amplitude)
            .map(|(a, b)| a / b)
            .fold(1.0, |worst: f64, x| if (x - 1.0).abs() > (worst - 1.0).abs() { x } else { worst });
        let passed = r.period_steps.is_some_and(|p| (p / sh.period_steps - 1.0).abs() < PERIOD_TOLERANCE)
            && (amplitude_ratio - 1.0).abs() < AMPLITUDE_TOLERANCE;
        let at_limit = r.period_steps.is_some_and(|p| at_limit((p / sh.period_steps - 1.0).abs(), PERIOD_TOLERANCE, 3))
            || at_limit((amplitude_ratio - 1.0).abs(), AMPLITUDE_TOLERANCE, 2);
        GaitWindow {
            teacher: sh.label.clone(),
            period_steps: r.period_steps,
            teacher_period_steps: sh.period_steps,
            amplitude_ratio,
            passed,
            at_limit,
        }
    }

    /// Seed `seed`'s model run through both switching schedules and judged;
    /// with the smooth and the abrupt run.
    fn judge(&self, m: &cpg_reservoir::TrainedCpg, seed: u64) -> Result<(GaitsSeed, Vec<f64>, Vec<f64>)> {
        let (d, g, rate) = (self.d, self.g, self.rate);
        let [s1, s2] = g.switch_at_s;
        let [ta, tb] = self.teachers;
        let ys = free_run(m, &self.smooth, self.n, None)?;
        let ya = free_run(m, &self.abrupt, self.n, None)?;
        let first = self.window(&ys, s1, 0);
        let second = self.window(&ys, s2, 1);
        let first_again = self.window(&ys, g.run_s, 0);
        let settle = [
            settle_on_orbit(&ys[..self.at(s2) * d], d, &tb.cycle, self.at(s1), rate),
            settle_on_orbit(&ys, d, &ta.cycle, self.at(s2), rate),
        ];
        let jump = |y: &[f64], s: f64| max_step(&y[self.at(s) * d..self.at(s + SWITCH_WINDOW_S) * d], d);
        let max_jump_smooth = jump(&ys, s1).max(jump(&ys, s2));
        let max_jump_abrupt = jump(&ya, s1).max(jump(&ya, s2));
        // Each part of the rule: (held, decided by less than the printed digits).
        let parts = [
            (first.passed, first.at_limit),
            (second.passed, second.at_limit),
            (first_again.passed, first_again.at_limit),
            (settle[0].is_some_and(|v| v <= SETTLE_S), settle[0].is_some_and(|v| at_limit(v, SETTLE_S, 2))),
            (settle[1].is_some_and(|v| v <= SETTLE_S), settle[1].is_some_and(|v| at_limit(v, SETTLE_S, 2))),
            (max_jump_smooth <= self.data_step, at_limit(max_jump_smooth, self.data_step, 3)),
        ];
        let passed = parts.iter().all(|p| p.0);
        let at_limit_seed = if passed { parts.iter().any(|p| p.1) } else { parts.iter().filter(|p| !p.0).all(|p| p.1) };
        let seed = GaitsSeed {
            model: SeedModel::of(m, seed),
            first,
            second,
            first_again,
            settle_s: settle,
            max_jump_smooth,
            max_jump_abrupt,
            passed,
            at_limit: at_limit_seed,
        };
        Ok((seed, ys, ya))
    }

    /// Figure 4's traces: the teachers, the smooth and the abrupt run.
    fn figure(&self, ys: &[f64], ya: &[f64]) -> Fig4 {
        let (d, rate) = (self.d, self.rate);
        let three = (GAIT_WINDOW_S * rate) as usize;
        Fig4 {
            teachers: self
                .teachers
                .iter()
                .map(|t| {
                    let p = t.cycle.len() / d;
                    (t.label.clone(), (0..three).map(|k| t.cycle[(k % p) * d]).collect())
                })
                .collect(),
            smooth: column(ys, d, 0),
            abrupt: column(ya, d, 0),
            smooth_control: last_control(&self.smooth, self.n, rate),
            abrupt_control: last_control(&self.abrupt, self.n, rate),
        }
    }
}

/// Runs E5 on configuration `c`.
pub fn run(c: &Config, g: &GaitsSection, opts: Options, progress: &dyn Progress) -> Result<GaitsResult> {
    let seeds = seeds(c, opts)?;
    let (prep, models) = train_seeds(c, &seeds, opts.threads, progress)?;
    let sw = Switching::new(c, g, &prep)?;
    let robot = match &g.robot {
        Some(r) => Some((cpg_robot::Robot::from_urdf_file(&r.urdf)?, cpg_robot::ChannelMap::load(&r.map)?)),
        None => None,
    };
    progress.start("switching runs", seeds.len() as u64);
    // Each seed's result; the first seed's figure traces and view.
    type SeedOut = (GaitsSeed, (Vec<f64>, Option<(Fig4, cpg_view::Scene)>));
    let per_seed: Result<Vec<SeedOut>> = seeds
        .par_iter()
        .zip(&models)
        .enumerate()
        .map(|(i, (&seed, m))| {
            let (judged, ys, ya) = sw.judge(m, seed)?;
            let fig = if i == 0 {
                let units = cpg_reservoir::to_units(&m.outputs, &ys);
                let view = crate::scene::run_scene(
                    &super::view_title(c),
                    m,
                    &sw.smooth,
                    0,
                    &units,
                    robot.as_ref().map(|(r, map)| crate::scene::RobotView {
                        robot: r,
                        map,
                        acceleration_rad_s2: cpg_robot::DEFAULT_ACCELERATION_RAD_S2,
                    }),
                )?;
                Some((sw.figure(&ys, &ya), view))
            } else {
                None
            };
            progress.tick();
            Ok((judged, (column(&ys, sw.d, 0), fig)))
        })
        .collect();
    progress.finish();
    let per_seed = per_seed?;
    let (fig4, view) = match per_seed.iter().find_map(|(_, (_, f))| f.clone()) {
        Some((f, v)) => (f, Some(v)),
        None => (Fig4::default(), None),
    };
    let smooth_runs = per_seed.iter().map(|(_, (y, _))| y.clone()).collect();
    let mut r = GaitsResult {
        header: header(c, &prep, models[0].reservoir.n_neurons())?,
        teachers: sw.shapes.to_vec(),
        data_step: sw.data_step,
        switch_at_s: g.switch_at_s,
        ramp_s: g.ramp_s,
        run_s: g.run_s,
        seeds: per_seed.into_iter().map(|(s, _)| s).collect(),
        claims: Vec::new(),
        table: Vec::new(),
        smooth_runs,
        fig4,
        view,
    };
    r.summarise();
    Ok(r)
}

impl super::Experiment for GaitsResult {
    fn figure(&self) -> &'static str {
        "Fig. 4"
    }
    super::common_accessors!();
    fn passed(&self) -> (usize, usize) {
        (self.seeds.iter().filter(|s| s.passed).count(), self.seeds.len())
    }
    fn target(&self) -> &'static str {
        "both gaits and switches passed"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        section::gaits(&mut s, all, ctx);
        Ok(s)
    }
}

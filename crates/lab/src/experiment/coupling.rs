//! E6: many outputs (the 22 HOAP-2 joints) and their phase coupling over a
//! long free run (wyffels & Schrauwen 2009, Fig. 5).

mod section;

use serde::Serialize;

use cpg_mocap::cycle::{align_to_cycle, align_to_cycle_fine, lag};
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, ClampReport, JointTrajectory, Robot};

use rayon::prelude::*;

use super::claim::{self, Claim, Measure, Source, Verdict};
use super::{Header, Judged, Options, Progress, SeedModel, header, section, verdict_over};
use crate::config::{Config, CouplingTestSection};
use crate::error::{Error, Result};
use crate::measure::{RunSpec, column, free_runs};
use crate::prepare::{Prepared, prepare};
use crate::schedule::ControlSchedule;
use crate::stats::{Proportion, at_limit};
use crate::train::{reservoir_for, train_prepared_on};

/// Largest drift of a joint's phase lag over the run for a seed to pass, cycles.
pub const DRIFT_TOLERANCE: f64 = 0.05;
/// Fraction of seeds that must keep the phase coupling.
pub const SEED_FRACTION: f64 = 0.8;
/// The rule of the E6 verdict, as printed beside it.
pub const RULE: &str = "at least 80 % of the seeds keep their phase relations without drift: no joint's phase relation to the reference (its deviation from the teacher's, aligned to a fraction of a frame) drifts by 0.05 cycle or more between the first and the last 10 s (a rule of drift, not of agreement with the teacher: how far each seed's relations end from the teacher's is given beside it)";

/// One seed of E6.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CouplingSeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// Largest |drift| of a joint, cycles.
    pub worst_drift: f64,
    /// Largest |deviation| of a joint's phase relation from the teacher's in
    /// the last 10 s, cycles: agreement with the teacher, which the rule does not test.
    #[serde(default)]
    pub worst_deviation_end: f64,
    /// Median per-joint cycle NMSE.
    pub median_cycle_nmse: f64,
    /// No joint drifted by [`DRIFT_TOLERANCE`] or more.
    pub passed: bool,
    /// The worst drift is within half a printed digit (3 decimals) of the tolerance.
    pub at_limit: bool,
}

/// One joint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LagRow {
    /// The channel.
    pub joint: String,
    /// The teacher's lag behind the reference, cycles (cross-correlation of the teacher cycle).
    pub teacher_lag: f64,
    /// The model's lag behind the reference in the last 10 s, cycles (same method).
    pub model_lag_end: f64,
    /// `model_lag_end − teacher_lag`, wrapped to (−0.5, 0.5]: the same phase
    /// relation read from the cross-correlation peaks (a joint with two similar
    /// peaks a cycle can jump between them, which [`LagRow::deviation_end`] does not).
    pub lag_change: f64,
    /// The model's phase relative to the teacher's phase relation in the first 10 s, cycles
    /// (0: exactly the teacher's lag; from aligning the joint's own teacher cycle
    /// to a fraction of a frame).
    pub deviation_start: f64,
    /// The same in the last 10 s.
    pub deviation_end: f64,
    /// `deviation_end − deviation_start`, wrapped to (−0.5, 0.5].
    pub drift: f64,
    /// NMSE of the last cycle against the teacher at its best phase.
    pub cycle_nmse: f64,
}

/// The HOAP-2 mapping of the last 10 s: at the model's rate and resampled to
/// 1 kHz, each kept within the URDF's position and velocity limits and the
/// acceleration bound.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Hoap2 {
    /// What each bound changed, per joint, in the 1 kHz trajectory.
    pub clamps: ClampReport,
    /// The acceleration bound, rad/s².
    pub acceleration_bound_rad_s2: f64,
    /// The smallest velocity limit of the joints in the URDF, rad/s.
    pub velocity_limit_rad_s: f64,
    /// The fastest joint speed commanded at 1 kHz, rad/s.
    pub max_speed_rad_s: f64,
    /// The largest joint acceleration commanded at 1 kHz, rad/s².
    pub max_acceleration_rad_s2: f64,
    /// Commanded angles that lie outside their joint's position range (0 when the limits held).
    pub n_outside_range: usize,
    /// The commands keep every bound: no angle outside its range, no speed
    /// above its limit, no acceleration above the bound (the limiter's job;
    /// what it changed to get there is in the shares below).
    pub within_limits: bool,
    /// Of all joints' frames at 1 kHz, the share whose asked angle lay outside its range.
    pub share_position_clamped: f64,
    /// The share the speed bound held back.
    pub share_velocity_limited: f64,
    /// The share the acceleration bound held back.
    pub share_acceleration_limited: f64,
    /// Frames of the model's rate in the loop (a whole number of the model's cycles).
    pub loop_frames: usize,
    /// Model cycles in the loop.
    pub loop_cycles: usize,
    /// Largest jump of a commanded angle across the loop's seam (last frame
    /// to first) at 1 kHz, radians.
    pub loop_seam_rad: f64,
    /// Largest step of a commanded angle between consecutive frames within the loop at 1 kHz, radians.
    pub loop_max_step_rad: f64,
    /// The robot's gait (HOAP-2 kinematics of the commanded angles, soles in the trunk frame).
    pub robot_gait: Option<cpg_robot::Gait>,
    /// The human's gait in the recorded segment (ankles relative to the root), lengths
    /// multiplied by [`Hoap2::leg_scale`].
    pub human_gait_scaled: Option<cpg_robot::Gait>,
    /// HOAP-2's leg length (thigh + shank) over the human's (femur + tibia).
    pub leg_scale: f64,
    /// The trajectory at the model's rate (radians).
    #[serde(skip)]
    pub trajectory: JointTrajectory,
    /// The trajectory at 1 kHz (radians).
    #[serde(skip)]
    pub trajectory_1khz: JointTrajectory,
    /// What was asked at 1 kHz before the limits (radians).
    #[serde(skip)]
    pub asked_1khz: JointTrajectory,
}

/// One channel plotted against the reference channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Portrait {
    /// The channel.
    pub channel: String,
    /// (reference, channel) over the whole recorded trial.
    pub data: Vec<(f64, f64)>,
    /// (reference, channel) over 10 s of the model's free run.
    pub model: Vec<(f64, f64)>,
}

/// E6: every seed's verdict; the tables, figures, views and the robot for the
/// first seed.
#[derive(Debug, Clone, Serialize)]
pub struct CouplingResult {
    /// What was run.
    pub header: Header,
    /// Every seed.
    pub seeds: Vec<CouplingSeed>,
    /// How the first seed's model was trained.
    pub model: SeedModel,
    /// Free-run length, steps.
    pub steps: usize,
    /// Free-run length, seconds.
    pub run_s: f64,
    /// The reference channel.
    pub reference: String,
    /// Frames per teacher cycle (one frame is `1 / period` of a cycle: the lag resolution).
    pub period_frames: usize,
    /// One row per joint of the first seed, in output order.
    pub rows: Vec<LagRow>,
    /// Largest |drift| of the first seed, cycles.
    pub worst_drift: f64,
    /// Median per-joint cycle NMSE of the first seed.
    pub median_cycle_nmse: f64,
    /// The claim E6, measured ([`CouplingResult::summarise`]).
    pub claims: Vec<Claim>,
    /// The section's other aggregates.
    pub table: Vec<Measure>,
    /// The first seed's deviation of every joint over the run: (start of a
    /// 10-s window in seconds, the deviation of each joint in output order, cycles).
    #[serde(skip)]
    pub deviation_over_time: Vec<(f64, Vec<f64>)>,
    /// The robot mapping, when the configuration names a robot.
    pub hoap2: Option<Hoap2>,
    /// Start of the portraits' model window, seconds.
    pub portrait_from_s: f64,
    /// Phase portraits against the reference, normalised.
    #[serde(skip)]
    pub portraits: Vec<Portrait>,
    /// The last 10 s in the channels' units, frame-major.
    #[serde(skip)]
    pub last10_units: Vec<f64>,
    /// The last 10 s: teacher, model and (when the configuration names a
    /// robot) the robot, for `cpg_view`.
    #[serde(skip)]
    pub view: Option<cpg_view::Scene>,
    /// The trained model (the comparison of families reuses it).
    #[serde(skip)]
    pub trained: Option<TrainedCpg>,
}

impl CouplingResult {
    /// E6: the phase coupling holds.
    pub fn verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| Judged { passed: s.passed, at_limit: s.at_limit }).collect();
        verdict_over(&j, SEED_FRACTION, RULE)
    }

    /// Seeds that kept the coupling.
    pub fn n_passed(&self) -> usize {
        self.seeds.iter().filter(|s| s.passed).count()
    }

    /// Fills [`CouplingResult::claims`] and [`CouplingResult::table`] from the seeds.
    pub fn summarise(&mut self) {
        let h = &self.header;
        let col = |f: &dyn Fn(&CouplingSeed) -> f64| self.seeds.iter().map(f).collect::<Vec<f64>>();
        self.claims = vec![Claim {
            experiment: "E6".into(),
            claim: format!("{} joints' phase relations do not drift over {:.0} s", self.rows.len(), self.run_s),
            sources: vec![Source::Quote(claim::PHASE_INTACT)],
            protocol: h.protocol.to_string(),
            differs: h.differs.iter().map(|d| d.describe()).collect(),
            measured: vec![
                Measure::count(
                    "seeds keeping every joint's drift below 0.05 cycle",
                    Proportion::count(self.seeds.iter().map(|s| s.passed)),
                ),
                Measure::spread(
                    "largest drift of a joint's phase relation over the run",
                    &col(&|s| s.worst_drift),
                    "cycles",
                    3,
                ),
                Measure::spread(
                    "largest deviation of a joint's phase relation from the teacher's, last 10 s (agreement: not in the rule)",
                    &col(&|s| s.worst_deviation_end),
                    "cycles",
                    3,
                ),
            ],
            verdict: self.verdict(),
        }];
        self.table = vec![Measure::spread(
            "median per-joint NMSE of the last cycle, best phase",
            &col(&|s| s.median_cycle_nmse),
            "",
            4,
        )];
        let models: Vec<&SeedModel> = self.seeds.iter().map(|s| &s.model).collect();
        self.table.extend(super::penalty_rows(&models, &mut self.header));
    }
}

fn wrap(x: f64) -> f64 {
    ((x + 0.5).rem_euclid(1.0)) - 0.5
}

/// One configuration of E6, ready to run.
struct Plan {
    c: Config,
    k: CouplingTestSection,
    seeds: Vec<u64>,
    prep: Prepared,
    d: usize,
    /// Frames per teacher cycle.
    p: usize,
    refc: usize,
    /// Free-run steps.
    n: usize,
    /// Steps in 10 s.
    ten: usize,
}

fn plan(c: &Config, k: &CouplingTestSection, opts: Options) -> Result<Plan> {
    section(c)?;
    let mut c = c.clone();
    if opts.quick {
        c.reservoir.n_neurons = Some(k.quick_neurons);
    }
    let seeds = super::seeds(&c, opts)?;
    let prep = prepare(&c)?;
    let rate = c.data.rate_hz;
    let d = prep.outputs.len();
    let teacher =
        prep.teachers.first().ok_or_else(|| Error::Unusable("E6 needs a looped (periodic) segment".into()))?;
    let p = teacher.cycle.len() / d;
    let refc = prep.outputs.iter().position(|o| o.name == k.reference).ok_or_else(|| {
        c.error("experiment.test.coupling.reference", format!("'{}' is not a learnt channel", k.reference))
    })?;
    let run_s = if opts.quick { k.quick_run_s } else { k.run_s };
    let n = (run_s * rate).round() as usize;
    let ten = (10.0 * rate) as usize;
    if n < 2 * ten {
        return Err(c.error("experiment.test.coupling.run_s", "must be at least 20 s"));
    }
    Ok(Plan { c, k: k.clone(), seeds, prep, d, p, refc, n, ten })
}

/// Runs E6 on configuration `c`: every seed trained and run; the first
/// seed's run is shown in full (tables, portraits, view, HOAP-2).
pub fn run(c: &Config, k: &CouplingTestSection, opts: Options, progress: &dyn Progress) -> Result<CouplingResult> {
    let mut v = run_together(&[(c, k)], opts, progress)?;
    v.pop().ok_or_else(|| Error::Unusable("E6 ran no configuration".into()))
}

/// Runs several E6 configurations as [`run`] runs each, with the same results.
/// When they list the same seeds and their reservoirs draw the same weights
/// for a seed (see [`super::share_reservoirs`]), each seed's long free runs
/// advance together, one pass over the weights for all of them; a long
/// 2,000-neuron run is bound by streaming its weights, so two configurations
/// cost little more than one.
pub fn run_together(
    items: &[(&Config, &CouplingTestSection)],
    opts: Options,
    progress: &dyn Progress,
) -> Result<Vec<CouplingResult>> {
    let plans = items.iter().map(|(c, k)| plan(c, k, opts)).collect::<Result<Vec<_>>>()?;
    let Some(first_plan) = plans.first() else { return Ok(Vec::new()) };
    if plans.iter().any(|pl| pl.seeds != first_plan.seeds) {
        // Nothing to share: one after the other.
        return items.iter().map(|(c, k)| run(c, k, opts, progress)).collect();
    }
    let seeds = first_plan.seeds.clone();
    // Seeds are trained as many at a time as there are cores, then each
    // seed's long free runs go on every core in turn (split by rows, one pass
    // over the weights for all the configurations: a 2,000-neuron W is
    // streamed from the shared cache instead of from memory twice over).
    // Only the first seed's models and runs are kept for the tables, figures
    // and the robot.
    progress.start("seeds: training and free run", seeds.len() as u64);
    type Kept = (TrainedCpg, Vec<f64>, Vec<LagRow>);
    let train_seed = |&seed: &u64| -> Result<Vec<TrainedCpg>> {
        // The weights and their spectral radius are drawn once for the seed.
        let drawn = reservoir_for(&first_plan.c, &first_plan.prep, seed)?;
        plans.iter().map(|pl| train_prepared_on(&pl.c, &pl.prep, seed, Some(drawn.clone()), opts.threads)).collect()
    };
    let width = opts.threads.max(1);
    let mut all: Vec<Vec<CouplingSeed>> = plans.iter().map(|_| Vec::with_capacity(seeds.len())).collect();
    let mut first: Vec<Option<Kept>> = plans.iter().map(|_| None).collect();
    for (ci, chunk) in seeds.chunks(width).enumerate() {
        let trained: Vec<Vec<TrainedCpg>> = if chunk.len() == 1 {
            chunk.iter().map(train_seed).collect::<Result<_>>()?
        } else {
            chunk.par_iter().map(train_seed).collect::<Result<_>>()?
        };
        for (j, (models, &seed)) in trained.into_iter().zip(chunk).enumerate() {
            let none = ControlSchedule::none();
            let specs: Vec<RunSpec<'_>> = models
                .iter()
                .zip(&plans)
                .map(|(m, pl)| RunSpec { model: m, controls: &none, steps: pl.n, push: None, noise: None })
                .collect();
            let ys = free_runs(&specs, opts.threads)?;
            drop(specs);
            for (p, ((m, y), pl)) in models.into_iter().zip(ys).zip(&plans).enumerate() {
                let rows = lag_rows(&pl.prep, &y, pl.n, pl.ten, pl.p, pl.refc);
                all[p].push(CouplingSeed {
                    model: SeedModel::of(&m, seed),
                    worst_drift: worst(&rows),
                    worst_deviation_end: rows.iter().map(|r| r.deviation_end.abs()).fold(0.0, f64::max),
                    median_cycle_nmse: median_nmse(&rows),
                    passed: worst(&rows) < DRIFT_TOLERANCE,
                    at_limit: at_limit(worst(&rows), DRIFT_TOLERANCE, 3),
                });
                if ci == 0 && j == 0 {
                    first[p] = Some((m, y, rows));
                }
            }
            progress.tick();
        }
    }
    progress.finish();
    plans.iter().zip(all).zip(first).map(|((pl, all), first)| finish(pl, all, first)).collect()
}

/// The tables, figures, view and robot of one configuration from its seeds
/// and its first seed's model and run.
fn finish(
    pl: &Plan,
    all: Vec<CouplingSeed>,
    first: Option<(TrainedCpg, Vec<f64>, Vec<LagRow>)>,
) -> Result<CouplingResult> {
    let Plan { c, k, prep, d, p, refc, n, ten, .. } = pl;
    let (c, k, prep, d, p, refc, n, ten) = (c, k, prep, *d, *p, *refc, *n, *ten);
    let rate = c.data.rate_hz;
    let (m, y, rows) = first.ok_or_else(|| Error::Unusable("E6 ran no seed".into()))?;
    let end_win = &y[(n - ten) * d..];
    let worst_drift = worst(&rows);
    let median_cycle_nmse = median_nmse(&rows);
    let last10_units = cpg_reservoir::to_units(&m.outputs, end_win);
    let names: Vec<String> = m.outputs.iter().map(|o| o.name.clone()).collect();
    let robot = match &k.robot {
        Some(r) => Some((Robot::from_urdf_file(&r.urdf)?, ChannelMap::load(&r.map)?)),
        None => None,
    };
    let view = crate::scene::run_scene(
        &super::view_title(c),
        &m,
        &ControlSchedule::none(),
        n - ten,
        &last10_units,
        robot.as_ref().map(|(r, map)| crate::scene::RobotView {
            robot: r,
            map,
            acceleration_rad_s2: cpg_robot::DEFAULT_ACCELERATION_RAD_S2,
        }),
    )?;
    let hoap2 = match &robot {
        Some((robot, map)) => Some(hoap2_loop(prep, &m, &y, n, p, refc, &names, robot, map, rate)?),
        None => None,
    };
    let from = ((500.0 * rate) as usize).min(n - ten);
    let data = prep.segments.first().cloned().unwrap_or_default();
    let portraits = k
        .portraits
        .iter()
        .map(|name| {
            let ch = names.iter().position(|x| x == name).ok_or_else(|| {
                c.error("experiment.test.coupling.portraits", format!("'{name}' is not a learnt channel"))
            })?;
            let dp = data.chunks_exact(d).map(|f| (f[refc], f[ch])).collect();
            let mp = (from..from + ten).map(|q| (y[q * d + refc], y[q * d + ch])).collect();
            Ok(Portrait { channel: name.clone(), data: dp, model: mp })
        })
        .collect::<Result<Vec<_>>>()?;
    let deviation_over_time = deviation_over_time(prep, &y, n, ten, p, refc);
    let mut r = CouplingResult {
        header: header(c, prep, m.reservoir.n_neurons())?,
        model: all.first().map(|s| s.model.clone()).unwrap_or_else(|| SeedModel::of(&m, c.reservoir.seed)),
        seeds: all,
        steps: n,
        run_s: n as f64 / rate,
        reference: k.reference.clone(),
        period_frames: p,
        rows,
        worst_drift,
        median_cycle_nmse,
        hoap2,
        portrait_from_s: from as f64 / rate,
        portraits,
        last10_units,
        view: Some(view),
        trained: Some(m),
        claims: Vec::new(),
        table: Vec::new(),
        deviation_over_time,
    };
    r.summarise();
    Ok(r)
}

/// Frames of margin kept on each side of the loop when it is resampled, so
/// that the spline's ends fall outside it.
pub const LOOP_MARGIN: usize = 8;

/// The HOAP-2 commands of the end of the first seed's run: a whole number
/// of the model's cycles (as many as fit in 10 s), cut where the run meets
/// itself best, mapped onto the robot, resampled to 1 kHz with a margin on
/// each side and limited as a loop.
#[allow(clippy::too_many_arguments)]
fn hoap2_loop(
    prep: &Prepared,
    m: &TrainedCpg,
    y: &[f64],
    n: usize,
    p: usize,
    refc: usize,
    names: &[String],
    robot: &Robot,
    map: &ChannelMap,
    rate: f64,
) -> Result<Hoap2> {
    let d = names.len();
    let a_max = cpg_robot::DEFAULT_ACCELERATION_RAD_S2;
    let ten = (10.0 * rate) as usize;
    // The model's own period, from the reference channel of the last 10 s.
    let refcol = column(&y[(n - ten) * d..], d, refc);
    let pm = cpg_mocap::cycle::estimate_period(&refcol, (p / 2).max(2), (2 * p).min(ten / 2)).unwrap_or(p as f64);
    let cycles = ((ten - 2 * LOOP_MARGIN) as f64 / pm).floor().max(1.0) as usize;
    let seam = |len: usize| -> f64 {
        // The frame before the loop should be the loop's last frame, and the one before it too.
        let (a, b) = (n - LOOP_MARGIN - 1, n - LOOP_MARGIN - 1 - len);
        (0..2).map(|k| (0..d).map(|c| (y[(a - k) * d + c] - y[(b - k) * d + c]).powi(2)).sum::<f64>()).sum()
    };
    let target = (cycles as f64 * pm).round() as usize;
    let len = [target.saturating_sub(1), target, target + 1]
        .into_iter()
        .filter(|&l| l > 0 && l + 2 * LOOP_MARGIN + 2 <= n)
        .min_by(|a, b| seam(*a).total_cmp(&seam(*b)))
        .unwrap_or(target);
    let from = n - len - 2 * LOOP_MARGIN;
    let units = cpg_reservoir::to_units(&m.outputs, &y[from * d..]);
    let mapped = map.apply(robot, names, &units, rate)?;
    let cut = |t: &JointTrajectory, a: usize, k: usize| -> JointTrajectory {
        let j = t.joints.len();
        let mut c = t.clone();
        c.values_rad = t.values_rad[a * j..(a + k) * j].to_vec();
        c.velocities_rad_s = t.velocities_rad_s[a * j..(a + k) * j].to_vec();
        c.accelerations_rad_s2 = t.accelerations_rad_s2[a * j..(a + k) * j].to_vec();
        for r in &mut c.clamps.joints {
            r.n_frames = k;
        }
        c
    };
    let asked_model_rate = cut(&mapped, LOOP_MARGIN, len);
    let trajectory = asked_model_rate.limit_loop(robot, a_max)?;
    let span_s = mapped.n_frames() as f64 / rate;
    let n_1khz_all = JointTrajectory::check_rate(1000.0, span_s, mapped.joints.len())?;
    let fast_all = mapped.resample(robot, 1000.0, n_1khz_all)?;
    let start_1khz = (LOOP_MARGIN as f64 / rate * 1000.0).round() as usize;
    let n_1khz = (len as f64 / rate * 1000.0).round() as usize;
    let asked_1khz = cut(&fast_all, start_1khz, n_1khz);
    let fast = asked_1khz.limit_loop(robot, a_max)?;
    let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let dj = fast.joints.len();
    let mut n_outside_range = 0;
    let mut velocity_limit_rad_s = f64::INFINITY;
    let mut within_speed = true;
    for (j, name) in fast.joints.iter().enumerate() {
        let joint = robot.joint(name)?;
        velocity_limit_rad_s = velocity_limit_rad_s.min(joint.velocity_rad_s);
        let col = JointTrajectory::column(&fast.values_rad, dj, j);
        n_outside_range += col.iter().filter(|q| !(joint.lower_rad..=joint.upper_rad).contains(*q)).count();
        within_speed &= JointTrajectory::column(&fast.velocities_rad_s, dj, j)
            .iter()
            .all(|v| v.abs() <= joint.velocity_rad_s + 1e-9);
    }
    let max_acceleration_rad_s2 = max_abs(&fast.accelerations_rad_s2);
    let frames = (fast.clamps.joints.len() * fast.n_frames()).max(1) as f64;
    let share =
        |f: fn(&cpg_robot::JointClamp) -> usize| fast.clamps.joints.iter().map(f).sum::<usize>() as f64 / frames;
    let nf = fast.n_frames();
    let loop_seam_rad =
        (0..dj).map(|j| (fast.values_rad[j] - fast.values_rad[(nf - 1) * dj + j]).abs()).fold(0.0, f64::max);
    let loop_max_step_rad = fast
        .values_rad
        .chunks_exact(dj)
        .collect::<Vec<_>>()
        .windows(2)
        .fold(0.0f64, |mx, w| w[0].iter().zip(w[1]).fold(mx, |mx, (a, b)| mx.max((b - a).abs())));
    let spec = robot.spec()?;
    let sole = spec.feet.sole_in_ankle_m;
    let robot_gait = cpg_robot::gait(
        &robot.path(&trajectory, &spec.legs.left.ankle_roll, sole)?,
        &robot.path(&trajectory, &spec.legs.right.ankle_roll, sole)?,
        rate,
        0,
        2,
    );
    let (human_gait_scaled, leg_scale) = human_gait(prep, names, robot, rate)?;
    Ok(Hoap2 {
        robot_gait,
        human_gait_scaled,
        leg_scale,
        clamps: fast.clamps.clone(),
        acceleration_bound_rad_s2: a_max,
        velocity_limit_rad_s,
        max_speed_rad_s: max_abs(&fast.velocities_rad_s),
        max_acceleration_rad_s2,
        n_outside_range,
        within_limits: n_outside_range == 0 && within_speed && max_acceleration_rad_s2 <= a_max + 1e-6,
        share_position_clamped: share(|c| c.n_clamped),
        share_velocity_limited: share(|c| c.n_velocity_limited),
        share_acceleration_limited: share(|c| c.n_acceleration_limited),
        loop_frames: len,
        loop_cycles: cycles,
        loop_seam_rad,
        loop_max_step_rad,
        trajectory,
        trajectory_1khz: fast,
        asked_1khz,
    })
}

/// The phase of channel `ch` of `win` against its own teacher cycle, frames
/// (to a fraction of a frame), from three cycles of the window.
fn shift_of(teacher: &cpg_reservoir::Teacher, d: usize, p: usize, win: &[f64], ch: usize) -> f64 {
    let cyc = column(&teacher.cycle, d, ch);
    align_to_cycle_fine(&column(win, d, ch)[..3 * p], &cyc, 1).0
}

/// How far channel `ch` of `win` is from the teacher's phase relation to the reference, cycles.
fn deviation(teacher: &cpg_reservoir::Teacher, d: usize, p: usize, win: &[f64], ch: usize, refc: usize) -> f64 {
    wrap((shift_of(teacher, d, p, win, ch) - shift_of(teacher, d, p, win, refc)) / p as f64)
}

/// Every joint's deviation in consecutive 10-s windows of the run (the last one ending at its end).
fn deviation_over_time(
    prep: &Prepared,
    y: &[f64],
    n: usize,
    ten: usize,
    p: usize,
    refc: usize,
) -> Vec<(f64, Vec<f64>)> {
    let d = prep.outputs.len();
    let Some(teacher) = prep.teachers.first() else { return Vec::new() };
    let rate = ten as f64 / 10.0;
    let mut starts: Vec<usize> = (0..n.saturating_sub(ten)).step_by(ten).collect();
    if starts.last() != Some(&(n - ten)) {
        starts.push(n - ten);
    }
    starts
        .into_par_iter()
        .map(|a| {
            let win = &y[a * d..(a + ten) * d];
            (a as f64 / rate, (0..d).map(|ch| deviation(teacher, d, p, win, ch, refc)).collect())
        })
        .collect()
}

/// Every joint's lag and drift over a free run `y` of `n` steps (`ten` steps
/// in 10 s, `p` frames per teacher cycle, `refc` the reference channel).
fn lag_rows(prep: &Prepared, y: &[f64], n: usize, ten: usize, p: usize, refc: usize) -> Vec<LagRow> {
    let d = prep.outputs.len();
    let Some(teacher) = prep.teachers.first() else { return Vec::new() };
    let start_win = &y[..ten * d];
    let end_win = &y[(n - ten) * d..];
    let teach = cpg_mocap::cycle::tile(&teacher.cycle, d, ten, 0);
    let (align, _) = align_to_cycle(&end_win[(ten - p) * d..], &teacher.cycle, d);
    prep.outputs
        .iter()
        .enumerate()
        .map(|(ch, o)| {
            let ds = deviation(teacher, d, p, start_win, ch, refc);
            let de = deviation(teacher, d, p, end_win, ch, refc);
            let last = column(&end_win[(ten - p) * d..], d, ch);
            let tc: Vec<f64> = (0..p).map(|q| teacher.cycle[((align + q) % p) * d + ch]).collect();
            let teacher_lag = lag(&column(&teach, d, refc), &column(&teach, d, ch), p / 2) / p as f64;
            let model_lag_end = lag(&column(end_win, d, refc), &column(end_win, d, ch), p / 2) / p as f64;
            LagRow {
                joint: o.name.clone(),
                teacher_lag,
                model_lag_end,
                lag_change: wrap(model_lag_end - teacher_lag),
                deviation_start: ds,
                deviation_end: de,
                drift: wrap(de - ds),
                cycle_nmse: crate::experiment::stability::nmse(&last, &tc, 1),
            }
        })
        .collect()
}

fn worst(rows: &[LagRow]) -> f64 {
    rows.iter().map(|r| r.drift.abs()).fold(0.0, f64::max)
}

fn median_nmse(rows: &[LagRow]) -> f64 {
    crate::stats::median(&rows.iter().map(|r| r.cycle_nmse).collect::<Vec<_>>())
}

/// The human's gait in the first recorded segment: ankle paths relative to
/// the root (root rotation 0, y up, facing +z), lengths scaled to HOAP-2's
/// legs; and the scale (HOAP-2's thigh + shank over the human's femur + tibia).
fn human_gait(prep: &Prepared, names: &[String], robot: &Robot, rate: f64) -> Result<(Option<cpg_robot::Gait>, f64)> {
    let Some(sk) = &prep.skeleton else { return Ok((None, f64::NAN)) };
    let bone = |n: &str| sk.bones.iter().find(|b| b.name == n).map(|b| b.length * sk.mm_per_unit() / 1000.0);
    let robot_leg = robot.joint("lleg_joint_4")?.origin_m[2].abs() + robot.joint("lleg_joint_5")?.origin_m[2].abs();
    let (Some(femur), Some(tibia), Some(seg)) = (bone("lfemur"), bone("ltibia"), prep.segments.first()) else {
        return Ok((None, f64::NAN));
    };
    let scale = robot_leg / (femur + tibia);
    let units = cpg_reservoir::to_units(&prep.outputs, seg);
    let channels = names
        .iter()
        .map(|n| {
            cpg_mocap::Channel::parse(n).ok_or_else(|| crate::Error::name(n, format!("'{n}' is not a mocap channel")))
        })
        .collect::<Result<Vec<_>>>()?;
    let m = sk.complete(&cpg_mocap::Motion::new(channels, units, rate)?)?;
    let p = sk.forward_kinematics(&m)?;
    let path = |point: &str| -> Option<Vec<[f64; 3]>> {
        let k = p.point_index(point)?;
        let root = p.point_index("root")?;
        Some(
            (0..p.n_frames())
                .map(|f| {
                    let (a, r) = (p.frame(f)[k], p.frame(f)[root]);
                    [(a[0] - r[0]) / 1000.0 * scale, (a[1] - r[1]) / 1000.0 * scale, (a[2] - r[2]) / 1000.0 * scale]
                })
                .collect(),
        )
    };
    let (Some(l), Some(r)) = (path("ltibia"), path("rtibia")) else { return Ok((None, scale)) };
    Ok((cpg_robot::gait(&l, &r, rate, 2, 1), scale))
}

impl super::Experiment for CouplingResult {
    fn figure(&self) -> &'static str {
        "Fig. 5"
    }
    super::common_accessors!();
    fn passed(&self) -> (usize, usize) {
        (self.n_passed(), self.seeds.len())
    }
    fn target(&self) -> &'static str {
        "phase coupling kept"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        section::coupling(&mut s, all, ctx);
        section::hoap2(&mut s, all);
        for r in all {
            section::last_10_s(&mut s, r)?;
        }
        Ok(s)
    }
}

//! E6: many outputs (the 22 HOAP-2 joints) and their phase coupling over a
//! long free run (wyffels & Schrauwen 2009, Fig. 5).

use serde::Serialize;

use cpg_hoap2::{ChannelMap, ClampReport, JointTrajectory, Robot};
use cpg_mocap::cycle::{align_to_cycle, lag};
use cpg_reservoir::TrainedCpg;

use rayon::prelude::*;

use super::{Header, Options, Progress, SeedModel, header, section};
use crate::config::{Config, CouplingTestSection};
use crate::error::{Error, Result};
use crate::measure::{RunSpec, column, free_runs};
use crate::prepare::{Prepared, prepare};
use crate::schedule::ControlSchedule;
use crate::train::{reservoir_for, train_prepared_on};

/// Largest drift of a joint's phase lag over the run for a seed to pass, cycles.
pub const DRIFT_TOLERANCE: f64 = 0.05;
/// Fraction of seeds that must keep the phase coupling.
pub const SEED_FRACTION: f64 = 0.8;
/// The rule of the E6 verdict, as printed beside it.
pub const RULE: &str = "at least 80 % of the seeds keep the phase coupling: no joint's lag behind the reference drifts by 0.05 cycle or more between the first and the last 10 s";

/// One seed of E6.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CouplingSeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// Largest |drift| of a joint, cycles.
    pub worst_drift: f64,
    /// Median per-joint cycle NMSE.
    pub median_cycle_nmse: f64,
    /// No joint drifted by [`DRIFT_TOLERANCE`] or more.
    pub passed: bool,
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
    /// The model's phase relative to the teacher's phase relation in the first 10 s, cycles
    /// (0: exactly the teacher's lag; from aligning the joint's own teacher cycle).
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
    /// The robot's gait (HOAP-2 kinematics of the commanded angles, soles in the trunk frame).
    pub robot_gait: Option<cpg_hoap2::Gait>,
    /// The human's gait in the recorded segment (ankles relative to the root), lengths
    /// multiplied by [`Hoap2::leg_scale`].
    pub human_gait_scaled: Option<cpg_hoap2::Gait>,
    /// HOAP-2's leg length (thigh + shank) over the human's (femur + tibia).
    pub leg_scale: f64,
    /// The trajectory at the model's rate (radians).
    #[serde(skip)]
    pub trajectory: JointTrajectory,
    /// The trajectory at 1 kHz (radians).
    #[serde(skip)]
    pub trajectory_1khz: JointTrajectory,
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
    /// The verdict over the seeds.
    pub passed: bool,
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
    pub fn verdict(&self) -> super::Verdict {
        super::Verdict { passed: self.passed, rule: RULE }
    }

    /// Seeds that kept the coupling.
    pub fn n_passed(&self) -> usize {
        self.seeds.iter().filter(|s| s.passed).count()
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
    let teacher = prep.teachers.first().ok_or_else(|| Error::Data("E6 needs a looped (periodic) segment".into()))?;
    let p = teacher.cycle.len() / d;
    let refc = prep.outputs.iter().position(|o| o.name == k.reference).ok_or_else(|| {
        c.error("experiment.coupling.reference", format!("'{}' is not a learnt channel", k.reference))
    })?;
    let run_s = if opts.quick { k.quick_run_s } else { k.run_s };
    let n = (run_s * rate).round() as usize;
    let ten = (10.0 * rate) as usize;
    if n < 2 * ten {
        return Err(c.error("experiment.coupling.run_s", "must be at least 20 s"));
    }
    Ok(Plan { c, k: k.clone(), seeds, prep, d, p, refc, n, ten })
}

/// Runs E6 on configuration `c`: every seed trained and run; the first
/// seed's run is shown in full (tables, portraits, view, HOAP-2).
pub fn run(c: &Config, k: &CouplingTestSection, opts: Options, progress: &dyn Progress) -> Result<CouplingResult> {
    let mut v = run_together(&[(c, k)], opts, progress)?;
    v.pop().ok_or_else(|| Error::Data("E6 ran no configuration".into()))
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
        plans.iter().map(|pl| train_prepared_on(&pl.c, &pl.prep, seed, Some(drawn.clone()))).collect()
    };
    let width = rayon::current_num_threads().max(1);
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
            let ys = free_runs(&specs)?;
            drop(specs);
            for (p, ((m, y), pl)) in models.into_iter().zip(ys).zip(&plans).enumerate() {
                let rows = lag_rows(&pl.prep, &y, pl.n, pl.ten, pl.p, pl.refc);
                all[p].push(CouplingSeed {
                    model: SeedModel::of(&m, seed),
                    worst_drift: worst(&rows),
                    median_cycle_nmse: median_nmse(&rows),
                    passed: worst(&rows) < DRIFT_TOLERANCE,
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
    let (m, y, rows) = first.ok_or_else(|| Error::Data("E6 ran no seed".into()))?;
    let end_win = &y[(n - ten) * d..];
    let worst_drift = worst(&rows);
    let median_cycle_nmse = median_nmse(&rows);
    let last10_units: Vec<f64> =
        end_win.iter().enumerate().map(|(i, v)| v * m.outputs[i % d].std + m.outputs[i % d].mean).collect();
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
            acceleration_rad_s2: cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2,
        }),
    )?;
    let hoap2 = match &robot {
        Some((robot, map)) => {
            let a_max = cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2;
            let mapped = map.apply(robot, &names, &last10_units, rate)?;
            let trajectory = mapped.limit(robot, a_max)?;
            let n_1khz = JointTrajectory::check_rate(1000.0, mapped.n_frames() as f64 / rate, mapped.joints.len())?;
            let fast = mapped.resample(robot, 1000.0, n_1khz)?.limit(robot, a_max)?;
            let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let d = fast.joints.len();
            let mut n_outside_range = 0;
            for (j, name) in fast.joints.iter().enumerate() {
                let joint = robot.joint(name)?;
                n_outside_range += fast
                    .values_rad
                    .iter()
                    .skip(j)
                    .step_by(d)
                    .filter(|q| !(joint.lower_rad..=joint.upper_rad).contains(*q))
                    .count();
            }
            let sole = cpg_hoap2::SOLE_IN_ANKLE_M;
            let robot_gait = cpg_hoap2::gait(
                &robot.path(&trajectory, "lleg_joint_6", sole)?,
                &robot.path(&trajectory, "rleg_joint_6", sole)?,
                rate,
                0,
                2,
            );
            let (human_gait_scaled, leg_scale) = human_gait(prep, &names, robot, rate)?;
            Some(Hoap2 {
                robot_gait,
                human_gait_scaled,
                leg_scale,
                clamps: fast.clamps.clone(),
                acceleration_bound_rad_s2: a_max,
                velocity_limit_rad_s: fast
                    .joints
                    .iter()
                    .map(|n| robot.joint(n).map(|j| j.velocity_rad_s))
                    .collect::<std::result::Result<Vec<_>, _>>()?
                    .into_iter()
                    .fold(f64::INFINITY, f64::min),
                max_speed_rad_s: max_abs(&fast.velocities_rad_s),
                max_acceleration_rad_s2: max_abs(&fast.accelerations_rad_s2),
                n_outside_range,
                trajectory,
                trajectory_1khz: fast,
            })
        }
        None => None,
    };
    let from = ((500.0 * rate) as usize).min(n - ten);
    let data = prep.segments.first().cloned().unwrap_or_default();
    let portraits =
        k.portraits
            .iter()
            .map(|name| {
                let ch = names.iter().position(|x| x == name).ok_or_else(|| {
                    c.error("experiment.coupling.portraits", format!("'{name}' is not a learnt channel"))
                })?;
                let dp = data.chunks_exact(d).map(|f| (f[refc], f[ch])).collect();
                let mp = (from..from + ten).map(|q| (y[q * d + refc], y[q * d + ch])).collect();
                Ok(Portrait { channel: name.clone(), data: dp, model: mp })
            })
            .collect::<Result<Vec<_>>>()?;
    let passed = super::enough(all.iter().filter(|s| s.passed).count(), all.len(), SEED_FRACTION);
    Ok(CouplingResult {
        header: header(c, prep, m.reservoir.n_neurons())?,
        model: all.first().map(|s| s.model.clone()).unwrap_or_else(|| SeedModel::of(&m, c.reservoir.seed)),
        seeds: all,
        steps: n,
        run_s: n as f64 / rate,
        reference: k.reference.clone(),
        period_frames: p,
        passed,
        rows,
        worst_drift,
        median_cycle_nmse,
        hoap2,
        portrait_from_s: from as f64 / rate,
        portraits,
        last10_units,
        view: Some(view),
        trained: Some(m),
    })
}

/// Every joint's lag and drift over a free run `y` of `n` steps (`ten` steps
/// in 10 s, `p` frames per teacher cycle, `refc` the reference channel).
fn lag_rows(prep: &Prepared, y: &[f64], n: usize, ten: usize, p: usize, refc: usize) -> Vec<LagRow> {
    let d = prep.outputs.len();
    let Some(teacher) = prep.teachers.first() else { return Vec::new() };
    let start_win = &y[..ten * d];
    let end_win = &y[(n - ten) * d..];
    let teach = cpg_mocap::cycle::tile(&teacher.cycle, d, ten, 0);
    let shift_of = |win: &[f64], ch: usize| -> f64 {
        let cyc = column(&teacher.cycle, d, ch);
        align_to_cycle(&column(win, d, ch)[..3 * p], &cyc, 1).0 as f64
    };
    let deviation = |win: &[f64], ch: usize| wrap((shift_of(win, ch) - shift_of(win, refc)) / p as f64);
    let (align, _) = align_to_cycle(&end_win[(ten - p) * d..], &teacher.cycle, d);
    prep.outputs
        .iter()
        .enumerate()
        .map(|(ch, o)| {
            let ds = deviation(start_win, ch);
            let de = deviation(end_win, ch);
            let last = column(&end_win[(ten - p) * d..], d, ch);
            let tc: Vec<f64> = (0..p).map(|q| teacher.cycle[((align + q) % p) * d + ch]).collect();
            LagRow {
                joint: o.name.clone(),
                teacher_lag: lag(&column(&teach, d, refc), &column(&teach, d, ch), p / 2) / p as f64,
                model_lag_end: lag(&column(end_win, d, refc), &column(end_win, d, ch), p / 2) / p as f64,
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
    let mut v: Vec<f64> = rows.iter().map(|r| r.cycle_nmse).collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The human's gait in the first recorded segment: ankle paths relative to
/// the root (root rotation 0, y up, facing +z), lengths scaled to HOAP-2's
/// legs; and the scale (HOAP-2's thigh + shank over the human's femur + tibia).
fn human_gait(prep: &Prepared, names: &[String], robot: &Robot, rate: f64) -> Result<(Option<cpg_hoap2::Gait>, f64)> {
    let Some(sk) = &prep.skeleton else { return Ok((None, f64::NAN)) };
    let bone = |n: &str| sk.bones.iter().find(|b| b.name == n).map(|b| b.length * sk.mm_per_unit() / 1000.0);
    let robot_leg = robot.joint("lleg_joint_4")?.origin_m[2].abs() + robot.joint("lleg_joint_5")?.origin_m[2].abs();
    let (Some(femur), Some(tibia), Some(seg)) = (bone("lfemur"), bone("ltibia"), prep.segments.first()) else {
        return Ok((None, f64::NAN));
    };
    let scale = robot_leg / (femur + tibia);
    let d = names.len();
    let units: Vec<f64> =
        seg.iter().enumerate().map(|(i, z)| z * prep.outputs[i % d].std + prep.outputs[i % d].mean).collect();
    let channels = names
        .iter()
        .map(|n| {
            cpg_mocap::Channel::parse(n).ok_or_else(|| crate::Error::Data(format!("'{n}' is not a mocap channel")))
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
    Ok((cpg_hoap2::gait(&l, &r, rate, 2, 1), scale))
}

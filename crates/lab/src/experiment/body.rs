//! The whole body in one generator: every rotation channel of a subject
//! standing, walking and running, selected by control inputs, each gait
//! judged against recorded trials that training never read, and the states
//! switched in one free run.
//!
//! **Held-out cycles.** Each held-out trial's best seamless loop of one
//! stride (found as training finds its loops, on the model's normalisation)
//! is time-normalised to [`PHASES`] samples in the channels' own units
//! (degrees). A generated cycle is the last period of the gait's free run,
//! sampled the same way. The error of one cycle against another is the RMS
//! over every channel and phase at the circular shift that makes it
//! smallest; the held-out trials' **spread** is that error between every
//! pair of them: what a new trial of the same person makes.

mod section;

use rayon::prelude::*;
use serde::Serialize;

use super::claim::{Claim, Measure, Source, Verdict};
use super::{Header, Judged, Options, Progress, SeedModel, header, seeds, train_seeds, verdict_over};
use crate::config::{Config, WholeBodySection};
use crate::error::Result;
use crate::measure::{
    CONTACT_MM, FEET, FLOOR_QUANTILE, RunSpec, STILL_SWING, WINDOW_S, channel_steps, column, floors, foot_slide_mm,
    free_runs, max_step, settle_on_orbit,
};
use crate::schedule::ControlSchedule;
use crate::stats::{Proportion, at_limit, median};
use crate::travel::{CLEAR_MM, PLANT_MM_S};
use cpg_mocap::cycle::{best_loop, estimate_period, half_range, tile};
use cpg_reservoir::{Teacher, TrainedCpg};

/// A gait's period must lie within the range of every recorded trial of that
/// gait (training and held-out), widened by this share on both sides; and a
/// gap of more than this to the training trials' median is a fault of the
/// teacher or of the generator (the report says which).
pub const PERIOD_TOLERANCE: f64 = 0.02;
/// A channel's amplitude (half range) must lie within the held-out trials'
/// own range widened on both sides by this share of their median…
pub const AMPLITUDE_TOLERANCE: f64 = 0.15;
/// …or, for a channel that barely moves in them (a median half range below
/// this), by this many degrees.
pub const BARELY_MOVES_DEG: f64 = 1.0;
/// Share of the channels a gait must hold within the amplitude rule (besides
/// every channel its training teacher holds).
pub const CHANNEL_SHARE: f64 = 0.95;
/// A switch settles within this many strides of the state it reaches (of
/// the state it leaves when it reaches a posture).
pub const SETTLE_STRIDES: f64 = 2.0;
/// Samples of a time-normalised cycle.
pub const PHASES: usize = 100;
/// Largest slide of a foot on the ground during one stance when the data
/// give no yardstick (no skeleton, no recorded rhythm), mm; otherwise the
/// recorded training trials' own largest slide by the same measure is the bound.
pub const SLIDE_MM: f64 = 20.0;

/// The robot's command rate, Hz.
pub const ROBOT_RATE_HZ: f64 = 1000.0;

/// Fraction of the seeds that must pass everything.
pub const SEED_FRACTION: f64 = 0.9;
/// Largest distance from the posture while standing, degrees.
pub const STAND_TOLERANCE_DEG: f64 = crate::measure::POSTURE_TOLERANCE;
/// Largest distance of a length from the posture while standing, and largest
/// travel over the judged stretch, mm (the bound on a foot's slide).
pub const STAND_TOLERANCE_MM: f64 = 20.0;

/// The rule of the whole body's verdict, as printed beside it.
pub fn rule(b: &WholeBodySection) -> String {
    format!(
        "standing: every rotation within {STAND_TOLERANCE_DEG}° of the posture and swinging less than {STILL_SWING}°, the root's height within {STAND_TOLERANCE_MM} mm and the figure travelling at most {STAND_TOLERANCE_MM} mm over the last {} s of a {} s free run; {}; every switch of the switching run on the orbit the generator keeps with the new inputs held within {SETTLE_STRIDES} strides of the ramp's end, no channel stepping further between frames than its largest step in every recorded trial of the person (training and held-out, as the period's range), no foot sliding during a stance more than the recorded training trials' own largest slide",
        b.stand_s,
        b.run_s,
        gait_rule(b.run_s)
    )
}

/// The rule of one gait, as printed beside its verdict.
pub fn gait_rule(run_s: f64) -> String {
    format!(
        "each gait after {run_s} s of free run (its last {WINDOW_S} s): the period within the range of every recorded trial of that gait (training and held-out) widened by {:.0} %; at least {:.0} % of the channels, and every channel the training teacher holds, with an amplitude (half range) within the held-out trials' own range widened on both sides by {:.0} % of their median (by {BARELY_MOVES_DEG}° for a channel whose median is below {BARELY_MOVES_DEG}°); the cycle's RMS error against the held-out trials (median over them) at most their spread (the median of their pairwise errors)",
        100.0 * PERIOD_TOLERANCE,
        100.0 * CHANNEL_SHARE,
        100.0 * AMPLITUDE_TOLERANCE
    )
}

/// One held-out trial's stride.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutTrial {
    /// The file's name.
    pub label: String,
    /// Its period, frames.
    pub period_frames: f64,
    /// Each channel's half range over the loop, in its units.
    pub amplitude: Vec<f64>,
    /// The loop time-normalised (`PHASES × d`, the channels' units).
    #[serde(skip)]
    pub cycle: Vec<f64>,
}

/// The held-out trials of one gait.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOutGait {
    /// The teacher they judge.
    pub teacher: String,
    /// The trials.
    pub trials: Vec<HeldOutTrial>,
    /// Their median period, frames.
    pub period_frames: f64,
    /// Each channel's median half range.
    pub amplitude: Vec<f64>,
    /// Each channel's smallest and largest half range over the trials, as a ratio to the median.
    pub amplitude_range: Vec<(f64, f64)>,
    /// Each channel's allowed half range (the trials' range widened), in its units.
    pub amplitude_bounds: Vec<(f64, f64)>,
    /// The training trials' own periods, frames (their loops).
    pub train_periods: Vec<f64>,
    /// The allowed period: the range of every recorded trial of the gait, widened, frames.
    pub period_bounds: (f64, f64),
    /// The training teacher's own period, frames.
    pub teacher_period: f64,
    /// Per channel, whether the training teacher holds the amplitude rule.
    pub teacher_channel_ok: Vec<bool>,
    /// Other teachers the training trials could give, judged by the same
    /// amplitude rule: (what, channels within). Reported, never chosen by
    /// it (choosing on the held-out trials would be tuning on the test).
    pub teacher_alternatives: Vec<(String, usize)>,
    /// The error of every pair of trials (RMS over channels and phases).
    pub pair_errors: Vec<f64>,
    /// Their median: the spread.
    pub spread: f64,
    /// Each channel's half range in the training teacher, in its units.
    pub teacher_amplitude: Vec<f64>,
    /// The training teacher judged as a generated cycle would be: channels
    /// within the amplitude tolerance (what a perfect copy of the training
    /// data scores: the yardstick for what the generator could reach).
    pub teacher_within: usize,
    /// Its cycle error against the held-out trials (median over them).
    pub teacher_error: f64,
    /// Per channel, the median over pairs of its RMS error at each pair's best shift.
    pub channel_spread: Vec<f64>,
    /// Each channel's largest frame-to-frame step in the trials, normalised units.
    pub steps: Vec<f64>,
    /// The training teacher's cycle time-normalised (`PHASES × d`, the
    /// channels' units), at its best shift against the first held-out trial.
    #[serde(skip)]
    pub teacher_cycle: Vec<f64>,
}

/// A gait of one seed, judged against its held-out trials.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodyGait {
    /// The teacher.
    pub teacher: String,
    /// The period of the end of the run, steps (`None`: no rhythm).
    pub period_steps: Option<f64>,
    /// The held-out trials' median period, steps.
    pub held_out_period_steps: f64,
    /// Each channel's half range over the last window, in its units.
    pub amplitude: Vec<f64>,
    /// Each channel's own period over the last window, steps (`None`: too still to say).
    pub channel_period_steps: Vec<Option<f64>>,
    /// The channel whose amplitude is furthest off, and its ratio to the held-out median.
    pub worst_amplitude: (String, f64),
    /// Channels within the amplitude rule.
    pub amplitudes_within: usize,
    /// Per channel, within the amplitude rule.
    pub channel_ok: Vec<bool>,
    /// Channels the training teacher holds and this run does not (the generator's fault).
    pub lost: Vec<String>,
    /// The cycle's error against each held-out trial, in their order.
    pub errors: Vec<f64>,
    /// Their median.
    pub error: f64,
    /// Per channel, the median over the trials of its RMS error.
    pub channel_error: Vec<f64>,
    /// The period within its range.
    pub period_ok: bool,
    /// Enough amplitudes within the rule, every one the teacher holds among them.
    pub amplitude_ok: bool,
    /// The error at most the spread.
    pub error_ok: bool,
    /// All three.
    pub passed: bool,
    /// A comparison that decided it was closer than the report prints.
    pub at_limit: bool,
    /// The run's last cycle time-normalised (`PHASES × d`, the channels'
    /// units), at its best shift against the first held-out trial; empty
    /// without a rhythm.
    #[serde(skip)]
    pub cycle: Vec<f64>,
}

/// The standing run of one seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodyStand {
    /// Largest distance of any rotation from the posture over the judged stretch, degrees.
    pub deviation: f64,
    /// The channel that went furthest.
    pub worst_channel: String,
    /// Largest half range of any rotation over the judged stretch, degrees.
    pub swing: f64,
    /// Largest distance of a length (the root's height) from the posture, mm.
    pub length_deviation_mm: f64,
    /// How far the figure travelled over the judged stretch (its integrated rates), mm.
    pub travel_mm: f64,
    /// Within the tolerances and still.
    pub passed: bool,
    /// Decided by less than the printed digits.
    pub at_limit: bool,
}

/// One switch of the switching run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodySwitch {
    /// The state left.
    pub from: String,
    /// The state reached.
    pub to: String,
    /// When the ramp starts, seconds.
    pub at_s: f64,
    /// Seconds from the ramp's end until back on the new state's orbit for good (`None`: never).
    pub settle_s: Option<f64>,
    /// The stride the settling is counted in, seconds.
    pub stride_s: f64,
    /// Largest frame-to-frame step from the switch to the next, normalised units.
    pub max_step: f64,
    /// The largest ratio of a channel's step to that channel's largest in every recorded trial (training and held-out).
    pub step_ratio: f64,
    /// The channel of that ratio.
    pub step_channel: String,
    /// The largest slide of a foot on the ground from the switch to the next, mm (`None`: no skeleton).
    pub slide_mm: Option<f64>,
    /// The same before the feet's cleanup ([`crate::travel`]): the legs as
    /// the generator gives them, a foot dragged while the other bears the weight, mm.
    pub raw_slide_mm: Option<f64>,
    /// The largest change the feet's cleanup made to a leg's rotation from
    /// the switch to the next, degrees (`None`: no skeleton).
    pub cleanup_deg: Option<f64>,
    /// Settled within the strides, no step beyond the data's.
    pub passed: bool,
    /// Decided by less than the printed digits.
    pub at_limit: bool,
}

/// One seed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BodySeed {
    /// How the model was trained.
    pub model: SeedModel,
    /// Standing.
    pub stand: BodyStand,
    /// Each judged gait.
    pub gaits: Vec<BodyGait>,
    /// Each switch.
    pub switches: Vec<BodySwitch>,
    /// Everything held.
    pub passed: bool,
    /// A comparison that decided it was closer than the report prints.
    pub at_limit: bool,
}

/// The whole body over seeds.
#[derive(Debug, Clone, Serialize)]
pub struct BodyResult {
    /// What was run.
    pub header: Header,
    /// The test's settings.
    pub test: WholeBodySection,
    /// The channels, in the model's order.
    pub channels: Vec<String>,
    /// The teachers' labels, in the model's order.
    pub teachers: Vec<String>,
    /// The held-out trials of each judged gait.
    pub held_out: Vec<HeldOutGait>,
    /// The largest frame-to-frame step in the teachers' cycles (each round its seam), normalised units.
    pub data_step: f64,
    /// The largest in every recorded trial (training and held-out).
    pub recorded_step: f64,
    /// Each recorded training trial's largest foot slide by the same rule, mm (the yardstick of the data).
    pub data_slide_mm: Vec<(String, f64)>,
    /// The training sequence's own largest foot slide (its blends between states included), mm.
    pub teacher_slide_mm: Option<f64>,
    /// How the readout was learnt (`ridge`, `FORCE`).
    pub trainer: String,
    /// Seconds the training of every seed took, on the run's threads.
    pub train_wall_s: f64,
    /// Threads it ran on.
    pub threads: usize,
    /// Free-run length of each state, seconds.
    pub run_s: f64,
    /// Each channel's largest frame-to-frame step in every recorded trial (training and held-out), normalised units.
    pub data_steps: Vec<f64>,
    /// When each switch of the switching run starts, seconds.
    pub switch_at_s: Vec<f64>,
    /// Per seed.
    pub seeds: Vec<BodySeed>,
    /// The claims, measured.
    pub claims: Vec<Claim>,
    /// The section's other aggregates.
    pub table: Vec<Measure>,
    /// Every seed's switching run, the left femur's channel in its units, for the figure.
    #[serde(skip)]
    pub switch_runs: Vec<Vec<f64>>,
    /// The first seed's switching run on the robot (when the test names one):
    /// its mapped joints at 1 kHz within their ranges, velocity limits and the
    /// acceleration bound, as `cpg hoap2` and `cpg stream` keep them.
    pub robot: Option<cpg_robot::ClampReport>,
    /// The acceleration bound the robot's joints were kept within, rad/s².
    pub robot_acceleration_rad_s2: f64,
    /// Each mapped joint's velocity limit from the robot's URDF, rad/s (in [`Self::robot`]'s order).
    pub robot_velocity_limits_rad_s: Vec<f64>,
    /// The first seed's switching run as a scene for `cpg_view`.
    #[serde(skip)]
    pub view: Option<cpg_view::Scene>,
}

/// `cycle` (`p × d`, any `p ≥ 1`) sampled at [`PHASES`] evenly spaced phases.
fn time_normalised(cycle: &[f64], d: usize) -> Vec<f64> {
    let p = cycle.len() / d;
    (0..PHASES)
        .flat_map(|k| {
            let pos = k as f64 * p as f64 / PHASES as f64;
            (0..d).map(move |c| crate::prepare::periodic(cycle, p, d, pos, c))
        })
        .collect()
}

/// The last `period` steps of `y` (`T × d`; a fractional period) sampled at [`PHASES`] phases.
fn last_cycle(y: &[f64], d: usize, period: f64) -> Vec<f64> {
    let t = y.len() / d;
    let start = (t - 1) as f64 - period;
    let mut out = Vec::with_capacity(PHASES * d);
    for k in 0..PHASES {
        let pos = (start + k as f64 * period / PHASES as f64).max(0.0);
        let (i, f) = (pos.floor() as usize, pos.fract());
        let j = (i + 1).min(t - 1);
        out.extend((0..d).map(|c| (1.0 - f) * y[i * d + c] + f * y[j * d + c]));
    }
    out
}

/// The error of cycle `a` against cycle `b` (both `PHASES × d`) at the
/// circular shift that makes it smallest over the channels `counted` (the
/// rotations, all in degrees): the RMS over those channels and every phase,
/// and each channel's RMS at that shift.
fn cycle_error(a: &[f64], b: &[f64], d: usize, counted: &[bool]) -> (f64, Vec<f64>) {
    let sq = |s: usize, c: usize| -> f64 {
        (0..PHASES).map(|k| (a[k * d + c] - b[((k + s) % PHASES) * d + c]).powi(2)).sum()
    };
    let n = counted.iter().filter(|x| **x).count().max(1);
    let best = (0..PHASES)
        .map(|s| (s, (0..d).filter(|&c| counted[c]).map(|c| sq(s, c)).sum::<f64>()))
        .fold((0, f64::INFINITY), |m, x| if x.1 < m.1 { x } else { m });
    let total = (best.1 / (PHASES * n) as f64).sqrt();
    (total, (0..d).map(|c| (sq(best.0, c) / PHASES as f64).sqrt()).collect())
}

/// Cycle `a` (`PHASES × d`) rotated to the shift at which it best matches `b`
/// over the channels `counted`: `a` drawn in `b`'s phase.
fn aligned(a: &[f64], b: &[f64], d: usize, counted: &[bool]) -> Vec<f64> {
    let cost = |s: usize| -> f64 {
        (0..PHASES)
            .map(|k| {
                (0..d)
                    .filter(|&c| counted[c])
                    .map(|c| (a[((k + s) % PHASES) * d + c] - b[k * d + c]).powi(2))
                    .sum::<f64>()
            })
            .sum()
    };
    let best = (0..PHASES).map(|s| (s, cost(s))).fold((0, f64::INFINITY), |m, x| if x.1 < m.1 { x } else { m }).0;
    (0..PHASES).flat_map(|k| a[((k + best) % PHASES) * d..][..d].iter().copied()).collect()
}

/// Which outputs are rotations (degrees): the channels the cycle error counts.
fn rotations(outputs: &[cpg_reservoir::OutputChannel]) -> Vec<bool> {
    outputs.iter().map(|o| crate::run::is_rotation(o.unit_name())).collect()
}

/// Each held-out trial of `h`'s gait read, its stride cut and time-normalised.
fn held_out(
    c: &Config,
    h: &crate::config::HeldOutSection,
    m: &TrainedCpg,
    sk: &cpg_mocap::Skeleton,
    k: usize,
) -> Result<HeldOutGait> {
    let d = m.outputs.len();
    let rate = c.data.rate_hz;
    let names: Vec<&str> = m.outputs.iter().map(|o| o.unit_name()).collect();
    let rates: Vec<usize> = (0..d).filter(|&k| m.outputs[k].integrates().is_some()).collect();
    let counted = rotations(&m.outputs);
    let period_channel = match &c.data.period_channel {
        Some(n) => Some(
            names
                .iter()
                .position(|x| x == n)
                .ok_or_else(|| c.error("data.period_channel", format!("'{n}' is not one of the learnt channels")))?,
        ),
        None => None,
    };
    let lo = (c.data.period_s[0] * rate).round() as usize;
    let hi = (c.data.period_s[1] * rate).round() as usize;
    let mut trials = Vec::with_capacity(h.motions.len());
    let mut steps = vec![0.0; d];
    for (i, path) in h.motions.iter().enumerate() {
        let key = format!("experiment.test.whole_body.held_out[{k}].motions[{i}]");
        let motion =
            crate::prepare::as_rates(&cpg_mocap::Motion::from_amc_file(path, sk, rate)?.select(&names)?, &rates)?;
        let units = motion.values();
        let z: Vec<f64> =
            units.chunks_exact(d).flat_map(|f| f.iter().zip(&m.outputs).map(|(v, o)| (v - o.mean) / o.std)).collect();
        let (p, _, _) = crate::prepare::gait_period(&z, d, lo, hi, period_channel).ok_or_else(|| {
            c.error(
                &key,
                format!("{}: no rhythm between {} and {} s", path.display(), c.data.period_s[0], c.data.period_s[1]),
            )
        })?;
        steps = widest(steps, channel_steps(&z, d));
        let lp = best_loop(&z, d, p, 1)
            .ok_or_else(|| c.error(&key, format!("{}: one cycle of {p:.1} frames does not fit", path.display())))?;
        let cycle = &units[lp.start * d..(lp.start + lp.len) * d];
        trials.push(HeldOutTrial {
            label: path.file_name().map_or_else(|| path.display().to_string(), |f| f.to_string_lossy().into_owned()),
            period_frames: p,
            amplitude: (0..d).map(|ch| half_range(&column(cycle, d, ch))).collect(),
            cycle: time_normalised(cycle, d),
        });
    }
    let amplitude: Vec<f64> =
        (0..d).map(|ch| median(&trials.iter().map(|t| t.amplitude[ch]).collect::<Vec<_>>())).collect();
    let amplitude_range: Vec<(f64, f64)> = (0..d)
        .map(|ch| {
            let r: Vec<f64> = trials.iter().map(|t| t.amplitude[ch] / amplitude[ch]).collect();
            (r.iter().copied().fold(f64::INFINITY, f64::min), r.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        })
        .collect();
    let mut pair_errors = Vec::new();
    let mut per_channel: Vec<Vec<f64>> = vec![Vec::new(); d];
    for i in 0..trials.len() {
        for j in i + 1..trials.len() {
            let (e, ch) = cycle_error(&trials[i].cycle, &trials[j].cycle, d, &counted);
            pair_errors.push(e);
            ch.into_iter().zip(&mut per_channel).for_each(|(v, p)| p.push(v));
        }
    }
    let amplitude_bounds = (0..d)
        .map(|ch| {
            let own = trials.iter().map(|t| t.amplitude[ch]);
            let (lo, hi) = own.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
            let m = amplitude[ch];
            let widen = if m < BARELY_MOVES_DEG { BARELY_MOVES_DEG } else { AMPLITUDE_TOLERANCE * m };
            (lo - widen, hi + widen)
        })
        .collect();
    Ok(HeldOutGait {
        teacher: h.teacher.clone(),
        period_frames: median(&trials.iter().map(|t| t.period_frames).collect::<Vec<_>>()),
        amplitude,
        amplitude_range,
        amplitude_bounds,
        train_periods: Vec::new(),
        period_bounds: (f64::NAN, f64::NAN),
        teacher_period: f64::NAN,
        teacher_channel_ok: Vec::new(),
        teacher_alternatives: Vec::new(),
        spread: median(&pair_errors),
        teacher_amplitude: Vec::new(),
        teacher_within: 0,
        teacher_error: f64::NAN,
        teacher_cycle: Vec::new(),
        channel_spread: per_channel.iter().map(|v| median(v)).collect(),
        pair_errors,
        trials,
        steps,
    })
}

/// Whether a held-out channel never moves (its median half range below [`STILL_SWING`]).
fn still(amplitude: f64) -> bool {
    amplitude < STILL_SWING
}

/// Whether a half range `a` holds channel `c`'s amplitude rule for `h`.
fn amplitude_holds(h: &HeldOutGait, c: usize, a: f64) -> bool {
    let (lo, hi) = h.amplitude_bounds[c];
    a >= lo && a <= hi
}

/// How close `a` is to channel `c`'s bounds, as a share of the rule's margin
/// there (0: on a bound), for the report's at-the-limit flag.
fn amplitude_near_bound(h: &HeldOutGait, c: usize, a: f64) -> bool {
    let (lo, hi) = h.amplitude_bounds[c];
    at_limit(a, lo, 2) || at_limit(a, hi, 2)
}

/// Judges the end of a gait's free run `y` (normalised) against its held-out trials.
fn judge_gait(m: &TrainedCpg, y: &[f64], h: &HeldOutGait, reference: usize, rate: f64) -> BodyGait {
    let d = m.outputs.len();
    let t = y.len() / d;
    let win = ((WINDOW_S * rate) as usize).max((3.0 * h.period_frames).ceil() as usize).min(t);
    let units = cpg_reservoir::to_units(&m.outputs, &y[(t - win) * d..]);
    let p = h.period_frames;
    let (lo, hi) = (((p / 2.0).floor() as usize).max(2), ((2.0 * p).ceil() as usize).min(win / 2));
    let amplitude: Vec<f64> = (0..d).map(|c| half_range(&column(&units, d, c))).collect();
    let channel_period_steps: Vec<Option<f64>> = (0..d)
        .map(|c| {
            if still(h.amplitude[c]) || still(amplitude[c]) {
                None
            } else {
                estimate_period(&column(&units, d, c), lo, hi)
            }
        })
        .collect();
    let period_steps = channel_period_steps[reference];
    let ratios: Vec<f64> = (0..d).map(|c| amplitude[c] / h.amplitude[c]).collect();
    let ok_channel = |c: usize| amplitude_holds(h, c, amplitude[c]);
    let worst = (0..d)
        .filter(|&c| !still(h.amplitude[c]))
        .max_by(|&a, &b| (ratios[a] - 1.0).abs().total_cmp(&(ratios[b] - 1.0).abs()));
    let worst_amplitude = worst.map_or((String::new(), 1.0), |c| (m.outputs[c].name.clone(), ratios[c]));
    let counted = rotations(&m.outputs);
    let cycle = period_steps.map(|ps| last_cycle(&units, d, ps));
    let (errors, per_channel): (Vec<f64>, Vec<Vec<f64>>) = match &cycle {
        Some(cycle) => h.trials.iter().map(|tr| cycle_error(cycle, &tr.cycle, d, &counted)).unzip(),
        None => (vec![f64::INFINITY; h.trials.len()], vec![vec![f64::INFINITY; d]; h.trials.len()]),
    };
    let cycle = match (cycle, h.trials.first()) {
        (Some(c), Some(first)) => aligned(&c, &first.cycle, d, &counted),
        _ => Vec::new(),
    };
    let error = median(&errors);
    let error = if errors.iter().all(|e| e.is_finite()) { error } else { f64::INFINITY };
    let channel_error = (0..d).map(|c| median(&per_channel.iter().map(|v| v[c]).collect::<Vec<_>>())).collect();
    let (lo, hi) = h.period_bounds;
    let period_ok = period_steps.is_some_and(|q| q >= lo && q <= hi);
    let period_near = period_steps.is_some_and(|q| at_limit(q / lo, 1.0, 3) || at_limit(q / hi, 1.0, 3));
    let channel_ok: Vec<bool> = (0..d).map(ok_channel).collect();
    let amplitudes_within = channel_ok.iter().filter(|x| **x).count();
    let lost: Vec<String> = (0..d)
        .filter(|&c| h.teacher_channel_ok.get(c).copied().unwrap_or(false) && !channel_ok[c])
        .map(|c| m.outputs[c].unit_name().to_owned())
        .collect();
    let needed = super::claim::seeds_needed(d, CHANNEL_SHARE);
    let amplitude_ok = amplitudes_within >= needed && lost.is_empty();
    let error_ok = error <= h.spread;
    let parts = [
        (period_ok, period_near),
        (amplitude_ok, {
            // At the limit only when the channels decided by less than the printed digits could
            // change the part's outcome: a passing channel near the bound, or every failing one.
            let near = |c: usize| amplitude_near_bound(h, c, amplitude[c]);
            if amplitude_ok {
                amplitudes_within == needed && (0..d).any(|c| channel_ok[c] && near(c))
            } else {
                (0..d).filter(|&c| !channel_ok[c]).all(near)
            }
        }),
        (error_ok, at_limit(error, h.spread, 2)),
    ];
    let (passed, at_limit) = combine(&parts);
    BodyGait {
        teacher: h.teacher.clone(),
        period_steps,
        held_out_period_steps: p,
        amplitude,
        channel_period_steps,
        worst_amplitude,
        amplitudes_within,
        channel_ok,
        lost,
        errors,
        error,
        channel_error,
        period_ok,
        amplitude_ok,
        error_ok,
        passed,
        at_limit,
        cycle,
    }
}

/// Whether every part held, and whether parts decided by a hair could change that.
fn combine(parts: &[(bool, bool)]) -> (bool, bool) {
    let passed = parts.iter().all(|p| p.0);
    let fragile = if passed { parts.iter().any(|p| p.1) } else { parts.iter().filter(|p| !p.0).all(|p| p.1) };
    (passed, fragile)
}

/// The orbit a free run `y` (normalised) ends on at a teacher's inputs: its
/// last frame for a posture, its last period (measured on `reference`, from
/// half to twice the teacher's) for a rhythm; `None` when it shows none.
fn own_orbit(y: &[f64], d: usize, t: &Teacher, reference: usize) -> Option<Vec<f64>> {
    let n = y.len() / d;
    if n == 0 {
        return None;
    }
    if t.is_posture(d) {
        return Some(y[(n - 1) * d..].to_vec());
    }
    let p = t.period_steps(d);
    let win = ((4.0 * p).ceil() as usize).min(n);
    let col = column(&y[(n - win) * d..], d, reference);
    let q = estimate_period(&col, ((p / 2.0).floor() as usize).max(2), ((2.0 * p).ceil() as usize).min(win / 2))?;
    let len = (q.round() as usize).clamp(2, n);
    Some(y[(n - len) * d..].to_vec())
}

/// The motion a run in units (`T × d`, rates integrated) is, as the skeleton
/// reads it.
fn as_motion(m: &TrainedCpg, y_units: &[f64]) -> Result<cpg_mocap::Motion> {
    Ok(cpg_mocap::Motion::new(crate::run::mocap_channels(m)?, y_units.to_vec(), m.provenance.sample_rate_hz)?)
}

/// Labelled values (a trial's name and its figure).
type Labelled = Vec<(String, f64)>;

/// The feet's yardsticks: each recorded rhythm segment of the training data
/// (the posture aside) with its largest foot slide by [`foot_slide_mm`]'s
/// rule, mm; the training sequence's own largest (its blends included); and
/// the feet's floors the recorded trials give.
fn data_slides(
    c: &Config,
    prep: &crate::prepare::Prepared,
    m: &TrainedCpg,
) -> Result<(Labelled, Option<f64>, Vec<f64>)> {
    let Some(sk) = &prep.skeleton else { return Ok((Vec::new(), None, vec![0.0; FEET.len()])) };
    let feet = crate::measure::feet(sk);
    let rate = c.data.rate_hz;
    // The recorded trials travel as recorded; the training sequence (its
    // blends included) as the model's runs do, carried by its feet.
    let positions = |x: &[f64], feet: bool| -> Result<cpg_mocap::Positions> {
        let mut units = cpg_reservoir::to_units(&m.outputs, x);
        cpg_reservoir::integrate_in_place(&m.outputs, &mut units, rate);
        if feet {
            crate::travel::feet_led(m, &mut units)?;
        }
        Ok(sk.forward_kinematics(&as_motion(m, &units)?)?)
    };
    let (mut labels, mut recorded) = (Vec::new(), Vec::new());
    for ((seg, x), cy) in c.data.segments.iter().zip(&prep.segments).zip(&prep.cycles) {
        if !seg.stand {
            labels.push(cy.label.clone());
            recorded.push(positions(x, false)?);
        }
    }
    let floor = floors(&recorded, &feet);
    let slides =
        labels.into_iter().zip(&recorded).map(|(l, p)| (l, foot_slide_mm(p, 0, p.n_frames(), &feet, &floor))).collect();
    let taught = positions(&prep.data.train.outputs, true)?;
    Ok((slides, Some(foot_slide_mm(&taught, 0, taught.n_frames(), &feet, &floor)), floor))
}

/// Judges the end of the standing run `y` (normalised) against the posture
/// `t`: the rotations within [`STAND_TOLERANCE_DEG`] and still, the other
/// lengths (the root's height) within [`STAND_TOLERANCE_MM`], and the
/// figure travelling less than that over the stretch: its travel as every
/// run of the model makes it, carried by its feet ([`crate::travel`]).
fn judge_stand(m: &TrainedCpg, y: &[f64], t: &Teacher, stand_s: f64, rate: f64, mm_per_unit: f64) -> Result<BodyStand> {
    let d = m.outputs.len();
    let steps = y.len() / d;
    let n = ((stand_s * rate).round() as usize).clamp(1, steps);
    let last = &y[(steps - n) * d..];
    let rotation = rotations(&m.outputs);
    let off = |c: usize| {
        let s = m.outputs[c].std;
        column(last, d, c)
            .iter()
            .map(|v| (v - t.cycle[c]).abs() * s)
            .fold(0.0, |a: f64, b| if b.is_nan() { f64::INFINITY } else { a.max(b) })
    };
    let dev: Vec<f64> = (0..d).map(|c| if rotation[c] { off(c) } else { 0.0 }).collect();
    let swing =
        (0..d).filter(|&c| rotation[c]).map(|c| half_range(&column(last, d, c)) * m.outputs[c].std).fold(0.0, f64::max);
    let worst = (0..d).max_by(|&a, &b| dev[a].total_cmp(&dev[b])).unwrap_or(0);
    let deviation = dev[worst];
    let lengths = (0..d)
        .filter(|&c| !rotation[c] && m.outputs[c].integrates().is_none())
        .map(|c| off(c) * mm_per_unit)
        .fold(0.0, f64::max);
    // The travel over the stretch: where the run's figure is at its end against its start.
    let mut units = cpg_reservoir::to_units(&m.outputs, y);
    cpg_reservoir::integrate_in_place(&m.outputs, &mut units, rate);
    // A model without feet travels by its learnt rates, already integrated.
    crate::travel::feet_led(m, &mut units)?;
    let (a, b) = (&units[(steps - n) * d..(steps - n + 1) * d], &units[(steps - 1) * d..]);
    let travel_mm =
        (0..d).filter(|&c| m.outputs[c].integrates().is_some()).map(|c| (b[c] - a[c]).powi(2)).sum::<f64>().sqrt()
            * mm_per_unit;
    let parts = [
        (deviation <= STAND_TOLERANCE_DEG, at_limit(deviation, STAND_TOLERANCE_DEG, 2)),
        (swing < STILL_SWING, at_limit(swing, STILL_SWING, 3)),
        (lengths <= STAND_TOLERANCE_MM, at_limit(lengths, STAND_TOLERANCE_MM, 1)),
        (travel_mm <= STAND_TOLERANCE_MM, at_limit(travel_mm, STAND_TOLERANCE_MM, 1)),
    ];
    let (passed, at_limit) = combine(&parts);
    Ok(BodyStand {
        deviation,
        worst_channel: m.outputs[worst].name.clone(),
        swing,
        length_deviation_mm: lengths,
        travel_mm,
        passed,
        at_limit,
    })
}

/// The switching run's schedule: each state of `sequence` held `stay_s`, cosine ramps of `ramp_s` between them;
/// with when each switch starts.
fn switching(teachers: &[Teacher], b: &WholeBodySection) -> (ControlSchedule, Vec<f64>, f64) {
    let mut knots = Vec::new();
    let mut at = Vec::new();
    let mut clock = 0.0;
    for (i, &k) in b.sequence.iter().enumerate() {
        let u = teachers[k].controls.clone();
        if i > 0 {
            at.push(clock);
            clock += b.ramp_s;
        }
        knots.push((clock, u.clone()));
        clock += b.stay_s;
        knots.push((clock, u));
    }
    (ControlSchedule::Knots(knots), at, clock)
}

/// The larger of `a` and `b`, element by element.
fn widest(a: Vec<f64>, b: Vec<f64>) -> Vec<f64> {
    a.iter().zip(&b).map(|(x, y)| x.max(*y)).collect()
}

/// Which teacher stands and which the held-out gaits judge; an error names the key.
fn roles(c: &Config, b: &WholeBodySection, teachers: &[Teacher], d: usize) -> Result<(usize, Vec<usize>)> {
    if let Some(&k) = b.sequence.iter().find(|&&k| k >= teachers.len()) {
        return Err(
            c.error("experiment.test.whole_body.sequence", format!("names teacher {k}; there are {}", teachers.len()))
        );
    }
    let stand = teachers
        .iter()
        .position(|t| t.is_posture(d))
        .ok_or_else(|| c.error("data.segments", "the whole body's test needs a standing posture (stand = true)"))?;
    let mut gait_index = Vec::new();
    for (k, h) in b.held_out.iter().enumerate() {
        let i = teachers.iter().position(|t| t.label == h.teacher && !t.is_posture(d)).ok_or_else(|| {
            c.error(
                &format!("experiment.test.whole_body.held_out[{k}].teacher"),
                format!(
                    "'{}' is not a rhythm the model learns; its teachers are {}",
                    h.teacher,
                    teachers.iter().map(|t| t.label.as_str()).collect::<Vec<_>>().join(", ")
                ),
            )
        })?;
        gait_index.push(i);
    }
    Ok((stand, gait_index))
}

/// The training teacher judged as a generated cycle would be (in `h`'s
/// fields), and the gait's period bounds from every recorded trial:
/// `train_periods` are the training trials' own.
fn judge_teacher(h: &mut HeldOutGait, t: &Teacher, outputs: &[cpg_reservoir::OutputChannel], train_periods: Vec<f64>) {
    let d = outputs.len();
    let units = cpg_reservoir::to_units(outputs, &t.cycle);
    h.teacher_amplitude = (0..d).map(|c| half_range(&column(&units, d, c))).collect();
    h.teacher_channel_ok = (0..d).map(|c| amplitude_holds(h, c, h.teacher_amplitude[c])).collect();
    h.teacher_within = h.teacher_channel_ok.iter().filter(|x| **x).count();
    h.teacher_period = t.period_steps(d);
    let all = h.trials.iter().map(|tr| tr.period_frames).chain(train_periods.iter().copied());
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p), b.max(p)));
    h.period_bounds = (lo * (1.0 - PERIOD_TOLERANCE), hi * (1.0 + PERIOD_TOLERANCE));
    h.train_periods = train_periods;
    let cycle = time_normalised(&units, d);
    let counted = rotations(outputs);
    h.teacher_error =
        median(&h.trials.iter().map(|tr| cycle_error(&cycle, &tr.cycle, d, &counted).0).collect::<Vec<_>>());
    h.teacher_cycle = match h.trials.first() {
        Some(first) => aligned(&cycle, &first.cycle, d, &counted),
        None => Vec::new(),
    };
    // Every trial drawn in the first one's phase (the errors, taken at each pair's best shift, are unchanged).
    if let Some((first, rest)) = h.trials.split_first_mut() {
        for tr in rest {
            tr.cycle = aligned(&tr.cycle, &first.cycle, d, &counted);
        }
    }
}

/// Everything judging one seed needs: the teachers' roles, the held-out
/// gaits, the yardsticks, the runs' schedules and lengths.
struct Test<'a> {
    b: &'a WholeBodySection,
    teachers: &'a [Teacher],
    stand: usize,
    gait_index: Vec<usize>,
    held: Vec<HeldOutGait>,
    reference: usize,
    /// Each channel's largest step in every recorded trial (training and held-out).
    data_steps: Vec<f64>,
    /// The skeleton's length unit, mm.
    mm_per_unit: f64,
    /// The skeleton, for the feet.
    skeleton: Option<cpg_mocap::Skeleton>,
    /// The feet's floors in the recorded trials, mm.
    floors: Vec<f64>,
    /// The feet's points ([`crate::measure::feet`]).
    feet: Vec<String>,
    /// The largest slide a switch may have: the recorded training trials' own largest, mm.
    slide_limit_mm: f64,
    rate: f64,
    d: usize,
    run_s: f64,
    steps: usize,
    constant: Vec<ControlSchedule>,
    schedule: ControlSchedule,
    switch_at_s: Vec<f64>,
    switch_len_s: f64,
    switch_steps: usize,
}

impl Test<'_> {
    /// The step at `s` seconds of the switching run.
    fn at(&self, s: f64) -> usize {
        ((s * self.rate).round() as usize).min(self.switch_steps)
    }

    /// Seed `seed`'s model run and judged; with its switching run in units (rates integrated).
    fn judge(&self, m: &TrainedCpg, seed: u64) -> Result<(BodySeed, Vec<f64>)> {
        let (b, d, rate) = (self.b, self.d, self.rate);
        let mut specs: Vec<RunSpec<'_>> = self
            .constant
            .iter()
            .map(|s| RunSpec { model: m, controls: s, steps: self.steps, push: None, noise: None })
            .collect();
        specs.push(RunSpec { model: m, controls: &self.schedule, steps: self.switch_steps, push: None, noise: None });
        let mut ys = free_runs(&specs, 1)?;
        let sw = ys.pop().unwrap_or_default();
        let mut units = cpg_reservoir::to_units(&m.outputs, &sw);
        cpg_reservoir::integrate_in_place(&m.outputs, &mut units, rate);
        let mut raw = units.clone();
        // One travel (its skeleton read and floors found once), with and without the feet's cleanup.
        if let Some(travel) = crate::travel::FeetTravel::for_model(m)? {
            travel.clone().apply_run(&mut units, d);
            travel.raw().apply_run(&mut raw, d);
        }
        let (feet, legs) = match &self.skeleton {
            Some(sk) => (
                Some(sk.forward_kinematics(&as_motion(m, &units)?)?),
                Some(sk.forward_kinematics(&as_motion(m, &raw)?)?),
            ),
            None => (None, None),
        };
        let stand = judge_stand(
            m,
            &ys[self.stand],
            &self.teachers[self.stand],
            b.stand_s.min(self.run_s),
            rate,
            self.mm_per_unit,
        )?;
        let gaits: Vec<BodyGait> = self
            .held
            .iter()
            .zip(&self.gait_index)
            .map(|(h, &k)| judge_gait(m, &ys[k], h, self.reference, rate))
            .collect();
        // Each state's own orbit: where the generator settles with those inputs held.
        let orbits: Vec<Option<Vec<f64>>> =
            self.teachers.iter().zip(&ys).map(|(t, y)| own_orbit(y, d, t, self.reference)).collect();
        let switches: Vec<BodySwitch> = (0..self.switch_at_s.len())
            .map(|s| {
                let cleaned = feet.as_ref().map(|_| (units.as_slice(), raw.as_slice()));
                self.switch(m, &sw, &orbits, [feet.as_ref(), legs.as_ref()], cleaned, s)
            })
            .collect();
        let mut parts = vec![(stand.passed, stand.at_limit)];
        parts.extend(gaits.iter().map(|g| (g.passed, g.at_limit)));
        parts.extend(switches.iter().map(|s| (s.passed, s.at_limit)));
        let (passed, at_limit) = combine(&parts);
        Ok((BodySeed { model: SeedModel::of(m, seed), stand, gaits, switches, passed, at_limit }, units))
    }

    /// Switch `s` of the switching run `sw` judged: settling onto the
    /// generator's own orbit of the state reached, and the steps.
    fn switch(
        &self,
        m: &TrainedCpg,
        sw: &[f64],
        orbits: &[Option<Vec<f64>>],
        [feet, legs]: [Option<&cpg_mocap::Positions>; 2],
        cleaned: Option<(&[f64], &[f64])>,
        s: usize,
    ) -> BodySwitch {
        let (b, d, rate, teachers) = (self.b, self.d, self.rate, self.teachers);
        let (from, to) = (b.sequence[s], b.sequence[s + 1]);
        let start = self.switch_at_s[s];
        let end = self.switch_at_s.get(s + 1).copied().unwrap_or(self.switch_len_s);
        let to_t = &teachers[to];
        let stride_steps = if to_t.is_posture(d) { teachers[from].period_steps(d) } else { to_t.period_steps(d) };
        let stride_s = stride_steps / rate;
        let settle_s = orbits[to]
            .as_ref()
            .and_then(|o| settle_on_orbit(&sw[..self.at(end) * d], d, o, self.at(start + b.ramp_s), rate));
        let window = &sw[self.at(start) * d..self.at(end) * d];
        let steps_c = channel_steps(window, d);
        let (step_channel, step_ratio) = (0..d)
            .filter(|&c| self.data_steps[c] > 1e-9)
            .map(|c| (c, steps_c[c] / self.data_steps[c]))
            .fold((0, 0.0), |w, x| if x.1 > w.1 { x } else { w });
        let limit = SETTLE_STRIDES * stride_s;
        let slide_mm = feet.map(|p| foot_slide_mm(p, self.at(start), self.at(end), &self.feet, &self.floors));
        let raw_slide_mm = legs.map(|p| foot_slide_mm(p, self.at(start), self.at(end), &self.feet, &self.floors));
        let cleanup_deg = cleaned.map(|(a, b)| {
            let (from, to) = (self.at(start) * d, (self.at(end) * d).min(a.len()));
            (from..to)
                .filter(|i| m.outputs[i % d].integrates().is_none())
                .map(|i| (a[i] - b[i]).abs())
                .fold(0.0, f64::max)
        });
        let parts = [
            (settle_s.is_some_and(|v| v <= limit), settle_s.is_some_and(|v| at_limit(v, limit, 2))),
            (step_ratio <= 1.0, at_limit(step_ratio, 1.0, 2)),
            (
                slide_mm.is_none_or(|v| v <= self.slide_limit_mm),
                slide_mm.is_some_and(|v| at_limit(v, self.slide_limit_mm, 0)),
            ),
        ];
        let (passed, fragile) = combine(&parts);
        BodySwitch {
            from: teachers[from].label.clone(),
            to: to_t.label.clone(),
            at_s: start,
            settle_s,
            stride_s,
            max_step: max_step(window, d),
            step_ratio,
            step_channel: m.outputs[step_channel].name.clone(),
            slide_mm,
            raw_slide_mm,
            cleanup_deg,
            passed,
            at_limit: fragile,
        }
    }

    /// The states on the switching run's timeline: the first from the start,
    /// each next from its ramp's start ("to walk") and end ("walk").
    fn marks(&self) -> Vec<cpg_view::Mark> {
        let label = |k: usize| self.teachers[k].label.clone();
        std::iter::once(cpg_view::Mark { time_s: 0.0, label: label(self.b.sequence[0]) })
            .chain(self.switch_at_s.iter().zip(&self.b.sequence[1..]).flat_map(|(&t, &k)| {
                [
                    cpg_view::Mark { time_s: t, label: format!("to {}", label(k)) },
                    cpg_view::Mark { time_s: t + self.b.ramp_s, label: label(k) },
                ]
            }))
            .collect()
    }
}

/// The training trials' own loops for the gait `label` judged by `h`'s
/// amplitude rule: the medoid trial's (the one closest to the others) and
/// each trial's, as the teachers training could have used instead of the
/// average (channels within the rule).
fn alternatives(c: &Config, prep: &crate::prepare::Prepared, h: &HeldOutGait, label: &str) -> Vec<(String, usize)> {
    let d = prep.outputs.len();
    let counted = rotations(&prep.outputs);
    let loops: Vec<(String, Vec<f64>)> = c
        .data
        .segments
        .iter()
        .zip(&prep.cycles)
        .zip(&prep.segments)
        .filter(|((s, cy), _)| !s.stand && (s.group.as_deref() == Some(label) || cy.label == label))
        .filter(|((_, cy), x)| cy.loop_len > 1 && (cy.loop_start + cy.loop_len) * d <= x.len())
        .map(|((_, cy), x)| {
            let units =
                cpg_reservoir::to_units(&prep.outputs, &x[cy.loop_start * d..(cy.loop_start + cy.loop_len) * d]);
            (cy.label.clone(), units)
        })
        .collect();
    let within = |units: &[f64]| (0..d).filter(|&ch| amplitude_holds(h, ch, half_range(&column(units, d, ch)))).count();
    let cycles: Vec<Vec<f64>> = loops.iter().map(|(_, u)| time_normalised(u, d)).collect();
    let medoid = (0..cycles.len()).min_by(|&a, &b| {
        let cost =
            |i: usize| (0..cycles.len()).map(|j| cycle_error(&cycles[i], &cycles[j], d, &counted).0).sum::<f64>();
        cost(a).total_cmp(&cost(b))
    });
    let mut out: Vec<(String, usize)> = Vec::new();
    if let Some(m) = medoid {
        out.push((format!("the medoid trial's own cycle ({})", loops[m].0), within(&loops[m].1)));
    }
    out.extend(loops.iter().map(|(name, u)| (format!("{name}'s own cycle"), within(u))));
    out
}

/// Every held-out gait of `b` read and compared among itself, with its
/// training teacher judged beside it.
fn read_held_out(
    c: &Config,
    b: &WholeBodySection,
    gait_index: &[usize],
    m: &TrainedCpg,
    prep: &crate::prepare::Prepared,
    progress: &dyn Progress,
) -> Result<Vec<HeldOutGait>> {
    let sk = prep
        .skeleton
        .as_ref()
        .ok_or_else(|| c.error("data.skeleton", "is needed to read the held-out trials (AMC)"))?;
    progress.start("reading the held-out trials", b.held_out.len() as u64);
    let mut held = Vec::with_capacity(b.held_out.len());
    for (k, (h, &i)) in b.held_out.iter().zip(gait_index).enumerate() {
        let mut g = held_out(c, h, m, sk, k)?;
        // The training trials of this gait: the segments of its group (or the segment itself).
        let label = &prep.teachers[i].label;
        let train_periods: Vec<f64> = c
            .data
            .segments
            .iter()
            .zip(&prep.cycles)
            .filter(|(s, cy)| !s.stand && (s.group.as_ref() == Some(label) || &cy.label == label))
            .map(|(_, cy)| cy.period_frames)
            .collect();
        judge_teacher(&mut g, &prep.teachers[i], &prep.outputs, train_periods);
        g.teacher_alternatives = alternatives(c, prep, &g, label);
        held.push(g);
        progress.tick();
    }
    progress.finish();
    Ok(held)
}

/// `m`'s run under `schedule` for `seconds` on the robot at [`ROBOT_RATE_HZ`],
/// within its limits: how each joint fared.
fn robot_clamps(
    m: &TrainedCpg,
    schedule: &ControlSchedule,
    seconds: f64,
    robot: &cpg_robot::Robot,
    map: &cpg_robot::ChannelMap,
) -> Result<cpg_robot::ClampReport> {
    let target = crate::stream::RobotTarget { robot, map, acceleration_rad_s2: cpg_robot::DEFAULT_ACCELERATION_RAD_S2 };
    Ok(crate::stream::joint_trajectory(m, schedule, seconds, Some(ROBOT_RATE_HZ), target)?.clamps)
}

/// Each channel's largest frame-to-frame step in every recorded trial of
/// the person: the training segments and the held-out trials, normalised units.
fn recorded_steps(segments: &[Vec<f64>], held: &[HeldOutGait], d: usize) -> Vec<f64> {
    segments.iter().map(|s| channel_steps(s, d)).chain(held.iter().map(|g| g.steps.clone())).fold(vec![0.0; d], widest)
}

/// How the readout was learnt, in the report's words.
fn trainer_words(c: &Config) -> String {
    match c.training.trainer {
        crate::config::Trainer::Ridge => match c.training.self_fed.rounds {
            0 => "ridge regression".into(),
            1 => "ridge regression, a round on its own output".into(),
            n => format!("ridge regression, {n} rounds on its own output"),
        },
        crate::config::Trainer::Force => "FORCE".into(),
    }
}

/// Runs the whole body's test on configuration `c`.
pub fn run(c: &Config, b: &WholeBodySection, opts: Options, progress: &dyn Progress) -> Result<BodyResult> {
    let seeds = seeds(c, opts)?;
    let t0 = std::time::Instant::now();
    let (prep, models) = train_seeds(c, &seeds, opts.threads, progress)?;
    let train_wall_s = t0.elapsed().as_secs_f64();
    let rate = c.data.rate_hz;
    let teachers = &prep.teachers;
    let d = prep.outputs.len();
    let first = &models[0];
    let (stand, gait_index) = roles(c, b, teachers, d)?;
    let held = read_held_out(c, b, &gait_index, first, &prep, progress)?;
    let reference =
        c.data.period_channel.as_ref().and_then(|n| prep.outputs.iter().position(|o| &o.name == n)).unwrap_or(0);
    // Each channel's largest step in every recorded trial of the person
    // (training and held-out: the data), and in the teachers' cycles, each tiled once round its seam (the
    // motion the generator learnt, averaged and smoother).
    let teacher_steps = teachers
        .iter()
        .map(|t| channel_steps(&tile(&t.cycle, d, t.cycle.len() / d + 1, 0), d))
        .fold(vec![0.0; d], widest);
    let data_steps = recorded_steps(&prep.segments, &held, d);
    let (data_slide_mm, teacher_slide_mm, floors) = data_slides(c, &prep, first)?;
    let run_s = if opts.quick { b.quick_run_s } else { b.run_s };
    let (schedule, switch_at_s, switch_len_s) = switching(teachers, b);
    let test = Test {
        b,
        teachers,
        stand,
        gait_index,
        held,
        reference,
        data_steps,
        mm_per_unit: prep.skeleton.as_ref().map_or(1.0, cpg_mocap::Skeleton::mm_per_unit),
        feet: prep.skeleton.as_ref().map(crate::measure::feet).unwrap_or_default(),
        skeleton: prep.skeleton.clone(),
        floors,
        slide_limit_mm: data_slide_mm.iter().map(|x| x.1).reduce(f64::max).unwrap_or(SLIDE_MM),
        rate,
        d,
        run_s,
        steps: (run_s * rate).round() as usize,
        constant: teachers.iter().map(|t| ControlSchedule::Constant(t.controls.clone())).collect(),
        schedule,
        switch_at_s,
        switch_len_s,
        switch_steps: (switch_len_s * rate).round() as usize,
    };
    let robot = match &b.robot {
        Some(r) => Some((cpg_robot::Robot::from_urdf_file(&r.urdf)?, cpg_robot::ChannelMap::load(&r.map)?)),
        None => None,
    };
    let robot_run = match &robot {
        Some((r, map)) => Some(robot_clamps(first, &test.schedule, switch_len_s, r, map)?),
        None => None,
    };
    progress.start("free runs", seeds.len() as u64);
    type SeedOut = (BodySeed, Vec<f64>, Option<cpg_view::Scene>);
    let per_seed: Result<Vec<SeedOut>> = seeds
        .par_iter()
        .zip(&models)
        .enumerate()
        .map(|(i, (&seed, m))| {
            let (judged, units) = test.judge(m, seed)?;
            let view = if i == 0 {
                let robot = robot.as_ref().map(|(r, map)| crate::scene::RobotView {
                    robot: r,
                    map,
                    acceleration_rad_s2: cpg_robot::DEFAULT_ACCELERATION_RAD_S2,
                });
                let mut scene = crate::scene::run_scene(&super::view_title(c), m, &test.schedule, 0, &units, robot)?;
                scene.marks = test.marks();
                Some(scene)
            } else {
                None
            };
            progress.tick();
            Ok((judged, column(&units, d, reference), view))
        })
        .collect();
    progress.finish();
    let per_seed = per_seed?;
    let Test { held, data_steps, switch_at_s, .. } = test;
    let mut r = BodyResult {
        header: header(c, &prep, first.reservoir.n_neurons())?,
        test: b.clone(),
        channels: prep.outputs.iter().map(|o| o.name.clone()).collect(),
        teachers: teachers.iter().map(|t| t.label.clone()).collect(),
        held_out: held,
        data_step: teacher_steps.iter().copied().fold(0.0, f64::max),
        recorded_step: data_steps.iter().copied().fold(0.0, f64::max),
        data_steps,
        data_slide_mm,
        teacher_slide_mm,
        train_wall_s,
        trainer: trainer_words(c),
        threads: opts.threads,
        run_s,
        switch_at_s,
        view: per_seed.iter().find_map(|s| s.2.clone()),
        robot_velocity_limits_rad_s: match (&robot, &robot_run) {
            (Some((r, _)), Some(c)) => {
                c.joints.iter().map(|j| r.joint(&j.joint).map_or(f64::NAN, |x| x.velocity_rad_s)).collect()
            }
            _ => Vec::new(),
        },
        robot: robot_run,
        robot_acceleration_rad_s2: cpg_robot::DEFAULT_ACCELERATION_RAD_S2,
        switch_runs: per_seed.iter().map(|s| s.1.clone()).collect(),
        seeds: per_seed.into_iter().map(|s| s.0).collect(),
        claims: Vec::new(),
        table: Vec::new(),
    };
    r.summarise();
    Ok(r)
}

/// What the target is, in words (this experiment goes beyond the papers).
fn beyond(text: &str) -> Vec<Source> {
    vec![Source::Inferred {
        text: format!("beyond the paper (its E5 switches one channel, its E6 holds 22 of one gait): {text}"),
    }]
}

impl BodyResult {
    /// What a gait's claim measures: the period against every recorded
    /// trial's range, the training trials' median and the teacher's own
    /// (and whose fault a gap is); the channels within the amplitude rule,
    /// the teacher's beside; the cycle error beside the trials' spread.
    fn gait_measures(&self, k: usize, g: &HeldOutGait) -> Vec<Measure> {
        let col = |f: &dyn Fn(&BodySeed) -> f64| self.seeds.iter().map(f).collect::<Vec<f64>>();
        let count = |f: &dyn Fn(&BodySeed) -> bool| Proportion::count(self.seeds.iter().map(f));
        let of = format!("of {}", self.channels.len());
        let train = median(&g.train_periods);
        let period = |s: &BodySeed| s.gaits[k].period_steps.unwrap_or(f64::NAN);
        let gen_over_train = median(&col(&|s| period(s) / train));
        let gen_over_teacher = median(&col(&|s| period(s) / g.teacher_period));
        let teacher_over_train = g.teacher_period / train;
        let off = |x: f64| (x - 1.0).abs() > PERIOD_TOLERANCE;
        let fault = match (off(gen_over_train), off(teacher_over_train), off(gen_over_teacher)) {
            (false, _, _) => {
                format!("none: the median seed is within {:.0} % of the training trials", 100.0 * PERIOD_TOLERANCE)
            }
            (true, true, false) => {
                "the teacher's: its own period is off the training trials', and the generator keeps it".into()
            }
            (true, false, true) => {
                "the generator's: the teacher keeps the training trials' period, the generator does not".into()
            }
            (true, true, true) => "both the teacher's and the generator's".into(),
            (true, false, false) => "neither alone: each is within the tolerance of the next".into(),
        };
        vec![
            Measure::count("seeds passing the gait's rule", count(&|s| s.gaits[k].passed)),
            Measure::spread("period (frames)", &col(&period), "", 1),
            Measure::text(
                "its allowed range: every recorded trial's, widened",
                format!("{:.1}–{:.1} frames", g.period_bounds.0, g.period_bounds.1),
            ),
            Measure::spread(
                format!("period / the training trials' median ({train:.1} frames)"),
                &col(&|s| period(s) / train),
                "",
                3,
            ),
            Measure::spread(
                format!("period / the held-out median ({:.1} frames)", g.period_frames),
                &col(&|s| period(s) / g.period_frames),
                "",
                3,
            ),
            Measure::number(
                format!("the teacher's own period ({:.0} frames) / the training trials' median", g.teacher_period),
                teacher_over_train,
                "",
                3,
            ),
            Measure::text(
                format!("a gap of more than {:.0} % to the training trials", 100.0 * PERIOD_TOLERANCE),
                fault,
            ),
            Measure::count("seeds with the amplitude rule held", count(&|s| s.gaits[k].amplitude_ok)),
            Measure::spread(
                "channels within the amplitude rule",
                &col(&|s| s.gaits[k].amplitudes_within as f64),
                &of,
                0,
            ),
            Measure::number("the same for the training teacher itself", g.teacher_within as f64, &of, 0),
            Measure::spread(
                "channels the teacher holds and the generator does not",
                &col(&|s| s.gaits[k].lost.len() as f64),
                "",
                0,
            ),
            Measure::text(
                "teachers the training trials could give instead, channels within (reported, not chosen by it)",
                std::iter::once(format!("the average of the trials, as trained: {}", g.teacher_within))
                    .chain(g.teacher_alternatives.iter().map(|(w, n)| format!("{w}: {n}")))
                    .collect::<Vec<_>>()
                    .join("; "),
            ),
            Measure::spread("cycle error against the held-out trials", &col(&|s| s.gaits[k].error), "°", 2),
            Measure::number("the same for the training teacher itself", g.teacher_error, "°", 2),
            Measure::number(format!("the held-out trials' spread ({} trials)", g.trials.len()), g.spread, "°", 2),
        ]
    }

    /// The largest slide a switch may have: the recorded training trials' own largest, mm.
    pub fn slide_limit_mm(&self) -> f64 {
        self.data_slide_mm.iter().map(|x| x.1).reduce(f64::max).unwrap_or(SLIDE_MM)
    }

    /// The verdict over seeds.
    pub fn verdict(&self) -> Verdict {
        let j: Vec<Judged> = self.seeds.iter().map(|s| Judged { passed: s.passed, at_limit: s.at_limit }).collect();
        verdict_over(&j, SEED_FRACTION, format!("at least 90 % of the seeds pass: {}", rule(&self.test)))
    }

    fn part_verdict(&self, f: impl Fn(&BodySeed) -> (bool, bool), rule: String) -> Verdict {
        let j: Vec<Judged> = self
            .seeds
            .iter()
            .map(|s| {
                let (passed, at_limit) = f(s);
                Judged { passed, at_limit }
            })
            .collect();
        verdict_over(&j, SEED_FRACTION, rule)
    }

    /// Fills the claims and the table from the seeds.
    pub fn summarise(&mut self) {
        let h = &self.header;
        let differs: Vec<String> = h.differs.iter().map(|d| d.describe()).collect();
        let col = |f: &dyn Fn(&BodySeed) -> f64| self.seeds.iter().map(f).collect::<Vec<f64>>();
        let count = |f: &dyn Fn(&BodySeed) -> bool| Proportion::count(self.seeds.iter().map(f));
        let claim = |claim: String, text: &str, measured: Vec<Measure>, verdict: Verdict| Claim {
            experiment: h.id.clone(),
            claim,
            sources: beyond(text),
            protocol: h.protocol.to_string(),
            differs: differs.clone(),
            measured,
            verdict,
        };
        let mut claims = vec![claim(
            "stands still in one posture".to_owned(),
            "standing is a fixed point of the generator, not a slow cycle",
            vec![
                Measure::count("seeds standing within the tolerances and still", count(&|s| s.stand.passed)),
                Measure::spread(format!("largest distance from the posture, last {} s", self.test.stand_s), &col(&|s| s.stand.deviation), "°", 2),
                Measure::spread("largest swing of a rotation", &col(&|s| s.stand.swing), "°", 3),
                Measure::spread(format!("travel over the last {} s", self.test.stand_s), &col(&|s| s.stand.travel_mm), "mm", 1),
            ],
            self.part_verdict(
                |s| (s.stand.passed, s.stand.at_limit),
                format!("at least 90 % of the seeds: every rotation within {STAND_TOLERANCE_DEG}° of the posture and swinging less than {STILL_SWING}°, the root's height within {STAND_TOLERANCE_MM} mm and the figure travelling at most {STAND_TOLERANCE_MM} mm over the last {} s of a {} s free run", self.test.stand_s, self.run_s),
            ),
        )];
        for (k, g) in self.held_out.iter().enumerate() {
            claims.push(claim(
                format!("{} like trials it never saw", g.teacher),
                "each gait judged on held-out trials of the same person",
                self.gait_measures(k, g),
                self.part_verdict(
                    |s| (s.gaits[k].passed, s.gaits[k].at_limit),
                    format!("at least 90 % of the seeds: {}", gait_rule(self.run_s)),
                ),
            ));
        }
        let n_sw = self.switch_at_s.len();
        let settle_strides: Vec<f64> = self
            .seeds
            .iter()
            .flat_map(|s| s.switches.iter().map(|w| w.settle_s.map_or(f64::NAN, |v| v / w.stride_s)))
            .collect();
        claims.push(claim(
            "switches between standing, walking and running".to_owned(),
            "stand → walk → run → walk → stand in one free run, by two inputs",
            vec![
                Measure::count(format!("seeds passing all {n_sw} switches"), count(&|s| s.switches.iter().all(|w| w.passed))),
                Measure::spread("settling after the ramp (every switch that settles)", &settle_strides, "strides", 2),
                Measure::spread("largest step after a switch, over the channel's largest in every recorded trial", &col(&|s| s.switches.iter().map(|w| w.step_ratio).fold(0.0, f64::max)), "", 2),
                Measure::spread("largest slide of a foot on the ground", &col(&|s| s.switches.iter().filter_map(|w| w.slide_mm).fold(0.0, f64::max)), "mm", 0),
                Measure::spread("the same in each recorded training trial", &self.data_slide_mm.iter().map(|x| x.1).collect::<Vec<_>>(), "mm", 0),
            ]
            .into_iter()
            .chain(self.teacher_slide_mm.map(|v| Measure::number("in the training sequence itself (its blends between states included)", v, "mm", 0)))
            .chain([
                Measure::spread("the generator's largest before the feet's cleanup (its legs as generated)", &col(&|s| s.switches.iter().filter_map(|w| w.raw_slide_mm).fold(0.0, f64::max)), "mm", 0),
                Measure::spread("the largest change the cleanup made to a leg's rotation", &col(&|s| s.switches.iter().filter_map(|w| w.cleanup_deg).fold(0.0, f64::max)), "°", 1),
            ])
            .collect(),
            self.part_verdict(
                |s| combine(&s.switches.iter().map(|w| (w.passed, w.at_limit)).collect::<Vec<_>>()),
                format!("at least 90 % of the seeds: every switch ({}-s cosine ramps, each state held {} s) on the orbit the generator keeps with the new inputs held (from its long run) within {SETTLE_STRIDES} strides of the ramp's end, no channel stepping further between frames than its largest step in every recorded trial of the person (training and held-out, as the period's range), no foot sliding during a stance more than the recorded training trials' own largest slide by the same measure ({:.0} mm; on the ground: within {CONTACT_MM} mm of its floor, the {:.0} % quantile of its heights in the recorded training trials; forward kinematics of the generated motion with its figure carried by its feet and its feet cleaned up, as every run of the model is: a foot coming down slower than {PLANT_MM_S} mm/s planted where it lands and held there by inverse kinematics of the hip and the knee, one dragged faster lifted {CLEAR_MM} mm clear; the slides before the cleanup beside)", self.test.ramp_s, self.test.stay_s, self.slide_limit_mm(), FLOOR_QUANTILE * 100.0),
            ),
        ));
        claims.push(claim(
            "the whole body in one generator".to_owned(),
            "≥ 9 of 10 seeds pass every per-gait check and every switch",
            vec![
                Measure::count("seeds passing everything", count(&|s| s.passed)),
                Measure::number(
                    format!("training, {} seeds on {} threads", self.seeds.len(), self.threads),
                    self.train_wall_s,
                    "s",
                    1,
                ),
            ],
            self.verdict(),
        ));
        self.claims = claims;
        let models: Vec<&SeedModel> = self.seeds.iter().map(|s| &s.model).collect();
        self.table = super::penalty_rows(&models, &mut self.header).to_vec();
    }
}

impl super::Experiment for BodyResult {
    fn figure(&self) -> &'static str {
        "beyond the paper"
    }
    super::common_accessors!();
    fn passed(&self) -> (usize, usize) {
        (self.seeds.iter().filter(|s| s.passed).count(), self.seeds.len())
    }
    fn target(&self) -> &'static str {
        "stands, walks and runs like held-out trials, and switches"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        section::body(&mut s, all, ctx);
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shifted_cycle_is_drawn_back_in_the_phase_of_the_one_it_matches() {
        let d = 2;
        let b: Vec<f64> = (0..PHASES)
            .flat_map(|k| {
                let x = std::f64::consts::TAU * k as f64 / PHASES as f64;
                [x.sin(), (2.0 * x).cos()]
            })
            .collect();
        let a: Vec<f64> = (0..PHASES).flat_map(|k| b[((k + 17) % PHASES) * d..][..d].to_vec()).collect();
        assert_ne!(a, b);
        let back = aligned(&a, &b, d, &[true, true]);
        assert!(back.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12));
    }

    #[test]
    fn a_cycle_against_itself_shifted_has_no_error_and_a_scaled_one_does() {
        let d = 2;
        let cycle: Vec<f64> = (0..80)
            .flat_map(|k| {
                let x = k as f64 * std::f64::consts::TAU / 80.0;
                [10.0 * x.sin(), 3.0 * (2.0 * x).cos()]
            })
            .collect();
        let a = time_normalised(&cycle, d);
        let shifted: Vec<f64> =
            (0..80).flat_map(|k| cycle[((k + 20) % 80) * d..((k + 20) % 80 + 1) * d].to_vec()).collect();
        let (e, per) = cycle_error(&a, &time_normalised(&shifted, d), d, &[true, true]);
        assert!(e < 1e-9 && per.iter().all(|v| *v < 1e-9), "{e} {per:?}");
        let scaled: Vec<f64> = cycle.iter().enumerate().map(|(i, v)| if i % 2 == 0 { 1.1 * v } else { *v }).collect();
        let (e, per) = cycle_error(&a, &time_normalised(&scaled, d), d, &[true, true]);
        // Channel 0 is 10 sin off by 10 %: an RMS of 1/√2; channel 1 is exact.
        assert!((per[0] - 0.5f64.sqrt()).abs() < 1e-3 && per[1] < 1e-9, "{per:?}");
        assert!((e - 0.5).abs() < 1e-3, "{e}");
    }

    #[test]
    fn the_last_cycle_of_a_run_is_its_last_period_at_a_fractional_length() {
        // A sine of period 37.5 steps: the last cycle sampled at 100 phases is a whole sine.
        let p = 37.5;
        let y: Vec<f64> = (0..1000).map(|k| (k as f64 * std::f64::consts::TAU / p).sin()).collect();
        let c = last_cycle(&y, 1, p);
        let reference: Vec<f64> = (0..PHASES)
            .map(|k| ((999.0 - p + k as f64 * p / PHASES as f64) * std::f64::consts::TAU / p).sin())
            .collect();
        let (e, _) = cycle_error(&c, &reference, 1, &[true]);
        assert!(e < 2e-3, "{e}");
    }

    #[test]
    fn a_switching_run_holds_each_state_and_ramps_between() {
        let t = |u: [f64; 2]| Teacher { label: String::new(), controls: u.to_vec(), cycle: vec![0.0], rate: 1.0 };
        let teachers = [t([0.0, 0.0]), t([1.0, 0.0]), t([0.0, 1.0])];
        let b = WholeBodySection {
            run_s: 900.0,
            quick_run_s: 90.0,
            stand_s: 60.0,
            held_out: Vec::new(),
            sequence: vec![0, 1, 2, 1, 0],
            stay_s: 20.0,
            ramp_s: 1.0,
            robot: None,
        };
        let (s, at, len) = switching(&teachers, &b);
        assert_eq!(at, [20.0, 41.0, 62.0, 83.0]);
        assert_eq!(len, 104.0);
        let mut u = [0.0; 2];
        s.fill((30.0 * 120.0) as usize, 120.0, &mut u);
        assert_eq!(u, [1.0, 0.0]);
        s.fill((50.0 * 120.0) as usize, 120.0, &mut u);
        assert_eq!(u, [0.0, 1.0]);
        s.fill((41.5 * 120.0) as usize, 120.0, &mut u);
        assert!((u[0] - 0.5).abs() < 1e-9 && (u[1] - 0.5).abs() < 1e-9, "{u:?}");
    }
}

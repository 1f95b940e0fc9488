//! The human's walk, retargeted to the HOAP-2: what is kept of the person
//! (stride period, double support, the swing foot's lift and progress over
//! the swing, the stride in leg lengths, the arms' swing), measured from the
//! forward kinematics of recorded trials, and the robot's walk planned from
//! it by [`cpg_robot::walk`] (ZMP preview control, inverse kinematics).
//! [`style`] says how much of the human's joint cycles the robot keeps.

use cpg_mocap::Positions;
use cpg_mocap::profile::{Resolved, SidePoints};
use cpg_robot::Robot;
use cpg_robot::physics::MassModel;
use cpg_robot::walk::{WalkParams, WalkPlan};

use crate::{Error, Result};

/// Samples in a time-normalised profile or cycle.
pub const PROFILE_SAMPLES: usize = 21;
/// Samples in a time-normalised joint cycle.
pub const CYCLE_SAMPLES: usize = 100;

/// What one or more recorded walking trials say about the person's walk.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct HumanWalk {
    /// Strides measured (left touch-down to left touch-down).
    pub strides: usize,
    /// Median stride period, seconds.
    pub stride_period_s: f64,
    /// The share of a stride a foot is on the ground (mean of both feet).
    pub duty_factor: f64,
    /// Hip to floor, standing: thigh + shank + the ankle's height, metres.
    pub leg_length_m: f64,
    /// The body's advance per stride, metres.
    pub stride_length_m: f64,
    /// The ankle's lift above its stance height at the swing's peak, metres.
    pub lift_m: f64,
    /// The swing ankle's height over the swing, peak 1 ([`PROFILE_SAMPLES`]).
    pub lift_profile: Vec<f64>,
    /// The swing ankle's forward progress over the swing, 0 to 1.
    pub advance_profile: Vec<f64>,
    /// Joint cycles over a stride from the left touch-down ([`CYCLE_SAMPLES`]), degrees:
    /// `hip_flexion_l`, `knee_flexion_l`, `ankle_l`, `shoulder_flexion_l`, `elbow_flexion_l` and the same `_r`.
    pub cycles_deg: Vec<(String, Vec<f64>)>,
}

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// A periodic cycle's value at phase `s` in [0, 1), linear between samples.
fn cyclic(v: &[f64], s: f64) -> f64 {
    let n = v.len();
    let x = s.rem_euclid(1.0) * n as f64;
    let i = (x.floor() as usize) % n;
    let f = x - x.floor();
    v[i] * (1.0 - f) + v[(i + 1) % n] * f
}

/// `v` resampled to `n` points from its first to its last, linear.
fn resample(v: &[f64], n: usize) -> Vec<f64> {
    (0..n).map(|k| cpg_robot::walk::sample(v, k as f64 / (n - 1) as f64)).collect()
}

/// The sagittal angle of segment `a → b` from the downward vertical, positive forward, degrees.
fn pitch_deg(a: V3, b: V3, forward: V3, up: V3) -> f64 {
    let d = sub(b, a);
    dot(d, forward).atan2(-dot(d, up)).to_degrees()
}

/// The angle between segments `a → b` and `b → c`, degrees (0: straight).
fn bend_deg(a: V3, b: V3, c: V3) -> f64 {
    let (u, v) = (sub(b, a), sub(c, b));
    (dot(u, v) / (norm(u) * norm(v))).clamp(-1.0, 1.0).acos().to_degrees()
}

struct Trial<'a> {
    p: &'a Positions,
    up: V3,
}

impl Trial<'_> {
    fn at(&self, f: usize, i: usize) -> V3 {
        let n = self.p.names.len();
        self.p.points_mm[f * n + i].map(|v| v / 1000.0)
    }
}

/// One side's joints as indices of a trial's points.
#[derive(Clone, Copy)]
struct Side {
    hip: usize,
    knee: usize,
    ankle: usize,
    ball: usize,
    shoulder: usize,
    elbow: usize,
    wrist: usize,
}

/// The points a walk is measured by, found in a trial through its skeleton's profile.
struct Points {
    root: usize,
    sides: [Side; 2],
}

impl Points {
    fn find(p: &Positions, r: &Resolved, trial: usize) -> Result<Points> {
        let at = |name: &str| {
            p.point_index(name).ok_or_else(|| {
                Error::name(
                    name,
                    format!("trial {trial}: the skeleton has no point '{name}' (profile '{}')", r.profile),
                )
            })
        };
        let side = |s: &SidePoints| -> Result<Side> {
            Ok(Side {
                hip: at(&s.hip)?,
                knee: at(&s.knee)?,
                ankle: at(&s.ankle)?,
                ball: at(&s.ball)?,
                shoulder: at(&s.shoulder)?,
                elbow: at(&s.elbow)?,
                wrist: at(&s.wrist)?,
            })
        };
        Ok(Points { root: at(&r.pelvis)?, sides: [side(&r.sides[0])?, side(&r.sides[1])?] })
    }
}

/// Stance (on the ground) per frame of one foot: the ankle or the ball low and nearly still.
fn stance(t: &Trial<'_>, ankle: usize, ball: usize) -> Vec<bool> {
    let n = t.p.n_frames();
    let dt = 1.0 / t.p.sample_rate_hz;
    let height = |i: usize| (0..n).map(|f| dot(t.at(f, i), t.up)).collect::<Vec<f64>>();
    let (ha, hb) = (height(ankle), height(ball));
    let window = (FLOOR_WINDOW_S / dt).round() as usize;
    let (ma, mb) = (floor(&ha, window), floor(&hb, window));
    let speed = |i: usize, f: usize| {
        let (a, b) = (t.at(f.saturating_sub(1), i), t.at((f + 1).min(n - 1), i));
        let d = sub(b, a);
        let vert = dot(d, t.up);
        ((dot(d, d) - vert * vert).max(0.0)).sqrt() / (dt * ((f + 1).min(n - 1) - f.saturating_sub(1)) as f64)
    };
    (0..n)
        .map(|f| {
            (ha[f] - ma[f] < CONTACT_M && speed(ankle, f) < 0.5) || (hb[f] - mb[f] < CONTACT_M && speed(ball, f) < 0.5)
        })
        .collect()
}

/// A foot point within this height of its floor may be on the ground, m.
const CONTACT_M: f64 = 0.03;
/// Half the window over which a drifting floor is found, s: about half a
/// walking stride, so that every window holds part of the foot's stance.
const FLOOR_WINDOW_S: f64 = 0.6;

/// The floor under a foot point whose heights are `h`, per frame: its lowest
/// height over the trial, or, where the floor the feet find drifts more than
/// [`CONTACT_M`] from that (a capture volume's floor calibrated off level, or
/// a drifting marker set), its lowest height within `window` frames each side.
fn floor(h: &[f64], window: usize) -> Vec<f64> {
    let lowest = h.iter().cloned().fold(f64::INFINITY, f64::min);
    let local: Vec<f64> = (0..h.len())
        .map(|f| {
            h[f.saturating_sub(window)..(f + window + 1).min(h.len())].iter().cloned().fold(f64::INFINITY, f64::min)
        })
        .collect();
    if local.iter().all(|&l| l - lowest <= CONTACT_M) { vec![lowest; h.len()] } else { local }
}

/// The first frame of the recording proper: a recording that opens on a
/// calibration pose (CMU's BVH conversions open on a T-pose) jumps from it
/// to the motion faster than any body part moves, so frames before a jump of
/// any point faster than [`JUMP_M_S`] within the first second are left out.
fn settled(p: &Positions) -> usize {
    let (n, d) = (p.n_frames(), p.names.len());
    let horizon = (p.sample_rate_hz.round() as usize).min(n.saturating_sub(2));
    let step_m = JUMP_M_S / p.sample_rate_hz;
    let jumps = |f: usize| {
        (0..d).any(|i| {
            let (a, b) = (p.points_mm[f * d + i], p.points_mm[(f + 1) * d + i]);
            norm(sub(b, a)) / 1000.0 > step_m
        })
    };
    (0..horizon).rev().find(|&f| jumps(f)).map_or(0, |f| f + 1)
}

/// Faster than any body part moves, m/s (a sprinter's foot peaks near 20).
const JUMP_M_S: f64 = 30.0;

/// Frames where `on` turns true (touch-downs), each after at least `min_off` frames off.
fn onsets(on: &[bool], min_off: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut off = 0;
    for (f, &c) in on.iter().enumerate() {
        if c {
            if off >= min_off && f > 0 {
                out.push(f);
            }
            off = 0;
        } else {
            off += 1;
        }
    }
    out
}

/// What the trials' strides add up to, before the medians and means.
#[derive(Default)]
struct Tally {
    periods: Vec<f64>,
    duty: f64,
    duty_n: usize,
    leg: Vec<f64>,
    stride_len: Vec<f64>,
    lift: Vec<f64>,
    lift_profiles: Vec<Vec<f64>>,
    advance_profiles: Vec<Vec<f64>>,
    cycles: Vec<(String, Vec<Vec<f64>>)>,
}

/// Measures the walk of the trials' forward kinematics (y up, as CMU's
/// skeletons are), each with its skeleton's profile
/// ([`cpg_mocap::profile`]: which points are the hips, knees, ankles, …).
pub fn human_walk(trials: &[(Positions, Resolved)]) -> Result<HumanWalk> {
    let mut tally = Tally::default();
    for (k, (p, r)) in trials.iter().enumerate() {
        tally.trial(k, p, r)?;
    }
    tally.finish()
}

impl Tally {
    /// Trial `k`: each foot's strides and swings, and the joint cycles over each left stride.
    fn trial(&mut self, k: usize, p: &Positions, r: &Resolved) -> Result<()> {
        let pts = Points::find(p, r, k + 1)?;
        let first = settled(p);
        let owned;
        let p = if first == 0 {
            p
        } else {
            let d = p.names.len();
            owned = Positions {
                names: p.names.clone(),
                points_mm: p.points_mm[first * d..].to_vec(),
                sample_rate_hz: p.sample_rate_hz,
            };
            &owned
        };
        let n = p.n_frames();
        if n < 3 || p.sample_rate_hz.is_nan() || p.sample_rate_hz <= 0.0 {
            return Err(Error::Unusable(format!("trial {}: {n} frames at {} Hz", k + 1, p.sample_rate_hz)));
        }
        let up = [0.0, 1.0, 0.0];
        let root_k = pts.root;
        let root = |f: usize| p.points_mm[f * p.names.len() + root_k].map(|v| v / 1000.0);
        let travel = sub(root(n - 1), root(0));
        let flat = [travel[0], 0.0, travel[2]];
        let len = norm(flat);
        if len < 0.3 {
            return Err(Error::Unusable(format!("trial {}: the body travels {len:.2} m; not a walk", k + 1)));
        }
        let forward = flat.map(|v| v / len);
        let t = Trial { p, up };
        let dt = 1.0 / p.sample_rate_hz;
        let min_off = (0.2 / dt) as usize;
        let on: Vec<Vec<bool>> = pts.sides.iter().map(|x| stance(&t, x.ankle, x.ball)).collect();
        for (s, &Side { ankle, hip, knee, .. }) in pts.sides.iter().enumerate() {
            let c = &on[s];
            let strikes = onsets(c, min_off);
            self.leg.push(
                norm(sub(t.at(0, knee), t.at(0, hip)))
                    + norm(sub(t.at(0, ankle), t.at(0, knee)))
                    + (0..n).map(|f| dot(t.at(f, ankle), up)).fold(f64::INFINITY, f64::min),
            );
            for w in strikes.windows(2) {
                let (a, b) = (w[0], w[1]);
                let on_share = c[a..b].iter().filter(|x| **x).count() as f64 / (b - a) as f64;
                self.duty += on_share;
                self.duty_n += 1;
                if s == 0 {
                    self.periods.push((b - a) as f64 * dt);
                    self.stride_len.push(dot(sub(root(b), root(a)), forward));
                }
                self.swing(&t, ankle, c, (a, b), forward);
            }
        }
        self.joint_cycles(&t, &pts, &onsets(&on[0], min_off), forward);
        Ok(())
    }

    /// The swing of `ankle` in the stride `a..b` (the last lift-off before b):
    /// its lift and the profiles of its height and progress.
    fn swing(&mut self, t: &Trial<'_>, ankle: usize, c: &[bool], (a, b): (usize, usize), forward: V3) {
        let up = t.up;
        let Some(off) = (a..b).rev().find(|&f| c[f]) else { return };
        let swing: Vec<usize> = (off + 1..=b).collect();
        if swing.len() < 4 {
            return;
        }
        // The height above the line from lift-off to touch-down: the
        // heel's rise at push-off is the foot's roll, which a flat
        // robot foot does not make.
        let h0: Vec<f64> = swing.iter().map(|&f| dot(t.at(f, ankle), up)).collect();
        let m = h0.len() - 1;
        let h: Vec<f64> =
            h0.iter().enumerate().map(|(i, v)| v - (h0[0] + (h0[m] - h0[0]) * i as f64 / m as f64)).collect();
        let peak = h.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if peak <= 0.0 {
            return;
        }
        self.lift.push(peak);
        self.lift_profiles.push(resample(&h.iter().map(|v| (v / peak).max(0.0)).collect::<Vec<_>>(), PROFILE_SAMPLES));
        let x: Vec<f64> = swing.iter().map(|&f| dot(t.at(f, ankle), forward)).collect();
        let span = x[x.len() - 1] - x[0];
        if span > 0.0 {
            self.advance_profiles.push(resample(
                &x.iter().map(|v| ((v - x[0]) / span).clamp(0.0, 1.0)).collect::<Vec<_>>(),
                PROFILE_SAMPLES,
            ));
        }
    }

    /// Every joint's cycle over each stride between the left touch-downs `strikes`.
    fn joint_cycles(&mut self, t: &Trial<'_>, pts: &Points, strikes: &[usize], forward: V3) {
        let up = t.up;
        let cycles = &mut self.cycles;
        for w in strikes.windows(2) {
            let (a, b) = (w[0], w[1]);
            let mut add = |name: String, v: Vec<f64>| match cycles.iter_mut().find(|(n, _)| *n == name) {
                Some((_, list)) => list.push(v),
                None => cycles.push((name, vec![v])),
            };
            for (side, &Side { hip, knee, ankle, ball, shoulder, elbow, wrist }) in
                ["l", "r"].into_iter().zip(&pts.sides)
            {
                let series = |g: &dyn Fn(usize) -> f64| -> Vec<f64> {
                    resample(&(a..=b).map(g).collect::<Vec<_>>(), CYCLE_SAMPLES + 1)[..CYCLE_SAMPLES].to_vec()
                };
                add(format!("hip_flexion_{side}"), series(&|f| pitch_deg(t.at(f, hip), t.at(f, knee), forward, up)));
                add(format!("knee_flexion_{side}"), series(&|f| bend_deg(t.at(f, hip), t.at(f, knee), t.at(f, ankle))));
                add(
                    format!("ankle_{side}"),
                    series(&|f| bend_deg(t.at(f, knee), t.at(f, ankle), t.at(f, ball)) - 90.0),
                );
                add(
                    format!("shoulder_flexion_{side}"),
                    series(&|f| pitch_deg(t.at(f, shoulder), t.at(f, elbow), forward, up)),
                );
                add(
                    format!("elbow_flexion_{side}"),
                    series(&|f| bend_deg(t.at(f, shoulder), t.at(f, elbow), t.at(f, wrist))),
                );
            }
        }
    }

    /// The medians and mean profiles.
    fn finish(mut self) -> Result<HumanWalk> {
        if self.periods.is_empty() || self.lift_profiles.is_empty() || self.advance_profiles.is_empty() {
            return Err(Error::Unusable(
                "no full stride (two left touch-downs with a swing between) in the trials".into(),
            ));
        }
        let median = |v: &mut Vec<f64>| crate::stats::median(v);
        let mean_profile = |ps: &[Vec<f64>]| -> Vec<f64> {
            (0..ps[0].len()).map(|i| ps.iter().map(|p| p[i]).sum::<f64>() / ps.len() as f64).collect()
        };
        let mut lift_profile = mean_profile(&self.lift_profiles);
        let peak = lift_profile.iter().cloned().fold(0.0, f64::max);
        if peak > 0.0 {
            lift_profile.iter_mut().for_each(|v| *v /= peak);
        }
        Ok(HumanWalk {
            strides: self.periods.len(),
            stride_period_s: median(&mut self.periods),
            duty_factor: self.duty / self.duty_n as f64,
            leg_length_m: median(&mut self.leg),
            stride_length_m: median(&mut self.stride_len),
            lift_m: median(&mut self.lift),
            lift_profile,
            advance_profile: mean_profile(&self.advance_profiles),
            cycles_deg: self.cycles.into_iter().map(|(n, list)| (n, mean_profile(&list))).collect(),
        })
    }
}

/// The slowest tempo of a retargeted walk (times the person's stride rate).
pub const MIN_TEMPO: f64 = 0.5;
/// The fastest tempo of a retargeted walk.
pub const MAX_TEMPO: f64 = 2.0;

/// What the robot's walk asks beyond the human's timing.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RetargetOptions {
    /// The robot's step as a share of the human's step scaled to the robot's leg.
    pub step_scale: f64,
    /// The swing lift as a share of the human's lift scaled to the robot's leg.
    pub lift_scale: f64,
    /// The arms' swing as a share of the human's.
    pub arm_scale: f64,
    /// The share of a step on both feet, instead of the human's.
    pub double_support_share: Option<f64>,
    /// The swing foot's least lift, as a share of a half-sine of the peak
    /// lift: the person's heel nears the floor well before touch-down, and a
    /// flat robot foot that close to the floor scuffs it.
    pub clearance: f64,
    /// Each sole centre's distance from the midline, metres.
    pub foot_y_m: f64,
    /// The trunk origin's height, metres.
    pub trunk_height_m: f64,
    /// Steps to walk.
    pub steps: usize,
    /// Standing before and after, seconds.
    pub stand_s: f64,
    /// The planner's rate, Hz.
    pub rate_hz: f64,
    /// The stride rate as a multiple of the person's (steps as long).
    pub tempo: f64,
}

impl Default for RetargetOptions {
    fn default() -> Self {
        RetargetOptions {
            step_scale: 0.2,
            lift_scale: 0.4,
            arm_scale: 1.0,
            double_support_share: None,
            clearance: 0.5,
            foot_y_m: 0.042,
            trunk_height_m: 0.2789,
            steps: 20,
            stand_s: 1.0,
            rate_hz: 200.0,
            tempo: 1.0,
        }
    }
}

/// The robot's leg, hip joint to floor with the leg straight, metres.
pub fn robot_leg_length_m(robot: &Robot) -> Result<f64> {
    let spec = robot.spec()?;
    let z = |n: &str| robot.joint(n).map(|j| j.origin_m[2]).map_err(Error::from);
    Ok(-(z(&spec.legs.left.knee)? + z(&spec.legs.left.ankle_pitch)?) + spec.feet.ankle_height_m)
}

/// The walk's parameters for `robot` from the human's walk.
pub fn walk_params(human: &HumanWalk, robot: &Robot, o: &RetargetOptions) -> Result<WalkParams> {
    for (name, v, hi) in
        [("step scale", o.step_scale, 2.0), ("lift scale", o.lift_scale, 2.0), ("arm scale", o.arm_scale, 2.0)]
    {
        if !(v.is_finite() && (0.0..=hi).contains(&v)) {
            return Err(Error::Bound(format!("{name} {v}: expected 0–{hi}")));
        }
    }
    if !(o.tempo.is_finite() && (MIN_TEMPO..=MAX_TEMPO).contains(&o.tempo)) {
        return Err(Error::Bound(format!("tempo {}: expected {MIN_TEMPO}–{MAX_TEMPO}", o.tempo)));
    }
    let scale = robot_leg_length_m(robot)? / human.leg_length_m;
    let cycle = |name: &str| human.cycles_deg.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone());
    let mut arm_swing = Vec::new();
    for (side, sign) in [("l", 1.0), ("r", 1.0)] {
        // Shoulder: joint 1 smaller swings the arm forward; elbow: joint 4 negative flexes.
        for (human_name, joint, s) in
            [("shoulder_flexion", "arm_joint_1", -1.0), ("elbow_flexion", "arm_joint_4", -1.0)]
        {
            let Some(v) = cycle(&format!("{human_name}_{side}")) else { continue };
            // The shoulder swings about the hanging arm; the elbow flexes from straight (its home).
            let base = if joint == "arm_joint_4" {
                v.iter().cloned().fold(f64::INFINITY, f64::min)
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            };
            let mut off: Vec<f64> = v.iter().map(|x| (x - base).to_radians() * s * sign * o.arm_scale).collect();
            off.push(off[0]);
            arm_swing.push((format!("{side}{joint}"), off));
        }
    }
    Ok(WalkParams {
        stride_period_s: human.stride_period_s / o.tempo,
        double_support_share: o.double_support_share.unwrap_or((2.0 * human.duty_factor - 1.0).clamp(0.0, 0.8)),
        step_length_m: o.step_scale * human.stride_length_m / 2.0 * scale,
        foot_y_m: o.foot_y_m,
        lift_m: o.lift_scale * human.lift_m * scale,
        lift_profile: {
            let n = human.lift_profile.len().max(2) - 1;
            human
                .lift_profile
                .iter()
                .enumerate()
                .map(|(i, v)| v.max(o.clearance * (std::f64::consts::PI * i as f64 / n as f64).sin()))
                .collect()
        },
        advance_profile: human.advance_profile.clone(),
        trunk_height_m: o.trunk_height_m,
        steps: o.steps,
        stand_s: o.stand_s,
        rate_hz: o.rate_hz,
        preview_s: 1.6,
        arm_swing,
    })
}

/// How one robot joint's cycle compares with the human's.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StyleRow {
    /// The human's measure (`knee_flexion_l`).
    pub human: String,
    /// The robot's joint.
    pub joint: String,
    /// Pearson correlation of the two time-normalised cycles.
    pub correlation: f64,
    /// The robot's range over the human's.
    pub range_ratio: f64,
    /// The best correlation at any phase shift, and the shift in cycles.
    pub shifted: (f64, f64),
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// The robot's joint cycles over its steady stride against the human's.
pub fn style(human: &HumanWalk, plan: &WalkPlan) -> Vec<StyleRow> {
    let (a, b) = plan.steady_stride;
    let d = plan.joints.len();
    let joint = |name: &str| -> Option<Vec<f64>> {
        let k = plan.joints.iter().position(|j| j == name)?;
        let v: Vec<f64> = (a..=b).map(|f| plan.q_rad[f * d + k].to_degrees()).collect();
        Some(resample(&v, CYCLE_SAMPLES + 1)[..CYCLE_SAMPLES].to_vec())
    };
    // (human measure, robot joint, sign that makes them the same sense)
    let pairs = [
        ("hip_flexion_l", "lleg_joint_3", -1.0),
        ("hip_flexion_r", "rleg_joint_3", -1.0),
        ("knee_flexion_l", "lleg_joint_4", 1.0),
        ("knee_flexion_r", "rleg_joint_4", 1.0),
        ("ankle_l", "lleg_joint_5", 1.0),
        ("ankle_r", "rleg_joint_5", 1.0),
        ("shoulder_flexion_l", "larm_joint_1", -1.0),
        ("shoulder_flexion_r", "rarm_joint_1", -1.0),
        ("elbow_flexion_l", "larm_joint_4", -1.0),
        ("elbow_flexion_r", "rarm_joint_4", -1.0),
    ];
    let mut out = Vec::new();
    for (h, j, sign) in pairs {
        let (Some((_, hv)), Some(rv)) = (human.cycles_deg.iter().find(|(n, _)| n == h), joint(j)) else { continue };
        let rv: Vec<f64> = rv.iter().map(|v| v * sign).collect();
        let range = |v: &[f64]| {
            v.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - v.iter().cloned().fold(f64::INFINITY, f64::min)
        };
        let mut best = (f64::NEG_INFINITY, 0.0);
        for shift in 0..CYCLE_SAMPLES {
            let s = shift as f64 / CYCLE_SAMPLES as f64;
            let moved: Vec<f64> =
                (0..CYCLE_SAMPLES).map(|i| cyclic(&rv, i as f64 / CYCLE_SAMPLES as f64 + s)).collect();
            let c = pearson(hv, &moved);
            if c > best.0 {
                best = (c, if s > 0.5 { s - 1.0 } else { s });
            }
        }
        out.push(StyleRow {
            human: h.to_owned(),
            joint: j.to_owned(),
            correlation: pearson(hv, &rv),
            range_ratio: range(&rv) / range(hv),
            shifted: best,
        });
    }
    out
}

/// What a plan asks of the robot: its joints' limits and speeds, and its ZMP margins.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlanChecks {
    /// Joints that leave their position range somewhere.
    pub outside_limits: Vec<String>,
    /// The fastest joint and its speed, rad/s.
    pub fastest_joint: (String, f64),
    /// The share of frames whose ZMP lies inside the support polygon.
    pub zmp_inside_share: f64,
    /// The ZMP's margin over the single-support frames, metres.
    pub single_support_margin_m: crate::stats::Spread,
}

/// Checks `plan` against `robot`'s limits.
pub fn check_plan(plan: &WalkPlan, robot: &Robot) -> PlanChecks {
    let (n, d) = (plan.n_frames(), plan.joints.len());
    let mut fastest = (String::new(), 0.0);
    let mut outside = Vec::new();
    for (k, j) in robot.joints.iter().enumerate() {
        let q = |f: usize| plan.q_rad[f * d + k];
        if (0..n).any(|f| q(f) < j.lower_rad - 1e-9 || q(f) > j.upper_rad + 1e-9) {
            outside.push(j.name.clone());
        }
        for f in 1..n {
            let v = (q(f) - q(f - 1)).abs() * plan.rate_hz;
            if v > fastest.1 {
                fastest = (j.name.clone(), v);
            }
        }
    }
    let single: Vec<f64> =
        (0..n).filter(|&f| plan.support[f] != cpg_robot::walk::Support::Double).map(|f| plan.margin_m[f]).collect();
    PlanChecks {
        outside_limits: outside,
        fastest_joint: fastest,
        zmp_inside_share: plan.margin_m.iter().filter(|m| **m >= 0.0).count() as f64 / n.max(1) as f64,
        single_support_margin_m: crate::stats::Spread::of(&single),
    }
}

/// The robot's walk from the human's: parameters, plan, style.
pub fn retarget(
    human: &HumanWalk,
    robot: &Robot,
    mass: &MassModel,
    o: &RetargetOptions,
) -> Result<(WalkParams, WalkPlan, Vec<StyleRow>)> {
    let p = walk_params(human, robot, o)?;
    let plan = cpg_robot::walk::plan(robot, mass, &p)?;
    let s = style(human, &plan);
    Ok((p, plan, s))
}

//! A walk the HOAP-2 can balance: footsteps, a zero-moment-point (ZMP)
//! reference, the centre of mass from ZMP preview control on a cart-table
//! model (Kajita et al. 2003), the whole body's centre of mass put on that
//! path, and the joint angles by the legs' inverse kinematics.
//!
//! The human's part is its timing and style, given as [`WalkParams`]: the
//! stride period, the share of double support, the swing foot's lift and
//! forward progress over the swing (time-normalised), the step length in leg
//! lengths, and the arms' swing. The robot's part is the rest: its leg
//! length scales the foot paths, the stance foot stays flat on the floor,
//! the trunk upright at a constant height, the ZMP inside the soles.
//!
//! Conventions: world frame x forward, y left, z up, the floor at z = 0; the
//! trunk frame is the URDF's root link. [`plan`] returns every frame's 25
//! joint angles and what was planned and what results (the multi-body ZMP,
//! its margin to the support polygon).

use nalgebra::{Isometry3, Matrix3, Matrix4, Translation3, Unit, UnitQuaternion, Vector3, Vector4};

use crate::physics::{MassModel, com_of, home_pose_rad};
use crate::spec::{FeetSpec, LegSpec, leg_chain};
use crate::{Error, Result, Robot};

/// Gravity, m/s².
pub const G_M_S2: f64 = 9.81;

/// The most frames a plan holds.
pub const MAX_FRAMES: usize = 2_000_000;

/// What a walk keeps of the human and what it asks of the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct WalkParams {
    /// One stride (a left and a right step), seconds: the human's.
    pub stride_period_s: f64,
    /// The share of a step spent on both feet: the human's.
    pub double_support_share: f64,
    /// The distance between consecutive footprints along x, metres.
    pub step_length_m: f64,
    /// Each sole centre's distance from the midline, metres.
    pub foot_y_m: f64,
    /// The swing foot's highest lift above the floor, metres.
    pub lift_m: f64,
    /// The swing foot's height over its swing, sampled uniformly from lift-off to touch-down, peak 1.
    pub lift_profile: Vec<f64>,
    /// The swing foot's forward progress over its swing (0 at lift-off, 1 at touch-down), sampled likewise.
    pub advance_profile: Vec<f64>,
    /// The trunk origin's height above the floor, metres (constant).
    pub trunk_height_m: f64,
    /// Steps to walk (at least 2).
    pub steps: usize,
    /// Standing before the first and after the last step, seconds.
    pub stand_s: f64,
    /// The planner's rate, Hz.
    pub rate_hz: f64,
    /// How far ahead the preview controller looks, seconds.
    pub preview_s: f64,
    /// Arm joints' offsets from the home pose over one stride, radians, as
    /// (joint, samples uniform over the stride from the left foot's touch-down).
    pub arm_swing: Vec<(String, Vec<f64>)>,
}

/// Which feet are on the floor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Support {
    /// Both soles.
    Double,
    /// The left sole only (the right foot swings).
    Left,
    /// The right sole only.
    Right,
}

impl Support {
    /// `double`, `left` or `right`.
    pub fn as_str(self) -> &'static str {
        match self {
            Support::Double => "double",
            Support::Left => "left",
            Support::Right => "right",
        }
    }
}

/// A planned walk, every frame at [`WalkPlan::rate_hz`].
#[derive(Debug, Clone, PartialEq)]
pub struct WalkPlan {
    /// Frames per second.
    pub rate_hz: f64,
    /// The robot's joints, in its order.
    pub joints: Vec<String>,
    /// Joint angles, frames × joints, radians.
    pub q_rad: Vec<f64>,
    /// The trunk origin in the world, metres.
    pub trunk_m: Vec<[f64; 3]>,
    /// The ankles (left, right) in the world, metres.
    pub ankles_m: Vec<[[f64; 3]; 2]>,
    /// The ZMP the preview controller was asked to follow, metres.
    pub zmp_ref_m: Vec<[f64; 2]>,
    /// The whole body's centre of mass (from the joint angles), metres.
    pub com_m: Vec<[f64; 3]>,
    /// The multi-body ZMP of the joint angles (the links' masses and accelerations), metres.
    pub zmp_m: Vec<[f64; 2]>,
    /// Which soles carry the body.
    pub support: Vec<Support>,
    /// The ZMP's distance inside the support polygon (negative: outside), metres.
    pub margin_m: Vec<f64>,
    /// The frames of the first and the last full stride of steady walking (start, end).
    pub steady_stride: (usize, usize),
    /// The largest leg inverse-kinematics residual over the plan, metres.
    pub ik_residual_m: f64,
}

impl WalkPlan {
    /// The number of frames.
    pub fn n_frames(&self) -> usize {
        self.trunk_m.len()
    }
}

/// The preview controller's gains for a cart-table model.
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewGains {
    /// Gain on the summed ZMP error.
    pub gi: f64,
    /// State feedback gains (position, velocity, acceleration).
    pub gx: [f64; 3],
    /// Preview gains on the reference `j` steps ahead (j = 1..).
    pub gd: Vec<f64>,
}

fn cart_table(dt: f64, zc: f64) -> (Matrix3<f64>, Vector3<f64>, [f64; 3]) {
    let a = Matrix3::new(1.0, dt, dt * dt / 2.0, 0.0, 1.0, dt, 0.0, 0.0, 1.0);
    let b = Vector3::new(dt * dt * dt / 6.0, dt * dt / 2.0, dt);
    (a, b, [1.0, 0.0, -zc / G_M_S2])
}

/// The optimal preview gains (Katayama's servo form, as Kajita et al. 2003
/// use it): the cart-table model at step `dt_s` with the centre of mass at
/// `zc_m`, ZMP error weight `q`, jerk weight `r`, `n` steps of preview.
pub fn preview_gains(dt_s: f64, zc_m: f64, q: f64, r: f64, n: usize) -> Result<PreviewGains> {
    if !(dt_s > 0.0 && zc_m > 0.0 && q > 0.0 && r > 0.0 && dt_s.is_finite() && zc_m.is_finite()) {
        return Err(Error::Input(format!("preview gains need positive dt {dt_s}, height {zc_m}, weights {q}, {r}")));
    }
    let (a, b, c) = cart_table(dt_s, zc_m);
    let cv = nalgebra::RowVector3::from(c);
    // Augmented state: the ZMP error's integral and the state's increment.
    let mut at = Matrix4::zeros();
    at[(0, 0)] = 1.0;
    let ca = cv * a;
    for j in 0..3 {
        at[(0, j + 1)] = ca[j];
        for i in 0..3 {
            at[(i + 1, j + 1)] = a[(i, j)];
        }
    }
    let cb = (cv * b)[0];
    let bt = Vector4::new(cb, b[0], b[1], b[2]);
    let mut qt = Matrix4::zeros();
    qt[(0, 0)] = q;
    // The discrete Riccati equation by iteration.
    let mut p = qt;
    let mut converged = false;
    for _ in 0..100_000 {
        let s = r + (bt.transpose() * p * bt)[0];
        let k = (bt.transpose() * p * at) / s;
        let next = at.transpose() * p * at - at.transpose() * p * bt * k + qt;
        let change = (next - p).abs().max();
        p = next;
        if change <= 1e-12 * p.abs().max().max(1.0) {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(Error::Input("the preview controller's Riccati equation did not converge".into()));
    }
    let s = r + (bt.transpose() * p * bt)[0];
    let k = (bt.transpose() * p * at) / s;
    let ac = at - bt * k;
    let mut x = -(ac.transpose() * p * Vector4::new(1.0, 0.0, 0.0, 0.0));
    let mut gd = Vec::with_capacity(n);
    gd.push(-k[0]);
    for _ in 1..n {
        gd.push((bt.transpose() * x)[0] / s);
        x = ac.transpose() * x;
    }
    Ok(PreviewGains { gi: k[0], gx: [k[1], k[2], k[3]], gd })
}

/// The centre of mass that makes the cart-table ZMP follow `zmp_ref` (one
/// axis), from rest at `zmp_ref[0]`; the reference is held at its last value
/// past its end. Returns the positions and the model's ZMP.
pub fn preview_track(gains: &PreviewGains, dt_s: f64, zc_m: f64, zmp_ref: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (a, b, c) = cart_table(dt_s, zc_m);
    let n = zmp_ref.len();
    let at = |k: usize| zmp_ref[k.min(n.saturating_sub(1))];
    let mut x = Vector3::new(at(0), 0.0, 0.0);
    let mut sum_e = 0.0;
    let (mut com, mut zmp) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let p = c[0] * x[0] + c[1] * x[1] + c[2] * x[2];
        com.push(x[0]);
        zmp.push(p);
        sum_e += p - at(k);
        let mut u = -gains.gi * sum_e - (gains.gx[0] * x[0] + gains.gx[1] * x[1] + gains.gx[2] * x[2]);
        for (j, g) in gains.gd.iter().enumerate() {
            u -= g * at(k + j + 1);
        }
        x = a * x + b * u;
    }
    (com, zmp)
}

/// A joint's position and its axis, in the trunk frame.
type JointFrame = (Vector3<f64>, Vector3<f64>);

/// One leg as a chain of six revolute joints, trunk to foot.
#[derive(Debug, Clone)]
struct Leg {
    index: [usize; 6],
    origin: [Vector3<f64>; 6],
    axis: [Unit<Vector3<f64>>; 6],
    lower: [f64; 6],
    upper: [f64; 6],
}

impl Leg {
    fn new(robot: &Robot, leg: &LegSpec) -> Result<Leg> {
        // The chain's order in the URDF (the HOAP-2's: yaw, pitch, roll, knee, ankle pitch, ankle roll).
        let index = leg_chain(robot, leg)?;
        let j = |i: usize| &robot.joints[index[i]];
        Ok(Leg {
            index,
            origin: std::array::from_fn(|i| Vector3::from(j(i).origin_m)),
            axis: std::array::from_fn(|i| Unit::new_normalize(Vector3::from(j(i).axis))),
            lower: std::array::from_fn(|i| j(i).lower_rad),
            upper: std::array::from_fn(|i| j(i).upper_rad),
        })
    }

    /// The foot link's pose in the trunk frame and each joint's (position, world axis).
    fn forward(&self, q: &[f64; 6]) -> (Isometry3<f64>, [JointFrame; 6]) {
        let mut pose = Isometry3::identity();
        let mut frames = [(Vector3::zeros(), Vector3::zeros()); 6];
        for i in 0..6 {
            pose *= Isometry3::from_parts(
                Translation3::from(self.origin[i]),
                UnitQuaternion::from_axis_angle(&self.axis[i], q[i]),
            );
            frames[i] = (pose.translation.vector, pose.rotation * self.axis[i].into_inner());
        }
        (pose, frames)
    }

    /// Joint angles putting the foot link at `target` (trunk frame), from
    /// `q`; returns the position residual in metres. Damped least squares.
    fn solve(&self, target: &Isometry3<f64>, q: &mut [f64; 6]) -> f64 {
        let mut residual = f64::INFINITY;
        for _ in 0..50 {
            let (pose, frames) = self.forward(q);
            let dp = target.translation.vector - pose.translation.vector;
            let dr = (target.rotation * pose.rotation.inverse()).scaled_axis();
            residual = dp.norm();
            if residual < 1e-9 && dr.norm() < 1e-8 {
                break;
            }
            let mut jac = nalgebra::Matrix6::zeros();
            for (i, (p, w)) in frames.iter().enumerate() {
                let lin = w.cross(&(pose.translation.vector - p));
                for r in 0..3 {
                    jac[(r, i)] = lin[r];
                    jac[(r + 3, i)] = w[r];
                }
            }
            let e = nalgebra::Vector6::new(dp.x, dp.y, dp.z, dr.x, dr.y, dr.z);
            let damp = 1e-6;
            let jjt = jac * jac.transpose() + nalgebra::Matrix6::identity() * damp;
            let Some(step) = jjt.lu().solve(&e) else { break };
            let dq = jac.transpose() * step;
            for i in 0..6 {
                q[i] = (q[i] + dq[i]).clamp(self.lower[i], self.upper[i]);
            }
        }
        residual
    }
}

/// The stride's phase in [0, 1) at frame `f`: its share of the way from
/// the last left touch-down in `strikes` to the next, so the arms keep
/// time with the legs whatever the rounding of each step to whole frames
/// (a phase counted at the nominal `stride_frames` drifts a little every
/// stride); before the first and after the last touch-down, the nearest
/// stride's length carries on.
fn stride_phase(f: usize, strikes: &[usize], stride_frames: f64) -> f64 {
    let f = f as f64;
    let len = |a: usize, b: usize| (b - a) as f64;
    let (from, period) = match strikes.iter().position(|&s| s as f64 > f) {
        // Between two touch-downs.
        Some(k) if k > 0 => (strikes[k - 1] as f64, len(strikes[k - 1], strikes[k])),
        // Before the first.
        Some(_) => (strikes[0] as f64, if strikes.len() > 1 { len(strikes[0], strikes[1]) } else { stride_frames }),
        // After the last (or none).
        None => match strikes {
            [.., a, b] => (*b as f64, len(*a, *b)),
            [a] => (*a as f64, stride_frames),
            [] => (0.0, stride_frames),
        },
    };
    ((f - from) / period).rem_euclid(1.0)
}

/// Where each foot is and which carries the body, from the step timing.
struct Footsteps {
    /// Per frame: left ankle, right ankle (world), support.
    ankles: Vec<[[f64; 3]; 2]>,
    support: Vec<Support>,
    zmp_ref: Vec<[f64; 2]>,
    /// The frame at which each left touch-down happens.
    left_strikes: Vec<usize>,
}

/// A profile sampled uniformly over [0, 1], at `s` (clamped), linear between samples.
pub fn sample(profile: &[f64], s: f64) -> f64 {
    let n = profile.len();
    if n == 0 {
        return 0.0;
    }
    if n == 1 {
        return profile[0];
    }
    let x = s.clamp(0.0, 1.0) * (n - 1) as f64;
    let i = (x.floor() as usize).min(n - 2);
    let f = x - i as f64;
    profile[i] * (1.0 - f) + profile[i + 1] * f
}

fn footsteps(p: &WalkParams, feet: &FeetSpec) -> Footsteps {
    let (sole_in_ankle, ankle_height) = (feet.sole_in_ankle_m, feet.ankle_height_m);
    let dt = 1.0 / p.rate_hz;
    let step_s = p.stride_period_s / 2.0;
    let ds_s = p.double_support_share * step_s;
    let ss_s = step_s - ds_s;
    let sole = |ankle: [f64; 3]| [ankle[0] + sole_in_ankle[0], ankle[1] + sole_in_ankle[1]];
    let mut left = [0.0, p.foot_y_m, ankle_height];
    let mut right = [0.0, -p.foot_y_m, ankle_height];
    let mut out = Footsteps { ankles: Vec::new(), support: Vec::new(), zmp_ref: Vec::new(), left_strikes: Vec::new() };
    let push = |out: &mut Footsteps, l: [f64; 3], r: [f64; 3], s: Support, z: [f64; 2]| {
        out.ankles.push([l, r]);
        out.support.push(s);
        out.zmp_ref.push(z);
    };
    let frames = |s: f64| (s / dt).round().max(1.0) as usize;
    let mid = |a: [f64; 2], b: [f64; 2]| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
    let lerp = |a: [f64; 2], b: [f64; 2], f: f64| [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f];
    for _ in 0..frames(p.stand_s) {
        push(&mut out, left, right, Support::Double, mid(sole(left), sole(right)));
    }
    // Step k: the right foot swings on even k, the left on odd k. The first
    // and the last step move the swing foot by one step length, the others by two.
    let mut zmp_from = mid(sole(left), sole(right));
    for k in 0..p.steps {
        let right_swings = k % 2 == 0;
        let advance = if k == 0 || k + 1 == p.steps { p.step_length_m } else { 2.0 * p.step_length_m };
        let stance = if right_swings { left } else { right };
        // Double support: the ZMP moves onto the stance sole (the first shift takes a whole step).
        let n_ds = if k == 0 { frames(step_s) } else { frames(ds_s) };
        for i in 0..n_ds {
            let f = (i + 1) as f64 / n_ds as f64;
            push(&mut out, left, right, Support::Double, lerp(zmp_from, sole(stance), f));
        }
        let n_ss = frames(ss_s);
        let swing0 = if right_swings { right } else { left };
        for i in 0..n_ss {
            let s = (i + 1) as f64 / n_ss as f64;
            let x = swing0[0] + advance * sample(&p.advance_profile, s);
            let z = ankle_height + p.lift_m * sample(&p.lift_profile, s);
            let foot = [x, swing0[1], z];
            let (l, r, sup) = if right_swings { (left, foot, Support::Left) } else { (foot, right, Support::Right) };
            push(&mut out, l, r, sup, sole(stance));
        }
        if right_swings {
            right = [swing0[0] + advance, swing0[1], ankle_height];
        } else {
            left = [swing0[0] + advance, swing0[1], ankle_height];
            out.left_strikes.push(out.ankles.len());
        }
        zmp_from = sole(stance);
    }
    // The last shift back to the middle takes a whole step; then stand.
    let n_end = frames(step_s);
    let end = mid(sole(left), sole(right));
    for i in 0..n_end {
        let f = (i + 1) as f64 / n_end as f64;
        push(&mut out, left, right, Support::Double, lerp(zmp_from, end, f));
    }
    for _ in 0..frames(p.stand_s) {
        push(&mut out, left, right, Support::Double, end);
    }
    out
}

/// A convex polygon's signed distance to point `p`: positive inside (to the nearest edge), negative outside.
pub fn polygon_margin(hull: &[[f64; 2]], p: [f64; 2]) -> f64 {
    let n = hull.len();
    if n < 3 {
        return f64::NEG_INFINITY;
    }
    let mut inside = true;
    let mut nearest = f64::INFINITY;
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
        let len2 = ex * ex + ey * ey;
        let t = (((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / len2).clamp(0.0, 1.0);
        let (dx, dy) = (p[0] - a[0] - t * ex, p[1] - a[1] - t * ey);
        nearest = nearest.min((dx * dx + dy * dy).sqrt());
        // Counter-clockwise hull: inside is to the left of every edge.
        if ex * (p[1] - a[1]) - ey * (p[0] - a[0]) < 0.0 {
            inside = false;
        }
    }
    if inside { nearest } else { -nearest }
}

/// The convex hull of points, counter-clockwise (Andrew's monotone chain).
pub fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> =
            if pass == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
        for &p in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The soles' corners (world xy) of the feet that carry the body.
fn support_corners(ankles: &[[f64; 3]; 2], support: Support, feet: &FeetSpec) -> Vec<[f64; 2]> {
    let (sole_in_ankle, sole_size) = (feet.sole_in_ankle_m, feet.sole_size_m);
    let feet: &[usize] = match support {
        Support::Double => &[0, 1],
        Support::Left => &[0],
        Support::Right => &[1],
    };
    let mut out = Vec::with_capacity(8);
    for &f in feet {
        let c = [ankles[f][0] + sole_in_ankle[0], ankles[f][1] + sole_in_ankle[1]];
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            out.push([c[0] + sx * sole_size[0] / 2.0, c[1] + sy * sole_size[1] / 2.0]);
        }
    }
    out
}

/// Checks a walk's parameters.
fn check_params(p: &WalkParams) -> Result<()> {
    let bad = |what: String| Err(Error::Input(what));
    if !(p.stride_period_s > 0.1 && p.stride_period_s < 10.0) {
        return bad(format!("stride period {} s: expected 0.1–10 s", p.stride_period_s));
    }
    if !(0.0..0.9).contains(&p.double_support_share) {
        return bad(format!("double support share {}: expected 0–0.9", p.double_support_share));
    }
    if !(p.rate_hz >= 20.0 && p.rate_hz <= 2000.0) {
        return bad(format!("planner rate {} Hz: expected 20–2000 Hz", p.rate_hz));
    }
    if p.steps < 2 || p.steps > 10_000 {
        return bad(format!("{} steps: expected 2–10000", p.steps));
    }
    for (name, v) in [
        ("step length", p.step_length_m),
        ("foot y", p.foot_y_m),
        ("lift", p.lift_m),
        ("trunk height", p.trunk_height_m),
        ("stand", p.stand_s),
        ("preview", p.preview_s),
    ] {
        if !(v.is_finite() && (0.0..10.0).contains(&v)) {
            return bad(format!("{name} {v}: expected a finite value in 0–10"));
        }
    }
    Ok(())
}

/// The multi-body ZMP of every frame (every link's centre of mass,
/// accelerations by central differences) and its margin to the support polygon.
fn multibody_zmp(
    robot: &Robot,
    mass: &MassModel,
    names: &[String],
    q_all: &[f64],
    trunk: &[[f64; 3]],
    steps: &Footsteps,
    dt: f64,
) -> Result<(Vec<[f64; 2]>, Vec<f64>)> {
    let n = trunk.len();
    let mut pts = Vec::with_capacity(robot.joints.len() + 1);
    let mut link_paths: Vec<Vec<(f64, Vector3<f64>)>> = Vec::with_capacity(n);
    for f in 0..n {
        let qf = &q_all[f * names.len()..(f + 1) * names.len()];
        mass.points(&robot.link_poses(names, qf)?, &mut pts);
        let t = Vector3::from(trunk[f]);
        link_paths.push(pts.iter().map(|(m, c)| (*m, c + t)).collect());
    }
    let mut zmp = Vec::with_capacity(n);
    let mut margin = Vec::with_capacity(n);
    for f in 0..n {
        let (a, b) = (f.saturating_sub(1), (f + 1).min(n - 1));
        let (mut num_x, mut num_y, mut den) = (0.0, 0.0, 0.0);
        for (i, (m, c)) in link_paths[f].iter().enumerate() {
            let acc = if b > a && f > 0 && f + 1 < n {
                (link_paths[b][i].1 - 2.0 * c + link_paths[a][i].1) / (dt * dt)
            } else {
                Vector3::zeros()
            };
            let w = m * (acc.z + G_M_S2);
            num_x += w * c.x - m * acc.x * c.z;
            num_y += w * c.y - m * acc.y * c.z;
            den += w;
        }
        let z = [num_x / den, num_y / den];
        zmp.push(z);
        let hull = convex_hull(&support_corners(&steps.ankles[f], steps.support[f], &robot.spec()?.feet));
        margin.push(polygon_margin(&hull, z));
    }
    Ok((zmp, margin))
}

/// Plans a walk of `robot` (its URDF `urdf` gives the masses) as `p` asks.
pub fn plan(robot: &Robot, mass: &MassModel, p: &WalkParams) -> Result<WalkPlan> {
    check_params(p)?;
    let bad = |what: String| Err(Error::Input(what));
    let names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    let arms: Vec<(usize, &Vec<f64>)> = p
        .arm_swing
        .iter()
        .map(|(j, v)| {
            robot
                .joints
                .iter()
                .position(|x| &x.name == j)
                .map(|k| (k, v))
                .ok_or_else(|| Error::UnknownJoint { name: j.clone(), valid: names.clone() })
        })
        .collect::<Result<_>>()?;
    let spec = robot.spec()?;
    let legs = [Leg::new(robot, &spec.legs.left)?, Leg::new(robot, &spec.legs.right)?];
    let dt = 1.0 / p.rate_hz;
    let expected = (2.0 * p.stand_s + (p.steps as f64 + 2.0) * p.stride_period_s / 2.0) * p.rate_hz;
    if expected > MAX_FRAMES as f64 {
        return bad(format!(
            "the walk needs about {expected:.0} frames: at most {MAX_FRAMES} (fewer steps or a lower rate)"
        ));
    }
    let steps = footsteps(p, &spec.feet);
    let n = steps.ankles.len();

    // The home crouch's whole-body centre of mass, relative to the trunk origin.
    let home = home_pose_rad(robot)?;
    let mut pts = Vec::with_capacity(robot.joints.len() + 1);
    mass.points(&robot.link_poses(&names, &home)?, &mut pts);
    let com_home = com_of(&pts);
    let zc = p.trunk_height_m + com_home.z;
    let gains = preview_gains(dt, zc, 1.0, 1e-6, (p.preview_s / dt).round().max(1.0) as usize)?;
    let rx: Vec<f64> = steps.zmp_ref.iter().map(|z| z[0]).collect();
    let ry: Vec<f64> = steps.zmp_ref.iter().map(|z| z[1]).collect();
    let (cx, _) = preview_track(&gains, dt, zc, &rx);
    let (cy, _) = preview_track(&gains, dt, zc, &ry);

    // Stride phase for the arms: from each left touch-down, over one stride.
    let stride_frames = p.stride_period_s / dt;
    let stand_frames = ((p.stand_s / dt).round() as usize).min(n / 2);
    let mut q_all = vec![0.0; n * names.len()];
    let mut trunk = Vec::with_capacity(n);
    let mut com = Vec::with_capacity(n);
    let mut q = home.clone();
    let mut leg_q = [[0.0; 6]; 2];
    for (s, leg) in legs.iter().enumerate() {
        for i in 0..6 {
            leg_q[s][i] = home[leg.index[i]];
        }
    }
    let mut residual_max: f64 = 0.0;
    let mut offset = Vector3::new(com_home.x, com_home.y, 0.0);
    for f in 0..n {
        // Arms: the human's swing, in phase with the stride, beside the home pose.
        // They fade in over the first stride of walking and out over the last.
        let phase = stride_phase(f, &steps.left_strikes, stride_frames);
        let (walk_from, walk_to) = (stand_frames as f64, (n - stand_frames) as f64);
        let fade = ((f as f64 - walk_from) / stride_frames).clamp(0.0, 1.0)
            * ((walk_to - f as f64) / stride_frames).clamp(0.0, 1.0);
        for &(k, v) in &arms {
            let j = &robot.joints[k];
            q[k] = (home[k] + fade * sample(v, phase)).clamp(j.lower_rad, j.upper_rad);
        }
        // Put the whole body's CoM on the planned path: move the trunk by the
        // CoM's error until it moves less than a micrometre.
        let mut residual = 0.0;
        let mut t = Vector3::zeros();
        for _ in 0..20 {
            let before = offset;
            t = Vector3::new(cx[f] - offset.x, cy[f] - offset.y, p.trunk_height_m);
            residual = 0.0_f64;
            for (s, leg) in legs.iter().enumerate() {
                let a = steps.ankles[f][s];
                let target = Isometry3::from_parts(
                    Translation3::new(a[0] - t.x, a[1] - t.y, a[2] - t.z),
                    UnitQuaternion::identity(),
                );
                residual = residual.max(leg.solve(&target, &mut leg_q[s]));
                for i in 0..6 {
                    q[leg.index[i]] = leg_q[s][i];
                }
            }
            mass.points(&robot.link_poses(&names, &q)?, &mut pts);
            let c = com_of(&pts);
            offset = Vector3::new(c.x, c.y, c.z);
            if (offset - before).xy().norm() < 1e-6 {
                break;
            }
        }
        residual_max = residual_max.max(residual);
        q_all[f * names.len()..(f + 1) * names.len()].copy_from_slice(&q);
        trunk.push([t.x, t.y, t.z]);
        com.push([t.x + offset.x, t.y + offset.y, t.z + offset.z]);
    }

    let (zmp, margin) = multibody_zmp(robot, mass, &names, &q_all, &trunk, &steps, dt)?;
    let steady_stride = match steps.left_strikes.as_slice() {
        [.., a, b, _] => (*a, *b),
        [a, b] => (*a, *b),
        _ => (0, n),
    };
    Ok(WalkPlan {
        rate_hz: p.rate_hz,
        joints: names,
        q_rad: q_all,
        trunk_m: trunk,
        ankles_m: steps.ankles,
        zmp_ref_m: steps.zmp_ref,
        com_m: com,
        zmp_m: zmp,
        support: steps.support,
        margin_m: margin,
        steady_stride,
        ik_residual_m: residual_max,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_preview_controller_follows_a_step_of_the_zmp() {
        let dt = 0.005;
        let g = preview_gains(dt, 0.25, 1.0, 1e-6, 320).unwrap();
        let zref: Vec<f64> = (0..1000).map(|k| if k < 400 { 0.0 } else { 0.05 }).collect();
        let (com, zmp) = preview_track(&g, dt, 0.25, &zref);
        // It moves before the step (preview), settles on the new value, and its ZMP follows the reference.
        assert!(com[399] > 0.005, "no anticipation: {}", com[399]);
        assert!((com[999] - 0.05).abs() < 1e-3, "{}", com[999]);
        let worst = zmp.iter().zip(&zref).skip(450).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 2e-3, "ZMP error {worst}");
    }

    #[test]
    fn the_stride_phase_restarts_at_every_left_touch_down() {
        let strikes = [100, 325, 551, 776];
        for &s in &strikes {
            assert_eq!(stride_phase(s, &strikes, 225.0), 0.0);
        }
        assert!((stride_phase(438, &strikes, 225.0) - 0.5).abs() < 1e-12);
        // Outside the touch-downs the nearest stride's length carries on.
        assert!((stride_phase(0, &strikes, 225.0) - (1.0 - 100.0 / 225.0)).abs() < 1e-12);
        assert_eq!(stride_phase(776 + 225, &strikes, 225.0), 0.0);
        assert_eq!(stride_phase(10, &[], 20.0), 0.5);
    }

    #[test]
    fn the_arms_keep_time_with_the_legs_over_a_long_walk() {
        // A stride whose steps round to whole frames (1.123 s at 200 Hz):
        // counted at the nominal period, the arms would drift a little every stride.
        let robot = Robot::hoap2().unwrap();
        let mass = MassModel::from_urdf(&robot, crate::assets::HOAP2_URDF, std::path::Path::new("hoap2.urdf")).unwrap();
        let swing: Vec<f64> = (0..=50).map(|i| 0.2 * (std::f64::consts::TAU * i as f64 / 50.0).sin()).collect();
        let p = WalkParams {
            stride_period_s: 1.123,
            double_support_share: 0.2,
            step_length_m: 0.03,
            foot_y_m: 0.039,
            lift_m: 0.02,
            lift_profile: vec![0.0, 1.0, 0.0],
            advance_profile: vec![0.0, 0.5, 1.0],
            trunk_height_m: 0.24,
            steps: 40,
            stand_s: 0.5,
            rate_hz: 200.0,
            preview_s: 1.0,
            arm_swing: vec![("larm_joint_1".into(), swing)],
        };
        let plan = plan(&robot, &mass, &p).unwrap();
        let steps = footsteps(&p, &robot.spec().unwrap().feet);
        let d = plan.joints.len();
        let k = plan.joints.iter().position(|j| j == "larm_joint_1").unwrap();
        let home = home_pose_rad(&robot).unwrap()[k];
        // Every left touch-down after the arms have faded in, up to the last stride: the swing's start.
        let strikes = &steps.left_strikes[1..steps.left_strikes.len() - 1];
        assert!(strikes.len() > 15);
        for &f in strikes {
            let q = plan.q_rad[f * d + k];
            assert!((q - home).abs() < 1e-9, "frame {f}: {:.4} rad off the swing's start", q - home);
        }
        // A quarter of each stride on: the swing's crest.
        for w in strikes.windows(2) {
            let f = w[0] + (w[1] - w[0]) / 4;
            let q = plan.q_rad[f * d + k] - home;
            assert!((q - 0.2).abs() < 0.01, "frame {f}: {q:.4} rad, the crest is 0.2");
        }
    }

    #[test]
    fn hull_and_margin() {
        let h = convex_hull(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]]);
        assert_eq!(h.len(), 4);
        assert!((polygon_margin(&h, [0.5, 0.5]) - 0.5).abs() < 1e-12);
        assert!((polygon_margin(&h, [0.5, 0.1]) - 0.1).abs() < 1e-12);
        assert!((polygon_margin(&h, [1.5, 0.5]) + 0.5).abs() < 1e-12);
    }
}

//! # cpg-view
//!
//! Watch motion as stick figures: a human skeleton from mocap forward
//! kinematics ([`Figure::human`]) and a robot from its URDF and a joint
//! trajectory ([`Figure::robot`]), side by side on one timeline
//! ([`Scene`]), written as
//!
//! - a self-contained HTML page ([`Scene::to_html`]): one file, no network
//!   (inline script and data, a 2-D canvas), with play/pause, speed, a time
//!   slider and a view angle that the mouse can drag;
//! - an animated GIF ([`Scene::to_gif`]) for papers and slides, drawn by the
//!   crate's own rasteriser (no font or system library).
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let skeleton = cpg_mocap::Skeleton::from_file("35.asf")?;
//! let motion = cpg_mocap::Motion::from_amc_file("35_01.amc", &skeleton, 120.0)?;
//! let walk = cpg_view::Figure::human("recorded walk", &skeleton, &motion)?;
//! let scene = cpg_view::Scene::new("35_01", 120.0, vec![walk])?;
//! std::fs::write("walk.html", scene.to_html())?;
//! std::fs::write("walk.gif", scene.to_gif(&cpg_view::GifOptions::default())?)?;
//! # Ok(()) }
//! ```
//!
//! Every figure is held in one frame: y up, millimetres; a human faces +z
//! with its left side at +x (the CMU convention), and a robot's URDF frame
//! (x forward, y left, z up, metres) is turned into it.

mod font;
mod raster;

use std::fmt::Write as _;

use cpg_mocap::{Motion, Skeleton};
use cpg_robot::{JointTrajectory, Robot};

pub use raster::{GifOptions, MAX_GIF_FRAMES};

/// The most coordinates one scene holds (every figure's frames × points × 3):
/// 128 MiB of `f32`, several minutes of three figures at 120 Hz.
pub const MAX_VALUES: usize = 1 << 25;

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Forward kinematics of a motion failed (a motion that does not fit its skeleton).
    #[error(transparent)]
    Mocap(#[from] cpg_mocap::Error),
    /// Robot kinematics failed.
    #[error(transparent)]
    Robot(#[from] cpg_robot::Error),
    /// The figures or options do not make a scene.
    #[error("{0}")]
    Input(String),
    /// The GIF encoder failed.
    #[error("encoding the GIF: {0}")]
    Gif(String),
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Which side of the body a segment belongs to (drawn in its own colour).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    /// Spine, head, trunk.
    Center,
    /// The left limbs.
    Left,
    /// The right limbs.
    Right,
}

impl Side {
    /// The side a bone or joint name belongs to: `Left…`/`Right…`, `l_`/`r_`,
    /// CMU's `l`/`r` + limb bone (`lfemur`, `rhumerus`, not `lowerback`) and
    /// HOAP-2's `lleg_`, `larm_`, `rleg_`, `rarm_`.
    pub fn of(name: &str) -> Side {
        const LIMBS: &[&str] = &[
            "hipjoint", "femur", "tibia", "foot", "toes", "clavicle", "humerus", "radius", "wrist", "hand", "fingers",
            "thumb", "leg", "arm", "hip", "knee", "ankle", "shoulder", "elbow", "upleg", "forearm", "toebase",
        ];
        let n = name.to_ascii_lowercase();
        let limb = |rest: &str| LIMBS.iter().any(|l| rest.starts_with(l));
        for (prefix, side) in [("left", Side::Left), ("right", Side::Right)] {
            if n.starts_with(prefix) {
                return side;
            }
        }
        match n.as_bytes().first() {
            Some(b'l') if n[1..].starts_with('_') || limb(&n[1..]) => Side::Left,
            Some(b'r') if n[1..].starts_with('_') || limb(&n[1..]) => Side::Right,
            _ => Side::Center,
        }
    }
}

/// One stick figure over time.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// Its name above the panel (`teacher`, `model`, `HOAP-2`).
    pub label: String,
    /// One line under the panel saying what is shown.
    pub note: String,
    /// Point names.
    pub names: Vec<String>,
    /// Segments between points, with the side each belongs to.
    pub segments: Vec<(usize, usize, Side)>,
    /// Points per frame, frame-major (`points_mm[frame * names.len() + point]`): y up, millimetres.
    pub points_mm: Vec<[f32; 3]>,
}

impl Figure {
    /// Frames held.
    pub fn n_frames(&self) -> usize {
        self.points_mm.len() / self.names.len().max(1)
    }

    /// A human skeleton moving as `motion` says: the root and every bone's
    /// end from [`Skeleton::forward_kinematics`], one segment per bone.
    /// Channels the motion lacks are 0; a motion without root translation is
    /// put on the floor first ([`Skeleton::ground`]).
    pub fn human(label: &str, skeleton: &Skeleton, motion: &Motion) -> Result<Figure> {
        check_frames(motion.n_frames(), skeleton.bones.len() + 1)?;
        let p = skeleton.forward_kinematics(&skeleton.ground(motion)?)?;
        let segments = skeleton
            .bones
            .iter()
            .enumerate()
            .filter(|(_, b)| b.length > 0.0)
            .map(|(k, b)| (b.parent.map_or(0, |p| p + 1), k + 1, Side::of(&b.name)))
            .collect();
        Ok(Figure {
            label: label.to_owned(),
            note: String::new(),
            names: p.names,
            segments,
            points_mm: p.points_mm.iter().map(|q| q.map(|v| v as f32)).collect(),
        })
    }

    /// A robot moving as the joint trajectory `t` says (joints it does not
    /// name stay at 0): the root link's origin and every joint's child-link
    /// origin from [`Robot::link_poses`], a segment from each joint's parent
    /// link to it, and the soles of its feet where its spec puts them
    /// (`feet.sole_in_ankle_m` of [`cpg_robot::RobotSpec`] below each leg's
    /// last joint; none for a robot read from a URDF alone).
    ///
    /// The robot is placed kinematically, with no dynamics: in every frame
    /// its lowest point touches the floor, and the body moves horizontally so
    /// that this point does not slide from one frame to the next.
    pub fn robot(label: &str, robot: &Robot, t: &JointTrajectory) -> Result<Figure> {
        let d = t.joints.len();
        let mut f = robot_figure(label, robot, t.n_frames(), &t.joints, |k| (&t.values_rad[k * d..(k + 1) * d], None))?;
        let n_pts = f.names.len();
        plant(&mut f.points_mm, n_pts);
        Ok(f)
    }

    /// A robot where a physics simulation put it: frame `k` has the joint
    /// angles `q_rad[k * joints.len()..]` and the root link's pose in the
    /// world `base[k]` (`[x, y, z]` in m, z up, and the orientation as a unit
    /// quaternion `[w, x, y, z]`), nothing planted or moved.
    pub fn robot_posed(
        label: &str,
        robot: &Robot,
        joints: &[String],
        q_rad: &[f64],
        base: &[([f64; 3], [f64; 4])],
    ) -> Result<Figure> {
        let d = joints.len();
        if q_rad.len() != base.len() * d {
            return Err(Error::Input(format!("{} angles for {} frames of {d} joints", q_rad.len(), base.len())));
        }
        if base.iter().flat_map(|(p, q)| p.iter().chain(q)).any(|v| !v.is_finite()) {
            return Err(Error::Input("a base pose is not finite".into()));
        }
        robot_figure(label, robot, base.len(), joints, |k| {
            let (p, q) = base[k];
            let rot = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
            let at = nalgebra::Isometry3::from_parts(nalgebra::Translation3::new(p[0], p[1], p[2]), rot);
            (&q_rad[k * d..(k + 1) * d], Some(at))
        })
    }

    /// The same figure with a note under its panel.
    pub fn with_note(mut self, note: impl Into<String>) -> Figure {
        self.note = note.into();
        self
    }

    /// The highest point over every frame, mm (its size on screen).
    pub fn height_mm(&self) -> f32 {
        self.points_mm.iter().map(|p| p[1]).fold(0.0, f32::max)
    }
}

/// A robot's stick figure over `n` frames: `frame(k)` gives the joint angles
/// (in the order of `joints`) and the root link's pose in the world (`None`:
/// at the origin, the points exactly as the link poses give them).
fn robot_figure<'a>(
    label: &str,
    robot: &Robot,
    n: usize,
    joints: &[String],
    frame: impl Fn(usize) -> (&'a [f64], Option<nalgebra::Isometry3<f64>>),
) -> Result<Figure> {
    let mut names = vec![robot.joints.first().map_or_else(|| "root".to_owned(), |j| j.parent.clone())];
    names.extend(robot.joints.iter().map(|j| j.child.clone()));
    // The parent point of each joint: the joint whose child link is this joint's parent link.
    let parent_point =
        |j: &cpg_robot::Joint| robot.joints.iter().position(|p| p.child == j.parent).map_or(0, |p| p + 1);
    let mut segments: Vec<(usize, usize, Side)> = robot
        .joints
        .iter()
        .enumerate()
        .filter(|(_, j)| j.origin_m.iter().any(|v| v.abs() > 1e-9))
        .map(|(k, j)| (parent_point(j), k + 1, Side::of(&j.name)))
        .collect();
    // The soles: below the last joint of each leg, where the robot's spec puts them (none without a spec).
    let (mut leaves, sole_in_ankle) = match &robot.spec {
        Some(spec) => {
            let last = |leg| cpg_robot::spec::leg_chain(robot, leg).map(|c| c[5]);
            (vec![last(&spec.legs.left)?, last(&spec.legs.right)?], spec.feet.sole_in_ankle_m)
        }
        None => (Vec::new(), [0.0; 3]),
    };
    leaves.sort_unstable();
    for &k in &leaves {
        names.push(format!("{}_sole", robot.joints[k].child));
        segments.push((k + 1, names.len() - 1, Side::of(&robot.joints[k].name)));
    }
    let n_pts = names.len();
    check_frames(n, n_pts)?;
    let mut points = Vec::with_capacity(n * n_pts);
    // URDF (x forward, y left, z up, m) → viewer (x left, y up, z forward, mm).
    let turn = |p: nalgebra::Point3<f64>| [(p.y * 1000.0) as f32, (p.z * 1000.0) as f32, (p.x * 1000.0) as f32];
    for f in 0..n {
        let (q, base) = frame(f);
        let mut poses = robot.link_poses(joints, q)?;
        match base {
            Some(b) => {
                poses.iter_mut().for_each(|p| *p = b * *p);
                points.push(turn(b * nalgebra::Point3::origin()));
            }
            None => points.push(turn(nalgebra::Point3::origin())),
        }
        points.extend(poses.iter().map(|p| turn(p * nalgebra::Point3::origin())));
        for &k in &leaves {
            points.push(turn(poses[k] * nalgebra::Point3::from(sole_in_ankle)));
        }
    }
    Ok(Figure { label: label.to_owned(), note: String::new(), names, segments, points_mm: points })
}

/// Whether a scene of `n_frames` frames whose figures hold `n_points` points
/// per frame between them fits in [`MAX_VALUES`] coordinates: the check a
/// caller makes before computing the frames (a model's free run), so that a
/// stretch too long is refused before the work, not after it.
pub fn check_scene_size(n_frames: usize, n_points: usize) -> Result<()> {
    check_frames(n_frames, n_points)
}

fn check_frames(n_frames: usize, n_points: usize) -> Result<()> {
    if n_frames == 0 {
        return Err(Error::Input("a figure needs at least one frame".into()));
    }
    if n_frames.saturating_mul(n_points).saturating_mul(3) > MAX_VALUES {
        return Err(Error::Input(format!(
            "{n_frames} frames of {n_points} points exceed the {MAX_VALUES} coordinates a scene holds; show a shorter stretch"
        )));
    }
    Ok(())
}

/// Puts a figure on the floor without sliding: each frame's lowest point at
/// height 0, and the figure shifted horizontally so that this point stays
/// where it was in the frame before.
fn plant(points: &mut [[f32; 3]], n_pts: usize) {
    let (mut x, mut z) = (0.0f64, 0.0f64);
    let mut before: Vec<[f32; 3]> = Vec::with_capacity(n_pts);
    for frame in points.chunks_mut(n_pts) {
        let low = (0..frame.len()).min_by(|&a, &b| frame[a][1].total_cmp(&frame[b][1])).unwrap_or(0);
        let p = frame[low];
        if let Some(q) = before.get(low) {
            x -= f64::from(p[0] - q[0]);
            z -= f64::from(p[2] - q[2]);
        }
        before.clear();
        before.extend_from_slice(frame);
        for q in frame.iter_mut() {
            q[0] += x as f32;
            q[1] -= p[1];
            q[2] += z as f32;
        }
    }
}

/// Where the camera looks from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Camera {
    /// Angle about the vertical axis, degrees: 0 looks at a human's front, 90 at its left side.
    pub yaw_deg: f64,
    /// Elevation, degrees above the horizon.
    pub pitch_deg: f64,
}

impl Default for Camera {
    fn default() -> Camera {
        Camera { yaw_deg: 60.0, pitch_deg: 12.0 }
    }
}

/// Figures side by side on one timeline.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The page's title.
    pub title: String,
    /// Lines printed under the title (what is shown, how it was made).
    pub notes: Vec<String>,
    /// Frames per second of every figure.
    pub rate_hz: f64,
    /// The figures, left to right.
    pub figures: Vec<Figure>,
    /// The initial view.
    pub camera: Camera,
    /// Moments marked on the timeline (a switch of the controls), in time order.
    pub marks: Vec<Mark>,
}

/// A moment marked on a scene's timeline: a tick on the time slider, a
/// button that jumps to it, and its label beside the clock from then on.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Mark {
    /// When, seconds from the scene's start.
    pub time_s: f64,
    /// What happens then (`walk`).
    pub label: String,
}

impl Scene {
    /// A scene of figures that all hold the same number of frames at `rate_hz`.
    pub fn new(title: &str, rate_hz: f64, figures: Vec<Figure>) -> Result<Scene> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::Input(format!("rate {rate_hz} Hz: expected a positive number")));
        }
        let Some(first) = figures.first() else {
            return Err(Error::Input("a scene needs at least one figure".into()));
        };
        let n = first.n_frames();
        for f in &figures {
            if f.n_frames() != n {
                return Err(Error::Input(format!(
                    "figure '{}' has {} frames, '{}' has {n}: figures of a scene share one timeline",
                    f.label,
                    f.n_frames(),
                    first.label
                )));
            }
            if let Some(k) = f.points_mm.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
                return Err(Error::Input(format!(
                    "figure '{}': point '{}' of frame {} is not finite",
                    f.label,
                    f.names[k % f.names.len()],
                    k / f.names.len()
                )));
            }
            if let Some(&(a, b, _)) = f.segments.iter().find(|s| s.0 >= f.names.len() || s.1 >= f.names.len()) {
                return Err(Error::Input(format!("figure '{}': segment {a}–{b} names a point it lacks", f.label)));
            }
        }
        let total: usize = figures.iter().map(|f| f.points_mm.len() * 3).sum();
        if total > MAX_VALUES {
            return Err(Error::Input(format!(
                "the figures hold {total} coordinates, more than the {MAX_VALUES} a scene holds; show a shorter stretch"
            )));
        }
        Ok(Scene {
            title: title.to_owned(),
            notes: Vec::new(),
            rate_hz,
            figures,
            camera: Camera::default(),
            marks: Vec::new(),
        })
    }

    /// Frames on the timeline.
    pub fn n_frames(&self) -> usize {
        self.figures.first().map_or(0, Figure::n_frames)
    }

    /// The scene as one self-contained HTML page: the data and the script
    /// inline, no request to any network. The page plays at once; `space`
    /// pauses, the arrow keys step, the slider scrubs, dragging turns the view.
    /// The page exposes its state as `window.cpgView` (`frame`, `playing`,
    /// `speed`, `yaw_deg`) for scripts and tests.
    pub fn to_html(&self) -> String {
        #[derive(serde::Serialize)]
        struct Fig<'a> {
            label: &'a str,
            note: &'a str,
            names: &'a [String],
            segments: Vec<(usize, usize, Side)>,
            height_mm: f32,
            points_f32_le_b64: String,
        }
        #[derive(serde::Serialize)]
        struct Data<'a> {
            title: &'a str,
            rate_hz: f64,
            n_frames: usize,
            camera: Camera,
            figures: Vec<Fig<'a>>,
            marks: &'a [Mark],
        }
        let data = Data {
            title: &self.title,
            rate_hz: self.rate_hz,
            n_frames: self.n_frames(),
            camera: self.camera,
            marks: &self.marks,
            figures: self
                .figures
                .iter()
                .map(|f| Fig {
                    label: &f.label,
                    note: &f.note,
                    names: &f.names,
                    segments: f.segments.clone(),
                    height_mm: f.height_mm(),
                    points_f32_le_b64: base64(f.points_mm.iter().flat_map(|p| p.iter().flat_map(|v| v.to_le_bytes()))),
                })
                .collect(),
        };
        // serde_json cannot fail on these plain types.
        let json = script_json(&serde_json::to_string(&data).unwrap_or_default());
        let mut notes = String::new();
        for n in &self.notes {
            let _ = writeln!(notes, "<p class=\"note\">{}</p>", escape(n));
        }
        fill(TEMPLATE, &[("TITLE", &escape(&self.title)), ("NOTES", &notes), ("SCENE", &json)])
    }

    /// The scene as an animated GIF (looping), each figure in a panel of its own.
    pub fn to_gif(&self, opts: &GifOptions) -> Result<Vec<u8>> {
        raster::gif(self, opts)
    }
}

const TEMPLATE: &str = include_str!("viewer.html");

/// The template with each `{{KEY}}` replaced by its value; values are not
/// scanned again, so a title cannot inject a marker.
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out = String::with_capacity(template.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some(at) = rest.find("{{") {
        out.push_str(&rest[..at]);
        let after = &rest[at + 2..];
        match after.find("}}").and_then(|end| values.iter().find(|(k, _)| *k == &after[..end]).map(|v| (end, v.1))) {
            Some((end, v)) => {
                out.push_str(v);
                rest = &after[end + 2..];
            }
            None => {
                out.push_str("{{");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// JSON text made safe inside a `<script>` element: every `<`, `>` and `&`
/// (which JSON holds only inside strings) becomes its `\u` escape, so no
/// name can close the element (`</script>`) or switch the HTML tokenizer into
/// its escaped states (`<!--`, `<script`); `JSON.parse` reads the same strings.
fn script_json(json: &str) -> String {
    json.replace('<', "\\u003c").replace('>', "\\u003e").replace('&', "\\u0026")
}

/// Text for HTML: `&`, `<`, `>` and `"` escaped.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Standard base64 with padding.
fn base64(bytes: impl Iterator<Item = u8>) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    let mut buf = [0u8; 3];
    let mut n = 0;
    let flush = |buf: &[u8; 3], n: usize, out: &mut String| {
        let v = (u32::from(buf[0]) << 16) | (u32::from(buf[1]) << 8) | u32::from(buf[2]);
        for k in 0..4 {
            if k <= n {
                out.push(A[((v >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    };
    for b in bytes {
        buf[n] = b;
        n += 1;
        if n == 3 {
            flush(&buf, 3, &mut out);
            buf = [0; 3];
            n = 0;
        }
    }
    if n > 0 {
        flush(&buf, n, &mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn base64_matches_the_standard_alphabet_and_padding() {
        assert_eq!(base64(b"".iter().copied()), "");
        assert_eq!(base64(b"f".iter().copied()), "Zg==");
        assert_eq!(base64(b"fo".iter().copied()), "Zm8=");
        assert_eq!(base64(b"foo".iter().copied()), "Zm9v");
        assert_eq!(base64(b"foobar".iter().copied()), "Zm9vYmFy");
        assert_eq!(base64([0xff, 0xfe, 0x00, 0x01].into_iter()), "//4AAQ==");
    }

    #[test]
    fn sides_follow_cmu_hoap2_and_bvh_names() {
        for (n, s) in [
            ("lfemur", Side::Left),
            ("rhumerus", Side::Right),
            ("lowerback", Side::Center),
            ("lowerneck", Side::Center),
            ("root", Side::Center),
            ("lleg_joint_3", Side::Left),
            ("rarm_joint_1", Side::Right),
            ("LeftUpLeg", Side::Left),
            ("RightForeArm", Side::Right),
            ("LHipJoint", Side::Left),
            ("head_joint_1", Side::Center),
        ] {
            assert_eq!(Side::of(n), s, "{n}");
        }
    }

    #[test]
    fn a_planted_figure_stands_on_the_floor_and_its_support_does_not_slide() {
        // Two "feet" swinging in antiphase under a hip, 1 m up.
        let n_pts = 3;
        let mut pts = Vec::new();
        // The leg swinging backward carries the weight (it reaches lower).
        for f in 0..100 {
            let phase = f as f32 / 10.0;
            let (a, back) = (phase.sin() * 0.4, -phase.cos());
            pts.push([0.0, 1000.0, 0.0]);
            pts.push([0.0, 1000.0 - 900.0 * a.cos() - 20.0 * back.max(0.0), 900.0 * a.sin()]);
            pts.push([0.0, 1000.0 - 900.0 * a.cos() - 20.0 * (-back).max(0.0), -900.0 * a.sin()]);
        }
        plant(&mut pts, n_pts);
        for f in 0..100 {
            let fr = &pts[f * n_pts..(f + 1) * n_pts];
            let low = fr.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min);
            assert!(low.abs() < 1e-3, "frame {f}: {low}");
            if f > 0 {
                let i = (0..n_pts).min_by(|&a, &b| fr[a][1].total_cmp(&fr[b][1])).unwrap();
                let prev = pts[(f - 1) * n_pts + i];
                assert!((prev[2] - fr[i][2]).abs() < 1e-2, "frame {f}: the support slid");
            }
        }
        // It walks: the hip moved forward or backward by more than a stride.
        assert!((pts[99 * n_pts][2] - pts[0][2]).abs() > 500.0);
    }
}

//! # cpg-robot
//!
//! A humanoid robot as data: its URDF and its `robot.toml` ([`spec`]), and
//! joint commands for it. The Fujitsu HOAP-2 (`assets/hoap2`) is the first
//! robot and the one compiled in:
//!
//! - [`Robot`]: the revolute joints of a URDF (names, axes, anchors, limits in
//!   radians), read with urdf-rs. The project's `assets/hoap2/hoap2.urdf`
//!   has the robot's 25 joints.
//! - [`ChannelMap`]: a data file (`assets/hoap2/cmu35_to_hoap2.tsv`) mapping
//!   named channels in degrees to joints: `q_rad = (sign·value_deg + offset_deg)·π/180`.
//! - [`JointTrajectory`]: mapped joint angles over time with their velocities
//!   and accelerations, resampled to any rate by a natural cubic spline
//!   ([`natural_spline`]), kept within the URDF's position and velocity
//!   limits and a stated acceleration bound by a [`Limiter`], with a
//!   [`ClampReport`] of what each bound changed; CSV and
//!   `trajectory_msgs/JointTrajectory`-shaped JSON or YAML export.
//! - [`Robot::link_poses`], [`Robot::path`]: forward kinematics from the URDF
//!   (nalgebra), and [`gait`]: the feet's excursion and lift, the period and
//!   the phase between the legs.
//! - [`assets`]: the project's URDF and maps compiled in ([`Robot::hoap2`],
//!   [`Robot::from_spec`], [`ChannelMap::from_spec`]).
//! - [`physics`]: the robot as a physical body (a solid box per link, its
//!   centre of mass and inertia, collision shapes) and the MuJoCo model built
//!   from the URDF ([`physics::mjcf`]; the project's `assets/hoap2/hoap2.xml`).
//! - [`control`]: the walk's controller inside a physics loop (the plan or a
//!   generator, balance feedback from an IMU, the servos' speed and range),
//!   on plain slices; `cpg.sim` runs MuJoCo with it.
//! - [`MapPlan`]: the map resolved against a robot and a channel list, for
//!   mapping one frame at a time without allocating (live control loops).
//!
//! The crate takes plain channel names and values, so it does not depend on
//! the mocap or reservoir crates.

pub mod assets;
pub mod control;
pub mod imu;
mod kinematics;
pub mod physics;
mod smooth;
pub mod spec;
pub mod walk;

pub use kinematics::{Gait, gait};
pub use smooth::{Bounds, LimitCounts, Limiter, natural_spline};
pub use spec::RobotSpec;

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The acceleration bound used when none is given, rad/s². The HOAP-2
/// documentation gives a speed limit (5 rad/s) but no acceleration limit;
/// this bound is ours: twenty times the speed limit per second, which a
/// 1 Hz gait of ±0.5 rad (peak acceleration about 20 rad/s²) stays far within.
pub const DEFAULT_ACCELERATION_RAD_S2: f64 = 100.0;

/// Share of frames above which a limited joint is worth a warning (`cpg hoap2 --strict` makes it an error).
pub const WARN_LIMITED_SHARE: f64 = 0.05;

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The URDF could not be read or parsed (the urdf-rs message is kept as text).
    #[error("{path}: not a readable URDF: {reason}")]
    Urdf {
        /// The file.
        path: PathBuf,
        /// What urdf-rs said.
        reason: String,
    },
    /// A joint whose limits or axis make no sense.
    #[error("{path}: joint '{joint}': {reason}")]
    BadJoint {
        /// The file.
        path: PathBuf,
        /// The joint.
        joint: String,
        /// What is wrong.
        reason: String,
    },
    /// A line of the channel map that cannot be parsed.
    #[error("{file}:{line}: {reason}")]
    Map {
        /// The file.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What was expected.
        reason: String,
    },
    /// A joint name that the robot does not have.
    #[error("unknown joint '{name}'{}; the robot has: {}", cpg_io::did_you_mean(name, valid.iter().map(String::as_str)), valid.join(", "))]
    UnknownJoint {
        /// The name.
        name: String,
        /// Every joint of the robot.
        valid: Vec<String>,
    },
    /// A channel the map needs is not in the input.
    #[error("the input lacks channel '{name}' (needed for joint '{joint}'); it has: {}", available.join(", "))]
    MissingChannel {
        /// The channel.
        name: String,
        /// The joint it feeds.
        joint: String,
        /// The channels given.
        available: Vec<String>,
    },
    /// Values of the wrong shape or not finite.
    #[error("invalid input: {0}")]
    Input(String),
    /// Reading a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// A number as a message shows it: plain when of ordinary size, else in `e` notation.
fn short_number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The largest URDF or map file read, bytes.
pub const MAX_FILE_BYTES: u64 = 64 << 20;

/// Reads a UTF-8 text file of at most [`MAX_FILE_BYTES`].
fn read_text(path: &Path) -> Result<String> {
    use std::io::Read as _;
    let io = |source| Error::Io { path: path.to_owned(), source };
    let mut bytes = Vec::new();
    std::fs::File::open(path).map_err(io)?.take(MAX_FILE_BYTES + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(Error::Input(format!("{}: larger than {MAX_FILE_BYTES} bytes", path.display())));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        Error::Input(format!(
            "{}: not UTF-8 text (invalid byte at offset {})",
            path.display(),
            e.utf8_error().valid_up_to()
        ))
    })?;
    Ok(text.strip_prefix('\u{feff}').map(str::to_owned).unwrap_or(text))
}

/// The deepest nesting of XML elements a URDF may have (a real one nests
/// four or five: robot, joint, limit; a Xacro expansion a few more).
pub const MAX_URDF_DEPTH: usize = 64;

/// Refuses XML whose elements nest deeper than `max`, naming the line where
/// the bound is crossed. A scan, not a parse: comments, CDATA, processing
/// instructions and declarations are skipped, quoted attribute values may
/// hold `>`, and a self-closing element (`<x/>`) does not nest. Whatever the
/// scan cannot make sense of is left for the XML parser to report.
pub fn check_nesting(text: &str, max: usize) -> std::result::Result<(), String> {
    let b = text.as_bytes();
    let (mut i, mut depth, mut line) = (0usize, 0usize, 1usize);
    // Skips to just past `end`, counting lines; false when the text ends first.
    let skip_past = |i: &mut usize, line: &mut usize, end: &[u8]| -> bool {
        while *i < b.len() {
            if b[*i..].starts_with(end) {
                *i += end.len();
                return true;
            }
            *line += usize::from(b[*i] == b'\n');
            *i += 1;
        }
        false
    };
    while i < b.len() {
        match b[i] {
            b'\n' => {
                line += 1;
                i += 1;
            }
            b'<' => {
                let rest = &b[i..];
                let at = line;
                if rest.starts_with(b"<!--") {
                    i += 4;
                    if !skip_past(&mut i, &mut line, b"-->") {
                        return Ok(());
                    }
                } else if rest.starts_with(b"<![CDATA[") {
                    i += 9;
                    if !skip_past(&mut i, &mut line, b"]]>") {
                        return Ok(());
                    }
                } else if rest.starts_with(b"<?") || rest.starts_with(b"<!") {
                    i += 2;
                    if !skip_past(&mut i, &mut line, b">") {
                        return Ok(());
                    }
                } else if rest.starts_with(b"</") {
                    depth = depth.saturating_sub(1);
                    i += 2;
                    if !skip_past(&mut i, &mut line, b">") {
                        return Ok(());
                    }
                } else {
                    // An opening tag: to its `>`, outside quoted values.
                    i += 1;
                    let mut quote = None;
                    while i < b.len() {
                        let c = b[i];
                        line += usize::from(c == b'\n');
                        i += 1;
                        match quote {
                            Some(q) if c == q => quote = None,
                            Some(_) => {}
                            None if c == b'"' || c == b'\'' => quote = Some(c),
                            None if c == b'>' => break,
                            None => {}
                        }
                    }
                    if i >= 2 && b[i - 1] == b'>' && b[i - 2] == b'/' {
                        continue; // self-closing
                    }
                    depth += 1;
                    if depth > max {
                        return Err(format!("line {at}: elements nested more than {max} deep (a URDF nests a few)"));
                    }
                }
            }
            _ => i += 1,
        }
    }
    Ok(())
}

/// One revolute joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name (`lleg_joint_3`).
    pub name: String,
    /// Parent link.
    pub parent: String,
    /// Child link.
    pub child: String,
    /// Anchor in the parent's frame, metres.
    pub origin_m: [f64; 3],
    /// Rotation axis (unit vector) in the joint frame.
    pub axis: [f64; 3],
    /// Lower limit, radians.
    pub lower_rad: f64,
    /// Upper limit, radians.
    pub upper_rad: f64,
    /// Velocity limit, rad/s.
    pub velocity_rad_s: f64,
}

impl Joint {
    /// This joint's position range and velocity limit, with `acceleration_rad_s2` as its acceleration bound.
    pub fn bounds(&self, acceleration_rad_s2: f64) -> Bounds {
        Bounds {
            lower_rad: self.lower_rad,
            upper_rad: self.upper_rad,
            velocity_rad_s: self.velocity_rad_s,
            acceleration_rad_s2,
        }
    }
}

/// The revolute joints of a robot, in URDF order.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Robot name.
    pub name: String,
    /// Revolute joints.
    pub joints: Vec<Joint>,
    /// Total mass of all links, kg.
    pub mass_kg: f64,
    /// What the robot's folder says beyond its URDF (legs, feet, sensors,
    /// servos, home pose): `None` for a robot read from a URDF alone.
    pub spec: Option<Box<RobotSpec>>,
}

impl Robot {
    /// Parses URDF text; `path` names the source in errors. Elements nested
    /// more than [`MAX_URDF_DEPTH`] deep are refused before the XML parser
    /// (which recurses) sees them.
    pub fn from_urdf_str(text: &str, path: &Path) -> Result<Robot> {
        check_nesting(text, MAX_URDF_DEPTH).map_err(|reason| Error::Urdf { path: path.to_owned(), reason })?;
        let r = urdf_rs::read_from_string(text)
            .map_err(|e| Error::Urdf { path: path.to_owned(), reason: e.to_string() })?;
        let mut joints = Vec::new();
        for j in &r.joints {
            if j.joint_type != urdf_rs::JointType::Revolute {
                continue;
            }
            let bad = |reason: String| Error::BadJoint { path: path.to_owned(), joint: j.name.clone(), reason };
            let (lo, hi) = (j.limit.lower, j.limit.upper);
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(bad(format!("limits [{lo}, {hi}] are not a finite interval")));
            }
            let a = *j.axis.xyz;
            let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
            if !(norm.is_finite() && norm > 0.0) {
                return Err(bad(format!("axis {a:?} has no direction")));
            }
            joints.push(Joint {
                name: j.name.clone(),
                parent: j.parent.link.clone(),
                child: j.child.link.clone(),
                origin_m: *j.origin.xyz,
                axis: a.map(|v| v / norm),
                lower_rad: lo,
                upper_rad: hi,
                velocity_rad_s: j.limit.velocity,
            });
        }
        let mass_kg = r.links.iter().map(|l| l.inertial.mass.value).sum();
        Ok(Robot { name: r.name, joints, mass_kg, spec: None })
    }

    /// The robot with its spec, checked against its joints.
    pub fn with_spec(mut self, spec: RobotSpec) -> Result<Robot> {
        spec.check(&self)?;
        self.spec = Some(Box::new(spec));
        Ok(self)
    }

    /// Its spec, or an error saying that what was asked needs one.
    pub fn spec(&self) -> Result<&RobotSpec> {
        self.spec.as_deref().ok_or_else(|| {
            Error::Input(format!(
                "robot '{}' was read from a URDF alone; walking it needs its folder's robot.toml (legs, feet, sensors, servos: crates/robot/src/spec.rs)",
                self.name
            ))
        })
    }

    /// Reads a URDF file, with the spec of its folder when a `robot.toml`
    /// beside it names this file as its URDF (a robot's folder).
    pub fn from_urdf_file(path: &Path) -> Result<Robot> {
        let text = read_text(path)?;
        let robot = Robot::from_urdf_str(&text, path)?;
        let beside = path.parent().unwrap_or(Path::new(".")).join("robot.toml");
        if !beside.is_file() {
            return Ok(robot);
        }
        let spec = RobotSpec::load(&beside)?;
        if spec.urdf.file_name() == path.file_name() { robot.with_spec(spec) } else { Ok(robot) }
    }

    /// A joint by name.
    pub fn joint(&self, name: &str) -> Result<&Joint> {
        self.joints.iter().find(|j| j.name == name).ok_or_else(|| Error::UnknownJoint {
            name: name.to_owned(),
            valid: self.joints.iter().map(|j| j.name.clone()).collect(),
        })
    }
}

/// One row of a channel map.
#[derive(Debug, Clone, PartialEq)]
pub struct MapEntry {
    /// Robot joint.
    pub joint: String,
    /// Source channel (`lfemur.rx`), in degrees.
    pub channel: String,
    /// +1 or −1.
    pub sign: f64,
    /// Added after the sign, degrees.
    pub offset_deg: f64,
}

/// Slowest rate a trajectory is resampled to, Hz.
pub const MIN_RATE_HZ: f64 = 1.0;
/// Fastest rate a trajectory is resampled to, Hz (ten times a 1 kHz servo loop).
pub const MAX_RATE_HZ: f64 = 10_000.0;
/// Most values (frames × joints) a resampled trajectory holds.
pub const MAX_VALUES: usize = 1 << 27;

/// Channel → joint relations, read from a tab-separated file with the
/// columns `joint channel sign offset_deg note` (`#` lines are comments).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelMap {
    /// The rows, in file order (this is the joint order of trajectories).
    pub entries: Vec<MapEntry>,
}

impl ChannelMap {
    /// Parses the file format; `file` names the source in errors.
    pub fn parse(text: &str, file: &str) -> Result<ChannelMap> {
        let mut entries: Vec<MapEntry> = Vec::new();
        let mut header = false;
        for (i, line) in text.lines().enumerate() {
            let err = |reason: String| Error::Map { file: file.to_owned(), line: i + 1, reason };
            let line = line.trim_end_matches('\r');
            if line.trim().is_empty() || line.starts_with('#') {
                continue;
            }
            let f: Vec<&str> = line.split('\t').collect();
            if !header {
                if f.len() < 4 || f[..4] != ["joint", "channel", "sign", "offset_deg"] {
                    return Err(err("expected the header 'joint<TAB>channel<TAB>sign<TAB>offset_deg<TAB>note'".into()));
                }
                header = true;
                continue;
            }
            if f.len() < 4 {
                return Err(err(format!("expected at least 4 tab-separated fields, found {}", f.len())));
            }
            let sign: f64 = match f[2].trim() {
                "1" | "+1" => 1.0,
                "-1" => -1.0,
                other => return Err(err(format!("sign '{other}': expected 1 or -1"))),
            };
            let offset_deg: f64 = f[3]
                .trim()
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| err(format!("offset '{}': expected a finite number of degrees", f[3])))?;
            if f[0].is_empty() || f[1].is_empty() {
                return Err(err("empty joint or channel name".into()));
            }
            if entries.iter().any(|e| e.joint == f[0]) {
                return Err(err(format!("joint '{}' is mapped twice", f[0])));
            }
            entries.push(MapEntry { joint: f[0].to_owned(), channel: f[1].to_owned(), sign, offset_deg });
        }
        if entries.is_empty() {
            return Err(Error::Map {
                file: file.to_owned(),
                line: text.lines().count().max(1),
                reason: "no mappings".into(),
            });
        }
        Ok(ChannelMap { entries })
    }

    /// Reads a map file.
    pub fn load(path: &Path) -> Result<ChannelMap> {
        let text = read_text(path)?;
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        ChannelMap::parse(&text, &name)
    }

    /// The channels the map reads, in joint order.
    pub fn channels(&self) -> Vec<&str> {
        self.entries.iter().map(|e| e.channel.as_str()).collect()
    }

    /// Resolves the map against `robot` and the channels of an input: which
    /// column feeds each joint, and the joints' limits.
    pub fn plan(&self, robot: &Robot, channels: &[String]) -> Result<MapPlan> {
        let mut cols = Vec::new();
        let mut joints = Vec::new();
        for e in &self.entries {
            joints.push(robot.joint(&e.joint)?.clone());
            cols.push(channels.iter().position(|c| *c == e.channel).ok_or_else(|| Error::MissingChannel {
                name: e.channel.clone(),
                joint: e.joint.clone(),
                available: channels.to_vec(),
            })?);
        }
        Ok(MapPlan { joints, cols, entries: self.entries.clone(), n_channels: channels.len() })
    }

    /// Maps frames of named channels (degrees, frame-major) to joint angles
    /// (radians), clamped to `robot`'s position limits; velocities and
    /// accelerations are those of the natural cubic spline through them.
    pub fn apply(
        &self,
        robot: &Robot,
        channels: &[String],
        values_deg: &[f64],
        rate_hz: f64,
    ) -> Result<JointTrajectory> {
        if channels.is_empty() || !values_deg.len().is_multiple_of(channels.len()) {
            return Err(Error::Input(format!(
                "{} values do not form frames of {} channels",
                values_deg.len(),
                channels.len()
            )));
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::Input(format!("rate {rate_hz} Hz must be positive")));
        }
        if let Some(k) = values_deg.iter().position(|v| !v.is_finite()) {
            return Err(Error::Input(format!("value {k} (channel '{}') is not finite", channels[k % channels.len()])));
        }
        let plan = self.plan(robot, channels)?;
        let n_frames = values_deg.len() / channels.len();
        let d = plan.joints.len();
        let mut values_rad = vec![0.0; n_frames * d];
        let mut report: Vec<JointClamp> =
            plan.joints.iter().map(|j| JointClamp { joint: j.name.clone(), n_frames, ..Default::default() }).collect();
        for f in 0..n_frames {
            let row = &values_deg[f * channels.len()..(f + 1) * channels.len()];
            let out = &mut values_rad[f * d..(f + 1) * d];
            plan.frame(row, out);
            for ((q, j), r) in out.iter_mut().zip(&plan.joints).zip(&mut report) {
                r.min_rad = if f == 0 { *q } else { r.min_rad.min(*q) };
                r.max_rad = if f == 0 { *q } else { r.max_rad.max(*q) };
                let c = q.clamp(j.lower_rad, j.upper_rad);
                if c != *q {
                    r.n_clamped += 1;
                    r.max_excess_rad = r.max_excess_rad.max((*q - c).abs());
                }
                *q = c;
            }
        }
        let mut t = JointTrajectory {
            joints: plan.joints.iter().map(|j| j.name.clone()).collect(),
            values_rad,
            velocities_rad_s: Vec::new(),
            accelerations_rad_s2: Vec::new(),
            rate_hz,
            clamps: ClampReport { joints: report },
        };
        t.spline_derivatives();
        Ok(t)
    }
}

/// A [`ChannelMap`] resolved against a robot and an input's channels.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPlan {
    /// The joints fed, in map order, with their limits.
    pub joints: Vec<Joint>,
    cols: Vec<usize>,
    entries: Vec<MapEntry>,
    n_channels: usize,
}

impl MapPlan {
    /// Maps one frame of channel values (degrees, in the input's channel
    /// order) to joint angles (radians, not clamped) in `out`. Allocates nothing.
    ///
    /// # Panics
    /// When `row` or `out` has the wrong length.
    pub fn frame(&self, row_deg: &[f64], out_rad: &mut [f64]) {
        assert_eq!(row_deg.len(), self.n_channels, "one value per input channel");
        assert_eq!(out_rad.len(), self.joints.len(), "one angle per joint");
        for ((o, e), &c) in out_rad.iter_mut().zip(&self.entries).zip(&self.cols) {
            *o = (e.sign * row_deg[c] + e.offset_deg) * PI / 180.0;
        }
    }
}

/// How one joint fared against its limits.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct JointClamp {
    /// Joint name.
    pub joint: String,
    /// Frames mapped.
    pub n_frames: usize,
    /// Frames in which the mapped angle was outside the limits.
    pub n_clamped: usize,
    /// Largest distance beyond a limit, radians.
    pub max_excess_rad: f64,
    /// Smallest mapped angle before clamping, radians.
    pub min_rad: f64,
    /// Largest mapped angle before clamping, radians.
    pub max_rad: f64,
    /// Frames held back by the velocity limit (after [`JointTrajectory::limit`]).
    pub n_velocity_limited: usize,
    /// Frames held back by the acceleration bound (after [`JointTrajectory::limit`]).
    pub n_acceleration_limited: usize,
    /// Fastest speed asked for before limiting, rad/s.
    pub max_velocity_rad_s: f64,
    /// Largest acceleration asked for before limiting, rad/s².
    pub max_acceleration_rad_s2: f64,
    /// Largest distance between the angle asked for and the one commanded, radians.
    pub max_lag_rad: f64,
}

impl JointClamp {
    /// The largest share of frames that one bound (position, velocity or acceleration) changed.
    pub fn limited_share(&self) -> f64 {
        let n = self.n_clamped.max(self.n_velocity_limited).max(self.n_acceleration_limited);
        n as f64 / self.n_frames.max(1) as f64
    }
}

/// Clamping statistics of a mapping, per joint.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ClampReport {
    /// One entry per joint, in trajectory order.
    pub joints: Vec<JointClamp>,
}

impl ClampReport {
    /// The joints that some bound changed in more than `share` of their frames.
    pub fn over(&self, share: f64) -> Vec<&JointClamp> {
        self.joints.iter().filter(|j| j.limited_share() > share).collect()
    }
}

/// Joint angles over time, in radians, frame-major, within the joint
/// limits, with their velocities and accelerations.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// Joint names (columns).
    pub joints: Vec<String>,
    /// `frames × joints` angles, radians.
    pub values_rad: Vec<f64>,
    /// `frames × joints` velocities, rad/s.
    pub velocities_rad_s: Vec<f64>,
    /// `frames × joints` accelerations, rad/s².
    pub accelerations_rad_s2: Vec<f64>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// What each bound changed, per joint.
    pub clamps: ClampReport,
}

impl JointTrajectory {
    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.values_rad.len() / self.joints.len().max(1)
    }

    /// Column `j` of a frame-major array of `d` joints.
    pub fn column(values: &[f64], d: usize, j: usize) -> Vec<f64> {
        values.iter().skip(j).step_by(d).copied().collect()
    }

    /// Velocities and accelerations of the natural cubic spline through the positions.
    fn spline_derivatives(&mut self) {
        let (n, d) = (self.n_frames(), self.joints.len());
        self.velocities_rad_s = vec![0.0; n * d];
        self.accelerations_rad_s2 = vec![0.0; n * d];
        for j in 0..d {
            let [_, v, a] =
                natural_spline(&JointTrajectory::column(&self.values_rad, d, j), self.rate_hz, self.rate_hz, n);
            for f in 0..n {
                self.velocities_rad_s[f * d + j] = v[f];
                self.accelerations_rad_s2[f * d + j] = a[f];
            }
        }
    }

    /// Resamples to exactly `n_out` frames at `rate_hz` by a natural cubic
    /// spline per joint (frames past the input's end hold its last value), then
    /// clamps the positions again to `robot`'s limits, where the spline may
    /// overshoot a clamped stretch.
    pub fn resample(&self, robot: &Robot, rate_hz: f64, n_out: usize) -> Result<JointTrajectory> {
        let (n_in, d) = (self.n_frames(), self.joints.len());
        if n_in == 0 {
            return Err(Error::Input("empty trajectory".into()));
        }
        let duration_s = n_out as f64 / rate_hz;
        JointTrajectory::check_rate(rate_hz, duration_s, d)?;
        let mut t = JointTrajectory {
            joints: self.joints.clone(),
            values_rad: vec![0.0; n_out * d],
            velocities_rad_s: vec![0.0; n_out * d],
            accelerations_rad_s2: vec![0.0; n_out * d],
            rate_hz,
            clamps: self.clamps.clone(),
        };
        for (j, name) in self.joints.iter().enumerate() {
            let limits = robot.joint(name)?;
            let [p, v, a] =
                natural_spline(&JointTrajectory::column(&self.values_rad, d, j), self.rate_hz, rate_hz, n_out);
            let r = &mut t.clamps.joints[j];
            r.n_frames = n_out;
            r.n_clamped = (r.n_clamped as f64 * n_out as f64 / n_in as f64).round() as usize;
            for f in 0..n_out {
                let q = p[f].clamp(limits.lower_rad, limits.upper_rad);
                t.values_rad[f * d + j] = q;
                t.velocities_rad_s[f * d + j] = if q == p[f] { v[f] } else { 0.0 };
                t.accelerations_rad_s2[f * d + j] = if q == p[f] { a[f] } else { 0.0 };
            }
        }
        Ok(t)
    }

    /// Keeps every joint within its position and velocity limits from
    /// `robot` and within `acceleration_rad_s2`, by following the trajectory
    /// with a [`Limiter`] per joint; the velocities and accelerations become
    /// the commanded ones, and the report says what each bound changed.
    pub fn limit(&self, robot: &Robot, acceleration_rad_s2: f64) -> Result<JointTrajectory> {
        self.limit_with(robot, acceleration_rad_s2, false)
    }

    /// [`JointTrajectory::limit`] for a trajectory that is played as a loop
    /// (a whole number of cycles): the limiter runs over it twice and the
    /// second lap is kept, so that it starts in the state the loop ends in
    /// and can be repeated without a seam; the report counts the second lap.
    pub fn limit_loop(&self, robot: &Robot, acceleration_rad_s2: f64) -> Result<JointTrajectory> {
        self.limit_with(robot, acceleration_rad_s2, true)
    }

    fn limit_with(&self, robot: &Robot, acceleration_rad_s2: f64, looped: bool) -> Result<JointTrajectory> {
        if !(acceleration_rad_s2.is_finite() && acceleration_rad_s2 > 0.0) {
            return Err(Error::Input(format!(
                "acceleration bound {acceleration_rad_s2} rad/s²: expected a positive number"
            )));
        }
        let (n, d) = (self.n_frames(), self.joints.len());
        let mut t = self.clone();
        let dt = 1.0 / self.rate_hz;
        for (j, name) in self.joints.iter().enumerate() {
            let joint = robot.joint(name)?;
            let mut l = Limiter::new(joint.bounds(acceleration_rad_s2), dt);
            if n > 0 {
                // In motion from the first frame, as the trajectory asks.
                l.start(self.values_rad[j], self.velocities_rad_s[j]);
            }
            if looped {
                for f in 0..n {
                    l.step(self.values_rad[f * d + j]);
                }
                l.counts = Default::default();
            }
            let r = &mut t.clamps.joints[j];
            for f in 0..n {
                let k = f * d + j;
                r.max_velocity_rad_s = r.max_velocity_rad_s.max(self.velocities_rad_s[k].abs());
                r.max_acceleration_rad_s2 = r.max_acceleration_rad_s2.max(self.accelerations_rad_s2[k].abs());
                t.values_rad[k] = if f == 0 && !looped {
                    // The start state is the asked one (clamped).
                    l.state().0
                } else {
                    l.step(self.values_rad[k])
                };
                let (_, v, a) = l.state();
                t.velocities_rad_s[k] = v;
                t.accelerations_rad_s2[k] = if f == 0 && !looped { 0.0 } else { a };
            }
            r.n_velocity_limited = l.counts.velocity;
            r.n_acceleration_limited = l.counts.acceleration;
            r.max_lag_rad = l.counts.max_lag_rad;
        }
        Ok(t)
    }

    /// Checks a resampling rate for `duration_s` of `d` joints and returns the
    /// frames it gives (`duration_s × rate_hz`, rounded; 30 s at 1 kHz is 30,000): the rate within [`MIN_RATE_HZ`, `MAX_RATE_HZ`], at most
    /// [`MAX_VALUES`] values.
    pub fn check_rate(rate_hz: f64, duration_s: f64, d: usize) -> Result<usize> {
        if !(rate_hz.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate_hz)) {
            return Err(Error::Input(format!(
                "rate {} Hz: expected {MIN_RATE_HZ} to {MAX_RATE_HZ} Hz",
                short_number(rate_hz)
            )));
        }
        let n_out = (duration_s.max(0.0) * rate_hz).round().max(1.0);
        if n_out * d.max(1) as f64 > MAX_VALUES as f64 {
            return Err(Error::Input(format!(
                "{duration_s:.1} s at {rate_hz} Hz × {d} joints is {:.3e} values; at most {MAX_VALUES} (1 GiB)",
                n_out * d as f64
            )));
        }
        Ok(n_out as usize)
    }

    /// CSV text: `time_s`, then per joint its angle (`<joint>_rad`), then
    /// per joint its velocity (`<joint>_rad_s`), then its acceleration (`<joint>_rad_s2`).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time_s");
        for suffix in ["rad", "rad_s", "rad_s2"] {
            for j in &self.joints {
                let _ = write!(out, ",{j}_{suffix}");
            }
        }
        out.push('\n');
        let d = self.joints.len();
        for f in 0..self.n_frames() {
            let _ = write!(out, "{:.6}", f as f64 / self.rate_hz);
            for values in [&self.values_rad, &self.velocities_rad_s, &self.accelerations_rad_s2] {
                for v in &values[f * d..(f + 1) * d] {
                    let _ = write!(out, ",{v:.6}");
                }
            }
            out.push('\n');
        }
        out
    }

    /// `time_from_start` of frame `f` as ROS writes a duration: whole seconds and nanoseconds.
    fn stamp(&self, f: usize) -> (u64, u32) {
        let ns = (f as f64 / self.rate_hz * 1e9).round() as u64;
        (ns / 1_000_000_000, (ns % 1_000_000_000) as u32)
    }

    fn row(values: &[f64], f: usize, d: usize) -> String {
        values[f * d..(f + 1) * d].iter().map(|v| format!("{v:.6}")).collect::<Vec<_>>().join(", ")
    }

    /// A `trajectory_msgs/JointTrajectory` as JSON: `joint_names`, then
    /// `points` with `positions`, `velocities`, `accelerations` and
    /// `time_from_start` (`sec`, `nanosec`), the field names of ROS 2.
    pub fn to_ros_json(&self) -> String {
        let d = self.joints.len();
        let names: Vec<String> = self.joints.iter().map(|j| format!("\"{j}\"")).collect();
        let mut out = format!("{{\n  \"joint_names\": [{}],\n  \"points\": [\n", names.join(", "));
        for f in 0..self.n_frames() {
            let (sec, nanosec) = self.stamp(f);
            let _ = writeln!(
                out,
                "    {{\"positions\": [{}], \"velocities\": [{}], \"accelerations\": [{}], \"time_from_start\": {{\"sec\": {sec}, \"nanosec\": {nanosec}}}}}{}",
                JointTrajectory::row(&self.values_rad, f, d),
                JointTrajectory::row(&self.velocities_rad_s, f, d),
                JointTrajectory::row(&self.accelerations_rad_s2, f, d),
                if f + 1 < self.n_frames() { "," } else { "" }
            );
        }
        out.push_str("  ]\n}\n");
        out
    }

    /// The same message as YAML (as `ros2 topic echo` prints it, flow sequences for the values).
    pub fn to_ros_yaml(&self) -> String {
        let d = self.joints.len();
        let mut out = String::from("joint_names:\n");
        for j in &self.joints {
            let _ = writeln!(out, "- {j}");
        }
        out.push_str("points:\n");
        for f in 0..self.n_frames() {
            let (sec, nanosec) = self.stamp(f);
            let _ = write!(
                out,
                "- positions: [{}]\n  velocities: [{}]\n  accelerations: [{}]\n  time_from_start:\n    sec: {sec}\n    nanosec: {nanosec}\n",
                JointTrajectory::row(&self.values_rad, f, d),
                JointTrajectory::row(&self.velocities_rad_s, f, d),
                JointTrajectory::row(&self.accelerations_rad_s2, f, d),
            );
        }
        out
    }
}

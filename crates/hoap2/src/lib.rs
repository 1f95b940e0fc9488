//! # cpg-hoap2
//!
//! Joint commands for the Fujitsu HOAP-2 humanoid:
//!
//! - [`Robot`]: the revolute joints of a URDF (names, axes, anchors, limits in
//!   radians), read with urdf-rs. The project's `assets/hoap2/hoap2.urdf`
//!   has the robot's 25 joints.
//! - [`ChannelMap`]: a data file (`assets/hoap2/cmu35_to_hoap2.tsv`) mapping
//!   named channels in degrees to joints: `q_rad = (sign·value_deg + offset_deg)·π/180`.
//! - [`JointTrajectory`]: mapped, clamped joint angles over time, with a
//!   [`ClampReport`] of how often and how far each joint hit its limits,
//!   resampling to another rate and CSV export.
//!
//! The crate takes plain channel names and values, so it does not depend on
//! the mocap or reservoir crates.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

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
    #[error("unknown joint '{name}'; the robot has: {}", valid.join(", "))]
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

/// The revolute joints of a robot, in URDF order.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Robot name.
    pub name: String,
    /// Revolute joints.
    pub joints: Vec<Joint>,
    /// Total mass of all links, kg.
    pub mass_kg: f64,
}

impl Robot {
    /// Parses URDF text; `path` names the source in errors.
    pub fn from_urdf_str(text: &str, path: &Path) -> Result<Robot> {
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
        Ok(Robot { name: r.name, joints, mass_kg })
    }

    /// Reads a URDF file.
    pub fn from_urdf_file(path: &Path) -> Result<Robot> {
        let text = read_text(path)?;
        Robot::from_urdf_str(&text, path)
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

    /// Maps frames of named channels (degrees, frame-major) to joint angles
    /// (radians), clamped to `robot`'s limits.
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
        let mut cols = Vec::new();
        let mut limits = Vec::new();
        for e in &self.entries {
            let j = robot.joint(&e.joint)?;
            let col = channels.iter().position(|c| *c == e.channel).ok_or_else(|| Error::MissingChannel {
                name: e.channel.clone(),
                joint: e.joint.clone(),
                available: channels.to_vec(),
            })?;
            cols.push(col);
            limits.push((j.lower_rad, j.upper_rad));
        }
        let n_frames = values_deg.len() / channels.len();
        let mut values_rad = Vec::with_capacity(n_frames * self.entries.len());
        let mut report: Vec<JointClamp> =
            self.entries.iter().map(|e| JointClamp { joint: e.joint.clone(), ..Default::default() }).collect();
        for f in 0..n_frames {
            let row = &values_deg[f * channels.len()..(f + 1) * channels.len()];
            for (k, e) in self.entries.iter().enumerate() {
                let q = (e.sign * row[cols[k]] + e.offset_deg) * PI / 180.0;
                let (lo, hi) = limits[k];
                let c = q.clamp(lo, hi);
                let r = &mut report[k];
                r.min_rad = if f == 0 { q } else { r.min_rad.min(q) };
                r.max_rad = if f == 0 { q } else { r.max_rad.max(q) };
                if c != q {
                    r.n_clamped += 1;
                    r.max_excess_rad = r.max_excess_rad.max((q - c).abs());
                }
                values_rad.push(c);
            }
        }
        for r in &mut report {
            r.n_frames = n_frames;
        }
        Ok(JointTrajectory {
            joints: self.entries.iter().map(|e| e.joint.clone()).collect(),
            values_rad,
            rate_hz,
            clamps: ClampReport { joints: report },
        })
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
}

/// Clamping statistics of a mapping, per joint.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct ClampReport {
    /// One entry per joint, in trajectory order.
    pub joints: Vec<JointClamp>,
}

/// Joint angles over time, in radians, frame-major, within the joint limits.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// Joint names (columns).
    pub joints: Vec<String>,
    /// `frames × joints` angles, radians.
    pub values_rad: Vec<f64>,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// How often each joint was clamped.
    pub clamps: ClampReport,
}

impl JointTrajectory {
    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.values_rad.len() / self.joints.len().max(1)
    }

    /// Resamples to `rate_hz` by linear interpolation over the same duration
    /// (the last output frame is at or before the last input frame).
    pub fn resample(&self, rate_hz: f64) -> Result<JointTrajectory> {
        let (n_in, d) = (self.n_frames(), self.joints.len());
        if n_in == 0 {
            return Err(Error::Input("empty trajectory".into()));
        }
        let duration_s = (n_in - 1) as f64 / self.rate_hz;
        let n_out = JointTrajectory::check_rate(rate_hz, duration_s, d)?;
        let mut values_rad = Vec::with_capacity(n_out * d);
        for k in 0..n_out {
            let pos = k as f64 / rate_hz * self.rate_hz;
            let i0 = (pos.floor() as usize).min(n_in - 1);
            let i1 = (i0 + 1).min(n_in - 1);
            let t = pos - i0 as f64;
            for j in 0..d {
                let (a, b) = (self.values_rad[i0 * d + j], self.values_rad[i1 * d + j]);
                values_rad.push(a + t * (b - a));
            }
        }
        Ok(JointTrajectory { joints: self.joints.clone(), values_rad, rate_hz, clamps: self.clamps.clone() })
    }

    /// Checks a resampling rate for `duration_s` of `d` joints and returns the
    /// frames it gives: the rate within [`MIN_RATE_HZ`, `MAX_RATE_HZ`], at most
    /// [`MAX_VALUES`] values.
    pub fn check_rate(rate_hz: f64, duration_s: f64, d: usize) -> Result<usize> {
        if !(rate_hz.is_finite() && (MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate_hz)) {
            return Err(Error::Input(format!(
                "rate {} Hz: expected {MIN_RATE_HZ} to {MAX_RATE_HZ} Hz",
                short_number(rate_hz)
            )));
        }
        let n_out = (duration_s.max(0.0) * rate_hz + 1e-9).floor() + 1.0;
        if n_out * d.max(1) as f64 > MAX_VALUES as f64 {
            return Err(Error::Input(format!(
                "{duration_s:.1} s at {rate_hz} Hz × {d} joints is {:.3e} values; at most {MAX_VALUES} (1 GiB)",
                n_out * d as f64
            )));
        }
        Ok(n_out as usize)
    }

    /// CSV text: `time_s`, then one column per joint in radians (`<joint>_rad`).
    pub fn to_csv(&self) -> String {
        let mut out = String::from("time_s");
        for j in &self.joints {
            let _ = write!(out, ",{j}_rad");
        }
        out.push('\n');
        let d = self.joints.len();
        for f in 0..self.n_frames() {
            let _ = write!(out, "{:.6}", f as f64 / self.rate_hz);
            for v in &self.values_rad[f * d..(f + 1) * d] {
                let _ = write!(out, ",{v:.6}");
            }
            out.push('\n');
        }
        out
    }
}

//! A robot as data: `assets/<robot>/robot.toml`.
//!
//! The file names the robot's model (its URDF, the MuJoCo scene), which of
//! its joints are each leg's hip yaw, roll and pitch, knee, ankle pitch and
//! roll, its feet (the sole's size and where it sits under the ankle), its
//! sensors as the MuJoCo scene names them, its servos (speed limit, the
//! commands' acceleration bound, the simulation's servo settings), its home
//! pose and the maps from a person's channels onto its joints. Everything
//! that walks a robot reads these facts from the spec, so that another robot
//! is another folder, not another branch in the code.
//!
//! ```toml
//! name = "hoap2"            # what commands call it (`--robot hoap2`)
//! title = "HOAP-2"          # how reports write it
//! urdf = "hoap2.urdf"       # paths relative to the file
//! mjcf = "hoap2.xml"
//! gains = "feedback-gains.json"  # optional: the walk's feedback gains (`cpg.sim.Gains`), `cpg-sim`'s default
//!
//! [maps]                    # name → TSV: a person's channels onto joints
//! hoap2 = "cmu35_to_hoap2.tsv"
//!
//! [legs.left]               # the joints of each leg by what they do
//! hip_yaw = "lleg_joint_1"
//! # hip_roll, hip_pitch, knee, ankle_pitch, ankle_roll
//!
//! [feet]
//! sole_size_m = [0.094, 0.062]           # length, width
//! sole_in_ankle_m = [0.0112, 0.0, -0.033] # the sole's centre in the ankle-roll joint's frame
//! ankle_height_m = 0.0355                 # the ankle-roll axis above the floor, standing
//!
//! [sensors]                 # the MuJoCo scene's names
//! imu_quat = "imu_quat"
//! imu_gyro = "imu_gyro"
//! touch = ["lleg_touch", "rleg_touch"]
//!
//! [servos]
//! speed_limit_rad_s = 5.0
//! acceleration_rad_s2 = 100.0
//! # timestep_s, kp_nm_per_rad, kv_nm_s_per_rad, armature_kg_m2, damping_nm_s_per_rad,
//! # sliding_friction, torsional_friction_m: the MuJoCo scene's settings
//!
//! [home_pose_deg]           # joints not named stand at 0
//! lleg_joint_3 = -20.0
//!
//! [[shapes]]                # the body: a solid box per link, in its frame
//! link = "trunk"
//! size_m = [0.09, 0.14, 0.11]
//! centre_m = [-0.034, 0.0, 0.055]
//! contact = "floor"         # floor, floor_and_other_leg, other_leg
//! source = "estimate"       # where the numbers come from
//! # name (the link's by default) and carries_mass = false for a shape that only collides (a sole)
//! ```
//!
//! [`RobotSpec::check`] holds the spec against its URDF: every joint it
//! names exists, and each leg's six joints form one serial chain.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::{Error, Result, Robot};

/// The most bytes read from a robot spec.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;

/// One leg's joints by what they do.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegSpec {
    /// The hip's yaw (the leg turning about the vertical).
    pub hip_yaw: String,
    /// The hip's roll (the leg swinging sideways).
    pub hip_roll: String,
    /// The hip's pitch (the leg swinging forward).
    pub hip_pitch: String,
    /// The knee.
    pub knee: String,
    /// The ankle's pitch.
    pub ankle_pitch: String,
    /// The ankle's roll.
    pub ankle_roll: String,
}

impl LegSpec {
    /// The joints with their roles, in the order of [`LegSpec::ROLES`].
    pub fn joints(&self) -> [&str; 6] {
        [&self.hip_yaw, &self.hip_roll, &self.hip_pitch, &self.knee, &self.ankle_pitch, &self.ankle_roll]
    }

    /// The roles, as the file's keys.
    pub const ROLES: [&'static str; 6] = ["hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll"];

    /// The joint doing `role` (one of [`LegSpec::ROLES`]).
    pub fn joint(&self, role: &str) -> Option<&str> {
        Self::ROLES.iter().position(|r| *r == role).map(|k| self.joints()[k])
    }
}

/// Both legs.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegsSpec {
    /// The left leg.
    pub left: LegSpec,
    /// The right leg.
    pub right: LegSpec,
}

/// The feet.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeetSpec {
    /// The sole's length and width, m.
    pub sole_size_m: [f64; 2],
    /// The sole's centre in the ankle-roll joint's frame, m.
    pub sole_in_ankle_m: [f64; 3],
    /// The ankle-roll axis above the floor with the sole flat on it, m.
    pub ankle_height_m: f64,
}

/// The sensors, as the MuJoCo scene names them.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorsSpec {
    /// The trunk's orientation (a frame quaternion).
    pub imu_quat: String,
    /// The trunk's angular rate.
    pub imu_gyro: String,
    /// The soles' contact forces, left then right.
    pub touch: [String; 2],
}

/// The servos, and the simulation's settings of them.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServosSpec {
    /// The servos' speed limit, rad/s (the commander keeps it; MuJoCo has none).
    pub speed_limit_rad_s: f64,
    /// The commands' acceleration bound, rad/s² (`cpg hoap2`, `cpg stream --robot`).
    pub acceleration_rad_s2: f64,
    /// Physics step of the MuJoCo scene, s.
    pub timestep_s: f64,
    /// Position servo stiffness, N·m/rad.
    pub kp_nm_per_rad: f64,
    /// Position servo damping, N·m·s/rad.
    pub kv_nm_s_per_rad: f64,
    /// Reflected rotor inertia of each joint's motor, kg·m².
    pub armature_kg_m2: f64,
    /// Viscous friction of each joint, N·m·s/rad.
    pub damping_nm_s_per_rad: f64,
    /// Sliding friction coefficient of the soles on the floor.
    pub sliding_friction: f64,
    /// Torsional friction of the soles, m.
    pub torsional_friction_m: f64,
}

/// A robot as data (see the module).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// What commands call it.
    pub name: String,
    /// How reports write it.
    pub title: String,
    /// The URDF, relative to the spec's folder.
    pub urdf: PathBuf,
    /// The MuJoCo scene, relative to the spec's folder.
    pub mjcf: PathBuf,
    /// The walk's balance feedback gains (JSON, `cpg.sim.Gains`), relative to
    /// the folder: what `cpg-sim` uses when it is given no `--gains`.
    #[serde(default)]
    pub gains: Option<PathBuf>,
    /// Maps from a person's channels onto the joints: name → TSV, relative to the folder.
    #[serde(default)]
    pub maps: BTreeMap<String, PathBuf>,
    /// The legs.
    pub legs: LegsSpec,
    /// The feet.
    pub feet: FeetSpec,
    /// The sensors.
    pub sensors: SensorsSpec,
    /// The servos.
    pub servos: ServosSpec,
    /// The home pose, degrees per joint (others at 0).
    #[serde(default)]
    pub home_pose_deg: BTreeMap<String, f64>,
    /// The body: one solid box per link (and the soles), from which
    /// [`crate::physics`] writes the physical URDF and the MuJoCo scene.
    #[serde(default)]
    pub shapes: Vec<crate::physics::Shape>,
}

/// The HOAP-2's spec, compiled in (`assets/hoap2/robot.toml`).
pub const HOAP2_SPEC: &str = include_str!("../../../assets/hoap2/robot.toml");

impl RobotSpec {
    /// Parses a spec's text; `label` names it in errors (line and column included).
    pub fn parse(label: &str, text: &str) -> Result<RobotSpec> {
        let mut spec: RobotSpec = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| line_col(text, s.start)).map_or(String::new(), |(l, c)| format!(":{l}:{c}"));
            Error::Input(format!("{label}{at}: {}", e.message()))
        })?;
        for shape in &mut spec.shapes {
            if shape.name.is_empty() {
                shape.name = shape.link.clone();
            }
        }
        spec.validate(label)?;
        Ok(spec)
    }

    /// Reads `dir/robot.toml`, or the spec file given.
    pub fn load(path: &Path) -> Result<RobotSpec> {
        let file = if path.is_dir() { path.join("robot.toml") } else { path.to_owned() };
        let bytes = cpg_io::read_bounded(&file, MAX_SPEC_BYTES)
            .map_err(|e| Error::Input(format!("{}: {e}", file.display())))?;
        let text = std::str::from_utf8(&bytes)
            .map_err(|e| Error::Input(format!("{}: not UTF-8 text (byte {})", file.display(), e.valid_up_to())))?;
        RobotSpec::parse(&file.display().to_string(), text)
    }

    /// The HOAP-2's compiled-in spec.
    pub fn hoap2() -> RobotSpec {
        // A test parses the compiled-in text; it cannot fail at run time.
        #[allow(clippy::expect_used)]
        RobotSpec::parse("assets/hoap2/robot.toml", HOAP2_SPEC).expect("the compiled-in HOAP-2 spec parses")
    }

    /// The numbers in range and the names well formed (what needs no URDF).
    fn validate(&self, label: &str) -> Result<()> {
        let fail = |key: &str, what: String| Err(Error::Input(format!("{label}: {key}: {what}")));
        if self.name.is_empty()
            || self.name.len() > 64
            || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return fail("name", format!("'{}': expected 1 to 64 letters, digits, '-' or '_'", self.name));
        }
        let positive = [
            ("feet.sole_size_m[0]", self.feet.sole_size_m[0]),
            ("feet.sole_size_m[1]", self.feet.sole_size_m[1]),
            ("feet.ankle_height_m", self.feet.ankle_height_m),
            ("servos.speed_limit_rad_s", self.servos.speed_limit_rad_s),
            ("servos.acceleration_rad_s2", self.servos.acceleration_rad_s2),
            ("servos.timestep_s", self.servos.timestep_s),
            ("servos.kp_nm_per_rad", self.servos.kp_nm_per_rad),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0 && v < 1e6) {
                return fail(key, format!("{v}: expected a positive finite number"));
            }
        }
        let non_negative = [
            ("servos.kv_nm_s_per_rad", self.servos.kv_nm_s_per_rad),
            ("servos.armature_kg_m2", self.servos.armature_kg_m2),
            ("servos.damping_nm_s_per_rad", self.servos.damping_nm_s_per_rad),
            ("servos.sliding_friction", self.servos.sliding_friction),
            ("servos.torsional_friction_m", self.servos.torsional_friction_m),
        ];
        for (key, v) in non_negative {
            if !(v.is_finite() && (0.0..1e6).contains(&v)) {
                return fail(key, format!("{v}: expected a finite number ≥ 0"));
            }
        }
        if self.feet.sole_in_ankle_m.iter().any(|v| !v.is_finite() || v.abs() > 1.0) {
            return fail("feet.sole_in_ankle_m", "expected three finite numbers within 1 m".into());
        }
        if self.shapes.len() > 10_000 {
            return fail("shapes", format!("{} of them; at most 10000", self.shapes.len()));
        }
        for (i, shape) in self.shapes.iter().enumerate() {
            let sizes_ok = shape.size_m.iter().all(|v| v.is_finite() && *v > 0.0 && *v < 10.0);
            let centre_ok = shape.centre_m.iter().all(|v| v.is_finite() && v.abs() < 10.0);
            if !sizes_ok || !centre_ok {
                return fail(
                    &format!("shapes[{i}] ({})", shape.name),
                    "expected sizes within (0, 10) m and a centre within 10 m".into(),
                );
            }
            if shape.carries_mass && self.shapes.iter().filter(|o| o.link == shape.link && o.carries_mass).count() > 1 {
                return fail(
                    &format!("shapes[{i}] ({})", shape.name),
                    format!("link '{}' has more than one shape carrying its mass", shape.link),
                );
            }
        }
        for (joint, deg) in &self.home_pose_deg {
            if !deg.is_finite() || deg.abs() > 360.0 {
                return fail(&format!("home_pose_deg.{joint}"), format!("{deg}: expected degrees within ±360"));
            }
        }
        Ok(())
    }

    /// A path of the spec (`urdf`, `mjcf`, a map) resolved against the folder `dir` it was read from.
    pub fn path_in(dir: &Path, relative: &Path) -> PathBuf {
        if relative.is_absolute() { relative.to_owned() } else { dir.join(relative) }
    }

    /// Holds the spec against `robot` (its URDF): every named joint exists
    /// and each leg is one serial chain from the hip to the ankle.
    pub fn check(&self, robot: &Robot) -> Result<()> {
        let names = self
            .legs
            .left
            .joints()
            .into_iter()
            .chain(self.legs.right.joints())
            .chain(self.home_pose_deg.keys().map(String::as_str));
        for n in names {
            robot.joint(n)?;
        }
        for leg in [&self.legs.left, &self.legs.right] {
            leg_chain(robot, leg)?;
        }
        Ok(())
    }

    /// The home pose as one angle per joint of `robot`, rad (joints not named at 0).
    pub fn home_pose_rad(&self, robot: &Robot) -> Vec<f64> {
        robot.joints.iter().map(|j| self.home_pose_deg.get(&j.name).map_or(0.0, |d| d.to_radians())).collect()
    }
}

/// The indices into `robot.joints` of `leg`'s six joints in the order the
/// URDF chains them, from the trunk to the foot.
pub fn leg_chain(robot: &Robot, leg: &LegSpec) -> Result<[usize; 6]> {
    let mut index = [0; 6];
    for (i, n) in leg.joints().iter().enumerate() {
        index[i] = robot.joints.iter().position(|j| j.name == *n).ok_or_else(|| Error::UnknownJoint {
            name: (*n).to_owned(),
            valid: robot.joints.iter().map(|j| j.name.clone()).collect(),
        })?;
    }
    // The first joint is the one whose parent link no other leg joint moves.
    let is_child = |link: &str| index.iter().any(|&k| robot.joints[k].child == link);
    let Some(&first) = index.iter().find(|&&k| !is_child(&robot.joints[k].parent)) else {
        return Err(Error::Input(format!("the leg {:?} is a loop, not a chain", leg.joints())));
    };
    let mut chain = [first; 6];
    for i in 1..6 {
        let prev = &robot.joints[chain[i - 1]].child;
        chain[i] = *index.iter().find(|&&k| robot.joints[k].parent == *prev).ok_or_else(|| {
            Error::Input(format!(
                "{}'s child link '{prev}' is no other leg joint's parent: the leg {:?} is not one serial chain",
                robot.joints[chain[i - 1]].name,
                leg.joints()
            ))
        })?;
    }
    Ok(chain)
}

/// 1-based line and column of byte `at` in `text`.
fn line_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hoap2_spec_parses_and_fits_its_urdf() {
        let s = RobotSpec::hoap2();
        assert_eq!(s.name, "hoap2");
        let robot = Robot::hoap2().unwrap();
        s.check(&robot).unwrap();
        // The URDF chains each leg yaw, pitch, roll, knee, ankle pitch, ankle roll.
        let chain = leg_chain(&robot, &s.legs.left).unwrap().map(|k| robot.joints[k].name.clone());
        assert_eq!(chain, [1, 3, 2, 4, 5, 6].map(|k| format!("lleg_joint_{k}")));
    }

    #[test]
    fn a_bad_spec_says_where_and_what() {
        let text = HOAP2_SPEC.replace("ankle_height_m = 0.0355", "ankle_hieght_m = 0.0355");
        let e = RobotSpec::parse("r.toml", &text).unwrap_err().to_string();
        let line = HOAP2_SPEC.lines().position(|l| l.starts_with("ankle_height_m")).unwrap() + 1;
        assert!(
            e.contains(&format!("r.toml:{line}:1:")) && e.contains("ankle_hieght_m") && e.contains("ankle_height_m"),
            "{e}"
        );
        let text = HOAP2_SPEC.replace("speed_limit_rad_s = 5.0", "speed_limit_rad_s = -5.0");
        let e = RobotSpec::parse("r.toml", &text).unwrap_err().to_string();
        assert!(e.contains("servos.speed_limit_rad_s") && e.contains("positive"), "{e}");
        let text = HOAP2_SPEC.replace("knee = \"lleg_joint_4\"", "knee = \"lleg_joint_9\"");
        let s = RobotSpec::parse("r.toml", &text).unwrap();
        let e = s.check(&Robot::hoap2().unwrap()).unwrap_err().to_string();
        assert!(e.contains("lleg_joint_9"), "{e}");
        // Two joints swapped between the legs: neither is one chain.
        let text = HOAP2_SPEC.replace("knee = \"lleg_joint_4\"", "knee = \"rleg_joint_4\"");
        let s = RobotSpec::parse("r.toml", &text).unwrap();
        let e = s.check(&Robot::hoap2().unwrap()).unwrap_err().to_string();
        assert!(e.contains("serial chain"), "{e}");
    }
}

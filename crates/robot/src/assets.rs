//! The HOAP-2 files the project writes (`assets/hoap2/`), compiled into the
//! crate: a program built from this crate (`cargo install`, a wheel) finds
//! them wherever it runs, with no checkout beside it.
//!
//! [`Robot::from_spec`] and [`ChannelMap::from_spec`] read a file, or one of
//! these by its name: `hoap2` (the robot; the 22-channel map) and `legs` (the
//! 12-channel map of the legs).

use std::path::Path;

use crate::{ChannelMap, Result, Robot};

/// `assets/hoap2/hoap2.urdf`: the HOAP-2's joints, links and limits.
pub const HOAP2_URDF: &str = include_str!("../../../assets/hoap2/hoap2.urdf");
/// `assets/hoap2/hoap2.xml`: the HOAP-2 in MuJoCo, built from [`HOAP2_URDF`] by [`crate::physics::mjcf`].
pub const HOAP2_MJCF: &str = include_str!("../../../assets/hoap2/hoap2.xml");
/// `assets/hoap2/feedback-gains.json`: the walk's balance feedback gains (`cpg.sim.Gains`, found by `cpg.sim_search`).
pub const HOAP2_GAINS: &str = include_str!("../../../assets/hoap2/feedback-gains.json");
/// `assets/hoap2/cmu35_to_hoap2.tsv`: CMU subject 35's channels onto the 22 leg and arm joints.
pub const CMU35_TO_HOAP2: &str = include_str!("../../../assets/hoap2/cmu35_to_hoap2.tsv");
/// `assets/hoap2/cmu35_legs_to_hoap2.tsv`: the 12 leg joints alone.
pub const CMU35_LEGS_TO_HOAP2: &str = include_str!("../../../assets/hoap2/cmu35_legs_to_hoap2.tsv");

/// The names a robot may be given by instead of a URDF file.
pub const ROBOTS: [&str; 1] = ["hoap2"];
/// The names a channel map may be given by instead of a TSV file.
pub const MAPS: [&str; 2] = ["hoap2", "legs"];

impl Robot {
    /// The HOAP-2 as the project describes it ([`HOAP2_URDF`], with its
    /// spec [`crate::spec::HOAP2_SPEC`]).
    pub fn hoap2() -> Result<Robot> {
        Robot::from_urdf_str(HOAP2_URDF, Path::new("hoap2.urdf"))?.with_spec(crate::RobotSpec::hoap2())
    }

    /// A robot given as `hoap2` (the built-in one), as a robot's folder (its
    /// `robot.toml` naming its URDF) or spec file, or as a URDF file's path
    /// (no spec: it can be mapped onto, not walked).
    pub fn from_spec(spec: &Path) -> Result<Robot> {
        if spec.as_os_str() == "hoap2" {
            return Robot::hoap2();
        }
        if !spec.exists() && spec.components().count() == 1 && spec.extension().is_none() {
            let name = spec.to_string_lossy();
            return Err(crate::Error::Input(format!(
                "robot '{name}'{}: neither a built-in robot ({}) nor a robot's folder, robot.toml or URDF",
                cpg_io::did_you_mean(&name, ROBOTS),
                ROBOTS.join(", ")
            )));
        }
        let is_spec = spec.is_dir() || spec.extension().is_some_and(|e| e == "toml");
        if !is_spec {
            return Robot::from_urdf_file(spec);
        }
        let s = crate::RobotSpec::load(spec)?;
        let dir = if spec.is_dir() { spec } else { spec.parent().unwrap_or(Path::new(".")) };
        Robot::from_urdf_file(&crate::RobotSpec::path_in(dir, &s.urdf))?.with_spec(s)
    }
}

impl ChannelMap {
    /// A built-in map by name ([`MAPS`]), if it is one.
    pub fn builtin(name: &str) -> Option<Result<ChannelMap>> {
        match name {
            "hoap2" => Some(ChannelMap::parse(CMU35_TO_HOAP2, "cmu35_to_hoap2.tsv")),
            "legs" => Some(ChannelMap::parse(CMU35_LEGS_TO_HOAP2, "cmu35_legs_to_hoap2.tsv")),
            _ => None,
        }
    }

    /// A map given by a built-in name ([`MAPS`]) or as a TSV file's path.
    pub fn from_spec(spec: &Path) -> Result<ChannelMap> {
        match spec.to_str().and_then(ChannelMap::builtin) {
            Some(m) => m,
            None if !spec.exists() && spec.components().count() == 1 && spec.extension().is_none() => {
                let name = spec.to_string_lossy();
                Err(crate::Error::Input(format!(
                    "map '{name}'{}: neither a built-in map ({}) nor a map file (a TSV path)",
                    cpg_io::did_you_mean(&name, MAPS),
                    MAPS.join(", ")
                )))
            }
            None => ChannelMap::load(spec),
        }
    }
}

//! # cpg-mocap
//!
//! Reads and writes Acclaim ASF/AMC motion-capture files (the format of the CMU
//! Graphics Lab database) and BVH files ([`bvh`]), holds motions as frames ×
//! named channels, and computes forward kinematics in millimetres.
//!
//! ```no_run
//! # fn main() -> Result<(), cpg_mocap::Error> {
//! let skeleton = cpg_mocap::Skeleton::from_file("35.asf")?;
//! let motion = cpg_mocap::Motion::from_amc_file("35_01.amc", &skeleton, 120.0)?;
//! let femur = motion.select(&["lfemur.rx"])?;
//! let points = skeleton.forward_kinematics(&motion)?;
//! # Ok(()) }
//! ```
//!
//! Conventions:
//! - Rotation channels are in **degrees** in a [`Motion`], whatever the file used.
//! - Root translation channels are in the skeleton's length unit (for CMU,
//!   inches × 0.45); [`Skeleton::mm_per_unit`] converts them.
//! - AMC files do not store a frame rate: every motion is given its rate explicitly.
//!
//! The crate does no networking and depends on no numeric library.

mod amc;
mod asf;
pub mod bvh;
pub mod cycle;
pub mod data;
mod error;
mod ground;
mod kinematics;
mod lex;
mod motion;
pub mod profile;

pub use amc::{parse_amc, write_amc};
pub use asf::{MAX_ASF_BONES, parse_asf, write_asf};
pub use bvh::{Bvh, BvhOptions, parse_bvh, write_bvh};
pub use error::{Error, ParseError, ParseErrorKind, Result};
pub use kinematics::{Kinematics, Positions};
pub use lex::MAX_MAGNITUDE;
pub use motion::{Channel, Motion, ZScore};

use std::path::Path;

/// A degree of freedom of a bone or of the root.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Dof {
    /// Translation along x.
    Tx,
    /// Translation along y.
    Ty,
    /// Translation along z.
    Tz,
    /// Rotation about x.
    Rx,
    /// Rotation about y.
    Ry,
    /// Rotation about z.
    Rz,
}

impl Dof {
    /// Parses `tx`…`rz`, case-insensitively.
    pub fn parse(s: &str) -> Option<Dof> {
        Some(match s.to_ascii_lowercase().as_str() {
            "tx" => Dof::Tx,
            "ty" => Dof::Ty,
            "tz" => Dof::Tz,
            "rx" => Dof::Rx,
            "ry" => Dof::Ry,
            "rz" => Dof::Rz,
            _ => return None,
        })
    }

    /// The lower-case name used in channel names (`rx`).
    pub fn as_str(self) -> &'static str {
        match self {
            Dof::Tx => "tx",
            Dof::Ty => "ty",
            Dof::Tz => "tz",
            Dof::Rx => "rx",
            Dof::Ry => "ry",
            Dof::Rz => "rz",
        }
    }

    /// Whether this is a rotation.
    pub fn is_rotation(self) -> bool {
        matches!(self, Dof::Rx | Dof::Ry | Dof::Rz)
    }

    /// The axis index 0, 1, 2 for x, y, z.
    pub fn axis(self) -> usize {
        match self {
            Dof::Tx | Dof::Rx => 0,
            Dof::Ty | Dof::Ry => 1,
            Dof::Tz | Dof::Rz => 2,
        }
    }
}

/// The order of the three rotations that build a bone's axis frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisOrder(pub [usize; 3]);

impl AxisOrder {
    /// `XYZ`: x applied first, then y, then z.
    pub const XYZ: AxisOrder = AxisOrder([0, 1, 2]);

    /// Parses a permutation of `XYZ`.
    pub fn parse(s: &str) -> Option<AxisOrder> {
        let b = s.as_bytes();
        if b.len() != 3 {
            return None;
        }
        let mut o = [0; 3];
        for (k, c) in b.iter().enumerate() {
            o[k] = match c.to_ascii_uppercase() {
                b'X' => 0,
                b'Y' => 1,
                b'Z' => 2,
                _ => return None,
            };
        }
        let mut seen = [false; 3];
        for &a in &o {
            if seen[a] {
                return None;
            }
            seen[a] = true;
        }
        Some(AxisOrder(o))
    }

    /// The order as text (`XYZ`).
    pub fn as_string(self) -> String {
        self.0.iter().map(|&a| ['X', 'Y', 'Z'][a]).collect()
    }
}

/// Unit of angles in an ASF file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AngleUnit {
    /// Degrees.
    Deg,
    /// Radians.
    Rad,
}

/// The `:units` section.
#[derive(Debug, Clone, PartialEq)]
pub struct Units {
    /// Mass scale.
    pub mass: f64,
    /// Length scale: file lengths are inches × this factor (CMU: 0.45).
    pub length: f64,
    /// Unit of the angles in the ASF file (`axis`, `limits`, root orientation).
    pub angle: AngleUnit,
}

/// The `:root` section.
#[derive(Debug, Clone, PartialEq)]
pub struct Root {
    /// Channel order of the root in AMC lines (CMU: TX TY TZ RX RY RZ).
    pub order: Vec<Dof>,
    /// Order of the orientation rotations.
    pub axis: AxisOrder,
    /// Default position, in skeleton length units.
    pub position: [f64; 3],
    /// Orientation of the root frame, degrees.
    pub orientation_deg: [f64; 3],
}

/// One bone of the skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct Bone {
    /// The `id` field (0 when absent).
    pub id: u32,
    /// Unique name.
    pub name: String,
    /// Unit direction of the bone in the world frame of the zero pose.
    pub direction: [f64; 3],
    /// Length in skeleton units.
    pub length: f64,
    /// Orientation of the bone's local frame, degrees.
    pub axis_deg: [f64; 3],
    /// Order of the axis rotations.
    pub axis_order: AxisOrder,
    /// Degrees of freedom, in AMC value order.
    pub dofs: Vec<Dof>,
    /// Limits per DOF in degrees (empty when the file gives none).
    pub limits: Vec<(f64, f64)>,
    /// Index of the parent bone; `None` for children of the root.
    pub parent: Option<usize>,
}

/// A parsed ASF skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    /// `:name`.
    pub name: String,
    /// `:version`.
    pub version: String,
    /// `:units`.
    pub units: Units,
    /// `:documentation` text.
    pub documentation: String,
    /// `:root`.
    pub root: Root,
    /// Bones in file order.
    pub bones: Vec<Bone>,
}

/// The most bytes read from one input file (CMU's longest AMC trials are a few MB).
pub const MAX_INPUT_BYTES: u64 = 256 << 20;

/// Reads a whole file, but at most `max_bytes`: a larger file (or an endless
/// one such as `/dev/zero`) is an error, not an allocation without bound.
pub fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    cpg_io::read_bounded(path, max_bytes).map_err(|e| match e {
        cpg_io::Error::Io { path, source } => Error::Io { path, source },
        cpg_io::Error::TooLarge { path, max_bytes } => Error::TooLarge { path, max_bytes },
        other => Error::Io { path: path.to_owned(), source: std::io::Error::other(other.to_string()) },
    })
}

impl Skeleton {
    /// Reads and parses an ASF file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Skeleton> {
        let path = path.as_ref();
        let bytes = read_bounded(path, MAX_INPUT_BYTES)?;
        Ok(parse_asf(&file_label(path), &bytes)?)
    }

    /// Index of a bone by name.
    pub fn bone_index(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    /// Millimetres per skeleton length unit (CMU: 25.4 / 0.45 = 56.44).
    pub fn mm_per_unit(&self) -> f64 {
        25.4 / self.units.length
    }

    /// The DOFs that an AMC line for `name` carries (`root` included).
    pub fn dofs_of(&self, name: &str) -> Option<&[Dof]> {
        if name == "root" {
            Some(&self.root.order)
        } else {
            self.bone_index(name).map(|i| self.bones[i].dofs.as_slice())
        }
    }

    /// Bone indices ordered so that every parent precedes its children.
    pub fn topological_order(&self) -> Vec<usize> {
        // Children lists once (linear in the bones), then depth-first with the
        // lower-numbered child first.
        let n = self.bones.len();
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (c, b) in self.bones.iter().enumerate() {
            if let Some(p) = b.parent.filter(|&p| p < n) {
                children[p].push(c);
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut frontier: Vec<usize> = (0..n).filter(|&i| self.bones[i].parent.is_none()).collect();
        while let Some(b) = frontier.pop() {
            order.push(b);
            frontier.extend(children[b].iter().rev());
        }
        order
    }

    /// Converts angles to degrees and checks that the hierarchy is a tree.
    fn finish(&mut self) -> std::result::Result<(), String> {
        if self.units.angle == AngleUnit::Rad {
            let k = 180.0 / std::f64::consts::PI;
            self.root.orientation_deg.iter_mut().for_each(|a| *a *= k);
            for b in &mut self.bones {
                b.axis_deg.iter_mut().for_each(|a| *a *= k);
                for (l, d) in b.limits.iter_mut().zip(&b.dofs) {
                    if d.is_rotation() {
                        l.0 *= k;
                        l.1 *= k;
                    }
                }
            }
        }
        let reached = self.topological_order().len();
        if reached != self.bones.len() {
            return Err(format!(
                "{} bone(s) are not connected to the root (a cycle in the parent links)",
                self.bones.len() - reached
            ));
        }
        Ok(())
    }
}

/// The file name used in error messages: the last path component.
pub(crate) fn file_label(path: &Path) -> String {
    path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| path.display().to_string())
}

/// The format a recording was read from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Format {
    /// An AMC motion with its ASF skeleton.
    Amc,
    /// A BVH file: skeleton and motion in one.
    Bvh {
        /// Millimetres per length unit.
        length_unit_mm: f64,
        /// Whether the unit was inferred from the figure's size.
        inferred: bool,
    },
}

/// A motion and the skeleton it moves, read from a file of either format.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The skeleton (for BVH, built from the hierarchy: see [`bvh`]).
    pub skeleton: Skeleton,
    /// The motion.
    pub motion: Motion,
    /// What it was read from.
    pub format: Format,
}

/// Whether `path` names a BVH file (by its extension, in any case).
pub fn is_bvh(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("bvh"))
}

/// Reads a recording: an AMC file with its ASF `skeleton` (at `rate_hz`,
/// which AMC does not store; 120 Hz when `None`), or a BVH file (no
/// skeleton; its own frame time, which `rate_hz`, when given, must match
/// within 0.1 %).
pub fn read_recording(
    path: &Path,
    skeleton: Option<&Path>,
    rate_hz: Option<f64>,
    bvh: &BvhOptions,
) -> Result<Recording> {
    if is_bvh(path) {
        if let Some(s) = skeleton {
            return Err(Error::InvalidArgument(format!(
                "{} is a BVH file, which carries its own skeleton; {} is not needed",
                file_label(path),
                s.display()
            )));
        }
        let b = Bvh::from_file(path, bvh)?;
        let rate = b.motion.sample_rate_hz();
        if let Some(r) = rate_hz
            && (r - rate).abs() > 1e-3 * rate
        {
            return Err(Error::InvalidArgument(format!(
                "{}: its frames are {} s apart ({rate} Hz), not {r} Hz as asked",
                file_label(path),
                b.frame_time_s
            )));
        }
        return Ok(Recording {
            skeleton: b.skeleton,
            motion: b.motion,
            format: Format::Bvh { length_unit_mm: b.length_unit_mm, inferred: b.unit_inferred },
        });
    }
    let Some(s) = skeleton else {
        return Err(Error::InvalidArgument(format!(
            "{} is an AMC motion: give its ASF skeleton (--skeleton FILE.asf)",
            file_label(path)
        )));
    };
    let sk = Skeleton::from_file(s)?;
    let motion = Motion::from_amc_file(path, &sk, rate_hz.unwrap_or(120.0))?;
    Ok(Recording { skeleton: sk, motion, format: Format::Amc })
}

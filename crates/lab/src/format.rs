//! Output formats, one registry: which formats exist, how a command's
//! output chooses one (`--format`, else the output's extension, else the
//! command's default), and the writers. Every file goes through
//! [`cpg_io::write_output`]: `-` is standard output, regular files are
//! written to a temporary file renamed over them, devices and FIFOs in place.
//!
//! To add a format: a variant of [`Format`] with its name and extensions
//! (the compiler then points to [`Format::name`] and [`Format::extensions`]),
//! and a branch in the writer of each kind of output that can take it.

use std::io::Write;
use std::path::Path;

use cpg_mocap::{Motion, Positions, Skeleton};
use cpg_reservoir::TrainedCpg;
use cpg_robot::JointTrajectory;

use crate::error::{Error, Result};
use crate::run::{Run, is_rotation};

/// A format an output can be written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// Comma-separated values with a header.
    Csv,
    /// NumPy's array format (float64, C order).
    Npy,
    /// ASF/AMC motion (any ASF/AMC viewer).
    Amc,
    /// BVH motion (Blender and most animation tools).
    Bvh,
    /// `trajectory_msgs/JointTrajectory` as JSON.
    Json,
    /// `trajectory_msgs/JointTrajectory` as YAML.
    Yaml,
    /// A self-contained HTML page.
    Html,
    /// An animated GIF.
    Gif,
}

impl Format {
    /// Every format.
    pub const ALL: [Format; 8] =
        [Format::Csv, Format::Npy, Format::Amc, Format::Bvh, Format::Json, Format::Yaml, Format::Html, Format::Gif];

    /// What a free run is written as (`cpg generate`).
    pub const RUN: [Format; 4] = [Format::Csv, Format::Npy, Format::Amc, Format::Bvh];
    /// What robot joint commands are written as (`cpg hoap2`).
    pub const TRAJECTORY: [Format; 4] = [Format::Csv, Format::Npy, Format::Json, Format::Yaml];
    /// What marker positions are written as (`cpg fk`).
    pub const POINTS: [Format; 2] = [Format::Csv, Format::Npy];
    /// What a scene is drawn as (`cpg view`).
    pub const SCENE: [Format; 2] = [Format::Html, Format::Gif];
    /// What a recorded motion is written as.
    pub const MOTION: [Format; 2] = [Format::Amc, Format::Bvh];

    /// The format's name, as `--format` takes it.
    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Npy => "npy",
            Format::Amc => "amc",
            Format::Bvh => "bvh",
            Format::Json => "json",
            Format::Yaml => "yaml",
            Format::Html => "html",
            Format::Gif => "gif",
        }
    }

    /// File extensions that name the format (lower case, without the dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Format::Csv => &["csv"],
            Format::Npy => &["npy"],
            Format::Amc => &["amc"],
            Format::Bvh => &["bvh"],
            Format::Json => &["json"],
            Format::Yaml => &["yaml", "yml"],
            Format::Html => &["html", "htm"],
            Format::Gif => &["gif"],
        }
    }

    /// The format a name (`csv`, `YAML`, `yml`) stands for.
    pub fn from_name(name: &str) -> Option<Format> {
        let n = name.to_ascii_lowercase();
        Format::ALL.into_iter().find(|f| f.name() == n || f.extensions().contains(&n.as_str()))
    }

    /// The format `path`'s extension names, with the extension as written.
    pub fn of_path(path: &Path) -> Option<(String, Format)> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Format::ALL.into_iter().find(|f| f.extensions().contains(&ext.as_str())).map(|f| (ext, f))
    }

    /// The format an output is written in: `explicit` (`--format`) when
    /// given, else the output's extension when it names a format, else
    /// `default`. It must be one of `accepted`; an extension that names
    /// another format than the one written is an error (`-o walk.gif` for
    /// CSV would give a file no GIF reader opens); other extensions are the
    /// user's.
    pub fn choose(explicit: Option<&str>, output: &Path, accepted: &[Format], default: Format) -> Result<Format> {
        let named = Format::of_path(output);
        let list = || accepted.iter().map(|f| f.name()).collect::<Vec<_>>().join(", ");
        let chosen = match explicit {
            Some(f) => Format::from_name(f)
                .filter(|g| accepted.contains(g))
                .ok_or_else(|| Error::Format(format!("--format {}: expected {}", f.to_ascii_lowercase(), list())))?,
            None => match &named {
                Some((ext, f)) if !accepted.contains(f) => {
                    return Err(Error::Format(format!(
                        "{}: .{ext} names a format this command does not write; it writes {} (give --format or another extension)",
                        output.display(),
                        list()
                    )));
                }
                Some((_, f)) => *f,
                None => default,
            },
        };
        if let Some((ext, g)) = &named
            && *g != chosen
        {
            return Err(Error::Format(format!(
                "{}: the extension .{ext} is not the format written ({}); name the file .{} or give --format {}",
                output.display(),
                chosen.name(),
                chosen.name(),
                g.name()
            )));
        }
        Ok(chosen)
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Writes `fill`'s output to `path` through [`cpg_io::write_output`]:
/// atomically for a regular file, `-` for standard output.
pub fn save(path: &Path, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<()> {
    cpg_io::write_output(path, |w| fill(w).map_err(|source| cpg_io::Error::Io { path: path.to_owned(), source }))
        .map_err(Error::from)
}

/// Writes `values` (row-major, C order) as a float64 `.npy` array of `shape`.
pub fn write_npy(w: &mut dyn Write, shape: &[usize], values: impl IntoIterator<Item = f64>) -> std::io::Result<()> {
    use npyz::WriterBuilder;
    let shape: Vec<u64> = shape.iter().map(|&n| n as u64).collect();
    let mut out = npyz::WriteOptions::<f64>::new().default_dtype().shape(&shape).writer(w).begin_nd()?;
    out.extend(values)?;
    out.finish()
}

/// The unit suffix of a channel's CSV column: `_deg` for rotations, else none.
pub fn unit_suffix(name: &str) -> &'static str {
    if is_rotation(name) { "_deg" } else { "" }
}

/// Writes a free run of `m` (`cpg generate`): CSV (`time_s`, then a column
/// per channel in its units), `.npy` (steps × channels), or AMC or BVH with
/// `skeleton` (the channels the model does not generate at 0, the figure on
/// the floor).
pub fn write_run(path: &Path, format: Format, m: &TrainedCpg, run: &Run, skeleton: Option<&Skeleton>) -> Result<()> {
    let d = m.outputs.len();
    match format {
        Format::Csv => save(path, |w| {
            write!(w, "time_s")?;
            for o in &m.outputs {
                write!(w, ",{}{}", o.unit_name(), unit_suffix(o.unit_name()))?;
            }
            writeln!(w)?;
            for k in 0..run.steps {
                write!(w, "{:.6}", k as f64 / run.rate_hz)?;
                for v in &run.values[k * d..(k + 1) * d] {
                    write!(w, ",{v:.6}")?;
                }
                writeln!(w)?;
            }
            Ok(())
        }),
        Format::Npy => save(path, |w| write_npy(w, &[run.steps, d], run.values.iter().copied())),
        Format::Amc | Format::Bvh => {
            let sk = skeleton.ok_or_else(|| {
                Error::Unusable("the model stores no skeleton (it was trained from arrays): give a skeleton".into())
            })?;
            let channels = crate::run::mocap_channels(m)?;
            // Every channel, and a root on the floor when the model generates none.
            let motion = sk.ground(&Motion::new(channels, run.values.clone(), run.rate_hz)?)?;
            write_motion(path, format, sk, &motion)
        }
        other => Err(unaccepted(other, &Format::RUN)),
    }
}

/// Writes a recorded motion as AMC or BVH (lengths in centimetres).
pub fn write_motion(path: &Path, format: Format, sk: &Skeleton, motion: &Motion) -> Result<()> {
    let text = match format {
        Format::Amc => cpg_mocap::write_amc(sk, motion)?,
        Format::Bvh => cpg_mocap::write_bvh(sk, motion)?,
        other => return Err(unaccepted(other, &Format::MOTION)),
    };
    save(path, |w| w.write_all(text.as_bytes()))
}

/// Writes robot joint commands: CSV (time, then each joint's angle,
/// velocity and acceleration), `.npy` (frames × joints × (angle, velocity,
/// acceleration)), or a `trajectory_msgs/JointTrajectory` as JSON or YAML.
pub fn write_trajectory(path: &Path, format: Format, t: &JointTrajectory) -> Result<()> {
    let text = match format {
        Format::Csv => t.to_csv(),
        Format::Json => t.to_ros_json(),
        Format::Yaml => t.to_ros_yaml(),
        Format::Npy => {
            let values = (0..t.values_rad.len())
                .flat_map(|k| [t.values_rad[k], t.velocities_rad_s[k], t.accelerations_rad_s2[k]]);
            return save(path, |w| write_npy(w, &[t.n_frames(), t.joints.len(), 3], values));
        }
        other => return Err(unaccepted(other, &Format::TRAJECTORY)),
    };
    save(path, |w| w.write_all(text.as_bytes()))
}

/// Writes marker positions (`cpg fk`): CSV (frame, time, then x, y, z of
/// every point in mm) or `.npy` (frames × points × 3).
pub fn write_points(path: &Path, format: Format, p: &Positions) -> Result<()> {
    match format {
        Format::Npy => {
            save(path, |w| write_npy(w, &[p.n_frames(), p.names.len(), 3], p.points_mm.iter().flatten().copied()))
        }
        Format::Csv => save(path, |w| {
            write!(w, "frame,time_s")?;
            for n in &p.names {
                write!(w, ",{n}_x_mm,{n}_y_mm,{n}_z_mm")?;
            }
            writeln!(w)?;
            for f in 0..p.n_frames() {
                write!(w, "{},{}", f + 1, f as f64 / p.sample_rate_hz)?;
                for q in p.frame(f) {
                    write!(w, ",{:.4},{:.4},{:.4}", q[0], q[1], q[2])?;
                }
                writeln!(w)?;
            }
            Ok(())
        }),
        other => Err(unaccepted(other, &Format::POINTS)),
    }
}

/// Writes a scene as a self-contained HTML page or an animated GIF.
pub fn write_scene(path: &Path, format: Format, scene: &cpg_view::Scene, gif: &cpg_view::GifOptions) -> Result<()> {
    let bytes = match format {
        Format::Html => scene.to_html().into_bytes(),
        Format::Gif => scene.to_gif(gif).map_err(crate::scene::view_error)?,
        other => return Err(unaccepted(other, &Format::SCENE)),
    };
    save(path, |w| w.write_all(&bytes))
}

fn unaccepted(f: Format, accepted: &[Format]) -> Error {
    Error::Format(format!(
        "{f} is not written for this output; expected {}",
        accepted.iter().map(|f| f.name()).collect::<Vec<_>>().join(", ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_format_has_a_name_and_an_extension_that_lead_back_to_it() {
        for f in Format::ALL {
            assert_eq!(Format::from_name(f.name()), Some(f));
            for e in f.extensions() {
                assert_eq!(Format::of_path(Path::new(&format!("x.{e}"))).map(|(_, g)| g), Some(f));
            }
        }
    }

    #[test]
    fn the_extension_chooses_unless_it_contradicts_the_format() {
        let c = |x: Option<&str>, p: &str| Format::choose(x, Path::new(p), &Format::RUN, Format::Csv);
        assert_eq!(c(None, "walk.NPY").unwrap(), Format::Npy);
        assert_eq!(c(None, "walk.txt").unwrap(), Format::Csv);
        assert_eq!(c(None, "-").unwrap(), Format::Csv);
        assert_eq!(c(Some("bvh"), "walk.out").unwrap(), Format::Bvh);
        let e = c(None, "walk.gif").unwrap_err().to_string();
        assert!(e.contains(".gif names a format this command does not write"), "{e}");
        let e = c(Some("npy"), "walk.csv").unwrap_err().to_string();
        assert!(e.contains("the extension .csv is not the format written (npy)"), "{e}");
        let e = c(Some("xml"), "walk").unwrap_err().to_string();
        assert_eq!(e, "--format xml: expected csv, npy, amc, bvh");
        assert!(matches!(c(Some("gif"), "w").unwrap_err(), Error::Format(_)));
    }
}

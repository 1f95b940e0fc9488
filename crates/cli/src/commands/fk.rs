//! `cpg fk`.

use std::path::Path;

use cpg_lab::format::Format;

use crate::output::Destination;

pub fn run(
    motion: &Path,
    skeleton: Option<&Path>,
    output: &Path,
    rate_hz: Option<f64>,
    bvh_unit_mm: Option<f64>,
) -> anyhow::Result<()> {
    let format = Format::choose(None, output, &Format::POINTS, Format::Csv)?;
    let dest = crate::output::check_writable(output)?;
    let r =
        cpg_mocap::read_recording(motion, skeleton, rate_hz, &cpg_mocap::BvhOptions { length_unit_mm: bvh_unit_mm })?;
    let p = r.skeleton.forward_kinematics(&r.motion)?;
    cpg_lab::format::write_points(output, format, &p)?;
    if format == Format::Npy {
        eprintln!(
            "wrote {} frames × {} points × 3 (x, y, z in mm; points: {}) to {}",
            p.n_frames(),
            p.names.len(),
            p.names.join(", "),
            Destination::describe(&dest)
        );
    } else {
        eprintln!("wrote {} frames × {} points to {}", p.n_frames(), p.names.len(), Destination::describe(&dest));
    }
    Ok(())
}

//! `cpg fk`.

use std::path::Path;

use crate::output::{Destination, write_output};

pub fn run(
    motion: &Path,
    skeleton: Option<&Path>,
    output: &Path,
    rate_hz: Option<f64>,
    bvh_unit_mm: Option<f64>,
) -> anyhow::Result<()> {
    let format = super::output_format(None, output, &["csv", "npy"], "csv")?;
    let dest = crate::output::check_writable(output)?;
    let r =
        cpg_mocap::read_recording(motion, skeleton, rate_hz, &cpg_mocap::BvhOptions { length_unit_mm: bvh_unit_mm })?;
    let p = r.skeleton.forward_kinematics(&r.motion)?;
    if format == "npy" {
        write_output(output, |w| {
            crate::npy::write_npy(w, &[p.n_frames(), p.names.len(), 3], p.points_mm.iter().flatten().copied())
        })?;
        eprintln!(
            "wrote {} frames × {} points × 3 (x, y, z in mm; points: {}) to {}",
            p.n_frames(),
            p.names.len(),
            p.names.join(", "),
            Destination::describe(&dest)
        );
        return Ok(());
    }
    write_output(output, |w| {
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
    })?;
    eprintln!("wrote {} frames × {} points to {}", p.n_frames(), p.names.len(), Destination::describe(&dest));
    Ok(())
}

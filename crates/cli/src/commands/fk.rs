//! `cpg fk`.

use std::path::Path;

use cpg_mocap::{Motion, Skeleton};

use crate::output::{Destination, write_output};

pub fn run(amc: &Path, skeleton: &Path, output: &Path, rate_hz: f64) -> anyhow::Result<()> {
    let sk = Skeleton::from_file(skeleton)?;
    let m = Motion::from_amc_file(amc, &sk, rate_hz)?;
    let p = sk.forward_kinematics(&m)?;
    let dest = crate::output::check_writable(output)?;
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

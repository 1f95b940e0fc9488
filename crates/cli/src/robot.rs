//! `cpg hoap2`: generated motion as HOAP-2 joint commands.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use cpg_hoap2::{ChannelMap, Robot};
use cpg_reservoir::TrainedCpg;

use cpg_cli::generate::{Controls, free_run};
use cpg_cli::output::write_atomic;

/// An asset of the project: as given, else under the workspace's assets/hoap2.
fn asset(given: Option<&PathBuf>, name: &str) -> PathBuf {
    if let Some(p) = given {
        return p.clone();
    }
    let local = Path::new("assets/hoap2").join(name);
    if local.is_file() {
        return local;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/hoap2").join(name)
}

pub struct Args<'a> {
    pub model: &'a Path,
    pub seconds: f64,
    pub control: Option<&'a str>,
    pub control_file: Option<&'a Path>,
    pub rate_hz: Option<f64>,
    pub urdf: Option<&'a PathBuf>,
    pub map: Option<&'a PathBuf>,
    pub output: &'a Path,
}

pub fn run(a: Args<'_>) -> anyhow::Result<()> {
    let m = TrainedCpg::load(a.model)?;
    let robot = Robot::from_urdf_file(&asset(a.urdf, "hoap2.urdf"))?;
    let map = ChannelMap::load(&asset(a.map, "cmu35_to_hoap2.tsv"))?;
    let names: Vec<String> = m.outputs.iter().map(|o| o.name.clone()).collect();
    let missing: Vec<&str> = map.channels().into_iter().filter(|c| !names.iter().any(|n| n == c)).collect();
    if !missing.is_empty() {
        bail!(
            "the model generates [{}]; the joint map also needs [{}] (train on those channels, or give a --map that uses only the model's)",
            names.join(", "),
            missing.join(", ")
        );
    }
    if !(a.seconds.is_finite() && a.seconds > 0.0) {
        bail!("--seconds {}: expected a positive duration", a.seconds);
    }
    let rate = m.provenance.sample_rate_hz;
    let n = (a.seconds * rate).round() as usize;
    let controls = Controls::from_args(&m, a.control, a.control_file)?;
    let y = free_run(&m, n, &controls)?;
    let mut t = map.apply(&robot, &names, &y, rate)?;
    if let Some(r) = a.rate_hz {
        t = t.resample(r).context("resampling")?;
    }
    let csv = t.to_csv();
    write_atomic(a.output, |w| Ok(w.write_all(csv.as_bytes())?))?;
    eprintln!(
        "wrote {} frames at {} Hz of {} HOAP-2 joints (rad) to {}",
        t.n_frames(),
        t.rate_hz,
        t.joints.len(),
        a.output.display()
    );
    eprintln!("{:<14} {:>9} {:>12} {:>10} {:>10}", "joint", "clamped", "max excess", "min (deg)", "max (deg)");
    for c in &t.clamps.joints {
        eprintln!(
            "{:<14} {:>8.1}% {:>10.2}° {:>10.1} {:>10.1}",
            c.joint,
            100.0 * c.n_clamped as f64 / c.n_frames.max(1) as f64,
            c.max_excess_rad.to_degrees(),
            c.min_rad.to_degrees(),
            c.max_rad.to_degrees()
        );
    }
    Ok(())
}

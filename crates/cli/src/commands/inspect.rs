//! `cpg inspect`.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, bail};
use cpg_mocap::{Motion, Skeleton};

pub fn run(file: &Path, skeleton: Option<&Path>, rate_hz: Option<f64>, bvh_unit_mm: Option<f64>) -> anyhow::Result<()> {
    let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let out = std::io::stdout();
    let mut out = out.lock();
    match ext.as_deref() {
        Some("asf") => skeleton_tree(&mut out, &Skeleton::from_file(file)?),
        Some("amc") => {
            let Some(sk) = skeleton else {
                bail!("{} is a motion file: give its skeleton with --skeleton <file.asf>", file.display());
            };
            let sk = Skeleton::from_file(sk)?;
            let m = Motion::from_amc_file(file, &sk, rate_hz.unwrap_or(120.0))?;
            motion_summary(&mut out, file, &m)
        }
        Some("bvh") => {
            let r = cpg_mocap::read_recording(
                file,
                skeleton,
                rate_hz,
                &cpg_mocap::BvhOptions { length_unit_mm: bvh_unit_mm },
            )?;
            if let cpg_mocap::Format::Bvh { length_unit_mm, inferred } = r.format {
                writeln!(
                    out,
                    "BVH: {length_unit_mm} mm per length unit ({})",
                    if inferred { "inferred from the figure's size; --bvh-unit-mm sets it" } else { "as given" }
                )?;
            }
            skeleton_tree(&mut out, &r.skeleton)?;
            motion_summary(&mut out, file, &r.motion)
        }
        _ => bail!("{}: expected an .asf, .amc or .bvh file", file.display()),
    }
}

fn skeleton_tree(out: &mut impl Write, sk: &Skeleton) -> anyhow::Result<()> {
    writeln!(out, "skeleton '{}' (version {})", sk.name, sk.version)?;
    writeln!(
        out,
        "units: mass {}, length {} ({:.3} mm per unit), angles in degrees",
        sk.units.mass,
        sk.units.length,
        sk.mm_per_unit()
    )?;
    let order: Vec<&str> = sk.root.order.iter().map(|d| d.as_str()).collect();
    let n_dofs = sk.root.order.len() + sk.bones.iter().map(|b| b.dofs.len()).sum::<usize>();
    writeln!(out, "{} bones, {} channels per frame", sk.bones.len(), n_dofs)?;
    writeln!(out, "root [{}]", order.join(" "))?;
    // Children lists once: a tree of thousands of bones prints in linear time.
    let mut kids: Vec<Vec<usize>> = vec![Vec::new(); sk.bones.len() + 1];
    for (c, b) in sk.bones.iter().enumerate() {
        kids[b.parent.map_or(0, |p| p + 1)].push(c);
    }
    let children = |p: Option<usize>| -> Vec<usize> { kids[p.map_or(0, |p| p + 1)].clone() };
    let mut stack: Vec<(usize, usize)> = children(None).into_iter().rev().map(|c| (c, 1)).collect();
    while let Some((b, depth)) = stack.pop() {
        let bone = &sk.bones[b];
        let dofs: Vec<String> = bone
            .dofs
            .iter()
            .enumerate()
            .map(|(k, d)| match bone.limits.get(k) {
                Some((lo, hi)) => format!("{} {lo}..{hi}", d.as_str()),
                None => d.as_str().to_owned(),
            })
            .collect();
        let dof_text = if dofs.is_empty() { "no dof".to_owned() } else { dofs.join(", ") };
        writeln!(
            out,
            "{}{} (length {:.1} mm) [{}]",
            // Indentation shows the depth up to 32 levels (a human figure has 8); deeper bones say theirs.
            if depth <= 32 { "  ".repeat(depth) } else { format!("{}[depth {depth}] ", "  ".repeat(32)) },
            bone.name,
            bone.length * sk.mm_per_unit(),
            dof_text
        )?;
        stack.extend(children(Some(b)).into_iter().rev().map(|c| (c, depth + 1)));
    }
    Ok(())
}

fn motion_summary(out: &mut impl Write, file: &Path, m: &Motion) -> anyhow::Result<()> {
    writeln!(
        out,
        "{}: {} frames at {} Hz = {:.3} s, {} channels (angles in deg, root translation in skeleton units)",
        file.display(),
        m.n_frames(),
        m.sample_rate_hz(),
        m.duration_s(),
        m.n_channels()
    )?;
    writeln!(out, "{:<16} {:>12} {:>12} {:>12}", "channel", "min", "max", "mean")?;
    for (k, c) in m.channels().iter().enumerate() {
        let col = m.column_at(k);
        let min = col.iter().copied().fold(f64::INFINITY, f64::min);
        let max = col.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mean = col.iter().sum::<f64>() / col.len() as f64;
        writeln!(out, "{:<16} {min:>12.4} {max:>12.4} {mean:>12.4}", c.to_string()).context("writing to stdout")?;
    }
    Ok(())
}

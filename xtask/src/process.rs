//! Running the tools xtask drives (cargo, python, maturin): one command at
//! a time from the workspace root, its time printed, a failure an error.

use std::process::Command;

use anyhow::{Context, bail};

/// Runs a command in the workspace root, echoing it; fails on a non-zero exit.
pub fn cmd(program: &str, args: &[&str], env: &[(&str, &str)]) -> anyhow::Result<()> {
    eprintln!("$ {program} {}", args.join(" "));
    let start = std::time::Instant::now();
    let status = Command::new(program)
        .args(args)
        .envs(env.iter().copied())
        .current_dir(crate::root())
        .status()
        .with_context(|| format!("starting {program}"))?;
    eprintln!("  ({program} {}: {:.1} s)", args.first().copied().unwrap_or(""), start.elapsed().as_secs_f64());
    if !status.success() {
        bail!("`{program} {}` failed ({status})", args.join(" "));
    }
    Ok(())
}

/// Runs a command in the workspace root and returns its standard output; fails on a non-zero exit.
pub fn output(program: &str, args: &[&str]) -> anyhow::Result<String> {
    let out = Command::new(program)
        .args(args)
        .current_dir(crate::root())
        .output()
        .with_context(|| format!("starting {program}"))?;
    if !out.status.success() {
        bail!("`{program} {}` failed: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

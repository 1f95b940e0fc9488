//! `cargo xtask fuzz`: runs each parser fuzz target for a bounded time.

use std::process::Command;

use anyhow::{Context, bail};

const TARGETS: &[&str] = &["parse_asf", "parse_amc"];

pub fn run(seconds: u64) -> anyhow::Result<()> {
    let have = Command::new("cargo").args(["fuzz", "--version"]).output().is_ok_and(|o| o.status.success());
    if !have {
        crate::ci::cmd("cargo", &["install", "cargo-fuzz", "--locked"], &[])?;
    }
    let dir = crate::root().join("crates/mocap/fuzz");
    let mut summary = Vec::new();
    for t in TARGETS {
        std::fs::create_dir_all(dir.join("corpus").join(t))?;
        let seeds = crate::root().join("crates/mocap/test_data");
        eprintln!("fuzzing {t} for {seconds} s");
        let out = Command::new("cargo")
            .args(["fuzz", "run", t, &format!("corpus/{t}"), &seeds.to_string_lossy(), "--"])
            .arg(format!("-max_total_time={seconds}"))
            .arg("-print_final_stats=1")
            .env("RUSTC_BOOTSTRAP", "1")
            .current_dir(&dir)
            .output()
            .context("running cargo fuzz")?;
        let err = String::from_utf8_lossy(&out.stderr);
        let runs = err
            .lines()
            .find_map(|l| l.strip_prefix("stat::number_of_executed_units:"))
            .map(|s| s.trim().to_owned())
            .unwrap_or_else(|| "?".into());
        if !out.status.success() {
            eprintln!("{err}");
            bail!(
                "fuzz target {t} failed after {runs} inputs: see the crash above and crates/mocap/fuzz/artifacts/{t}"
            );
        }
        summary.push(format!("{t}: {runs} inputs in {seconds} s, no crash"));
    }
    for s in summary {
        println!("{s}");
    }
    Ok(())
}

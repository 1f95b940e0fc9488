//! `cargo xtask fuzz`: builds the fuzz targets of `fuzz/` with the stable
//! toolchain and runs each under libFuzzer for a bounded time.
//!
//! Nothing beyond a fresh machine is needed: the coverage instrumentation is
//! LLVM's sanitizer-coverage pass, asked for with stable `-C` flags;
//! libFuzzer itself comes from the `libfuzzer-sys` crate, compiled by the
//! machine's C++ compiler. Each target's corpus grows in `target/fuzz/corpus`;
//! an input that crashes, hangs or exhausts memory is copied into
//! `fuzz/regressions/<target>/`, where `tests/fuzz_regressions.rs` replays
//! it from then on.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, bail};

/// The targets, as named in `fuzz/Cargo.toml` and `fuzz/checks.rs`.
pub const TARGETS: [&str; 7] = ["asf", "amc", "bvh", "config", "model", "control_csv", "urdf"];

/// The instrumentation cargo-fuzz would ask for, without its nightly-only
/// sanitizer flag: edge coverage with inline 8-bit counters, the PC table
/// and comparison tracing, plus debug assertions and overflow checks.
const RUSTFLAGS: &str = "-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
    -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
    -Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks";

/// Longest input tried, bytes (the seeds are a few kB).
const MAX_LEN: usize = 16_384;

fn host_triple() -> anyhow::Result<String> {
    let out = Command::new("rustc").arg("-vV").output().context("running rustc -vV")?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: "))
        .map(str::to_owned)
        .context("rustc -vV names no host")
}

/// How the targets are built.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Build {
    /// Everything optimised: for runs long enough to search.
    Release,
    /// The reservoir crate unoptimised (fuzz/Cargo.toml's `smoke` profile):
    /// two minutes less to build, for CI's few seconds per target.
    Smoke,
}

impl Build {
    fn profile(self) -> &'static str {
        match self {
            Build::Release => "release",
            Build::Smoke => "smoke",
        }
    }
}

/// Builds every target; returns the directory of the binaries.
fn build(root: &Path, how: Build) -> anyhow::Result<PathBuf> {
    let host = host_triple()?;
    let target_dir = root.join("target/fuzz");
    let profile = how.profile();
    eprintln!(
        "$ cargo build --profile {profile} --manifest-path fuzz/Cargo.toml --target {host} (instrumented for libFuzzer)"
    );
    // An explicit --target keeps the flags off build scripts and proc macros.
    let status = Command::new("cargo")
        .args(["build", "--profile", profile, "--bins", "--manifest-path", "fuzz/Cargo.toml", "--target", &host])
        .arg("--target-dir")
        .arg(&target_dir)
        .env("RUSTFLAGS", RUSTFLAGS)
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .current_dir(root)
        .status()
        .context("starting cargo")?;
    if !status.success() {
        bail!("building the fuzz targets failed ({status}); libfuzzer-sys needs a C++ compiler (g++ or clang++)");
    }
    Ok(target_dir.join(host).join(profile))
}

/// One target's run: executions, and the inputs it failed on (if any).
struct Outcome {
    executions: u64,
    failures: Vec<PathBuf>,
}

fn run_target(root: &Path, bin: &Path, target: &str, seconds: u64, seed: Option<u64>) -> anyhow::Result<Outcome> {
    let work = root.join("target/fuzz");
    let corpus = work.join("corpus").join(target);
    let artifacts = work.join("artifacts").join(target);
    let logs = work.join("logs");
    // Artifacts of earlier runs were kept in fuzz/regressions already.
    let _ = std::fs::remove_dir_all(&artifacts);
    for d in [&corpus, &artifacts, &logs] {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    let log_path = logs.join(format!("{target}.log"));
    let log = std::fs::File::create(&log_path).with_context(|| format!("creating {}", log_path.display()))?;
    let mut command = Command::new(bin);
    if let Some(seed) = seed {
        command.arg(format!("-seed={seed}"));
    }
    let status = command
        .arg(&corpus)
        .arg(root.join("fuzz/seeds").join(target))
        .arg(format!("-max_total_time={seconds}"))
        .arg(format!("-max_len={MAX_LEN}"))
        .arg("-timeout=10")
        .arg("-rss_limit_mb=2048")
        .arg("-print_final_stats=1")
        .arg(format!("-artifact_prefix={}/", artifacts.display()))
        .stdout(Stdio::null())
        .stderr(log)
        .current_dir(root)
        .status()
        .with_context(|| format!("starting {}", bin.display()))?;
    let text = std::fs::read_to_string(&log_path).unwrap_or_default();
    let executions = text
        .lines()
        .find_map(|l| l.strip_prefix("stat::number_of_executed_units:"))
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(0);
    let mut failures = Vec::new();
    if !status.success() {
        let kept = root.join("fuzz/regressions").join(target);
        std::fs::create_dir_all(&kept)?;
        for e in std::fs::read_dir(&artifacts)?.flatten() {
            let dest = kept.join(e.file_name());
            std::fs::copy(e.path(), &dest)?;
            failures.push(dest);
        }
        if failures.is_empty() {
            bail!("fuzz target {target} exited with {status} and left no input; see {}", log_path.display());
        }
    }
    Ok(Outcome { executions, failures })
}

/// Adds a run to `target/fuzz/executions.tsv` and returns the target's total over every run kept there.
fn tally(root: &Path, target: &str, executions: u64, seconds: u64) -> anyhow::Result<u64> {
    let path = root.join("target/fuzz/executions.tsv");
    let mut text = std::fs::read_to_string(&path).unwrap_or_default();
    text.push_str(&format!("{target}\t{executions}\t{seconds}\n"));
    std::fs::write(&path, &text)?;
    Ok(text
        .lines()
        .filter_map(|l| {
            let mut f = l.split('\t');
            (f.next() == Some(target)).then(|| f.next().and_then(|n| n.parse::<u64>().ok())).flatten()
        })
        .sum())
}

/// Builds the targets and runs each of `targets` (all when empty) for
/// `seconds`, with libFuzzer's random seed or the one given.
pub fn run(seconds: u64, targets: &[String], seed: Option<u64>, how: Build) -> anyhow::Result<()> {
    let root = crate::root();
    for t in targets {
        if !TARGETS.contains(&t.as_str()) {
            bail!("unknown fuzz target '{t}'; the targets are {}", TARGETS.join(", "));
        }
    }
    let chosen: Vec<&str> =
        if targets.is_empty() { TARGETS.to_vec() } else { targets.iter().map(String::as_str).collect() };
    let started = std::time::Instant::now();
    let bin_dir = build(&root, how)?;
    eprintln!("  (building the fuzz targets: {:.1} s)", started.elapsed().as_secs_f64());
    let mut summary = Vec::new();
    let mut failed = Vec::new();
    for t in chosen {
        eprintln!("fuzzing {t} for {seconds} s …");
        let o = run_target(&root, &bin_dir.join(t), t, seconds, seed)?;
        let total = tally(&root, t, o.executions, seconds)?;
        if o.failures.is_empty() {
            summary.push(format!(
                "{t:<12} {:>12} inputs in {seconds} s, no crash ({total} on this machine in all)",
                o.executions
            ));
        } else {
            let names: Vec<String> = o.failures.iter().map(|p| p.display().to_string()).collect();
            summary.push(format!("{t:<12} FAILED after {} inputs; kept: {}", o.executions, names.join(", ")));
            failed.push(t);
        }
    }
    for s in &summary {
        println!("{s}");
    }
    if !failed.is_empty() {
        bail!(
            "fuzz target(s) {} failed; the inputs are kept in fuzz/regressions (replayed by tests/fuzz_regressions.rs); logs in target/fuzz/logs",
            failed.join(", ")
        );
    }
    Ok(())
}

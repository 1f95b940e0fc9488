//! Project automation: `cargo xtask <command>`. Runs optimised (see
//! `.cargo/config.toml`), so training and evaluation never run in a debug build.

mod bench;
mod ci;
mod fetch;
mod figures;
mod fuzz;
mod hoap2_model;
mod process;
mod python;
mod report;
mod train;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Project automation for the cpg workspace.
#[derive(Debug, Parser)]
#[command(name = "cargo xtask", bin_name = "cargo xtask", about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fill data/cmu35, data/cmu86 and data/cmu-bvh (other people, in BVH) with the files listed in their MANIFEST.tsv.
    ///
    /// Files are copied from a directory (--from; by default ../shared/data/cmu/SUBJECT
    /// when it exists) or downloaded from the CMU site. Every file is checked
    /// against the manifest's size and SHA-256 before it is moved into place, so a
    /// failed, truncated or corrupt transfer leaves nothing behind. Files that
    /// are already present and verify are left alone.
    FetchData(fetch::Args),
    /// The checks CI runs, in this order: fmt, clippy (warnings denied), the
    /// crate layering rules (checked with `cargo tree`), the docs (warnings
    /// denied), every test (after fetching the data), the Python package's
    /// tests (`cargo xtask python`), and each fuzz target for 5 s (a smoke run;
    /// `cargo xtask fuzz` runs them longer); it prints each step's time at the end.
    Ci,
    /// Fetch the data if needed, then run every test of the workspace.
    Test {
        /// Extra arguments passed to `cargo test`.
        #[arg(trailing_var_arg = true)]
        args: Vec<String>,
    },
    /// Build the Python package (crates/python) into target/python-venv with
    /// maturin, pytest, numpy, mujoco, optuna and mypy from PyPI, check its
    /// type stubs against the compiled module (mypy.stubtest), and run its
    /// tests (crates/python/tests: the README's Python quick start, the same
    /// bits as `cpg train`, the MuJoCo example).
    Python,
    /// Train experiment configurations of experiments/ and save their models
    /// (the same models the report trains; `cpg train --config` does the same for one file).
    Train(train::TrainArgs),
    /// Run every experiment configuration and write report/: REPORT.md (a
    /// summary of every claim of both papers, each measured beside the
    /// paper's, with its rule), metrics.json, the figures (PNG and SVG) and
    /// HOAP-2 joint trajectories.
    Evaluate(report::Args),
    /// Benchmarks, each figure beside a floor measured in the same run: K
    /// free runs per pass over the weights (K = 1, 8, 32, 128; N = 300 and
    /// 2000; f32 and f64; one and two cores) against the multiply-add peak and
    /// the weight-streaming floor; one stream split over both cores with its
    /// synchronisation cost; the training phases; f32 against f64 accuracy;
    /// E1's pipeline (with --vs-reservoirpy, beside ReservoirPy); `cpg tune`'s
    /// configurations per minute; the HOAP-2's closed loop in MuJoCo against
    /// real time; the full evaluation's time by section; and the peak memory
    /// of each process.
    Bench(bench::Args),
    /// Write the HOAP-2's physical model: assets/hoap2/hoap2.urdf (each link's
    /// centre of mass, inertia and collision box from cpg-robot's shape table,
    /// the joints and masses kept), assets/hoap2/hoap2.xml (the MuJoCo scene built
    /// from that URDF) and the derived table of docs/hoap2-model.md. A test checks
    /// that the committed files are what this writes.
    Hoap2Model,
    /// Build the fuzz targets (ASF, AMC, BVH, TOML config, model file,
    /// control CSV, URDF) with the stable toolchain and run each under
    /// libFuzzer for a bounded time.
    ///
    /// Needs only what a fresh machine has: cargo, the C++ compiler that
    /// builds libFuzzer (from the libfuzzer-sys crate) and crates.io. An input
    /// that crashes, hangs or runs out of memory is copied into
    /// fuzz/regressions/TARGET, which `cargo test` replays. `cargo xtask ci`
    /// runs every target for a short time.
    Fuzz {
        /// Seconds per target.
        #[arg(long, default_value_t = 60)]
        seconds: u64,
        /// libFuzzer's seed (default: a new one each run).
        #[arg(long)]
        seed: Option<u64>,
        /// Targets to run (default: all): asf, amc, bvh, config, model, control_csv, urdf.
        targets: Vec<String>,
    },
}

/// The cores this machine offers: the thread count evaluation, training and
/// benches are given (the library reads no ambient pool size).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::FetchData(args) => fetch::run(&args),
        Command::Ci => ci::run(),
        Command::Test { args } => ci::test(&args),
        Command::Fuzz { seconds, seed, targets } => fuzz::run(seconds, &targets, seed, fuzz::Build::Release),
        Command::Bench(args) => bench::run(&args),
        Command::Train(args) => train::run(&args),
        Command::Python => python::run(),
        Command::Hoap2Model => hoap2_model::run(),
        Command::Evaluate(args) => report::run(&args),
    };
    if let Some(line) = cpg_lab::memory::report_line() {
        eprintln!("{line}");
    }
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The checkout the command runs in: the nearest folder at or above the
/// current directory whose `Cargo.toml` declares the workspace and which holds
/// `xtask/` (what cargo itself finds for `cargo xtask`); failing that, the
/// checkout cargo ran this binary from (`CARGO_MANIFEST_DIR` at run time).
/// Never the path the binary was compiled in: with one `CARGO_TARGET_DIR`
/// shared by two clones, that could be the other clone.
pub fn root() -> PathBuf {
    static ROOT: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    ROOT.get_or_init(|| {
        if let Some(d) = std::env::current_dir().ok().and_then(|cwd| find_root(&cwd)) {
            return d;
        }
        let here = std::env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("xtask"));
        here.parent().map(PathBuf::from).unwrap_or(here)
    })
    .clone()
}

/// The nearest folder at or above `start` that is this workspace's checkout.
fn find_root(start: &std::path::Path) -> Option<PathBuf> {
    let is_root = |d: &std::path::Path| {
        d.join("xtask").is_dir()
            && std::fs::read_to_string(d.join("Cargo.toml")).is_ok_and(|t| t.lines().any(|l| l.trim() == "[workspace]"))
    };
    start.ancestors().find(|d| is_root(d)).map(std::path::Path::to_owned)
}

/// Where cargo puts what it builds for this checkout: `cargo metadata`'s
/// `target_directory` (so `CARGO_TARGET_DIR` and `build.target-dir` are
/// honoured), else `target/` in the checkout.
pub fn target_dir() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| metadata_target_dir(&root(), &[]).unwrap_or_else(|| root().join("target"))).clone()
}

/// `cargo metadata`'s target directory for the checkout at `root`, with `env` set.
fn metadata_target_dir(root: &std::path::Path, env: &[(&str, &str)]) -> Option<PathBuf> {
    let out = std::process::Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .envs(env.iter().copied())
        .current_dir(root)
        .output()
        .ok()?;
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).ok().filter(|_| out.status.success())?;
    v.get("target_directory").and_then(|t| t.as_str()).map(PathBuf::from)
}

/// A binary of this workspace built in the release profile (`cpg`).
pub fn release_binary(name: &str) -> PathBuf {
    target_dir().join("release").join(format!("{name}{}", std::env::consts::EXE_SUFFIX))
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn no_library_function_is_longer_than_the_bound() {
        let long = crate::ci::long_functions(&super::root()).unwrap();
        assert!(long.is_empty(), "{long:?}");
        // The scan finds a long function, and not one in a macro or the app.
        let dir = std::env::temp_dir().join(format!("cpg-long-fns-{}", std::process::id()));
        let body = "    let x = 1;\n".repeat(130);
        for (p, text) in [
            ("crates/a/src/lib.rs", format!("pub fn long() {{\n{body}}}\n\nfn short() {{\n}}\n")),
            (
                "crates/b/src/lib.rs",
                format!("macro_rules! m {{\n    () => {{\n        fn inside() {{\n{body}        }}\n    }};\n}}\n"),
            ),
            ("crates/cli/src/main.rs", format!("fn main() {{\n{body}}}\n")),
        ] {
            let f = dir.join(p);
            std::fs::create_dir_all(f.parent().unwrap()).unwrap();
            std::fs::write(&f, text).unwrap();
        }
        let found = crate::ci::long_functions(&dir).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(found, vec![("crates/a/src/lib.rs".to_owned(), 1, "long".to_owned(), 132)]);
    }

    /// `cargo xtask --help` and each task's help, pinned (UPDATE_SNAPSHOTS=1 rewrites them).
    #[test]
    fn help_texts_match_their_snapshots() {
        let dir = super::root().join("xtask/tests/help");
        let mut cmd = super::Cli::command().term_width(100);
        cmd.build();
        let mut texts = vec![("xtask".to_owned(), cmd.render_long_help().to_string())];
        for sub in cmd.get_subcommands_mut() {
            let name = format!("xtask-{}", sub.get_name());
            texts.push((name, sub.render_long_help().to_string()));
        }
        let mut changed = Vec::new();
        for (name, now) in texts {
            let path = dir.join(format!("{name}.txt"));
            if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
                std::fs::write(&path, &now).unwrap();
                continue;
            }
            if std::fs::read_to_string(&path).unwrap_or_default() != now {
                changed.push(name);
            }
        }
        assert!(changed.is_empty(), "help texts changed (UPDATE_SNAPSHOTS=1 to accept): {changed:?}");
    }

    /// The checkout is the one the command runs in, found from the current
    /// directory, and built binaries are where cargo puts them: with
    /// `CARGO_TARGET_DIR` set, not in `target/` of the checkout (the main job
    /// once failed there after 25 minutes, and with one target directory
    /// shared by two clones it read and wrote the other clone).
    #[test]
    fn the_checkout_is_found_from_where_the_command_runs_and_binaries_where_cargo_builds() {
        let here = super::root();
        assert!(here.join("xtask/Cargo.toml").is_file() && here.join("experiments").is_dir(), "{}", here.display());
        let dir = tempfile::tempdir().unwrap();
        let other = dir.path().join("other-clone");
        std::fs::create_dir_all(other.join("xtask")).unwrap();
        std::fs::create_dir_all(other.join("crates/lab/src")).unwrap();
        std::fs::write(other.join("Cargo.toml"), "[workspace]\nmembers = []\n").unwrap();
        assert_eq!(super::find_root(&other.join("crates/lab/src")), Some(other.clone()));
        assert_eq!(super::find_root(dir.path()), None, "above a checkout there is none");
        let shared = dir.path().join("shared-target");
        let t = super::metadata_target_dir(&here, &[("CARGO_TARGET_DIR", shared.to_str().unwrap())]).unwrap();
        assert_eq!(t, shared);
        assert!(super::release_binary("cpg").starts_with(super::target_dir()));
    }

    #[test]
    fn usage_says_cargo_xtask() {
        let h = super::Cli::command().render_usage().to_string();
        assert!(h.contains("cargo xtask"), "{h}");
    }
}

//! Project automation: `cargo xtask <command>`. Runs optimised (see
//! `.cargo/config.toml`), so training and evaluation never run in a debug build.

mod bench;
mod centralized_eval;
mod ci;
mod evaluate;
mod experiments;
mod fetch;
mod figures;
mod fuzz;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// Project automation for the cpg workspace.
#[derive(Debug, Parser)]
#[command(name = "cargo xtask", about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fill data/cmu35 (and data/cmu86) with the CMU files listed in their MANIFEST.tsv.
    ///
    /// Files are copied from a directory (--from; by default ../shared/data/cmu/SUBJECT
    /// when it exists) or downloaded from the CMU site. Every file is checked
    /// against the manifest's size and SHA-256 before it is moved into place, so a
    /// failed, truncated or corrupt transfer leaves nothing behind. Files that
    /// are already present and verify are left alone.
    FetchData(fetch::Args),
    /// The checks CI runs: fmt, clippy (warnings denied), the tests, docs, and the
    /// crate layering rules (checked with `cargo tree`).
    Ci,
    /// Fetch the data if needed, then run every test of the workspace.
    Test {
        /// Extra arguments passed to `cargo test`.
        #[arg(trailing_var_arg = true)]
        args: Vec<String>,
    },
    /// Train an experiment's CPG and save it under models/ (E1 so far: the
    /// left femur of 35_01), then check it in a 900 s free run.
    Train(experiments::TrainArgs),
    /// Run every experiment of wyffels & Schrauwen (2009) and write report/:
    /// REPORT.md (each metric beside the paper's claim), metrics.json, the
    /// figures (PNG and SVG) and HOAP-2 joint trajectories.
    Evaluate(evaluate::Args),
    /// Benchmarks: one free-run step, harvesting, the 91-penalty sweep and
    /// training, each beside a measured floor, and f32 against f64 accuracy.
    Bench,
    /// Run the coverage-guided fuzz targets of the parsers for a bounded time.
    ///
    /// Needs cargo-fuzz (installed from crates.io when missing) and uses the
    /// stable toolchain with RUSTC_BOOTSTRAP=1.
    Fuzz {
        /// Seconds per target.
        #[arg(long, default_value_t = 60)]
        seconds: u64,
    },
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::FetchData(args) => fetch::run(&args),
        Command::Ci => ci::run(),
        Command::Test { args } => ci::test(&args),
        Command::Fuzz { seconds } => fuzz::run(seconds),
        Command::Bench => bench::run(),
        Command::Train(args) => experiments::run_train(&args),
        Command::Evaluate(args) => evaluate::run_all(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// The workspace root (the parent of this crate).
pub fn root() -> PathBuf {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    here.parent().map(PathBuf::from).unwrap_or(here)
}

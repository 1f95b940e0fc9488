//! `cpg`: learn rhythmic motion from motion capture and play it back as a
//! central pattern generator. This binary is glue: the work is in the library crates.

mod fk;
mod inspect;
mod output;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Learn rhythmic human motion from motion capture and play it back as a CPG.
#[derive(Debug, Parser)]
#[command(name = "cpg", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Show what a mocap file holds.
    ///
    /// For an ASF skeleton: units, root and the bone tree with each bone's
    /// degrees of freedom and limits. For an AMC motion (needs --skeleton):
    /// frame count, duration and per-channel minimum, maximum and mean.
    Inspect {
        /// An .asf or .amc file.
        file: PathBuf,
        /// The skeleton (.asf) that an .amc file belongs to.
        #[arg(long, short)]
        skeleton: Option<PathBuf>,
        /// Capture rate of the AMC file in Hz (AMC files do not store it; CMU uses 120).
        #[arg(long, default_value_t = 120.0)]
        rate_hz: f64,
    },
    /// Forward kinematics: world positions of the root and every bone end, in mm.
    ///
    /// Writes a CSV with columns frame, time_s, then POINT_x_mm, POINT_y_mm,
    /// POINT_z_mm for the root and each bone (31 points for CMU skeletons).
    /// The skeleton frame is y-up.
    Fk {
        /// The motion (.amc).
        amc: PathBuf,
        /// Its skeleton (.asf).
        #[arg(long, short)]
        skeleton: PathBuf,
        /// Output CSV file (written atomically).
        #[arg(long, short)]
        output: PathBuf,
        /// Capture rate in Hz.
        #[arg(long, default_value_t = 120.0)]
        rate_hz: f64,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, skeleton, rate_hz } => inspect::run(&file, skeleton.as_deref(), rate_hz),
        Command::Fk { amc, skeleton, output, rate_hz } => fk::run(&amc, &skeleton, &output, rate_hz),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`cpg inspect … | head`) is not an error.
            if e.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

//! `cpg`: learn rhythmic motion from motion capture and play it back as a
//! central pattern generator. This binary is glue: the work is in the library crates.

mod fk;
mod inspect;
mod robot;
mod train;

use cpg_cli::{evaluate, generate};

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
    /// Train a CPG on your own mocap data, as described by a TOML file.
    ///
    /// The file names the skeleton, the motion segments (each with its control
    /// values), the channels to learn, the reservoir (a preset plus overrides) and
    /// the penalty search; see examples/walk22.toml. Writes a model file.
    Train {
        /// The configuration file.
        #[arg(long, short)]
        config: PathBuf,
        /// Write the model here instead of the path in the file's output section.
        #[arg(long, short)]
        output: Option<PathBuf>,
    },
    /// Run a trained CPG freely and write what it generates (CSV or AMC).
    ///
    /// CSV columns: time_s, then one per output channel in the training units
    /// (degrees for rotation channels, suffix _deg).
    Generate {
        #[command(flatten)]
        run: RunArgs,
        /// csv, or amc (playable in any ASF/AMC viewer; needs --skeleton).
        #[arg(long, default_value = "csv")]
        format: String,
        /// The skeleton for --format amc.
        #[arg(long)]
        skeleton: Option<PathBuf>,
        /// Output file (written atomically).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Run a trained CPG and write HOAP-2 joint commands (CSV: time_s, then the joints in rad).
    ///
    /// Channels are mapped to joints by a TSV map (default assets/hoap2/cmu35_to_hoap2.tsv),
    /// clamped to the URDF's limits (default assets/hoap2/hoap2.urdf), and a table of how
    /// often and how far each joint hit its limits is printed.
    Hoap2 {
        #[command(flatten)]
        run: RunArgs,
        /// Resample to this rate (e.g. 1000 for a 1 kHz servo loop); default: the model's rate.
        #[arg(long)]
        rate_hz: Option<f64>,
        /// The robot description.
        #[arg(long)]
        urdf: Option<PathBuf>,
        /// The channel-to-joint map.
        #[arg(long)]
        map: Option<PathBuf>,
        /// Output CSV (written atomically).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Stability of a trained CPG: a long free run against the teacher's cycle
    /// (period, amplitude, phase-aligned error) and the recovery from a 50 ms
    /// perturbation after 2 s (the paper's Fig. 2).
    Evaluate {
        #[command(flatten)]
        run: RunArgs,
    },
}

/// What every command that runs a model takes.
#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The model file (from `cpg train` or `cargo xtask train`).
    #[arg(long, short)]
    model: PathBuf,
    /// Seconds to generate [default: 30; evaluate: 900, the paper's long run].
    #[arg(long)]
    seconds: Option<f64>,
    /// Constant control values, comma-separated, one per control input (e.g. 1,0).
    #[arg(long, allow_hyphen_values = true)]
    control: Option<String>,
    /// Control values over time: a CSV whose header names the control inputs, one row per step (the last row is held).
    #[arg(long)]
    control_file: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, skeleton, rate_hz } => inspect::run(&file, skeleton.as_deref(), rate_hz),
        Command::Fk { amc, skeleton, output, rate_hz } => fk::run(&amc, &skeleton, &output, rate_hz),
        Command::Train { config, output } => train::run(&config, output.as_deref()),
        Command::Generate { run, format, skeleton, output } => generate::run(
            &run.model,
            run.seconds.unwrap_or(30.0),
            run.control.as_deref(),
            run.control_file.as_deref(),
            &format,
            skeleton.as_ref(),
            &output,
        ),
        Command::Hoap2 { run, rate_hz, urdf, map, output } => robot::run(robot::Args {
            model: &run.model,
            seconds: run.seconds.unwrap_or(30.0),
            control: run.control.as_deref(),
            control_file: run.control_file.as_deref(),
            rate_hz,
            urdf: urdf.as_ref(),
            map: map.as_ref(),
            output: &output,
        }),
        Command::Evaluate { run } => {
            evaluate::run(&run.model, run.seconds.unwrap_or(900.0), run.control.as_deref(), run.control_file.as_deref())
        }
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

//! `cpg`: learn rhythmic motion from motion capture and play it back as a
//! central pattern generator. This binary is glue: it parses arguments and
//! calls the library crates (`cpg-lab` for training, control schedules and
//! measures; `cpg-mocap`, `cpg-reservoir`, `cpg-robot` below it).

mod commands;
mod output;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Learn rhythmic human motion from motion capture and play it back as a CPG.
///
/// Typical use: `cpg train --config experiments/e1.toml`, then `cpg generate`,
/// `cpg hoap2` or `cpg evaluate` with the model it writes. The configuration
/// format is documented in docs/config.md.
#[derive(Debug, Parser)]
#[command(name = "cpg", version, about, long_about)]
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
    /// frame count, duration and per-channel minimum, maximum and mean. For a
    /// BVH file: its length unit, the hierarchy as bones, and the motion.
    Inspect {
        /// An .asf, .amc or .bvh file.
        file: PathBuf,
        /// The skeleton (.asf) that an .amc file belongs to.
        #[arg(long, short)]
        skeleton: Option<PathBuf>,
        #[command(flatten)]
        rec: RecordingArgs,
    },
    /// Forward kinematics: world positions of the root and every bone end, in mm.
    ///
    /// Writes a CSV with columns frame, time_s, then POINT_x_mm, POINT_y_mm,
    /// POINT_z_mm for the root and each bone (31 points for CMU skeletons);
    /// or, for -o NAME.npy, a float64 array of frames × points × 3 (the point
    /// names go to standard error). The skeleton frame is y-up.
    Fk {
        /// The motion: .amc (with --skeleton) or .bvh.
        motion: PathBuf,
        /// The skeleton (.asf) of an .amc motion.
        #[arg(long, short)]
        skeleton: Option<PathBuf>,
        /// Output file, .csv or .npy (`-`: standard output; a file is written
        /// atomically, a symlink's target likewise, a device or FIFO in place).
        #[arg(long, short)]
        output: PathBuf,
        #[command(flatten)]
        rec: RecordingArgs,
    },
    /// Retarget recorded walking to the HOAP-2: a walk it can balance.
    ///
    /// Measures the person's walk in the trials (stride period, time on the
    /// ground, the swing foot's lift and progress over the swing, the stride in
    /// leg lengths, the arms' swing) and plans the robot's: footsteps scaled to
    /// its leg, the stance foot flat, the zero-moment point (ZMP) inside the
    /// soles by ZMP preview control on a cart-table model (Kajita et al. 2003),
    /// the whole body's centre of mass on the planned path, the legs by inverse
    /// kinematics. Writes a CSV: time_s, the 25 joints (JOINT_rad), the trunk,
    /// the centre of mass, the multi-body ZMP, its margin to the support
    /// polygon (m, negative outside) and which feet carry the body; prints what
    /// was kept of the human and the ZMP margins (--report: the same as JSON).
    Retarget {
        /// Walking trials: .amc (with --skeleton) or .bvh.
        #[arg(long = "motion", short, required = true)]
        motions: Vec<PathBuf>,
        /// The skeleton (.asf) of .amc trials.
        #[arg(long, short)]
        skeleton: Option<PathBuf>,
        /// Which bones are the person's hips, knees, ankles, toes, shoulders, elbows and wrists:
        /// a profile file (docs/skeletons.md) for a skeleton whose bones are named otherwise
        /// [default: the built-in profile the skeleton fits, CMU's ASF or CMU's BVH conversion].
        #[arg(long)]
        profile: Option<PathBuf>,
        /// Steps to walk (the first and last half steps included).
        #[arg(long, default_value_t = 20)]
        steps: usize,
        /// The robot's step as a share of the human's step scaled to the robot's leg length.
        #[arg(long, default_value_t = 0.2)]
        step_scale: f64,
        /// The swing foot's lift as a share of the human's, scaled to the robot's leg length.
        #[arg(long, default_value_t = 0.4)]
        lift_scale: f64,
        /// The arms' swing as a share of the human's.
        #[arg(long, default_value_t = 1.0)]
        arm_scale: f64,
        /// The share of a step on both feet (0–0.9) [default: the human's, from the time both feet are down].
        #[arg(long)]
        double_support_share: Option<f64>,
        /// The swing foot's least lift as a share of a half-sine of its peak (0–1): a flat foot
        /// skimming the floor, as the person's heel does before touch-down, scuffs it.
        #[arg(long, default_value_t = 0.5)]
        clearance: f64,
        /// The stride rate as a multiple of the human's (0.5–2), steps as long.
        #[arg(long, default_value_t = 1.0)]
        tempo: f64,
        /// The planner's rate, Hz (20–2000).
        #[arg(long, default_value_t = 200.0)]
        plan_rate_hz: f64,
        /// Output CSV (`-`: standard output).
        #[arg(long, short)]
        output: PathBuf,
        /// Also write the measures as JSON here.
        #[arg(long)]
        report: Option<PathBuf>,
        #[command(flatten)]
        rec: RecordingArgs,
    },
    /// Train a CPG as a TOML configuration describes and write the model file.
    ///
    /// The file names the skeleton, the motion segments (each with its control
    /// values), the channels to learn (names, globs such as lfemur.*, or the
    /// groups legs, arms, hoap2), the reservoir (a preset plus overrides) and
    /// how the penalty is chosen. Every field is documented in docs/config.md;
    /// experiments/ holds the configurations of the report.
    Train {
        /// The configuration file.
        #[arg(long, short)]
        config: PathBuf,
        /// Write the model here instead of the path in the file's [output] section (`-`: standard output).
        #[arg(long, short)]
        output: Option<PathBuf>,
        /// Write the model even when its best validation score is worse than 1
        /// (a flat line at the mean scores 1); without it, training fails.
        #[arg(long)]
        allow_unstable: bool,
    },
    /// Run a trained CPG freely and write what it generates (CSV, NPY, AMC or BVH).
    ///
    /// CSV columns: time_s, then one per output channel in the training units
    /// (degrees for rotation channels, suffix _deg). NPY: a float64 array of
    /// steps × channels in the same units. AMC and BVH use the skeleton the
    /// model was trained from, with the channels it does not generate at 0 and
    /// the figure put on the floor; BVH lengths are in centimetres.
    Generate {
        #[command(flatten)]
        run: RunArgs,
        /// Seconds to generate.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        /// csv, npy, amc (any ASF/AMC viewer) or bvh (Blender and most
        /// animation tools) [default: from the extension, else csv].
        #[arg(long)]
        format: Option<String>,
        /// A skeleton (.asf) for --format amc or bvh instead of the one stored in the model.
        #[arg(long)]
        skeleton: Option<PathBuf>,
        /// Output file (`-`: standard output; a file is written atomically, a
        /// symlink's target likewise, a device or FIFO in place).
        #[arg(long, short)]
        output: PathBuf,
    },
    /// Run a trained CPG and write HOAP-2 joint commands a controller can stream.
    ///
    /// Channels are mapped to joints by a TSV map and clamped to the URDF's
    /// position limits; the trajectory is resampled to --rate-hz by a natural
    /// cubic spline (exactly seconds × rate rows) and kept within the URDF's
    /// velocity limits and the --acceleration-rad-s2 bound by a limiter that
    /// brakes in time. A table says, per joint, what each bound changed; a
    /// joint limited in more than 5 % of its frames is a warning (--strict: an
    /// error). Output: CSV (time_s, then every joint's angle in rad, then its
    /// velocity in rad/s, then its acceleration in rad/s²), NPY (a float64
    /// array of frames × joints × (angle, velocity, acceleration)), or a
    /// trajectory_msgs/JointTrajectory as JSON or YAML.
    Hoap2 {
        #[command(flatten)]
        run: RunArgs,
        /// Seconds to generate.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        /// Resample to this rate (e.g. 1000 for a 1 kHz servo loop) [default: the model's rate].
        #[arg(long)]
        rate_hz: Option<f64>,
        #[command(flatten)]
        robot: RobotArgs,
        /// Output file (`-`: standard output; a file is written atomically, a
        /// symlink's target likewise, a device or FIFO in place).
        #[arg(long, short)]
        output: PathBuf,
        /// csv (positions, velocities, accelerations), npy (the same as an
        /// array), json or yaml (a trajectory_msgs/JointTrajectory) [default:
        /// from the extension, else csv].
        #[arg(long)]
        format: Option<String>,
        /// Fail, writing nothing, when a joint is limited in more than 5 % of
        /// its frames (without it, a warning).
        #[arg(long)]
        strict: bool,
    },
    /// Run a CPG as a live control loop: controls in, one line of commands per tick.
    ///
    /// Control values may arrive at any time, one setting per line: numbers in
    /// the model's control order (`1, 0`) or name=value pairs (`u_run=1`).
    /// Each tick writes `time_s` and one value per channel (degrees), or with
    /// --robot one angle per joint (radians, within the URDF's position and
    /// velocity limits and the acceleration bound). The model steps at its own
    /// rate; ticks between its steps are interpolated. Ticks are paced by a
    /// monotonic clock; at the end the lateness of the ticks (mean, median,
    /// 99th percentile, worst) and the missed deadlines go to standard error.
    /// The loop allocates nothing.
    Stream {
        /// The model file.
        #[arg(long, short)]
        model: PathBuf,
        /// Ticks per second [default: the model's rate].
        #[arg(long)]
        rate_hz: Option<f64>,
        /// Stop after this long [default: when standard input closes].
        #[arg(long)]
        seconds: Option<f64>,
        /// The control values to start with [default: the first teacher's].
        #[arg(long)]
        control: Option<String>,
        /// Map onto a robot's joints: hoap2 (with --urdf and --map).
        #[arg(long)]
        robot: Option<String>,
        /// With --robot: the robot description, the map and the acceleration bound.
        #[command(flatten)]
        robot_args: RobotArgs,
        /// Run as fast as possible instead of in real time (for tests and files).
        #[arg(long)]
        no_pacing: bool,
    },
    /// Search for settings that keep the rhythm, starting from a configuration.
    ///
    /// A seeded random search: --budget candidates draw the settings the paper
    /// calls "not critical" (spectral radius, leak rate, feedback and input
    /// scaling), the noise on the fed-back teacher while harvesting, and how
    /// the penalty is validated (the paper's noisy NMSE or our orbit score,
    /// with or without the preference for larger penalties). Each candidate,
    /// and the starting configuration, is trained on --seeds reservoir seeds
    /// and judged by free runs of --seconds at every control setting it is
    /// taught, with mild state noise: passed when the period stays within 1 %,
    /// every amplitude within 5 %, the rhythm has converged and it is back on
    /// the orbit after the paper's push. Candidates run in parallel on all
    /// cores; the result does not depend on their number. Prints the best
    /// candidates with their spread across seeds and writes the best as a
    /// configuration `cpg train` reads.
    Tune {
        /// The starting configuration (its data, channels and controls are kept).
        #[arg(long, short)]
        config: PathBuf,
        /// Candidates drawn.
        #[arg(long, default_value_t = 24)]
        budget: usize,
        /// Reservoir seeds per candidate.
        #[arg(long, default_value_t = 3)]
        seeds: u64,
        /// Seconds of each judged free run.
        #[arg(long, default_value_t = 300.0)]
        seconds: f64,
        /// Seed of the search.
        #[arg(long, default_value_t = 1)]
        search_seed: u64,
        /// Where the best configuration is written [default: NAME-tuned.toml beside the configuration].
        #[arg(long, short)]
        output: Option<PathBuf>,
        /// Print every candidate as JSON instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Watch a CPG move: teacher, model and HOAP-2 side by side, as one HTML page or a GIF.
    ///
    /// With --model: the teacher cycle the model learnt (looped; with
    /// controls, the teacher of the control setting at each step), the
    /// model's free run, both as the skeleton stored in the model (channels
    /// it does not generate at 0, put on the floor), and the HOAP-2 from its
    /// URDF driven by that run through the channel map, within its position,
    /// velocity and acceleration limits (a channel the model does not generate
    /// counts as 0 there too; --no-robot leaves the robot out). With --motion
    /// (and --skeleton for AMC): a recording, AMC or BVH, and the HOAP-2
    /// driven by it. With --sim: a run of the HOAP-2 in MuJoCo as `cpg-sim -o`
    /// recorded it (the body where the physics put it, at 50 Hz).
    ///
    /// HTML (the default, or -o NAME.html): one self-contained file, no
    /// network, that plays at once, with play/pause, speed, a time slider and
    /// a view angle (drag a figure to turn it). GIF (-o NAME.gif or --format
    /// gif): the first --gif-seconds as a looping animation for papers.
    View {
        /// The model file [or --motion].
        #[arg(long, short)]
        model: Option<PathBuf>,
        /// Constant control values for the model, comma-separated (e.g. 1,0).
        #[arg(long, allow_hyphen_values = true)]
        control: Option<String>,
        /// Control values over time: a CSV whose header names the control inputs, one row per step.
        #[arg(long)]
        control_file: Option<PathBuf>,
        /// A recording to watch instead of a model: .amc (with --skeleton) or .bvh.
        #[arg(long)]
        motion: Option<PathBuf>,
        /// The skeleton (.asf) of an .amc recording.
        #[arg(long, short)]
        skeleton: Option<PathBuf>,
        /// A simulated run to watch instead: the JSON `cpg-sim -o` writes.
        #[arg(long)]
        sim: Option<PathBuf>,
        #[command(flatten)]
        rec: RecordingArgs,
        /// Seconds shown (a recording: at most its length).
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
        /// Leave the robot out.
        #[arg(long)]
        no_robot: bool,
        #[command(flatten)]
        robot: RobotArgs,
        /// Output file: .html or .gif (`-`: standard output; a file is written
        /// atomically, a symlink's target likewise, a device or FIFO in place).
        #[arg(long, short)]
        output: PathBuf,
        /// html or gif [default: from the extension, else html].
        #[arg(long)]
        format: Option<String>,
        /// Seconds of the GIF, from the start.
        #[arg(long, default_value_t = 6.0)]
        gif_seconds: f64,
        /// Frames per second of the GIF (its delays are in hundredths of a
        /// second, so 25 or 50 play exactly in real time).
        #[arg(long, default_value_t = 25.0)]
        fps: f64,
        /// The initial view angle about the vertical, degrees (0: from the
        /// front, 90: from the figure's left side).
        #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
        yaw_deg: f64,
    },
    /// Judge a trained CPG: a long free run and a push, against its teachers.
    ///
    /// For each control setting the model was taught (or the one given by
    /// --control), a free run of --seconds is judged against that setting's
    /// teacher: the period and every amplitude at the end (accurate: within
    /// 1 % and 5 %), whether the rhythm still changes between the first minute
    /// and the end (converged), and the recovery from the paper's push (the
    /// fed-back output held at the cycle's maximum + 2 σ for 50 ms after 2 s),
    /// against the teacher's orbit and against an unperturbed twin. The
    /// definitions are those of the report (cpg_lab::measure).
    Evaluate {
        #[command(flatten)]
        run: RunArgs,
        /// Seconds of free run (the paper's long run is 900).
        #[arg(long, default_value_t = 900.0)]
        seconds: f64,
        /// Print the measures as JSON.
        #[arg(long)]
        json: bool,
    },
}

/// How a recording is read.
#[derive(Debug, clap::Args)]
struct RecordingArgs {
    /// Capture rate in Hz [default: 120 for AMC, which does not store it
    /// (CMU uses 120); a BVH file's own frame time, which this must match].
    #[arg(long)]
    rate_hz: Option<f64>,
    /// Millimetres per length unit of a BVH file [default: inferred from the
    /// figure's size: metres, CMU units, inches, centimetres or millimetres].
    #[arg(long)]
    bvh_unit_mm: Option<f64>,
}

/// The robot a command drives: its URDF, the map onto its joints, and the acceleration bound.
#[derive(Debug, clap::Args)]
struct RobotArgs {
    /// The robot description: a URDF file, a robot's folder (its
    /// `robot.toml` naming its URDF, legs, feet and servos), or `hoap2` for
    /// the project's `assets/hoap2`, built into this program.
    #[arg(long, default_value = "hoap2")]
    urdf: PathBuf,
    /// The channel-to-joint map: a TSV file (joint, channel, sign, offset_deg;
    /// see docs/hoap2-map.md), or a built-in one: `hoap2` (the 22 leg and arm
    /// joints, `assets/hoap2/cmu35_to_hoap2.tsv`) or `legs` (the 12 leg joints).
    #[arg(long, default_value = "hoap2")]
    map: PathBuf,
    /// The acceleration bound every joint is kept within, rad/s² (the
    /// HOAP-2 documents give none; this default is ours).
    #[arg(long, default_value_t = cpg_robot::DEFAULT_ACCELERATION_RAD_S2)]
    acceleration_rad_s2: f64,
}

/// What every command that runs a model takes.
#[derive(Debug, clap::Args)]
struct RunArgs {
    /// The model file (from `cpg train` or `cargo xtask train`).
    #[arg(long, short)]
    model: PathBuf,
    /// Constant control values, comma-separated, one per control input (e.g. 1,0).
    #[arg(long, allow_hyphen_values = true)]
    control: Option<String>,
    /// Control values over time: a CSV whose header names the control inputs, one row per step (the last row is held).
    #[arg(long)]
    control_file: Option<PathBuf>,
}

/// The threads long work runs on: the machine's cores.
pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn main() -> ExitCode {
    output::install_signal_cleanup();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Inspect { file, skeleton, rec } => {
            commands::inspect(&file, skeleton.as_deref(), rec.rate_hz, rec.bvh_unit_mm)
        }
        Command::Fk { motion, skeleton, output, rec } => {
            commands::fk(&motion, skeleton.as_deref(), &output, rec.rate_hz, rec.bvh_unit_mm)
        }
        Command::Retarget {
            motions,
            skeleton,
            profile,
            steps,
            step_scale,
            lift_scale,
            arm_scale,
            double_support_share,
            clearance,
            tempo,
            plan_rate_hz,
            output,
            report,
            rec,
        } => commands::retarget(commands::Retarget {
            motions: &motions,
            skeleton: skeleton.as_deref(),
            profile: profile.as_deref(),
            options: cpg_lab::retarget::RetargetOptions {
                step_scale,
                lift_scale,
                arm_scale,
                double_support_share,
                clearance,
                steps,
                rate_hz: plan_rate_hz,
                tempo,
                ..Default::default()
            },
            output: &output,
            report: report.as_deref(),
            rate_hz: rec.rate_hz,
            bvh_unit_mm: rec.bvh_unit_mm,
        }),
        Command::Train { config, output, allow_unstable } => {
            commands::train(&config, output.as_deref(), allow_unstable)
        }
        Command::Generate { run, seconds, format, skeleton, output } => commands::generate(
            &run.model,
            seconds,
            run.control.as_deref(),
            run.control_file.as_deref(),
            format.as_deref(),
            skeleton.as_deref(),
            &output,
        ),
        Command::Hoap2 { run, seconds, rate_hz, robot, output, format, strict } => commands::hoap2(commands::Hoap2 {
            model: &run.model,
            seconds,
            control: run.control.as_deref(),
            control_file: run.control_file.as_deref(),
            rate_hz,
            urdf: &robot.urdf,
            map: &robot.map,
            output: &output,
            format: format.as_deref(),
            acceleration_rad_s2: robot.acceleration_rad_s2,
            strict,
        }),
        Command::Stream { model, rate_hz, seconds, control, robot, robot_args, no_pacing } => {
            match robot.as_deref() {
                None | Some("hoap2") => {}
                Some(other) => {
                    eprintln!("error: --robot {other}: the robot known is hoap2");
                    return ExitCode::from(2);
                }
            }
            let (urdf, map) = (robot_args.urdf.clone(), robot_args.map.clone());
            commands::stream(commands::Stream {
                model: &model,
                rate_hz,
                seconds,
                control: control.as_deref(),
                robot: robot.is_some().then_some((urdf.as_path(), map.as_path())),
                acceleration_rad_s2: robot_args.acceleration_rad_s2,
                pacing: !no_pacing,
            })
        }
        Command::Tune { config, budget, seeds, seconds, search_seed, output, json } => {
            let s = cpg_lab::tune::TuneSettings {
                budget,
                seeds,
                long_run_s: seconds,
                search_seed,
                threads: cores(),
                ..Default::default()
            };
            commands::tune(&config, &s, output.as_deref(), json)
        }
        Command::View {
            model,
            control,
            control_file,
            motion,
            skeleton,
            sim,
            rec,
            seconds,
            no_robot,
            robot,
            output,
            format,
            gif_seconds,
            fps,
            yaw_deg,
        } => commands::view(commands::View {
            model: model.as_deref(),
            control: control.as_deref(),
            control_file: control_file.as_deref(),
            motion: motion.as_deref(),
            skeleton: skeleton.as_deref(),
            sim: sim.as_deref(),
            motion_rate_hz: rec.rate_hz,
            bvh_unit_mm: rec.bvh_unit_mm,
            seconds,
            robot: !no_robot,
            urdf: &robot.urdf,
            map: &robot.map,
            acceleration_rad_s2: robot.acceleration_rad_s2,
            output: &output,
            format: format.as_deref(),
            gif_seconds,
            fps,
            yaw_deg,
        }),
        Command::Evaluate { run, seconds, json } => {
            commands::evaluate(&run.model, seconds, run.control.as_deref(), run.control_file.as_deref(), json)
        }
    };
    if let Some(line) = cpg_lab::memory::report_line() {
        eprintln!("{line}");
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`cpg generate -o - | head`) is not an error, at whatever depth the
            // library wrapped it.
            if broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {}", show(&message(&e)));
            ExitCode::from(2)
        }
    }
}

/// Whether `e` or one of its causes is a write to a pipe whose reader has gone.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

/// Text for the terminal: control characters that a file or joint name may
/// carry (ESC, NUL, a bare carriage return) are shown escaped (`\u{1b}`), so
/// a message cannot move the cursor, recolour the terminal or hide itself;
/// tabs and newlines stay.
pub fn show(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if c.is_control() && c != '\n' && c != '\t' {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    out
}

/// The error and its causes on one line, each cause once: a library error
/// whose message already quotes its source (`file: … (os error 2)`) is not
/// followed by that source again.
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

//! One function per subcommand.

mod fk;
mod inspect;
mod retarget;
mod stream;
mod view;

pub use fk::run as fk;
pub use inspect::run as inspect;
pub use retarget::{Retarget, run as retarget};
pub use stream::{Stream, run as stream};
pub use view::{View, run as view};

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use cpg_lab::format::Format;
use cpg_lab::run::Controls;
use cpg_lab::{Config, ControlSchedule};
use cpg_mocap::Skeleton;
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, Robot};

use crate::output::{check_writable, write_output};

/// A path without `.`/`..` components, for messages.
fn tidy(p: &Path) -> PathBuf {
    cpg_io::lexical(p)
}

/// Makes the directory of a config's `output.model` when it is missing.
fn create_model_dir(model: &Path) -> anyhow::Result<()> {
    let Some(dir) = model.parent().filter(|d| !d.as_os_str().is_empty()) else { return Ok(()) };
    if !dir.exists() {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating {}, the directory of the config's output.model", tidy(dir).display()))?;
        eprintln!("created {} (the directory of the config's output.model)", tidy(dir).display());
    }
    Ok(())
}

/// `cpg train`.
pub fn train(config: &Path, output: Option<&Path>, allow_unstable: bool) -> anyhow::Result<()> {
    let mut c = Config::load(config)?;
    if let Some(o) = output {
        c.output.model = o.to_owned();
    }
    let start = Instant::now();
    eprintln!("preparing the data of {} …", config.display());
    let p = cpg_lab::prepare::prepare(&c)?;
    eprintln!("data: {}", p.description);
    for n in &p.notes {
        eprintln!("note: {n}");
    }
    // Every setting is checked before the output: a bad config is reported
    // as such, whatever the state of the model's directory.
    let rc = cpg_lab::train::reservoir_config(&c, p.outputs.len())?;
    let s = cpg_lab::train::train_settings(&c)?;
    if output.is_none() {
        // The config's own `output.model` (the project's layout, such as
        // `models/`): its directory is made. A path typed with `-o` is not.
        create_model_dir(&c.output.model)?;
    }
    let dest = check_writable(&c.output.model)?;
    eprintln!(
        "training a {}-neuron reservoir (seed {}): {} samples, {} penalties × {} noise draws, score {} …",
        rc.n_neurons,
        c.reservoir.seed,
        p.data.train.len(p.outputs.len()),
        s.penalties.len(),
        s.n_noise_draws,
        c.training.score
    );
    let trained =
        cpg_lab::in_pool(crate::cores(), || cpg_lab::train::train_prepared(&c, &p, c.reservoir.seed, crate::cores()));
    let model = match trained {
        Err(cpg_lab::Error::Reservoir(e @ cpg_reservoir::Error::AllDiverged { .. })) => bail!(
            "{}: {e}: the reservoir does not hold a rhythm with these settings (try `cpg tune --config {}`)",
            config.display(),
            config.display()
        ),
        other => other?,
    };
    let pv = &model.provenance;
    let best = pv.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min);
    if let Some(why) = cpg_lab::train::unstable(&model) {
        let msg = format!("{}: {why}", config.display());
        if !allow_unstable {
            bail!(
                "{msg}. Nothing was written; `--allow-unstable` writes the model anyway, `cpg tune --config {}` searches for settings that work",
                config.display()
            );
        }
        eprintln!("warning: {}; written anyway (--allow-unstable)", crate::show(&msg.to_string()));
    }
    write_output(&c.output.model, |w| Ok(w.write_all(&model.to_bytes()?)?))?;
    if cpg_lab::train::penalty_at_edge(&model) {
        eprintln!(
            "warning: the chosen penalty {:.2e} is at the edge of the grid; the best may lie beyond it",
            pv.chosen_penalty
        );
    }
    eprintln!(
        "trained in {:.2} s: penalty {:.2e} (validation score {best:.4}, one-step training NMSE {:.2e}) → {}",
        start.elapsed().as_secs_f64(),
        pv.chosen_penalty,
        pv.train_nmse,
        match &dest {
            crate::output::Destination::Stdout => "standard output".into(),
            _ => tidy(&c.output.model).display().to_string(),
        }
    );
    Ok(())
}

/// The control schedule of `--control` / `--control-file` (one of them, or
/// neither for a model without control inputs).
fn schedule(m: &TrainedCpg, values: Option<&str>, file: Option<&Path>) -> anyhow::Result<ControlSchedule> {
    let source = match (values, file) {
        (Some(_), Some(_)) => bail!("give either --control or --control-file, not both"),
        (Some(v), None) => Controls::Values(v),
        (None, Some(f)) => Controls::File(f),
        (None, None) => Controls::Unset { strict: true },
    };
    Ok(cpg_lab::run::schedule(m, source)?)
}

/// The steps of `--seconds` at `rate` Hz with `d` channels, bounded.
fn steps(seconds: f64, rate: f64, d: usize) -> anyhow::Result<usize> {
    Ok(cpg_lab::run::steps("--seconds", seconds, rate, d)?)
}

/// A free run of `m` in its units, with a warning for each channel that
/// leaves the range it was taught.
fn run_units(m: &TrainedCpg, controls: &ControlSchedule, n: usize) -> anyhow::Result<cpg_lab::run::Run> {
    let opts = cpg_lab::run::RunOptions { threads: cpg_lab::run::default_threads(m), cancel: None };
    let run = cpg_lab::run::generate(m, controls, n, opts)?.context("the run was cancelled")?;
    for w in cpg_lab::run::range_warnings(m, &run.values) {
        eprintln!("warning: {w}");
    }
    Ok(run)
}

/// `cpg generate`.
pub fn generate(
    model: &Path,
    seconds: f64,
    control: Option<&str>,
    control_file: Option<&Path>,
    format: Option<&str>,
    skeleton: Option<&Path>,
    output: &Path,
) -> anyhow::Result<()> {
    let format = Format::choose(format, output, &Format::RUN, Format::Csv)?;
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    let d = m.outputs.len();
    let n = steps(seconds, rate, d)?;
    let dest = check_writable(output)?;
    let controls = schedule(&m, control, control_file)?;
    let sk = match format {
        Format::Amc | Format::Bvh => Some(match (skeleton, &m.skeleton_asf) {
            (Some(p), _) => Skeleton::from_file(p)?,
            (None, Some(text)) => {
                cpg_mocap::parse_asf(&format!("the skeleton stored in {}", model.display()), text.as_bytes())
                    .map_err(cpg_mocap::Error::from)?
            }
            (None, None) => {
                bail!("{} stores no skeleton (it was trained from arrays): give --skeleton FILE.asf", model.display())
            }
        }),
        _ => None,
    };
    let run = run_units(&m, &controls, n)?;
    cpg_lab::format::write_run(output, format, &m, &run, sk.as_ref())?;
    if format == Format::Npy {
        let names: Vec<&str> = m.outputs.iter().map(|o| o.unit_name()).collect();
        eprintln!("columns: {} (degrees for rotation channels)", names.join(", "));
    }
    eprintln!("wrote {n} frames ({seconds} s at {rate} Hz) of {d} channel(s) as {format} to {}", dest.describe());
    Ok(())
}

/// `cpg hoap2`'s arguments.
pub struct Hoap2<'a> {
    pub model: &'a Path,
    pub seconds: f64,
    pub control: Option<&'a str>,
    pub control_file: Option<&'a Path>,
    pub rate_hz: Option<f64>,
    pub urdf: &'a Path,
    pub map: &'a Path,
    pub output: &'a Path,
    pub format: Option<&'a str>,
    pub acceleration_rad_s2: f64,
    pub strict: bool,
}

/// `cpg hoap2`.
pub fn hoap2(a: Hoap2<'_>) -> anyhow::Result<()> {
    let m = TrainedCpg::load(a.model)?;
    let robot = Robot::from_spec(a.urdf)?;
    let map = ChannelMap::from_spec(a.map)?;
    let rate = m.provenance.sample_rate_hz;
    // The sizes are checked before anything runs.
    steps(a.seconds, rate, m.outputs.len())?;
    cpg_robot::JointTrajectory::check_rate(a.rate_hz.unwrap_or(rate), a.seconds, map.entries.len())?;
    let format = Format::choose(a.format, a.output, &Format::TRAJECTORY, Format::Csv)?;
    let dest = check_writable(a.output)?;
    let controls = schedule(&m, a.control, a.control_file)?;
    let target = cpg_lab::stream::RobotTarget { robot: &robot, map: &map, acceleration_rad_s2: a.acceleration_rad_s2 };
    let t = cpg_lab::stream::joint_trajectory(&m, &controls, a.seconds, a.rate_hz, target)?;
    eprintln!(
        "{:<14} {:>9} {:>10} {:>10} {:>10} {:>10} {:>10} {:>8} {:>8} {:>8}",
        "joint", "position", "max excess", "min (deg)", "max (deg)", "speed asked", "acc asked", "speed", "acc", "lag"
    );
    let pct = |k: usize, n: usize| 100.0 * k as f64 / n.max(1) as f64;
    for c in &t.clamps.joints {
        eprintln!(
            "{:<14} {:>8.1}% {:>9.2}° {:>10.1} {:>10.1} {:>8.2}/s {:>8.1}/s² {:>7.1}% {:>7.1}% {:>7.2}°",
            c.joint,
            pct(c.n_clamped, c.n_frames),
            c.max_excess_rad.to_degrees(),
            c.min_rad.to_degrees(),
            c.max_rad.to_degrees(),
            c.max_velocity_rad_s,
            c.max_acceleration_rad_s2,
            pct(c.n_velocity_limited, c.n_frames),
            pct(c.n_acceleration_limited, c.n_frames),
            c.max_lag_rad.to_degrees()
        );
    }
    eprintln!(
        "(position: frames clamped to the URDF range; speed and acc asked: the largest before limiting, rad; speed, acc: frames held back by the URDF's velocity limit and the {} rad/s² acceleration bound; lag: the largest distance from the angle asked)",
        a.acceleration_rad_s2
    );
    let over = t.clamps.over(cpg_robot::WARN_LIMITED_SHARE);
    if !over.is_empty() {
        let list: Vec<String> =
            over.iter().map(|c| format!("{} ({:.0} %)", c.joint, 100.0 * c.limited_share())).collect();
        let msg = format!(
            "{} joint(s) limited in more than {:.0} % of frames: {}",
            over.len(),
            100.0 * cpg_robot::WARN_LIMITED_SHARE,
            list.join(", ")
        );
        if a.strict {
            bail!("{msg}; nothing was written (--strict)");
        }
        eprintln!("warning: {} (--strict makes this an error)", crate::show(&msg.to_string()));
    }
    cpg_lab::format::write_trajectory(a.output, format, &t)?;
    if format == Format::Npy {
        eprintln!(
            "npy: frames × joints × (angle rad, velocity rad/s, acceleration rad/s²); joints: {}",
            t.joints.join(", ")
        );
    }
    eprintln!(
        "wrote {} frames ({} s at {} Hz) of {} HOAP-2 joints ({format}: positions rad, velocities rad/s, accelerations rad/s²) to {}",
        t.n_frames(),
        a.seconds,
        t.rate_hz,
        t.joints.len(),
        dest.describe()
    );
    Ok(())
}

/// `cpg evaluate`.
pub fn evaluate(
    model: &Path,
    seconds: f64,
    control: Option<&str>,
    control_file: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    let d = m.outputs.len();
    let n = steps(seconds, rate, d)?;
    let given = match (control, control_file) {
        (None, None) => None,
        _ => Some(schedule(&m, control, control_file)?),
    };
    let out =
        cpg_lab::measure::judge(&m, n, given.as_ref(), crate::cores()).with_context(|| model.display().to_string())?;
    if json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("{}: {n} steps ({seconds} s) of free run per control setting", model.display());
    for j in &out {
        let st = &j.stability;
        let ctl = if j.controls.is_empty() {
            String::new()
        } else {
            format!(" at controls [{}]", j.controls.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", "))
        };
        if let Some(hold) = &st.posture {
            println!("teacher '{}'{ctl}: a posture", j.teacher);
            print_posture(&m, hold, st);
        } else {
            print_rhythm(&m, &j.teacher, &ctl, st);
        }
        let r = &j.recovery;
        let s = |x: Option<f64>| x.map_or("never".to_owned(), |v| format!("after {v:.2} s"));
        println!(
            "  push (output held at the cycle's maximum + 2 σ for 50 ms at 2 s): back on the teacher's orbit {}, on the unperturbed twin {}, phase shift {:+.3} cycles",
            s(r.orbit_s),
            s(r.twin_s),
            r.phase_shift_cycles
        );
    }
    Ok(())
}

/// What `cpg evaluate` prints of a posture held.
fn print_posture(
    m: &cpg_reservoir::TrainedCpg,
    hold: &cpg_lab::measure::PostureHold,
    st: &cpg_lab::measure::Stability,
) {
    for (k, o) in m.outputs.iter().enumerate() {
        println!(
            "  {}: at the end up to {:.3} from the posture, half range {:.3} (the channel's units)",
            o.name, hold.deviation[k], hold.swing[k]
        );
    }
    let tol = cpg_lab::measure::POSTURE_TOLERANCE;
    println!(
        "  still (every channel's half range at the end below {}): {}",
        cpg_lab::measure::STILL_SWING,
        if st.converged { "yes" } else { "no" }
    );
    println!(
        "  held (every channel within {tol} of the posture at the end): {}",
        if st.accurate { "yes" } else { "no" }
    );
}

/// What `cpg evaluate` prints of a rhythm.
fn print_rhythm(m: &cpg_reservoir::TrainedCpg, teacher: &str, ctl: &str, st: &cpg_lab::measure::Stability) {
    println!("teacher '{teacher}'{ctl}: period {:.2} steps", st.teacher.period_steps);
    match (st.end.period_steps, st.decayed_at_s) {
        (_, Some(t)) => println!("  decayed at {t:.1} s: no rhythm at the end"),
        (Some(pe), None) => println!(
            "  period at the end: {pe:.2} steps ({:+.2} % of the teacher's)",
            100.0 * (pe / st.teacher.period_steps - 1.0)
        ),
        (None, None) => println!("  no period found at the end"),
    }
    let still = st.teacher.still();
    for (k, o) in m.outputs.iter().enumerate() {
        if still[k] {
            println!(
                "  {}: still in the teacher; half range at the end {:.2e} (its own units; at most {} to match)",
                o.name,
                st.end.amplitude[k],
                cpg_lab::measure::STILL_SWING
            );
            continue;
        }
        println!(
            "  {}: half range at the end {:.3} (normalised units; teacher {:.3}, {:+.1} %)",
            o.name,
            st.end.amplitude[k],
            st.teacher.amplitude[k],
            100.0 * (st.amplitude_ratio(k) - 1.0)
        );
    }
    println!("  phase-aligned NMSE of the last window: {:.4}", st.end.aligned_nmse);
    println!(
        "  converged (the rhythm no longer changes after the first minute): {}",
        if st.converged { "yes" } else { "no" }
    );
    println!(
        "  {}: {}",
        cpg_lab::experiment::stability::RULE.replacen(": ", " (", 1) + ")",
        if st.accurate { "yes" } else { "no" }
    );
}

/// A progress bar on standard error.
struct Bar(std::sync::Mutex<Option<indicatif::ProgressBar>>);

impl cpg_lab::experiment::Progress for Bar {
    fn start(&self, label: &str, total: u64) {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed} (eta {eta})")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.set_message(label.to_owned());
        b.enable_steady_tick(std::time::Duration::from_millis(250));
        *self.0.lock().unwrap_or_else(|e| e.into_inner()) = Some(b);
    }
    fn tick(&self) {
        if let Some(b) = self.0.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(1);
        }
    }
    fn finish(&self) {
        if let Some(b) = self.0.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

/// `cpg tune`.
pub fn tune(config: &Path, s: &cpg_lab::tune::TuneSettings, output: Option<&Path>, json: bool) -> anyhow::Result<()> {
    let base = Config::load(config)?;
    let stem = config.file_stem().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| "config".into());
    let out = output.map(Path::to_owned).unwrap_or_else(|| config.with_file_name(format!("{stem}-tuned.toml")));
    let dest = crate::output::check_writable(&out)?;
    // The configuration may go to standard output: the table then goes to standard error.
    let mut report: Box<dyn std::io::Write> = if dest == crate::output::Destination::Stdout {
        Box::new(std::io::stderr())
    } else {
        Box::new(std::io::stdout())
    };
    let start = Instant::now();
    eprintln!(
        "tuning {}: {} candidates and the starting configuration, {} seed(s) each, judged over {} s …",
        config.display(),
        s.budget,
        s.seeds,
        s.long_run_s
    );
    let r = cpg_lab::tune::tune(&base, s, &Bar(std::sync::Mutex::new(None)))?;
    let minutes = start.elapsed().as_secs_f64() / 60.0;
    if json {
        writeln!(report, "{}", serde_json::to_string_pretty(&r)?)?;
    } else {
        writeln!(
            report,
            "{:>4} {:>6} {:>9} {:>6} {:>8} {:>8} {:>7} {:>6} {:>7}  {:<20}",
            "cand", "passed", "cost", "range", "radius", "leak", "fb", "tnoise", "prefer", "validation"
        )?;
        for c in r.candidates.iter().take(8) {
            let k = &c.knobs;
            let score = if k.score == cpg_lab::config::ScoreKind::Nmse {
                format!("nmse (noise {:.0e})", k.noise_variance)
            } else {
                "orbit".into()
            };
            writeln!(
                report,
                "{:>4} {:>3}/{:<2} {:>9.2} {:>6.2} {:>8.3} {:>8.3} {:>7.3} {:>6.3} {:>7} {:<20}",
                if c.index == 0 { "base".to_owned() } else { c.index.to_string() },
                c.passed,
                c.seeds.len(),
                c.mean_cost,
                c.cost_range.1 - c.cost_range.0,
                k.spectral_radius,
                k.leak_rate,
                k.feedback_scale,
                k.teacher_noise,
                k.prefer_larger_within,
                score
            )?;
        }
    }
    let best = r.best().context("no candidate")?;
    let mut c = best.config.clone();
    let model = c.output.model.clone();
    let mstem = model.file_stem().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| "model".into());
    c.output.model = model.with_file_name(format!("{mstem}-tuned.cpg"));
    let dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let text = format!(
        "# Written by `cpg tune` from {} (candidate {}, {} of {} seeds passed, mean cost {:.2}; search seed {}, {} candidates).\n# Train it with: cpg train --config {}\n\n{}",
        config.display(),
        if best.index == 0 { "0, the starting configuration".to_owned() } else { best.index.to_string() },
        best.passed,
        best.seeds.len(),
        best.mean_cost,
        s.search_seed,
        s.budget,
        out.display(),
        c.to_toml(dir)?
    );
    write_output(&out, |w| Ok(w.write_all(text.as_bytes())?))?;
    eprintln!(
        "{} candidates in {:.1} min ({:.1} per minute); the best passed on {} of {} seeds → {}",
        r.candidates.len(),
        minutes,
        r.candidates.len() as f64 / minutes.max(1e-9),
        best.passed,
        best.seeds.len(),
        if dest == crate::output::Destination::Stdout {
            "standard output".into()
        } else {
            tidy(&out).display().to_string()
        }
    );
    Ok(())
}

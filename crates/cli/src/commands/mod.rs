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
use cpg_hoap2::{ChannelMap, Robot};
use cpg_lab::measure::free_run;
use cpg_lab::{Config, ControlSchedule};
use cpg_mocap::{Channel, Motion, Skeleton, write_amc};
use cpg_reservoir::TrainedCpg;

use crate::output::{check_writable, write_output};

/// A path without `.`/`..` components, for messages.
fn tidy(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
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

/// The worst validation score `cpg train` accepts without `--allow-unstable`.
const UNSTABLE_SCORE: f64 = 1.0;

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
    let model = match cpg_lab::train::train_prepared(&c, &p, c.reservoir.seed) {
        Err(cpg_lab::Error::Reservoir(e @ cpg_reservoir::Error::AllDiverged { .. })) => bail!(
            "{}: {e}: the reservoir does not hold a rhythm with these settings (try `cpg tune --config {}`)",
            config.display(),
            config.display()
        ),
        other => other?,
    };
    let pv = &model.provenance;
    let best = pv.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min);
    if best.is_nan() || best > UNSTABLE_SCORE {
        let msg = format!(
            "{}: the best validation score is {best:.4} (penalty {:.2e}), worse than {UNSTABLE_SCORE} (a flat line at the mean scores 1): the free run does not follow the teacher",
            config.display(),
            pv.chosen_penalty
        );
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

fn schedule(m: &TrainedCpg, values: Option<&str>, file: Option<&Path>) -> anyhow::Result<ControlSchedule> {
    match (values, file) {
        (Some(_), Some(_)) => bail!("give either --control or --control-file, not both"),
        (Some(v), None) => Ok(ControlSchedule::parse_values(v, &m.controls)?),
        (None, Some(f)) => {
            let bytes = cpg_mocap::read_bounded(f, cpg_mocap::MAX_INPUT_BYTES)?;
            let text = String::from_utf8(bytes).map_err(|e| {
                anyhow::anyhow!(
                    "{}: not UTF-8 text (invalid byte at offset {})",
                    f.display(),
                    e.utf8_error().valid_up_to()
                )
            })?;
            Ok(ControlSchedule::parse_csv(&text, f, &m.controls)?)
        }
        (None, None) if m.controls.is_empty() => Ok(ControlSchedule::none()),
        (None, None) => {
            bail!("the model has control inputs [{}]: give --control or --control-file", m.controls.join(", "))
        }
    }
}

/// A number as a message shows it: plain when of ordinary size, else in `e` notation.
fn short_number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// Longest run one command makes, seconds (a day).
const MAX_SECONDS: f64 = 86_400.0;
/// Most values one run holds in memory (1 GiB of f64).
const MAX_VALUES: usize = 1 << 27;

/// Checks `--seconds`: above 0 and at most [`MAX_SECONDS`].
fn check_seconds(seconds: f64) -> anyhow::Result<()> {
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= MAX_SECONDS) {
        bail!("--seconds {}: expected a duration above 0 and at most {MAX_SECONDS} (one day)", short_number(seconds));
    }
    Ok(())
}

/// The steps of a run of `seconds` at `rate` Hz with `d` channels, bounded.
fn steps(seconds: f64, rate: f64, d: usize) -> anyhow::Result<usize> {
    check_seconds(seconds)?;
    let n = (seconds * rate).round() as usize;
    if n == 0 {
        bail!("--seconds {seconds} at {rate} Hz is less than one step");
    }
    if n.saturating_mul(d.max(1)) > MAX_VALUES {
        bail!(
            "--seconds {seconds}: {n} steps × {d} channels would hold {:.1} GiB; at most {MAX_VALUES} values (1 GiB) per run",
            (n as f64 * d as f64 * 8.0) / (1u64 << 30) as f64
        );
    }
    Ok(n)
}

/// The model's outputs in their own units, frame-major.
fn run_units(m: &TrainedCpg, controls: &ControlSchedule, n: usize) -> anyhow::Result<Vec<f64>> {
    let d = m.outputs.len();
    let mut y = free_run(m, controls, n, None)?;
    for (k, v) in y.iter_mut().enumerate() {
        let o = &m.outputs[k % d];
        *v = *v * o.std + o.mean;
    }
    warn_out_of_range(m, &y);
    Ok(y)
}

/// How far beyond the teachers' range (as a share of its span) an output may
/// go before `generate` and `hoap2` warn.
const RANGE_MARGIN: f64 = 0.5;

/// Warns, once per channel, when the output `y` (in the model's units,
/// frame-major) leaves the range of the teacher cycles by more than
/// [`RANGE_MARGIN`] of that range: a sign of an unstable model.
fn warn_out_of_range(m: &TrainedCpg, y: &[f64]) {
    let d = m.outputs.len();
    for (k, o) in m.outputs.iter().enumerate() {
        let taught = m.teachers.iter().flat_map(|t| t.cycle.iter().skip(k).step_by(d)).map(|z| z * o.std + o.mean);
        let (lo, hi) = taught.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        let (min, max) =
            y.iter().skip(k).step_by(d).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let margin = RANGE_MARGIN * (hi - lo);
        if min < lo - margin || max > hi + margin {
            eprintln!(
                "warning: {} spans {min:.1} to {max:.1}{u}, beyond the training data's {lo:.1} to {hi:.1}{u} by more than {:.0} % of that range: the model may be unstable (`cpg evaluate` measures it)",
                o.name,
                RANGE_MARGIN * 100.0,
                u = unit_suffix(&o.name).replace('_', " "),
            );
        }
    }
}

fn unit_suffix(name: &str) -> &'static str {
    if name.ends_with(".rx") || name.ends_with(".ry") || name.ends_with(".rz") { "_deg" } else { "" }
}

/// Extensions that name an output format, and the format each names.
const FORMAT_EXTENSIONS: [(&str, &str); 10] = [
    ("csv", "csv"),
    ("npy", "npy"),
    ("amc", "amc"),
    ("bvh", "bvh"),
    ("json", "json"),
    ("yaml", "yaml"),
    ("yml", "yaml"),
    ("html", "html"),
    ("htm", "html"),
    ("gif", "gif"),
];

/// The format an output is written in: `--format` when given, else the
/// output's extension when it names one of `known`, else `default`. An
/// extension that names another format is an error (`-o walk.gif` for CSV
/// would give a file no GIF reader opens); other extensions are the user's.
pub(crate) fn output_format(
    format: Option<&str>,
    output: &Path,
    known: &[&str],
    default: &str,
) -> anyhow::Result<String> {
    let named = output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .and_then(|e| FORMAT_EXTENSIONS.iter().find(|(x, _)| *x == e).map(|(x, f)| ((*x).to_owned(), *f)));
    let f = match format {
        Some(f) => f.to_ascii_lowercase(),
        None => named.as_ref().map(|(_, f)| (*f).to_owned()).unwrap_or_else(|| default.to_owned()),
    };
    if !known.contains(&f.as_str()) {
        match (format, &named) {
            (None, Some((ext, _))) => bail!(
                "{}: .{ext} names a format this command does not write; it writes {} (give --format or another extension)",
                output.display(),
                known.join(", ")
            ),
            _ => bail!("--format {f}: expected {}", known.join(", ")),
        }
    }
    if let Some((ext, g)) = &named
        && *g != f
    {
        bail!(
            "{}: the extension .{ext} is not the format written ({f}); name the file .{f} or give --format {g}",
            output.display()
        );
    }
    Ok(f)
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
    let format = output_format(format, output, &["csv", "npy", "amc", "bvh"], "csv")?;
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    let d = m.outputs.len();
    let n = steps(seconds, rate, d)?;
    let dest = check_writable(output)?;
    let controls = schedule(&m, control, control_file)?;
    match format.as_str() {
        "csv" => {
            let y = run_units(&m, &controls, n)?;
            write_output(output, |w| {
                write!(w, "time_s")?;
                for o in &m.outputs {
                    write!(w, ",{}{}", o.name, unit_suffix(&o.name))?;
                }
                writeln!(w)?;
                for k in 0..n {
                    write!(w, "{:.6}", k as f64 / rate)?;
                    for v in &y[k * d..(k + 1) * d] {
                        write!(w, ",{v:.6}")?;
                    }
                    writeln!(w)?;
                }
                Ok(())
            })?
        }
        "npy" => {
            let y = run_units(&m, &controls, n)?;
            write_output(output, |w| crate::npy::write_npy(w, &[n, d], y.iter().copied()))?;
            let names: Vec<&str> = m.outputs.iter().map(|o| o.name.as_str()).collect();
            eprintln!("columns: {} (degrees for rotation channels)", names.join(", "));
        }
        _ => {
            let sk = match (skeleton, &m.skeleton_asf) {
                (Some(p), _) => Skeleton::from_file(p)?,
                (None, Some(text)) => {
                    cpg_mocap::parse_asf(&format!("the skeleton stored in {}", model.display()), text.as_bytes())
                        .map_err(cpg_mocap::Error::from)?
                }
                (None, None) => bail!(
                    "{} stores no skeleton (it was trained from arrays): give --skeleton FILE.asf",
                    model.display()
                ),
            };
            let channels: Vec<Channel> = m
                .outputs
                .iter()
                .map(|o| {
                    Channel::parse(&o.name)
                        .with_context(|| format!("output '{}' is not a mocap channel (bone.dof)", o.name))
                })
                .collect::<anyhow::Result<_>>()?;
            let y = run_units(&m, &controls, n)?;
            // Every channel, and a root on the floor when the model generates none.
            let motion = sk.ground(&Motion::new(channels, y, rate)?)?;
            let text = if format == "bvh" { cpg_mocap::write_bvh(&sk, &motion)? } else { write_amc(&sk, &motion)? };
            write_output(output, |w| Ok(w.write_all(text.as_bytes())?))?;
        }
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
    cpg_hoap2::JointTrajectory::check_rate(a.rate_hz.unwrap_or(rate), a.seconds, map.entries.len())?;
    let format = output_format(a.format, a.output, &["csv", "npy", "json", "yaml"], "csv")?;
    let dest = check_writable(a.output)?;
    let controls = schedule(&m, a.control, a.control_file)?;
    let target = cpg_lab::stream::RobotTarget { robot: &robot, map: &map, acceleration_rad_s2: a.acceleration_rad_s2 };
    let t = cpg_lab::stream::joint_trajectory(&m, &controls, a.seconds, a.rate_hz, target)?;
    let text = match format.as_str() {
        "json" => t.to_ros_json(),
        "yaml" => t.to_ros_yaml(),
        "npy" => String::new(),
        _ => t.to_csv(),
    };
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
    let over = t.clamps.over(cpg_hoap2::WARN_LIMITED_SHARE);
    if !over.is_empty() {
        let list: Vec<String> =
            over.iter().map(|c| format!("{} ({:.0} %)", c.joint, 100.0 * c.limited_share())).collect();
        let msg = format!(
            "{} joint(s) limited in more than {:.0} % of frames: {}",
            over.len(),
            100.0 * cpg_hoap2::WARN_LIMITED_SHARE,
            list.join(", ")
        );
        if a.strict {
            bail!("{msg}; nothing was written (--strict)");
        }
        eprintln!("warning: {} (--strict makes this an error)", crate::show(&msg.to_string()));
    }
    if format == "npy" {
        // frames × joints × (angle, velocity, acceleration).
        let values =
            (0..t.values_rad.len()).flat_map(|k| [t.values_rad[k], t.velocities_rad_s[k], t.accelerations_rad_s2[k]]);
        write_output(a.output, |w| crate::npy::write_npy(w, &[t.n_frames(), t.joints.len(), 3], values))?;
        eprintln!(
            "npy: frames × joints × (angle rad, velocity rad/s, acceleration rad/s²); joints: {}",
            t.joints.join(", ")
        );
    } else {
        write_output(a.output, |w| Ok(w.write_all(text.as_bytes())?))?;
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
    let out = cpg_lab::measure::judge(&m, n, given.as_ref()).with_context(|| model.display().to_string())?;
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
        println!("teacher '{}'{ctl}: period {:.2} steps", j.teacher, st.teacher.period_steps);
        match (st.end.period_steps, st.decayed_at_s) {
            (_, Some(t)) => println!("  decayed at {t:.1} s: no rhythm at the end"),
            (Some(pe), None) => println!(
                "  period at the end: {pe:.2} steps ({:+.2} % of the teacher's)",
                100.0 * (pe / st.teacher.period_steps - 1.0)
            ),
            (None, None) => println!("  no period found at the end"),
        }
        for (k, o) in m.outputs.iter().enumerate() {
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
            let score =
                if k.score == "nmse" { format!("nmse (noise {:.0e})", k.noise_variance) } else { "orbit".into() };
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

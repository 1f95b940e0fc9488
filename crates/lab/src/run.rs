//! One model run, the way every caller makes it: `cpg generate`, `cpg hoap2`
//! and `cpg view`, the Python package's `Model.generate`, `Model.hoap2` and
//! `Model.evaluate`, and the report. Its length is bounded here (seconds or
//! steps), its control inputs come from constants, a table file, an array or
//! a schedule, and its output is in the channels' own units.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use cpg_reservoir::{Generator, TrainedCpg};

use crate::error::{Error, Result};
use crate::measure::{RunSpec, free_runs_on};
use crate::schedule::ControlSchedule;

/// The longest run one call makes, seconds (a day).
pub const MAX_SECONDS: f64 = 86_400.0;
/// The most values one run holds in memory (1 GiB of f64).
pub const MAX_VALUES: usize = 1 << 27;

/// Steps between checks of a cancel flag in a run on one thread.
const CHECK_EVERY_STEPS: usize = 4096;

/// A number as a message shows it: plain when of ordinary size, else in `e` notation.
fn short_number(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// Checks a duration: above 0 and at most [`MAX_SECONDS`]. `name` is the
/// argument as the caller's user wrote it (`--seconds`, `seconds`).
pub fn check_seconds(name: &str, seconds: f64) -> Result<()> {
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= MAX_SECONDS) {
        return Err(Error::Bound(format!(
            "{name} {}: expected a duration above 0 and at most {MAX_SECONDS} (one day)",
            short_number(seconds)
        )));
    }
    Ok(())
}

/// The steps of a run of `seconds` at `rate_hz` with `d` channels, within
/// [`MAX_SECONDS`] and [`MAX_VALUES`]; `name` as in [`check_seconds`].
pub fn steps(name: &str, seconds: f64, rate_hz: f64, d: usize) -> Result<usize> {
    check_seconds(name, seconds)?;
    let n = (seconds * rate_hz).round() as usize;
    if n == 0 {
        return Err(Error::Bound(format!("{name} {seconds} at {rate_hz} Hz is less than one step")));
    }
    if n.saturating_mul(d.max(1)) > MAX_VALUES {
        return Err(Error::Bound(format!(
            "{name} {seconds}: {n} steps × {d} channels would hold {:.1} GiB; at most {MAX_VALUES} values (1 GiB) per run",
            (n as f64 * d as f64 * 8.0) / (1u64 << 30) as f64
        )));
    }
    Ok(n)
}

/// The most steps a run of a model with `d` channels may take.
pub fn max_steps(d: usize) -> usize {
    (MAX_VALUES / d.max(1)).max(1)
}

/// Where a run's control values come from.
#[derive(Debug, Clone, Copy)]
pub enum Controls<'a> {
    /// None given: a model without control inputs runs without; a model with
    /// them is an error (`strict`) or holds its first teacher's setting.
    Unset {
        /// Refuse a model that has control inputs.
        strict: bool,
    },
    /// Values as typed: `1, 0` (every input in order).
    Values(&'a str),
    /// A CSV file whose header names the inputs, one row per step.
    File(&'a Path),
    /// A schedule made by the caller (an array, knots).
    Schedule(&'a ControlSchedule),
}

/// The control schedule of a run of `m` from `source`, checked against the
/// model's control inputs.
pub fn schedule(m: &TrainedCpg, source: Controls<'_>) -> Result<ControlSchedule> {
    let u = m.controls.len();
    let s = match source {
        Controls::Unset { .. } if u == 0 => ControlSchedule::none(),
        Controls::Unset { strict: true } => {
            return Err(Error::Control(format!(
                "the model has control inputs [{}]: give --control or --control-file",
                m.controls.join(", ")
            )));
        }
        Controls::Unset { strict: false } => {
            ControlSchedule::Constant(m.teachers.first().map_or_else(|| vec![0.0; u], |t| t.controls.clone()))
        }
        Controls::Values(v) => ControlSchedule::parse_values(v, &m.controls)?,
        Controls::File(f) => {
            let bytes = cpg_mocap::read_bounded(f, cpg_mocap::MAX_INPUT_BYTES)?;
            let text = String::from_utf8(bytes).map_err(|e| {
                Error::data_file(
                    f,
                    None,
                    format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()),
                )
            })?;
            ControlSchedule::parse_csv(&text, f, &m.controls)?
        }
        Controls::Schedule(s) => s.clone(),
    };
    s.check(u)?;
    Ok(s)
}

/// How a run is made.
#[derive(Debug, Clone, Copy)]
pub struct RunOptions<'a> {
    /// Threads the run may use: with more than one, a long run is split by
    /// rows over them (the bits do not change).
    pub threads: usize,
    /// Checked every few thousand steps of a run on one thread: when set,
    /// the run stops and [`generate`] returns `None`.
    pub cancel: Option<&'a AtomicBool>,
}

impl Default for RunOptions<'_> {
    fn default() -> Self {
        RunOptions { threads: 1, cancel: None }
    }
}

/// The threads a run of `m` uses when the caller leaves the choice to the
/// library: two for a reservoir of [`crate::measure::SPLIT_MIN_NEURONS`]
/// neurons or more, else one.
pub fn default_threads(m: &TrainedCpg) -> usize {
    if m.reservoir.n_neurons() >= crate::measure::SPLIT_MIN_NEURONS { 2 } else { 1 }
}

/// A free run in the channels' units.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// Frame-major values (`steps × channels`), in the channels' units
    /// (degrees for rotation channels).
    pub values: Vec<f64>,
    /// Steps.
    pub steps: usize,
    /// The model's rate, Hz.
    pub rate_hz: f64,
}

/// Runs `m` freely for `steps` steps (at most [`max_steps`]) from its start
/// state under `controls`, in the channels' units; `None` when cancelled.
pub fn generate(m: &TrainedCpg, controls: &ControlSchedule, steps: usize, opts: RunOptions<'_>) -> Result<Option<Run>> {
    let d = m.outputs.len();
    if steps == 0 || steps > max_steps(d) {
        return Err(Error::Bound(format!(
            "{steps} steps of {d} channels: expected at least one step and at most {MAX_VALUES} values"
        )));
    }
    controls.check(m.controls.len())?;
    let rate_hz = m.provenance.sample_rate_hz;
    let values = if opts.threads > 1 || opts.cancel.is_none() {
        let spec = RunSpec { model: m, controls, steps, push: None, noise: None };
        let mut y = free_runs_on(&[spec], opts.threads)?.pop().unwrap_or_else(|| Ok(Vec::new()))?;
        cpg_reservoir::to_units_in_place(&m.outputs, &mut y);
        cpg_reservoir::integrate_in_place(&m.outputs, &mut y, rate_hz);
        crate::travel::feet_led(m, &mut y)?;
        y
    } else {
        // One thread, step by step (the same bits as a batched run, in units:
        // the generator de-normalises and integrates rates), checking the flag.
        // The thread's watch, if it has one (cpg_reservoir::watch), sees the steps as a batched run's would.
        let cancel = opts.cancel.unwrap_or(&NEVER);
        let watch = cpg_reservoir::watch::current();
        let mut travel = crate::travel::FeetTravel::for_model(m)?;
        let mut g = Generator::new(m);
        let mut u = vec![0.0; m.controls.len()];
        let mut y = Vec::with_capacity(steps * d);
        for k in 0..steps {
            if k % CHECK_EVERY_STEPS == 0 {
                if cancel.load(Ordering::Relaxed) || watch.as_ref().is_some_and(|w| w.cancelled()) {
                    return Ok(None);
                }
                if let Some(w) = &watch {
                    w.steps.fetch_add(CHECK_EVERY_STEPS.min(steps - k) as u64, Ordering::Relaxed);
                }
            }
            controls.fill(k, rate_hz, &mut u);
            y.extend_from_slice(g.step(&u)?);
            if let Some(t) = travel.as_mut() {
                let n = y.len();
                t.apply(&mut y[n - d..]);
            }
        }
        y
    };
    Ok(Some(Run { values, steps, rate_hz }))
}

static NEVER: AtomicBool = AtomicBool::new(false);

/// How far beyond the teachers' range (as a share of its span) an output may
/// go before [`range_warnings`] names it.
pub const RANGE_MARGIN: f64 = 0.5;

/// A channel of a run that left the range of the cycles the model was taught
/// by more than [`RANGE_MARGIN`] of that range: a sign of an unstable model.
#[derive(Debug, Clone, PartialEq)]
pub struct RangeWarning {
    /// The channel.
    pub channel: String,
    /// The run's lowest and highest value, in the channel's units.
    pub run: (f64, f64),
    /// The teachers' lowest and highest value.
    pub taught: (f64, f64),
}

impl std::fmt::Display for RangeWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let u = if is_rotation(&self.channel) { " deg" } else { "" };
        write!(
            f,
            "{} spans {:.1} to {:.1}{u}, beyond the training data's {:.1} to {:.1}{u} by more than {:.0} % of that range: the model may be unstable (`cpg evaluate` measures it)",
            self.channel,
            self.run.0,
            self.run.1,
            self.taught.0,
            self.taught.1,
            RANGE_MARGIN * 100.0
        )
    }
}

/// The channels a model generates in units, as mocap channels (`bone.dof`;
/// a rate's is the channel it integrates into): what a skeleton reads its
/// runs as. An output that is not a mocap channel is an error naming it.
pub fn mocap_channels(m: &TrainedCpg) -> Result<Vec<cpg_mocap::Channel>> {
    m.outputs
        .iter()
        .map(|o| {
            cpg_mocap::Channel::parse(o.unit_name())
                .ok_or_else(|| Error::name(&o.name, format!("output '{}' is not a mocap channel (bone.dof)", o.name)))
        })
        .collect()
}

/// Whether a channel name is a rotation (`bone.rx`, `.ry`, `.rz`: degrees).
pub fn is_rotation(name: &str) -> bool {
    name.ends_with(".rx") || name.ends_with(".ry") || name.ends_with(".rz")
}

/// The channels of `y` (a run of `m` in units, frame-major) that leave the
/// teachers' range by more than [`RANGE_MARGIN`] of it, in channel order.
pub fn range_warnings(m: &TrainedCpg, y: &[f64]) -> Vec<RangeWarning> {
    let d = m.outputs.len();
    let mut out = Vec::new();
    for (k, o) in m.outputs.iter().enumerate() {
        if o.integrates().is_some() {
            // Taught as a rate, generated as the position it integrates to.
            continue;
        }
        let taught = m.teachers.iter().flat_map(|t| t.cycle.iter().skip(k).step_by(d)).map(|z| o.to_units(*z));
        let (lo, hi) = taught.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        let (min, max) =
            y.iter().skip(k).step_by(d).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let margin = RANGE_MARGIN * (hi - lo);
        if min < lo - margin || max > hi + margin {
            out.push(RangeWarning { channel: o.name.clone(), run: (min, max), taught: (lo, hi) });
        }
    }
    out
}

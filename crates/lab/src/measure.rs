//! How a generated rhythm is judged. Every verdict of the report and of
//! `cpg evaluate` is built from these definitions, stated once:
//!
//! - **Rhythm of a window**: its period (autocorrelation of the reference
//!   channel, searched from half to twice the teacher's period), the half
//!   range of every channel, and the phase-aligned NMSE against the teacher
//!   ([`cpg_reservoir::orbit_nmse`]). A window whose reference channel's half
//!   range is below [`DECAYED_FRACTION`] of the teacher's has **decayed**: it
//!   has no period.
//! - **Accurate**: at the end of the run the period is within
//!   [`PERIOD_TOLERANCE`] of the teacher's and every channel's half range
//!   within [`AMPLITUDE_TOLERANCE`] of the teacher's. A channel that does
//!   not move in the teacher (half range below [`STILL_HALF_RANGE`]: in the
//!   data it never moves, and it is normalised in its own units) matches when
//!   its half range stays below [`STILL_SWING`], as a held posture's
//!   channels do.
//! - **Converged**: the same tolerances between the window ending at the
//!   first minute and the last window: the rhythm no longer changes, whether
//!   or not it is the teacher's.
//! - **Back on an orbit / on the twin**: distances are RMS over windows of a
//!   quarter period, in standard deviations of the teacher cycle; to the
//!   teacher's orbit at the best phase, to the unperturbed twin at the same
//!   time. Recovered at the start of the first window after the release
//!   from which every window until the end of the run stays below the
//!   threshold ([`RECOVERY_THRESHOLD_SD`]), at least a whole period of them;
//!   0 s means at once. A run that comes back and leaves again has not
//!   recovered.
//! - **A posture** (a teacher of one frame: standing) has no rhythm. A run
//!   holds it when, over the last window, every channel stays within
//!   [`POSTURE_TOLERANCE`] of it in the channel's own units (degrees for
//!   joint angles): *accurate*; and it is *still* (a fixed point, not a slow
//!   cycle) when every channel's half range over that window is below a
//!   tenth of it: *converged*. Back on a posture after a push: the same
//!   windows as a rhythm's, a quarter of a second long, distances in the
//!   normalised units (a posture has no spread), held for a second.

use cpg_mocap::cycle::{estimate_period, half_range, lag, orbit_distance};
use cpg_reservoir::batch::{Controls, Run};
use cpg_reservoir::{Hold, OrbitStay, Teacher, TrainedCpg, orbit_nmse};
use serde::Serialize;

use crate::config::PushSection;
use crate::error::{Error, Result};
use crate::schedule::ControlSchedule;

/// Relative period error allowed for "accurate" and "converged".
pub const PERIOD_TOLERANCE: f64 = 0.01;
/// Relative amplitude error allowed for "accurate" and "converged".
pub const AMPLITUDE_TOLERANCE: f64 = 0.05;
/// Below this fraction of the teacher's half range, a rhythm has decayed.
pub const DECAYED_FRACTION: f64 = 0.05;
/// Distance (teacher standard deviations) under which a run is back on an orbit.
pub const RECOVERY_THRESHOLD_SD: f64 = 0.25;
/// Length of the windows judged at the start and at the end of a run, seconds.
pub const WINDOW_S: f64 = 10.0;
/// Largest distance from a taught posture that still holds it, in each
/// channel's own units (degrees for joint angles).
pub const POSTURE_TOLERANCE: f64 = 1.0;
/// Largest half range of a channel that holds still (a posture's channels, a
/// channel that never moves in the teacher): a tenth of [`POSTURE_TOLERANCE`].
pub const STILL_SWING: f64 = 0.1 * POSTURE_TOLERANCE;
/// A teacher's channel whose half range is below this (normalised units)
/// does not move: [`within`] judges it as a posture's channel.
pub const STILL_HALF_RANGE: f64 = 1e-6;
/// A posture's "period" for the windows of [`recovery`], seconds: windows of a
/// quarter of it, held for the whole of it.
pub const POSTURE_HOLD_S: f64 = 1.0;

/// Channel `c` of a frame-major signal with `d` channels.
pub fn column(x: &[f64], d: usize, c: usize) -> Vec<f64> {
    x.iter().skip(c).step_by(d).copied().collect()
}

/// The rhythm of one window.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rhythm {
    /// Period in steps; `None` when the window has decayed or shows no rhythm.
    pub period_steps: Option<f64>,
    /// Half range of each channel, normalised units.
    pub amplitude: Vec<f64>,
    /// NMSE against the teacher at the best phase.
    pub aligned_nmse: f64,
    /// The reference channel's half range is below [`DECAYED_FRACTION`] of the teacher's.
    pub decayed: bool,
}

/// What a teacher looks like in the measures: its period in steps and half ranges.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TeacherShape {
    /// The teacher's label.
    pub label: String,
    /// Period in generated steps.
    pub period_steps: f64,
    /// Half range of each channel.
    pub amplitude: Vec<f64>,
}

impl TeacherShape {
    /// The shape of `t` for a model with `d` outputs.
    pub fn of(t: &Teacher, d: usize) -> TeacherShape {
        TeacherShape {
            label: t.label.clone(),
            period_steps: t.period_steps(d),
            amplitude: (0..d).map(|c| half_range(&column(&t.cycle, d, c))).collect(),
        }
    }

    /// Which channels do not move in the teacher ([`STILL_HALF_RANGE`]).
    pub fn still(&self) -> Vec<bool> {
        self.amplitude.iter().map(|&a| a < STILL_HALF_RANGE).collect()
    }
}

/// The rhythm of `window` (`t × d`) against `teacher`, periods measured on channel `reference`.
pub fn rhythm(window: &[f64], d: usize, teacher: &Teacher, reference: usize) -> Rhythm {
    let shape = TeacherShape::of(teacher, d);
    let amplitude: Vec<f64> = (0..d).map(|c| half_range(&column(window, d, c))).collect();
    let decayed = amplitude[reference].is_nan() || amplitude[reference] < DECAYED_FRACTION * shape.amplitude[reference];
    let p = shape.period_steps;
    let col = column(window, d, reference);
    let lo = ((p / 2.0).floor() as usize).max(2);
    let hi = ((2.0 * p).ceil() as usize).min(col.len() / 2);
    let period_steps = if decayed { None } else { estimate_period(&col, lo, hi) };
    let stay =
        OrbitStay { end: window.len() / d, window: window.len() / d, cycle: teacher.cycle.clone(), rate: teacher.rate };
    Rhythm { period_steps, amplitude, aligned_nmse: orbit_nmse(window, &stay, d), decayed }
}

/// Whether `a` matches `b` within the tolerances (period and every amplitude;
/// a channel `still` in the teacher by staying below [`STILL_SWING`]).
pub fn within(a_period: Option<f64>, a_amp: &[f64], b_period: f64, b_amp: &[f64], still: &[bool]) -> bool {
    let Some(p) = a_period else { return false };
    (p / b_period - 1.0).abs() < PERIOD_TOLERANCE
        && a_amp.iter().zip(b_amp).enumerate().all(|(k, (x, y))| {
            if still.get(k) == Some(&true) { *x < STILL_SWING } else { (x / y - 1.0).abs() < AMPLITUDE_TOLERANCE }
        })
}

/// A long free run judged against its teacher.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stability {
    /// Steps run.
    pub steps: usize,
    /// The teacher.
    pub teacher: TeacherShape,
    /// The window ending at the first minute (or earlier for shorter runs).
    pub early: Rhythm,
    /// The last window.
    pub end: Rhythm,
    /// When the output decayed for good, seconds (`None`: it did not).
    pub decayed_at_s: Option<f64>,
    /// Period and amplitudes unchanged between the early and the last window.
    pub converged: bool,
    /// Period and amplitudes at the end within the tolerances of the teacher's.
    pub accurate: bool,
    /// For a posture: how far and how much the last window moved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub posture: Option<PostureHold>,
}

/// A run against a posture, over its last window, in each channel's units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PostureHold {
    /// Largest distance from the posture, per channel.
    pub deviation: Vec<f64>,
    /// Half range, per channel (a slow cycle shows here).
    pub swing: Vec<f64>,
}

impl Stability {
    /// Relative period error at the end (`None` when decayed).
    pub fn period_error(&self) -> Option<f64> {
        self.end.period_steps.map(|p| p / self.teacher.period_steps - 1.0)
    }

    /// End amplitude over the teacher's, channel `c`.
    pub fn amplitude_ratio(&self, c: usize) -> f64 {
        self.end.amplitude[c] / self.teacher.amplitude[c]
    }
}

/// Judges a run `y` (`steps × d`, normalised) against `teacher`.
pub fn stability(y: &[f64], d: usize, teacher: &Teacher, reference: usize, rate_hz: f64) -> Stability {
    let steps = y.len() / d;
    let shape = TeacherShape::of(teacher, d);
    let win = ((WINDOW_S * rate_hz) as usize).max((3.0 * shape.period_steps).ceil() as usize).min(steps);
    let minute = ((60.0 * rate_hz) as usize).clamp(win, steps);
    let early = rhythm(&y[(minute - win) * d..minute * d], d, teacher, reference);
    let end = rhythm(&y[(steps - win) * d..], d, teacher, reference);
    // Decayed for good: from the start of the first period-long window after
    // which every window is below the decay fraction. Only whole periods are
    // judged: a few steps left over at the end can lie near a turning point
    // and look flat without being so.
    let p = (shape.period_steps.round() as usize).max(2);
    let floor = DECAYED_FRACTION * shape.amplitude[reference];
    let refc = column(y, d, reference);
    let mut decayed_from = None;
    for (i, w) in refc.chunks_exact(p).enumerate().rev() {
        if half_range(w) < floor {
            decayed_from = Some(i * p);
        } else {
            break;
        }
    }
    let decayed_at_s = decayed_from.filter(|&k| k < steps).map(|k| k as f64 / rate_hz);
    let still = shape.still();
    let converged = !early.decayed
        && within(end.period_steps, &end.amplitude, early.period_steps.unwrap_or(f64::NAN), &early.amplitude, &still);
    let accurate = within(end.period_steps, &end.amplitude, shape.period_steps, &shape.amplitude, &still);
    Stability { steps, teacher: shape, early, end, decayed_at_s, converged, accurate, posture: None }
}

/// Judges a run `y` (`steps × d`, normalised) against a posture `teacher`
/// (one frame); `std` is each channel's normalisation, so the verdicts are in
/// its units. The windows are [`stability`]'s.
pub fn posture_stability(y: &[f64], d: usize, teacher: &Teacher, rate_hz: f64, std: &[f64]) -> Stability {
    let steps = y.len() / d;
    let win = ((WINDOW_S * rate_hz) as usize).clamp(1, steps.max(1)).min(steps);
    let minute = ((60.0 * rate_hz) as usize).clamp(win, steps);
    let still = |w: &[f64]| Rhythm {
        period_steps: None,
        amplitude: (0..d).map(|c| half_range(&column(w, d, c))).collect(),
        aligned_nmse: orbit_nmse(w, &OrbitStay { end: 0, window: 0, cycle: teacher.cycle.clone(), rate: 1.0 }, d),
        decayed: false,
    };
    let (early, end) = (still(&y[(minute - win) * d..minute * d]), still(&y[(steps - win) * d..]));
    let last = &y[(steps - win) * d..];
    let deviation: Vec<f64> = (0..d)
        .map(|c| column(last, d, c).iter().map(|v| (v - teacher.cycle[c]).abs() * std[c]).fold(0.0, f64::max))
        .collect();
    let swing: Vec<f64> = (0..d).map(|c| end.amplitude[c] * std[c]).collect();
    let finite = last.iter().all(|v| v.is_finite());
    Stability {
        steps,
        teacher: TeacherShape::of(teacher, d),
        early,
        converged: finite && swing.iter().all(|&a| a < STILL_SWING),
        accurate: finite && deviation.iter().all(|&e| e <= POSTURE_TOLERANCE),
        end,
        decayed_at_s: None,
        posture: Some(PostureHold { deviation, swing }),
    }
}

/// What a perturbed run did, against its unperturbed twin.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct Recovery {
    /// Seconds from the release until the run is back on the teacher's orbit.
    pub orbit_s: Option<f64>,
    /// Seconds from the release until it is back on the orbit its unpushed
    /// twin ends on (that run's last period): recovery from the push as such,
    /// whatever the model's own orbit is (`None`: never).
    #[serde(default)]
    pub own_orbit_s: Option<f64>,
    /// Whether the unpushed twin itself ends on the teacher's orbit (within
    /// the same threshold): when it does not, `orbit_s` cannot be reached by
    /// any recovery, and measures the model's accuracy instead.
    #[serde(default)]
    pub unpushed_on_orbit: bool,
    /// Seconds from the release until it is back on its twin (same phase).
    pub twin_s: Option<f64>,
    /// Lag behind the twin long after the release, cycles (positive: behind).
    pub phase_shift_cycles: f64,
}

/// Time from `release` until `dist` (indexed by window start; windows that
/// run past the end are infinite) is below `threshold` for good: from the
/// start of the first window after which every window up to the last whole
/// one stays below it, provided at least `hold` windows do. A run that
/// returns and leaves again has not recovered.
fn settle(dist: &[f64], release: usize, threshold: f64, hold: usize, rate_hz: f64) -> Option<f64> {
    let last = dist.iter().rposition(|v| v.is_finite())?;
    let mut from = last + 1;
    while from > release && dist[from - 1] < threshold {
        from -= 1;
    }
    (from <= last && last + 1 - from >= hold.max(1)).then(|| (from - release) as f64 / rate_hz)
}

/// The steps [`recovery`] takes for one period of `cycle` (`p × d`): its
/// period, or for a posture (one frame) [`POSTURE_HOLD_S`], whose windows
/// then span a second as a rhythm's span its period.
fn recovery_period(cycle: &[f64], d: usize, rate_hz: f64) -> usize {
    if cycle.len() == d { ((POSTURE_HOLD_S * rate_hz).round() as usize).max(4) } else { cycle.len() / d.max(1) }
}

/// Compares a perturbed run `b` with its unperturbed twin `a` (both `T × d`,
/// frame-major) after the step `release`, against the teacher `cycle`
/// (`p × d`, the same units). At least 4 periods must follow the release.
pub fn recovery(a: &[f64], b: &[f64], d: usize, cycle: &[f64], release: usize, rate_hz: f64) -> Result<Recovery> {
    if d == 0 || a.len() != b.len() || !a.len().is_multiple_of(d) || cycle.len() < d || !cycle.len().is_multiple_of(d) {
        return Err(Error::Shape(format!(
            "runs of {} and {} values and a cycle of {} values are not frames of {d} outputs",
            a.len(),
            b.len(),
            cycle.len()
        )));
    }
    let posture = cycle.len() == d;
    let p = recovery_period(cycle, d, rate_hz);
    let t = a.len() / d;
    if t < release + 4 * p {
        return Err(Error::Shape(format!(
            "{} steps after the release are fewer than 4 cycles of {p}",
            t.saturating_sub(release)
        )));
    }
    let w = (p / 4).max(2);
    let ending = orbit_distance(b, cycle, d, w);
    let orbit: Vec<f64> = (0..t).map(|k| ending.get(k + w - 1).copied().unwrap_or(f64::INFINITY)).collect();
    let sd = if posture {
        1.0
    } else {
        let m = cycle.iter().sum::<f64>() / cycle.len() as f64;
        (cycle.iter().map(|v| (v - m).powi(2)).sum::<f64>() / cycle.len() as f64).sqrt().max(f64::MIN_POSITIVE)
    };
    let sq: Vec<f64> = a
        .chunks_exact(d)
        .zip(b.chunks_exact(d))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).powi(2)).sum::<f64>() / d as f64)
        .collect();
    let twin: Vec<f64> = (0..t)
        .map(|k| if k + w <= t { (sq[k..k + w].iter().sum::<f64>() / w as f64).sqrt() / sd } else { f64::INFINITY })
        .collect();
    let tail = release + (t - release - 2 * p).min((t - release) / 2);
    let shift = if posture {
        0.0
    } else {
        lag(&column(&a[tail * d..], d, 0), &column(&b[tail * d..], d, 0), p / 2 + 1) / p as f64
    };
    // The unpushed twin's own orbit: its last period (its own, which may differ from the teacher's).
    let own_p = if posture {
        1
    } else {
        let win = (4 * p).min(t);
        estimate_period(&column(&a[(t - win) * d..], d, 0), (p / 2).max(2), (2 * p).min(win / 2))
            .map_or(p, |q| (q.round() as usize).clamp(2, t))
    };
    let own = &a[(t - own_p) * d..];
    let a_ending = orbit_distance(a, cycle, d, w);
    let a_orbit: Vec<f64> = (0..t).map(|k| a_ending.get(k + w - 1).copied().unwrap_or(f64::INFINITY)).collect();
    Ok(Recovery {
        orbit_s: settle(&orbit, release, RECOVERY_THRESHOLD_SD, p, rate_hz),
        own_orbit_s: settle_on_orbit(b, d, own, release, rate_hz),
        unpushed_on_orbit: settle(&a_orbit, release, RECOVERY_THRESHOLD_SD, p, rate_hz).is_some(),
        twin_s: settle(&twin, release, RECOVERY_THRESHOLD_SD, p, rate_hz),
        phase_shift_cycles: shift,
    })
}

/// Seconds from step `from` until `y` (`T × d`) is on the orbit of `cycle`
/// (`p × d`; one frame: a posture) for good: the same windows and threshold as [`recovery`].
pub fn settle_on_orbit(y: &[f64], d: usize, cycle: &[f64], from: usize, rate_hz: f64) -> Option<f64> {
    let t = y.len() / d.max(1);
    if d == 0 || cycle.len() < d || t == 0 {
        return None;
    }
    let p = recovery_period(cycle, d, rate_hz);
    let w = (p / 4).max(2);
    let ending = orbit_distance(y, cycle, d, w);
    let dist: Vec<f64> = (0..t).map(|k| ending.get(k + w - 1).copied().unwrap_or(f64::INFINITY)).collect();
    settle(&dist, from, RECOVERY_THRESHOLD_SD, p, rate_hz)
}

/// Largest step-to-step change of any channel of `y` (`T × d`).
pub fn max_step(y: &[f64], d: usize) -> f64 {
    channel_steps(y, d).into_iter().fold(0.0, f64::max)
}

/// Each channel's largest step-to-step change in `y` (`T × d`).
pub fn channel_steps(y: &[f64], d: usize) -> Vec<f64> {
    let mut out = vec![0.0; d];
    if d == 0 {
        return out;
    }
    for (a, b) in y.chunks_exact(d).zip(y.chunks_exact(d).skip(1)) {
        for ((m, x), z) in out.iter_mut().zip(a).zip(b) {
            *m = f64::max(*m, (z - x).abs());
        }
    }
    out
}

/// A perturbation of a reservoir run: from `at`, for `len` steps, the fed-back
/// outputs are held at `values` (normalised units).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Push {
    /// First held step.
    pub at: usize,
    /// Held steps.
    pub len: usize,
    /// Held values, normalised.
    pub values: Vec<f64>,
}

/// The push `p` describes for teacher `t` of a model with `d` outputs at
/// `rate_hz`: each output held at its cycle's maximum plus `p.above_max`.
pub fn push_for(p: &PushSection, t: &Teacher, d: usize, rate_hz: f64) -> Push {
    let values =
        (0..d).map(|c| column(&t.cycle, d, c).into_iter().fold(f64::NEG_INFINITY, f64::max) + p.above_max).collect();
    Push { at: (p.at_s * rate_hz).round() as usize, len: ((p.hold_s * rate_hz).round() as usize).max(1), values }
}

/// Runs `model` freely for `steps` from its start state under `controls`;
/// returns the normalised outputs (`steps × D`). An optional push holds the
/// fed-back outputs. On the calling thread ([`free_runs`] takes a thread count).
pub fn free_run(model: &TrainedCpg, controls: &ControlSchedule, steps: usize, push: Option<&Push>) -> Result<Vec<f64>> {
    free_run_with(model, controls, steps, push, None)
}

/// [`free_run`] with Gaussian state noise of the given (variance, seed) after every update.
pub fn free_run_with(
    model: &TrainedCpg,
    controls: &ControlSchedule,
    steps: usize,
    push: Option<&Push>,
    noise: Option<(f64, u64)>,
) -> Result<Vec<f64>> {
    let mut y = free_runs(&[RunSpec { model, controls, steps, push, noise }], 1)?;
    Ok(y.pop().unwrap_or_default())
}

/// One free run of [`free_runs`].
#[derive(Clone, Copy)]
pub struct RunSpec<'a> {
    /// The model, from its start state.
    pub model: &'a TrainedCpg,
    /// Its controls.
    pub controls: &'a ControlSchedule,
    /// Steps.
    pub steps: usize,
    /// An optional push.
    pub push: Option<&'a Push>,
    /// Gaussian state noise (variance, seed) after every update.
    pub noise: Option<(f64, u64)>,
}

/// A schedule at a model's rate, as the reservoir's batched runs read controls.
struct At<'a>(&'a ControlSchedule, f64);

impl Controls for At<'_> {
    fn fill(&self, step: usize, out: &mut [f64]) {
        self.0.fill(step, self.1, out)
    }
}

/// Runs several free runs at once (see [`cpg_reservoir::batch`]): runs whose
/// models share a reservoir's weights advance with one matrix product per
/// step, a long run split by rows over `threads` threads. Returns each run's
/// normalised outputs (`steps × D`), the same bits as [`free_run_with`]
/// gives for it alone; a run that diverged is an error.
pub fn free_runs(runs: &[RunSpec<'_>], threads: usize) -> Result<Vec<Vec<f64>>> {
    free_runs_each(runs, threads)?.into_iter().collect()
}

/// [`free_runs`], with each run's outcome on its own: a run that diverged
/// does not hide the others. The outer error is a schedule that does not fit its model.
pub fn free_runs_each(runs: &[RunSpec<'_>], threads: usize) -> Result<Vec<Result<Vec<f64>>>> {
    free_runs_on(runs, threads)
}

/// Reservoirs at least this large run one free run split over two cores when
/// the caller leaves the choice to the library (the Python package's
/// `threads=None`): below it, the exchange of half states between the cores
/// after every step costs more than the rows each core saves. Set from
/// `cargo xtask bench` ("When one run is split"; 2-core AVX-512 machine,
/// f64): the split was slower at N = 300, 600 and 1500, level at 1000, and
/// 5–6 % faster at 2000 and 3000, where the weights no longer fit in cache
/// and both cores wait on memory.
pub const SPLIT_MIN_NEURONS: usize = 2000;

/// [`free_runs_each`] on `threads` threads (a long run is split by rows over
/// them; 1 runs on the calling thread alone). The bits do not depend on it.
pub fn free_runs_on(runs: &[RunSpec<'_>], threads: usize) -> Result<Vec<Result<Vec<f64>>>> {
    let mut at = Vec::with_capacity(runs.len());
    let mut holds = Vec::with_capacity(runs.len());
    for r in runs {
        r.controls.check(r.model.controls.len())?;
        at.push(At(r.controls, r.model.provenance.sample_rate_hz));
        holds.push(r.push.map(|p| Hold { from: p.at, len: p.len, values: p.values.clone() }));
    }
    let batch: Vec<Run<'_>> = runs
        .iter()
        .zip(&at)
        .zip(&holds)
        .map(|((r, a), h)| Run { model: r.model, controls: a, steps: r.steps, hold: h.as_ref(), noise: r.noise })
        .collect();
    Ok(cpg_reservoir::batch::free_runs(&batch, threads.max(1)).into_iter().map(|r| r.map_err(Error::from)).collect())
}

/// One control setting of a model judged: what `cpg evaluate` prints and the
/// Python package's `Model.evaluate` returns.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Judged {
    /// The teacher it is judged against.
    pub teacher: String,
    /// Its control values.
    pub controls: Vec<f64>,
    /// The long free run against the teacher.
    pub stability: Stability,
    /// The paper's push (the fed-back output held at the cycle's maximum + 2 σ
    /// for 50 ms after 2 s), against the teacher's orbit and an unperturbed twin.
    pub recovery: Recovery,
}

/// Judges `model` by free runs of `steps` and the paper's push: at every
/// control setting it was taught, or under `controls` against the teacher of
/// the setting they end at; each setting's runs on `threads` threads.
pub fn judge(
    model: &TrainedCpg,
    steps: usize,
    controls: Option<&ControlSchedule>,
    threads: usize,
) -> Result<Vec<Judged>> {
    let rate = model.provenance.sample_rate_hz;
    if model.teachers.is_empty() {
        return Err(Error::Unusable(
            "the model has no teacher cycle (it was not trained on a looped periodic signal), so there is nothing to compare its rhythm with"
                .into(),
        ));
    }
    let d = model.outputs.len();
    let settings: Vec<(ControlSchedule, &Teacher)> = match controls {
        None => model.teachers.iter().map(|t| (ControlSchedule::Constant(t.controls.clone()), t)).collect(),
        Some(s) => {
            let mut last = vec![0.0; model.controls.len()];
            s.fill(usize::MAX / 2, rate, &mut last);
            let t = model.teacher_for(&last).ok_or_else(|| Error::Unusable("no teacher".into()))?;
            vec![(s.clone(), t)]
        }
    };
    let mut out = Vec::with_capacity(settings.len());
    for (s, t) in settings {
        let posture = t.is_posture(d);
        let p = recovery_period(&t.cycle, d, rate);
        let push = push_for(&PushSection::default(), t, d, rate);
        let release = push.at + push.len;
        if steps < release + 4 * p {
            return Err(Error::Shape(format!(
                "{:.1} s of free run is too short for the push at 2 s and 4 cycles after it ({:.1} s)",
                steps as f64 / rate,
                (release + 4 * p) as f64 / rate
            )));
        }
        let after = (40 * p).min(steps - release);
        let mut ys = free_runs(
            &[
                RunSpec { model, controls: &s, steps, push: None, noise: None },
                RunSpec { model, controls: &s, steps: release + after, push: Some(&push), noise: None },
            ],
            threads,
        )?
        .into_iter();
        let (y, pushed) = (ys.next().unwrap_or_default(), ys.next().unwrap_or_default());
        let rec = recovery(&y[..(release + after) * d], &pushed, d, &t.cycle, release, rate)?;
        let std: Vec<f64> = model.outputs.iter().map(|o| o.std).collect();
        out.push(Judged {
            teacher: t.label.clone(),
            controls: t.controls.clone(),
            stability: if posture { posture_stability(&y, d, t, rate, &std) } else { stability(&y, d, t, 0, rate) },
            recovery: rec,
        });
    }
    Ok(out)
}

/// A foot point is on the ground when it is at most this high above its
/// floor (the [`FLOOR_QUANTILE`] of its heights in the recorded training trials), mm.
pub const CONTACT_MM: f64 = 10.0;
/// A foot point's floor: this quantile of its heights over the recorded
/// training trials (the lowest would be a glitch's).
pub const FLOOR_QUANTILE: f64 = 0.05;
/// The shortest stance counted, seconds (a touch shorter than this is not a stance).
pub const MIN_STANCE_S: f64 = 0.1;
/// The point of each foot that bears the weight through a stance in CMU's
/// ASF skeletons: the end of its `foot` bone, the ball (a toe's tip passes
/// within a centimetre of the floor in a walking swing). Any skeleton's are
/// found by its profile: [`feet`].
pub const FEET: [&str; 2] = ["lfoot", "rfoot"];

/// The balls of the feet of skeleton `sk` (left, right), as forward
/// kinematics names them: where its profile's toes start
/// ([`cpg_mocap::profile`], the built-in profile it fits); CMU's ASF names
/// ([`FEET`]) for a skeleton no built-in profile fits.
pub fn feet(sk: &cpg_mocap::Skeleton) -> Vec<String> {
    match cpg_mocap::profile::Profile::detect(sk).and_then(|p| p.resolve(sk).ok()) {
        Some(r) => r.sides.iter().map(|s| s.ball.clone()).collect(),
        None => FEET.iter().map(|f| (*f).to_owned()).collect(),
    }
}

/// The largest slide of a foot on the ground in frames `from..to` of
/// `pos` (world positions, mm, y up): a foot point is on the ground while
/// within [`CONTACT_MM`] of its floor (`floors`, one per point of `feet`);
/// during each stance of at least [`MIN_STANCE_S`], its
/// horizontal distance from where it landed. The worst over the points, mm
/// (0 when none lands).
pub fn foot_slide_mm(pos: &cpg_mocap::Positions, from: usize, to: usize, feet: &[String], floors: &[f64]) -> f64 {
    let n = pos.names.len();
    let to = to.min(pos.n_frames());
    let min_frames = ((MIN_STANCE_S * pos.sample_rate_hz).round() as usize).max(2);
    let mut worst: f64 = 0.0;
    for (name, &floor) in feet.iter().zip(floors) {
        let Some(i) = pos.point_index(name) else { continue };
        let at = |k: usize| pos.points_mm[k * n + i];
        let mut k = from;
        while k < to {
            if at(k)[1] > floor + CONTACT_MM {
                k += 1;
                continue;
            }
            let start = k;
            while k < to && at(k)[1] <= floor + CONTACT_MM {
                k += 1;
            }
            if k - start >= min_frames {
                let p0 = at(start);
                let slide = (start..k)
                    .map(|j| {
                        let p = at(j);
                        ((p[0] - p0[0]).powi(2) + (p[2] - p0[2]).powi(2)).sqrt()
                    })
                    .fold(0.0, f64::max);
                worst = worst.max(slide);
            }
        }
    }
    worst
}

/// The floor of each point of `feet`: the [`FLOOR_QUANTILE`]
/// of its heights over every frame of `positions` (recorded rhythm trials), mm.
pub fn floors(positions: &[cpg_mocap::Positions], feet: &[String]) -> Vec<f64> {
    feet.iter()
        .map(|name| {
            let mut h: Vec<f64> = positions
                .iter()
                .filter_map(|p| p.point_index(name).map(|i| (p, i)))
                .flat_map(|(p, i)| (0..p.n_frames()).map(move |k| p.points_mm[k * p.names.len() + i][1]))
                .collect();
            h.sort_by(f64::total_cmp);
            h.get(((FLOOR_QUANTILE * h.len() as f64) as usize).min(h.len().saturating_sub(1))).copied().unwrap_or(0.0)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_that_returns_and_leaves_again_has_not_recovered() {
        let inf = f64::INFINITY;
        // Windows: bad, good for 5, bad again, good for 4 to the end, then windows past the end.
        let d = [1.0, 0.1, 0.1, 0.1, 0.1, 0.1, 1.0, 0.1, 0.1, 0.1, 0.1, inf, inf];
        assert_eq!(settle(&d, 0, 0.25, 3, 1.0), Some(7.0), "back for good from window 7");
        assert_eq!(settle(&d, 0, 0.25, 5, 1.0), None, "the last good stretch is shorter than 5");
        let leaves = [1.0, 0.1, 0.1, 0.1, 0.1, 1.0, inf];
        assert_eq!(settle(&leaves, 0, 0.25, 2, 1.0), None, "it left again before the end");
        assert_eq!(settle(&[0.1, 0.1, 0.1, inf], 0, 0.25, 1, 1.0), Some(0.0), "at once");
    }

    #[test]
    fn a_run_that_ends_near_a_turning_point_has_not_decayed() {
        // A sine of period 100 steps, 1003 steps long: the last 3 steps sit on
        // a crest, flat on their own; only whole periods are judged.
        let cycle: Vec<f64> = (0..100).map(|k| (k as f64 * std::f64::consts::TAU / 100.0).sin()).collect();
        let teacher = Teacher { label: "sine".into(), controls: Vec::new(), cycle: cycle.clone(), rate: 1.0 };
        let y: Vec<f64> = (0..1003).map(|k| cycle[(k + 24) % 100]).collect();
        let s = stability(&y, 1, &teacher, 0, 10.0);
        assert_eq!(s.decayed_at_s, None, "3 leftover steps on a crest are not a decay");
        // A run that does decay still says when.
        let mut z = y.clone();
        z[500..].iter_mut().for_each(|v| *v *= 1e-3);
        assert_eq!(stability(&z, 1, &teacher, 0, 10.0).decayed_at_s, Some(50.0));
    }

    #[test]
    fn a_channel_still_in_the_teacher_matches_while_it_stays_still() {
        // Channel 0 a sine of period 100 steps, channel 1 never moves (normalised to 0).
        let cycle: Vec<f64> = (0..100).flat_map(|k| [(k as f64 * std::f64::consts::TAU / 100.0).sin(), 0.0]).collect();
        let teacher = Teacher { label: "walk".into(), controls: Vec::new(), cycle: cycle.clone(), rate: 1.0 };
        assert_eq!(TeacherShape::of(&teacher, 2).still(), [false, true]);
        let run = |wobble: f64| -> Vec<f64> {
            (0..3000).flat_map(|k| [cycle[2 * (k % 100)], wobble * (k as f64 * 0.3).sin()]).collect()
        };
        let quiet = stability(&run(0.01), 2, &teacher, 0, 10.0);
        assert!(quiet.accurate && quiet.converged, "±0.01 of a still channel is still");
        let moving = stability(&run(0.2), 2, &teacher, 0, 10.0);
        assert!(!moving.accurate, "±0.2 is not: a tenth of the posture tolerance is the bound");
    }

    #[test]
    fn a_posture_is_held_within_a_degree_and_still() {
        // Two channels of 2° and 10° per normalised unit; the posture (0.5, -1).
        let teacher = Teacher { label: "stand".into(), controls: Vec::new(), cycle: vec![0.5, -1.0], rate: 1.0 };
        let std = [2.0, 10.0];
        let run = |f: &dyn Fn(usize) -> [f64; 2]| -> Vec<f64> { (0..2000).flat_map(f).collect() };
        let held = posture_stability(&run(&|_| [0.5, -1.0 + 0.09]), 2, &teacher, 10.0, &std);
        assert!(held.accurate && held.converged, "0.9° off and still holds: {:?}", held.posture);
        let off = posture_stability(&run(&|_| [0.5 + 0.6, -1.0]), 2, &teacher, 10.0, &std);
        assert!(!off.accurate && off.converged, "1.2° off is not the posture, though still");
        let sway = |k: usize| [0.5 + 0.06 * (k as f64 * 0.05).sin(), -1.0];
        let slow = posture_stability(&run(&sway), 2, &teacher, 10.0, &std);
        assert!(slow.accurate && !slow.converged, "a slow cycle of ±0.12° is near, but not still");
        // Pushed off and back: recovered once within a quarter σ for a second.
        let a = run(&|_| [0.5, -1.0]);
        let b = run(&|k| if k < 100 { [3.0, -1.0] } else { [0.5, -1.0] });
        let r = recovery(&a, &b, 2, &teacher.cycle, 50, 10.0).unwrap();
        assert!(r.orbit_s.is_some_and(|s| (4.0..=5.1).contains(&s)), "{r:?}");
    }
}

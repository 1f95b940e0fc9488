//! `cpg stream`: a live control loop. Control values arrive on standard input
//! whenever they come; one line of commands leaves on standard output per tick,
//! paced by a monotonic clock.

use std::io::{BufRead, Write};
use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use cpg_hoap2::{ChannelMap, Robot};
use cpg_lab::ControlSchedule;
use cpg_reservoir::TrainedCpg;

/// What `cpg stream` was asked for.
pub struct Stream<'a> {
    pub model: &'a Path,
    pub rate_hz: Option<f64>,
    pub seconds: Option<f64>,
    pub control: Option<&'a str>,
    pub robot: Option<(&'a Path, &'a Path)>,
    pub acceleration_rad_s2: f64,
    pub pacing: bool,
}

/// Lateness of a tick, in whole microseconds, counted up to this bound (the last bucket holds the rest).
const MAX_LATENESS_US: usize = 100_000;

/// What arrives from the reader thread.
enum Input {
    Controls(Vec<f64>),
    Closed,
}

/// Reads control lines from standard input and sends the controls after each;
/// bad lines are reported and skipped.
fn read_controls(names: Vec<String>, start: Vec<f64>, tx: mpsc::Sender<Input>) {
    let stdin = std::io::stdin();
    let mut current = start;
    for (k, line) in stdin.lock().lines().enumerate() {
        let Ok(line) = line else { break };
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        match ControlSchedule::parse_update(text, &names, &mut current) {
            Ok(()) => {
                if tx.send(Input::Controls(current.clone())).is_err() {
                    return;
                }
            }
            Err(e) => eprintln!("warning: standard input line {}: {e}; ignored", k + 1),
        }
    }
    let _ = tx.send(Input::Closed);
}

/// Waits until `deadline`: sleeps until shortly before it (a sleep may
/// overshoot by tens of microseconds), then spins the last stretch.
fn wait_until(deadline: Instant) {
    const SPIN: Duration = Duration::from_micros(60);
    let now = Instant::now();
    if deadline > now + SPIN {
        std::thread::sleep(deadline - now - SPIN);
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}

/// `cpg stream`.
pub fn run(s: Stream<'_>) -> anyhow::Result<()> {
    let m = TrainedCpg::load(s.model)?;
    let model_rate = m.provenance.sample_rate_hz;
    let rate = s.rate_hz.unwrap_or(model_rate);
    // The same rate range as a resampled trajectory; the stream holds no frames, so only the duration is bounded.
    cpg_hoap2::JointTrajectory::check_rate(rate, 0.0, 1).context("--rate-hz")?;
    if let Some(sec) = s.seconds {
        super::check_seconds(sec)?;
    }
    if !(s.acceleration_rad_s2.is_finite() && s.acceleration_rad_s2 > 0.0) {
        bail!("--acceleration-rad-s2 {}: expected a positive bound", s.acceleration_rad_s2);
    }
    let mut controls = match (s.control, m.controls.is_empty()) {
        (Some(v), _) => {
            let mut c = vec![0.0; m.controls.len()];
            if let Some(t) = m.teachers.first() {
                c.copy_from_slice(&t.controls);
            }
            ControlSchedule::parse_update(v, &m.controls, &mut c).context("--control")?;
            c
        }
        (None, true) => Vec::new(),
        (None, false) => m.teachers.first().map(|t| t.controls.clone()).unwrap_or_else(|| vec![0.0; m.controls.len()]),
    };
    // Columns out: the model's channels (degrees), or the robot's joints (radians, limited).
    let loaded = match s.robot {
        Some((urdf, map)) => Some((Robot::from_urdf_file(urdf)?, ChannelMap::load(map)?)),
        None => None,
    };
    let target = loaded.as_ref().map(|(robot, map)| cpg_lab::stream::RobotTarget {
        robot,
        map,
        acceleration_rad_s2: s.acceleration_rad_s2,
    });
    // Everything the loop touches is allocated here.
    let mut ticker = cpg_lab::stream::Ticker::new(&m, rate, target)?;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    write!(out, "time_s")?;
    match ticker.columns() {
        joints if !joints.is_empty() => {
            for j in joints {
                write!(out, ",{j}_rad")?;
            }
        }
        _ => {
            for o in &m.outputs {
                write!(out, ",{}{}", o.name, super::unit_suffix(&o.name))?;
            }
        }
    }
    writeln!(out)?;
    out.flush()?;

    let (tx, rx) = mpsc::channel();
    let (names, start) = (m.controls.clone(), controls.clone());
    std::thread::spawn(move || read_controls(names, start, tx));

    let mut lateness = vec![0u32; MAX_LATENESS_US + 1];
    let mut missed = 0u64;
    let mut worst_us = 0u64;
    let n_ticks = s.seconds.map(|sec| (sec * rate).round().max(1.0) as u64);
    let period = Duration::from_secs_f64(1.0 / rate);
    let mut stdin_open = true;
    let start = Instant::now();
    let mut tick = 0u64;
    loop {
        if n_ticks.is_some_and(|n| tick >= n) || (n_ticks.is_none() && !stdin_open) {
            break;
        }
        // New control values, if any arrived.
        while let Ok(msg) = rx.try_recv() {
            match msg {
                Input::Controls(v) => controls.copy_from_slice(&v),
                Input::Closed => stdin_open = false,
            }
        }
        let t_s = ticker.time_s();
        let values = ticker.tick(&controls).context("the model diverged")?;
        if s.pacing {
            let deadline = start + period.mul_f64(tick as f64);
            wait_until(deadline);
            let late = Instant::now().saturating_duration_since(deadline);
            let us = late.as_micros() as u64;
            worst_us = worst_us.max(us);
            lateness[(us as usize).min(MAX_LATENESS_US)] += 1;
            if late > period {
                missed += 1;
            }
        }
        write!(out, "{t_s:.6}")?;
        for v in values {
            write!(out, ",{v:.6}")?;
        }
        writeln!(out)?;
        out.flush()?;
        tick += 1;
    }
    // The report, on standard error.
    if s.pacing && tick > 0 {
        let mut seen = 0u64;
        let (mut p50, mut p99) = (0, 0);
        let mut sum = 0u64;
        for (us, &n) in lateness.iter().enumerate() {
            let before = seen;
            seen += n as u64;
            sum += us as u64 * n as u64;
            if before < tick / 2 && seen >= tick / 2 {
                p50 = us;
            }
            if before < tick * 99 / 100 && seen >= tick * 99 / 100 {
                p99 = us;
            }
        }
        eprintln!(
            "{tick} ticks at {rate} Hz: lateness mean {:.1} µs, median {p50} µs, 99th percentile {p99} µs, worst {worst_us} µs; {missed} missed deadline(s) (later than one period, {:.0} µs)",
            sum as f64 / tick as f64,
            1e6 / rate
        );
    } else {
        eprintln!("{tick} ticks at {rate} Hz, unpaced (--no-pacing)");
    }
    for (name, c) in ticker.limit_counts() {
        if c.position + c.velocity + c.acceleration > 0 {
            eprintln!(
                "{name}: limited at {} tick(s) by position, {} by velocity, {} by acceleration; largest lag {:.2}°",
                c.position,
                c.velocity,
                c.acceleration,
                c.max_lag_rad.to_degrees()
            );
        }
    }
    Ok(())
}

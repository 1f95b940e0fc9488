//! `cpg stream`: a live control loop. Control values arrive on standard input
//! whenever they come; one line of commands leaves on standard output per tick,
//! paced by a monotonic clock.

use std::io::{BufRead, Write};
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use cpg_lab::ControlSchedule;
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, Robot};

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

/// What the reader thread leaves for the loop: the newest control values
/// (absolute, so only the newest matters), how many values were replaced
/// before a tick read them, and whether the input has ended. One slot, not a
/// queue: input that arrives faster than the ticks (`yes 1,0 | cpg stream`)
/// costs no memory and makes no tick late.
#[derive(Default)]
struct Inbox {
    newest: Option<Vec<f64>>,
    dropped: u64,
    closed: bool,
}

/// The slot shared by the reader thread and the loop.
type Shared = std::sync::Arc<std::sync::Mutex<Inbox>>;

fn inbox(s: &Shared) -> std::sync::MutexGuard<'_, Inbox> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// The longest control line read; a longer one is reported and skipped.
pub const MAX_CONTROL_LINE_BYTES: usize = 4096;

/// One line of `r`, at most `max` bytes kept: `Ok(None)` at the end of the
/// input, `Ok(Some(Err(n)))` for a line of `n` bytes longer than `max` (read
/// to its end and dropped, in bounded memory).
fn bounded_line(r: &mut impl BufRead, max: usize, buf: &mut Vec<u8>) -> std::io::Result<Option<Result<(), usize>>> {
    buf.clear();
    let mut total = 0usize;
    loop {
        let chunk = r.fill_buf()?;
        if chunk.is_empty() {
            return Ok(if total == 0 {
                None
            } else if total > max {
                Some(Err(total))
            } else {
                Some(Ok(()))
            });
        }
        let (take, end) = match chunk.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (chunk.len(), false),
        };
        if total < max {
            let keep = take.min(max + 1 - total);
            buf.extend_from_slice(&chunk[..keep]);
        }
        total += take;
        r.consume(take);
        if end {
            return Ok(Some(if total > max + 1 { Err(total) } else { Ok(()) }));
        }
    }
}

/// Reads control lines from standard input and leaves the controls after
/// each in the slot (replacing values no tick has read yet). A bad line (not
/// UTF-8, too long, not controls) is reported and skipped; reading goes on.
fn read_controls(names: Vec<String>, start: Vec<f64>, slot: Shared) {
    let stdin = std::io::stdin();
    let mut r = stdin.lock();
    let mut current = start;
    let mut buf = Vec::with_capacity(MAX_CONTROL_LINE_BYTES + 2);
    for k in 1.. {
        let line = match bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf) {
            Ok(None) => break,
            Ok(Some(Err(n))) => {
                eprintln!("warning: standard input line {k}: {n} bytes, longer than {MAX_CONTROL_LINE_BYTES}; ignored");
                continue;
            }
            Ok(Some(Ok(()))) => buf.as_slice(),
            Err(e) => {
                eprintln!("warning: standard input: {e}; no more control values are read");
                break;
            }
        };
        let Ok(text) = std::str::from_utf8(line) else {
            eprintln!("warning: standard input line {k}: not UTF-8 text; ignored");
            continue;
        };
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        match ControlSchedule::parse_update(text, &names, &mut current) {
            Ok(()) => {
                let mut b = inbox(&slot);
                match &mut b.newest {
                    Some(v) => {
                        v.copy_from_slice(&current);
                        b.dropped += 1;
                    }
                    None => b.newest = Some(current.clone()),
                }
            }
            Err(e) => eprintln!("warning: standard input line {k}: {}; ignored", crate::show(&e.to_string())),
        }
    }
    inbox(&slot).closed = true;
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
    cpg_robot::JointTrajectory::check_rate(rate, 0.0, 1).context("--rate-hz")?;
    if let Some(sec) = s.seconds {
        cpg_lab::run::check_seconds("--seconds", sec)?;
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
        Some((urdf, map)) => Some((Robot::from_spec(urdf)?, ChannelMap::from_spec(map)?)),
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
                write!(out, ",{}{}", o.name, cpg_lab::format::unit_suffix(&o.name))?;
            }
        }
    }
    writeln!(out)?;
    out.flush()?;

    // From here a signal ends the loop as its last tick would, with the report.
    crate::output::interruptible();
    let slot: Shared = Shared::default();
    let (names, start) = (m.controls.clone(), controls.clone());
    let reader = slot.clone();
    std::thread::spawn(move || read_controls(names, start, reader));

    let mut lateness = vec![0u32; MAX_LATENESS_US + 1];
    let mut missed = 0u64;
    let mut worst_us = 0u64;
    let n_ticks = s.seconds.map(|sec| (sec * rate).round().max(1.0) as u64);
    let period = Duration::from_secs_f64(1.0 / rate);
    let mut stdin_open = true;
    let start = Instant::now();
    let mut tick = 0u64;
    loop {
        if n_ticks.is_some_and(|n| tick >= n) || (n_ticks.is_none() && !stdin_open) || crate::output::interrupted() {
            break;
        }
        // The newest control values, if any arrived.
        {
            let mut b = inbox(&slot);
            if let Some(v) = b.newest.take() {
                controls.copy_from_slice(&v);
            }
            stdin_open = !b.closed;
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
    if crate::output::interrupted() {
        eprintln!(
            "interrupted: {tick} line(s) of commands went to standard output ({:.3} s of the model at {rate} Hz), each complete",
            tick as f64 / rate
        );
    }
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
    let dropped = inbox(&slot).dropped;
    if dropped > 0 {
        eprintln!(
            "{dropped} control line(s) were replaced by newer ones before a tick read them (the input came faster than the ticks; each tick used the newest values)"
        );
    }
    let interrupted = crate::output::interrupted();
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
    if interrupted {
        std::process::exit(130);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_longer_than_the_bound_is_dropped_in_bounded_memory() {
        let mut input: Vec<u8> = b"1,0\n".to_vec();
        input.extend(std::iter::repeat_n(b'0', 10 * MAX_CONTROL_LINE_BYTES));
        input.extend_from_slice(b"\nu_run=1\n\xff\xfe\n");
        let mut r = std::io::BufReader::with_capacity(64, input.as_slice());
        let mut buf = Vec::new();
        assert_eq!(bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf).unwrap(), Some(Ok(())));
        assert_eq!(buf, b"1,0\n");
        assert_eq!(
            bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf).unwrap(),
            Some(Err(10 * MAX_CONTROL_LINE_BYTES + 1))
        );
        assert!(buf.len() <= MAX_CONTROL_LINE_BYTES + 1);
        assert_eq!(bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf).unwrap(), Some(Ok(())));
        assert_eq!(buf, b"u_run=1\n");
        assert_eq!(bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf).unwrap(), Some(Ok(())));
        assert!(std::str::from_utf8(&buf).is_err());
        assert_eq!(bounded_line(&mut r, MAX_CONTROL_LINE_BYTES, &mut buf).unwrap(), None);
    }
}

//! Analysis of rhythmic signals: period, amplitude, seamless loops, phase alignment.
//!
//! Signals are plain slices. Multi-channel signals are frame-major
//! (`frames × n_channels`), like [`Motion::values`](crate::Motion::values).

/// Mean of a slice (0 for an empty one).
fn mean(x: &[f64]) -> f64 {
    if x.is_empty() { 0.0 } else { x.iter().sum::<f64>() / x.len() as f64 }
}

/// Normalised autocorrelation of `x` at `lag` (Pearson correlation of `x[..n−lag]` with `x[lag..]`).
pub fn autocorrelation(x: &[f64], lag: usize) -> f64 {
    if lag >= x.len().saturating_sub(1) {
        return 0.0;
    }
    let (a, b) = (&x[..x.len() - lag], &x[lag..]);
    let (ma, mb) = (mean(a), mean(b));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (p, q) in a.iter().zip(b) {
        sab += (p - ma) * (q - mb);
        saa += (p - ma) * (p - ma);
        sbb += (q - mb) * (q - mb);
    }
    let den = (saa * sbb).sqrt();
    if den > 0.0 { sab / den } else { 0.0 }
}

/// The period of a rhythmic signal, in samples: the first lag in
/// `min_lag..=max_lag` whose autocorrelation peaks within 0.05 of the highest, refined to a fraction of a sample by a
/// parabola through the peak and its neighbours. `None` when the range is
/// empty or does not fit the signal.
pub fn estimate_period(x: &[f64], min_lag: usize, max_lag: usize) -> Option<f64> {
    let max_lag = max_lag.min(x.len().saturating_sub(2));
    if min_lag < 1 || min_lag > max_lag {
        return None;
    }
    let ac: Vec<f64> = (min_lag - 1..=max_lag + 1).map(|l| autocorrelation(x, l)).collect();
    // Multiples of the period correlate almost as well as the period itself:
    // take the first local maximum that comes within 0.05 of the highest one.
    let top = ac[1..ac.len() - 1].iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let best =
        (1..ac.len() - 1).find(|&k| ac[k] >= ac[k - 1] && ac[k] >= ac[k + 1] && ac[k] >= top - 0.05).unwrap_or(1);
    let (y0, y1, y2) = (ac[best - 1], ac[best], ac[best + 1]);
    let den = y0 - 2.0 * y1 + y2;
    let shift = if den < 0.0 { (0.5 * (y0 - y2) / den).clamp(-0.5, 0.5) } else { 0.0 };
    Some((min_lag - 1 + best) as f64 + shift)
}

/// Half the peak-to-peak range of a signal.
pub fn half_range(x: &[f64]) -> f64 {
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if x.is_empty() { 0.0 } else { 0.5 * (hi - lo) }
}

/// A stretch of a signal that can be repeated without a visible seam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loop {
    /// First frame of the loop.
    pub start: usize,
    /// Number of frames in the loop.
    pub len: usize,
    /// RMS jump at the seam (between the loop's last frame followed by its
    /// first), in units of each channel's standard deviation, minus the typical
    /// step of the signal: 0 means the seam looks like any other step.
    pub seam_excess: f64,
}

/// Largest relative difference between a loop's length and the whole number
/// of periods it stands for.
pub const LOOP_LENGTH_TOLERANCE: f64 = 0.01;

/// Finds the loop of `n_cycles` periods whose repetition is smoothest.
///
/// `x` is frame-major with `n_channels` channels; `period` is the signal's
/// period in frames. Lengths within [`LOOP_LENGTH_TOLERANCE`] of `n_cycles ·
/// period` (the nearest whole number when no whole number is that close) and
/// every start that fits are tried, so that the loop lasts as long as the
/// measured rhythm and a CPG that learns it keeps the recording's tempo. The cost is the jump from the loop's last frame to its
/// first, compared with the jump from the last frame to the frame that really
/// follows it, and the same one frame earlier (so slope matters too), each
/// channel scaled by its standard deviation. `None` when no loop fits.
pub fn best_loop(x: &[f64], n_channels: usize, period: f64, n_cycles: usize) -> Option<Loop> {
    if n_channels == 0 || !x.len().is_multiple_of(n_channels) || !(period.is_finite() && period > 1.0) {
        return None;
    }
    let t = x.len() / n_channels;
    let target = period * n_cycles as f64;
    let (mut lo, mut hi) = (
        (target * (1.0 - LOOP_LENGTH_TOLERANCE)).ceil() as usize,
        (target * (1.0 + LOOP_LENGTH_TOLERANCE)).floor() as usize,
    );
    if lo > hi {
        (lo, hi) = (target.round() as usize, target.round() as usize);
    }
    let lo = lo.max(2);
    let hi = hi.max(lo);
    let scale: Vec<f64> = (0..n_channels)
        .map(|c| {
            let col: Vec<f64> = x.iter().skip(c).step_by(n_channels).copied().collect();
            let m = mean(&col);
            let s = (col.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / col.len() as f64).sqrt();
            if s > 0.0 { 1.0 / s } else { 1.0 }
        })
        .collect();
    let frame = |k: usize| &x[k * n_channels..(k + 1) * n_channels];
    let dist2 = |a: usize, b: usize| -> f64 {
        frame(a).iter().zip(frame(b)).zip(&scale).map(|((p, q), s)| ((p - q) * s).powi(2)).sum::<f64>()
            / n_channels as f64
    };
    let typical = (1..t).map(|k| dist2(k - 1, k).sqrt()).sum::<f64>() / (t - 1).max(1) as f64;
    let mut best: Option<(f64, usize, usize)> = None;
    for len in lo..=hi {
        // The frame after the loop (start + len) must exist for the comparison.
        for start in 1..t.saturating_sub(len) {
            let end = start + len; // first frame after the loop
            // The loop wraps from end-1 to start; the data went from end-1 to end.
            let cost = dist2(end, start) + dist2(end - 1, start - 1);
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, start, len));
            }
        }
    }
    best.map(|(cost, start, len)| Loop { start, len, seam_excess: ((cost / 2.0).sqrt() - typical).max(0.0) })
}

/// `len` frames of a looped signal: frame `k` is `cycle[(offset + k) mod period]`
/// (frame-major, `n_channels` wide).
pub fn tile(cycle: &[f64], n_channels: usize, len: usize, offset: usize) -> Vec<f64> {
    let p = cycle.len() / n_channels.max(1);
    if p == 0 {
        return Vec::new();
    }
    (0..len)
        .flat_map(|k| {
            let f = (offset + k) % p;
            cycle[f * n_channels..(f + 1) * n_channels].iter().copied()
        })
        .collect()
}

/// Aligns `model` (one or more frames, `n_channels` wide) with a periodic
/// `cycle` (one period of the teacher, frame-major): returns the circular
/// shift of the cycle that minimises the mean squared error and that error's
/// NMSE (MSE divided by the cycle's variance, averaged over channels).
pub fn align_to_cycle(model: &[f64], cycle: &[f64], n_channels: usize) -> (usize, f64) {
    let errors = shift_errors(model, cycle, n_channels);
    errors.iter().enumerate().fold((0, f64::INFINITY), |b, (k, &e)| if e < b.1 { (k, e) } else { b })
}

/// [`align_to_cycle`] to a fraction of a frame: the best whole shift moved
/// by the vertex of the parabola through its error and its two neighbours'
/// (the cycle wraps), within half a frame. Returns the shift in frames, in
/// `[0, p)`, and the error at the best whole shift.
pub fn align_to_cycle_fine(model: &[f64], cycle: &[f64], n_channels: usize) -> (f64, f64) {
    let errors = shift_errors(model, cycle, n_channels);
    let p = errors.len();
    let (k, e1) = errors.iter().enumerate().fold((0, f64::INFINITY), |b, (k, &e)| if e < b.1 { (k, e) } else { b });
    if p < 3 || !e1.is_finite() {
        return (k as f64, e1);
    }
    let (e0, e2) = (errors[(k + p - 1) % p], errors[(k + 1) % p]);
    let den = e0 - 2.0 * e1 + e2;
    let frac = if den > 0.0 { (0.5 * (e0 - e2) / den).clamp(-0.5, 0.5) } else { 0.0 };
    ((k as f64 + frac).rem_euclid(p as f64), e1)
}

/// The NMSE of `model` against the cycle at every whole shift.
fn shift_errors(model: &[f64], cycle: &[f64], n_channels: usize) -> Vec<f64> {
    let t = model.len() / n_channels.max(1);
    let p = cycle.len() / n_channels.max(1);
    if t == 0 || p == 0 {
        return vec![f64::INFINITY; p.max(1)];
    }
    let var: Vec<f64> = (0..n_channels)
        .map(|c| {
            let col: Vec<f64> = cycle.iter().skip(c).step_by(n_channels).copied().collect();
            let m = mean(&col);
            (col.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / col.len() as f64).max(f64::MIN_POSITIVE)
        })
        .collect();
    (0..p)
        .map(|shift| {
            let mut err = 0.0;
            for k in 0..t {
                let q = (shift + k) % p;
                for c in 0..n_channels {
                    let d = model[k * n_channels + c] - cycle[q * n_channels + c];
                    err += d * d / var[c];
                }
            }
            err / (t * n_channels) as f64
        })
        .collect()
}

/// Distance of a signal to a periodic orbit, over time: for each `t ≥ window − 1`,
/// the RMS difference between the last `window` frames of `y` and the best-
/// matching stretch of the repeated `cycle`, divided by the cycle's standard
/// deviation (pooled over channels; a cycle that does not move, such as a
/// one-frame posture, has none: the distance is then in the signal's own
/// units). 0 means "on the orbit"; entries before the first full window are `NaN`.
pub fn orbit_distance(y: &[f64], cycle: &[f64], n_channels: usize, window: usize) -> Vec<f64> {
    let t = y.len() / n_channels;
    let p = cycle.len() / n_channels;
    let mut out = vec![f64::NAN; t];
    if p == 0 || window == 0 || t < window {
        return out;
    }
    let m = mean(cycle);
    let var = cycle.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / cycle.len() as f64;
    let norm = if var < 1e-12 { 1.0 } else { var };
    for (end, slot) in out.iter_mut().enumerate().skip(window - 1) {
        let start = end + 1 - window;
        let mut best = f64::INFINITY;
        for shift in 0..p {
            let mut e = 0.0;
            for k in 0..window {
                let q = (shift + k) % p;
                for c in 0..n_channels {
                    let d = y[(start + k) * n_channels + c] - cycle[q * n_channels + c];
                    e += d * d;
                }
                if e >= best {
                    break;
                }
            }
            best = best.min(e);
        }
        *slot = (best / (window * n_channels) as f64 / norm).sqrt();
    }
    out
}

/// The first index `k ≥ from` after which `distance` stays below `threshold`
/// for `hold` consecutive samples (the start of that run), or `None`.
/// With [`orbit_distance`], this is when a perturbed rhythm is back on its orbit.
pub fn settling_index(distance: &[f64], from: usize, threshold: f64, hold: usize) -> Option<usize> {
    let mut run = 0;
    for (k, v) in distance.iter().enumerate().skip(from) {
        run = if *v < threshold { run + 1 } else { 0 };
        if run >= hold.max(1) {
            return Some(k + 1 - run);
        }
    }
    None
}

/// The lag (in frames, fractional) by which `b` trails `a`, searched in
/// `−max_lag..=max_lag` by the peak of their cross-correlation, refined by a
/// parabola. Both are single-channel signals of the same length.
pub fn lag(a: &[f64], b: &[f64], max_lag: usize) -> f64 {
    let n = a.len().min(b.len());
    let (ma, mb) = (mean(&a[..n]), mean(&b[..n]));
    // Mean product over the overlap, so that long lags are not penalised.
    let corr = |l: isize| -> f64 {
        let (mut s, mut k) = (0.0, 0usize);
        for i in 0..n as isize {
            let j = i + l;
            if j >= 0 && (j as usize) < n {
                s += (a[i as usize] - ma) * (b[j as usize] - mb);
                k += 1;
            }
        }
        if k > 0 { s / k as f64 } else { 0.0 }
    };
    let m = max_lag.min(n.saturating_sub(2)) as isize;
    let (mut best, mut best_v) = (0isize, f64::NEG_INFINITY);
    for l in -m..=m {
        let v = corr(l);
        if v > best_v {
            best = l;
            best_v = v;
        }
    }
    if best.abs() < m {
        let (y0, y1, y2) = (corr(best - 1), best_v, corr(best + 1));
        let den = y0 - 2.0 * y1 + y2;
        if den < 0.0 {
            return best as f64 + (0.5 * (y0 - y2) / den).clamp(-0.5, 0.5);
        }
    }
    best as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(n: usize, period: f64, phase: f64) -> Vec<f64> {
        (0..n).map(|k| (2.0 * std::f64::consts::PI * k as f64 / period + phase).sin()).collect()
    }

    #[test]
    fn period_of_a_sine_to_a_fraction_of_a_sample() {
        let x = sine(2000, 133.4, 0.3);
        let p = estimate_period(&x, 50, 300).unwrap();
        assert!((p - 133.4).abs() < 0.2, "{p}");
        assert_eq!(estimate_period(&x, 0, 10), None);
        assert!((half_range(&x) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn best_loop_of_a_sine_is_one_period() {
        let x = sine(400, 100.0, 0.0);
        let l = best_loop(&x, 1, 100.0, 1).unwrap();
        assert_eq!(l.len, 100);
        assert!(l.seam_excess < 1e-9, "{l:?}");
        let two = best_loop(&x, 1, 100.0, 2).unwrap();
        assert_eq!(two.len, 200);
    }

    #[test]
    fn orbit_distance_is_zero_on_the_orbit_and_lag_finds_the_delay() {
        let cycle = sine(100, 100.0, 0.0);
        let y = sine(300, 100.0, 1.0);
        let d = orbit_distance(&y, &cycle, 1, 25);
        assert!(d[..24].iter().all(|v| v.is_nan()));
        assert!(d[24..].iter().all(|v| *v < 0.05), "{:?}", &d[24..30]);
        let off: Vec<f64> = y.iter().map(|v| 0.5 * v).collect();
        assert!(orbit_distance(&off, &cycle, 1, 25)[50] > 0.2);
        let dist = [0.0, 0.5, 0.1, 0.1, 0.5, 0.1, 0.1, 0.1, 0.5];
        assert_eq!(settling_index(&dist, 1, 0.2, 3), Some(5));
        assert_eq!(settling_index(&dist, 1, 0.2, 4), None);
        // Over 40 periods the edge effects of the overlap average are small.
        let a = sine(4000, 100.0, 0.0);
        let b = sine(4000, 100.0, -2.0 * std::f64::consts::PI * 7.3 / 100.0);
        assert!((lag(&a, &b, 30) - 7.3).abs() < 0.1, "{}", lag(&a, &b, 30));
        assert!((lag(&b, &a, 30) + 7.3).abs() < 0.1, "{}", lag(&b, &a, 30));
    }

    #[test]
    fn alignment_recovers_the_phase() {
        let cycle = sine(100, 100.0, 0.0);
        let model = sine(250, 100.0, 2.0 * std::f64::consts::PI * 30.0 / 100.0);
        let (shift, nmse) = align_to_cycle(&model, &cycle, 1);
        assert_eq!(shift, 30);
        assert!(nmse < 1e-20);
    }

    #[test]
    fn fine_alignment_finds_a_fraction_of_a_frame() {
        let p = 120.0;
        let cycle = sine(120, p, 0.0);
        for shift in [0.0, 0.3, 17.6, 119.8] {
            let model: Vec<f64> =
                (0..360).map(|k| (2.0 * std::f64::consts::PI * (k as f64 + shift) / p).sin()).collect();
            let (s, _) = align_to_cycle_fine(&model, &cycle, 1);
            let d = (s - shift).rem_euclid(p);
            assert!(d.min(p - d) < 0.02, "shift {shift}: found {s}");
        }
    }

    #[test]
    fn a_loop_lasts_the_measured_period_within_one_percent() {
        // Strides of 100 frames, but the smoothest seam would be at 106 (a slower stride).
        let x: Vec<f64> = (0..600)
            .map(|k| {
                let k = k as f64;
                let slow = if (200.0..306.0).contains(&k) { 106.0 } else { 100.0 };
                (2.0 * std::f64::consts::PI * k / slow).sin()
            })
            .collect();
        let l = best_loop(&x, 1, 100.0, 1).unwrap();
        assert!((99..=101).contains(&l.len), "loop of {} frames for a period of 100", l.len);
    }
}

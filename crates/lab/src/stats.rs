//! Aggregates over seeds, defined once for the report, `metrics.json` and
//! the tests: the median (the mean of the two middle values of an even
//! count), the range, and a count of successes with its 95 % interval.

use serde::Serialize;

/// The median of the finite values of `v` (NaN when there are none): the
/// middle value, or the mean of the two middle values for an even count.
pub fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => s[n / 2],
        _ => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The median and range of some values (their finite ones).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    /// Finite values used.
    pub n: usize,
    /// Their median ([`median`]).
    pub median: f64,
    /// The smallest.
    pub min: f64,
    /// The largest.
    pub max: f64,
}

impl Spread {
    /// The spread of the finite values of `v` (NaN median and range when there are none).
    pub fn of(v: &[f64]) -> Spread {
        let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        let (min, max) = if f.is_empty() {
            (f64::NAN, f64::NAN)
        } else {
            f.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
        };
        Spread { n: f.len(), median: median(&f), min, max }
    }
}

/// `k` successes in `n` trials with the Wilson score interval at 95 %.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Proportion {
    /// Successes.
    pub k: usize,
    /// Trials.
    pub n: usize,
    /// Lower end of the 95 % interval of the success rate.
    pub low: f64,
    /// Upper end.
    pub high: f64,
}

/// The normal quantile of a two-sided 95 % interval.
const Z95: f64 = 1.959_963_984_540_054;

impl Proportion {
    /// `k` of `n` with its Wilson interval (for `n = 0`, the whole of [0, 1]).
    pub fn new(k: usize, n: usize) -> Proportion {
        if n == 0 {
            return Proportion { k, n, low: 0.0, high: 1.0 };
        }
        let (kf, nf) = (k.min(n) as f64, n as f64);
        let p = kf / nf;
        let z2 = Z95 * Z95;
        let centre = (p + z2 / (2.0 * nf)) / (1.0 + z2 / nf);
        let half = Z95 / (1.0 + z2 / nf) * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
        Proportion { k, n, low: (centre - half).max(0.0), high: (centre + half).min(1.0) }
    }

    /// The successes among `flags`.
    pub fn count(flags: impl IntoIterator<Item = bool>) -> Proportion {
        let (mut k, mut n) = (0, 0);
        for f in flags {
            n += 1;
            k += usize::from(f);
        }
        Proportion::new(k, n)
    }
}

/// Whether a comparison of `value` with `limit`, both printed with `digits`
/// decimals, is decided by less than the report can show: they print the
/// same, or lie within half a unit of the last printed digit.
pub fn at_limit(value: f64, limit: f64, digits: usize) -> bool {
    let scale = 10f64.powi(digits as i32);
    value.is_finite()
        && limit.is_finite()
        && ((value * scale).round() == (limit * scale).round() || (value - limit).abs() < 0.5 / scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&[1.0, f64::NAN, 3.0]), 2.0);
        assert!(median(&[]).is_nan());
        let s = Spread::of(&[0.5, f64::INFINITY, 0.1, 0.3, 0.2]);
        assert_eq!((s.n, s.median, s.min, s.max), (4, 0.25, 0.1, 0.5));
    }

    #[test]
    fn wilson_intervals_match_published_values() {
        // 8 of 10: 0.490–0.943; 10 of 10: 0.722–1 (Wilson 1927, as tabulated by Newcombe 1998).
        let p = Proportion::new(8, 10);
        assert!((p.low - 0.4902).abs() < 1e-4 && (p.high - 0.9433).abs() < 1e-4, "{p:?}");
        let q = Proportion::new(10, 10);
        assert!((q.low - 0.7225).abs() < 1e-4 && q.high > 1.0 - 1e-12, "{q:?}");
        let z = Proportion::new(0, 10);
        assert!(z.low < 1e-12 && (z.high - 0.2775).abs() < 1e-4, "{z:?}");
        assert_eq!(Proportion::count([true, false, true]).k, 2);
    }

    #[test]
    fn a_comparison_closer_than_the_printed_digits_is_at_the_limit() {
        assert!(at_limit(0.19666, 0.19675, 3));
        assert!(!at_limit(0.1960, 0.1975, 3));
        // 12.44 mm against 12.38 mm: both print 12.4.
        assert!(at_limit(12.44, 12.38, 1) && !at_limit(12.46, 12.34, 1));
        assert!(!at_limit(f64::NAN, 0.1, 3));
    }
}

//! What a real IMU tells the controller: the trunk's orientation and rates
//! as the simulator knows them, read late, with a constant tilt bias, a
//! heading that drifts, and noise (`cpg-sim`'s `--imu-*` options).
//!
//! At step time `t`, with the true readings of `latency` ago (the first
//! reading before there were any), the controller receives:
//!
//! ```text
//! roll'  = roll  + bias_roll  + σ·n₁        rate_roll'  = rate_roll  + σ/s·n₄
//! pitch' = pitch + bias_pitch + σ·n₂        rate_pitch' = rate_pitch + σ/s·n₅
//! yaw'   = yaw   + drift·t    + σ·n₃
//! ```
//!
//! `n₁…n₅` standard normal draws, new every reading, from the stream of
//! `seed`. No faults is the simulator's reading, bit for bit. Nothing is
//! allocated after [`Imu::new`].

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

use crate::control::{Sensors, tilt};

/// The longest latency an IMU may have, ms.
pub const MAX_LATENCY_MS: f64 = 1000.0;
/// The largest bias, noise or drift, degrees (or degrees per second).
pub const MAX_FAULT_DEG: f64 = 90.0;

/// An IMU's faults (all zero: a perfect one).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuFaults {
    /// Standard deviation of the noise on each reading's roll, pitch and yaw,
    /// degrees; the rates get the same number in degrees per second.
    pub noise_deg: f64,
    /// A constant offset of the roll the IMU reports, degrees.
    pub bias_roll_deg: f64,
    /// A constant offset of the pitch the IMU reports, degrees.
    pub bias_pitch_deg: f64,
    /// How fast the reported heading drifts, degrees per second.
    pub yaw_drift_deg_s: f64,
    /// How old each reading is when the controller gets it, ms.
    pub latency_ms: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl ImuFaults {
    /// Whether the faults are usable: finite, within their bounds.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("noise_deg", self.noise_deg),
            ("bias_roll_deg", self.bias_roll_deg),
            ("bias_pitch_deg", self.bias_pitch_deg),
            ("yaw_drift_deg_s", self.yaw_drift_deg_s),
        ] {
            if !(v.is_finite() && v.abs() <= MAX_FAULT_DEG) {
                return Err(format!("imu {name} = {v}: expected a number within ±{MAX_FAULT_DEG}"));
            }
        }
        if self.noise_deg < 0.0 {
            return Err(format!("imu noise_deg = {}: expected 0 or more", self.noise_deg));
        }
        if !(self.latency_ms.is_finite() && (0.0..=MAX_LATENCY_MS).contains(&self.latency_ms)) {
            return Err(format!("imu latency_ms = {}: expected 0 to {MAX_LATENCY_MS} ms", self.latency_ms));
        }
        Ok(())
    }

    fn is_perfect(&self) -> bool {
        let ImuFaults { noise_deg, bias_roll_deg, bias_pitch_deg, yaw_drift_deg_s, latency_ms, seed: _ } = *self;
        [noise_deg, bias_roll_deg, bias_pitch_deg, yaw_drift_deg_s, latency_ms].iter().all(|v| *v == 0.0)
    }
}

/// One reading the IMU keeps: the orientation and the two rates.
type Reading = ([f64; 4], [f64; 2]);

/// An IMU with its faults, read once per control step.
#[derive(Debug, Clone)]
pub struct Imu {
    faults: ImuFaults,
    /// The last `delay` true readings (one slot when there is no delay), oldest at `head`.
    ring: Vec<Reading>,
    delay: usize,
    head: usize,
    primed: bool,
    /// No faults at all: the truth passes unchanged (decided once, not per reading).
    perfect: bool,
    rng: ChaCha8Rng,
}

impl Imu {
    /// An IMU read every `dt_s` seconds.
    pub fn new(faults: ImuFaults, dt_s: f64) -> Result<Imu, String> {
        faults.check()?;
        if !(dt_s.is_finite() && dt_s > 0.0) {
            return Err(format!("the control step {dt_s} s: expected more than 0"));
        }
        let delay = (faults.latency_ms / 1000.0 / dt_s).round() as usize;
        if delay > 1_000_000 {
            return Err(format!("a latency of {} ms at a step of {dt_s} s: over a million steps", faults.latency_ms));
        }
        Ok(Imu {
            faults,
            ring: vec![([1.0, 0.0, 0.0, 0.0], [0.0; 2]); delay.max(1)],
            delay,
            head: 0,
            primed: false,
            perfect: faults.is_perfect(),
            rng: ChaCha8Rng::seed_from_u64(faults.seed),
        })
    }

    /// The faults.
    pub fn faults(&self) -> &ImuFaults {
        &self.faults
    }

    /// What the controller reads at `t_s` when the truth is `s` (the soles'
    /// forces pass unchanged).
    pub fn read(&mut self, t_s: f64, s: &Sensors) -> Sensors {
        if self.perfect {
            return *s;
        }
        let now = (s.quat, s.gyro);
        if !self.primed {
            self.ring.iter_mut().for_each(|r| *r = now);
            self.primed = true;
        }
        // The ring holds the last `delay` readings: the oldest is read, the newest takes its place.
        let (quat, gyro) = if self.delay == 0 {
            now
        } else {
            let old = std::mem::replace(&mut self.ring[self.head], now);
            self.head = (self.head + 1) % self.ring.len();
            old
        };
        let f = self.faults;
        let sigma = f.noise_deg.to_radians();
        let rng = &mut self.rng;
        let mut n = || {
            if sigma > 0.0 {
                let z: f64 = StandardNormal.sample(rng);
                sigma * z
            } else {
                0.0
            }
        };
        let (roll, pitch, yaw) = tilt(quat);
        let roll = roll + f.bias_roll_deg.to_radians() + n();
        let pitch = pitch + f.bias_pitch_deg.to_radians() + n();
        let yaw = yaw + (f.yaw_drift_deg_s * t_s).to_radians() + n();
        let gyro = [gyro[0] + n(), gyro[1] + n()];
        Sensors { quat: from_tilt(roll, pitch, yaw), gyro, touch_n: s.touch_n }
    }
}

/// The quaternion `[w, x, y, z]` of roll, pitch and yaw (rad), the inverse of [`tilt`].
pub fn from_tilt(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]
}

#[cfg(test)]
mod tests {
    use super::*;

    const LEVEL: Sensors = Sensors { quat: [1.0, 0.0, 0.0, 0.0], gyro: [0.0; 2], touch_n: [30.0, 40.0] };

    fn pitched(deg: f64) -> Sensors {
        Sensors { quat: from_tilt(0.0, deg.to_radians(), 0.0), gyro: [0.0, 0.1], ..LEVEL }
    }

    #[test]
    fn tilt_and_from_tilt_are_inverse() {
        for (r, p, y) in [(0.1, -0.2, 0.3), (-0.5, 0.4, -2.9), (0.0, 0.0, 0.0)] {
            let (a, b, c) = tilt(from_tilt(r, p, y));
            assert!((a - r).abs() < 1e-12 && (b - p).abs() < 1e-12 && (c - y).abs() < 1e-12, "{a} {b} {c}");
        }
    }

    #[test]
    fn a_perfect_imu_reads_the_truth_bit_for_bit() {
        let mut imu = Imu::new(ImuFaults { seed: 9, ..ImuFaults::default() }, 0.001).unwrap();
        let s = pitched(3.0);
        let r = imu.read(1.0, &s);
        assert_eq!((r.quat, r.gyro, r.touch_n), (s.quat, s.gyro, s.touch_n));
    }

    #[test]
    fn latency_bias_and_drift_do_what_they_say() {
        let faults = ImuFaults { latency_ms: 20.0, bias_roll_deg: 2.0, yaw_drift_deg_s: 1.0, ..ImuFaults::default() };
        let mut imu = Imu::new(faults, 0.001).unwrap();
        // Level for 100 steps, then pitched 5°: the controller sees it 20 steps later.
        let mut seen = Vec::new();
        for k in 0..200 {
            let s = if k < 100 { LEVEL } else { pitched(5.0) };
            let r = imu.read(k as f64 * 0.001, &s);
            let (roll, pitch, yaw) = tilt(r.quat);
            assert!((roll.to_degrees() - 2.0).abs() < 1e-9, "the roll bias: {}", roll.to_degrees());
            assert!((yaw.to_degrees() - k as f64 * 0.001).abs() < 1e-9, "the drift: {}", yaw.to_degrees());
            assert_eq!(r.touch_n, LEVEL.touch_n, "the soles are not the IMU's");
            seen.push(pitch.to_degrees());
        }
        assert!(seen[119].abs() < 1e-9 && (seen[120] - 5.0).abs() < 1e-9, "{} {}", seen[119], seen[120]);
    }

    #[test]
    fn noise_is_seeded_and_of_its_size() {
        let faults = ImuFaults { noise_deg: 1.0, seed: 4, ..ImuFaults::default() };
        let run = |f: ImuFaults| {
            let mut imu = Imu::new(f, 0.001).unwrap();
            (0..4000).map(|k| tilt(imu.read(k as f64 * 0.001, &LEVEL).quat).1.to_degrees()).collect::<Vec<_>>()
        };
        let (a, b) = (run(faults), run(faults));
        assert_eq!(a, b, "the same seed, the same noise");
        assert_ne!(a, run(ImuFaults { seed: 5, ..faults }), "another seed, other noise");
        let sd = (a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64).sqrt();
        assert!((sd - 1.0).abs() < 0.05, "the pitch noise's standard deviation {sd:.3}°");
    }

    #[test]
    fn bad_faults_are_refused_by_name() {
        for (f, word) in [
            (ImuFaults { noise_deg: -1.0, ..ImuFaults::default() }, "noise_deg"),
            (ImuFaults { latency_ms: 2000.0, ..ImuFaults::default() }, "latency_ms"),
            (ImuFaults { bias_roll_deg: f64::NAN, ..ImuFaults::default() }, "bias_roll_deg"),
            (ImuFaults { yaw_drift_deg_s: 1e9, ..ImuFaults::default() }, "yaw_drift_deg_s"),
        ] {
            let e = Imu::new(f, 0.001).unwrap_err();
            assert!(e.contains(word), "{e}");
        }
        assert!(Imu::new(ImuFaults::default(), 0.0).is_err());
    }
}

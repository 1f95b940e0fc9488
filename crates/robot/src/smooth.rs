//! Smooth resampling and speed limits of joint trajectories.
//!
//! - [`natural_spline`] interpolates samples by a natural cubic spline: positions,
//!   velocities and accelerations are continuous (the acceleration is piecewise
//!   linear), so resampling 120 Hz to 1 kHz adds no jumps at the knots.
//! - [`Limiter`] follows a target joint angle one tick at a time within a position
//!   range, a velocity bound and an acceleration bound, braking early enough
//!   to stop at a target that stands still. It allocates nothing and needs no
//!   future samples, so a live control loop (`cpg stream`) and a file
//!   (`cpg hoap2`) limit alike.

/// Second derivatives of the natural cubic spline through `y` (unit spacing):
/// the tridiagonal system `m[i-1] + 4 m[i] + m[i+1] = 6 (y[i+1] - 2 y[i] + y[i-1])`
/// with `m[0] = m[n-1] = 0`, solved by the Thomas algorithm.
fn second_derivatives(y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    // Forward sweep over the interior unknowns 1..n-1.
    let mut c = vec![0.0; n];
    let mut d = vec![0.0; n];
    for i in 1..n - 1 {
        let rhs = 6.0 * (y[i + 1] - 2.0 * y[i] + y[i - 1]);
        let denom = 4.0 - if i > 1 { c[i - 1] } else { 0.0 };
        c[i] = 1.0 / denom;
        d[i] = (rhs - if i > 1 { d[i - 1] } else { 0.0 }) / denom;
    }
    for i in (1..n - 1).rev() {
        m[i] = d[i] - c[i] * m[i + 1];
    }
    m
}

/// Position, velocity and acceleration (per unit of the sample index) of the
/// natural cubic spline through `y` at `x` (0 ≤ x ≤ len − 1).
fn eval(y: &[f64], m: &[f64], x: f64) -> (f64, f64, f64) {
    let n = y.len();
    if n == 1 {
        return (y[0], 0.0, 0.0);
    }
    let i = (x.floor() as usize).min(n - 2);
    let t = x - i as f64;
    let (y0, y1, m0, m1) = (y[i], y[i + 1], m[i], m[i + 1]);
    let a = 1.0 - t;
    let p = a * y0 + t * y1 + ((a * a * a - a) * m0 + (t * t * t - t) * m1) / 6.0;
    let v = y1 - y0 + ((1.0 - 3.0 * a * a) * m0 + (3.0 * t * t - 1.0) * m1) / 6.0;
    let acc = a * m0 + t * m1;
    (p, v, acc)
}

/// One joint's samples at `rate_in_hz`, resampled to `n_out` samples at
/// `rate_out_hz` by a natural cubic spline: `(positions, velocities per s,
/// accelerations per s²)`. Samples past the last input are held at its value.
pub fn natural_spline(y: &[f64], rate_in_hz: f64, rate_out_hz: f64, n_out: usize) -> [Vec<f64>; 3] {
    let m = second_derivatives(y);
    let last = (y.len().max(1) - 1) as f64;
    let mut out = [Vec::with_capacity(n_out), Vec::with_capacity(n_out), Vec::with_capacity(n_out)];
    for k in 0..n_out {
        let x = k as f64 * rate_in_hz / rate_out_hz;
        let (p, v, a) = if x <= last { eval(y, &m, x) } else { (y[y.len() - 1], 0.0, 0.0) };
        out[0].push(p);
        out[1].push(v * rate_in_hz);
        out[2].push(a * rate_in_hz * rate_in_hz);
    }
    out
}

/// The fastest speed `v` with `v·dt + v²/(2a) ≤ distance`: one more tick at
/// `v`, then a stop at `a`. If `v` fits `distance`, the same bound one tick
/// later is at least `v − a·dt`, so ticks that keep to it always can stop in time.
fn stopping_speed(a: f64, dt: f64, distance: f64) -> f64 {
    (a * ((dt * dt + 2.0 * distance / a).sqrt() - dt)).max(0.0)
}

/// Bounds a joint is kept within.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Lowest angle, radians.
    pub lower_rad: f64,
    /// Highest angle, radians.
    pub upper_rad: f64,
    /// Largest speed, rad/s.
    pub velocity_rad_s: f64,
    /// Largest acceleration, rad/s².
    pub acceleration_rad_s2: f64,
}

/// What a [`Limiter`] changed, counted over the ticks it ran.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct LimitCounts {
    /// Ticks whose target lay outside the position range.
    pub position: usize,
    /// Ticks at which the speed bound held the joint back.
    pub velocity: usize,
    /// Ticks at which the acceleration bound held the joint back.
    pub acceleration: usize,
    /// Largest distance between the target and the commanded angle, radians.
    pub max_lag_rad: f64,
}

/// Follows a target angle tick by tick within [`Bounds`] (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Limiter {
    bounds: Bounds,
    dt_s: f64,
    position_rad: f64,
    velocity_rad_s: f64,
    acceleration_rad_s2: f64,
    last_target_rad: f64,
    started: bool,
    /// What was changed so far.
    pub counts: LimitCounts,
}

impl Limiter {
    /// A limiter for ticks of `dt_s` seconds.
    pub fn new(bounds: Bounds, dt_s: f64) -> Limiter {
        Limiter {
            bounds,
            dt_s,
            position_rad: 0.0,
            velocity_rad_s: 0.0,
            acceleration_rad_s2: 0.0,
            last_target_rad: 0.0,
            started: false,
            counts: LimitCounts::default(),
        }
    }

    /// Starts at `position_rad` (clamped to the range) moving at
    /// `velocity_rad_s` (clamped to the speed bound): the state a trajectory
    /// already in motion begins in, so that its first ticks are not spent
    /// accelerating from rest. The next [`Limiter::step`] is an ordinary tick.
    pub fn start(&mut self, position_rad: f64, velocity_rad_s: f64) {
        let b = self.bounds;
        self.position_rad = position_rad.clamp(b.lower_rad, b.upper_rad);
        self.velocity_rad_s = velocity_rad_s.clamp(-b.velocity_rad_s, b.velocity_rad_s);
        self.acceleration_rad_s2 = 0.0;
        self.last_target_rad = self.position_rad;
        self.started = true;
    }

    /// The commanded angle, velocity and acceleration after the last tick.
    pub fn state(&self) -> (f64, f64, f64) {
        (self.position_rad, self.velocity_rad_s, self.acceleration_rad_s2)
    }

    /// One tick toward `target_rad`; returns the commanded angle. The first
    /// tick starts at the (position-clamped) target at rest.
    pub fn step(&mut self, target_rad: f64) -> f64 {
        let b = self.bounds;
        let target = target_rad.clamp(b.lower_rad, b.upper_rad);
        if target != target_rad {
            self.counts.position += 1;
        }
        if !self.started {
            self.started = true;
            self.position_rad = target;
            self.last_target_rad = target;
            return target;
        }
        let dt = self.dt_s;
        let error = target - self.position_rad;
        let target_velocity = (target - self.last_target_rad) / dt;
        self.last_target_rad = target;
        let dv = b.acceleration_rad_s2 * dt;
        let v0 = self.velocity_rad_s;
        // Reach the target this tick when the bounds allow it; otherwise close in
        // on it no faster than a stop relative to its motion allows (v² = 2 a e),
        // so that a held or steadily moving target is met without overshoot.
        let reach = error / dt;
        // (landing must also leave the target's own speed within reach of the next tick).
        let mut wanted =
            if (reach - v0).abs() <= dv && (reach - target_velocity).abs() <= dv && reach.abs() <= b.velocity_rad_s {
                reach
            } else {
                // The distance is what is left after moving with the target for this tick.
                let left = error - target_velocity * dt;
                target_velocity + stopping_speed(b.acceleration_rad_s2, dt, left.abs()) * left.signum()
            };
        // The position limits are walls: never faster toward one than a stop before it allows.
        let toward_wall = if wanted > 0.0 { b.upper_rad - self.position_rad } else { self.position_rad - b.lower_rad };
        let wall = stopping_speed(b.acceleration_rad_s2, dt, toward_wall.max(0.0));
        if wanted.abs() > wall {
            wanted = wall * wanted.signum();
        }
        if wanted.abs() > b.velocity_rad_s {
            wanted = b.velocity_rad_s * wanted.signum();
            self.counts.velocity += 1;
        }
        let mut v = wanted.clamp(v0 - dv, v0 + dv);
        if v != wanted {
            self.counts.acceleration += 1;
        }
        // Still moving toward a wall (the acceleration bound may not let it turn yet): as slow as allowed.
        let toward_wall = if v > 0.0 { b.upper_rad - self.position_rad } else { self.position_rad - b.lower_rad };
        let wall = stopping_speed(b.acceleration_rad_s2, dt, toward_wall.max(0.0));
        if v.abs() > wall {
            let slowest = if v.signum() == v0.signum() { (v0.abs() - dv).max(0.0) } else { 0.0 };
            v = v.signum() * wall.max(slowest);
        }
        let mut p = self.position_rad + v * dt;
        let mut v_now = v;
        if p < b.lower_rad || p > b.upper_rad {
            p = p.clamp(b.lower_rad, b.upper_rad);
            v_now = (p - self.position_rad) / dt;
        }
        self.acceleration_rad_s2 = (v_now - v0) / dt;
        self.velocity_rad_s = v_now;
        self.position_rad = p;
        self.counts.max_lag_rad = self.counts.max_lag_rad.max((target_rad - p).abs());
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spline_passes_through_its_samples_and_has_continuous_acceleration() {
        let y: Vec<f64> = (0..40).map(|k| (k as f64 * 0.3).sin()).collect();
        let [p, _, _] = natural_spline(&y, 10.0, 100.0, 391);
        for (k, yk) in y.iter().enumerate() {
            assert!((p[k * 10] - yk).abs() < 1e-12, "knot {k}");
        }
        // Position, velocity and acceleration agree from both sides of every inner knot.
        let m = second_derivatives(&y);
        for k in 1..y.len() - 1 {
            let (l, r) = (eval(&y, &m, k as f64 - 1e-9), eval(&y, &m, k as f64 + 1e-9));
            assert!(
                (l.0 - r.0).abs() < 1e-7 && (l.1 - r.1).abs() < 1e-6 && (l.2 - r.2).abs() < 1e-6,
                "knot {k}: {l:?} {r:?}"
            );
        }
        // A sine at 10 Hz sampling: the spline's derivative is close to the true one.
        let [_, v, _] = natural_spline(&y, 10.0, 10.0, 40);
        for (k, vk) in v.iter().enumerate().take(35).skip(5) {
            let truth = 3.0 * (k as f64 * 0.3).cos();
            assert!((vk - truth).abs() < 0.02, "k {k}: {vk} vs {truth}");
        }
    }

    #[test]
    fn the_limiter_keeps_every_bound_and_tracks_a_slow_target_exactly() {
        let b = Bounds { lower_rad: -1.0, upper_rad: 1.0, velocity_rad_s: 5.0, acceleration_rad_s2: 100.0 };
        let dt = 0.001;
        // A step far beyond the position range, then a fast sine that needs both bounds.
        let mut l = Limiter::new(b, dt);
        let mut prev = (0.0, 0.0);
        for k in 0..4000 {
            let t = k as f64 * dt;
            let target = if k < 1000 { if k < 10 { 0.0 } else { 3.0 } } else { 0.9 * (t * 40.0).sin() };
            let p = l.step(target);
            let (_, v, a) = l.state();
            assert!((-1.0..=1.0).contains(&p));
            assert!(v.abs() <= 5.0 + 1e-9, "tick {k}: v {v}");
            if k > 0 {
                assert!(a.abs() <= 100.0 + 1e-6, "tick {k}: a {a}");
                assert!(((p - prev.0) / dt - v).abs() < 1e-9);
            }
            prev = (p, v);
        }
        assert!(l.counts.position > 0 && l.counts.velocity > 0 && l.counts.acceleration > 0, "{:?}", l.counts);
        // A slow sine inside every bound: the limiter starts at rest, catches up within
        // 50 ms (the sine starts at 1 rad/s), then follows it to within rounding.
        let mut l = Limiter::new(b, dt);
        for k in 0..3000 {
            let target = 0.5 * (k as f64 * dt * 2.0).sin();
            let p = l.step(target);
            assert!((p - target).abs() < if k < 50 { 0.01 } else { 1e-9 }, "tick {k}: {p} vs {target}");
        }
        assert_eq!((l.counts.position, l.counts.velocity), (0, 0));
    }

    #[test]
    fn a_limiter_started_in_motion_follows_at_once() {
        let b = Bounds { lower_rad: -3.0, upper_rad: 3.0, velocity_rad_s: 5.0, acceleration_rad_s2: 100.0 };
        let dt = 0.001;
        // 1 Hz, 0.5 rad: up to 3.1 rad/s and 19.7 rad/s², inside every bound.
        let target = |k: usize| 0.5 * (2.0 * std::f64::consts::PI * k as f64 * dt).sin();
        let speed0 = 0.5 * 2.0 * std::f64::consts::PI;
        let mut rest = Limiter::new(b, dt);
        let mut moving = Limiter::new(b, dt);
        moving.start(target(0), speed0);
        let (mut lag_rest, mut lag_moving) = (0.0f64, 0.0f64);
        for k in 1..200 {
            lag_rest = lag_rest.max((rest.step(target(k)) - target(k)).abs());
            lag_moving = lag_moving.max((moving.step(target(k)) - target(k)).abs());
        }
        assert!(lag_moving < 1e-9, "in motion from the start: lag {lag_moving}");
        assert!(lag_rest > 1e-3 && rest.counts.acceleration > 0, "from rest it must catch up: lag {lag_rest}");
        assert_eq!(moving.counts.acceleration, 0);
    }
}

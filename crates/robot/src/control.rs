//! The walk's controller inside a physics loop, once per physics step: a
//! planned walk played on its gait clock (with phase resetting at touch-down),
//! or a generator stepped at its own rate and interpolated between its steps,
//! the balance feedback from a simulated IMU, and every command moved by at
//! most the servos' speed and kept in their range.
//!
//! [`WalkController::control`] reads the sensors and writes the servos'
//! commands; [`WalkController::measure`] reads the servos' forces after the
//! physics step (largest torque, mechanical work). Neither allocates. The
//! simulator itself is the caller's (`cpg.sim` drives MuJoCo with it): the
//! controller sees plain slices, so it is tested here without one.
//!
//! The arithmetic is written in the order `cpg.sim` wrote it in NumPy before
//! it moved here (the same IEEE operations, the same libm calls), so a run's
//! measures did not change.

use serde::{Deserialize, Serialize};

/// Balance feedback gains: `offset = -(kp·angle + kd·rate)` per joint group
/// (rad per rad, rad per rad/s; 0: none), and phase resetting at touch-down.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Gains {
    /// Trunk pitch on both ankles' pitch.
    pub ankle_pitch_kp: f64,
    /// Trunk pitch rate on both ankles' pitch.
    pub ankle_pitch_kd: f64,
    /// Trunk roll on both ankles' roll.
    pub ankle_roll_kp: f64,
    /// Trunk roll rate on both ankles' roll.
    pub ankle_roll_kd: f64,
    /// Trunk pitch on both hips' pitch.
    pub hip_pitch_kp: f64,
    /// Trunk roll on both hips' roll.
    pub hip_roll_kp: f64,
    /// Trunk heading on both hips' yaw (steering).
    pub hip_yaw_kp: f64,
    /// The gait clock waits for a late touch-down and jumps to an early one.
    pub phase_reset: bool,
    /// The longest wait per step for a late touch-down, s.
    pub max_wait_s: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Gains {
            ankle_pitch_kp: 0.0,
            ankle_pitch_kd: 0.0,
            ankle_roll_kp: 0.0,
            ankle_roll_kd: 0.0,
            hip_pitch_kp: 0.0,
            hip_roll_kp: 0.0,
            hip_yaw_kp: 0.0,
            phase_reset: false,
            max_wait_s: 0.1,
        }
    }
}

/// The leg joints the attitude feedback moves, by their role in the robot's
/// spec ([`crate::spec::LegSpec`]), in the order of [`WalkController::feedback`]'s terms.
pub const FEEDBACK_ROLES: [&str; 5] = ["ankle_pitch", "ankle_roll", "hip_pitch", "hip_roll", "hip_yaw"];

/// Roll, pitch and yaw (rad) of an orientation quaternion `[w, x, y, z]`.
pub fn tilt(q: [f64; 4]) -> (f64, f64, f64) {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    (roll, pitch, yaw)
}

/// NumPy's pairwise sum of a float64 array (`np.add.reduce`), to the bit:
/// eight running sums over blocks of eight, combined as a tree.
pub fn pairwise_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        return a.iter().fold(0.0, |s, v| s + v);
    }
    if n > 128 {
        let mut half = n / 2;
        half -= half % 8;
        return pairwise_sum(&a[..half]) + pairwise_sum(&a[half..]);
    }
    let mut r = [0.0; 8];
    r.copy_from_slice(&a[..8]);
    let whole = n - n % 8;
    let mut i = 8;
    while i < whole {
        for (k, rk) in r.iter_mut().enumerate() {
            *rk += a[i + k];
        }
        i += 8;
    }
    let mut s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for v in &a[whole..] {
        s += v;
    }
    s
}

/// A planned walk: the joints' angles on a clock, and the plan's touch-downs.
#[derive(Debug, Clone)]
pub struct Plan {
    clock_s: Vec<f64>,
    angles_rad: Vec<f64>,
    joints: usize,
    /// Samples per second when the clock is uniform.
    uniform_hz: Option<f64>,
    /// (time, foot: 0 left, 1 right) where the swing foot lands.
    landings: Vec<(f64, usize)>,
}

impl Plan {
    /// `clock_s` from 0 (at least two increasing times), `angles_rad` one
    /// row of `joints` values per time, `landings` the touch-downs (time,
    /// foot 0 left or 1 right) in time order.
    pub fn new(
        clock_s: Vec<f64>,
        angles_rad: Vec<f64>,
        joints: usize,
        landings: Vec<(f64, usize)>,
    ) -> Result<Plan, String> {
        let n = clock_s.len();
        if n < 2 || joints == 0 || angles_rad.len() != n * joints {
            return Err(format!(
                "a plan of {n} times and {} angles for {joints} joints (expected at least 2 times and one row of angles per time)",
                angles_rad.len()
            ));
        }
        if clock_s.windows(2).any(|w| w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater)) {
            return Err("the plan's times must increase".into());
        }
        if landings.iter().any(|&(_, f)| f > 1) {
            return Err("a landing's foot must be 0 (left) or 1 (right)".into());
        }
        // NumPy's allclose(diff, diff[0], rtol=1e-6, atol=1e-9).
        let d0 = clock_s[1] - clock_s[0];
        let uniform = clock_s.windows(2).all(|w| ((w[1] - w[0]) - d0).abs() <= 1e-9 + 1e-6 * d0.abs());
        Ok(Plan { uniform_hz: uniform.then_some(1.0 / d0), clock_s, angles_rad, joints, landings })
    }

    fn row(&self, i: usize) -> &[f64] {
        &self.angles_rad[i * self.joints..(i + 1) * self.joints]
    }

    /// The frame at clock `c`, linearly interpolated, into `out`.
    fn frame_at(&self, c: f64, out: &mut [f64]) {
        let last = self.clock_s.len() - 1;
        if let Some(hz) = self.uniform_hz {
            let x = (c * hz).max(0.0).min(last as f64);
            let i = (x as usize).min(last - 1);
            let f = x - i as f64;
            for ((o, a), b) in out.iter_mut().zip(self.row(i)).zip(self.row(i + 1)) {
                *o = a * (1.0 - f) + b * f;
            }
            return;
        }
        // NumPy's interp: held at the ends, a slope between the neighbours.
        let t = &self.clock_s;
        if c <= t[0] || c >= t[last] {
            out.copy_from_slice(self.row(if c <= t[0] { 0 } else { last }));
            return;
        }
        let j = t.partition_point(|&v| v <= c) - 1;
        for (k, o) in out.iter_mut().enumerate() {
            let (a, b) = (self.row(j)[k], self.row(j + 1)[k]);
            *o = (b - a) / (t[j + 1] - t[j]) * (c - t[j]) + a;
        }
    }

    /// The clock's last time.
    pub fn end_s(&self) -> f64 {
        self.clock_s[self.clock_s.len() - 1]
    }
}

/// What drives after the hand-over: a generator of joint angles in degrees.
pub trait Drive {
    /// Why a step failed.
    type Error;
    /// One step with these control values; the outputs in degrees.
    fn step(&mut self, control: &[f64]) -> Result<&[f64], Self::Error>;
}

/// The control inputs over a run: a base setting, a cosine ramp of the tempo
/// input to `base × tempo` from `tempo_at_s`, of the walk input from 0 up to
/// its base from `start_at_s` (0 before it: standing), and down to 0 from
/// `stop_at_s`.
#[derive(Debug, Clone)]
pub struct Schedule {
    /// Each control input's value from the start.
    pub base: Vec<f64>,
    /// Which input is the tempo (`u_tempo`), if any.
    pub tempo_input: Option<usize>,
    /// Which input is walk/stand (`u_walk`), if any.
    pub walk_input: Option<usize>,
    /// The ramp of the tempo change, s.
    pub tempo_ramp_s: f64,
    /// When the walk input starts falling to 0, if ever.
    pub stop_at_s: Option<f64>,
    /// The ramp of the stop, s.
    pub stop_ramp_s: f64,
    /// When the walk input starts rising from 0 (standing until then), if the run starts standing.
    pub start_at_s: Option<f64>,
    /// The ramp of the start, s.
    pub start_ramp_s: f64,
}

/// The generator after the hand-over and its interpolation state.
#[derive(Debug)]
pub struct Driven<D> {
    /// The generator.
    pub drive: D,
    /// The joint (index into the plan's joints) of each of its outputs.
    pub joints: Vec<usize>,
    /// Its steps per second at tempo 1.
    pub rate_hz: f64,
    /// When it takes over from the plan, s.
    pub handover_s: f64,
    /// Its control inputs over the run.
    pub schedule: Schedule,
    prev_rad: Vec<f64>,
    next_rad: Vec<f64>,
    due_s: f64,
    u: Vec<f64>,
}

impl<D: Drive> Driven<D> {
    /// A generator whose last output was `first_rad` (its phase matched to the
    /// plan's at `handover_s`).
    pub fn new(
        drive: D,
        joints: Vec<usize>,
        rate_hz: f64,
        handover_s: f64,
        first_rad: &[f64],
        schedule: Schedule,
    ) -> Result<Driven<D>, String> {
        if first_rad.len() != joints.len() {
            return Err(format!("{} first outputs for {} driven joints", first_rad.len(), joints.len()));
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(format!("the generator's rate {rate_hz} Hz: expected a positive number"));
        }
        schedule.check()?;
        let u = schedule.base.clone();
        Ok(Driven {
            drive,
            joints,
            rate_hz,
            handover_s,
            schedule,
            prev_rad: first_rad.to_vec(),
            next_rad: first_rad.to_vec(),
            due_s: handover_s,
            u,
        })
    }
}

impl Schedule {
    /// Whether the tempo and walk inputs name inputs of `base`.
    pub fn check(&self) -> Result<(), String> {
        match self.tempo_input.max(self.walk_input) {
            Some(k) if k >= self.base.len() => {
                Err(format!("a control input's index {k} beyond the {} inputs", self.base.len()))
            }
            _ => Ok(()),
        }
    }

    /// The control values at `t_s` with a tempo factor `tempo` from
    /// `tempo_at_s` on, into `u` (one per input).
    pub fn at(&self, t_s: f64, tempo: f64, tempo_at_s: f64, u: &mut [f64]) {
        use std::f64::consts::PI;
        u.copy_from_slice(&self.base);
        let progress = |from: f64, over: f64| if over <= 0.0 { 1.0 } else { ((t_s - from) / over).min(1.0) };
        if let Some(k) = self.tempo_input
            && t_s >= tempo_at_s
        {
            let w = 0.5 - 0.5 * (PI * progress(tempo_at_s, self.tempo_ramp_s)).cos();
            u[k] = self.base[k] * (1.0 + (tempo - 1.0) * w);
        }
        if let (Some(k), Some(at)) = (self.walk_input, self.start_at_s) {
            u[k] =
                if t_s < at { 0.0 } else { self.base[k] * (0.5 - 0.5 * (PI * progress(at, self.start_ramp_s)).cos()) };
        }
        if let (Some(k), Some(at)) = (self.walk_input, self.stop_at_s)
            && t_s >= at
        {
            u[k] *= 0.5 + 0.5 * (PI * progress(at, self.stop_ramp_s)).cos();
        }
    }
}

/// The sensors the controller reads each step.
#[derive(Debug, Clone, Copy)]
pub struct Sensors {
    /// The trunk's orientation `[w, x, y, z]`.
    pub quat: [f64; 4],
    /// The trunk's roll and pitch rates, rad/s.
    pub gyro: [f64; 2],
    /// The left and right soles' normal force, N.
    pub touch_n: [f64; 2],
}

/// The controller of one run: see the module's documentation.
#[derive(Debug)]
pub struct WalkController<D> {
    plan: Plan,
    gains: Gains,
    dt_s: f64,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// (joint, feedback group) of every joint the feedback moves.
    fed: Vec<(usize, usize)>,
    /// The servos' speed limit, rad/s (MuJoCo has none of its own).
    speed_limit_rad_s: f64,
    /// The sole's force from which it counts as loaded: a fifth of the robot's weight, N.
    loaded_n: f64,
    tempo: f64,
    tempo_at_s: f64,
    driven: Option<Driven<D>>,
    clock_s: f64,
    waited_s: f64,
    land_k: usize,
    held: (f64, Vec<f64>),
    target: Vec<f64>,
    cmd: Vec<f64>,
    torque_peak: Vec<f64>,
    power: Vec<f64>,
    work_j: f64,
}

impl<D: Drive> WalkController<D> {
    /// A controller for `plan` (its joints in the order of `lo`, `hi`) on
    /// the robot `robot` describes (its legs' joints, its servos' speed), with
    /// the robot's `mass_kg`, a physics step of `dt_s`, a tempo factor from
    /// `tempo_at_s` on, `servos` actuators measured, and `driven` taking over
    /// at its hand-over. The commands start at the plan's first frame.
    #[allow(clippy::too_many_arguments)] // one run's settings, each named at the call
    pub fn new(
        plan: Plan,
        robot: &crate::RobotSpec,
        joint_names: &[&str],
        lo: Vec<f64>,
        hi: Vec<f64>,
        gains: Gains,
        mass_kg: f64,
        dt_s: f64,
        tempo: f64,
        tempo_at_s: f64,
        servos: usize,
        driven: Option<Driven<D>>,
    ) -> Result<WalkController<D>, String> {
        let j = plan.joints;
        if joint_names.len() != j || lo.len() != j || hi.len() != j {
            return Err(format!(
                "{} names and {}/{} limits for a plan of {j} joints",
                joint_names.len(),
                lo.len(),
                hi.len()
            ));
        }
        if let Some(d) = &driven
            && let Some(&k) = d.joints.iter().find(|&&k| k >= j)
        {
            return Err(format!("a driven joint index {k} for a plan of {j} joints"));
        }
        let mut fed = Vec::new();
        for (g, role) in FEEDBACK_ROLES.iter().enumerate() {
            for leg in [&robot.legs.left, &robot.legs.right] {
                let name = leg.joint(role).unwrap_or_default();
                if let Some(k) = joint_names.iter().position(|n| *n == name) {
                    fed.push((k, g));
                }
            }
        }
        let mut first = vec![0.0; j];
        plan.frame_at(0.0, &mut first);
        Ok(WalkController {
            loaded_n: 0.2 * mass_kg * 9.81,
            plan,
            gains,
            dt_s,
            lo,
            hi,
            fed,
            speed_limit_rad_s: robot.servos.speed_limit_rad_s,
            tempo,
            tempo_at_s,
            driven,
            clock_s: 0.0,
            waited_s: 0.0,
            land_k: 0,
            held: (f64::NAN, first.clone()),
            target: vec![0.0; j],
            cmd: first,
            torque_peak: vec![0.0; servos],
            power: vec![0.0; servos],
            work_j: 0.0,
        })
    }

    /// The commands (rad, the plan's joint order) sent last, or the first frame.
    pub fn commands(&self) -> &[f64] {
        &self.cmd
    }

    /// The gait clock, s (it stops at the hand-over).
    pub fn clock_s(&self) -> f64 {
        self.clock_s
    }

    /// Each servo's largest |torque| so far, N·m.
    pub fn torque_peak(&self) -> &[f64] {
        &self.torque_peak
    }

    /// The servos' mechanical work so far (Σ|τ·ω|·dt), J.
    pub fn work_j(&self) -> f64 {
        self.work_j
    }

    /// The five feedback terms (rad) for the trunk's attitude.
    pub fn feedback(&self, s: &Sensors) -> [f64; 5] {
        let g = &self.gains;
        let (roll, pitch, yaw) = tilt(s.quat);
        let [wx, wy] = s.gyro;
        [
            g.ankle_pitch_kp * pitch + g.ankle_pitch_kd * wy,
            g.ankle_roll_kp * roll + g.ankle_roll_kd * wx,
            g.hip_pitch_kp * pitch,
            g.hip_roll_kp * roll,
            g.hip_yaw_kp * yaw,
        ]
    }

    /// The step at time `t_s`: the gait clock (or the generator) gives the
    /// target, the feedback moves it, and `ctrl[act[k]]` gets joint `k`'s
    /// command, moved by at most the speed limit and kept in range.
    pub fn control(&mut self, t_s: f64, s: &Sensors, act: &[usize], ctrl: &mut [f64]) -> Result<(), D::Error> {
        let rate = if t_s >= self.tempo_at_s { self.tempo } else { 1.0 };
        let dt = self.dt_s;
        let mut advance = dt * rate;
        if self.gains.phase_reset && self.land_k < self.plan.landings.len() {
            let (t_land, foot) = self.plan.landings[self.land_k];
            let loaded = s.touch_n[foot] > self.loaded_n;
            let clock = self.clock_s;
            if clock + advance >= t_land && !loaded && self.waited_s < self.gains.max_wait_s {
                advance = (t_land - clock).max(0.0);
                self.waited_s += dt;
            } else if loaded && t_land - clock < 0.15 * rate && clock < t_land {
                advance = t_land - clock;
            }
        }
        self.clock_s = (self.clock_s + advance).min(self.plan.end_s());
        while self.land_k < self.plan.landings.len() && self.clock_s >= self.plan.landings[self.land_k].0 {
            self.land_k += 1;
            self.waited_s = 0.0;
        }
        if self.clock_s != self.held.0 {
            self.held.0 = self.clock_s;
            self.plan.frame_at(self.clock_s, &mut self.held.1);
        }
        self.target.copy_from_slice(&self.held.1);
        if let Some(d) = &mut self.driven
            && t_s >= d.handover_s
        {
            let by_input = d.schedule.tempo_input.is_some();
            let g_rate = if by_input { d.rate_hz } else { d.rate_hz * rate };
            while d.due_s <= t_s {
                std::mem::swap(&mut d.prev_rad, &mut d.next_rad);
                d.schedule.at(t_s, self.tempo, self.tempo_at_s, &mut d.u);
                let y = d.drive.step(&d.u)?;
                for (n, v) in d.next_rad.iter_mut().zip(y) {
                    *n = v.to_radians();
                }
                d.due_s += 1.0 / g_rate;
            }
            let f = 1.0 - (d.due_s - t_s) * g_rate;
            for ((&k, p), n) in d.joints.iter().zip(&d.prev_rad).zip(&d.next_rad) {
                self.target[k] = p * (1.0 - f) + n * f;
            }
            self.clock_s = self.clock_s.min(d.handover_s);
        }
        let terms = self.feedback(s);
        for &(k, g) in &self.fed {
            self.target[k] -= terms[g];
        }
        let step_max = self.speed_limit_rad_s * dt;
        for (k, (c, t)) in self.cmd.iter_mut().zip(&self.target).enumerate() {
            // In NumPy's order: the step limited, then the range (NaN passes through).
            let mut d = t - *c;
            if d > step_max {
                d = step_max;
            }
            if d < -step_max {
                d = -step_max;
            }
            *c += d;
            if *c > self.hi[k] {
                *c = self.hi[k];
            }
            if *c < self.lo[k] {
                *c = self.lo[k];
            }
            ctrl[act[k]] = *c;
        }
        Ok(())
    }

    /// After the physics step: the servos' forces (N·m) and velocities (rad/s).
    pub fn measure(&mut self, force: &[f64], velocity: &[f64]) {
        for (((peak, p), f), v) in self.torque_peak.iter_mut().zip(&mut self.power).zip(force).zip(velocity) {
            let a = f.abs();
            if a > *peak || a.is_nan() {
                *peak = a;
            }
            *p = a * v.abs();
        }
        self.work_j += pairwise_sum(&self.power) * self.dt_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Sine {
        out: Vec<f64>,
        steps: usize,
    }

    impl Drive for Sine {
        type Error = String;
        fn step(&mut self, control: &[f64]) -> Result<&[f64], String> {
            self.steps += 1;
            let x = (self.steps as f64 * 0.3).sin() * 10.0 * control[0];
            self.out.fill(x);
            Ok(&self.out)
        }
    }

    fn plan(joints: usize) -> Plan {
        let clock: Vec<f64> = (0..101).map(|k| k as f64 * 0.01).collect();
        let angles = clock.iter().flat_map(|t| (0..joints).map(move |j| t * (j + 1) as f64)).collect();
        Plan::new(clock, angles, joints, vec![(0.5, 0)]).unwrap()
    }

    const LEVEL: Sensors = Sensors { quat: [1.0, 0.0, 0.0, 0.0], gyro: [0.0; 2], touch_n: [0.0; 2] };

    #[test]
    fn numpy_pairwise_sum_is_reproduced() {
        // The tree changes the rounding against a running sum: a value the two orders round differently.
        let a: Vec<f64> = (0..25).map(|k| if k == 0 { 1e16 } else { 1.0 + k as f64 * 1e-3 }).collect();
        let running = a.iter().fold(0.0, |s, v| s + v);
        let mut r = [0.0; 8];
        r.copy_from_slice(&a[..8]);
        for i in (8..24).step_by(8) {
            for k in 0..8 {
                r[k] += a[i + k];
            }
        }
        let tree = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7])) + a[24];
        assert_eq!(pairwise_sum(&a).to_bits(), tree.to_bits());
        assert_ne!(tree.to_bits(), running.to_bits(), "the example must tell the orders apart");
        assert_eq!(pairwise_sum(&[1.0, 2.0, 3.0]), 6.0);
        let long: Vec<f64> = (0..300).map(|k| k as f64).collect();
        assert_eq!(pairwise_sum(&long), 299.0 * 300.0 / 2.0);
    }

    #[test]
    fn a_level_trunk_gets_no_feedback_and_a_tilted_one_does() {
        let g = Gains { ankle_pitch_kp: 0.5, hip_roll_kp: -1.0, ..Gains::default() };
        let names = ["lleg_joint_5", "rleg_joint_2", "larm_joint_1"];
        let c: WalkController<Sine> = WalkController::new(
            plan(3),
            &crate::RobotSpec::hoap2(),
            &names,
            vec![-1.0; 3],
            vec![1.0; 3],
            g,
            7.0,
            1e-3,
            1.0,
            0.0,
            3,
            None,
        )
        .unwrap();
        assert_eq!(c.feedback(&LEVEL), [0.0; 5]);
        let a = 0.1_f64; // pitch by 0.1 rad: a rotation about y
        let pitched = Sensors { quat: [(a / 2.0).cos(), 0.0, (a / 2.0).sin(), 0.0], ..LEVEL };
        let t = c.feedback(&pitched);
        assert!((t[0] - 0.05).abs() < 1e-12 && t[3] == 0.0, "{t:?}");
        let (r, p, y) = tilt(pitched.quat);
        assert!(r.abs() < 1e-12 && (p - a).abs() < 1e-12 && y.abs() < 1e-12);
    }

    #[test]
    fn commands_follow_the_plan_within_the_speed_limit_and_the_range() {
        let names = ["a", "b"];
        let mut c: WalkController<Sine> = WalkController::new(
            plan(2),
            &crate::RobotSpec::hoap2(),
            &names,
            vec![-1.0; 2],
            vec![0.5, 1.5],
            Gains::default(),
            7.0,
            1e-3,
            1.0,
            0.0,
            2,
            None,
        )
        .unwrap();
        let mut ctrl = [0.0; 4];
        let act = [3, 1];
        for step in 0..1000 {
            let before = c.commands().to_vec();
            c.control(step as f64 * 1e-3, &LEVEL, &act, &mut ctrl).unwrap();
            for (b, a) in before.iter().zip(c.commands()) {
                assert!((a - b).abs() <= crate::RobotSpec::hoap2().servos.speed_limit_rad_s * 1e-3 + 1e-15);
            }
            assert_eq!([ctrl[3], ctrl[1]], [c.commands()[0], c.commands()[1]]);
        }
        // The plan ends at 1 s: joint a at 1.0 rad is held at its 0.5 limit, b at 2.0 at 1.5.
        assert_eq!(c.commands(), &[0.5, 1.5]);
        assert!(c.clock_s() <= 1.0);
    }

    #[test]
    fn the_generator_takes_over_at_the_handover_and_the_clock_stops() {
        let names = ["a"];
        let schedule = Schedule {
            base: vec![1.0],
            tempo_input: None,
            walk_input: None,
            tempo_ramp_s: 0.0,
            stop_at_s: None,
            stop_ramp_s: 0.0,
            start_at_s: None,
            start_ramp_s: 0.0,
        };
        let d = Driven::new(Sine { out: vec![0.0], steps: 0 }, vec![0], 100.0, 0.2, &[0.0], schedule).unwrap();
        let mut c = WalkController::new(
            plan(1),
            &crate::RobotSpec::hoap2(),
            &names,
            vec![-10.0],
            vec![10.0],
            Gains::default(),
            7.0,
            1e-3,
            1.0,
            0.0,
            1,
            Some(d),
        )
        .unwrap();
        let mut ctrl = [0.0];
        for step in 0..400 {
            c.control(step as f64 * 1e-3, &LEVEL, &[0], &mut ctrl).unwrap();
        }
        assert!((c.clock_s() - 0.2).abs() < 1e-9, "the gait clock stops at the hand-over: {}", c.clock_s());
        // The generator took 20 steps by 0.399 s (one at 0.2 s, then every 10 ms).
        assert_eq!(c.driven.as_ref().unwrap().drive.steps, 20);
    }

    #[test]
    fn the_measures_keep_the_largest_torque_and_add_the_work() {
        let mut c: WalkController<Sine> = WalkController::new(
            plan(1),
            &crate::RobotSpec::hoap2(),
            &["a"],
            vec![-1.0],
            vec![1.0],
            Gains::default(),
            7.0,
            0.5,
            1.0,
            0.0,
            2,
            None,
        )
        .unwrap();
        c.measure(&[2.0, -3.0], &[1.0, 1.0]);
        c.measure(&[-1.0, 1.0], &[0.0, 2.0]);
        assert_eq!(c.torque_peak(), &[2.0, 3.0]);
        assert_eq!(c.work_j(), (2.0 + 3.0) * 0.5 + 2.0 * 0.5);
    }

    #[test]
    fn a_plan_that_cannot_be_played_is_refused() {
        assert!(Plan::new(vec![0.0], vec![0.0], 1, vec![]).is_err());
        assert!(Plan::new(vec![0.0, 0.0], vec![0.0; 2], 1, vec![]).is_err());
        assert!(Plan::new(vec![0.0, 1.0], vec![0.0; 3], 1, vec![]).is_err());
        assert!(Plan::new(vec![0.0, 1.0], vec![0.0; 2], 1, vec![(0.5, 2)]).is_err());
    }
}

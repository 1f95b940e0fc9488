//! A trained CPG run at any tick rate, one tick at a time, as a control loop
//! or a physics simulator needs it: `cpg stream`, the Python package's
//! `Stream` and the MuJoCo example all run this.
//!
//! The model steps at its own rate; a tick between two of its steps is the
//! linear interpolation of their outputs. With a robot, each tick's channels
//! are mapped onto the joints ([`MapPlan`]) and every joint is kept within
//! its position range, its velocity limit and the acceleration bound by a
//! braking [`Limiter`]. A tick allocates nothing.

use cpg_reservoir::{Generator, TrainedCpg};
use cpg_robot::{ChannelMap, LimitCounts, Limiter, MapPlan, Robot};

use crate::error::{Error, Result};

/// The robot a [`Ticker`] drives.
#[derive(Debug, Clone, Copy)]
pub struct RobotTarget<'a> {
    /// The robot description.
    pub robot: &'a Robot,
    /// Channels → joints; the model must generate every channel it reads.
    pub map: &'a ChannelMap,
    /// The acceleration bound of every joint, rad/s².
    pub acceleration_rad_s2: f64,
}

#[derive(Debug, Clone)]
struct Joints {
    plan: MapPlan,
    limiters: Vec<Limiter>,
    out: Vec<f64>,
}

/// A trained CPG ticking at `rate_hz`.
#[derive(Debug, Clone)]
pub struct Ticker {
    g: Generator,
    model_rate_hz: f64,
    rate_hz: f64,
    previous: Vec<f64>,
    current: Vec<f64>,
    frame: Vec<f64>,
    model_steps: u64,
    tick: u64,
    joints: Option<Joints>,
    /// The figure's travel carried by its feet (a model that has one).
    travel: Option<crate::travel::FeetTravel>,
}

impl Ticker {
    /// A ticker at the model's start state. `rate_hz` is the tick rate
    /// (1 Hz to 10 kHz); with `robot`, ticks are joint angles.
    pub fn new(m: &TrainedCpg, rate_hz: f64, robot: Option<RobotTarget<'_>>) -> Result<Ticker> {
        if !(rate_hz.is_finite() && (cpg_robot::MIN_RATE_HZ..=cpg_robot::MAX_RATE_HZ).contains(&rate_hz)) {
            return Err(Error::Bound(format!(
                "tick rate {rate_hz} Hz: expected {} to {} Hz",
                cpg_robot::MIN_RATE_HZ,
                cpg_robot::MAX_RATE_HZ
            )));
        }
        let joints = match robot {
            Some(r) => {
                if !(r.acceleration_rad_s2.is_finite() && r.acceleration_rad_s2 > 0.0) {
                    return Err(Error::Bound(format!(
                        "acceleration bound {} rad/s²: expected a positive number",
                        r.acceleration_rad_s2
                    )));
                }
                let names: Vec<String> = m.outputs.iter().map(|o| o.unit_name().to_owned()).collect();
                let plan = r.map.plan(r.robot, &names)?;
                let dt = 1.0 / rate_hz;
                let limiters = plan.joints.iter().map(|j| Limiter::new(j.bounds(r.acceleration_rad_s2), dt)).collect();
                let n = plan.joints.len();
                Some(Joints { plan, limiters, out: vec![0.0; n] })
            }
            None => None,
        };
        let d = m.outputs.len();
        Ok(Ticker {
            g: Generator::new(m),
            model_rate_hz: m.provenance.sample_rate_hz,
            rate_hz,
            previous: vec![0.0; d],
            current: vec![0.0; d],
            frame: vec![0.0; d],
            model_steps: 0,
            tick: 0,
            joints,
            travel: crate::travel::FeetTravel::for_model(m)?,
        })
    }

    /// The names of what a tick returns: the model's channels (in their
    /// units, degrees for rotations) or the robot's joints (radians).
    pub fn columns(&self) -> Vec<String> {
        match &self.joints {
            Some(j) => j.plan.joints.iter().map(|j| j.name.clone()).collect(),
            None => Vec::new(),
        }
    }

    /// The tick rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// Time of the next tick, seconds.
    pub fn time_s(&self) -> f64 {
        self.tick as f64 / self.rate_hz
    }

    /// Ticks taken.
    pub fn ticks(&self) -> u64 {
        self.tick
    }

    /// One tick with `controls` (one value per control input): the model's
    /// channels, or with a robot its joint angles within every limit.
    pub fn tick(&mut self, controls: &[f64]) -> Result<&[f64]> {
        if self.model_steps == 0 {
            self.current.copy_from_slice(self.g.step(controls)?);
            if let Some(t) = self.travel.as_mut() {
                t.apply(&mut self.current);
            }
            self.model_steps = 1;
        }
        // This tick lies between outputs i and i + 1 of the model (output i is that of its (i + 1)-th step).
        let model_pos = self.tick as f64 / self.rate_hz * self.model_rate_hz;
        let i = model_pos.floor();
        while (self.model_steps as f64) < i + 2.0 {
            self.previous.copy_from_slice(&self.current);
            self.current.copy_from_slice(self.g.step(controls)?);
            if let Some(t) = self.travel.as_mut() {
                t.apply(&mut self.current);
            }
            self.model_steps += 1;
        }
        let frac = model_pos - i;
        for ((f, a), b) in self.frame.iter_mut().zip(&self.previous).zip(&self.current) {
            *f = a + frac * (b - a);
        }
        self.tick += 1;
        match &mut self.joints {
            Some(j) => {
                j.plan.frame(&self.frame, &mut j.out);
                for (q, l) in j.out.iter_mut().zip(j.limiters.iter_mut()) {
                    *q = l.step(*q);
                }
                Ok(&j.out)
            }
            None => Ok(&self.frame),
        }
    }

    /// With a robot: per joint, how often each limit acted so far.
    pub fn limit_counts(&self) -> Vec<(String, LimitCounts)> {
        match &self.joints {
            Some(j) => j.plan.joints.iter().zip(&j.limiters).map(|(jt, l)| (jt.name.clone(), l.counts)).collect(),
            None => Vec::new(),
        }
    }
}

/// The joint trajectory of `seconds` of `m`'s free run under `controls` on
/// `target`: mapped (every channel the map reads must be generated),
/// clamped to the position ranges, resampled to `rate_hz` (default: the
/// model's rate) by a natural cubic spline to exactly `seconds × rate_hz`
/// frames, and kept within the velocity limits and the acceleration bound
/// by the braking limiter: what `cpg hoap2` writes.
pub fn joint_trajectory(
    m: &TrainedCpg,
    controls: &crate::ControlSchedule,
    seconds: f64,
    rate_hz: Option<f64>,
    target: RobotTarget<'_>,
) -> Result<cpg_robot::JointTrajectory> {
    let names: Vec<String> = m.outputs.iter().map(|o| o.unit_name().to_owned()).collect();
    let missing: Vec<&str> = target.map.channels().into_iter().filter(|c| !names.iter().any(|n| n == c)).collect();
    if !missing.is_empty() {
        return Err(Error::name(
            missing[0],
            format!(
                "the model generates [{}]; the joint map also needs [{}] (train on those channels, or give a map that uses only the model's)",
                names.join(", "),
                missing.join(", ")
            ),
        ));
    }
    let rate = m.provenance.sample_rate_hz;
    let out_rate = rate_hz.unwrap_or(rate);
    let d = m.outputs.len();
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err(Error::Bound(format!("{seconds} s: expected a positive duration")));
    }
    let n_out = cpg_robot::JointTrajectory::check_rate(out_rate, seconds, target.map.entries.len())?;
    let n = (seconds * rate).round() as usize;
    if n == 0 || n.saturating_mul(d) > cpg_robot::MAX_VALUES {
        return Err(Error::Bound(format!(
            "{seconds} s at {rate} Hz: expected at least one step and at most {} values",
            cpg_robot::MAX_VALUES
        )));
    }
    // Two frames more than asked, so that the spline reaches the last output row.
    let mut y = crate::measure::free_run(m, controls, n + 2, None)?;
    cpg_reservoir::to_units_in_place(&m.outputs, &mut y);
    cpg_reservoir::integrate_in_place(&m.outputs, &mut y, rate);
    let t = target.map.apply(target.robot, &names, &y, rate)?;
    let t = t.resample(target.robot, out_rate, n_out)?;
    Ok(t.limit(target.robot, target.acceleration_rad_s2)?)
}

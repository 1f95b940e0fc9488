//! The common step interface and its four implementations.

use cpg_centralized::{Basis, CentralizedNet, HopfCenters, Switched};
use cpg_dmp::RhythmicDmp;
use cpg_reservoir::{Generator, TrainedCpg};

use crate::{Error, Result};

/// A rhythm generator advanced one sample at a time.
///
/// Outputs are in the units of the data the generator was fitted on. Neither
/// method allocates.
pub trait PatternGenerator {
    /// Short name of the family, for reports.
    fn family(&self) -> &'static str;
    /// Number of output coordinates.
    fn n_outputs(&self) -> usize;
    /// Duration of one step, seconds.
    fn dt_s(&self) -> f64;
    /// Back to the start state.
    fn reset(&mut self);
    /// One step of free generation; writes the outputs into `out`.
    fn step(&mut self, out: &mut [f64]) -> Result<()>;
    /// One step during which an outside force holds the outputs at `held`;
    /// writes `held` into `out`. How the generator's state reacts is what
    /// distinguishes the families: the reservoir feeds `held` back, the DMP's
    /// spring–damper is moved there, a clock-driven network has no state to move.
    fn step_held(&mut self, held: &[f64], out: &mut [f64]) -> Result<()>;
}

fn check_len(what: &str, got: usize, want: usize) -> Result<()> {
    if got != want {
        return Err(Error::Data(format!("{what} has {got} values, the generator has {want} outputs")));
    }
    Ok(())
}

/// Runs `steps` free steps from the current state; frame-major outputs.
pub fn run(g: &mut dyn PatternGenerator, steps: usize) -> Result<Vec<f64>> {
    let d = g.n_outputs();
    let mut out = vec![0.0; steps * d];
    for frame in out.chunks_exact_mut(d.max(1)) {
        g.step(frame)?;
    }
    Ok(out)
}

/// The reservoir CPG (cpg-reservoir) with constant control inputs.
#[derive(Debug, Clone)]
pub struct ReservoirCpg {
    model: TrainedCpg,
    generator: Generator,
    control: Vec<f64>,
    scratch: Vec<f64>,
}

impl ReservoirCpg {
    /// A generator at the model's start state; `control` holds one value per control input.
    pub fn new(model: TrainedCpg, control: Vec<f64>) -> Result<ReservoirCpg> {
        check_len("the control vector", control.len(), model.controls.len())?;
        let generator = Generator::new(&model);
        let scratch = vec![0.0; model.outputs.len()];
        Ok(ReservoirCpg { model, generator, control, scratch })
    }
}

impl PatternGenerator for ReservoirCpg {
    fn family(&self) -> &'static str {
        "reservoir CPG"
    }
    fn n_outputs(&self) -> usize {
        self.model.outputs.len()
    }
    fn dt_s(&self) -> f64 {
        1.0 / self.model.provenance.sample_rate_hz
    }
    fn reset(&mut self) {
        self.generator = Generator::new(&self.model);
    }
    fn step(&mut self, out: &mut [f64]) -> Result<()> {
        check_len("the output buffer", out.len(), self.n_outputs())?;
        out.copy_from_slice(self.generator.step(&self.control)?);
        Ok(())
    }
    fn step_held(&mut self, held: &[f64], out: &mut [f64]) -> Result<()> {
        check_len("the held outputs", held.len(), self.n_outputs())?;
        check_len("the output buffer", out.len(), self.n_outputs())?;
        for ((s, h), ch) in self.scratch.iter_mut().zip(held).zip(&self.model.outputs) {
            *s = (h - ch.mean) / ch.std;
        }
        self.generator.step_clamped(&self.control, &self.scratch)?;
        out.copy_from_slice(held);
        Ok(())
    }
}

/// How a centralized network's centers are run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Clock {
    /// Phase form, `φ = ω·t`.
    Phase,
    /// Hopf normal form ([`HopfCenters`]).
    Hopf,
}

/// A centralized network (cpg-centralized) run from time 0 at a fixed rate.
#[derive(Debug, Clone)]
pub struct CentralizedCpg {
    net: CentralizedNet,
    clock: Clock,
    hopf: HopfCenters,
    rate_hz: f64,
    step: u64,
    phases: Vec<f64>,
    sat: Vec<f64>,
}

impl CentralizedCpg {
    /// A generator sampling `net` at `rate_hz` with the given center form.
    pub fn new(net: CentralizedNet, clock: Clock, rate_hz: f64) -> Result<CentralizedCpg> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::Parameter(format!("rate {rate_hz} Hz must be positive")));
        }
        if clock == Clock::Hopf && net.basis == Basis::Polynomial {
            return Err(Error::Parameter(
                "the polynomial basis is a function of time, not of a phase; run it with Clock::Phase".into(),
            ));
        }
        let m = net.omega_rad_s.len();
        Ok(CentralizedCpg {
            hopf: HopfCenters::new(net.omega_rad_s.clone()),
            sat: vec![0.0; net.n_satellites],
            phases: vec![0.0; m],
            net,
            clock,
            rate_hz,
            step: 0,
        })
    }

    /// The Hopf centers (to perturb them); unused with [`Clock::Phase`].
    pub fn hopf_mut(&mut self) -> &mut HopfCenters {
        &mut self.hopf
    }

    fn advance(&mut self) {
        self.step += 1;
        if self.clock == Clock::Hopf {
            self.hopf.advance(1.0 / self.rate_hz);
        }
    }
}

impl PatternGenerator for CentralizedCpg {
    fn family(&self) -> &'static str {
        "centralized network"
    }
    fn n_outputs(&self) -> usize {
        self.net.readout.n_outputs()
    }
    fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
    fn reset(&mut self) {
        self.step = 0;
        self.hopf = HopfCenters::new(self.net.omega_rad_s.clone());
    }
    /// The first step returns the output at `t = 0`, like the data's first frame.
    fn step(&mut self, out: &mut [f64]) -> Result<()> {
        check_len("the output buffer", out.len(), self.n_outputs())?;
        match self.clock {
            Clock::Phase => self.net.output(self.step as f64 / self.rate_hz, &mut self.sat, out),
            Clock::Hopf => {
                self.hopf.phases(&mut self.phases);
                self.net.satellites_at_phases(&self.phases, &mut self.sat);
                self.net.readout.apply(&self.sat, out);
            }
        }
        self.advance();
        Ok(())
    }
    fn step_held(&mut self, held: &[f64], out: &mut [f64]) -> Result<()> {
        check_len("the held outputs", held.len(), self.n_outputs())?;
        check_len("the output buffer", out.len(), self.n_outputs())?;
        out.copy_from_slice(held);
        self.advance();
        Ok(())
    }
}

/// Networks glued by the switching module (cpg-centralized), sampled at a fixed rate.
#[derive(Debug, Clone)]
pub struct SwitchedCpg {
    sw: Switched,
    rate_hz: f64,
    step: u64,
    w: Vec<f64>,
    sat: Vec<f64>,
    y: Vec<f64>,
}

impl SwitchedCpg {
    /// A generator sampling `sw` at `rate_hz`.
    pub fn new(sw: Switched, rate_hz: f64) -> Result<SwitchedCpg> {
        if sw.nets.is_empty() || sw.boundaries_s.len() != sw.nets.len() + 1 {
            return Err(Error::Parameter(format!(
                "{} networks need {} boundaries, got {}",
                sw.nets.len(),
                sw.nets.len() + 1,
                sw.boundaries_s.len()
            )));
        }
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::Parameter(format!("rate {rate_hz} Hz must be positive")));
        }
        let d = sw.nets[0].readout.n_outputs();
        if let Some(k) = sw.nets.iter().position(|n| n.readout.n_outputs() != d) {
            return Err(Error::Parameter(format!("network {k} does not have {d} outputs like network 0")));
        }
        Ok(SwitchedCpg {
            w: vec![0.0; sw.nets.len()],
            sat: vec![0.0; sw.max_satellites()],
            y: vec![0.0; d],
            sw,
            rate_hz,
            step: 0,
        })
    }
}

impl PatternGenerator for SwitchedCpg {
    fn family(&self) -> &'static str {
        "switched centralized networks"
    }
    fn n_outputs(&self) -> usize {
        self.y.len()
    }
    fn dt_s(&self) -> f64 {
        1.0 / self.rate_hz
    }
    fn reset(&mut self) {
        self.step = 0;
    }
    fn step(&mut self, out: &mut [f64]) -> Result<()> {
        check_len("the output buffer", out.len(), self.n_outputs())?;
        self.sw.output(self.step as f64 / self.rate_hz, &mut self.w, &mut self.sat, &mut self.y, out);
        self.step += 1;
        Ok(())
    }
    fn step_held(&mut self, held: &[f64], out: &mut [f64]) -> Result<()> {
        check_len("the held outputs", held.len(), self.n_outputs())?;
        check_len("the output buffer", out.len(), self.n_outputs())?;
        out.copy_from_slice(held);
        self.step += 1;
        Ok(())
    }
}

/// A rhythmic DMP (cpg-dmp) at tempo `tau`, one step per sample.
#[derive(Debug, Clone)]
pub struct DmpCpg {
    dmp: RhythmicDmp,
    tau: f64,
    dt_s: f64,
}

impl DmpCpg {
    /// A generator at the DMP's start (`y0`, phase 0); one step lasts `dt_s` seconds.
    pub fn new(mut dmp: RhythmicDmp, tau: f64, dt_s: f64) -> Result<DmpCpg> {
        if !(tau.is_finite() && tau > 0.0 && dt_s.is_finite() && dt_s > 0.0) {
            return Err(Error::Parameter(format!("tau {tau} and step {dt_s} s must be positive")));
        }
        dmp.reset();
        Ok(DmpCpg { dmp, tau, dt_s })
    }
}

impl PatternGenerator for DmpCpg {
    fn family(&self) -> &'static str {
        "rhythmic DMP"
    }
    fn n_outputs(&self) -> usize {
        self.dmp.n_dofs()
    }
    fn dt_s(&self) -> f64 {
        self.dt_s
    }
    fn reset(&mut self) {
        self.dmp.reset();
    }
    fn step(&mut self, out: &mut [f64]) -> Result<()> {
        check_len("the output buffer", out.len(), self.n_outputs())?;
        out.copy_from_slice(self.dmp.step(self.tau, 0.0));
        Ok(())
    }
    fn step_held(&mut self, held: &[f64], out: &mut [f64]) -> Result<()> {
        check_len("the held outputs", held.len(), self.n_outputs())?;
        check_len("the output buffer", out.len(), self.n_outputs())?;
        self.dmp.step(self.tau, 0.0);
        self.dmp.hold(held);
        out.copy_from_slice(held);
        Ok(())
    }
}

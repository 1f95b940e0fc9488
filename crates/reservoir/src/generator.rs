//! Step-by-step generation for a robot control loop.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use pulp::{Simd, WithSimd};

use crate::config::Precision;
use crate::engine::{Engine, ReadoutR};
use crate::error::{Error, Result};
use crate::kernel::{Aligned, SimdDot};
use crate::model::{OutputChannel, TrainedCpg};
use crate::reservoir::rng;

#[derive(Debug, Clone)]
struct Gen<R: SimdDot> {
    engine: Engine<R>,
    readout: ReadoutR<R>,
    x: Aligned<R>,
    y: Vec<R>,
    u: Vec<R>,
    pre: Aligned<R>,
    noise: Vec<R>,
}

impl<R: SimdDot> Gen<R> {
    fn new(m: &TrainedCpg) -> Gen<R> {
        let engine = Engine::<R>::new(&m.reservoir);
        let (n, np, d, u) = (engine.shared.n, engine.shared.np, engine.shared.d, engine.shared.u);
        Gen {
            readout: ReadoutR::new(&m.readout),
            x: engine.state(&m.start_state),
            y: vec![R::ZERO; d],
            u: vec![R::ZERO; u],
            pre: Aligned::zeros(np),
            noise: vec![R::ZERO; n],
            engine,
        }
    }

    /// Readout, then one update fed back with the output or with `clamp`.
    /// Writes the normalised output into `out`; returns whether all is finite.
    fn step(
        &mut self,
        control: &[f64],
        clamp: Option<&[f64]>,
        noise: Option<(&mut ChaCha8Rng, f64)>,
        out: &mut [f64],
    ) -> bool {
        struct Op<'a, 'b, R: SimdDot> {
            g: &'a mut Gen<R>,
            control: &'a [f64],
            clamp: Option<&'a [f64]>,
            noise: Option<(&'b mut ChaCha8Rng, f64)>,
            out: &'a mut [f64],
        }
        impl<R: SimdDot> WithSimd for Op<'_, '_, R> {
            type Output = bool;
            #[inline(always)]
            fn with_simd<S: Simd>(self, simd: S) -> bool {
                let Op { g, control, clamp, noise, out } = self;
                g.readout.apply(simd, g.x.as_slice(), &mut g.y);
                for (o, y) in out.iter_mut().zip(&g.y) {
                    *o = y.to_f64();
                }
                if let Some(c) = clamp {
                    for (y, v) in g.y.iter_mut().zip(c) {
                        *y = R::from_f64(*v);
                    }
                }
                for (a, b) in g.u.iter_mut().zip(control) {
                    *a = R::from_f64(*b);
                }
                let z = match noise {
                    Some((r, sigma)) => {
                        for e in g.noise.iter_mut() {
                            *e = R::from_f64(sigma * r.sample::<f64, _>(StandardNormal));
                        }
                        Some(g.noise.as_slice())
                    }
                    None => None,
                };
                g.engine.update_simd(simd, g.x.as_mut_slice(), &g.y, &g.u, g.pre.as_mut_slice(), z);
                out.iter().all(|v| v.is_finite()) && g.x.as_slice().iter().all(|v| v.finite())
            }
        }
        let arch = self.engine.arch();
        arch.dispatch(Op { g: self, control, clamp, noise, out })
    }
}

#[derive(Debug, Clone)]
enum Inner {
    F32(Gen<f32>),
    F64(Gen<f64>),
}

/// Runs a trained CPG one step at a time, in free run from its start state.
///
/// Each [`step`](Generator::step) reads the output from the state, feeds it
/// back, and advances the state; it allocates nothing. Outputs come back in
/// the units of the training data (the normalisation is undone; a channel
/// learnt as its rate, [`VELOCITY_SUFFIX`](crate::VELOCITY_SUFFIX), integrated
/// from 0 at the first step, or at the first step after a resume), controls go
/// in as they were given in training. A non-finite control is rejected before
/// it touches the state; a non-finite state or output becomes
/// [`Error::Diverged`], and the generator refuses to continue until it is reset.
#[derive(Debug, Clone)]
pub struct Generator {
    inner: Inner,
    outputs: Vec<OutputChannel>,
    normalised: Vec<f64>,
    out: Vec<f64>,
    /// The integrated channels' positions (rates' channels, `VELOCITY_SUFFIX`), from 0.
    position: Vec<f64>,
    /// Which outputs are rates to integrate (read from the names once).
    integrates: Vec<bool>,
    rate_hz: f64,
    n_controls: usize,
    steps: u64,
    noise: Option<(ChaCha8Rng, f64)>,
    diverged: bool,
}

impl Generator {
    /// A generator at the model's start state.
    pub fn new(model: &TrainedCpg) -> Generator {
        let inner = match model.reservoir.config().precision {
            Precision::F32 => Inner::F32(Gen::new(model)),
            Precision::F64 => Inner::F64(Gen::new(model)),
        };
        let d = model.outputs.len();
        Generator {
            inner,
            outputs: model.outputs.clone(),
            normalised: vec![0.0; d],
            out: vec![0.0; d],
            position: vec![0.0; d],
            integrates: model.outputs.iter().map(|o| o.integrates().is_some()).collect(),
            rate_hz: model.provenance.sample_rate_hz,
            n_controls: model.controls.len(),
            steps: 0,
            noise: None,
            diverged: false,
        }
    }

    /// Adds Gaussian noise of `variance` to every state after each update
    /// (`variance` 0 switches it off).
    pub fn set_state_noise(&mut self, variance: f64, seed: u64) {
        self.noise = (variance > 0.0).then(|| (rng(seed, 9_000), variance.sqrt()));
    }

    /// Number of steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The reservoir state (one value per neuron, exactly, whatever the
    /// precision) and the steps taken: what [`Generator::resume`] continues from.
    pub fn state(&self) -> (Vec<f64>, u64) {
        let x = match &self.inner {
            Inner::F32(g) => g.x.as_slice()[..g.engine.shared.n].iter().map(|v| f64::from(*v)).collect(),
            Inner::F64(g) => g.x.as_slice()[..g.engine.shared.n].to_vec(),
        };
        (x, self.steps)
    }

    /// A generator for `model` that continues from `state` after `steps`
    /// steps (from [`Generator::state`] of a generator of the same model): its
    /// next steps are bit for bit those the original would have taken.
    pub fn resume(model: &TrainedCpg, state: &[f64], steps: u64) -> Result<Generator> {
        let n = model.reservoir.n_neurons();
        if state.len() != n || state.iter().any(|v| !v.is_finite()) {
            return Err(Error::Shape(format!(
                "a state of {} values for {n} neurons (expected finite values)",
                state.len()
            )));
        }
        let mut g = Generator::new(model);
        match &mut g.inner {
            Inner::F32(x) => x.x = x.engine.state(state),
            Inner::F64(x) => x.x = x.engine.state(state),
        }
        g.steps = steps;
        Ok(g)
    }

    /// Whether a step diverged (the generator then refuses further steps).
    pub fn diverged(&self) -> bool {
        self.diverged
    }

    /// One step of free run. `control` has one value per control input.
    pub fn step(&mut self, control: &[f64]) -> Result<&[f64]> {
        self.advance(control, None)
    }

    /// One step whose fed-back output is forced to `clamp_normalised` (in
    /// normalised units) instead of the network's own output: the paper's
    /// perturbation. Returns the network's own (unforced) output.
    pub fn step_clamped(&mut self, control: &[f64], clamp_normalised: &[f64]) -> Result<&[f64]> {
        self.advance(control, Some(clamp_normalised))
    }

    /// The last output, in the units of the training data (what the last [`Generator::step`] returned).
    pub fn output(&self) -> &[f64] {
        &self.out
    }

    /// The last output in normalised units (what the network sees).
    pub fn normalised_output(&self) -> &[f64] {
        &self.normalised
    }

    fn advance(&mut self, control: &[f64], clamp: Option<&[f64]>) -> Result<&[f64]> {
        if self.diverged {
            return Err(Error::Diverged { what: "state", step: self.steps });
        }
        if control.len() != self.n_controls {
            return Err(Error::Shape(format!(
                "{} control values for {} control inputs",
                control.len(),
                self.n_controls
            )));
        }
        if let Some(k) = control.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFiniteInput { what: "control", sample: self.steps as usize, column: k });
        }
        if let Some(c) = clamp
            && (c.len() != self.out.len() || c.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::Shape(format!("clamp needs {} finite values", self.out.len())));
        }
        let noise = self.noise.as_mut().map(|(g, s)| (g, *s));
        let ok = match &mut self.inner {
            Inner::F32(g) => g.step(control, clamp, noise, &mut self.normalised),
            Inner::F64(g) => g.step(control, clamp, noise, &mut self.normalised),
        };
        self.steps += 1;
        if !ok {
            self.diverged = true;
            return Err(Error::Diverged { what: "state or output", step: self.steps });
        }
        let channels = self.outputs.iter().zip(&self.integrates);
        for (((o, v), (ch, &rate)), p) in
            self.out.iter_mut().zip(&self.normalised).zip(channels).zip(&mut self.position)
        {
            *o = ch.to_units(*v);
            if rate {
                *p += *o / self.rate_hz;
                *o = *p;
            }
        }
        Ok(&self.out)
    }
}

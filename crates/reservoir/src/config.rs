//! Reservoir configuration: an unchecked form that users edit and serialise,
//! and a checked form that the rest of the crate accepts.

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// The neuron non-linearity `f`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Activation {
    /// Hyperbolic tangent (default).
    Tanh,
    /// Logistic sigmoid `1 / (1 + e^{−x})`.
    Logistic,
}

/// Floating-point precision of the dynamics. Training always solves the
/// regression in `f64`; this sets the reservoir states and the free run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// 32-bit floats: the weight matrix of a 300-neuron reservoir fits a core's L2 cache.
    F32,
    /// 64-bit floats.
    F64,
}

/// Sparse random connections from a signal into the reservoir: each neuron is
/// connected with probability `fraction`, with weight `+scale` or `−scale`
/// with equal probability (the paper's "binomial" scaling). A control input
/// drives the neurons with `(u − center)`; feedback has no center.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Coupling {
    /// Fraction of neurons that receive the signal, in [0, 1].
    pub fraction: f64,
    /// Magnitude of each connection, >= 0.
    pub scale: f64,
    /// The value of the signal that drives nothing (0: the raw signal).
    #[serde(default)]
    pub center: f64,
}

impl Coupling {
    /// `fraction` of the neurons at `±scale`, no center.
    pub const fn new(fraction: f64, scale: f64) -> Coupling {
        Coupling { fraction, scale, center: 0.0 }
    }
}

/// The unchecked reservoir configuration.
///
/// | field | paper (wyffels & Schrauwen 2009) | meaning | valid |
/// |---|---|---|---|
/// | `n_neurons` | 300 (600 gait switching, 2000 for 22 joints) | reservoir size N | 1 ..= 20000 |
/// | `connectivity` | 0.5 | fraction of non-zero entries of W | (0, 1] |
/// | `spectral_radius` | 1.0 | largest eigenvalue modulus of W after rescaling | > 0 |
/// | `leak_rate` | 0.3 | λ in `x ← (1−λ)x + λ f(…)` | (0, 1] |
/// | `bias_range` | [0, 0.1] | each neuron's bias is uniform in it | lo <= hi |
/// | `feedback` | 100 % at ±0.05 (65 % at ±0.11 for 22 outputs) | output → reservoir | fraction in [0, 1], scale >= 0 |
/// | `inputs` | none; 25 % / 50 % at ±0.2 for control inputs | one coupling per control input | as feedback |
/// | `n_outputs` | 1 (22 for the HOAP-2 joints) | number of generated signals D | >= 1 |
/// | `activation` | sigmoid (we read: tanh) | neuron non-linearity | |
/// | `precision` | | f32 or f64 dynamics | |
/// | `tempo_input` | none (our addition) | a control input that multiplies the leak rate | index < inputs |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReservoirConfig {
    /// Number of neurons N.
    pub n_neurons: usize,
    /// Fraction of non-zero recurrent weights.
    pub connectivity: f64,
    /// Spectral radius W is rescaled to.
    pub spectral_radius: f64,
    /// Leak rate λ.
    pub leak_rate: f64,
    /// Interval [lo, hi] of the uniform per-neuron bias.
    pub bias_range: [f64; 2],
    /// Output feedback.
    pub feedback: Coupling,
    /// Control inputs, one coupling each.
    pub inputs: Vec<Coupling>,
    /// Number of outputs D.
    pub n_outputs: usize,
    /// Neuron non-linearity.
    pub activation: Activation,
    /// Precision of the dynamics.
    pub precision: Precision,
    /// A control input that sets the tempo: at every step the leak rate is
    /// `leak_rate · u[tempo_input]`, clamped to [0, 1]. The neurons' time
    /// constant shrinks as the input grows, so the whole rhythm speeds up.
    /// (Not in the paper; `None` is the paper's fixed leak rate.)
    #[serde(default)]
    pub tempo_input: Option<usize>,
}

impl ReservoirConfig {
    /// The paper's reservoir for one output and no control input: 300 neurons,
    /// 50 % connectivity, N(0,1) weights rescaled to spectral radius 1, leak
    /// rate 0.3, bias U[0, 0.1], feedback to every neuron with ±0.05, tanh, f32.
    pub fn wyffels_schrauwen_2009() -> ReservoirConfig {
        ReservoirConfig {
            n_neurons: 300,
            connectivity: 0.5,
            spectral_radius: 1.0,
            leak_rate: 0.3,
            bias_range: [0.0, 0.1],
            feedback: Coupling::new(1.0, 0.05),
            inputs: Vec::new(),
            n_outputs: 1,
            activation: Activation::Tanh,
            precision: Precision::F32,
            tempo_input: None,
        }
    }

    /// Checks every field; the error names the first bad one.
    pub fn check(self) -> Result<CheckedConfig, ConfigError> {
        let bad =
            |field: &str, value: String, expected: &'static str| ConfigError { field: field.into(), value, expected };
        if !(1..=20_000).contains(&self.n_neurons) {
            return Err(bad("n_neurons", self.n_neurons.to_string(), "expected 1 ..= 20000"));
        }
        if !(self.connectivity > 0.0 && self.connectivity <= 1.0) {
            return Err(bad("connectivity", self.connectivity.to_string(), "expected a fraction in (0, 1]"));
        }
        if !(self.spectral_radius.is_finite() && self.spectral_radius > 0.0) {
            return Err(bad("spectral_radius", self.spectral_radius.to_string(), "expected a finite number > 0"));
        }
        if !(self.leak_rate > 0.0 && self.leak_rate <= 1.0) {
            return Err(bad("leak_rate", self.leak_rate.to_string(), "expected a number in (0, 1]"));
        }
        let [lo, hi] = self.bias_range;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(bad("bias_range", format!("[{lo}, {hi}]"), "expected finite [lo, hi] with lo <= hi"));
        }
        let coupling = |name: String, c: &Coupling| -> Result<(), ConfigError> {
            if !(0.0..=1.0).contains(&c.fraction) {
                return Err(bad(&format!("{name}.fraction"), c.fraction.to_string(), "expected a fraction in [0, 1]"));
            }
            if !(c.scale.is_finite() && c.scale >= 0.0) {
                return Err(bad(&format!("{name}.scale"), c.scale.to_string(), "expected a finite number >= 0"));
            }
            if !c.center.is_finite() {
                return Err(bad(&format!("{name}.center"), c.center.to_string(), "expected a finite number"));
            }
            Ok(())
        };
        coupling("feedback".into(), &self.feedback)?;
        if self.feedback.center != 0.0 {
            return Err(bad(
                "feedback.center",
                self.feedback.center.to_string(),
                "expected 0 (feedback has no center)",
            ));
        }
        for (k, c) in self.inputs.iter().enumerate() {
            coupling(format!("inputs[{k}]"), c)?;
        }
        if !(1..=1000).contains(&self.n_outputs) {
            return Err(bad("n_outputs", self.n_outputs.to_string(), "expected 1 ..= 1000"));
        }
        if let Some(k) = self.tempo_input
            && k >= self.inputs.len()
        {
            return Err(bad("tempo_input", k.to_string(), "expected the index of a control input"));
        }
        Ok(CheckedConfig(self))
    }
}

/// A configuration whose every field is in range. Only [`ReservoirConfig::check`] makes one.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckedConfig(ReservoirConfig);

impl CheckedConfig {
    /// The validated values.
    pub fn get(&self) -> &ReservoirConfig {
        &self.0
    }
}

impl std::ops::Deref for CheckedConfig {
    type Target = ReservoirConfig;
    fn deref(&self) -> &ReservoirConfig {
        &self.0
    }
}

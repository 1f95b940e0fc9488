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
#[serde(deny_unknown_fields)]
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

/// The most neurons a reservoir may have.
pub const MAX_NEURONS: usize = 20_000;
/// The most outputs a reservoir may generate.
pub const MAX_OUTPUTS: usize = 1000;

/// A named set of base values for [`ReservoirConfig`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Preset {
    /// wyffels & Schrauwen (2009): [`ReservoirConfig::wyffels_schrauwen_2009`].
    #[default]
    #[serde(rename = "wyffels-schrauwen-2009")]
    WyffelsSchrauwen2009,
}

impl Preset {
    /// The preset's configuration.
    pub fn config(self) -> ReservoirConfig {
        match self {
            Preset::WyffelsSchrauwen2009 => ReservoirConfig::wyffels_schrauwen_2009(),
        }
    }
}

fn default_seed() -> u64 {
    1
}

fn bad(field: impl Into<String>, value: String, expected: impl Into<String>) -> ConfigError {
    ConfigError { field: field.into(), value, expected: expected.into() }
}

/// `v` in `lo..=hi`.
fn count_in(lo: usize, hi: usize) -> impl Fn(&str, &usize) -> Result<(), ConfigError> {
    move |f, v| {
        if (lo..=hi).contains(v) { Ok(()) } else { Err(bad(f, v.to_string(), format!("expected {lo} ..= {hi}"))) }
    }
}

fn coupling(name: &str, c: &Coupling) -> Result<(), ConfigError> {
    if !(0.0..=1.0).contains(&c.fraction) {
        return Err(bad(format!("{name}.fraction"), c.fraction.to_string(), "expected a fraction in [0, 1]"));
    }
    if !(c.scale.is_finite() && c.scale >= 0.0) {
        return Err(bad(format!("{name}.scale"), c.scale.to_string(), "expected a finite number >= 0"));
    }
    if !c.center.is_finite() {
        return Err(bad(format!("{name}.center"), c.center.to_string(), "expected a finite number"));
    }
    Ok(())
}

/// Declares the parameters a configuration file may set, each once: its
/// doc line, type, the paper's value and its check. From the list come the
/// fields of [`ReservoirConfig`] (with the preset's values as serde
/// defaults, so a model file that predates a parameter still reads) and the
/// optional fields of [`ReservoirSettings`] (what `[reservoir]` in a
/// configuration file gives over a preset).
macro_rules! parameters {
    ($( $(#[doc = $doc:literal])* $name:ident: $ty:ty = $paper:expr, valid $check:expr; )*) => {
        /// The unchecked reservoir configuration: the parameters below, the
        /// number of outputs and the tempo input (both set from the data).
        /// Missing fields take the paper's values ([`Default`]).
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct ReservoirConfig {
            $( $(#[doc = $doc])* pub $name: $ty, )*
            /// Number of outputs D (from the data), 1 ..= [`MAX_OUTPUTS`].
            pub n_outputs: usize,
            /// A control input (its index) that sets the tempo: at every step
            /// the leak rate is `leak_rate · u[tempo_input]`, clamped to [0, 1].
            /// The neurons' time constant shrinks as the input grows, so the
            /// whole rhythm speeds up. (Not in the paper; `None` is the paper's
            /// fixed leak rate.)
            pub tempo_input: Option<usize>,
        }

        impl ReservoirConfig {
            /// The paper's reservoir for one output and no control input: 300
            /// neurons, 50 % connectivity, N(0,1) weights rescaled to spectral
            /// radius 1, leak rate 0.3, bias U[0, 0.1], feedback to every neuron
            /// with ±0.05, tanh, f32.
            pub fn wyffels_schrauwen_2009() -> ReservoirConfig {
                ReservoirConfig { $( $name: $paper, )* n_outputs: 1, tempo_input: None }
            }

            fn check_parameters(&self) -> Result<(), ConfigError> {
                $( ($check)(stringify!($name), &self.$name)?; )*
                Ok(())
            }
        }

        /// A reservoir as a configuration file's `[reservoir]` gives it: a
        /// preset, the seed of its random weights, the parameters it changes
        /// and the tempo input by name. [`ReservoirSettings::resolve`] makes
        /// the [`ReservoirConfig`].
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct ReservoirSettings {
            /// The base values.
            #[serde(default)]
            pub preset: Preset,
            /// Seed of the random weights.
            #[serde(default = "default_seed")]
            pub seed: u64,
            $( $(#[doc = $doc])* #[serde(default, skip_serializing_if = "Option::is_none")] pub $name: Option<$ty>, )*
            /// The control input (by name) whose value multiplies the leak rate.
            #[serde(default, skip_serializing_if = "Option::is_none")]
            pub tempo_input: Option<String>,
        }

        impl Default for ReservoirSettings {
            fn default() -> Self {
                ReservoirSettings { preset: Preset::default(), seed: default_seed(), $( $name: None, )* tempo_input: None }
            }
        }

        impl ReservoirSettings {
            fn overlay(&self, c: &mut ReservoirConfig) {
                $( if let Some(v) = &self.$name { c.$name = v.clone(); } )*
            }
        }
    };
}

parameters! {
    /// Number of neurons N (paper: 300; 600 for gait switching, 2000 for 22 joints).
    n_neurons: usize = 300, valid count_in(1, MAX_NEURONS);
    /// Fraction of non-zero recurrent weights, in (0, 1].
    connectivity: f64 = 0.5, valid |f: &str, v: &f64| {
        if *v > 0.0 && *v <= 1.0 { Ok(()) } else { Err(bad(f, v.to_string(), "expected a fraction in (0, 1]")) }
    };
    /// Spectral radius W is rescaled to, > 0.
    spectral_radius: f64 = 1.0, valid |f: &str, v: &f64| {
        if v.is_finite() && *v > 0.0 { Ok(()) } else { Err(bad(f, v.to_string(), "expected a finite number > 0")) }
    };
    /// Leak rate λ in `x ← (1−λ)x + λ f(…)`, in (0, 1].
    leak_rate: f64 = 0.3, valid |f: &str, v: &f64| {
        if *v > 0.0 && *v <= 1.0 { Ok(()) } else { Err(bad(f, v.to_string(), "expected a number in (0, 1]")) }
    };
    /// Interval [lo, hi] of the uniform per-neuron bias.
    bias_range: [f64; 2] = [0.0, 0.1], valid |f: &str, v: &[f64; 2]| {
        let [lo, hi] = *v;
        if lo.is_finite() && hi.is_finite() && lo <= hi {
            Ok(())
        } else {
            Err(bad(f, format!("[{lo}, {hi}]"), "expected finite [lo, hi] with lo <= hi"))
        }
    };
    /// Output feedback (paper: every neuron at ±0.05; 65 % at ±0.11 for 22 outputs); no center.
    feedback: Coupling = Coupling::new(1.0, 0.05), valid |f: &str, c: &Coupling| {
        coupling(f, c)?;
        if c.center != 0.0 {
            return Err(bad(format!("{f}.center"), c.center.to_string(), "expected 0 (feedback has no center)"));
        }
        Ok(())
    };
    /// One coupling per control input (default with controls: 50 % at ±0.2 each).
    inputs: Vec<Coupling> = Vec::new(), valid |f: &str, v: &Vec<Coupling>| {
        v.iter().enumerate().try_for_each(|(k, c)| coupling(&format!("{f}[{k}]"), c))
    };
    /// Neuron non-linearity: `tanh` or `logistic` (paper: sigmoid; we read tanh).
    activation: Activation = Activation::Tanh, valid |_: &str, _: &Activation| Ok(());
    /// Precision of the dynamics: `f32` or `f64`.
    precision: Precision = Precision::F32, valid |_: &str, _: &Precision| Ok(());
}

impl Default for ReservoirConfig {
    fn default() -> Self {
        ReservoirConfig::wyffels_schrauwen_2009()
    }
}

impl ReservoirConfig {
    /// Checks every field; the error names the first bad one.
    pub fn check(self) -> Result<CheckedConfig, ConfigError> {
        self.check_parameters()?;
        count_in(1, MAX_OUTPUTS)("n_outputs", &self.n_outputs)?;
        if let Some(k) = self.tempo_input
            && k >= self.inputs.len()
        {
            return Err(bad("tempo_input", k.to_string(), "expected the index of a control input"));
        }
        Ok(CheckedConfig(self))
    }
}

impl ReservoirSettings {
    /// The configuration for `n_outputs` outputs and the control inputs
    /// `controls` (by name): the preset, the parameters given over it, one
    /// default coupling (50 % at ±0.2) per control input when none are
    /// given, and the tempo input's index. Unchecked: call
    /// [`ReservoirConfig::check`].
    pub fn resolve(&self, n_outputs: usize, controls: &[String]) -> Result<ReservoirConfig, ConfigError> {
        let mut c = self.preset.config();
        self.overlay(&mut c);
        c.n_outputs = n_outputs;
        if self.inputs.is_none() {
            c.inputs = vec![Coupling::new(0.5, 0.2); controls.len()];
        }
        if c.inputs.len() != controls.len() {
            return Err(bad(
                "inputs",
                format!("{} couplings", c.inputs.len()),
                format!("expected one per control input ({})", controls.len()),
            ));
        }
        c.tempo_input = match &self.tempo_input {
            Some(name) => Some(controls.iter().position(|x| x == name).ok_or_else(|| {
                bad(
                    "tempo_input",
                    format!("'{name}' is not a control input"),
                    format!("expected one of the control inputs [{}]", controls.join(", ")),
                )
            })?),
            None => None,
        };
        Ok(c)
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

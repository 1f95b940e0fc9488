//! `cpg train --config FILE`: the TOML training configuration.
//!
//! Paths are relative to the configuration file. Unknown keys are errors, so a
//! misspelt option is reported instead of silently ignored.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use cpg_reservoir::{Activation, Coupling, Precision, ReservoirConfig};
use serde::Deserialize;

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// What to learn.
    pub data: Data,
    /// The reservoir: a preset plus overrides.
    #[serde(default)]
    pub reservoir: ReservoirSection,
    /// How to choose the penalty.
    #[serde(default)]
    pub training: Training,
    /// Where the model goes.
    pub output: Output,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Data {
    /// The ASF skeleton.
    pub skeleton: PathBuf,
    /// Capture rate of the AMC files, Hz (AMC does not store it).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Channels to learn (`lfemur.rx`, …); they become the CPG's outputs.
    pub channels: Vec<String>,
    /// Names of the control inputs (empty: none).
    #[serde(default)]
    pub controls: Vec<String>,
    /// One or more motion segments, each with constant control values.
    pub segments: Vec<Segment>,
    /// Cut a seamless loop of this many gait cycles out of each segment and
    /// repeat it (0: use the segments as they are).
    #[serde(default = "default_cycles")]
    pub loop_cycles: usize,
    /// With loops: samples of each segment's repeated loop in the training sequence.
    #[serde(default = "default_samples")]
    pub samples_per_segment: usize,
}

fn default_rate() -> f64 {
    120.0
}
fn default_cycles() -> usize {
    1
}
fn default_samples() -> usize {
    2200
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// The AMC file.
    pub motion: PathBuf,
    /// Control values held during this segment, one per control input.
    #[serde(default)]
    pub controls: Vec<f64>,
    /// Frame range `[start, end)`, 0-based (default: all).
    pub frames: Option<[usize; 2]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReservoirSection {
    /// Base values: `wyffels-schrauwen-2009`.
    #[serde(default = "default_preset")]
    pub preset: String,
    /// Seed of the random weights.
    #[serde(default = "default_seed")]
    pub seed: u64,
    pub n_neurons: Option<usize>,
    pub connectivity: Option<f64>,
    pub spectral_radius: Option<f64>,
    pub leak_rate: Option<f64>,
    pub bias_range: Option<[f64; 2]>,
    pub feedback: Option<CouplingToml>,
    /// One coupling per control input (default: 50 % at ±0.2 each).
    pub inputs: Option<Vec<CouplingToml>>,
    /// `tanh` or `logistic`.
    pub activation: Option<String>,
    /// `f32` or `f64`.
    pub precision: Option<String>,
}

impl Default for ReservoirSection {
    fn default() -> Self {
        ReservoirSection {
            preset: default_preset(),
            seed: default_seed(),
            n_neurons: None,
            connectivity: None,
            spectral_radius: None,
            leak_rate: None,
            bias_range: None,
            feedback: None,
            inputs: None,
            activation: None,
            precision: None,
        }
    }
}

fn default_preset() -> String {
    "wyffels-schrauwen-2009".into()
}
fn default_seed() -> u64 {
    1
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingToml {
    pub fraction: f64,
    pub scale: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Training {
    #[serde(default = "default_washout")]
    pub washout: usize,
    #[serde(default = "default_validation")]
    pub validation_samples: usize,
    #[serde(default = "default_noise")]
    pub noise_variance: f64,
    #[serde(default = "default_draws")]
    pub noise_draws: usize,
    #[serde(default = "default_seed")]
    pub noise_seed: u64,
    /// Penalties `10^start, 10^(start−step), …, 10^stop`.
    #[serde(default = "default_penalties")]
    pub penalty_log10: PenaltyRange,
}

impl Default for Training {
    fn default() -> Self {
        Training {
            washout: default_washout(),
            validation_samples: default_validation(),
            noise_variance: default_noise(),
            noise_draws: default_draws(),
            noise_seed: default_seed(),
            penalty_log10: default_penalties(),
        }
    }
}

fn default_washout() -> usize {
    200
}
fn default_validation() -> usize {
    500
}
fn default_noise() -> f64 {
    1e-3
}
fn default_draws() -> usize {
    5
}
fn default_penalties() -> PenaltyRange {
    PenaltyRange { start: 1.0, step: 0.1, stop: -8.0 }
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PenaltyRange {
    pub start: f64,
    pub step: f64,
    pub stop: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// The model file to write.
    pub model: PathBuf,
}

impl Config {
    /// Reads and checks a configuration; relative paths are resolved against its directory.
    pub fn load(path: &Path) -> anyhow::Result<Config> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let mut c: Config = toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        fix(&mut c.data.skeleton);
        fix(&mut c.output.model);
        for s in &mut c.data.segments {
            fix(&mut s.motion);
        }
        if c.data.channels.is_empty() {
            bail!("{}: [data] channels is empty; name at least one channel such as \"lfemur.rx\"", path.display());
        }
        if c.data.segments.is_empty() {
            bail!("{}: [data] needs at least one [[data.segments]] with a motion file", path.display());
        }
        for (k, s) in c.data.segments.iter().enumerate() {
            if s.controls.len() != c.data.controls.len() {
                bail!(
                    "{}: segment {} has {} control values, [data] controls names {} ({})",
                    path.display(),
                    k + 1,
                    s.controls.len(),
                    c.data.controls.len(),
                    c.data.controls.join(", ")
                );
            }
        }
        Ok(c)
    }

    /// The reservoir configuration: the preset with the overrides applied.
    pub fn reservoir(&self) -> anyhow::Result<ReservoirConfig> {
        let r = &self.reservoir;
        let mut c = match r.preset.as_str() {
            "wyffels-schrauwen-2009" => ReservoirConfig::wyffels_schrauwen_2009(),
            other => bail!("unknown reservoir preset '{other}'; valid: wyffels-schrauwen-2009"),
        };
        c.n_outputs = self.data.channels.len();
        c.n_neurons = r.n_neurons.unwrap_or(c.n_neurons);
        c.connectivity = r.connectivity.unwrap_or(c.connectivity);
        c.spectral_radius = r.spectral_radius.unwrap_or(c.spectral_radius);
        c.leak_rate = r.leak_rate.unwrap_or(c.leak_rate);
        c.bias_range = r.bias_range.unwrap_or(c.bias_range);
        if let Some(f) = r.feedback {
            c.feedback = Coupling { fraction: f.fraction, scale: f.scale };
        }
        c.inputs = match &r.inputs {
            Some(v) => v.iter().map(|f| Coupling { fraction: f.fraction, scale: f.scale }).collect(),
            None => vec![Coupling { fraction: 0.5, scale: 0.2 }; self.data.controls.len()],
        };
        if c.inputs.len() != self.data.controls.len() {
            bail!(
                "[reservoir] inputs has {} couplings for {} control inputs",
                c.inputs.len(),
                self.data.controls.len()
            );
        }
        if let Some(a) = &r.activation {
            c.activation = match a.as_str() {
                "tanh" => Activation::Tanh,
                "logistic" => Activation::Logistic,
                other => bail!("[reservoir] activation '{other}'; valid: tanh, logistic"),
            };
        }
        if let Some(p) = &r.precision {
            c.precision = match p.as_str() {
                "f32" => Precision::F32,
                "f64" => Precision::F64,
                other => bail!("[reservoir] precision '{other}'; valid: f32, f64"),
            };
        }
        Ok(c)
    }
}

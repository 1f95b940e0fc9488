//! Building the fixed random weights of a reservoir.

use faer::Mat;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::config::{CheckedConfig, Coupling, ReservoirConfig};
use crate::error::{Error, Result};

/// Random-stream numbers: each matrix has its own stream of the seeded
/// generator, so adding a control input does not change W or the feedback.
const STREAM_W: u64 = 0;
const STREAM_FEEDBACK: u64 = 1;
const STREAM_BIAS: u64 = 2;
const STREAM_INPUT0: u64 = 16;

pub(crate) fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// A reservoir: the configuration and its fixed weights, all `f64`, row-major.
///
/// - `w_unit`: `N × N` recurrent weights, N(0, 1) where connected, rescaled to
///   spectral radius 1. The dynamics multiply `w_unit · x` by the configured
///   spectral radius ρ, so reservoirs that differ only in ρ share `w_unit`
///   (and batched runs can advance them with one product); [`Reservoir::w`]
///   is the product `ρ · w_unit`.
/// - `w_feedback`: `N × D` output-feedback weights.
/// - `w_input`: `N × U` control-input weights.
/// - `bias`: `N` biases.
#[derive(Debug, Clone, PartialEq)]
pub struct Reservoir {
    config: ReservoirConfig,
    seed: u64,
    w_unit: Vec<f64>,
    w_feedback: Vec<f64>,
    w_input: Vec<f64>,
    bias: Vec<f64>,
    raw_spectral_radius: f64,
}

fn coupling(rng: &mut ChaCha8Rng, n: usize, c: &Coupling) -> Vec<f64> {
    (0..n)
        .map(|_| {
            let connected = rng.random::<f64>() < c.fraction;
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            if connected { sign * c.scale } else { 0.0 }
        })
        .collect()
}

impl Reservoir {
    /// Draws the weights of `config` from `seed` and rescales W to spectral
    /// radius 1, computed from the eigenvalues of the (non-symmetric) matrix;
    /// the dynamics scale `W·x` by the configured radius.
    pub fn new(config: &CheckedConfig, seed: u64) -> Result<Reservoir> {
        let n = config.n_neurons;
        let mut r = rng(seed, STREAM_W);
        let mut w: Vec<f64> = (0..n * n)
            .map(|_| {
                let connected = r.random::<f64>() < config.connectivity;
                let v: f64 = r.sample(StandardNormal);
                if connected { v } else { 0.0 }
            })
            .collect();
        // Rounded to 9 decimals: eigenvalue routines on different instruction
        // sets may disagree in the last bits, and W must not.
        let raw = (spectral_radius(&w, n)? * 1e9).round() / 1e9;
        if raw <= 0.0 {
            return Err(Error::ZeroRadius);
        }
        let factor = 1.0 / raw;
        w.iter_mut().for_each(|v| *v *= factor);

        // Feedback: N × D, drawn output by output.
        let d = config.n_outputs;
        let mut r = rng(seed, STREAM_FEEDBACK);
        let by_output: Vec<Vec<f64>> = (0..d).map(|_| coupling(&mut r, n, &config.feedback)).collect();
        let w_feedback = (0..n).flat_map(|i| by_output.iter().map(move |col| col[i])).collect();

        let u = config.inputs.len();
        let by_input: Vec<Vec<f64>> = config
            .inputs
            .iter()
            .enumerate()
            .map(|(k, c)| coupling(&mut rng(seed, STREAM_INPUT0 + k as u64), n, c))
            .collect();
        let w_input = (0..n).flat_map(|i| by_input.iter().map(move |col| col[i])).collect::<Vec<f64>>();
        debug_assert_eq!(w_input.len(), n * u);

        let mut r = rng(seed, STREAM_BIAS);
        let [lo, hi] = config.bias_range;
        let bias = (0..n).map(|_| lo + (hi - lo) * r.random::<f64>()).collect();
        Ok(Reservoir {
            config: config.get().clone(),
            seed,
            w_unit: w,
            w_feedback,
            w_input,
            bias,
            raw_spectral_radius: raw,
        })
    }

    /// Rebuilds a reservoir from stored weights (a model file), checking
    /// shapes and values; `w_unit` is W at spectral radius 1.
    pub fn from_parts(
        config: ReservoirConfig,
        seed: u64,
        w_unit: Vec<f64>,
        w_feedback: Vec<f64>,
        w_input: Vec<f64>,
        bias: Vec<f64>,
        raw_spectral_radius: f64,
    ) -> Result<Reservoir> {
        let config = config.check()?;
        let (n, d, u) = (config.n_neurons, config.n_outputs, config.inputs.len());
        for (name, v, len) in [
            ("w", &w_unit, n * n),
            ("w_feedback", &w_feedback, n * d),
            ("w_input", &w_input, n * u),
            ("bias", &bias, n),
        ] {
            if v.len() != len {
                return Err(Error::Shape(format!("{name} has {} values, the config needs {len}", v.len())));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(Error::Shape(format!("{name}[{k}] is not finite")));
            }
        }
        Ok(Reservoir { config: config.get().clone(), seed, w_unit, w_feedback, w_input, bias, raw_spectral_radius })
    }

    /// The configuration.
    pub fn config(&self) -> &ReservoirConfig {
        &self.config
    }

    /// The seed the weights were drawn from.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Number of neurons.
    pub fn n_neurons(&self) -> usize {
        self.config.n_neurons
    }

    /// Number of outputs.
    pub fn n_outputs(&self) -> usize {
        self.config.n_outputs
    }

    /// Number of control inputs.
    pub fn n_inputs(&self) -> usize {
        self.config.inputs.len()
    }

    /// Recurrent weights at spectral radius 1, `N × N` row-major: what the
    /// dynamics multiply the state by before scaling with the radius.
    pub fn w_unit(&self) -> &[f64] {
        &self.w_unit
    }

    /// The effective recurrent weights `ρ · w_unit`, `N × N` row-major.
    pub fn w(&self) -> Vec<f64> {
        let rho = self.config.spectral_radius;
        self.w_unit.iter().map(|v| v * rho).collect()
    }

    /// Whether `other` has the same `w_unit` (same size, connectivity and
    /// seed), so that both can advance in one batched product.
    pub fn shares_w_with(&self, other: &Reservoir) -> bool {
        self.seed == other.seed
            && self.config.n_neurons == other.config.n_neurons
            && self.config.connectivity == other.config.connectivity
            && self.config.precision == other.config.precision
            && self.raw_spectral_radius == other.raw_spectral_radius
            && self.w_unit == other.w_unit
    }

    /// Feedback weights, `N × D` row-major.
    pub fn w_feedback(&self) -> &[f64] {
        &self.w_feedback
    }

    /// Control-input weights, `N × U` row-major.
    pub fn w_input(&self) -> &[f64] {
        &self.w_input
    }

    /// Biases.
    pub fn bias(&self) -> &[f64] {
        &self.bias
    }

    /// Spectral radius of the random matrix before rescaling.
    pub fn raw_spectral_radius(&self) -> f64 {
        self.raw_spectral_radius
    }
}

/// Largest eigenvalue modulus of the `n × n` row-major matrix `w`, from its
/// full (complex) eigenvalue decomposition.
pub fn spectral_radius(w: &[f64], n: usize) -> Result<f64> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{self, ComputeEigenvectors};
    let m = Mat::from_fn(n, n, |i, j| w[i * n + j]);
    let mut re = faer::diag::Diag::<f64>::zeros(n);
    let mut im = faer::diag::Diag::<f64>::zeros(n);
    // Sequential on purpose: the result must not depend on the thread count.
    let par = faer::Par::Seq;
    let scratch = evd::evd_scratch::<f64>(n, ComputeEigenvectors::No, ComputeEigenvectors::No, par, Default::default());
    evd::evd_real(
        m.as_ref(),
        re.as_mut(),
        im.as_mut(),
        None,
        None,
        par,
        MemStack::new(&mut MemBuffer::new(scratch)),
        Default::default(),
    )
    .map_err(|_| Error::Eigenvalues { n })?;
    let (re, im) = (re.column_vector(), im.column_vector());
    Ok((0..n).map(|k| re[k].hypot(im[k])).fold(0.0, f64::max))
}

//! # cpg-reservoir
//!
//! A reservoir-computing central pattern generator after wyffels & Schrauwen
//! (2009): a leaky-integrator echo state network with output feedback and
//! control inputs,
//!
//! ```text
//! x[k+1] = (1 − λ)·x[k] + λ·f(W·x[k] + W_in·u[k] + W_fb·y[k] + b)
//! y[k]   = W_out·x[k] + b_out
//! ```
//!
//! whose readout `W_out` is trained by ridge regression on teacher-forced
//! states, with the penalty chosen by running every candidate freely, with
//! state noise, over a validation sequence.
//!
//! - [`ReservoirConfig`] → [`ReservoirConfig::check`] → [`Reservoir::new`]: seeded weights,
//!   W rescaled to a spectral radius computed from its eigenvalues.
//! - [`train`]: harvest, all penalties from one factorisation
//!   ([`cpg_regression::RidgePath`]), batched noisy free-run validation across all
//!   cores, best penalty.
//! - [`TrainedCpg`]: the model with provenance, saved in a versioned, checksummed file.
//! - [`Generator`]: allocation-free `step(control) → output` for a control loop.
//! - [`batch::free_runs`]: many free runs per pass over the weights (runs
//!   that share `Ŵ` advance with one matrix-matrix product per step).
//!
//! Determinism: the same configuration, seed and data give bit-identical
//! weights, models and outputs whatever the number of threads. Inner loops
//! sum in a fixed order (the recurrent product by chains of fused
//! multiply-adds) and `tanh` is computed by this crate, not by libm.

pub mod batch;
mod config;
mod controls;
mod engine;
mod error;
mod force;
mod generator;
pub mod kernel;
mod model;
mod orbit;
mod real;
mod reservoir;
mod train;
pub mod watch;

pub use config::{
    Activation, CheckedConfig, Coupling, MAX_NEURONS, MAX_OUTPUTS, Precision, Preset, ReservoirConfig,
    ReservoirSettings,
};
pub use engine::Hold;
pub use error::{ConfigError, Error, Result};
pub use force::{ForceSettings, train_force_on};
pub use generator::Generator;
pub use model::{
    FORMAT_VERSION, MAGIC, MAX_MODEL_BYTES, MAX_SAMPLE_RATE_HZ, MIN_SAMPLE_RATE_HZ, OutputChannel, Provenance, Teacher,
    TrainedCpg, VELOCITY_SUFFIX, check_name, integrate_in_place, to_units, to_units_in_place,
};
pub use orbit::{OrbitStay, STILL_VARIANCE, orbit_nmse};
pub use real::Real;
pub use reservoir::{Reservoir, spectral_radius};
pub use train::{
    Candidate, Harvest, Score, Scoring, SelfFed, Sequence, TrainSettings, Training, TrainingData, ValidationPoint,
    harvest, teacher_forced_states, train, train_on, validate,
};

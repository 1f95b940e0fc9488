//! Errors of this crate.

use std::path::PathBuf;

/// A configuration value out of its valid range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid reservoir config: `{field}` = {value}; {expected}")]
pub struct ConfigError {
    /// The field, as a path (`feedback.fraction`, `inputs[1].scale`).
    pub field: String,
    /// Its value, as text.
    pub value: String,
    /// The valid range.
    pub expected: String,
}

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A bad configuration.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A failure in the regression.
    #[error(transparent)]
    Regression(#[from] cpg_regression::Error),
    /// The eigenvalues of the reservoir matrix could not be computed.
    #[error("eigenvalues of the {n}×{n} reservoir matrix did not converge")]
    Eigenvalues {
        /// Matrix size.
        n: usize,
    },
    /// Every candidate penalty's validation free run diverged.
    #[error("every one of the {candidates} candidate penalties diverged in validation")]
    AllDiverged {
        /// Candidates validated.
        candidates: usize,
    },
    /// The random matrix has spectral radius 0 (for example no connections), so it cannot be rescaled.
    #[error("the reservoir matrix has spectral radius 0 and cannot be rescaled (connectivity too low?)")]
    ZeroRadius,
    /// Data of the wrong shape.
    #[error("shape mismatch: {0}")]
    Shape(String),
    /// A NaN or infinity in input data.
    #[error("{what}: non-finite value at sample {sample}, column {column}")]
    NonFiniteInput {
        /// Which input.
        what: &'static str,
        /// Sample index.
        sample: usize,
        /// Column index.
        column: usize,
    },
    /// The network state or output became NaN or infinite.
    #[error("the network diverged: non-finite {what} at step {step}")]
    Diverged {
        /// `state` or `output`.
        what: &'static str,
        /// Step counter of the generator.
        step: u64,
    },
    /// The caller cancelled its [`crate::watch::Watch`] and the work stopped.
    #[error("cancelled")]
    Cancelled,
    /// Bad training settings.
    #[error("invalid training settings: {0}")]
    Settings(String),
    /// Reading or writing a model file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A model file that cannot be loaded.
    #[error("{path}: {reason}")]
    ModelFile {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

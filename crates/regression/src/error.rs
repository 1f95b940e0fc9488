//! Errors of this crate.

/// What can go wrong in a regression.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Matrices whose shapes do not fit together.
    #[error("shape mismatch: {0}")]
    Shape(String),
    /// A NaN or infinity in the data.
    #[error("{what} contains a non-finite value at row {row}, column {col}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Row of the first bad value.
        row: usize,
        /// Column of the first bad value.
        col: usize,
    },
    /// A penalty that is negative or not finite.
    #[error("penalty {0} is not a finite number >= 0")]
    InvalidPenalty(f64),
    /// A grid that is empty or malformed.
    #[error("invalid penalty grid: {0}")]
    InvalidGrid(String),
    /// The eigendecomposition failed to converge.
    #[error("eigendecomposition of the Gram matrix did not converge")]
    Decomposition,
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

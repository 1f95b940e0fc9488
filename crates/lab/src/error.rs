//! Errors of this crate.

use std::path::PathBuf;

/// Everything that can go wrong in an experiment or a training run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration file that cannot be used.
    #[error("{}", config_message(file, *line, field, message))]
    Config {
        /// The file.
        file: PathBuf,
        /// Its line, when known (1-based).
        line: Option<usize>,
        /// The field, as written in the file (`training.penalty_log10`), or empty.
        field: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Data that cannot be turned into a training sequence.
    #[error("{0}")]
    Data(String),
    /// A request larger than the stated budget.
    #[error("{what} needs about {needed_mib} MiB; the limit is {limit_mib} MiB ({hint})")]
    Budget {
        /// What was asked for.
        what: String,
        /// Estimated memory.
        needed_mib: u64,
        /// The limit.
        limit_mib: u64,
        /// How to stay within it.
        hint: &'static str,
    },
    /// From the motion-capture layer.
    #[error(transparent)]
    Mocap(#[from] cpg_mocap::Error),
    /// From the reservoir.
    #[error(transparent)]
    Reservoir(#[from] cpg_reservoir::Error),
    /// From the regression.
    #[error(transparent)]
    Regression(#[from] cpg_regression::Error),
    /// From the comparison of generator families.
    #[error(transparent)]
    Compare(#[from] cpg_compare::Error),
    /// From the centralized networks.
    #[error(transparent)]
    Centralized(#[from] cpg_centralized::Error),
    /// From the DMP.
    #[error(transparent)]
    Dmp(#[from] cpg_dmp::Error),
    /// From the HOAP-2 layer.
    #[error(transparent)]
    Hoap2(#[from] cpg_hoap2::Error),
}

fn config_message(file: &std::path::Path, line: Option<usize>, field: &str, message: &str) -> String {
    let place = match line {
        Some(l) => format!("{}:{l}", file.display()),
        None => file.display().to_string(),
    };
    if field.is_empty() { format!("{place}: {message}") } else { format!("{place}: `{field}` {message}") }
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

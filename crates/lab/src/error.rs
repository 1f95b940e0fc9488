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
    /// A data file (a table of control values) that does not hold what was
    /// expected at a line.
    #[error("{}", file_message(file, *line, message))]
    DataFile {
        /// The file.
        file: PathBuf,
        /// Its line, when known (1-based).
        line: Option<usize>,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A name that is not there: a mocap channel, a point of the skeleton, a
    /// control input, a channel a joint map needs.
    #[error("{message}")]
    Name {
        /// The name as given.
        name: String,
        /// The whole message (it names the name).
        message: String,
    },
    /// Control values that do not fit the model's control inputs.
    #[error("{0}")]
    Control(String),
    /// Sizes that do not fit each other: values that are not frames of the
    /// channels, runs shorter than the measure needs.
    #[error("{0}")]
    Shape(String),
    /// A number outside its bounds: a rate, a duration, a size of work.
    #[error("{0}")]
    Bound(String),
    /// The data lacks what the work needs: a rhythm, a looped segment, a
    /// teacher cycle, a full stride, a skeleton.
    #[error("{0}")]
    Unusable(String),
    /// An output format that cannot be written as asked.
    #[error("{0}")]
    Format(String),
    /// A file that cannot be read or written (bounded reads, atomic writes).
    #[error(transparent)]
    File(#[from] cpg_io::Error),
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
    Hoap2(#[from] cpg_robot::Error),
}

fn config_message(file: &std::path::Path, line: Option<usize>, field: &str, message: &str) -> String {
    let place = match line {
        Some(l) => format!("{}:{l}", file.display()),
        None => file.display().to_string(),
    };
    if field.is_empty() { format!("{place}: {message}") } else { format!("{place}: `{field}` {message}") }
}

impl Error {
    /// A [`Error::Name`] error about `name`.
    pub(crate) fn name(name: &str, message: impl Into<String>) -> Error {
        Error::Name { name: name.to_owned(), message: message.into() }
    }

    /// A [`Error::DataFile`] error about `file` at `line`.
    pub(crate) fn data_file(file: &std::path::Path, line: Option<usize>, message: impl Into<String>) -> Error {
        Error::DataFile { file: file.to_owned(), line, message: message.into() }
    }
}

fn file_message(file: &std::path::Path, line: Option<usize>, message: &str) -> String {
    match line {
        Some(l) => format!("{}:{l}: {message}", file.display()),
        None => format!("{}: {message}", file.display()),
    }
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

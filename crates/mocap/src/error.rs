//! Error types. Parse errors carry the file name, line and column of the
//! offending token and say what was expected.

use std::fmt;
use std::path::PathBuf;

use crate::Dof;

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be parsed.
    #[error(transparent)]
    Parse(#[from] ParseError),
    /// A file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file that was being read.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A file is larger than this crate reads.
    #[error("{}: larger than {max_bytes} bytes, the most read from one input file", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The limit.
        max_bytes: u64,
    },
    /// A channel name is not part of a motion.
    #[error("unknown channel '{name}'{}; valid channels are: {}", cpg_io::did_you_mean(name, valid.iter().map(String::as_str)), valid.join(", "))]
    UnknownChannel {
        /// The name that was asked for.
        name: String,
        /// Every channel the motion has.
        valid: Vec<String>,
    },
    /// Two motions cannot be combined.
    #[error("motions do not match: {0}")]
    Mismatch(String),
    /// An argument is out of its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A channel has no variance, so it cannot be z-scored.
    #[error("channel '{0}' is constant (standard deviation 0); it cannot be z-scored")]
    ConstantChannel(String),
    /// A motion does not fit a skeleton.
    #[error("motion does not fit skeleton '{skeleton}': {detail}")]
    SkeletonMismatch {
        /// Name of the skeleton.
        skeleton: String,
        /// What is missing or extra.
        detail: String,
    },
    /// No data directory holds the requested files.
    #[error("{what} not found; looked in:\n{}", tried.iter().map(|p| format!("  {}", p.display())).collect::<Vec<_>>().join("\n"))]
    DataNotFound {
        /// What was looked for.
        what: String,
        /// Every place that was tried, in order.
        tried: Vec<PathBuf>,
    },
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A parse failure at a known place in a file.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// Name of the file (or the label the caller gave the text).
    pub file: String,
    /// 1-based line number.
    pub line: usize,
    /// 1-based column (in characters) of the offending token; 0 when the whole line or file is meant.
    pub column: usize,
    /// What went wrong.
    pub kind: ParseErrorKind,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.column > 0 {
            write!(f, "{}:{}:{}: {}", self.file, self.line, self.column, self.kind)
        } else {
            write!(f, "{}:{}: {}", self.file, self.line, self.kind)
        }
    }
}

impl std::error::Error for ParseError {}

fn dofs(d: &[Dof]) -> String {
    d.iter().map(|d| d.as_str()).collect::<Vec<_>>().join(" ")
}

/// The kinds of parse failure.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParseErrorKind {
    /// The bytes are not UTF-8 text (binary garbage, wrong encoding).
    #[error("not UTF-8 text (byte {byte_offset}); expected a text motion-capture file (ASF, AMC or BVH)")]
    NotUtf8 {
        /// Offset of the first invalid byte.
        byte_offset: usize,
    },
    /// Lines end in a carriage return alone (old Mac OS), which the line-based formats cannot read.
    #[error(
        "the lines end in a carriage return alone (old Mac OS line endings); convert them to LF or CRLF (e.g. `tr '\\r' '\\n'`)"
    )]
    CrOnlyLineEnds,
    /// The file has no content.
    #[error("file is empty; expected {expected}")]
    Empty {
        /// What the file should contain.
        expected: &'static str,
    },
    /// The file ended too early.
    #[error("unexpected end of file; expected {expected}")]
    UnexpectedEof {
        /// What should have followed.
        expected: String,
    },
    /// A token is not what the grammar allows here.
    #[error("expected {expected}, found '{found}'")]
    Unexpected {
        /// What the grammar allows.
        expected: String,
        /// What is there.
        found: String,
    },
    /// A token is not a number.
    #[error("'{token}' is not a number; expected {expected}")]
    BadNumber {
        /// The token.
        token: String,
        /// What number was expected.
        expected: &'static str,
    },
    /// A number is NaN or infinite (or too large to represent).
    #[error("'{token}' is not a finite number")]
    NonFinite {
        /// The token.
        token: String,
    },
    /// A finite number too large in magnitude to mean anything here.
    #[error("'{token}' is out of range; expected {expected} within ±{max}")]
    OutOfRange {
        /// The token.
        token: String,
        /// What number was expected.
        expected: &'static str,
        /// The largest magnitude allowed.
        max: f64,
    },
    /// A line has too few or too many values.
    #[error("'{keyword}' takes {expected} values, found {found}")]
    Arity {
        /// The keyword or bone of the line.
        keyword: String,
        /// How many values it takes.
        expected: usize,
        /// How many there are.
        found: usize,
    },
    /// An unknown degree-of-freedom name.
    #[error("unknown degree of freedom '{0}'; expected one of tx ty tz rx ry rz")]
    UnknownDof(String),
    /// An unknown axis order.
    #[error("unknown axis order '{0}'; expected a permutation of XYZ")]
    UnknownAxisOrder(String),
    /// A bone name that the skeleton does not have.
    #[error("unknown bone '{0}'")]
    UnknownBone(String),
    /// A bone is defined twice in the ASF.
    #[error("bone '{0}' is defined twice")]
    DuplicateBone(String),
    /// A bone block lacks a required field.
    #[error("bone '{bone}' has no '{field}'")]
    MissingField {
        /// The bone.
        bone: String,
        /// The missing field.
        field: &'static str,
    },
    /// `limits` does not have one interval per DOF.
    #[error("bone '{bone}' has {found} limit intervals, its dof line declares {expected}")]
    LimitsCount {
        /// The bone.
        bone: String,
        /// Number of DOFs.
        expected: usize,
        /// Number of intervals.
        found: usize,
    },
    /// The hierarchy is not a tree rooted at `root`.
    #[error("hierarchy: {0}")]
    Hierarchy(String),
    /// A required section is missing.
    #[error("missing section '{0}'")]
    MissingSection(&'static str),
    /// An AMC bone line has the wrong number of values.
    #[error("bone '{bone}' has {found} values, skeleton declares {} ({})", declared.len(), dofs(declared))]
    WrongValueCount {
        /// The bone.
        bone: String,
        /// Values on the line.
        found: usize,
        /// DOFs in the skeleton.
        declared: Vec<Dof>,
    },
    /// A frame number is not the next one.
    #[error("frame number {found}, expected {expected} (frames must be numbered consecutively)")]
    FrameNumber {
        /// The frame number that should come next.
        expected: usize,
        /// The one that is there.
        found: usize,
    },
    /// A bone appears twice in one frame.
    #[error("bone '{bone}' appears twice in frame {frame}")]
    DuplicateInFrame {
        /// The bone.
        bone: String,
        /// The frame number.
        frame: usize,
    },
    /// A frame lacks bones that carry DOFs.
    #[error("frame {frame} lacks bones: {}", bones.join(", "))]
    MissingInFrame {
        /// The frame number.
        frame: usize,
        /// The bones that were not given.
        bones: Vec<String>,
    },
    /// A bone that has no DOFs appears in a frame.
    #[error("bone '{0}' has no degrees of freedom in the skeleton but appears in a frame")]
    NoDofBone(String),
    /// The AMC file has no frames.
    #[error("no frames")]
    NoFrames,
}

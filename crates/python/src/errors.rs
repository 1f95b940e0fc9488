//! Errors as Python sees them: `cpg.CpgError` (a `ValueError`) with the
//! library's message, `TypeError` for arguments of the wrong type, and the
//! checks of whole-number and rate arguments.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyInt};

// The module named is the one pickle finds it in: `cpg.CpgError` (re-exported there).
pyo3::create_exception!(
    cpg,
    CpgError,
    pyo3::exceptions::PyValueError,
    "An error of the cpg library: a file that cannot be read or parsed, an input of the wrong shape or out of range, a model that diverged. The message is the library's."
);

/// The library error as a Python exception.
pub(crate) fn err(e: impl std::fmt::Display) -> PyErr {
    CpgError::new_err(e.to_string())
}

/// A whole number argument within `lo..=hi`: a `TypeError` when it is not an
/// integer, a `CpgError` naming the range when it is out of it (never an
/// `OverflowError`, whatever its size or sign).
pub(crate) fn int_arg(v: &Bound<'_, PyAny>, name: &str, lo: u64, hi: u64) -> PyResult<u64> {
    if v.is_instance_of::<PyBool>() || !v.is_instance_of::<PyInt>() {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "{name}: expected an integer, got {}",
            v.get_type().name()?
        )));
    }
    match v.extract::<u64>() {
        Ok(x) if (lo..=hi).contains(&x) => Ok(x),
        _ => Err(err(format!("{name} = {}: expected a whole number from {lo} to {hi}", short(&v.str()?.to_string())))),
    }
}

/// Text clipped for a message (a Python int can have a million digits).
pub(crate) fn short(s: &str) -> String {
    if s.chars().count() <= 40 { s.to_owned() } else { format!("{}…", s.chars().take(40).collect::<String>()) }
}

/// A sample rate argument: finite, within the library's range.
pub(crate) fn rate_arg(rate_hz: f64, name: &str) -> PyResult<f64> {
    use cpg_reservoir::{MAX_SAMPLE_RATE_HZ, MIN_SAMPLE_RATE_HZ};
    if !(rate_hz.is_finite() && (MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&rate_hz)) {
        return Err(err(format!("{name} = {rate_hz}: expected {MIN_SAMPLE_RATE_HZ} to {MAX_SAMPLE_RATE_HZ} Hz")));
    }
    Ok(rate_hz)
}

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

/// A whole number argument within `lo..=hi`: a Python `int` or anything
/// that is one (`numpy.int64`: whatever `operator.index` takes, booleans
/// aside); a `TypeError` when it is not an integer, a `CpgError` naming the
/// range when it is out of it (never an `OverflowError`, whatever its size or sign).
pub(crate) fn int_arg(v: &Bound<'_, PyAny>, name: &str, lo: u64, hi: u64) -> PyResult<u64> {
    let v = as_int(v).ok_or_else(|| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "{name}: expected an integer, got {}",
            v.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))
    })?;
    match v.extract::<u64>() {
        Ok(x) if (lo..=hi).contains(&x) => Ok(x),
        _ => Err(err(format!("{name} = {}: expected a whole number from {lo} to {hi}", short(&v.str()?.to_string())))),
    }
}

/// `v` as a Python `int` when it is a whole number (an `int`, a numpy
/// integer, anything `operator.index` takes), not a boolean (Python's or numpy's).
pub(crate) fn as_int<'py>(v: &Bound<'py, PyAny>) -> Option<Bound<'py, PyAny>> {
    if v.is_instance_of::<PyBool>() || is_numpy_bool(v) {
        return None;
    }
    if v.is_instance_of::<PyInt>() {
        return Some(v.clone());
    }
    v.py().import("operator").ok()?.call_method1("index", (v,)).ok()
}

/// Whether `v` is a numpy boolean (`numpy.bool_`), which is no Python `bool`.
pub(crate) fn is_numpy_bool(v: &Bound<'_, PyAny>) -> bool {
    v.get_type().name().is_ok_and(|n| n == "bool" || n == "bool_")
        && v.get_type().module().is_ok_and(|m| m.to_string().starts_with("numpy"))
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

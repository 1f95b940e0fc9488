//! Files from Python as the command line handles them (`cpg_io`): bounded
//! reads, outputs checked before the work and written by the project's rule
//! (`-` is standard output; a regular file atomically, through a temporary
//! beside it renamed over it; a symlink's target; a device, FIFO or socket
//! in place, never replaced; a directory or a missing directory refused). The
//! simulator's command-line tools (`cpg-sim`, `cpg.sim_search`,
//! `cpg.walk_eval`) read and write through these.

use std::io::Write;
use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyBytes;

use crate::errors::*;

/// Fails at once, before any work, when `path` cannot be written (a
/// directory, a missing or read-only directory); returns how messages name
/// it ("standard output" for `-`).
#[pyfunction]
pub(crate) fn _check_output(path: PathBuf) -> PyResult<String> {
    Ok(cpg_io::check_writable(&path).map_err(err)?.describe())
}

/// Writes `data` where `path` points, by the project's rule (see the module).
/// On failure nothing is left behind: the old file stays and the temporary goes.
#[pyfunction]
pub(crate) fn _write_output(py: Python<'_>, path: PathBuf, data: &[u8]) -> PyResult<()> {
    // Python's own buffered standard output first, so that `-` keeps the order of what was printed.
    if path.as_os_str() == "-" {
        py.import("sys")?.getattr("stdout")?.call_method0("flush")?;
    }
    let data = data.to_vec();
    py.detach(move || {
        cpg_io::write_output(&path, |w: &mut dyn Write| {
            w.write_all(&data).map_err(|source| cpg_io::Error::Io { path: path.clone(), source })
        })
    })
    .map_err(err)
}

/// The bytes of `path`, refused as soon as it holds more than `max_bytes`
/// (`/dev/zero` or an endless pipe is refused at the bound, not after filling the memory).
#[pyfunction]
pub(crate) fn _read_bounded<'py>(py: Python<'py>, path: PathBuf, max_bytes: u64) -> PyResult<Bound<'py, PyBytes>> {
    let bytes = py.detach(move || cpg_io::read_bounded(&path, max_bytes)).map_err(err)?;
    Ok(PyBytes::new(py, &bytes))
}

//! Conversion between Python and the library: arrays to and from numpy
//! (any array-like in, float64 out), dicts to TOML configurations, JSON
//! values to Python objects, and long work off the GIL (Ctrl-C answered).

use cpg_lab::Config;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::path::PathBuf;

use crate::errors::*;

/// Anything NumPy reads as numbers (arrays of any dtype, lists of lists,
/// objects with `__array__`), as float64 values with their shape, converted
/// once; a 1-D input is one channel. Errors name the argument and the shape.
pub(crate) fn matrix(py: Python<'_>, v: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<f64>, usize, usize)> {
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (v, "float64")).map_err(|e| {
        err(format!("{name}: expected numbers NumPy can read as float64 (time × channels): {}", e.value(py)))
    })?;
    let a = np.call_method1("ascontiguousarray", (a,))?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    let a = match shape.as_slice() {
        [n] => a.call_method1("reshape", ((*n, 1usize),))?,
        [_, _] => a,
        other => {
            return Err(err(format!(
                "{name}: an array of shape ({}); expected time × channels (or one channel as a 1-D array){}",
                other.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "),
                if other.len() == 3 { "; give several segments to fit_segments([...])" } else { "" }
            )));
        }
    };
    let arr: PyReadonlyArray2<'_, f64> = a.extract()?;
    Ok(rows(&arr))
}

/// One value per `n` (a control or an output row) from anything NumPy reads as numbers.
pub(crate) fn vector(py: Python<'_>, v: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (v, "float64"))
        .map_err(|e| err(format!("{name}: expected {n} numbers NumPy can read as float64: {}", e.value(py))))?;
    let flat: Vec<f64> = np.call_method1("ravel", (a,))?.call_method0("tolist")?.extract()?;
    if flat.len() != n {
        return Err(err(format!("{name}: {} value(s) for {n}", flat.len())));
    }
    Ok(flat)
}

/// The threads long work runs on: the machine's cores.
pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The largest magnitude of a value given as data, as in motion files.
pub(crate) const MAX_VALUE: f64 = cpg_mocap::MAX_MAGNITUDE;

/// What a progress line says about long work: its label and the free-run
/// steps it will take in all (what [`cpg_reservoir::watch::Watch::steps`] counts).
pub(crate) struct Progress {
    pub label: String,
    pub total_steps: u64,
}

/// Runs `work` on its own thread while this one answers signals: Ctrl-C
/// raises `KeyboardInterrupt` within 0.1 s and cancels the work's watch,
/// which the worker thread carries ([`cpg_reservoir::watch`], and every pool
/// `cpg_lab::in_pool` builds inside it): training, validation and free runs
/// stop at their next check, within a few thousand steps, so no core stays
/// busy after the interrupt. `work` may also read the watch itself.
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(&cpg_reservoir::watch::Watch) -> T + Send + 'static,
) -> PyResult<T> {
    interruptible_with(py, None, work)
}

/// [`interruptible`], showing `progress` on standard error while the work
/// runs longer than a second, when standard error is a terminal: a bar, the
/// share done, the seconds so far and the estimate of those left (as the
/// command line's bars do); the line is cleared at the end.
pub(crate) fn interruptible_with<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<Progress>,
    work: impl FnOnce(&cpg_reservoir::watch::Watch) -> T + Send + 'static,
) -> PyResult<T> {
    use cpg_reservoir::watch::Watch;
    use std::sync::Arc;
    let watch = Arc::new(Watch::default());
    let (tx, rx) = std::sync::mpsc::channel();
    let mine = watch.clone();
    std::thread::Builder::new()
        .name("cpg-work".into())
        .spawn(move || {
            cpg_reservoir::watch::set_for_this_thread(Some(mine.clone()));
            let _ = tx.send(work(&mine));
        })
        .map_err(err)?;
    let start = std::time::Instant::now();
    let stderr = py.import("sys")?.getattr("stderr")?;
    let tty = progress.is_some() && stderr.call_method0("isatty").and_then(|v| v.extract::<bool>()).unwrap_or(false);
    let mut shown = false;
    let mut rx = rx;
    let result = loop {
        let (got, back) = py.detach(move || (rx.recv_timeout(std::time::Duration::from_millis(50)), rx));
        rx = back;
        match got {
            Ok(v) => break Ok(v),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                break Err(err("the work stopped without a result (it panicked)"));
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    watch.cancel();
                    break Err(e);
                }
                if let (true, Some(p)) = (tty, &progress)
                    && start.elapsed().as_secs_f64() >= 1.0
                {
                    let _ = stderr.call_method1("write", (progress_line(p, watch.steps_done(), start.elapsed()),));
                    let _ = stderr.call_method0("flush");
                    shown = true;
                }
            }
        }
    };
    if shown {
        let _ = stderr.call_method1("write", ("\r\x1b[K",));
        let _ = stderr.call_method0("flush");
    }
    result
}

/// One progress line, drawn over the last (`\r`).
fn progress_line(p: &Progress, done: u64, elapsed: std::time::Duration) -> String {
    let share = if p.total_steps == 0 { 0.0 } else { (done as f64 / p.total_steps as f64).clamp(0.0, 1.0) };
    let width = 30;
    let filled = (share * width as f64).round() as usize;
    let secs = elapsed.as_secs_f64();
    let eta = if share > 0.01 { format!(" (eta {:.0} s)", secs * (1.0 - share) / share) } else { String::new() };
    format!(
        "\r{} [{}{}] {:>3.0}% {secs:.0} s{eta}\x1b[K",
        p.label,
        "#".repeat(filled),
        "-".repeat(width - filled),
        100.0 * share
    )
}

/// A 2-D float64 array as row-major values, with its shape (any strides, any order).
pub(crate) fn rows(a: &PyReadonlyArray2<'_, f64>) -> (Vec<f64>, usize, usize) {
    let v = a.as_array();
    let (n, d) = v.dim();
    (v.iter().copied().collect(), n, d)
}

pub(crate) fn array2<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    n: usize,
    d: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Ok(Array2::from_shape_vec((n, d), values).map_err(err)?.into_pyarray(py))
}

/// A `serde_json` value as Python objects (dicts, lists, floats, ints, strings, None).
pub(crate) fn to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value as V;
    Ok(match v {
        V::Null => py.None().into_bound(py),
        V::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        V::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => PyInt::new(py, i).into_any(),
            (None, Some(f)) => PyFloat::new(py, f).into_any(),
            _ => py.None().into_bound(py),
        },
        V::String(s) => PyString::new(py, s).into_any(),
        V::Array(a) => {
            let items: Vec<Bound<'py, PyAny>> = a.iter().map(|x| to_py(py, x)).collect::<PyResult<_>>()?;
            PyList::new(py, items)?.into_any()
        }
        V::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// The deepest nesting of a configuration dict taken (TOML tables nest a few levels).
pub(crate) const MAX_CONFIG_DEPTH: usize = 32;

/// A Python dict (with lists, numbers, strings, booleans, paths; None means
/// "leave the key out") as a TOML value. A dict or list nested deeper than
/// [`MAX_CONFIG_DEPTH`], or that contains itself, is an error.
pub(crate) fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<Option<toml::Value>> {
    to_toml_at(v, key, &mut Vec::new())
}

pub(crate) fn to_toml_at(v: &Bound<'_, PyAny>, key: &str, path: &mut Vec<usize>) -> PyResult<Option<toml::Value>> {
    if v.is_none() {
        return Ok(None);
    }
    let name = if key.is_empty() { "the configuration".to_owned() } else { format!("`{key}`") };
    let container = v.is_instance_of::<PyDict>() || v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>();
    if container {
        let id = v.as_ptr() as usize;
        if path.contains(&id) {
            return Err(err(format!("{name} contains itself")));
        }
        if path.len() >= MAX_CONFIG_DEPTH {
            return Err(err(format!("{name}: nested more than {MAX_CONFIG_DEPTH} levels deep")));
        }
        path.push(id);
    }
    let out = to_toml_inner(v, key, path);
    if container {
        path.pop();
    }
    out
}

pub(crate) fn to_toml_inner(v: &Bound<'_, PyAny>, key: &str, path: &mut Vec<usize>) -> PyResult<Option<toml::Value>> {
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| err(format!("{key}: keys must be strings")))?;
            let p = if key.is_empty() { k.clone() } else { format!("{key}.{k}") };
            if let Some(val) = to_toml_at(&x, &p, path)? {
                t.insert(k, val);
            }
        }
        return Ok(Some(toml::Value::Table(t)));
    }
    if v.is_instance_of::<PyBool>() || is_numpy_bool(v) {
        return Ok(Some(toml::Value::Boolean(v.is_truthy()?)));
    }
    // A whole number, numpy's included (numpy.int64(50) is an integer, not 50.0).
    if let Some(i) = as_int(v) {
        let i: i64 = i.extract().map_err(|_| err(format!("`{key}`: an integer beyond 64 bits")))?;
        return Ok(Some(toml::Value::Integer(i)));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Some(toml::Value::String(v.extract()?)));
    }
    if let Ok(f) = v.extract::<f64>() {
        return Ok(Some(toml::Value::Float(f)));
    }
    if let Ok(p) = v.extract::<PathBuf>() {
        return Ok(Some(toml::Value::String(p.display().to_string())));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (k, x) in v.try_iter()?.enumerate() {
            if let Some(val) = to_toml_at(&x?, &format!("{key}[{k}]"), path)? {
                items.push(val);
            }
        }
        return Ok(Some(toml::Value::Array(items)));
    }
    Err(err(format!("`{key}`: a {} cannot be a configuration value", v.get_type().name()?)))
}

pub(crate) fn config_from_table(t: &toml::Table, name: &str) -> PyResult<Config> {
    let here = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    cpg_lab::fit::config_from_table(t, name, &here).map_err(err)
}

//! `cpg._cpg`: the native part of the `cpg` Python package. Arrays go in
//! and out as numpy float64 arrays shaped (time, channels); every error of
//! the library becomes `cpg.CpgError` (a `ValueError`) with the library's
//! message; long work (training, free runs, evaluation) releases the GIL.
//! The Python layer (`python/cpg/__init__.py`) re-exports this module and
//! documents it; the stubs are `python/cpg/_cpg.pyi`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use cpg_hoap2::{ChannelMap, Robot as UrdfRobot};
use cpg_lab::format::Format;
use cpg_lab::run::Controls;
use cpg_lab::{Config, ControlSchedule};
use cpg_mocap::{BvhOptions, Skeleton};
use cpg_reservoir::TrainedCpg;

// The module named is the one pickle finds it in: `cpg.CpgError` (re-exported there).
pyo3::create_exception!(
    cpg,
    CpgError,
    pyo3::exceptions::PyValueError,
    "An error of the cpg library: a file that cannot be read or parsed, an input of the wrong shape or out of range, a model that diverged. The message is the library's."
);

/// The library error as a Python exception.
fn err(e: impl std::fmt::Display) -> PyErr {
    CpgError::new_err(e.to_string())
}

/// A whole number argument within `lo..=hi`: a `TypeError` when it is not an
/// integer, a `CpgError` naming the range when it is out of it (never an
/// `OverflowError`, whatever its size or sign).
fn int_arg(v: &Bound<'_, PyAny>, name: &str, lo: u64, hi: u64) -> PyResult<u64> {
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
fn short(s: &str) -> String {
    if s.chars().count() <= 40 { s.to_owned() } else { format!("{}…", s.chars().take(40).collect::<String>()) }
}

/// A sample rate argument: finite, within the library's range.
fn rate_arg(rate_hz: f64, name: &str) -> PyResult<f64> {
    use cpg_reservoir::{MAX_SAMPLE_RATE_HZ, MIN_SAMPLE_RATE_HZ};
    if !(rate_hz.is_finite() && (MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&rate_hz)) {
        return Err(err(format!("{name} = {rate_hz}: expected {MIN_SAMPLE_RATE_HZ} to {MAX_SAMPLE_RATE_HZ} Hz")));
    }
    Ok(rate_hz)
}

/// Anything NumPy reads as numbers (arrays of any dtype, lists of lists,
/// objects with `__array__`), as float64 values with their shape, converted
/// once; a 1-D input is one channel. Errors name the argument and the shape.
fn matrix(py: Python<'_>, v: &Bound<'_, PyAny>, name: &str) -> PyResult<(Vec<f64>, usize, usize)> {
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
                if other.len() == 3 { "; give several segments as segments=[...]" } else { "" }
            )));
        }
    };
    let arr: PyReadonlyArray2<'_, f64> = a.extract()?;
    Ok(rows(&arr))
}

/// One value per `n` (a control or an output row) from anything NumPy reads as numbers.
fn vector(py: Python<'_>, v: &Bound<'_, PyAny>, name: &str, n: usize) -> PyResult<Vec<f64>> {
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
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The largest magnitude of a value given as data, as in motion files.
const MAX_VALUE: f64 = cpg_mocap::MAX_MAGNITUDE;

/// Runs `work` on its own thread while this one answers signals: Ctrl-C
/// raises `KeyboardInterrupt` within 0.1 s. `work` is told through its flag
/// and stops at its next check; work that cannot stop finishes unseen.
fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(&std::sync::atomic::AtomicBool) -> T + Send + 'static,
) -> PyResult<T> {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let cancel = Arc::new(AtomicBool::new(false));
    let (tx, rx) = std::sync::mpsc::channel();
    let flag = cancel.clone();
    std::thread::Builder::new()
        .name("cpg-work".into())
        .spawn(move || {
            let _ = tx.send(work(&flag));
        })
        .map_err(err)?;
    let mut rx = rx;
    loop {
        let (got, back) = py.detach(move || (rx.recv_timeout(std::time::Duration::from_millis(50)), rx));
        rx = back;
        match got {
            Ok(v) => return Ok(v),
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(err("the work stopped without a result (it panicked)"));
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    cancel.store(true, Ordering::SeqCst);
                    return Err(e);
                }
            }
        }
    }
}

/// A 2-D float64 array as row-major values, with its shape (any strides, any order).
fn rows(a: &PyReadonlyArray2<'_, f64>) -> (Vec<f64>, usize, usize) {
    let v = a.as_array();
    let (n, d) = v.dim();
    (v.iter().copied().collect(), n, d)
}

fn array2<'py>(py: Python<'py>, values: Vec<f64>, n: usize, d: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    Ok(Array2::from_shape_vec((n, d), values).map_err(err)?.into_pyarray(py))
}

/// A `serde_json` value as Python objects (dicts, lists, floats, ints, strings, None).
fn to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
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
const MAX_CONFIG_DEPTH: usize = 32;

/// A Python dict (with lists, numbers, strings, booleans, paths; None means
/// "leave the key out") as a TOML value. A dict or list nested deeper than
/// [`MAX_CONFIG_DEPTH`], or that contains itself, is an error.
fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<Option<toml::Value>> {
    to_toml_at(v, key, &mut Vec::new())
}

fn to_toml_at(v: &Bound<'_, PyAny>, key: &str, path: &mut Vec<usize>) -> PyResult<Option<toml::Value>> {
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

fn to_toml_inner(v: &Bound<'_, PyAny>, key: &str, path: &mut Vec<usize>) -> PyResult<Option<toml::Value>> {
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
    if v.is_instance_of::<PyBool>() {
        return Ok(Some(toml::Value::Boolean(v.extract()?)));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| err(format!("`{key}`: an integer beyond 64 bits")))?;
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

fn config_from_table(t: &toml::Table, name: &str) -> PyResult<Config> {
    let here = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    cpg_lab::fit::config_from_table(t, name, &here).map_err(err)
}

/// A motion and (when read from a file) its skeleton.
#[pyclass(module = "cpg._cpg", name = "Motion", frozen)]
struct Motion {
    motion: cpg_mocap::Motion,
    skeleton: Option<Skeleton>,
    format: String,
}

#[pymethods]
impl Motion {
    /// A motion from arrays: `values` frames × channels (anything NumPy reads
    /// as numbers), `channels` their names (`bone.dof`: `lfemur.rx`), at
    /// `rate_hz`. It has no skeleton (no forward kinematics, no files).
    #[new]
    fn new(py: Python<'_>, values: &Bound<'_, PyAny>, channels: Vec<String>, rate_hz: f64) -> PyResult<Motion> {
        let rate_hz = rate_arg(rate_hz, "rate_hz")?;
        let (v, n, d) = matrix(py, values, "values")?;
        if channels.len() != d {
            return Err(err(format!("channels: {} names for {d} columns", channels.len())));
        }
        if let Some(i) = v.iter().position(|x| !(x.is_finite() && x.abs() <= MAX_VALUE)) {
            return Err(err(format!(
                "values: frame {}, channel {} is {}; expected finite values within ±{MAX_VALUE}",
                i / d.max(1),
                i % d.max(1),
                v[i]
            )));
        }
        let parsed = channels
            .iter()
            .map(|c| {
                cpg_mocap::Channel::parse(c)
                    .ok_or_else(|| err(format!("channels: {c:?} is not a channel name (bone.dof, e.g. lfemur.rx)")))
            })
            .collect::<PyResult<Vec<_>>>()?;
        if n == 0 {
            return Err(err("values: no frames"));
        }
        let motion = cpg_mocap::Motion::new(parsed, v, rate_hz).map_err(err)?;
        Ok(Motion { motion, skeleton: None, format: "arrays".into() })
    }

    /// Frames × channels, float64 (degrees for rotations, skeleton units for translations).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        array2(py, self.motion.values().to_vec(), self.motion.n_frames(), self.motion.n_channels())
    }

    /// Channel names (`bone.dof`), one per column.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.motion.channel_names()
    }

    /// Frames per second.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.motion.sample_rate_hz()
    }

    /// Number of frames.
    #[getter]
    fn n_frames(&self) -> usize {
        self.motion.n_frames()
    }

    /// `amc` or `bvh` (with the length unit), or `arrays`.
    #[getter]
    fn format(&self) -> String {
        self.format.clone()
    }

    /// The skeleton as ASF text, if the motion has one.
    #[getter]
    fn skeleton_asf(&self) -> Option<String> {
        self.skeleton.as_ref().map(cpg_mocap::write_asf)
    }

    /// Millimetres per skeleton length unit (None without a skeleton).
    #[getter]
    fn mm_per_unit(&self) -> Option<f64> {
        self.skeleton.as_ref().map(Skeleton::mm_per_unit)
    }

    /// Forward kinematics: (points, names) with points frames × points × 3 in
    /// millimetres (y up): the root and every bone's end.
    fn forward_kinematics<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyArray3<f64>>, Vec<String>)> {
        let sk = self.skeleton.as_ref().ok_or_else(|| err("this motion has no skeleton (it was made from arrays)"))?;
        let p = py.detach(|| sk.forward_kinematics(&sk.complete(&self.motion)?)).map_err(err)?;
        let (n, k) = (p.n_frames(), p.names.len());
        let flat: Vec<f64> = p.points_mm.iter().flatten().copied().collect();
        let a = numpy::ndarray::Array3::from_shape_vec((n, k, 3), flat).map_err(err)?;
        Ok((a.into_pyarray(py), p.names))
    }

    /// The motion with only these channels (names, in this order).
    fn select(&self, channels: Vec<String>) -> PyResult<Motion> {
        let names: Vec<&str> = channels.iter().map(String::as_str).collect();
        Ok(Motion {
            motion: self.motion.select(&names).map_err(err)?,
            skeleton: self.skeleton.clone(),
            format: self.format.clone(),
        })
    }

    /// Writes the motion as BVH (lengths in centimetres) or AMC, by the
    /// extension, atomically: the file holds the old motion or the new one,
    /// never half of one; a missing directory is an error.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let sk = self.skeleton.as_ref().ok_or_else(|| err("this motion has no skeleton to write it with"))?;
        let format = if cpg_mocap::is_bvh(&path) { Format::Bvh } else { Format::Amc };
        cpg_lab::format::write_motion(&path, format, sk, &self.motion).map_err(err)
    }

    fn __repr__(&self) -> String {
        format!(
            "Motion({} frames × {} channels at {} Hz, {})",
            self.motion.n_frames(),
            self.motion.n_channels(),
            self.motion.sample_rate_hz(),
            self.format
        )
    }
}

/// Reads a motion file: AMC (with `skeleton`, the ASF) or BVH.
#[pyfunction]
#[pyo3(signature = (path, skeleton=None, rate_hz=None, bvh_unit_mm=None))]
fn read_motion(
    py: Python<'_>,
    path: PathBuf,
    skeleton: Option<PathBuf>,
    rate_hz: Option<f64>,
    bvh_unit_mm: Option<f64>,
) -> PyResult<Motion> {
    let rate_hz = rate_hz.map(|r| rate_arg(r, "rate_hz")).transpose()?;
    let r = py
        .detach(|| {
            cpg_mocap::read_recording(&path, skeleton.as_deref(), rate_hz, &BvhOptions { length_unit_mm: bvh_unit_mm })
        })
        .map_err(err)?;
    let format = match r.format {
        cpg_mocap::Format::Amc => "amc".to_owned(),
        cpg_mocap::Format::Bvh { length_unit_mm, inferred } => {
            format!("bvh ({length_unit_mm} mm per unit{})", if inferred { ", inferred" } else { "" })
        }
    };
    Ok(Motion { motion: r.motion, skeleton: Some(r.skeleton), format })
}

/// A trained CPG.
#[pyclass(module = "cpg._cpg", name = "Model", frozen)]
struct Model {
    m: Arc<TrainedCpg>,
}

impl Model {
    fn of(m: TrainedCpg) -> Model {
        Model { m: Arc::new(m) }
    }
}

/// Reservoirs at least this large split one free run over two cores by
/// default (`threads=None`); defined, and checked by the bench, in cpg-lab.
pub use cpg_lab::measure::SPLIT_MIN_NEURONS;

/// Control values for `steps` steps: None (the first teacher's setting, or
/// none for a model without controls), a sequence of one value per input
/// (constant), or an array steps × inputs (the last row is held).
fn schedule(m: &TrainedCpg, controls: Option<&Bound<'_, PyAny>>) -> PyResult<ControlSchedule> {
    let u = m.controls.len();
    let s = match controls {
        None => return cpg_lab::run::schedule(m, Controls::Unset { strict: false }).map_err(err),
        Some(c) => {
            if let Ok(a) = c.extract::<PyReadonlyArray2<'_, f64>>() {
                let (values, n, w) = rows(&a);
                if w != u || n == 0 {
                    return Err(err(format!(
                        "controls: an array of {n} × {w}; expected steps × {u} (one column per control input: {})",
                        m.controls.join(", ")
                    )));
                }
                ControlSchedule::Table { width: u, rows: values }
            } else {
                let v: Vec<f64> = c
                    .extract()
                    .map_err(|_| err(format!("controls: expected {u} numbers or an array of steps × {u}")))?;
                ControlSchedule::Constant(v)
            }
        }
    };
    cpg_lab::run::schedule(m, Controls::Schedule(&s)).map_err(err)
}

fn load_robot(urdf: Option<PathBuf>, map: Option<&str>) -> PyResult<(UrdfRobot, ChannelMap)> {
    let robot = match urdf {
        Some(p) => UrdfRobot::from_urdf_file(&p),
        None => UrdfRobot::hoap2(),
    }
    .map_err(err)?;
    let map = ChannelMap::from_spec(Path::new(map.unwrap_or("hoap2"))).map_err(err)?;
    Ok((robot, map))
}

/// Steps of `seconds` at `rate`, bounded.
fn steps_for(seconds: f64, rate: f64, d: usize) -> PyResult<usize> {
    cpg_lab::run::steps("seconds", seconds, rate, d).map_err(err)
}

#[pymethods]
impl Model {
    /// The output channels, in column order.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.m.outputs.iter().map(|o| o.name.clone()).collect()
    }

    /// The control inputs' names.
    #[getter]
    fn controls(&self) -> Vec<String> {
        self.m.controls.clone()
    }

    /// Steps per second.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.m.provenance.sample_rate_hz
    }

    /// Reservoir size.
    #[getter]
    fn n_neurons(&self) -> usize {
        self.m.reservoir.n_neurons()
    }

    /// The ridge penalty chosen by validation.
    #[getter]
    fn penalty(&self) -> f64 {
        self.m.provenance.chosen_penalty
    }

    /// The best validation score (1 is a flat line at the mean).
    #[getter]
    fn validation_score(&self) -> f64 {
        self.m.provenance.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min)
    }

    /// What the model was trained on.
    #[getter]
    fn data(&self) -> String {
        self.m.provenance.data.clone()
    }

    /// The skeleton the model was trained with, as ASF text (None when trained from arrays).
    #[getter]
    fn skeleton_asf(&self) -> Option<String> {
        self.m.skeleton_asf.clone()
    }

    /// The teachers: label, controls, period in steps and one cycle
    /// (period × channels, in the channels' units).
    #[getter]
    fn teachers<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let d = self.m.outputs.len();
        self.m
            .teachers
            .iter()
            .map(|t| {
                let dict = PyDict::new(py);
                dict.set_item("label", &t.label)?;
                dict.set_item("controls", t.controls.clone())?;
                dict.set_item("period_steps", t.period_steps(d))?;
                let units = cpg_reservoir::to_units(&self.m.outputs, &t.cycle);
                dict.set_item("cycle", array2(py, units, t.cycle.len() / d, d)?)?;
                Ok(dict)
            })
            .collect()
    }

    /// Free run of `steps` steps under `controls`: steps × channels, in the
    /// channels' units (degrees for rotations). `threads`: 1 runs on one core,
    /// 2 or more split the run by rows (the same bits); by default a
    /// reservoir of 1,500 neurons or more is split over two cores, a smaller
    /// one is not. Ctrl-C stops it.
    #[pyo3(signature = (steps, controls=None, threads=None))]
    fn generate<'py>(
        &self,
        py: Python<'py>,
        steps: &Bound<'py, PyAny>,
        controls: Option<&Bound<'py, PyAny>>,
        threads: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let d = self.m.outputs.len();
        let steps = int_arg(steps, "steps", 1, cpg_lab::run::max_steps(d) as u64)? as usize;
        let threads = match threads {
            Some(t) => int_arg(t, "threads", 1, 64)? as usize,
            None => cpg_lab::run::default_threads(&self.m),
        };
        let s = schedule(&self.m, controls)?;
        let m = self.m.clone();
        let y = interruptible(py, move |cancel| {
            cpg_lab::run::generate(&m, &s, steps, cpg_lab::run::RunOptions { threads, cancel: Some(cancel) })
        })?
        .map_err(err)?
        .ok_or_else(|| err("interrupted"))?;
        array2(py, y.values, steps, d)
    }

    /// A step-by-step generator at the model's start state (for control loops).
    fn generator(&self) -> Generator {
        Generator { g: cpg_reservoir::Generator::new(&self.m), m: self.m.clone() }
    }

    /// A stream at `rate_hz` ticks per second (interpolating between the
    /// model's steps); with `robot=True`, each tick is the HOAP-2's joint
    /// angles (radians) within its position, velocity and acceleration limits.
    #[pyo3(signature = (rate_hz, robot=false, urdf=None, map=None, acceleration_rad_s2=100.0))]
    fn stream(
        &self,
        rate_hz: f64,
        robot: bool,
        urdf: Option<PathBuf>,
        map: Option<String>,
        acceleration_rad_s2: f64,
    ) -> PyResult<Stream> {
        let loaded = if robot { Some(load_robot(urdf, map.as_deref())?) } else { None };
        let target =
            loaded.as_ref().map(|(r, m)| cpg_lab::stream::RobotTarget { robot: r, map: m, acceleration_rad_s2 });
        let t = cpg_lab::stream::Ticker::new(&self.m, rate_hz, target).map_err(err)?;
        let columns = if robot { t.columns() } else { self.channels() };
        Ok(Stream { t, columns, u: self.m.controls.len() })
    }

    /// Judges the model: a free run of `seconds` and the paper's push, at every
    /// control setting it was taught (or under `controls`). A list of dicts:
    /// `teacher`, `controls`, `stability` (period and amplitudes at the end,
    /// `accurate`, `converged`) and `recovery` (seconds back on the orbit and on
    /// an unperturbed twin, phase shift).
    #[pyo3(signature = (seconds=900.0, controls=None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        seconds: f64,
        controls: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = steps_for(seconds, self.m.provenance.sample_rate_hz, self.m.outputs.len())?;
        let s = match controls {
            Some(c) => Some(schedule(&self.m, Some(c))?),
            None => None,
        };
        let m = self.m.clone();
        let j = interruptible(py, move |_| cpg_lab::measure::judge(&m, n, s.as_ref(), cores()))?.map_err(err)?;
        to_py(py, &serde_json::to_value(j).map_err(err)?)
    }

    /// HOAP-2 joint commands for `seconds` of free run: mapped (`map`: the
    /// 22-joint map, `"legs"`, or a map file), clamped to the URDF's ranges,
    /// resampled to `rate_hz` (default: the model's) and kept within every
    /// velocity limit and the acceleration bound. A dict: `joints`, `rate_hz`,
    /// `positions_rad`, `velocities_rad_s`, `accelerations_rad_s2` (frames ×
    /// joints) and `limits` (what each bound changed, per joint).
    #[pyo3(signature = (seconds, rate_hz=None, controls=None, urdf=None, map=None, acceleration_rad_s2=100.0))]
    #[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
    fn hoap2<'py>(
        &self,
        py: Python<'py>,
        seconds: f64,
        rate_hz: Option<f64>,
        controls: Option<&Bound<'py, PyAny>>,
        urdf: Option<PathBuf>,
        map: Option<String>,
        acceleration_rad_s2: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (robot, chmap) = load_robot(urdf, map.as_deref())?;
        let s = schedule(&self.m, controls)?;
        steps_for(seconds, self.m.provenance.sample_rate_hz, self.m.outputs.len())?;
        let rate_hz = rate_hz.map(|r| rate_arg(r, "rate_hz")).transpose()?;
        let m = self.m.clone();
        let t = interruptible(py, move |_| {
            let target = cpg_lab::stream::RobotTarget { robot: &robot, map: &chmap, acceleration_rad_s2 };
            cpg_lab::stream::joint_trajectory(&m, &s, seconds, rate_hz, target)
        })?
        .map_err(err)?;
        trajectory_dict(py, &t)
    }

    /// The model file's bytes (the format `cpg train` writes).
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, &self.m.to_bytes().map_err(err)?))
    }

    /// Saves the model file (atomically; the CLI reads it).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.m.save(&path).map_err(err)
    }

    /// A model from a model file's bytes.
    #[staticmethod]
    #[pyo3(signature = (data, name="<bytes>"))]
    fn from_bytes(data: &[u8], name: &str) -> PyResult<Model> {
        Ok(Model::of(TrainedCpg::from_bytes(data, Path::new(name)).map_err(err)?))
    }

    /// Pickling: the model file's bytes.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let f = py.import("cpg._cpg")?.getattr("_model_from_bytes")?;
        Ok((f, (self.to_bytes(py)?,)))
    }

    fn __repr__(&self) -> String {
        format!(
            "Model({} neurons, channels [{}], controls [{}], {} Hz, penalty {:.2e})",
            self.m.reservoir.n_neurons(),
            self.channels().join(", "),
            self.m.controls.join(", "),
            self.m.provenance.sample_rate_hz,
            self.m.provenance.chosen_penalty
        )
    }
}

fn trajectory_dict<'py>(py: Python<'py>, t: &cpg_hoap2::JointTrajectory) -> PyResult<Bound<'py, PyDict>> {
    let (n, j) = (t.n_frames(), t.joints.len());
    let d = PyDict::new(py);
    d.set_item("joints", t.joints.clone())?;
    d.set_item("rate_hz", t.rate_hz)?;
    d.set_item("positions_rad", array2(py, t.values_rad.clone(), n, j)?)?;
    d.set_item("velocities_rad_s", array2(py, t.velocities_rad_s.clone(), n, j)?)?;
    d.set_item("accelerations_rad_s2", array2(py, t.accelerations_rad_s2.clone(), n, j)?)?;
    let limits: Vec<Bound<'py, PyDict>> = t
        .clamps
        .joints
        .iter()
        .map(|c| {
            let x = PyDict::new(py);
            x.set_item("joint", &c.joint)?;
            x.set_item("frames", c.n_frames)?;
            x.set_item("position_clamped", c.n_clamped)?;
            x.set_item("velocity_limited", c.n_velocity_limited)?;
            x.set_item("acceleration_limited", c.n_acceleration_limited)?;
            x.set_item("max_speed_asked_rad_s", c.max_velocity_rad_s)?;
            x.set_item("max_lag_rad", c.max_lag_rad)?;
            Ok(x)
        })
        .collect::<PyResult<_>>()?;
    d.set_item("limits", limits)?;
    Ok(d)
}

/// Runs a model one step at a time.
#[pyclass(module = "cpg._cpg", name = "Generator")]
struct Generator {
    g: cpg_reservoir::Generator,
    m: Arc<TrainedCpg>,
}

/// One value per control input from anything NumPy reads as numbers (None: none).
fn control_values(py: Python<'_>, c: Option<&Bound<'_, PyAny>>, u: usize) -> PyResult<Vec<f64>> {
    match c {
        None if u == 0 => Ok(Vec::new()),
        None => Err(err(format!("the model has {u} control input(s): give step(control)"))),
        Some(a) => vector(py, a, "control", u),
    }
}

/// The output array `out`: float64, one dimension of `d` values, writable.
fn check_out<'py>(o: &Bound<'py, PyAny>, d: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let describe = |o: &Bound<'_, PyAny>| -> String {
        match (o.getattr("dtype"), o.getattr("shape")) {
            (Ok(t), Ok(s)) => format!(
                "a {} array of shape {}",
                t.str().map(|x| x.to_string()).unwrap_or_default(),
                s.str().map(|x| x.to_string()).unwrap_or_default()
            ),
            _ => format!("a {}", o.get_type().name().map(|x| x.to_string()).unwrap_or_default()),
        }
    };
    let a = o.cast::<PyArray1<f64>>().map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "out: expected a float64 array of shape ({d},), got {}",
            describe(o)
        ))
    })?;
    if a.len() != d {
        return Err(err(format!("out: expected a float64 array of shape ({d},), got {}", describe(o))));
    }
    Ok(a.clone())
}

#[pymethods]
impl Generator {
    /// One step: the output (channels, in their units) for `control` (one
    /// value per control input; a list or any array). With `out` (a float64
    /// array of one value per channel) the output is written there and `out`
    /// is returned.
    #[pyo3(signature = (control=None, out=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        control: Option<&Bound<'py, PyAny>>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let d = self.m.outputs.len();
        let c = control_values(py, control, self.m.controls.len())?;
        let target = out.map(|o| check_out(o, d)).transpose()?;
        if let Err(e) = self.g.step(&c) {
            return Err(err(if self.g.diverged() {
                format!(
                    "the generator diverged at step {}: {e}; reset() starts it again from the model's start state",
                    self.g.steps()
                )
            } else {
                e.to_string()
            }));
        }
        let y = self.g.output();
        match target {
            Some(o) => {
                let mut w = o.try_readwrite().map_err(err)?;
                let slice = w.as_slice_mut().map_err(|_| err("out: expected a contiguous float64 array"))?;
                slice.copy_from_slice(y);
                drop(w);
                Ok(o)
            }
            None => Ok(PyArray1::from_slice(py, y)),
        }
    }

    /// Back to the model's start state (after a divergence, or to start over).
    fn reset(&mut self) {
        self.g = cpg_reservoir::Generator::new(&self.m);
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.g.steps()
    }

    /// Whether a step diverged (then only `reset()` brings it back).
    #[getter]
    fn diverged(&self) -> bool {
        self.g.diverged()
    }

    /// Pickling: the model's bytes, the reservoir state and the steps taken.
    #[allow(clippy::type_complexity)] // the shape pickle asks for
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>, Vec<f64>, u64, bool))> {
        let f = py.import("cpg._cpg")?.getattr("_generator_from_state")?;
        let (x, steps) = self.g.state();
        Ok((f, (PyBytes::new(py, &self.m.to_bytes().map_err(err)?), x, steps, self.g.diverged())))
    }
}

/// A model from its file's bytes (what a pickled `Model` is made from again).
#[pyfunction]
fn _model_from_bytes(data: &[u8]) -> PyResult<Model> {
    Model::from_bytes(data, "<pickle>")
}

/// A generator from a pickled one's model, state and steps.
#[pyfunction]
fn _generator_from_state(data: &[u8], state: Vec<f64>, steps: u64, diverged: bool) -> PyResult<Generator> {
    let m = Arc::new(TrainedCpg::from_bytes(data, Path::new("<pickle>")).map_err(err)?);
    if diverged {
        return Err(err("the pickled generator had diverged; reset() it before pickling"));
    }
    let g = cpg_reservoir::Generator::resume(&m, &state, steps).map_err(err)?;
    Ok(Generator { g, m })
}

/// A model at any tick rate, optionally as HOAP-2 joint angles.
#[pyclass(module = "cpg._cpg", name = "Stream")]
struct Stream {
    t: cpg_lab::stream::Ticker,
    columns: Vec<String>,
    u: usize,
}

#[pymethods]
impl Stream {
    /// One tick: the channels (or joint angles, radians) for `control` (a list or any array).
    #[pyo3(signature = (control=None))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        control: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let c = control_values(py, control, self.u)?;
        Ok(PyArray1::from_slice(py, self.t.tick(&c).map_err(err)?))
    }

    /// What each tick holds: channel names or joint names.
    #[getter]
    fn columns(&self) -> Vec<String> {
        self.columns.clone()
    }

    /// Time of the next tick, seconds.
    #[getter]
    fn time_s(&self) -> f64 {
        self.t.time_s()
    }

    /// Ticks per second.
    #[getter]
    fn rate_hz(&self) -> f64 {
        self.t.rate_hz()
    }
}

/// Reads a model file.
#[pyfunction]
fn load(path: PathBuf) -> PyResult<Model> {
    Ok(Model::of(TrainedCpg::load(&path).map_err(err)?))
}

/// Trains a model as `cpg train` does, from a configuration file (a path)
/// or a dict with the same fields (docs/config.md; relative paths against
/// the working directory). The same configuration and seed give the same
/// model, bit for bit, as `cpg train`.
#[pyfunction]
fn train(py: Python<'_>, config: &Bound<'_, PyAny>) -> PyResult<Model> {
    let c = if config.is_instance_of::<PyDict>() {
        let Some(toml::Value::Table(t)) = to_toml(config, "")? else {
            return Err(err("the configuration dict is empty"));
        };
        config_from_table(&t, "<dict>")?
    } else {
        let p: PathBuf = config.extract().map_err(|_| err("config: expected a path or a dict"))?;
        Config::load(&p).map_err(err)?
    };
    let m = interruptible(py, move |_| cpg_lab::in_pool(cores(), || cpg_lab::train::train(&c, cores()).map(|t| t.0)))?
        .map_err(err)?;
    Ok(Model::of(m))
}

/// Trains a model on arrays: `y` is one segment (time × channels, anything
/// NumPy reads as numbers; a 1-D array is one channel), or `segments` a list
/// of them, each with its own control values; z-scoring is inside.
#[pyfunction]
#[pyo3(signature = (y=None, rate_hz=None, controls=None, channels=None, control_names=None, seed=None, config=None, segments=None))]
#[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
fn fit(
    py: Python<'_>,
    y: Option<&Bound<'_, PyAny>>,
    rate_hz: Option<f64>,
    controls: Option<&Bound<'_, PyAny>>,
    channels: Option<Vec<String>>,
    control_names: Option<Vec<String>>,
    seed: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyDict>>,
    segments: Option<&Bound<'_, PyAny>>,
) -> PyResult<Model> {
    let rate_hz = rate_arg(rate_hz.ok_or_else(|| err("rate_hz: required (frames per second)"))?, "rate_hz")?;
    let seed = match seed {
        Some(s) => int_arg(s, "seed", 0, u64::MAX)?,
        None => 1,
    };
    // The segments, each converted once and checked at once.
    let segs: Vec<(Vec<f64>, usize, usize)> = match (y, segments) {
        (Some(y), None) => vec![matrix(py, y, "y")?],
        (None, Some(list)) => {
            let n = list.len().map_err(|_| err("segments: expected a list of arrays"))?;
            if n == 0 || n > cpg_lab::config::MAX_SEGMENTS {
                return Err(err(format!("segments: {n} arrays; expected 1 to {}", cpg_lab::config::MAX_SEGMENTS)));
            }
            list.try_iter()?
                .enumerate()
                .map(|(k, a)| matrix(py, &a?, &format!("segments[{k}]")))
                .collect::<PyResult<_>>()?
        }
        (Some(_), Some(_)) => return Err(err("give y (one segment) or segments=[...], not both")),
        (None, None) => return Err(err("give y (time × channels) or segments=[...] (several)")),
    };
    let which = |k: usize| if segments.is_some() { format!("segments[{k}]") } else { "y".to_owned() };
    let ctl: Vec<Vec<f64>> = match controls {
        None => vec![Vec::new(); segs.len()],
        Some(c) => {
            let v: Vec<Vec<f64>> =
                c.extract().map_err(|_| err("controls: expected one list of control values per segment"))?;
            if v.len() != segs.len() {
                return Err(err(format!("controls: {} settings for {} segments", v.len(), segs.len())));
            }
            v
        }
    };
    let overrides = match config {
        Some(cfg) => match to_toml(cfg.as_any(), "")? {
            Some(toml::Value::Table(t)) => Some(t),
            _ => None,
        },
        None => None,
    };
    let request = cpg_lab::fit::FitRequest {
        labels: (0..segs.len()).map(which).collect(),
        segments: segs
            .into_iter()
            .zip(ctl)
            .map(|((values, n, d), controls)| cpg_lab::fit::Segment { values, n, d, controls })
            .collect(),
        rate_hz,
        channels,
        control_names,
        seed,
        overrides,
        threads: cores(),
    };
    // Checked at once, before the work.
    cpg_lab::fit::check(&request).map_err(err)?;
    let m = interruptible(py, move |_| cpg_lab::fit::fit(request))?.map_err(err)?;
    Ok(Model::of(m))
}

/// The HOAP-2 URDF the package carries (the project's `assets/hoap2/hoap2.urdf`).
#[pyfunction]
fn hoap2_urdf() -> &'static str {
    cpg_hoap2::assets::HOAP2_URDF
}

/// The HOAP-2 as a MuJoCo scene (the project's `assets/hoap2/hoap2.xml`):
/// floor, body on a free joint, a position servo per joint (named after it),
/// IMU and sole touch sensors, keyframe `home` standing in the home crouch.
/// Load it with `mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())`.
#[pyfunction]
fn hoap2_mjcf() -> &'static str {
    cpg_hoap2::assets::HOAP2_MJCF
}

/// The HOAP-2 joints of a URDF (default: the package's): name, parent and
/// child links, lower and upper limits (rad), velocity limit (rad/s).
#[pyfunction]
#[pyo3(signature = (urdf=None))]
fn robot_joints<'py>(py: Python<'py>, urdf: Option<PathBuf>) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let (robot, _) = load_robot(urdf, None)?;
    robot
        .joints
        .iter()
        .map(|j| {
            let d = PyDict::new(py);
            d.set_item("name", &j.name)?;
            d.set_item("parent", &j.parent)?;
            d.set_item("child", &j.child)?;
            d.set_item("lower_rad", j.lower_rad)?;
            d.set_item("upper_rad", j.upper_rad)?;
            d.set_item("velocity_rad_s", j.velocity_rad_s)?;
            Ok(d)
        })
        .collect()
}

/// Maps channels (frames × channels, degrees) onto HOAP-2 joints at
/// `rate_hz`: clamped to the URDF's ranges and kept within the velocity
/// limits and the acceleration bound. A dict as `Model.hoap2` returns.
#[pyfunction]
#[pyo3(signature = (values, channels, rate_hz, urdf=None, map=None, acceleration_rad_s2=100.0))]
fn map_hoap2<'py>(
    py: Python<'py>,
    values: &Bound<'py, PyAny>,
    channels: Vec<String>,
    rate_hz: f64,
    urdf: Option<PathBuf>,
    map: Option<String>,
    acceleration_rad_s2: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let rate_hz = rate_arg(rate_hz, "rate_hz")?;
    let (robot, chmap) = load_robot(urdf, map.as_deref())?;
    let (v, _, d) = matrix(py, values, "values")?;
    if d != channels.len() {
        return Err(err(format!("{} channel names for {d} columns", channels.len())));
    }
    let t =
        py.detach(|| chmap.apply(&robot, &channels, &v, rate_hz)?.limit(&robot, acceleration_rad_s2)).map_err(err)?;
    trajectory_dict(py, &t)
}

// The signatures' literal default (100.0, shown by help()) is the library's bound.
const _: () = assert!(cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2 == 100.0);

#[pymodule]
fn _cpg(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CpgError", m.py().get_type::<CpgError>())?;
    m.add_class::<Motion>()?;
    m.add_class::<Model>()?;
    m.add_class::<Generator>()?;
    m.add_class::<Stream>()?;
    m.add_function(wrap_pyfunction!(read_motion, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(train, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(hoap2_urdf, m)?)?;
    m.add_function(wrap_pyfunction!(hoap2_mjcf, m)?)?;
    m.add_function(wrap_pyfunction!(robot_joints, m)?)?;
    m.add_function(wrap_pyfunction!(map_hoap2, m)?)?;
    m.add_function(wrap_pyfunction!(_model_from_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(_generator_from_state, m)?)?;
    m.add("DEFAULT_ACCELERATION_RAD_S2", cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2)?;
    m.add("SPLIT_MIN_NEURONS", SPLIT_MIN_NEURONS)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

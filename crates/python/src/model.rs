//! `Model`, `load`, `train` and `fit`: trained CPGs, their runs, judgements
//! and HOAP-2 commands (all through `cpg_lab::run`, `cpg_lab::measure`,
//! `cpg_lab::stream` and `cpg_lab::fit`).

use cpg_lab::run::Controls;
use cpg_lab::{Config, ControlSchedule};
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, Robot as UrdfRobot};
use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::convert::*;
use crate::errors::*;
use crate::stream::*;

/// A trained CPG.
#[pyclass(module = "cpg._cpg", name = "Model", frozen)]
pub(crate) struct Model {
    pub(crate) m: Arc<TrainedCpg>,
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
/// (constant), or a table steps × inputs (the last row is held): anything
/// NumPy reads as numbers (a list of lists, a float32 array, …).
pub(crate) fn schedule(m: &TrainedCpg, controls: Option<&Bound<'_, PyAny>>) -> PyResult<ControlSchedule> {
    let u = m.controls.len();
    let s = match controls {
        None => return cpg_lab::run::schedule(m, Controls::Unset { strict: false }).map_err(err),
        Some(c) => {
            let np = c.py().import("numpy")?;
            let a = np.call_method1("asarray", (c, "float64")).map_err(|e| {
                err(format!(
                    "controls: expected {u} numbers or a table of steps × {u} that NumPy reads as numbers: {}",
                    e.value(c.py())
                ))
            })?;
            let ndim: usize = a.getattr("ndim")?.extract()?;
            if ndim == 2 {
                let a = np.call_method1("ascontiguousarray", (a,))?;
                let arr: PyReadonlyArray2<'_, f64> = a.extract()?;
                let (values, n, w) = rows(&arr);
                if w != u || n == 0 {
                    return Err(err(format!(
                        "controls: an array of {n} × {w}; expected steps × {u} (one column per control input: {})",
                        m.controls.join(", ")
                    )));
                }
                ControlSchedule::Table { width: u, rows: values }
            } else if ndim <= 1 {
                let v: Vec<f64> = np.call_method1("ravel", (a,))?.call_method0("tolist")?.extract()?;
                ControlSchedule::Constant(v)
            } else {
                return Err(err(format!(
                    "controls: an array of {ndim} dimensions; expected {u} numbers or steps × {u}"
                )));
            }
        }
    };
    cpg_lab::run::schedule(m, Controls::Schedule(&s)).map_err(err)
}

pub(crate) fn load_robot(urdf: Option<PathBuf>, map: Option<&str>) -> PyResult<(UrdfRobot, ChannelMap)> {
    let robot = match urdf {
        Some(p) => UrdfRobot::from_urdf_file(&p),
        None => UrdfRobot::hoap2(),
    }
    .map_err(err)?;
    let map = ChannelMap::from_spec(Path::new(map.unwrap_or("hoap2"))).map_err(err)?;
    Ok((robot, map))
}

/// Steps of `seconds` at `rate`, bounded.
pub(crate) fn steps_for(seconds: f64, rate: f64, d: usize) -> PyResult<usize> {
    cpg_lab::run::steps("seconds", seconds, rate, d).map_err(err)
}

#[pymethods]
impl Model {
    /// The output channels, in column order.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.m.outputs.iter().map(|o| o.unit_name().to_owned()).collect()
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
        let progress = Progress { label: "generate".into(), total_steps: steps as u64 };
        let y = interruptible_with(py, Some(progress), move |watch| {
            cpg_lab::run::generate(&m, &s, steps, cpg_lab::run::RunOptions { threads, cancel: Some(&watch.cancel) })
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
        // Each control setting judged: a free run of n steps, and a pushed one (at most as long).
        let settings = if s.is_some() { 1 } else { self.m.teachers.len() as u64 };
        let progress = Progress { label: "evaluate".into(), total_steps: settings * 2 * n as u64 };
        let j = interruptible_with(py, Some(progress), move |_| {
            cpg_lab::in_pool(cores(), || cpg_lab::measure::judge(&m, n, s.as_ref(), cores()))
        })?
        .map_err(err)?;
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

    /// A model from a model file's bytes (`bytes`, `bytearray`, `memoryview`
    /// or any object with the buffer protocol).
    #[staticmethod]
    #[pyo3(signature = (data, name="<bytes>"))]
    fn from_bytes(data: &Bound<'_, PyAny>, name: &str) -> PyResult<Model> {
        let bytes = buffer_bytes(data)?;
        Ok(Model::of(TrainedCpg::from_bytes(&bytes, Path::new(name)).map_err(err)?))
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

pub(crate) fn trajectory_dict<'py>(py: Python<'py>, t: &cpg_robot::JointTrajectory) -> PyResult<Bound<'py, PyDict>> {
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

/// A model from its file's bytes (what a pickled `Model` is made from again).
#[pyfunction]
pub(crate) fn _model_from_bytes(data: &[u8]) -> PyResult<Model> {
    Ok(Model::of(TrainedCpg::from_bytes(data, Path::new("<pickle>")).map_err(err)?))
}

/// The bytes of any object with the buffer protocol, its size bounded
/// (as a model file's) before they are copied.
fn buffer_bytes(data: &Bound<'_, PyAny>) -> PyResult<Vec<u8>> {
    if let Ok(b) = data.cast::<PyBytes>() {
        return Ok(b.as_bytes().to_vec());
    }
    let view = data.py().import("builtins")?.getattr("memoryview")?.call1((data,)).map_err(|_| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "data: expected bytes, a bytearray or a buffer, got {}",
            data.get_type().name().map(|n| n.to_string()).unwrap_or_default()
        ))
    })?;
    let n: u64 = view.getattr("nbytes")?.extract()?;
    if n > cpg_reservoir::MAX_MODEL_BYTES {
        return Err(err(format!("data: {n} bytes, more than a model file holds ({})", cpg_reservoir::MAX_MODEL_BYTES)));
    }
    Ok(view.call_method0("tobytes")?.cast_into::<PyBytes>()?.as_bytes().to_vec())
}

/// Reads a model file.
#[pyfunction]
pub(crate) fn load(path: PathBuf) -> PyResult<Model> {
    Ok(Model::of(TrainedCpg::load(&path).map_err(err)?))
}

/// Trains a model as `cpg train` does, from a configuration file (a path)
/// or a dict with the same fields (docs/config.md; relative paths against
/// the working directory; a dict needs no `[output]`). The same
/// configuration and seed give the same model, bit for bit, as `cpg train`;
/// `seed` replaces the configuration's reservoir seed. A model whose free
/// run does not follow its teacher (best validation score worse than 1) is
/// refused as `cpg train` refuses it, unless `allow_unstable=True` (then a
/// warning says the same). Ctrl-C stops the training.
#[pyfunction]
#[pyo3(signature = (config, seed=None, allow_unstable=false))]
pub(crate) fn train(
    py: Python<'_>,
    config: &Bound<'_, PyAny>,
    seed: Option<&Bound<'_, PyAny>>,
    allow_unstable: bool,
) -> PyResult<Model> {
    let seed = seed.map(|s| int_arg(s, "seed", 0, u64::MAX)).transpose()?;
    let mut c = if config.is_instance_of::<PyDict>() {
        let Some(toml::Value::Table(mut t)) = to_toml(config, "")? else {
            return Err(err("the configuration dict is empty"));
        };
        // The model is returned, not written: a dict needs no [output] (one given is read and unused).
        if !t.contains_key("output") {
            let output: toml::Table =
                [("model".to_owned(), toml::Value::String("unused.cpg".into()))].into_iter().collect();
            t.insert("output".into(), toml::Value::Table(output));
        }
        config_from_table(&t, "config")?
    } else {
        let p: PathBuf = config.extract().map_err(|_| err("config: expected a path or a dict"))?;
        Config::load(&p).map_err(err)?
    };
    if let Some(s) = seed {
        c.reservoir.seed = s;
    }
    let source = c.source.display().to_string();
    let m = interruptible(py, move |_| cpg_lab::in_pool(cores(), || cpg_lab::train::train(&c, cores()).map(|t| t.0)))?
        .map_err(err)?;
    stable_or_refused(py, m, if source.is_empty() { "config" } else { &source }, allow_unstable)
}

/// The model, or the refusal `cpg train` gives an unstable one (a warning instead with `allow_unstable`).
fn stable_or_refused(py: Python<'_>, m: TrainedCpg, source: &str, allow_unstable: bool) -> PyResult<Model> {
    if let Some(why) = cpg_lab::train::unstable(&m) {
        if !allow_unstable {
            return Err(err(format!(
                "{source}: {why}. No model was returned; allow_unstable=True returns it anyway, `cpg tune` searches for settings that work"
            )));
        }
        let warnings = py.import("warnings")?;
        warnings.call_method1("warn", (format!("{source}: {why}; returned anyway (allow_unstable=True)"),))?;
    }
    Ok(Model::of(m))
}

/// Trains a CPG on one recording held in an array, as `cpg train` does on a
/// file (our protocol of `experiments/e1.toml`; z-scoring is inside).
///
/// - `y`: time × channels, anything NumPy reads as numbers (a 1-D array is
///   one channel; a pandas DataFrame's columns name the channels).
/// - `rate_hz`: frames per second of `y` (required).
/// - `controls`: the control values held during `y`, one per control input
///   (e.g. `[1.0]`); none by default.
/// - `channels`: the channels' names (default: a DataFrame's columns, else `y0`, `y1`, …).
/// - `control_names`: the control inputs' names (default `u0`, `u1`, …).
/// - `seed`: the reservoir's seed (default 1; any 64-bit whole number).
/// - `config`: settings over the preset, as a dict of the sections `data`,
///   `reservoir` and `training` of a configuration file (docs/config.md).
/// - `allow_unstable`: return a model whose free run does not follow its
///   teacher (best validation score worse than 1) with a warning, instead of
///   refusing it as `cpg train` does.
///
/// Several recordings, each under its own control values: `fit_segments`.
/// Ctrl-C stops the training.
#[pyfunction]
#[pyo3(signature = (y, rate_hz, controls=None, channels=None, control_names=None, seed=None, config=None, allow_unstable=false))]
#[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
pub(crate) fn fit(
    py: Python<'_>,
    y: &Bound<'_, PyAny>,
    rate_hz: f64,
    controls: Option<&Bound<'_, PyAny>>,
    channels: Option<Vec<String>>,
    control_names: Option<Vec<String>>,
    seed: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyDict>>,
    allow_unstable: bool,
) -> PyResult<Model> {
    let rate_hz = rate_arg(rate_hz, "rate_hz")?;
    let seg = matrix(py, y, "y")?;
    let ctl = match controls {
        None => Vec::new(),
        Some(c) => one_setting(c, "controls")?,
    };
    let channels = channels.or_else(|| column_names(y, seg.2));
    let m = fit_on(py, vec![seg], vec!["y".into()], vec![ctl], rate_hz, channels, control_names, seed, config)?;
    stable_or_refused(py, m, "fit", allow_unstable)
}

/// Trains a CPG on several recordings, each held under its own control
/// values (a gait per setting, as `experiments/e5-extension.toml` does).
///
/// - `segments`: a list of arrays, each time × channels (the same channels).
/// - `rate_hz`: frames per second (required).
/// - `controls`: one list of control values per segment (e.g. `[[1, 0], [0, 1]]`).
/// - `channels`, `control_names`, `seed`, `config`, `allow_unstable`: as
///   `fit`'s (a DataFrame's columns name the channels when `channels` is not given).
///
/// Ctrl-C stops the training.
#[pyfunction]
#[pyo3(signature = (segments, rate_hz, controls=None, channels=None, control_names=None, seed=None, config=None, allow_unstable=false))]
#[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
pub(crate) fn fit_segments(
    py: Python<'_>,
    segments: &Bound<'_, PyAny>,
    rate_hz: f64,
    controls: Option<&Bound<'_, PyAny>>,
    channels: Option<Vec<String>>,
    control_names: Option<Vec<String>>,
    seed: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyDict>>,
    allow_unstable: bool,
) -> PyResult<Model> {
    let rate_hz = rate_arg(rate_hz, "rate_hz")?;
    // Any iterable of arrays (a list, a tuple, a generator), at most MAX_SEGMENTS of them taken.
    let max = cpg_lab::config::MAX_SEGMENTS;
    let iter = segments.try_iter().map_err(|_| err("segments: expected a list of arrays"))?;
    let items: Vec<Bound<'_, PyAny>> = iter.take(max + 1).collect::<PyResult<_>>()?;
    let n = match segments.len() {
        Ok(n) => n,
        Err(_) => items.len(),
    };
    if n == 0 || n > max {
        let shown = if n > max && segments.len().is_err() { format!("more than {max}") } else { n.to_string() };
        return Err(err(format!("segments: {shown} arrays; expected 1 to {max}")));
    }
    let segs: Vec<(Vec<f64>, usize, usize)> =
        items.iter().enumerate().map(|(k, a)| matrix(py, a, &format!("segments[{k}]"))).collect::<PyResult<_>>()?;
    let ctl: Vec<Vec<f64>> = match controls {
        None => vec![Vec::new(); segs.len()],
        Some(c) => {
            let rows: Vec<Bound<'_, PyAny>> = c
                .try_iter()
                .map_err(|_| err("controls: expected one list of control values per segment"))?
                .collect::<PyResult<_>>()?;
            if rows.len() != segs.len() {
                return Err(err(format!("controls: {} settings for {} segments", rows.len(), segs.len())));
            }
            rows.iter().enumerate().map(|(k, r)| one_setting(r, &format!("controls[{k}]"))).collect::<PyResult<_>>()?
        }
    };
    let channels = channels.or_else(|| column_names(&items[0], segs[0].2));
    let labels = (0..segs.len()).map(|k| format!("segments[{k}]")).collect();
    let m = fit_on(py, segs, labels, ctl, rate_hz, channels, control_names, seed, config)?;
    stable_or_refused(py, m, "fit_segments", allow_unstable)
}

/// One control setting: a flat sequence of numbers (`[1.0]`, a 1-D array; a
/// single row `[[1.0]]` too).
fn one_setting(c: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f64>> {
    let np = c.py().import("numpy")?;
    let a = np
        .call_method1("asarray", (c, "float64"))
        .map_err(|e| err(format!("{name}: expected control values NumPy reads as numbers: {}", e.value(c.py()))))?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    if shape.len() > 1 && shape[..shape.len() - 1].iter().any(|&n| n != 1) {
        return Err(err(format!(
            "{name}: an array of shape {shape:?}; expected one value per control input (several segments: fit_segments)"
        )));
    }
    np.call_method1("ravel", (a,))?.call_method0("tolist")?.extract()
}

/// The channels' names a table carries: a pandas DataFrame's columns (or a
/// Series' name), when there are `d` of them.
fn column_names(y: &Bound<'_, PyAny>, d: usize) -> Option<Vec<String>> {
    let names: Vec<String> = if let Ok(cols) = y.getattr("columns") {
        cols.try_iter().ok()?.map(|c| c.and_then(|c| c.str().map(|s| s.to_string()))).collect::<PyResult<_>>().ok()?
    } else if y.hasattr("to_numpy").unwrap_or(false) && y.hasattr("name").unwrap_or(false) {
        let n = y.getattr("name").ok()?;
        if n.is_none() {
            return None;
        }
        vec![n.str().ok()?.to_string()]
    } else {
        return None;
    };
    (names.len() == d).then_some(names)
}

/// What `fit` and `fit_segments` share: the request checked at once, then the training off the GIL.
#[allow(clippy::too_many_arguments)]
fn fit_on(
    py: Python<'_>,
    segs: Vec<(Vec<f64>, usize, usize)>,
    labels: Vec<String>,
    ctl: Vec<Vec<f64>>,
    rate_hz: f64,
    channels: Option<Vec<String>>,
    control_names: Option<Vec<String>>,
    seed: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyDict>>,
) -> PyResult<TrainedCpg> {
    let seed = match seed {
        Some(s) => int_arg(s, "seed", 0, u64::MAX)?,
        None => 1,
    };
    let overrides = match config {
        Some(cfg) => match to_toml(cfg.as_any(), "")? {
            Some(toml::Value::Table(t)) => Some(t),
            _ => None,
        },
        None => None,
    };
    let request = cpg_lab::fit::FitRequest {
        labels,
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
    interruptible(py, move |_| cpg_lab::fit::fit(request))?.map_err(err)
}

//! `cpg._cpg`: the native part of the `cpg` Python package. Arrays go in
//! and out as numpy float64 arrays shaped (time, channels); every error of
//! the library becomes `cpg.CpgError` (a `ValueError`) with the library's
//! message; long work (training, free runs, evaluation) releases the GIL.
//! The Python layer (`python/cpg/__init__.py`) re-exports this module and
//! documents it; the stubs are `python/cpg/_cpg.pyi`.

use std::path::{Path, PathBuf};

use numpy::ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

use cpg_hoap2::{ChannelMap, Robot as UrdfRobot};
use cpg_lab::{Config, ControlSchedule};
use cpg_mocap::{BvhOptions, Skeleton};
use cpg_reservoir::TrainedCpg;

pyo3::create_exception!(
    _cpg,
    CpgError,
    pyo3::exceptions::PyValueError,
    "An error of the cpg library: a file that cannot be read or parsed, an input of the wrong shape or out of range, a model that diverged. The message is the library's."
);

/// The library error as a Python exception.
fn err(e: impl std::fmt::Display) -> PyErr {
    CpgError::new_err(e.to_string())
}

/// The project's HOAP-2 description and channel maps, carried in the package.
const HOAP2_URDF: &str = include_str!("../../../assets/hoap2/hoap2.urdf");
const HOAP2_MAP: &str = include_str!("../../../assets/hoap2/cmu35_to_hoap2.tsv");
const HOAP2_LEGS_MAP: &str = include_str!("../../../assets/hoap2/cmu35_legs_to_hoap2.tsv");

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

/// A Python dict (with lists, numbers, strings, booleans, paths; None means
/// "leave the key out") as a TOML value.
fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<Option<toml::Value>> {
    if v.is_none() {
        return Ok(None);
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| err(format!("{key}: keys must be strings")))?;
            let path = if key.is_empty() { k.clone() } else { format!("{key}.{k}") };
            if let Some(val) = to_toml(&x, &path)? {
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
    if let Ok(l) = v.try_iter() {
        let mut items = Vec::new();
        for (k, x) in l.enumerate() {
            if let Some(val) = to_toml(&x?, &format!("{key}[{k}]"))? {
                items.push(val);
            }
        }
        return Ok(Some(toml::Value::Array(items)));
    }
    Err(err(format!("`{key}`: a {} cannot be a configuration value", v.get_type().name()?)))
}

/// Merges `over` into `base`, table by table.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

fn config_from_table(t: &toml::Table, name: &str) -> PyResult<Config> {
    let text = toml::to_string(t).map_err(err)?;
    let here = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    Config::from_toml(&text, Path::new(name), &here).map_err(err)
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

    /// Writes the motion as BVH (lengths in centimetres) or AMC, by the extension.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        let sk = self.skeleton.as_ref().ok_or_else(|| err("this motion has no skeleton to write it with"))?;
        let text = if cpg_mocap::is_bvh(&path) {
            cpg_mocap::write_bvh(sk, &self.motion)
        } else {
            cpg_mocap::write_amc(sk, &self.motion)
        }
        .map_err(err)?;
        std::fs::write(&path, text).map_err(|e| err(format!("{}: {e}", path.display())))
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
    m: TrainedCpg,
}

/// Control values for `steps` steps: None (the first teacher's setting, or
/// none for a model without controls), a sequence of one value per input
/// (constant), or an array steps × inputs (the last row is held).
fn schedule(m: &TrainedCpg, controls: Option<&Bound<'_, PyAny>>) -> PyResult<ControlSchedule> {
    let u = m.controls.len();
    let s = match controls {
        None if u == 0 => ControlSchedule::none(),
        None => ControlSchedule::Constant(m.teachers.first().map_or_else(|| vec![0.0; u], |t| t.controls.clone())),
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
    s.check(u).map_err(err)?;
    Ok(s)
}

fn load_robot(urdf: Option<PathBuf>, map: Option<&str>) -> PyResult<(UrdfRobot, ChannelMap)> {
    let robot = match urdf {
        Some(p) => UrdfRobot::from_urdf_file(&p),
        None => UrdfRobot::from_urdf_str(HOAP2_URDF, Path::new("hoap2.urdf")),
    }
    .map_err(err)?;
    let map = match map {
        None | Some("hoap2") => ChannelMap::parse(HOAP2_MAP, "cmu35_to_hoap2.tsv"),
        Some("legs") => ChannelMap::parse(HOAP2_LEGS_MAP, "cmu35_legs_to_hoap2.tsv"),
        Some(p) => ChannelMap::load(Path::new(p)),
    }
    .map_err(err)?;
    Ok((robot, map))
}

/// Steps of `seconds` at `rate`, bounded.
fn steps_for(seconds: f64, rate: f64, d: usize) -> PyResult<usize> {
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= 86_400.0) {
        return Err(err(format!("seconds = {seconds}: expected a duration above 0 and at most 86400 (one day)")));
    }
    let n = (seconds * rate).round() as usize;
    if n == 0 || n.saturating_mul(d.max(1)) > 1 << 27 {
        return Err(err(format!("{seconds} s at {rate} Hz: expected at least one step and at most 2^27 values")));
    }
    Ok(n)
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
                let units: Vec<f64> = t
                    .cycle
                    .iter()
                    .enumerate()
                    .map(|(k, z)| z * self.m.outputs[k % d].std + self.m.outputs[k % d].mean)
                    .collect();
                dict.set_item("cycle", array2(py, units, t.cycle.len() / d, d)?)?;
                Ok(dict)
            })
            .collect()
    }

    /// Free run of `steps` steps under `controls`: steps × channels, in the
    /// channels' units (degrees for rotations).
    #[pyo3(signature = (steps, controls=None))]
    fn generate<'py>(
        &self,
        py: Python<'py>,
        steps: usize,
        controls: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let d = self.m.outputs.len();
        if steps == 0 || steps.saturating_mul(d) > 1 << 27 {
            return Err(err(format!("steps = {steps}: expected 1 to {} for {d} channels", (1usize << 27) / d.max(1))));
        }
        let s = schedule(&self.m, controls)?;
        let y = py
            .detach(|| {
                let mut y = cpg_lab::measure::free_run(&self.m, &s, steps, None)?;
                for (k, v) in y.iter_mut().enumerate() {
                    let o = &self.m.outputs[k % d];
                    *v = *v * o.std + o.mean;
                }
                Ok::<_, cpg_lab::Error>(y)
            })
            .map_err(err)?;
        array2(py, y, steps, d)
    }

    /// A step-by-step generator at the model's start state (for control loops).
    fn generator(&self) -> Generator {
        Generator { g: cpg_reservoir::Generator::new(&self.m), d: self.m.outputs.len(), u: self.m.controls.len() }
    }

    /// A stream at `rate_hz` ticks per second (interpolating between the
    /// model's steps); with `robot=True`, each tick is the HOAP-2's joint
    /// angles (radians) within its position, velocity and acceleration limits.
    #[pyo3(signature = (rate_hz, robot=false, urdf=None, map=None, acceleration_rad_s2=cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2))]
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
        let j = py.detach(|| cpg_lab::measure::judge(&self.m, n, s.as_ref())).map_err(err)?;
        to_py(py, &serde_json::to_value(j).map_err(err)?)
    }

    /// HOAP-2 joint commands for `seconds` of free run: mapped (`map`: the
    /// 22-joint map, `"legs"`, or a map file), clamped to the URDF's ranges,
    /// resampled to `rate_hz` (default: the model's) and kept within every
    /// velocity limit and the acceleration bound. A dict: `joints`, `rate_hz`,
    /// `positions_rad`, `velocities_rad_s`, `accelerations_rad_s2` (frames ×
    /// joints) and `limits` (what each bound changed, per joint).
    #[pyo3(signature = (seconds, rate_hz=None, controls=None, urdf=None, map=None, acceleration_rad_s2=cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2))]
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
        let target = cpg_lab::stream::RobotTarget { robot: &robot, map: &chmap, acceleration_rad_s2 };
        let t = py.detach(|| cpg_lab::stream::joint_trajectory(&self.m, &s, seconds, rate_hz, target)).map_err(err)?;
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
        Ok(Model { m: TrainedCpg::from_bytes(data, Path::new(name)).map_err(err)? })
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
    d: usize,
    u: usize,
}

fn control_values(c: Option<PyReadonlyArray1<'_, f64>>, u: usize) -> PyResult<Vec<f64>> {
    match c {
        None if u == 0 => Ok(Vec::new()),
        None => Err(err(format!("the model has {u} control input(s): give step(control)"))),
        Some(a) => {
            let v: Vec<f64> = a.as_array().iter().copied().collect();
            if v.len() != u {
                return Err(err(format!("control: {} values for {u} control input(s)", v.len())));
            }
            Ok(v)
        }
    }
}

#[pymethods]
impl Generator {
    /// One step: the output (channels, in their units) for `control` (one
    /// value per control input). With `out` (a float64 array of one value per
    /// channel) the output is written there and `out` is returned.
    #[pyo3(signature = (control=None, out=None))]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        control: Option<PyReadonlyArray1<'py, f64>>,
        out: Option<Bound<'py, PyArray1<f64>>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let c = control_values(control, self.u)?;
        let y = self.g.step(&c).map_err(err)?;
        match out {
            Some(o) => {
                if o.len() != self.d {
                    return Err(err(format!("out has {} values; the model has {} channels", o.len(), self.d)));
                }
                let mut w = o.try_readwrite().map_err(err)?;
                let slice = w.as_slice_mut().map_err(err)?;
                slice.copy_from_slice(y);
                drop(w);
                Ok(o)
            }
            None => Ok(PyArray1::from_slice(py, y)),
        }
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.g.steps()
    }
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
    /// One tick: the channels (or joint angles, radians) for `control`.
    #[pyo3(signature = (control=None))]
    fn tick<'py>(
        &mut self,
        py: Python<'py>,
        control: Option<PyReadonlyArray1<'py, f64>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let c = control_values(control, self.u)?;
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
    Ok(Model { m: TrainedCpg::load(&path).map_err(err)? })
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
    let m = py
        .detach(|| {
            let p = cpg_lab::prepare::prepare(&c)?;
            cpg_lab::train::train_prepared(&c, &p, c.reservoir.seed)
        })
        .map_err(err)?;
    Ok(Model { m })
}

/// The configuration `fit` starts from: our protocol of experiments/e1.toml
/// (e5-extension.toml's sequence for several segments), whose validation
/// push and switches are not the ones `Model.evaluate` tests.
fn fit_defaults(segments: usize) -> toml::Table {
    let text = if segments > 1 {
        "[data]\nloop_cycles = 1\nsamples_per_segment = 1000\nrepeats = 3\nmorph_s = 1\n\n[reservoir]\nseed = 1\n\n[training]\nwashout = 200\nnoise_variance = 0\nnoise_draws = 1\npenalty_log10 = { start = 1, step = 0.1, stop = -8 }\nteacher_noise = 0.1\nscore = \"orbit\"\nprefer_larger_within = 1\n\n[training.orbit]\nstay_s = 5\nramp_s = 2\nsettle_s = 1\n"
    } else {
        "[data]\nloop_cycles = 1\nsamples_per_segment = 2200\n\n[reservoir]\nseed = 1\n\n[training]\nwashout = 200\nnoise_variance = 0\nnoise_draws = 1\npenalty_log10 = { start = 1, step = 0.1, stop = -8 }\nteacher_noise = 0.1\nscore = \"orbit\"\nprefer_larger_within = 1\n\n[training.orbit]\nstay_s = 10\nsettle_s = 6.5\npush = { at_s = 1.3, hold_s = 0.1, above_max = 1 }\n"
    };
    text.parse().unwrap_or_default()
}

/// Trains a model on arrays: `y` is one array (time × channels) or a list of
/// them (segments, each with its own control values); z-scoring is inside.
#[pyfunction]
#[pyo3(signature = (y, rate_hz, controls=None, channels=None, control_names=None, seed=1, config=None))]
#[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
fn fit(
    py: Python<'_>,
    y: &Bound<'_, PyAny>,
    rate_hz: f64,
    controls: Option<&Bound<'_, PyAny>>,
    channels: Option<Vec<String>>,
    control_names: Option<Vec<String>>,
    seed: u64,
    config: Option<&Bound<'_, PyDict>>,
) -> PyResult<Model> {
    // The segments, checked at once.
    let arrays: Vec<PyReadonlyArray2<'_, f64>> = if let Ok(a) = y.extract::<PyReadonlyArray2<'_, f64>>() {
        vec![a]
    } else if y.is_instance_of::<PyList>() || y.is_instance_of::<PyTuple>() {
        y.try_iter()?
            .enumerate()
            .map(|(k, a)| {
                a?.extract::<PyReadonlyArray2<'_, f64>>()
                    .map_err(|_| err(format!("y[{k}]: expected a 2-D float64 array (time × channels)")))
            })
            .collect::<PyResult<_>>()?
    } else {
        return Err(err("y: expected a 2-D float64 array (time × channels) or a list of them"));
    };
    if arrays.is_empty() {
        return Err(err("y: no segments"));
    }
    let segs: Vec<(Vec<f64>, usize, usize)> = arrays.iter().map(rows).collect();
    let d = segs[0].2;
    for (k, (v, n, w)) in segs.iter().enumerate() {
        if *w != d {
            return Err(err(format!("y[{k}] has {w} channels; y[0] has {d}")));
        }
        if *n < 4 {
            return Err(err(format!("y[{k}] has {n} frames; a rhythm needs many more")));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(err(format!("y[{k}]: value at frame {}, channel {} is not finite", i / w, i % w)));
        }
    }
    let names = channels.unwrap_or_else(|| (0..d).map(|k| format!("y{k}")).collect());
    if names.len() != d {
        return Err(err(format!("channels: {} names for {d} columns", names.len())));
    }
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
    let u = ctl[0].len();
    let cnames = control_names.unwrap_or_else(|| (0..u).map(|k| format!("u{k}")).collect());
    if ctl.iter().any(|c| c.len() != u) || cnames.len() != u {
        return Err(err("controls: every segment needs one value per control input (and one name each)"));
    }
    // Inside, the columns are channels c0.rx, c1.rx, … (the motion format's `bone.dof`); the model carries the user's names.
    let inner: Vec<cpg_mocap::Channel> =
        (0..d).map(|k| cpg_mocap::Channel { bone: format!("c{k}"), dof: cpg_mocap::Dof::Rx }).collect();
    let mut table = fit_defaults(segs.len());
    let seg_tables: Vec<toml::Value> = ctl
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let mut t = toml::Table::new();
            t.insert("motion".into(), toml::Value::String(format!("y[{k}]")));
            t.insert("label".into(), toml::Value::String(format!("y[{k}]")));
            t.insert("controls".into(), toml::Value::Array(c.iter().map(|v| toml::Value::Float(*v)).collect()));
            toml::Value::Table(t)
        })
        .collect();
    let data: toml::Table = [
        ("rate_hz".to_owned(), toml::Value::Float(rate_hz)),
        ("channels".to_owned(), toml::Value::Array(inner.iter().map(|c| toml::Value::String(c.to_string())).collect())),
        ("controls".to_owned(), toml::Value::Array(cnames.iter().map(|c| toml::Value::String(c.clone())).collect())),
        ("segments".to_owned(), toml::Value::Array(seg_tables)),
    ]
    .into_iter()
    .collect();
    merge(&mut table, [("data".to_owned(), toml::Value::Table(data))].into_iter().collect());
    merge(
        &mut table,
        [
            (
                "reservoir".to_owned(),
                toml::Value::Table([("seed".to_owned(), toml::Value::Integer(seed as i64))].into_iter().collect()),
            ),
            (
                "output".to_owned(),
                toml::Value::Table([("model".to_owned(), toml::Value::String("fit.cpg".into()))].into_iter().collect()),
            ),
        ]
        .into_iter()
        .collect(),
    );
    if let Some(cfg) = config
        && let Some(toml::Value::Table(over)) = to_toml(cfg.as_any(), "")?
    {
        for key in over.keys() {
            if !["data", "reservoir", "training"].contains(&key.as_str()) {
                return Err(err(format!("config: `{key}`; fit takes the sections data, reservoir and training")));
            }
        }
        merge(&mut table, over);
    }
    let c = config_from_table(&table, "<fit>")?;
    let parts: Vec<cpg_mocap::Motion> = segs
        .into_iter()
        .map(|(v, _, _)| cpg_mocap::Motion::new(inner.clone(), v, rate_hz))
        .collect::<Result<_, _>>()
        .map_err(err)?;
    let mut m = py
        .detach(|| {
            let p = cpg_lab::prepare::prepare_recorded(&c, cpg_lab::prepare::Recorded { skeleton: None, parts })?;
            cpg_lab::train::train_prepared(&c, &p, c.reservoir.seed)
        })
        .map_err(err)?;
    for (o, n) in m.outputs.iter_mut().zip(&names) {
        o.name.clone_from(n);
    }
    Ok(Model { m })
}

/// The HOAP-2 URDF the package carries (the project's `assets/hoap2/hoap2.urdf`).
#[pyfunction]
fn hoap2_urdf() -> &'static str {
    HOAP2_URDF
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
#[pyo3(signature = (values, channels, rate_hz, urdf=None, map=None, acceleration_rad_s2=cpg_hoap2::DEFAULT_ACCELERATION_RAD_S2))]
fn map_hoap2<'py>(
    py: Python<'py>,
    values: PyReadonlyArray2<'py, f64>,
    channels: Vec<String>,
    rate_hz: f64,
    urdf: Option<PathBuf>,
    map: Option<String>,
    acceleration_rad_s2: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let (robot, chmap) = load_robot(urdf, map.as_deref())?;
    let (v, _, d) = rows(&values);
    if d != channels.len() {
        return Err(err(format!("{} channel names for {d} columns", channels.len())));
    }
    let t =
        py.detach(|| chmap.apply(&robot, &channels, &v, rate_hz)?.limit(&robot, acceleration_rad_s2)).map_err(err)?;
    trajectory_dict(py, &t)
}

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
    m.add_function(wrap_pyfunction!(robot_joints, m)?)?;
    m.add_function(wrap_pyfunction!(map_hoap2, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

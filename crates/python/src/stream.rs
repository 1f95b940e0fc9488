//! `Generator` and `Stream`: a model stepped one step or one tick at a time.

use cpg_reservoir::TrainedCpg;
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::Path;
use std::sync::Arc;

use crate::convert::*;
use crate::errors::*;

/// Runs a model one step at a time.
#[pyclass(module = "cpg._cpg", name = "Generator")]
pub(crate) struct Generator {
    pub(crate) g: cpg_reservoir::Generator,
    pub(crate) m: Arc<TrainedCpg>,
}

/// One value per control input from anything NumPy reads as numbers (None: none).
pub(crate) fn control_values(py: Python<'_>, c: Option<&Bound<'_, PyAny>>, u: usize) -> PyResult<Vec<f64>> {
    match c {
        None if u == 0 => Ok(Vec::new()),
        None => Err(err(format!("the model has {u} control input(s): give step(control)"))),
        Some(a) => vector(py, a, "control", u),
    }
}

/// The output array `out`: float64, one dimension of `d` values, writable.
pub(crate) fn check_out<'py>(o: &Bound<'py, PyAny>, d: usize) -> PyResult<Bound<'py, PyArray1<f64>>> {
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
    // Checked before the step is taken: a step whose output cannot be kept would be lost.
    let writeable = o.getattr("flags").and_then(|f| f.getattr("writeable")).and_then(|w| w.extract::<bool>());
    if !writeable.unwrap_or(false) {
        return Err(err("out: the array is read-only (its flags.writeable is False); no step was taken"));
    }
    if !a.is_contiguous() {
        return Err(err("out: expected a contiguous float64 array; no step was taken"));
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

/// A generator from a pickled one's model, state and steps.
#[pyfunction]
pub(crate) fn _generator_from_state(data: &[u8], state: Vec<f64>, steps: u64, diverged: bool) -> PyResult<Generator> {
    let m = Arc::new(TrainedCpg::from_bytes(data, Path::new("<pickle>")).map_err(err)?);
    if diverged {
        return Err(err("the pickled generator had diverged; reset() it before pickling"));
    }
    let g = cpg_reservoir::Generator::resume(&m, &state, steps).map_err(err)?;
    Ok(Generator { g, m })
}

/// A model at any tick rate, optionally as HOAP-2 joint angles.
#[pyclass(module = "cpg._cpg", name = "Stream")]
pub(crate) struct Stream {
    pub(crate) t: cpg_lab::stream::Ticker,
    pub(crate) columns: Vec<String>,
    pub(crate) u: usize,
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

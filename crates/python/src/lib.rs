//! `cpg._cpg`: the native part of the `cpg` Python package. Arrays go in
//! and out as numpy float64 arrays shaped (time, channels); every error of
//! the library becomes `cpg.CpgError` (a `ValueError`) with the library's
//! message; long work (training, free runs, evaluation) releases the GIL.
//! The Python layer (`python/cpg/__init__.py`) re-exports this module and
//! documents it; the stubs are `python/cpg/_cpg.pyi`.

mod convert;
mod errors;
mod files;
mod model;
mod motion;
mod robot;
mod sim;
mod stream;

use pyo3::prelude::*;

use errors::CpgError;
use files::{_check_output, _read_bounded, _write_output};
use model::*;
use motion::*;
use robot::*;
use sim::{_controls_at, WalkLoop};
use stream::*;

#[pymodule]
fn _cpg(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("CpgError", m.py().get_type::<CpgError>())?;
    m.add_class::<Motion>()?;
    m.add_class::<Model>()?;
    m.add_class::<Generator>()?;
    m.add_class::<Stream>()?;
    m.add_class::<WalkLoop>()?;
    m.add_function(wrap_pyfunction!(read_motion, m)?)?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(train, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(fit_segments, m)?)?;
    m.add_function(wrap_pyfunction!(hoap2_urdf, m)?)?;
    m.add_function(wrap_pyfunction!(hoap2_mjcf, m)?)?;
    m.add_function(wrap_pyfunction!(_robot_scene, m)?)?;
    m.add_function(wrap_pyfunction!(robot_joints, m)?)?;
    m.add_function(wrap_pyfunction!(map_hoap2, m)?)?;
    m.add_function(wrap_pyfunction!(_model_from_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(_generator_from_state, m)?)?;
    m.add_function(wrap_pyfunction!(_controls_at, m)?)?;
    m.add_function(wrap_pyfunction!(_check_output, m)?)?;
    m.add_function(wrap_pyfunction!(_write_output, m)?)?;
    m.add_function(wrap_pyfunction!(_read_bounded, m)?)?;
    m.add("DEFAULT_ACCELERATION_RAD_S2", cpg_robot::DEFAULT_ACCELERATION_RAD_S2)?;
    m.add("SPLIT_MIN_NEURONS", SPLIT_MIN_NEURONS)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

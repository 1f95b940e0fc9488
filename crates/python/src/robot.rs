//! The HOAP-2 the package carries: its URDF, its MuJoCo scene, its joints,
//! and recorded channels mapped onto it.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::*;
use crate::errors::*;
use crate::model::*;

/// The HOAP-2 URDF the package carries (the project's `assets/hoap2/hoap2.urdf`).
#[pyfunction]
pub(crate) fn hoap2_urdf() -> &'static str {
    cpg_hoap2::assets::HOAP2_URDF
}

/// The HOAP-2 as a MuJoCo scene (the project's `assets/hoap2/hoap2.xml`):
/// floor, body on a free joint, a position servo per joint (named after it),
/// IMU and sole touch sensors, keyframe `home` standing in the home crouch.
/// Load it with `mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())`.
#[pyfunction]
pub(crate) fn hoap2_mjcf() -> &'static str {
    cpg_hoap2::assets::HOAP2_MJCF
}

/// The HOAP-2 joints of a URDF (default: the package's): name, parent and
/// child links, lower and upper limits (rad), velocity limit (rad/s).
#[pyfunction]
#[pyo3(signature = (urdf=None))]
pub(crate) fn robot_joints<'py>(py: Python<'py>, urdf: Option<PathBuf>) -> PyResult<Vec<Bound<'py, PyDict>>> {
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
pub(crate) fn map_hoap2<'py>(
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

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
    cpg_robot::assets::HOAP2_URDF
}

/// The HOAP-2 as a MuJoCo scene (the project's `assets/hoap2/hoap2.xml`):
/// floor, body on a free joint, a position servo per joint (named after it),
/// IMU and sole touch sensors, keyframe `home` standing in the home crouch.
/// Load it with `mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())`.
#[pyfunction]
pub(crate) fn hoap2_mjcf() -> &'static str {
    cpg_robot::assets::HOAP2_MJCF
}

/// The most bytes of a robot's MuJoCo scene read.
const MAX_MJCF_BYTES: u64 = 64 << 20;
/// The largest gains file a robot's folder may hold, bytes.
const MAX_GAINS_BYTES: u64 = 1 << 20;

/// A robot's scene as the simulator needs it: `name`, `title`, `mjcf` (the
/// MuJoCo scene's text), `mjcf_path` (its file, for a robot's folder, so
/// that meshes beside it load; `None` for a built-in robot), `trunk` (the
/// URDF's root link, the body the simulator follows), the sensors' names
/// (`imu_quat`, `imu_gyro`, `touch`: left then right), `leg_m` (hip to
/// floor with the leg straight, to 0.1 mm) and `gains_json` (the walk's
/// shipped feedback gains, or `None`). `robot`: a built-in name
/// (`hoap2`) or a robot's folder (its `robot.toml`).
#[pyfunction]
pub(crate) fn _robot_scene<'py>(py: Python<'py>, robot: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let r = cpg_robot::Robot::from_spec(&robot).map_err(err)?;
    let spec = r.spec().map_err(err)?;
    let builtin = robot.as_os_str() == "hoap2";
    // A file the spec names, relative to its folder, read as text within `max` bytes.
    let dir = if robot.is_dir() { robot.clone() } else { robot.parent().map(PathBuf::from).unwrap_or_default() };
    let read_text = |name: &std::path::Path, max: u64| -> PyResult<(String, PathBuf)> {
        let path = cpg_robot::RobotSpec::path_in(&dir, name);
        let bytes = cpg_io::read_bounded(&path, max).map_err(|e| err(format!("{}: {e}", path.display())))?;
        let text = String::from_utf8(bytes).map_err(|_| err(format!("{}: not UTF-8 text", path.display())))?;
        Ok((text, path))
    };
    let (mjcf, mjcf_path) = if builtin {
        (cpg_robot::assets::HOAP2_MJCF.to_owned(), None)
    } else {
        let (text, path) = read_text(&spec.mjcf, MAX_MJCF_BYTES)?;
        (text, Some(path))
    };
    let leg = cpg_lab::retarget::robot_leg_length_m(&r).map_err(err)?;
    let d = PyDict::new(py);
    d.set_item("name", &spec.name)?;
    d.set_item("title", &spec.title)?;
    d.set_item("mjcf", mjcf)?;
    d.set_item("mjcf_path", mjcf_path)?;
    let trunk = r.joints.iter().map(|j| j.parent.as_str()).find(|p| !r.joints.iter().any(|j| j.child == *p));
    d.set_item("trunk", trunk)?;
    d.set_item("imu_quat", &spec.sensors.imu_quat)?;
    d.set_item("imu_gyro", &spec.sensors.imu_gyro)?;
    d.set_item("touch", spec.sensors.touch.to_vec())?;
    d.set_item("leg_m", (leg * 1e4).round() / 1e4)?;
    // The walk's shipped feedback gains (JSON text), if the spec names them.
    let gains = match &spec.gains {
        None => None,
        Some(_) if builtin => Some(cpg_robot::assets::HOAP2_GAINS.to_owned()),
        Some(g) => Some(read_text(g, MAX_GAINS_BYTES)?.0),
    };
    d.set_item("gains_json", gains)?;
    Ok(d)
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
const _: () = assert!(cpg_robot::DEFAULT_ACCELERATION_RAD_S2 == 100.0);

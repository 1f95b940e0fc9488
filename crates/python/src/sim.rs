//! `_WalkLoop`: `cpg.sim`'s controller, one call before and one after each
//! MuJoCo step (`cpg_robot::control` on MjData's own arrays).

use cpg_robot::control::{Drive, Driven, Gains, Plan, Schedule, Sensors, WalkController};
use cpg_robot::imu::{Imu, ImuFaults};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::errors::*;
use crate::stream::Generator;

/// A model's generator as the controller's drive.
struct Gen(cpg_reservoir::Generator);

impl Drive for Gen {
    type Error = String;
    fn step(&mut self, control: &[f64]) -> Result<&[f64], String> {
        let steps = self.0.steps();
        self.0.step(control).map_err(|e| format!("the generator failed at its step {steps}: {e}"))
    }
}

/// The controller of one `cpg.sim.simulate` run, reading and writing
/// MjData's arrays in place (views kept at construction).
#[pyclass(module = "cpg._cpg", name = "_WalkLoop", unsendable)]
pub(crate) struct WalkLoop {
    c: WalkController<Gen>,
    act: Vec<usize>,
    sensordata: Py<PyArray1<f64>>,
    ctrl: Py<PyArray1<f64>>,
    force: Py<PyArray1<f64>>,
    velocity: Py<PyArray1<f64>>,
    quat: usize,
    gyro: usize,
    touch: [usize; 2],
    imu: Imu,
}

/// A contiguous array's values, borrowed for reading.
fn values<'py>(a: &Bound<'py, PyArray1<f64>>, name: &str) -> PyResult<PyReadonlyArray1<'py, f64>> {
    let r = a.try_readonly().map_err(|e| err(format!("{name}: {e}")))?;
    if !r.is_contiguous() {
        return Err(err(format!("{name}: expected a contiguous float64 array")));
    }
    Ok(r)
}

#[pymethods]
impl WalkLoop {
    #[new]
    #[pyo3(signature = (
        *, clock_s, angles_rad, joints, landings, act, lo, hi, gains_json, mass_kg, dt_s, tempo, tempo_at_s,
        sensordata, ctrl, force, velocity, quat_adr, gyro_adr, touch_adr,
        generator=None, drive=None, rate_hz=0.0, handover_s=0.0, first_rad=None, base=None,
        tempo_input=None, walk_input=None, tempo_ramp_s=3.0, stop_at_s=None, stop_ramp_s=2.0,
        start_at_s=None, start_ramp_s=2.0, robot="hoap2", imu_json="{}"
    ))]
    #[allow(clippy::too_many_arguments)] // keyword-only: one run's settings, each named at the call
    fn new(
        clock_s: PyReadonlyArray1<'_, f64>,
        angles_rad: PyReadonlyArray2<'_, f64>,
        joints: Vec<String>,
        landings: Vec<(f64, usize)>,
        act: Vec<usize>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        gains_json: &str,
        mass_kg: f64,
        dt_s: f64,
        tempo: f64,
        tempo_at_s: f64,
        sensordata: Bound<'_, PyArray1<f64>>,
        ctrl: Bound<'_, PyArray1<f64>>,
        force: Bound<'_, PyArray1<f64>>,
        velocity: Bound<'_, PyArray1<f64>>,
        quat_adr: usize,
        gyro_adr: usize,
        touch_adr: [usize; 2],
        generator: Option<PyRef<'_, Generator>>,
        drive: Option<Vec<usize>>,
        rate_hz: f64,
        handover_s: f64,
        first_rad: Option<Vec<f64>>,
        base: Option<Vec<f64>>,
        tempo_input: Option<usize>,
        walk_input: Option<usize>,
        tempo_ramp_s: f64,
        stop_at_s: Option<f64>,
        stop_ramp_s: f64,
        start_at_s: Option<f64>,
        start_ramp_s: f64,
        robot: &str,
        imu_json: &str,
    ) -> PyResult<Self> {
        let gains: Gains = serde_json::from_str(gains_json).map_err(|e| err(format!("gains: {e}")))?;
        let faults: ImuFaults = serde_json::from_str(imu_json).map_err(|e| err(format!("imu: {e}")))?;
        let imu = Imu::new(faults, dt_s).map_err(err)?;
        let a = angles_rad.as_array();
        let plan =
            Plan::new(clock_s.as_slice()?.to_vec(), a.iter().copied().collect(), a.ncols(), landings).map_err(err)?;
        let (nu, ns) = (ctrl.len(), sensordata.len());
        if act.len() != joints.len() || act.iter().any(|&k| k >= nu) {
            return Err(err(format!("act: one servo index below {nu} per joint ({} joints)", joints.len())));
        }
        if force.len() != nu || velocity.len() != nu {
            return Err(err(format!("force and velocity: one value per servo ({nu})")));
        }
        if quat_adr + 4 > ns || gyro_adr + 2 > ns || touch_adr.iter().any(|&k| k >= ns) {
            return Err(err(format!("a sensor address beyond the {ns} sensor values")));
        }
        let driven = match generator {
            None => None,
            Some(g) => {
                let schedule = Schedule {
                    base: base.unwrap_or_default(),
                    tempo_input,
                    walk_input,
                    tempo_ramp_s,
                    stop_at_s,
                    stop_ramp_s,
                    start_at_s,
                    start_ramp_s,
                };
                if schedule.base.len() != g.m.controls.len() {
                    return Err(err(format!("base: one value per control input ({})", g.m.controls.len())));
                }
                let drive = drive.unwrap_or_default();
                if drive.len() != g.m.outputs.len() {
                    return Err(err(format!("drive: one joint per model channel ({})", g.m.outputs.len())));
                }
                let first = first_rad.unwrap_or_default();
                Some(Driven::new(Gen(g.g.clone()), drive, rate_hz, handover_s, &first, schedule).map_err(err)?)
            }
        };
        let names: Vec<&str> = joints.iter().map(String::as_str).collect();
        // The robot's legs and servos: a built-in name or a robot's folder (its robot.toml).
        let robot = cpg_robot::Robot::from_spec(std::path::Path::new(robot)).map_err(err)?;
        let spec = robot.spec().map_err(err)?;
        let c = WalkController::new(plan, spec, &names, lo, hi, gains, mass_kg, dt_s, tempo, tempo_at_s, nu, driven)
            .map_err(err)?;
        Ok(WalkLoop {
            c,
            act,
            sensordata: sensordata.unbind(),
            ctrl: ctrl.unbind(),
            force: force.unbind(),
            velocity: velocity.unbind(),
            quat: quat_adr,
            gyro: gyro_adr,
            touch: touch_adr,
            imu,
        })
    }

    /// Before the physics step at `t_s`: the sensors read, the servos' commands written.
    fn control(&mut self, py: Python<'_>, t_s: f64) -> PyResult<()> {
        let r = values(self.sensordata.bind(py), "sensordata")?;
        let s = r.as_slice()?;
        let q = &s[self.quat..self.quat + 4];
        let sensors = Sensors {
            quat: [q[0], q[1], q[2], q[3]],
            gyro: [s[self.gyro], s[self.gyro + 1]],
            touch_n: [s[self.touch[0]], s[self.touch[1]]],
        };
        drop(r);
        // What the IMU reports: late, biased, drifting and noisy as the run's world asks.
        let sensors = self.imu.read(t_s, &sensors);
        let mut w = self.ctrl.bind(py).try_readwrite().map_err(|e| err(format!("ctrl: {e}")))?;
        let out = w.as_slice_mut().map_err(|_| err("ctrl: expected a contiguous float64 array"))?;
        self.c.control(t_s, &sensors, &self.act, out).map_err(err)
    }

    /// After the physics step: the servos' torques and work counted.
    fn measure(&mut self, py: Python<'_>) -> PyResult<()> {
        let f = values(self.force.bind(py), "force")?;
        let v = values(self.velocity.bind(py), "velocity")?;
        self.c.measure(f.as_slice()?, v.as_slice()?);
        Ok(())
    }

    /// Each servo's largest |torque| so far, N·m.
    #[getter]
    fn torque_peak(&self) -> Vec<f64> {
        self.c.torque_peak().to_vec()
    }

    /// The servos' work so far, J.
    #[getter]
    fn work_j(&self) -> f64 {
        self.c.work_j()
    }

    /// The gait clock, s.
    #[getter]
    fn clock_s(&self) -> f64 {
        self.c.clock_s()
    }
}

/// The control inputs at `t_s` of a run's schedule (what `_WalkLoop` gives
/// the generator then): `base` with the tempo ramp, the start and the stop applied.
#[pyfunction]
#[pyo3(signature = (
    t_s, *, base, tempo_input, walk_input, tempo, tempo_at_s, tempo_ramp_s, stop_at_s, stop_ramp_s,
    start_at_s=None, start_ramp_s=2.0
))]
#[allow(clippy::too_many_arguments)] // keyword-only, as _WalkLoop takes them
pub(crate) fn _controls_at(
    t_s: f64,
    base: Vec<f64>,
    tempo_input: Option<usize>,
    walk_input: Option<usize>,
    tempo: f64,
    tempo_at_s: f64,
    tempo_ramp_s: f64,
    stop_at_s: Option<f64>,
    stop_ramp_s: f64,
    start_at_s: Option<f64>,
    start_ramp_s: f64,
) -> PyResult<Vec<f64>> {
    let mut u = base.clone();
    let s = Schedule { base, tempo_input, walk_input, tempo_ramp_s, stop_at_s, stop_ramp_s, start_at_s, start_ramp_s };
    s.check().map_err(err)?;
    s.at(t_s, tempo, tempo_at_s, &mut u);
    Ok(u)
}

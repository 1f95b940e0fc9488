//! What a trained CPG looks like: a [`cpg_view::Scene`] of the teacher it
//! learnt, the model's free run, and the HOAP-2 driven by that run, on one
//! timeline. This module builds the scene; rendering it (HTML, GIF) is
//! `cpg_view`'s.

use cpg_mocap::{Channel, Motion, Skeleton};
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, Robot};
use cpg_view::{Figure, Scene};

use crate::error::{Error, Result};
use crate::measure::free_run;
use crate::schedule::ControlSchedule;

/// The robot panel of a scene: the robot, the map from the model's
/// channels to its joints (a channel the model does not generate counts as
/// 0, as it does in the human figures), and the acceleration bound of every joint.
#[derive(Debug, Clone, Copy)]
pub struct RobotView<'a> {
    /// The robot description.
    pub robot: &'a Robot,
    /// Channels → joints.
    pub map: &'a ChannelMap,
    /// The acceleration bound, rad/s² (as `cpg hoap2` uses it).
    pub acceleration_rad_s2: f64,
}

/// The teacher (when the model has one), the model's free run of `n_steps`
/// under `controls`, and, with `robot`, the robot driven by that run
/// (mapped, clamped to its position range and kept within its velocity
/// limits and the acceleration bound, as `cpg hoap2` does).
///
/// The human figures use the skeleton stored in the model; channels the
/// model does not generate are held at 0, and the figure is put on the floor.
/// At each step the teacher panel shows the teacher of the control values of
/// that step (`TrainedCpg::teacher_for`), its cycle looped.
pub fn model_scene(
    title: &str,
    m: &TrainedCpg,
    controls: &ControlSchedule,
    n_steps: usize,
    robot: Option<RobotView<'_>>,
) -> Result<Scene> {
    // The scene's size is bounded before the free run: its human figures (teacher and
    // model) and at least the robot's links, frame by frame.
    if let Some(asf) = &m.skeleton_asf {
        let sk =
            cpg_mocap::parse_asf("the skeleton stored in the model", asf.as_bytes()).map_err(cpg_mocap::Error::from)?;
        let humans = 1 + usize::from(!m.teachers.is_empty());
        let points = humans * (sk.bones.len() + 1) + robot.as_ref().map_or(0, |r| r.robot.joints.len() + 1);
        if cpg_view::check_scene_size(n_steps, points).is_err() {
            let most_s = (cpg_view::MAX_VALUES / (3 * points.max(1))) as f64 / m.provenance.sample_rate_hz;
            return Err(Error::Bound(format!(
                "{n_steps} steps ({:.0} s) of {points} points per frame are more than the {} coordinates a page holds: at most {most_s:.0} s of this model",
                n_steps as f64 / m.provenance.sample_rate_hz,
                cpg_view::MAX_VALUES
            )));
        }
    }
    let mut y = free_run(m, controls, n_steps, None)?;
    cpg_reservoir::to_units_in_place(&m.outputs, &mut y);
    cpg_reservoir::integrate_in_place(&m.outputs, &mut y, m.provenance.sample_rate_hz);
    crate::travel::feet_led(m, &mut y)?;
    run_scene(title, m, controls, 0, &y, robot)
}

/// [`model_scene`] of a run already made: `y_units` holds the model's
/// outputs in their own units (degrees; rates integrated, as
/// [`cpg_reservoir::integrate_in_place`] does), frame-major, from step
/// `first_step` of `controls` on.
pub fn run_scene(
    title: &str,
    m: &TrainedCpg,
    controls: &ControlSchedule,
    first_step: usize,
    y_units: &[f64],
    robot: Option<RobotView<'_>>,
) -> Result<Scene> {
    let Some(asf) = &m.skeleton_asf else {
        return Err(Error::Unusable(
            "the model stores no skeleton (it was not trained from an ASF/AMC recording), so there is no figure to draw"
                .into(),
        ));
    };
    let sk =
        cpg_mocap::parse_asf("the skeleton stored in the model", asf.as_bytes()).map_err(cpg_mocap::Error::from)?;
    let channels = crate::run::mocap_channels(m)?;
    let rate = m.provenance.sample_rate_hz;
    let d = m.outputs.len();
    if d == 0 || y_units.is_empty() || !y_units.len().is_multiple_of(d) {
        return Err(Error::Shape(format!("{} values do not form frames of {d} channels", y_units.len())));
    }
    let n_steps = y_units.len() / d;
    let mut figures = Vec::new();
    if !m.teachers.is_empty() {
        let mut u = vec![0.0; m.controls.len()];
        let mut t = Vec::with_capacity(n_steps * d);
        for k in first_step..first_step + n_steps {
            controls.fill(k, rate, &mut u);
            let Some(teacher) = m.teacher_for(&u) else { break };
            let p = teacher.cycle.len() / d;
            t.extend(teacher.cycle[(k % p) * d..(k % p + 1) * d].iter().zip(&m.outputs).map(|(z, o)| o.to_units(*z)));
        }
        cpg_reservoir::integrate_in_place(&m.outputs, &mut t, rate);
        let labels: Vec<&str> = m.teachers.iter().map(|t| t.label.as_str()).collect();
        figures.push(
            human(&sk, &channels, t, rate, "teacher")?
                .with_note(format!("the cycle it learnt, looped: {}", labels.join("; "))),
        );
    }
    figures.push(human(&sk, &channels, y_units.to_vec(), rate, "model")?.with_note(format!(
        "the CPG's free run: {} channel(s){}",
        d,
        if d < sk.all_channels().len() { ", the others at 0" } else { "" }
    )));
    if let Some(r) = robot {
        // Channels of the map the model does not generate are 0, as in the human figures.
        let mut names: Vec<String> = m.outputs.iter().map(|o| o.unit_name().to_owned()).collect();
        let driven = r.map.entries.iter().filter(|e| names.contains(&e.channel)).count();
        if driven > 0 {
            let missing: Vec<String> =
                r.map.channels().into_iter().filter(|c| !names.iter().any(|n| n == c)).map(str::to_owned).collect();
            let width = d + missing.len();
            let mut values = vec![0.0; n_steps * width];
            for (row, y) in values.chunks_exact_mut(width).zip(y_units.chunks_exact(d)) {
                row[..d].copy_from_slice(y);
            }
            names.extend(missing);
            let t = r.map.apply(r.robot, &names, &values, rate)?.limit(r.robot, r.acceleration_rad_s2)?;
            figures.push(Figure::robot(&robot_label(r.robot), r.robot, &t).map_err(view_error)?.with_note(format!(
                "{driven} of the map's {} joints driven by the model (the others as the map puts a channel at 0, like the human figures), within position, velocity and {} rad/s² limits; placed on the floor kinematically",
                r.map.entries.len(),
                r.acceleration_rad_s2
            )));
        }
    }
    let mut scene = Scene::new(title, rate, figures).map_err(view_error)?;
    scene.notes.push(format!(
        "{} steps ({:.1} s at {rate} Hz) of free run from {:.1} s on; model trained on {}.",
        n_steps,
        n_steps as f64 / rate,
        first_step as f64 / rate,
        m.provenance.data
    ));
    Ok(scene)
}

/// The robot's name as people write it (`HOAP-2` for the URDF's `hoap2`).
pub fn robot_label(robot: &Robot) -> String {
    if robot.name.eq_ignore_ascii_case("hoap2") { "HOAP-2".to_owned() } else { robot.name.clone() }
}

fn human(sk: &Skeleton, channels: &[Channel], values: Vec<f64>, rate: f64, label: &str) -> Result<Figure> {
    let motion = Motion::new(channels.to_vec(), values, rate)?;
    Figure::human(label, sk, &motion).map_err(view_error)
}

pub(crate) fn view_error(e: cpg_view::Error) -> Error {
    match e {
        cpg_view::Error::Mocap(e) => Error::Mocap(e),
        cpg_view::Error::Robot(e) => Error::Hoap2(e),
        other => Error::Shape(other.to_string()),
    }
}

//! `cpg view`: watch a model (teacher, free run, robot) or a recording, as a
//! self-contained HTML page or an animated GIF.

use std::path::Path;

use anyhow::{Context, bail};
use cpg_reservoir::TrainedCpg;
use cpg_robot::{ChannelMap, Robot};
use cpg_view::{Camera, Figure, GifOptions, Scene};

use super::{schedule, steps};
use cpg_lab::format::Format;

use crate::output::check_writable;

/// `cpg view`'s arguments.
pub struct View<'a> {
    pub model: Option<&'a Path>,
    pub control: Option<&'a str>,
    pub control_file: Option<&'a Path>,
    pub motion: Option<&'a Path>,
    pub skeleton: Option<&'a Path>,
    pub sim: Option<&'a Path>,
    pub motion_rate_hz: Option<f64>,
    pub bvh_unit_mm: Option<f64>,
    pub seconds: f64,
    pub robot: bool,
    pub urdf: &'a Path,
    pub map: &'a Path,
    pub acceleration_rad_s2: f64,
    pub output: &'a Path,
    pub format: Option<&'a str>,
    pub gif_seconds: f64,
    pub fps: f64,
    pub yaw_deg: f64,
}

pub fn run(a: View<'_>) -> anyhow::Result<()> {
    let format = Format::choose(a.format, a.output, &Format::SCENE, Format::Html)?;
    if !(a.yaw_deg.is_finite() && (-360.0..=360.0).contains(&a.yaw_deg)) {
        bail!("--yaw-deg {}: expected an angle from -360 to 360", a.yaw_deg);
    }
    let dest = check_writable(a.output)?;
    let mut scene = match (a.model, a.motion, a.sim) {
        (Some(model), None, None) => model_scene(&a, model)?,
        (None, Some(motion), None) => recording_scene(&a, motion)?,
        (None, None, Some(sim)) => sim_scene(&a, sim)?,
        (None, None, None) => bail!(
            "give --model FILE.cpg (a trained CPG), --motion FILE.amc with --skeleton (a recording) or --sim RUN.json (a simulated run)"
        ),
        _ => bail!("give one of --model, --motion and --sim"),
    };
    scene.camera = Camera { yaw_deg: a.yaw_deg, ..Camera::default() };
    let gif = GifOptions { seconds: Some(a.gif_seconds), fps: a.fps, ..GifOptions::default() };
    cpg_lab::format::write_scene(a.output, format, &scene, &gif)?;
    let labels: Vec<&str> = scene.figures.iter().map(|f| f.label.as_str()).collect();
    eprintln!(
        "wrote {} ({} frames, {:.1} s at {} Hz: {}) to {}",
        if format == Format::Gif { "an animated GIF" } else { "a self-contained HTML page" },
        scene.n_frames(),
        scene.n_frames() as f64 / scene.rate_hz,
        scene.rate_hz,
        labels.join(", "),
        dest.describe()
    );
    Ok(())
}

fn model_scene(a: &View<'_>, model: &Path) -> anyhow::Result<Scene> {
    let m = TrainedCpg::load(model)?;
    let rate = m.provenance.sample_rate_hz;
    let n = steps(a.seconds, rate, m.outputs.len())?;
    let controls = schedule(&m, a.control, a.control_file)?;
    let loaded;
    let robot = if a.robot {
        loaded = (Robot::from_spec(a.urdf)?, ChannelMap::from_spec(a.map)?);
        Some(cpg_lab::scene::RobotView { robot: &loaded.0, map: &loaded.1, acceleration_rad_s2: a.acceleration_rad_s2 })
    } else {
        None
    };
    let title = model.file_name().map_or_else(|| model.display().to_string(), |f| f.to_string_lossy().into_owned());
    cpg_lab::scene::model_scene(&title, &m, &controls, n, robot).with_context(|| format!("drawing {}", model.display()))
}

fn sim_scene(a: &View<'_>, sim: &Path) -> anyhow::Result<Scene> {
    let bytes = cpg_mocap::read_bounded(sim, cpg_mocap::MAX_INPUT_BYTES)?;
    let text = String::from_utf8(bytes).with_context(|| format!("{}: not UTF-8 text", sim.display()))?;
    let run = cpg_lab::experiment::walking::SimRun::from_json(&text, sim)?;
    let name = sim.file_name().map_or_else(|| sim.display().to_string(), |f| f.to_string_lossy().into_owned());
    run.scene(&name, Some(a.seconds)).with_context(|| format!("drawing {}", sim.display()))
}

fn recording_scene(a: &View<'_>, motion: &Path) -> anyhow::Result<Scene> {
    let r = cpg_mocap::read_recording(
        motion,
        a.skeleton,
        a.motion_rate_hz,
        &cpg_mocap::BvhOptions { length_unit_mm: a.bvh_unit_mm },
    )?;
    let rate = r.motion.sample_rate_hz();
    let n = steps(a.seconds, rate, r.motion.n_channels())?.min(r.motion.n_frames());
    let m = r.motion.slice(0, n)?;
    let name = motion.file_name().map_or_else(|| motion.display().to_string(), |f| f.to_string_lossy().into_owned());
    let mut figures = vec![Figure::human("recording", &r.skeleton, &m)?.with_note(format!("{n} frames of {name}"))];
    let names = m.channel_names();
    let bvh = matches!(r.format, cpg_mocap::Format::Bvh { .. });
    if a.robot && bvh {
        eprintln!(
            "note: the robot is left out: channel maps read AMC channels (rotations about each bone's ASF axes), and a BVH file's channels are rotations about world-aligned axes (docs/hoap2-map.md)"
        );
    }
    let map = if a.robot && !bvh { Some(ChannelMap::from_spec(a.map)?) } else { None };
    let lacking: Vec<String> = map
        .as_ref()
        .map(|m| m.channels().into_iter().filter(|c| !names.iter().any(|n| n == c)).map(str::to_owned).collect())
        .unwrap_or_default();
    if !lacking.is_empty() {
        eprintln!(
            "note: the robot is left out: its map reads channels the recording lacks ({}{}); --map names another map",
            lacking[..lacking.len().min(4)].join(", "),
            if lacking.len() > 4 { ", …" } else { "" }
        );
    }
    if let Some(map) = map.filter(|_| lacking.is_empty()) {
        let robot = Robot::from_spec(a.urdf)?;
        let t = map.apply(&robot, &names, m.values(), rate)?;
        let t = t.limit(&robot, a.acceleration_rad_s2)?;
        figures.push(Figure::robot(&cpg_lab::scene::robot_label(&robot), &robot, &t)?.with_note(format!(
            "the recording mapped onto {} joints, within position, velocity and {} rad/s² limits; placed on the floor kinematically",
            t.joints.len(),
            a.acceleration_rad_s2
        )));
    }
    Ok(Scene::new(&name, rate, figures)?)
}

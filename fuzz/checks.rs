//! What every fuzz target checks, one function per target. The fuzz binaries
//! (`fuzz/targets/*.rs`) call these on generated inputs; the workspace test
//! `tests/fuzz_regressions.rs` calls them on every input kept in
//! `fuzz/regressions/<target>/` and `fuzz/seeds/<target>/`. A check passes
//! when the input is rejected with an error, or accepted and everything built
//! from it is finite and of the announced shape; it fails by panicking.

#![allow(dead_code)] // each fuzz binary uses one of the checks

use std::path::Path;

/// The three-bone test skeleton the AMC target parses against.
pub const TINY_ASF: &[u8] = include_bytes!("../crates/mocap/test_data/tiny.asf");

/// The control inputs the control-CSV target's header must name.
pub const CONTROL_NAMES: [&str; 2] = ["speed", "gait"];

/// Steps generated from an accepted model.
const MODEL_STEPS: usize = 64;

/// ASF: rejected, or a skeleton of finite geometry whose rest pose is finite.
pub fn asf(data: &[u8]) {
    let Ok(sk) = cpg_mocap::parse_asf("fuzz.asf", data) else { return };
    assert!(sk.mm_per_unit().is_finite() && sk.mm_per_unit() > 0.0, "unit {}", sk.mm_per_unit());
    for b in &sk.bones {
        assert!(b.length.is_finite(), "bone {} length {}", b.name, b.length);
        assert!(b.direction.iter().chain(&b.axis_deg).all(|v| v.is_finite()), "bone {}", b.name);
        // ASF limits are optional: none, or one interval per degree of freedom.
        assert!(b.limits.is_empty() || b.limits.len() == b.dofs.len(), "bone {}", b.name);
    }
    // The rest pose: one frame of zeros for every channel.
    let channels = sk.all_channels();
    let zeros = vec![0.0; channels.len()];
    if let Ok(m) = cpg_mocap::Motion::new(channels, zeros, 120.0)
        && let Ok(p) = sk.forward_kinematics(&m)
    {
        assert!(p.frame(0).iter().flatten().all(|v| v.is_finite()), "rest pose not finite");
    }
}

/// AMC against the tiny skeleton: rejected, or finite values whose
/// kinematics are finite, and written AMC that parses back to the same motion.
pub fn amc(data: &[u8]) {
    let sk = cpg_mocap::parse_asf("tiny.asf", TINY_ASF).expect("the test skeleton parses");
    let Ok(m) = cpg_mocap::parse_amc("fuzz.amc", data, &sk, 120.0) else { return };
    assert!(m.n_frames() >= 1);
    assert!(m.values().iter().all(|v| v.is_finite()), "non-finite value accepted");
    if let Ok(p) = sk.forward_kinematics(&m) {
        for f in 0..p.n_frames() {
            assert!(p.frame(f).iter().flatten().all(|v| v.is_finite()), "frame {f}: kinematics not finite");
        }
    }
    let text = cpg_mocap::write_amc(&sk, &m).expect("an accepted motion can be written");
    let again = cpg_mocap::parse_amc("again.amc", text.as_bytes(), &sk, 120.0).expect("written AMC parses");
    assert_eq!(again.n_frames(), m.n_frames());
}

/// BVH: rejected, or a skeleton and motion whose kinematics are finite, and
/// written BVH that parses back to the same marker positions (to 1e-6 mm
/// per mm of the figure's size, as the values are written with 9 decimals).
pub fn bvh(data: &[u8]) {
    let opts = cpg_mocap::BvhOptions { length_unit_mm: Some(10.0) };
    let Ok(b) = cpg_mocap::parse_bvh("fuzz.bvh", data, &opts) else { return };
    assert!(b.motion.n_frames() >= 1);
    assert!(b.motion.values().iter().all(|v| v.is_finite()), "non-finite value accepted");
    let Ok(p) = b.skeleton.forward_kinematics(&b.motion) else { return };
    for f in 0..p.n_frames() {
        assert!(p.frame(f).iter().flatten().all(|v| v.is_finite()), "frame {f}: kinematics not finite");
    }
    let again = cpg_mocap::parse_asf("again.asf", cpg_mocap::write_asf(&b.skeleton).as_bytes())
        .expect("the ASF of a BVH skeleton parses");
    assert_eq!(again.bones.len(), b.skeleton.bones.len());
    // Writing refuses what could not be read back (values beyond ±1e6); what it writes reads.
    if let Ok(text) = cpg_mocap::write_bvh(&b.skeleton, &b.motion) {
        let back = cpg_mocap::parse_bvh("again.bvh", text.as_bytes(), &opts).expect("written BVH parses");
        assert_eq!(back.motion.n_frames(), b.motion.n_frames());
    }
}

/// A URDF: rejected, or a robot whose every joint has a finite interval of
/// limits, a unit axis and a finite origin, and whose joints can be looked up by name.
pub fn urdf(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(r) = cpg_robot::Robot::from_urdf_str(text, Path::new("fuzz.urdf")) else { return };
    for j in &r.joints {
        assert!(j.lower_rad.is_finite() && j.upper_rad.is_finite() && j.lower_rad < j.upper_rad, "{}", j.name);
        let n = j.axis.iter().map(|a| a * a).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-9, "{}: axis {:?}", j.name, j.axis);
        assert!(r.joint(&j.name).is_ok(), "{}", j.name);
    }
}

/// A TOML configuration: rejected, or accepted with every checked bound
/// (the sizes it asks for are what `Config::check` allows).
pub fn config(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(c) = cpg_lab::Config::from_toml(text, Path::new("fuzz.toml"), Path::new("/nonexistent")) else { return };
    let max = cpg_lab::config::MAX_TRAINING_SAMPLES;
    assert!(c.data.samples_per_segment <= max && c.training.washout <= max);
    assert!(c.training.validation_samples <= max && c.training.noise_draws <= 100);
    assert!(c.data.rate_hz.is_finite() && c.data.rate_hz > 0.0);
    // Everything derived from it without reading data must work or fail cleanly.
    if let Ok(s) = cpg_lab::train::train_settings(&c) {
        assert!(s.penalties.len() <= cpg_lab::config::MAX_PENALTIES);
    }
    let _ = cpg_lab::train::reservoir_config(&c, c.data.channels.len().max(1));
    let _ = c.to_toml(Path::new("/nonexistent"));
}

/// A model file: the raw bytes, and the bytes framed as a valid file
/// (magic, version, length and checksum around them), so that the decoder
/// and the field checks behind the checksum are reached. Accepted models
/// generate finite output.
pub fn model(data: &[u8]) {
    let _ = cpg_reservoir::TrainedCpg::from_bytes(data, Path::new("fuzz.cpg"));
    let framed = cpg_reservoir::TrainedCpg::frame_payload(data);
    let Ok(m) = cpg_reservoir::TrainedCpg::from_bytes(&framed, Path::new("fuzz.cpg")) else { return };
    // Accepted models are small enough to run: the fuzzer's inputs are at most a few kB.
    let controls: Vec<f64> =
        m.teachers.first().map(|t| t.controls.clone()).unwrap_or_else(|| vec![0.0; m.controls.len()]);
    let mut g = cpg_reservoir::Generator::new(&m);
    for _ in 0..MODEL_STEPS {
        // A model whose weights make it diverge stops with an error; what it does output is finite.
        let Ok(y) = g.step(&controls) else { break };
        assert!(y.iter().all(|v| v.is_finite()), "non-finite output");
    }
    if let Some(text) = &m.skeleton_asf {
        asf(text.as_bytes());
    }
    let again = m.to_bytes().expect("an accepted model can be written");
    assert!(cpg_reservoir::TrainedCpg::from_bytes(&again, Path::new("again.cpg")).is_ok());
}

/// A control CSV for the inputs [`CONTROL_NAMES`]: rejected, or a schedule
/// of the right width whose every value is finite.
pub fn control_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let names: Vec<String> = CONTROL_NAMES.iter().map(|s| s.to_string()).collect();
    let Ok(s) = cpg_lab::ControlSchedule::parse_csv(text, Path::new("fuzz.csv"), &names) else { return };
    assert_eq!(s.width(), names.len());
    s.check(names.len()).expect("a parsed schedule passes its own check");
    let mut row = vec![0.0; names.len()];
    for step in [0, 1, 7, 1000] {
        s.fill(step, 120.0, &mut row);
        assert!(row.iter().all(|v| v.is_finite()), "step {step}: {row:?}");
    }
}

//! The project's HOAP-2 URDF and channel map against the reference facts and real data.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::path::{Path, PathBuf};

use cpg_hoap2::{ChannelMap, Error, Robot};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton};

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/hoap2").join(name)
}

/// Limits in degrees as shared/reference/hoap2-joints.md lists them.
const LIMITS_DEG: [(&str, f64, f64); 25] = [
    ("body_joint_1", -1.0, 90.0),
    ("lleg_joint_1", -31.0, 91.0),
    ("lleg_joint_3", -82.0, 71.0),
    ("lleg_joint_2", -21.0, 31.0),
    ("lleg_joint_4", -1.0, 130.0),
    ("lleg_joint_5", -61.0, 61.0),
    ("lleg_joint_6", -25.0, 25.0),
    ("rleg_joint_1", -91.0, 31.0),
    ("rleg_joint_3", -82.0, 71.0),
    ("rleg_joint_2", -31.0, 21.0),
    ("rleg_joint_4", -1.0, 130.0),
    ("rleg_joint_5", -61.0, 61.0),
    ("rleg_joint_6", -25.0, 25.0),
    ("larm_joint_1", -91.0, 151.0),
    ("larm_joint_2", -1.0, 96.0),
    ("larm_joint_3", -91.0, 91.0),
    ("larm_joint_4", -115.0, 1.0),
    ("larm_joint_5", -60.0, 60.0),
    ("rarm_joint_1", -91.0, 151.0),
    ("rarm_joint_2", -96.0, 1.0),
    ("rarm_joint_3", -91.0, 91.0),
    ("rarm_joint_4", -115.0, 1.0),
    ("rarm_joint_5", -60.0, 60.0),
    ("head_joint_1", -60.0, 60.0),
    ("head_joint_2", -15.0, 60.0),
];

fn robot() -> Robot {
    Robot::from_urdf_file(&asset("hoap2.urdf")).unwrap()
}

#[test]
fn urdf_has_the_25_joints_with_the_documented_limits() {
    let r = robot();
    assert_eq!(r.name, "hoap2");
    assert_eq!(r.joints.len(), 25);
    for (name, lo, hi) in LIMITS_DEG {
        let j = r.joint(name).unwrap();
        // The reference rounds degrees to whole numbers; radians are given to 5–6 digits.
        assert!((j.lower_rad.to_degrees() - lo).abs() < 0.03, "{name} lower {}", j.lower_rad.to_degrees());
        assert!((j.upper_rad.to_degrees() - hi).abs() < 0.03, "{name} upper {}", j.upper_rad.to_degrees());
        assert_eq!(j.velocity_rad_s, 5.0);
    }
    // Geometry: thigh and shank 0.1 m, elbow 0.101 m from the shoulder, legs nested 1 → 3 → 2 → 4.
    assert_eq!(r.joint("lleg_joint_4").unwrap().origin_m, [0.0, 0.0, -0.1]);
    assert_eq!(r.joint("larm_joint_4").unwrap().origin_m, [0.101, 0.0, 0.0]);
    assert_eq!(r.joint("lleg_joint_2").unwrap().parent, r.joint("lleg_joint_3").unwrap().child);
    assert_eq!(r.joint("body_joint_1").unwrap().axis, [0.0, -1.0, 0.0]);
    // Total mass: the Webots model's ≈ 7.16 kg (with a 0.02 kg sole sensor on each foot).
    assert!((r.mass_kg - 7.16).abs() < 0.005, "mass {}", r.mass_kg);
}

#[test]
fn map_covers_22_arm_and_leg_joints_of_the_robot() {
    let r = robot();
    let m = ChannelMap::load(&asset("cmu35_to_hoap2.tsv")).unwrap();
    assert_eq!(m.entries.len(), 22);
    for e in &m.entries {
        r.joint(&e.joint).unwrap();
        assert!(e.joint.contains("leg") || e.joint.contains("arm"), "{}", e.joint);
    }
}

#[test]
fn walking_trial_maps_within_limits_with_a_clamp_report() {
    let r = robot();
    let m = ChannelMap::load(&asset("cmu35_to_hoap2.tsv")).unwrap();
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let motion = Motion::from_amc_file(find(Subject::S35, "35_01.amc").unwrap(), &sk, 120.0).unwrap();
    let t = m.apply(&r, &motion.channel_names(), motion.values(), 120.0).unwrap();
    assert_eq!(t.n_frames(), 358);
    assert_eq!(t.joints.len(), 22);
    for (k, name) in t.joints.iter().enumerate() {
        let j = r.joint(name).unwrap();
        for f in 0..t.n_frames() {
            let q = t.values_rad[f * 22 + k];
            assert!(q >= j.lower_rad && q <= j.upper_rad, "{name} frame {f}: {q}");
        }
    }
    // Sagittal joints of a walk stay inside HOAP-2's range: no clamping there.
    for name in ["lleg_joint_3", "lleg_joint_4", "rleg_joint_3", "rleg_joint_4", "larm_joint_4"] {
        let c = t.clamps.joints.iter().find(|c| c.joint == *name).unwrap();
        assert_eq!(c.n_clamped, 0, "{c:?}");
    }
    // Knee flexion 11…71° on 35_01 (reference table) → radians.
    let knee = t.clamps.joints.iter().find(|c| c.joint == "lleg_joint_4").unwrap();
    assert!(
        (knee.min_rad.to_degrees() - 11.0).abs() < 2.0 && (knee.max_rad.to_degrees() - 71.0).abs() < 2.0,
        "{knee:?}"
    );
    // Resampled to 1 kHz: same span, endpoints kept.
    let k = t.resample(1000.0).unwrap();
    assert_eq!(k.n_frames(), (357.0 / 120.0 * 1000.0f64).floor() as usize + 1);
    assert_eq!(&k.values_rad[..22], &t.values_rad[..22]);
    let csv = k.to_csv();
    let header = csv.lines().next().unwrap();
    assert!(header.starts_with("time_s,lleg_joint_1_rad,"));
    assert_eq!(header.split(',').count(), 23);
    assert_eq!(csv.lines().count(), 1 + k.n_frames());
}

#[test]
fn bad_map_files_and_inputs_are_located_errors() {
    let head = "joint\tchannel\tsign\toffset_deg\tnote\n";
    let e = ChannelMap::parse(&format!("{head}lleg_joint_1\tlfemur.ry\t2\t0\tx\n"), "m.tsv").unwrap_err();
    assert_eq!(e.to_string(), "m.tsv:2: sign '2': expected 1 or -1");
    let e = ChannelMap::parse(&format!("# c\n{head}a\tb\t1\tNaN\n"), "m.tsv").unwrap_err();
    assert!(matches!(e, Error::Map { line: 3, .. }), "{e}");
    let e = ChannelMap::parse("a\tb\t1\t0\n", "m.tsv").unwrap_err();
    assert!(e.to_string().contains("header"), "{e}");
    let e = ChannelMap::parse(&format!("{head}a\tb\t1\t0\na\tc\t1\t0\n"), "m.tsv").unwrap_err();
    assert!(e.to_string().contains("mapped twice"), "{e}");
    let r = robot();
    let m = ChannelMap::parse(&format!("{head}no_such_joint\tx.rx\t1\t0\n"), "m.tsv").unwrap();
    assert!(matches!(m.apply(&r, &["x.rx".into()], &[1.0], 120.0), Err(Error::UnknownJoint { .. })));
    let m = ChannelMap::parse(&format!("{head}lleg_joint_1\tx.rx\t1\t0\n"), "m.tsv").unwrap();
    assert!(matches!(m.apply(&r, &["y.rx".into()], &[1.0], 120.0), Err(Error::MissingChannel { .. })));
    assert!(matches!(m.apply(&r, &["x.rx".into()], &[f64::NAN], 120.0), Err(Error::Input(_))));
    assert!(matches!(Robot::from_urdf_str("<robot", Path::new("x.urdf")), Err(Error::Urdf { .. })));
}

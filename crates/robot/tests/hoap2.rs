//! The project's HOAP-2 URDF and channel map against the reference facts and real data.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::path::{Path, PathBuf};

use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton};
use cpg_robot::{ChannelMap, Error, JointTrajectory, Robot};

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
    // Resampled to 1 kHz for the trial's 358 / 120 s: exactly that many rows, the knots kept.
    let n_out = JointTrajectory::check_rate(1000.0, 358.0 / 120.0, 22).unwrap();
    assert_eq!(n_out, 2983);
    let k = t.resample(&r, 1000.0, n_out).unwrap();
    assert_eq!(k.n_frames(), 2983);
    assert_eq!(&k.values_rad[..22], &t.values_rad[..22]);
    let frame_at = |f120: usize| &k.values_rad[f120 * 25 / 3 * 22..][..22];
    for (a, b) in frame_at(3).iter().zip(&t.values_rad[3 * 22..4 * 22]) {
        assert!((a - b).abs() < 1e-9, "knot kept");
    }
    // Smooth: from one millisecond to the next the spline's acceleration changes by a
    // tenth or less of what linear interpolation gives at a knot (its velocity jumps there,
    // by Δ²q·120 rad/s within one 1-ms step).
    let knee = k.joints.iter().position(|j| j == "lleg_joint_4").unwrap();
    let acc: Vec<f64> = k.accelerations_rad_s2.iter().skip(knee).step_by(22).copied().collect();
    let jump = acc.windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    let q: Vec<f64> = t.values_rad.iter().skip(knee).step_by(22).copied().collect();
    let linear = q.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs() * 120.0 * 1000.0).fold(0.0, f64::max);
    assert!(jump < linear / 10.0, "knee: the spline's acceleration steps by {jump} rad/s², linear's by {linear}");
    // Limited: every joint within position, velocity (the URDF's 5 rad/s) and the stated acceleration bound.
    let l = k.limit(&r, cpg_robot::DEFAULT_ACCELERATION_RAD_S2).unwrap();
    for (j, name) in l.joints.iter().enumerate() {
        let joint = r.joint(name).unwrap();
        for f in 0..l.n_frames() {
            let i = f * 22 + j;
            assert!((joint.lower_rad..=joint.upper_rad).contains(&l.values_rad[i]), "{name}");
            assert!(l.velocities_rad_s[i].abs() <= joint.velocity_rad_s + 1e-9, "{name} frame {f}");
            assert!(
                l.accelerations_rad_s2[i].abs() <= cpg_robot::DEFAULT_ACCELERATION_RAD_S2 + 1e-6,
                "{name} frame {f}: {:?}",
                (f.saturating_sub(3)..f + 2)
                    .map(|g| (
                        k.values_rad[g * 22 + j],
                        l.values_rad[g * 22 + j],
                        l.velocities_rad_s[g * 22 + j],
                        l.accelerations_rad_s2[g * 22 + j]
                    ))
                    .collect::<Vec<_>>()
            );
        }
    }
    let c = &l.clamps.joints[knee];
    assert!(c.max_velocity_rad_s > 1.0 && c.max_acceleration_rad_s2 > 1.0, "what was asked is reported: {c:?}");
    let csv = l.to_csv();
    let header = csv.lines().next().unwrap();
    assert!(header.starts_with("time_s,lleg_joint_1_rad,"));
    assert!(header.contains(",lleg_joint_1_rad_s,") && header.ends_with("_rad_s2"));
    assert_eq!(header.split(',').count(), 1 + 3 * 22);
    assert_eq!(csv.lines().count(), 1 + l.n_frames());
    // The ROS message shapes.
    let json = l.to_ros_json();
    assert!(
        json.contains("\"joint_names\": [\"lleg_joint_1\"")
            && json.contains("\"time_from_start\": {\"sec\": 2, \"nanosec\": 982000000}")
    );
    assert_eq!(json.matches("\"positions\"").count(), 2983);
    let yaml = l.to_ros_yaml();
    assert!(
        yaml.starts_with("joint_names:\n- lleg_joint_1\n")
            && yaml.contains("  time_from_start:\n    sec: 0\n    nanosec: 1000000\n")
    );
}

/// A frame at a time, without allocating: the same angles as the whole-trajectory mapping.
#[test]
fn a_plan_maps_one_frame_as_apply_does() {
    let r = robot();
    let m = ChannelMap::load(&asset("cmu35_to_hoap2.tsv")).unwrap();
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let motion = Motion::from_amc_file(find(Subject::S35, "35_01.amc").unwrap(), &sk, 120.0).unwrap();
    let names = motion.channel_names();
    let t = m.apply(&r, &names, motion.values(), 120.0).unwrap();
    let plan = m.plan(&r, &names).unwrap();
    let mut out = vec![0.0; 22];
    let d = names.len();
    plan.frame(&motion.values()[10 * d..11 * d], &mut out);
    for (j, (q, joint)) in out.iter().zip(&plan.joints).enumerate() {
        assert_eq!(q.clamp(joint.lower_rad, joint.upper_rad), t.values_rad[10 * 22 + j]);
    }
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

/// A URDF nested 20,000 elements deep once overflowed the stack (the XML
/// parser recurses); the nesting is bounded before it parses, and comments,
/// CDATA, quoted `>` and self-closing elements do not count as nesting.
#[test]
fn deeply_nested_urdf_is_an_error_naming_its_line_not_a_crash() {
    let n = 20_000;
    let deep = format!("<robot name=\"r\">\n{}{}</robot>", "<link name=\"a\">".repeat(n), "</link>".repeat(n));
    let e = Robot::from_urdf_str(&deep, Path::new("deep.urdf")).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, Error::Urdf { .. }) && text.contains("deep.urdf") && text.contains("line 2"), "{text}");
    assert!(text.contains("nested more than 64"), "{text}");
    // Just within the bound the scan lets the parser decide; flat elements are any number.
    let ok = format!(
        "<?xml version=\"1.0\"?><!-- <a><b> --><robot name=\"r\">{}<link name=\"x>y\"/><![CDATA[<<<]]>{}</robot>",
        "<link name=\"a\"/>".repeat(5000),
        ""
    );
    assert!(cpg_robot::check_nesting(&ok, 2).is_ok());
    let nested = format!("<robot>{}{}</robot>", "<a>".repeat(63), "</a>".repeat(63));
    assert!(cpg_robot::check_nesting(&nested, 64).is_ok());
    let nested = format!("<robot>{}{}</robot>", "<a>".repeat(64), "</a>".repeat(64));
    assert!(cpg_robot::check_nesting(&nested, 64).is_err());
    // The project's own URDF is well within it.
    Robot::from_urdf_file(&asset("hoap2.urdf")).unwrap();
}

/// Forward kinematics against the reference geometry, and the gait of the mapped 35_01 walk.
#[test]
fn kinematics_put_the_feet_where_the_reference_says_and_the_walk_alternates() {
    let r = robot();
    let none: Vec<String> = Vec::new();
    let poses = r.link_poses(&none, &[]).unwrap();
    let ankle = r.joints.iter().position(|j| j.name == "lleg_joint_6").unwrap();
    let sole = poses[ankle] * nalgebra::Point3::from(cpg_robot::RobotSpec::hoap2().feet.sole_in_ankle_m);
    // Zero pose: the hip 0.034 m behind, 0.039 m to the side of and 0.055 m below the trunk
    // origin, thigh and shank 0.1 m each, the sole 0.033 m below the ankle and 0.0112 m forward.
    assert!((sole.x - (-0.034 + 0.0112)).abs() < 1e-9 && (sole.y - 0.039).abs() < 1e-9, "{sole}");
    assert!((sole.z - (-0.055 - 0.2 - 0.033)).abs() < 1e-9, "{sole}");
    // Knee flexed 90° (with the hip straight): the ankle comes up to knee height and moves back.
    let names = vec!["lleg_joint_4".to_owned()];
    let p = r.link_poses(&names, &[std::f64::consts::FRAC_PI_2]).unwrap()[ankle].translation.vector;
    assert!((p.z - (-0.155)).abs() < 1e-9 && (p.x - (-0.134)).abs() < 1e-9, "{p}");

    let m = ChannelMap::load(&asset("cmu35_to_hoap2.tsv")).unwrap();
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let motion = Motion::from_amc_file(find(Subject::S35, "35_01.amc").unwrap(), &sk, 120.0).unwrap();
    let t = m.apply(&r, &motion.channel_names(), motion.values(), 120.0).unwrap();
    let left = r.path(&t, "lleg_joint_6", cpg_robot::RobotSpec::hoap2().feet.sole_in_ankle_m).unwrap();
    let right = r.path(&t, "rleg_joint_6", cpg_robot::RobotSpec::hoap2().feet.sole_in_ankle_m).unwrap();
    let g = cpg_robot::gait(&left, &right, 120.0, 0, 2).unwrap();
    // 35_01's stride is about 135 frames (1.12 s), the legs in antiphase.
    assert!((g.period_s - 1.12).abs() < 0.1, "{g:?}");
    assert!((g.left_right_phase - 0.5).abs() < 0.1, "{g:?}");
    assert!(g.excursion_m > 0.03 && g.lift_m > 0.005, "{g:?}");
}

/// A periodic trajectory limited as a loop starts in the state it ends in:
/// played again and again, it has no seam larger than a step within it.
#[test]
fn a_loop_limited_as_a_loop_repeats_without_a_seam() {
    let r = robot();
    let joints = vec!["lleg_joint_4".to_owned(), "lleg_joint_5".to_owned()];
    let n = 1000;
    // 1 Hz at 1 kHz: the ankle asks for 8 rad/s at its fastest, beyond the 5 rad/s limit.
    let w = 2.0 * std::f64::consts::PI;
    let (mut q, mut v, mut a) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..n {
        let t = k as f64 / 1000.0;
        for (amp, mid) in [(0.5, 0.7), (1.3, 0.0)] {
            q.push(mid + amp * (w * t).sin());
            v.push(amp * w * (w * t).cos());
            a.push(-amp * w * w * (w * t).sin());
        }
    }
    let clamps = cpg_robot::ClampReport {
        joints: joints
            .iter()
            .map(|j| cpg_robot::JointClamp { joint: j.clone(), n_frames: n, ..Default::default() })
            .collect(),
    };
    let t = JointTrajectory {
        joints,
        values_rad: q,
        velocities_rad_s: v,
        accelerations_rad_s2: a,
        rate_hz: 1000.0,
        clamps,
    };
    let l = t.limit_loop(&r, cpg_robot::DEFAULT_ACCELERATION_RAD_S2).unwrap();
    let d = 2;
    let step = l
        .values_rad
        .chunks_exact(d)
        .collect::<Vec<_>>()
        .windows(2)
        .fold(0.0f64, |m, w| w[0].iter().zip(w[1]).fold(m, |m, (x, y)| m.max((y - x).abs())));
    for j in 0..d {
        let seam = (l.values_rad[j] - l.values_rad[(n - 1) * d + j]).abs();
        assert!(seam <= step + 1e-12, "joint {j}: seam {seam} rad, largest step {step} rad");
        let vseam = (l.velocities_rad_s[j] - l.velocities_rad_s[(n - 1) * d + j]).abs();
        assert!(
            vseam <= cpg_robot::DEFAULT_ACCELERATION_RAD_S2 * 0.001 + 1e-9,
            "joint {j}: velocity jumps {vseam} rad/s"
        );
    }
    assert!(l.clamps.joints[1].n_velocity_limited > 0, "the ankle is held back by its speed limit");
}

/// A robot is a folder of data: the HOAP-2's folder copied under another
/// name with every leg and arm joint renamed (in its URDF and its
/// robot.toml) loads by its folder and plans the same walk, number for
/// number, under the new names; a robot read from its URDF alone cannot be
/// walked and says what it lacks.
#[test]
fn a_robot_is_a_folder_and_its_names_are_data() {
    use cpg_robot::physics::MassModel;
    use cpg_robot::walk::{WalkParams, plan};
    let dir = std::env::temp_dir().join(format!("cpg-robot-folder-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let rename = |t: &str| t.replace("lleg_joint_", "left_leg_").replace("rleg_joint_", "right_leg_");
    let urdf = rename(&std::fs::read_to_string(asset("hoap2.urdf")).unwrap());
    std::fs::write(dir.join("twin.urdf"), &urdf).unwrap();
    let spec = rename(&std::fs::read_to_string(asset("robot.toml")).unwrap())
        .replace("name = \"hoap2\"", "name = \"twin\"")
        .replace("urdf = \"hoap2.urdf\"", "urdf = \"twin.urdf\"");
    std::fs::write(dir.join("robot.toml"), spec).unwrap();
    let twin = Robot::from_spec(&dir).unwrap();
    let hoap2 = Robot::hoap2().unwrap();
    assert_eq!(twin.spec().unwrap().name, "twin");
    assert_eq!(twin.spec().unwrap().legs.left.knee, "left_leg_4");
    let p = WalkParams {
        stride_period_s: 1.1,
        double_support_share: 0.2,
        step_length_m: 0.03,
        foot_y_m: 0.039,
        lift_m: 0.02,
        lift_profile: vec![0.0, 1.0, 0.0],
        advance_profile: vec![0.0, 0.5, 1.0],
        trunk_height_m: 0.24,
        steps: 6,
        stand_s: 0.5,
        rate_hz: 200.0,
        preview_s: 1.0,
        arm_swing: Vec::new(),
    };
    let mass = |r: &Robot, text: &str| MassModel::from_urdf(r, text, Path::new("m.urdf")).unwrap();
    let a = plan(&hoap2, &mass(&hoap2, cpg_robot::assets::HOAP2_URDF), &p).unwrap();
    let b = plan(&twin, &mass(&twin, &urdf), &p).unwrap();
    assert_eq!(b.joints, a.joints.iter().map(|j| rename(j)).collect::<Vec<_>>());
    assert_eq!(a.q_rad, b.q_rad);
    assert_eq!(a.margin_m, b.margin_m);
    // The URDF alone: mapped onto, not walked.
    std::fs::remove_file(dir.join("robot.toml")).unwrap();
    let bare = Robot::from_urdf_file(&dir.join("twin.urdf")).unwrap();
    let e = plan(&bare, &mass(&bare, &urdf), &p).unwrap_err().to_string();
    assert!(e.contains("robot.toml"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

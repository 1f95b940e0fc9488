//! Every CMU file of the project parses, matches the manifest, and gives
//! physically sensible forward kinematics.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_mocap::data::{self, Subject};
use cpg_mocap::{Motion, Skeleton};
use cpg_tests::{CMU_RATE_HZ, cmu35, manifest, motion35, skeleton35};

/// Values of bone `bone` in the first and last frame, read straight from the text.
fn text_values(path: &std::path::Path, bone: &str) -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(path).unwrap();
    let vals: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some(bone))
        .map(|l| l.split_whitespace().skip(1).map(|t| t.parse().unwrap()).collect())
        .collect();
    (vals[0].clone(), vals[vals.len() - 1].clone())
}

#[test]
fn every_subject35_file_parses_with_manifest_frame_counts() {
    let sk = skeleton35();
    assert_eq!(sk.bones.len(), 30);
    let entries = manifest(Subject::S35);
    let amcs: Vec<_> = entries.iter().filter(|e| e.file.ends_with(".amc")).collect();
    assert_eq!(amcs.len(), 28, "manifest lists 19 complete and 9 partial trials");
    for e in amcs {
        let path = cmu35(&e.file);
        let m = Motion::from_amc_file(&path, &sk, CMU_RATE_HZ).unwrap_or_else(|err| panic!("{err}"));
        assert_eq!(Some(m.n_frames()), e.frames, "{}", e.file);
        assert_eq!(m.n_channels(), 62, "{}", e.file);
        for bone in ["root", "lfemur", "rhumerus", "ltoes"] {
            let (first, last) = text_values(&path, bone);
            let dofs = sk.dofs_of(bone).unwrap();
            for (k, d) in dofs.iter().enumerate() {
                let name = format!("{bone}.{}", d.as_str());
                let col = m.column(&name).unwrap();
                assert_eq!(col[0], first[k], "{} first frame {name}", e.file);
                assert_eq!(col[col.len() - 1], last[k], "{} last frame {name}", e.file);
            }
        }
    }
}

#[test]
fn subject86_skeleton_parses() {
    let path = data::find(Subject::S86, "86.asf").unwrap_or_else(|e| panic!("{e}"));
    let sk = Skeleton::from_file(path).unwrap();
    assert_eq!(sk.bones.len(), 30);
    assert_eq!(sk.root.order.len(), 6);
    let dofs: usize = sk.bones.iter().map(|b| b.dofs.len()).sum::<usize>() + sk.root.order.len();
    assert_eq!(dofs, 62);
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Bone lengths hold, the root follows its translation channels.
fn check_rigid(sk: &Skeleton, m: &Motion) {
    let p = sk.forward_kinematics(m).unwrap();
    assert_eq!(p.names.len(), 31);
    let scale = sk.mm_per_unit();
    let (tx, ty, tz) = (m.column("root.tx").unwrap(), m.column("root.ty").unwrap(), m.column("root.tz").unwrap());
    for f in 0..p.n_frames() {
        let pts = p.frame(f);
        let root = pts[0];
        for (k, want) in [tx[f], ty[f], tz[f]].iter().enumerate() {
            assert!((root[k] - want * scale).abs() < 1e-9, "frame {f}: root axis {k}");
        }
        for (b, bone) in sk.bones.iter().enumerate() {
            let start = bone.parent.map_or(root, |q| pts[q + 1]);
            let len = dist(start, pts[b + 1]);
            let want = bone.length * scale;
            assert!((len - want).abs() < 1e-9 * want.max(1.0), "frame {f}: bone {} length {len} vs {want}", bone.name);
        }
    }
}

#[test]
fn kinematics_is_rigid_on_walk_and_run() {
    let sk = skeleton35();
    for trial in ["35_01.amc", "35_17.amc"] {
        check_rigid(&sk, &motion35(&sk, trial));
    }
}

/// While walking, the lowest foot point touches the same floor every frame.
#[test]
fn walking_feet_stay_on_one_floor() {
    let sk = skeleton35();
    let m = motion35(&sk, "35_01.amc");
    let p = sk.forward_kinematics(&m).unwrap();
    let feet: Vec<usize> = ["lfoot", "ltoes", "rfoot", "rtoes"].iter().map(|n| p.point_index(n).unwrap()).collect();
    let lowest: Vec<f64> =
        (0..p.n_frames()).map(|f| feet.iter().map(|&k| p.frame(f)[k][1]).fold(f64::INFINITY, f64::min)).collect();
    let lo = lowest.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = lowest.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    // The root travels almost 4 m. Heel-to-toe roll moves the lowest of these
    // points by a few centimetres (47 mm measured); the transposed convention
    // `C⁻¹·M·C` lifts and tilts the feet and gives 95 mm on the same trial.
    let travel = dist(p.frame(0)[0], p.frame(p.n_frames() - 1)[0]);
    eprintln!("floor spread {:.1} mm over {:.0} mm of travel", hi - lo, travel);
    assert!(travel > 2000.0, "travel {travel}");
    assert!(hi - lo < 60.0, "lowest foot point varies by {:.1} mm", hi - lo);
}

/// AMC → BVH → forward kinematics gives the AMC's own marker positions, to
/// 1e-6 of the skeleton's length unit, for every frame of a real trial; the
/// BVH's skeleton also survives an ASF round trip.
#[test]
fn amc_to_bvh_keeps_every_marker_of_35_01() {
    let sk = skeleton35();
    let m = motion35(&sk, "35_01.amc");
    let text = cpg_mocap::write_bvh(&sk, &m).unwrap();
    let bvh = cpg_mocap::parse_bvh("35_01.bvh", text.as_bytes(), &cpg_mocap::BvhOptions::default()).unwrap();
    assert!(bvh.unit_inferred && bvh.length_unit_mm == 10.0, "written in centimetres: {}", bvh.length_unit_mm);
    assert_eq!(bvh.motion.n_frames(), m.n_frames());
    assert_eq!(bvh.motion.sample_rate_hz(), CMU_RATE_HZ);
    let a = sk.forward_kinematics(&m).unwrap();
    let b = bvh.skeleton.forward_kinematics(&bvh.motion).unwrap();
    // An ASF bone ends where the BVH joint of its first child starts, or at its own End Site.
    let point = |k: usize| -> usize {
        let kids: Vec<&str> = sk.bones.iter().filter(|c| c.parent == Some(k)).map(|c| c.name.as_str()).collect();
        let name =
            if kids.len() > 1 { format!("{}_to_{}", sk.bones[k].name, kids[0]) } else { sk.bones[k].name.clone() };
        b.point_index(&name).unwrap_or_else(|| panic!("no BVH point {name}"))
    };
    let pairs: Vec<(usize, usize)> = std::iter::once((0, b.point_index("root").unwrap()))
        .chain((0..sk.bones.len()).map(|k| (k + 1, point(k))))
        .collect();
    let mut worst = 0.0f64;
    for f in 0..a.n_frames() {
        for &(i, j) in &pairs {
            let d = (0..3).map(|c| (a.frame(f)[i][c] - b.frame(f)[j][c]).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(d);
        }
    }
    let unit_mm = sk.mm_per_unit();
    assert!(
        worst < 1e-6 * unit_mm,
        "largest marker difference {worst:e} mm, 1e-6 of the unit is {:e} mm",
        1e-6 * unit_mm
    );
    let again = cpg_mocap::parse_asf("again.asf", cpg_mocap::write_asf(&bvh.skeleton).as_bytes()).unwrap();
    assert_eq!(again, bvh.skeleton);
}

/// The retargeted walk (`cpg retarget`): the human's timing measured on
/// 35_01–35_06, a robot walk whose multi-body ZMP stays inside the soles,
/// within every joint's position and speed limits, keeping the human's
/// joint cycles' shapes.
#[test]
fn the_retargeted_walk_balances_within_the_limits_and_keeps_the_style() {
    use cpg_lab::retarget::{RetargetOptions, human_walk, retarget};
    use cpg_robot::Robot;
    use cpg_robot::physics::MassModel;
    use cpg_robot::walk::Support;
    let sk = skeleton35();
    let profile = cpg_mocap::profile::Profile::for_skeleton(&sk, None).unwrap();
    assert_eq!(profile.profile, "cmu-asf");
    let trials: Vec<_> = (1..=6)
        .map(|i| (sk.forward_kinematics(&motion35(&sk, &format!("35_0{i}.amc"))).unwrap(), profile.clone()))
        .collect();
    let human = human_walk(&trials).unwrap();
    // Subject 35 walks a stride in about 1.1 s, a foot on the ground a little over half of it.
    assert!(human.strides >= 6, "{human:?}");
    assert!((1.0..1.3).contains(&human.stride_period_s), "{human:?}");
    assert!((0.5..0.7).contains(&human.duty_factor), "{human:?}");
    assert!((0.8..1.0).contains(&human.leg_length_m) && (1.1..1.7).contains(&human.stride_length_m), "{human:?}");
    let robot = Robot::hoap2().unwrap();
    let mass = MassModel::from_urdf(&robot, cpg_robot::assets::HOAP2_URDF, std::path::Path::new("hoap2.urdf")).unwrap();
    let (params, plan, style) = retarget(&human, &robot, &mass, &RetargetOptions::default()).unwrap();
    assert!((params.stride_period_s - human.stride_period_s).abs() < 1e-12, "the human's tempo is kept");
    assert!(plan.ik_residual_m < 1e-6, "IK residual {} m", plan.ik_residual_m);
    let n = plan.n_frames();
    let d = plan.joints.len();
    for (k, j) in robot.joints.iter().enumerate() {
        for f in 0..n {
            let q = plan.q_rad[f * d + k];
            assert!(q >= j.lower_rad - 1e-9 && q <= j.upper_rad + 1e-9, "{} at {q} rad in frame {f}", j.name);
            if f > 0 {
                let v = (q - plan.q_rad[(f - 1) * d + k]).abs() * plan.rate_hz;
                assert!(v <= j.velocity_rad_s, "{} at {v} rad/s in frame {f}", j.name);
            }
        }
    }
    // The multi-body ZMP, with the links' accelerations, inside the sole(s) that carry the body.
    let worst = plan.margin_m.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(worst > 0.0, "the ZMP leaves the support polygon by {:.1} mm", -1e3 * worst);
    let single: Vec<f64> = (0..n).filter(|&f| plan.support[f] != Support::Double).map(|f| plan.margin_m[f]).collect();
    assert!(!single.is_empty() && single.iter().all(|m| *m > 0.01), "under 1 cm of margin in single support");
    // The stance foot flat and on the floor; the feet never cross.
    for f in 0..n {
        let [l, r] = plan.ankles_m[f];
        assert!(l[1] - r[1] > 0.07, "frame {f}: the feet are {} m apart", l[1] - r[1]);
        match plan.support[f] {
            Support::Left => assert!((l[2] - robot.spec().unwrap().feet.ankle_height_m).abs() < 1e-12),
            Support::Right => assert!((r[2] - robot.spec().unwrap().feet.ankle_height_m).abs() < 1e-12),
            Support::Double => {}
        }
    }
    // Style: the hips, knees and arms follow the human's cycle (correlation at the best phase).
    for s in &style {
        let floor = if s.human.starts_with("ankle") { 0.4 } else { 0.85 };
        assert!(s.shifted.0 > floor, "{s:?}");
    }
}

/// Another person: CMU subject 07's walk in the common BVH conversion (bones
/// `LeftUpLeg`, `LeftLeg`, …) is measured through the built-in `cmu-bvh`
/// profile; the same file with every bone renamed is refused without a
/// profile (naming what it looked for) and measured identically with a
/// profile file naming the new bones.
#[test]
fn another_persons_bvh_walk_is_measured_through_its_skeleton_profile() {
    use cpg_lab::retarget::human_walk;
    use cpg_mocap::profile::Profile;
    let path = data::find(Subject::OtherBvh, "07_06.bvh").unwrap_or_else(|e| panic!("{e}"));
    let read = |text: &str| {
        let b = cpg_mocap::parse_bvh("07_06.bvh", text.as_bytes(), &cpg_mocap::BvhOptions::default()).unwrap();
        (b.skeleton.forward_kinematics(&b.motion).unwrap(), b.skeleton)
    };
    let text = std::fs::read_to_string(&path).unwrap();
    let (pos, sk) = read(&text);
    let points = Profile::for_skeleton(&sk, None).unwrap();
    assert_eq!(points.profile, "cmu-bvh");
    let human = human_walk(&[(pos, points)]).unwrap();
    // Subject 07 walks a stride of about 138 frames at 120 Hz (the data's README), feet on the ground over half of it.
    assert!(human.strides >= 2, "{human:?}");
    assert!((1.0..1.35).contains(&human.stride_period_s), "{human:?}");
    assert!((0.5..0.75).contains(&human.duty_factor), "{human:?}");
    assert!((0.7..1.1).contains(&human.leg_length_m), "{human:?}");

    // The same motion, its bones named otherwise.
    let renamed = ["LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "LeftArm", "LeftForeArm", "LeftHand"]
        .iter()
        .fold(text.clone(), |t, b| {
            let n = format!("L_{}", &b[4..]);
            t.replace(&format!("JOINT {b}\r"), &format!("JOINT {n}\r"))
                .replace(&format!("JOINT {b}\n"), &format!("JOINT {n}\n"))
        })
        .replace("JOINT Neck\r", "JOINT Collar\r")
        .replace("JOINT Neck\n", "JOINT Collar\n");
    assert_ne!(renamed, text);
    let (pos2, sk2) = read(&renamed);
    let e = Profile::for_skeleton(&sk2, None).unwrap_err().to_string();
    assert!(e.contains("profile 'cmu-bvh': chest = 'Neck'") && e.contains("profile file"), "{e}");
    let file = "name = \"renamed\"\npelvis = \"root\"\nchest = \"Collar\"\n[left]\nhip = \"L_UpLeg\"\nknee = \"L_Leg\"\nankle = \"L_Foot\"\ntoes = \"L_ToeBase\"\nshoulder = \"L_Arm\"\nelbow = \"L_ForeArm\"\nwrist = \"L_Hand\"\n[right]\nhip = \"RightUpLeg\"\nknee = \"RightLeg\"\nankle = \"RightFoot\"\ntoes = \"RightToeBase\"\nshoulder = \"RightArm\"\nelbow = \"RightForeArm\"\nwrist = \"RightHand\"\n";
    let profile = Profile::parse("renamed.toml", file).unwrap();
    let points2 = Profile::for_skeleton(&sk2, Some(&profile)).unwrap();
    assert_eq!(human_walk(&[(pos2, points2)]).unwrap(), human);
    // A profile naming a bone the skeleton lacks says which and what is near.
    let wrong = Profile::parse("wrong.toml", &file.replace("L_Leg\"", "L_Lge\"")).unwrap();
    let e = Profile::for_skeleton(&sk2, Some(&wrong)).unwrap_err().to_string();
    assert!(e.contains("left.knee = 'L_Lge'") && e.contains("L_Leg"), "{e}");
}

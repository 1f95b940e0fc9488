//! BVH: written BVH reads back to the same marker positions, any channel
//! order is read as the file says, units are inferred or given, and bad files
//! fail at their file, line and column.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_mocap::ParseErrorKind as K;
use cpg_mocap::{Bvh, BvhOptions, Channel, Motion, Skeleton, parse_asf, parse_bvh, write_asf, write_bvh};
use proptest::prelude::*;

const ASF: &str = include_str!("../test_data/tiny.asf");

fn tiny() -> Skeleton {
    parse_asf("tiny.asf", ASF.as_bytes()).unwrap()
}

/// The BVH point that sits where an ASF bone ends: the bone's own name, or,
/// for a bone with several children, the link to its first child.
fn point_for(sk: &Skeleton, bone: usize, bvh: &cpg_mocap::Positions) -> usize {
    let b = &sk.bones[bone];
    let kids: Vec<&str> = sk.bones.iter().filter(|c| c.parent == Some(bone)).map(|c| c.name.as_str()).collect();
    let name = if kids.len() > 1 { format!("{}_to_{}", b.name, kids[0]) } else { b.name.clone() };
    bvh.point_index(&name).unwrap_or_else(|| panic!("no point {name} in {:?}", bvh.names))
}

/// Largest distance between the ASF points and the BVH points, in mm.
fn worst_mm(sk: &Skeleton, motion: &Motion, bvh: &Bvh) -> f64 {
    let a = sk.forward_kinematics(&sk.complete(motion).unwrap()).unwrap();
    let b = bvh.skeleton.forward_kinematics(&bvh.motion).unwrap();
    assert_eq!(a.n_frames(), b.n_frames());
    let mut worst = 0.0f64;
    for f in 0..a.n_frames() {
        let (pa, pb) = (a.frame(f), b.frame(f));
        let mut pairs = vec![(0usize, b.point_index("root").unwrap())];
        pairs.extend((0..sk.bones.len()).map(|k| (k + 1, point_for(sk, k, &b))));
        for (i, j) in pairs {
            let d = (0..3).map(|c| (pa[i][c] - pb[j][c]).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(d);
        }
    }
    worst
}

fn motion_on(sk: &Skeleton, rows: &[Vec<f64>]) -> Motion {
    let ch = sk.all_channels();
    Motion::new(ch, rows.concat(), 120.0).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any pose of the test skeleton (root anywhere, every angle up to a full
    /// turn) survives the trip through BVH to within 1e-6 of its length unit.
    #[test]
    fn written_bvh_has_the_same_marker_positions(rows in prop::collection::vec(prop::collection::vec(-360.0..360.0f64, 10), 1..6)) {
        let sk = tiny();
        let m = motion_on(&sk, &rows);
        let text = write_bvh(&sk, &m).unwrap();
        let bvh = parse_bvh("w.bvh", text.as_bytes(), &BvhOptions { length_unit_mm: Some(10.0) }).unwrap();
        let worst = worst_mm(&sk, &m, &bvh);
        prop_assert!(worst < 1e-6 * sk.mm_per_unit(), "{worst} mm");
    }
}

#[test]
fn the_channel_order_of_each_joint_is_the_files() {
    // One arm segment of 10 cm along +x under a joint whose channels are X, then Z, then Y:
    // R = Rx(a)·Rz(b)·Ry(c), the first listed outermost.
    let text = "HIERARCHY\nROOT hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation\n JOINT arm\n {\n  OFFSET 0 100 0\n  CHANNELS 3 Xrotation Zrotation Yrotation\n  End Site\n  {\n   OFFSET 10 0 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0 0 0 0 30 40 50\n";
    let bvh = parse_bvh("order.bvh", text.as_bytes(), &BvhOptions { length_unit_mm: Some(10.0) }).unwrap();
    let p = bvh.skeleton.forward_kinematics(&bvh.motion).unwrap();
    let tip = p.frame(0)[p.point_index("arm").unwrap()];
    // Rx(30)·Rz(40)·Ry(50)·(100, 0, 0) mm, by hand.
    let (a, b, c) = (30f64.to_radians(), 40f64.to_radians(), 50f64.to_radians());
    let v = [100.0 * c.cos(), 0.0, -100.0 * c.sin()]; // Ry
    let v = [v[0] * b.cos() - v[1] * b.sin(), v[0] * b.sin() + v[1] * b.cos(), v[2]]; // Rz
    let v = [v[0], v[1] * a.cos() - v[2] * a.sin(), v[1] * a.sin() + v[2] * a.cos()]; // Rx
    let want = [v[0], 1000.0 + v[1], v[2]];
    for k in 0..3 {
        assert!((tip[k] - want[k]).abs() < 1e-9, "{tip:?} vs {want:?}");
    }
    assert_eq!(bvh.motion.n_frames(), 1);
    assert_eq!(bvh.motion.sample_rate_hz(), 100.0);
    let names: Vec<String> = bvh.motion.channels().iter().map(Channel::to_string).collect();
    assert_eq!(names, ["root.tx", "root.ty", "root.tz", "root.ry", "root.rx", "root.rz", "arm.rx", "arm.rz", "arm.ry"]);
}

/// A hierarchy as the public CMU conversions write it: renamed joints, ZYX
/// channels, several children with zero offsets, and one with an offset.
const CMU_LIKE: &str = "HIERARCHY\r\nROOT Hips\r\n{\r\n\tOFFSET 0.00000 0.00000 0.00000\r\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation \r\n\tJOINT LHipJoint\r\n\t{\r\n\t\tOFFSET 0 0 0\r\n\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\tJOINT LeftUpLeg\r\n\t\t{\r\n\t\t\tOFFSET 1.77779 -1.88989 0.48267\r\n\t\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\t\tEnd Site\r\n\t\t\t{\r\n\t\t\t\tOFFSET 2.53442 -6.96327 0.00000\r\n\t\t\t}\r\n\t\t}\r\n\t}\r\n\tJOINT LowerBack\r\n\t{\r\n\t\tOFFSET 0 0 0\r\n\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\tJOINT Spine\r\n\t\t{\r\n\t\t\tOFFSET 0.03410 2.01612 -0.22230\r\n\t\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\t\tJOINT Head\r\n\t\t\t{\r\n\t\t\t\tOFFSET 0 9 0\r\n\t\t\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\t\t\tEnd Site\r\n\t\t\t\t{\r\n\t\t\t\t\tOFFSET 0 1.7 0\r\n\t\t\t\t}\r\n\t\t\t}\r\n\t\t\tJOINT LeftArm\r\n\t\t\t{\r\n\t\t\t\tOFFSET 3.36 1.0 -0.37\r\n\t\t\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\t\t\tEnd Site\r\n\t\t\t\t{\r\n\t\t\t\t\tOFFSET 5.06 0 0\r\n\t\t\t\t}\r\n\t\t\t}\r\n\t\t}\r\n\t}\r\n}\r\nMOTION\r\nFrames: 2\r\nFrame Time: .0083333\r\n0.6636 18.0401 -17.9943 0 0 0 0 0 0 -21 0 0 0 0 0 0 0 0 0 0 0 0 0 0\r\n0.6636 18.0401 -17.9943 -5.6589 -3.1659 -1.7935 0 0 0 -12.19 -6.58 -24.96 12.07 18.42 66.23 -0.008 -4.78 -3.06 0.1 -2.1 -5.8 30 0 0\r\n";

#[test]
fn a_cmu_conversion_reads_with_its_units_rate_and_names() {
    let bvh = parse_bvh("35_07.bvh", CMU_LIKE.as_bytes(), &BvhOptions::default()).unwrap();
    // About 26 units tall: CMU's ASF units (inches / 0.45).
    assert!(bvh.unit_inferred);
    assert!((bvh.length_unit_mm - 25.4 / 0.45).abs() < 1e-9, "{}", bvh.length_unit_mm);
    assert_eq!(bvh.motion.sample_rate_hz(), 120.0, "0.0083333 s is 120 Hz");
    assert_eq!(bvh.motion.n_frames(), 2);
    let ch = bvh.motion.channel_names();
    assert_eq!(ch.len(), 24);
    assert!(ch.contains(&"LeftUpLeg.rx".to_owned()) && ch.contains(&"root.tz".to_owned()), "{ch:?}");
    let names: Vec<&str> = bvh.skeleton.bones.iter().map(|b| b.name.as_str()).collect();
    // Spine has two children with offsets: a zero-length bone and two links.
    assert_eq!(
        names,
        ["LHipJoint", "LeftUpLeg", "LowerBack", "Spine", "Spine_to_Head", "Head", "Spine_to_LeftArm", "LeftArm"]
    );
    // In the rest pose (frame 1) the head's top is 1.7 units above the head: positions follow the offsets.
    let p = bvh.skeleton.forward_kinematics(&bvh.motion).unwrap();
    let f0 = p.frame(0);
    let (head, top) = (f0[p.point_index("Spine_to_Head").unwrap()], f0[p.point_index("Head").unwrap()]);
    assert!((top[1] - head[1] - 1.7 * bvh.length_unit_mm).abs() < 1e-9);
    // An ASF of the skeleton reads back to it.
    let again = parse_asf("again.asf", write_asf(&bvh.skeleton).as_bytes()).unwrap();
    assert_eq!(again, bvh.skeleton);
    // LF gives the same.
    let lf = parse_bvh("35_07.bvh", CMU_LIKE.replace("\r\n", "\n").as_bytes(), &BvhOptions::default()).unwrap();
    assert_eq!(lf, bvh);
}

#[test]
fn an_asf_written_out_reads_back_the_same() {
    let sk = tiny();
    let mut again = parse_asf("again.asf", write_asf(&sk).as_bytes()).unwrap();
    again.documentation = sk.documentation.clone();
    assert_eq!(again, sk);
}

fn err(text: &str) -> (K, usize, String) {
    match parse_bvh("bad.bvh", text.as_bytes(), &BvhOptions { length_unit_mm: Some(10.0) }) {
        Err(cpg_mocap::Error::Parse(e)) => (e.kind.clone(), e.line, e.to_string()),
        other => panic!("expected a parse error for:\n{text}\ngot {other:?}"),
    }
}

#[test]
fn malformed_bvh_fails_at_its_line_saying_what_was_expected() {
    let good = CMU_LIKE.replace("\r\n", "\n");
    let cases: Vec<(String, usize, &str)> = vec![
        (String::new(), 1, "empty"),
        (good.replace("HIERARCHY", "HIERARCHIE"), 1, "'HIERARCHY'"),
        (good.replace("Xposition Yposition", "Xposition Wposition"), 5, "Xposition, Yposition"),
        (good.replace("CHANNELS 6", "CHANNELS 60"), 5, "channel count from 0 to 6"),
        (
            good.replace(
                "CHANNELS 3 Zrotation Yrotation Xrotation\n\t\tJOINT LeftUpLeg",
                "CHANNELS 3 Zrotation Zrotation Xrotation\n\t\tJOINT LeftUpLeg",
            ),
            9,
            "each channel once",
        ),
        (
            good.replace(
                "CHANNELS 3 Zrotation Yrotation Xrotation\n\t\tJOINT LeftUpLeg",
                "CHANNELS 3 Xposition Yrotation Xrotation\n\t\tJOINT LeftUpLeg",
            ),
            9,
            "position channels are read on the root only",
        ),
        (good.replace("OFFSET 1.77779", "OFFSET nan"), 12, "not a finite number"),
        (good.replace("OFFSET 1.77779", "OFFSET 1e300"), 12, "out of range"),
        (good.replace("Frames: 2", "Frames: 3"), 54, "3 frames as 'Frames:' says; the file ends after 2"),
        (good.replace("Frames: 2", "Frames: 1"), 53, "the 1 frame(s) 'Frames:' declares"),
        (good.replace("Frames: 2", "Frames: 0"), 50, "frame count from 1"),
        (good.replace("Frame Time: .0083333", "Frame Time: 0"), 51, "frame time from"),
        (good.replace(" 30 0 0\n", " 30 0\n"), 53, "'frame 2' takes 24 values, found 23"),
        (good.replace(" 30 0 0\n", " 30 0 x\n"), 53, "'x' is not a number"),
        (good.replace("JOINT LowerBack", "JOINT LHipJoint"), 20, "defined twice"),
        (
            good.replace("\t\t\t\tOFFSET 5.06 0 0\n", "\t\t\t\tOFFSET 5.06 0 0\n\t\t\t\tJOINT x\n"),
            44,
            "an End Site has only an OFFSET",
        ),
        (good[..good.find("MOTION").unwrap()].to_owned(), 49, "'MOTION'"),
        (good[..300].to_owned(), 13, "found 'Xrot'"),
        (
            good[..good.find("\t\t\tEnd Site").unwrap()].to_owned(),
            14,
            "unexpected end of file; expected 'JOINT', 'End Site' or '}'",
        ),
    ];
    for (text, line, needle) in cases {
        let (_, l, msg) = err(&text);
        assert!(msg.contains(needle) && msg.starts_with("bad.bvh:"), "wanted '{needle}', got: {msg}");
        assert_eq!(l, line, "{msg}");
    }
    // Not UTF-8.
    let e = parse_bvh("bin.bvh", &[b'H', 0xff, 0xfe], &BvhOptions::default()).unwrap_err().to_string();
    assert!(e.contains("not UTF-8"), "{e}");
    // A size that matches no unit asks for one.
    let small = good
        .replace("OFFSET 0 9 0", "OFFSET 0 0 0")
        .replace("-6.96327", "-0.5")
        .replace("2.01612", "0.1")
        .replace("5.06 0 0", "0.5 0 0")
        .replace("3.36 1.0", "0.36 0.1")
        .replace("0 1.7 0", "0 0.1 0")
        .replace("-1.88989", "-0.1");
    let e = parse_bvh("small.bvh", small.as_bytes(), &BvhOptions::default()).unwrap_err().to_string();
    assert!(e.contains("matches no length unit") && e.contains("bvh_unit_mm"), "{e}");
}

#[test]
fn deep_or_huge_hierarchies_are_bounded() {
    // 20,000 nested joints: refused without recursion or unbounded work.
    let mut t = String::from("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n");
    for k in 0..20_000 {
        t.push_str(&format!("JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n"));
    }
    let (_, _, msg) = err(&t);
    assert!(msg.contains("at most 10000 joints"), "{msg}");
}

#[test]
fn a_written_bvh_of_a_grounded_motion_stands_on_the_floor() {
    let sk = tiny();
    let ch = vec![Channel::parse("femur.rx").unwrap()];
    let vals: Vec<f64> = (0..40).map(|k| 25.0 * (k as f64 / 6.0).sin()).collect();
    let m = sk.ground(&Motion::new(ch, vals, 120.0).unwrap()).unwrap();
    let bvh =
        parse_bvh("g.bvh", write_bvh(&sk, &m).unwrap().as_bytes(), &BvhOptions { length_unit_mm: Some(10.0) }).unwrap();
    let p = bvh.skeleton.forward_kinematics(&bvh.motion).unwrap();
    for f in 0..p.n_frames() {
        let low = p.frame(f).iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
        assert!(low.abs() < 1e-6, "frame {f}: lowest point {low} mm");
    }
}

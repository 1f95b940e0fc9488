//! The same training from BVH as from AMC: a subject-35 walk written as BVH
//! (world-aligned rotation channels, a T-pose frame first, as the public CMU
//! conversions have it) trains through the same configuration keys and gives
//! the period the AMC gives; configurations that mix or misname fail clearly.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::path::Path;

use cpg_lab::Config;
use cpg_tests::{cmu35, motion35, skeleton35};

/// A copy of experiments/e1.toml reading `motion` (and `skeleton`, when given),
/// learning `channel`, written into `dir`.
fn e1_config(dir: &Path, motion: &Path, skeleton: Option<&Path>, channel: &str, frames: Option<[usize; 2]>) -> Config {
    let base = std::fs::read_to_string(cpg_tests::workspace_root().join("experiments/e1.toml")).unwrap();
    let mut text = base
        .replace(
            "skeleton = \"../data/cmu35/35.asf\"\n",
            &skeleton.map_or(String::new(), |s| format!("skeleton = {:?}\n", s.display().to_string())),
        )
        .replace("motion = \"../data/cmu35/35_01.amc\"", &format!("motion = {:?}", motion.display().to_string()))
        .replace("channels = [\"lfemur.rx\"]", &format!("channels = [{channel:?}]"))
        .replace("model = \"../models/e1.cpg\"", "model = \"m.cpg\"");
    if let Some([a, b]) = frames {
        text = text.replace("label = \"walk (35_01)\"", &format!("label = \"walk (35_01)\"\nframes = [{a}, {b}]"));
    }
    let path = dir.join("c.toml");
    std::fs::write(&path, text).unwrap();
    Config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_bvh_walk_trains_with_the_period_of_its_amc() {
    let dir = tempfile::tempdir().unwrap();
    let sk = skeleton35();
    let m = motion35(&sk, "35_01.amc");
    // As the public conversions: a rest-pose frame first, then the trial.
    let rest = cpg_mocap::Motion::new(m.channels().to_vec(), vec![0.0; m.n_channels()], 120.0).unwrap();
    let bvh = dir.path().join("35_01.bvh");
    std::fs::write(&bvh, cpg_mocap::write_bvh(&sk, &rest.concat(&m).unwrap()).unwrap()).unwrap();

    let amc = e1_config(dir.path(), &cmu35("35_01.amc"), Some(&cmu35("35.asf")), "lfemur.rx", None);
    let from_bvh = e1_config(dir.path(), &bvh, None, "lfemur.rx", Some([1, m.n_frames() + 1]));
    let (pa, pb) = (cpg_lab::prepare::prepare(&amc).unwrap(), cpg_lab::prepare::prepare(&from_bvh).unwrap());
    let (a, b) = (pa.cycles[0].period_frames, pb.cycles[0].period_frames);
    // The rhythm found in the data (autocorrelation) is the same; the BVH's
    // channel is another angle (rotation about world axes, not the ASF femur axes).
    assert!((a - b).abs() <= 0.01 * a, "AMC period {a:.2} frames, BVH period {b:.2} frames");
    // The model keeps a skeleton it can export: an ASF written from the BVH hierarchy.
    let (model, _) = cpg_lab::train::train(&from_bvh, 2).unwrap();
    let asf = model.skeleton_asf.as_deref().unwrap();
    let kept = cpg_mocap::parse_asf("kept", asf.as_bytes()).unwrap();
    assert!(kept.bone_index("lfemur").is_some());
    // It keeps the rhythm it was taught: 60 s of free run end on the teacher's period and amplitude.
    let y = cpg_lab::measure::free_run(&model, &cpg_lab::ControlSchedule::none(), 7200, None).unwrap();
    let st = cpg_lab::measure::stability(&y, 1, &model.teachers[0], 0, 120.0);
    assert!(st.accurate, "{st:?}");
}

#[test]
fn bvh_configurations_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let sk = skeleton35();
    let m = motion35(&sk, "35_01.amc");
    let bvh = dir.path().join("35_01.bvh");
    std::fs::write(&bvh, cpg_mocap::write_bvh(&sk, &m).unwrap()).unwrap();
    let base = std::fs::read_to_string(cpg_tests::workspace_root().join("experiments/e1.toml")).unwrap();
    let write = |text: &str| {
        let p = dir.path().join("bad.toml");
        std::fs::write(&p, text).unwrap();
        Config::load(&p).and_then(|c| cpg_lab::prepare::prepare(&c).map(|_| ())).unwrap_err().to_string()
    };
    let with_bvh =
        base.replace("motion = \"../data/cmu35/35_01.amc\"", &format!("motion = {:?}", bvh.display().to_string()));
    // A skeleton beside BVH motions.
    let e = write(&with_bvh);
    assert!(e.contains("`data.skeleton`") && e.contains("BVH motions carry their own skeleton"), "{e}");
    // AMC without its skeleton.
    let e = write(&base.replace("skeleton = \"../data/cmu35/35.asf\"\n", ""));
    assert!(e.contains("`data.skeleton`") && e.contains("AMC motions need their ASF skeleton"), "{e}");
    let no_skeleton = with_bvh.replace("skeleton = \"../data/cmu35/35.asf\"\n", "");
    // A rate the file does not have.
    let e = write(&no_skeleton.replace("rate_hz = 120", "rate_hz = 100"));
    assert!(e.contains("`data.rate_hz`") && e.contains("120 Hz") && e.contains("set data.rate_hz = 120"), "{e}");
    // A channel the BVH does not have.
    let e = write(&no_skeleton.replace("channels = [\"lfemur.rx\"]", "channels = [\"LeftUpLeg.rx\"]"));
    assert!(e.contains("`data.channels`") && e.contains("LeftUpLeg.rx"), "{e}");
    // A unit out of range.
    let e = write(&no_skeleton.replace("rate_hz = 120", "rate_hz = 120\nbvh_unit_mm = 0"));
    assert!(e.contains("`data.bvh_unit_mm`"), "{e}");
}

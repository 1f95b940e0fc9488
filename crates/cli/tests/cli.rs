//! The `cpg` binary on the real subject-35 files.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::path::PathBuf;
use std::process::{Command, Output};

use cpg_mocap::data::{Subject, find};

fn cmu(file: &str) -> PathBuf {
    find(Subject::S35, file).unwrap_or_else(|e| panic!("{e}"))
}

fn cpg(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cpg")).args(args).output().unwrap()
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn inspect_skeleton_prints_the_bone_tree() {
    let o = cpg(&["inspect".as_ref(), cmu("35.asf").as_os_str()]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("30 bones, 62 channels per frame"), "{out}");
    assert!(out.contains("    lfemur (length 418.3 mm) [rx -160..20, ry -70..70, rz -60..70]"), "{out}");
}

#[test]
fn inspect_motion_prints_channel_statistics() {
    let o = cpg(&["inspect".as_ref(), cmu("35_01.amc").as_os_str(), "--skeleton".as_ref(), cmu("35.asf").as_os_str()]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("358 frames at 120 Hz = 2.983 s, 62 channels"), "{out}");
    let femur = out.lines().find(|l| l.starts_with("lfemur.rx")).unwrap();
    let nums: Vec<f64> = femur.split_whitespace().skip(1).map(|t| t.parse().unwrap()).collect();
    // The hazard ranges in ../shared/reference/hoap2-joints.md: lfemur rx −29…18 on 35_01.
    assert!((nums[0] + 29.0).abs() < 1.0 && (nums[1] - 18.0).abs() < 1.0, "{femur}");
}

#[test]
fn fk_writes_31_points_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sub/points.csv");
    let o = cpg(&[
        "fk".as_ref(),
        cmu("35_17.amc").as_os_str(),
        "-s".as_ref(),
        cmu("35.asf").as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let csv = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 1 + 167);
    assert_eq!(lines[0].split(',').count(), 2 + 31 * 3);
    assert!(lines[0].starts_with("frame,time_s,root_x_mm,root_y_mm,root_z_mm,lhipjoint_x_mm"));
    assert_eq!(std::fs::read_dir(dir.path().join("sub")).unwrap().count(), 1, "no temporary file left");
}

#[test]
fn bad_input_gives_a_located_error_and_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.amc");
    let good = std::fs::read_to_string(cmu("35_01.amc")).unwrap();
    std::fs::write(&bad, good.replacen("ltibia 22.5608", "ltibia 22.5608 1.0", 1)).unwrap();
    let o = cpg(&["inspect".as_ref(), bad.as_os_str(), "-s".as_ref(), cmu("35.asf").as_os_str()]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("bad.amc:31:1: bone 'ltibia' has 2 values, skeleton declares 1 (rx)"), "{err}");

    let o = cpg(&["inspect".as_ref(), cmu("35_01.amc").as_os_str()]);
    assert!(text(&o).1.contains("give its skeleton with --skeleton"));
    let o = cpg(&[
        "fk".as_ref(),
        dir.path().join("none.amc").as_os_str(),
        "-s".as_ref(),
        cmu("35.asf").as_os_str(),
        "-o".as_ref(),
        dir.path().join("o.csv").as_os_str(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("none.amc"));
    assert!(!dir.path().join("o.csv").exists());
}

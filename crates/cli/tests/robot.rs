//! Robot-ready output: HOAP-2 trajectories within every limit at any rate,
//! the formats robots read, `cpg stream` through a pipe, AMC on the floor.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::ffi::OsStr;
use std::io::{BufRead, Write};
use std::process::{Command, Stdio};

mod common;

use common::{cmu, cpg, ok, repo, walk22};

/// The robot's files are part of the program: a copy of `cpg` run far from
/// the checkout (as `cargo install` leaves it) drives the HOAP-2 with its
/// built-in URDF and map.
#[test]
fn the_robot_files_travel_with_the_program() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("cpg");
    std::fs::copy(env!("CARGO_BIN_EXE_cpg"), &bin).unwrap();
    let model = dir.path().join("walk22.cpg");
    std::fs::copy(walk22(), &model).unwrap();
    let o = Command::new(&bin)
        .args(["hoap2", "-m", "walk22.cpg", "--seconds", "1", "-o", "j.csv"])
        .current_dir(dir.path())
        .env_remove("CARGO_MANIFEST_DIR")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let text = std::fs::read_to_string(dir.path().join("j.csv")).unwrap();
    assert_eq!(text.lines().next().unwrap().split(',').count(), 1 + 3 * 22, "22 joints from the built-in map");
    // `cpg view` draws the robot from the built-in files too.
    let o = Command::new(&bin)
        .args(["view", "-m", "walk22.cpg", "--seconds", "1", "-o", "v.html"])
        .current_dir(dir.path())
        .env_remove("CARGO_MANIFEST_DIR")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("HOAP-2"), "{err}");
    assert!(std::fs::read_to_string(dir.path().join("v.html")).unwrap().contains("HOAP-2"));
    // A missing file is still an error, not a silent fallback to the built-in robot.
    let o = Command::new(&bin)
        .args(["hoap2", "-m", "walk22.cpg", "--seconds", "1", "--urdf", "assets/hoap2/hoap2.urdf", "-o", "k.csv"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("hoap2.urdf"));
}

#[test]
fn hoap2_trajectories_have_exact_rows_and_keep_every_limit() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("j.csv");
    let err = ok(&cpg(&[
        OsStr::new("hoap2"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "5".as_ref(),
        "--rate-hz".as_ref(),
        "1000".as_ref(),
        "-o".as_ref(),
        csv.as_os_str(),
    ]));
    assert!(err.contains("wrote 5000 frames") && err.contains("speed asked"), "{err}");
    let robot = cpg_robot::Robot::from_urdf_file(&repo().join("assets/hoap2/hoap2.urdf")).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 1 + 3 * 22);
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 5000, "exactly seconds × rate rows");
    assert!((rows[4999][0] - 4.999).abs() < 1e-9);
    let (mut fastest, mut hardest) = (0.0f64, 0.0f64);
    for (c, h) in header.iter().enumerate().skip(1) {
        let (name, kind) = if let Some(n) = h.strip_suffix("_rad_s2") {
            (n, 2)
        } else if let Some(n) = h.strip_suffix("_rad_s") {
            (n, 1)
        } else {
            (h.strip_suffix("_rad").unwrap(), 0)
        };
        let j = robot.joint(name).unwrap();
        for r in &rows {
            match kind {
                0 => assert!(r[c] >= j.lower_rad - 1e-6 && r[c] <= j.upper_rad + 1e-6, "{h} = {}", r[c]),
                1 => {
                    assert!(r[c].abs() <= j.velocity_rad_s + 1e-5, "{h} = {}", r[c]);
                    fastest = fastest.max(r[c].abs());
                }
                _ => {
                    assert!(r[c].abs() <= cpg_robot::DEFAULT_ACCELERATION_RAD_S2 + 1e-3, "{h} = {}", r[c]);
                    hardest = hardest.max(r[c].abs());
                }
            }
        }
    }
    // The walk uses the speed it is allowed (it asks for more: see the table).
    assert!(fastest > 1.0 && hardest > 10.0, "{fastest} {hardest}");
    // Velocities are the positions' derivative.
    let knee = header.iter().position(|h| *h == "lleg_joint_4_rad").unwrap();
    let knee_v = header.iter().position(|h| *h == "lleg_joint_4_rad_s").unwrap();
    for w in rows.windows(2).skip(10) {
        assert!(((w[1][knee] - w[0][knee]) * 1000.0 - w[1][knee_v]).abs() < 0.01);
    }

    // The same as a trajectory_msgs/JointTrajectory, by the file's extension.
    let json = dir.path().join("j.json");
    ok(&cpg(&[
        OsStr::new("hoap2"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "2".as_ref(),
        "--rate-hz".as_ref(),
        "250".as_ref(),
        "-o".as_ref(),
        json.as_os_str(),
    ]));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["joint_names"].as_array().unwrap().len(), 22);
    let points = v["points"].as_array().unwrap();
    assert_eq!(points.len(), 500);
    assert_eq!(points[1]["time_from_start"], serde_json::json!({"sec": 0, "nanosec": 4_000_000}));
    for key in ["positions", "velocities", "accelerations"] {
        assert_eq!(points[499][key].as_array().unwrap().len(), 22);
    }
    let o = cpg(&[
        OsStr::new("hoap2"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "--format".as_ref(),
        "yaml".as_ref(),
        "-o".as_ref(),
        "-".as_ref(),
    ]);
    ok(&o);
    let yaml = String::from_utf8(o.stdout).unwrap();
    assert!(yaml.starts_with("joint_names:\n- lleg_joint_1\n") && yaml.matches("- positions: [").count() == 120);
}

#[test]
fn strict_turns_the_limit_warning_into_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("j.csv");
    let args = |strict: bool| {
        let mut a: Vec<&OsStr> = vec![
            OsStr::new("hoap2"),
            "-m".as_ref(),
            walk22().as_os_str(),
            "--seconds".as_ref(),
            "5".as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
        ];
        // A tight acceleration bound holds some joint back in more than 5 % of its frames.
        a.extend([OsStr::new("--acceleration-rad-s2"), "5".as_ref()]);
        if strict {
            a.push("--strict".as_ref());
        }
        a
    };
    let err = ok(&cpg(&args(false)));
    assert!(err.contains("warning:") && err.contains("limited in more than 5 % of frames"), "{err}");
    assert!(out.exists());
    std::fs::remove_file(&out).unwrap();
    let o = cpg(&args(true));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nothing was written (--strict)"));
    assert!(!out.exists());
}

/// Upward zero crossings (around the series' mean) of column 1 between `from_s` and `to_s`.
fn crossings(rows: &[(f64, f64)], from_s: f64, to_s: f64) -> Vec<f64> {
    let part: Vec<&(f64, f64)> = rows.iter().filter(|r| r.0 >= from_s && r.0 < to_s).collect();
    let mean = part.iter().map(|r| r.1).sum::<f64>() / part.len() as f64;
    part.windows(2).filter(|w| w[0].1 < mean && w[1].1 >= mean).map(|w| w[1].0).collect()
}

#[test]
fn stream_follows_a_control_change_through_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    // E5 (walk and run of the left femur, two control inputs) with a coarser penalty grid.
    let mut c = std::fs::read_to_string(repo().join("experiments/e5.toml")).unwrap();
    c = c.replace("../data/cmu35/35.asf", &cmu("35.asf").display().to_string());
    for f in ["35_01.amc", "35_17.amc"] {
        c = c.replace(&format!("../data/cmu35/{f}"), &cmu(f).display().to_string());
    }
    c = c.replacen(
        "penalty_log10 = { start = 1, step = 0.1, stop = -8 }",
        "penalty_log10 = { start = 0, step = 0.5, stop = -6 }",
        1,
    );
    let config = dir.path().join("e5.toml");
    std::fs::write(&config, c).unwrap();
    let model = dir.path().join("e5.cpg");
    ok(&cpg(&[OsStr::new("train"), "-c".as_ref(), config.as_os_str(), "-o".as_ref(), model.as_os_str()]));

    let mut child = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("stream"),
            "-m".as_ref(),
            model.as_os_str(),
            "--rate-hz".as_ref(),
            "1000".as_ref(),
            "--seconds".as_ref(),
            "7".as_ref(),
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    writeln!(stdin, "1, 0").unwrap();
    // Read lines as they come; switch to running once 3 s of commands have arrived.
    let stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut rows = Vec::new();
    let mut switched = false;
    for line in stdout.lines().skip(1) {
        let line = line.unwrap();
        let mut f = line.split(',').map(|v| v.parse::<f64>().unwrap());
        let (t, y) = (f.next().unwrap(), f.next().unwrap());
        if t >= 3.0 && !switched {
            writeln!(stdin, "u_walk=0 u_run=1").unwrap();
            switched = true;
        }
        rows.push((t, y));
    }
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("7000 ticks at 1000 Hz: lateness mean") && err.contains("missed deadline"), "{err}");
    assert_eq!(rows.len(), 7000);
    let walk = crossings(&rows, 0.0, 3.0);
    let run = crossings(&rows, 4.0, 7.0);
    let period = |c: &[f64]| (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64;
    assert!(walk.len() >= 2 && run.len() >= 3, "{walk:?} {run:?}");
    let (pw, pr) = (period(&walk), period(&run));
    // Walking (35_01) has a stride of about 135 frames (1.12 s), running (35_17) about 88 (0.73 s).
    assert!((pw - 1.12).abs() < 0.12 && (pr - 0.73).abs() < 0.12, "walk period {pw} s, run period {pr} s");

    // Unpaced, it writes exactly seconds × rate lines.
    let o = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("stream"),
            "-m".as_ref(),
            model.as_os_str(),
            "--rate-hz".as_ref(),
            "500".as_ref(),
            "--seconds".as_ref(),
            "2".as_ref(),
            "--no-pacing".as_ref(),
            "--control".as_ref(),
            "u_run=1,u_walk=0".as_ref(),
        ])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(String::from_utf8(o.stdout).unwrap().lines().count(), 1 + 1000);
}

#[test]
fn generated_amc_stands_on_the_floor() {
    let dir = tempfile::tempdir().unwrap();
    let amc = dir.path().join("walk.amc");
    ok(&cpg(&[
        OsStr::new("generate"),
        "-m".as_ref(),
        walk22().as_os_str(),
        "--seconds".as_ref(),
        "3".as_ref(),
        "--format".as_ref(),
        "amc".as_ref(),
        "-o".as_ref(),
        amc.as_os_str(),
    ]));
    let sk = cpg_mocap::Skeleton::from_file(cmu("35.asf")).unwrap();
    let m = cpg_mocap::Motion::from_amc_file(&amc, &sk, 120.0).unwrap();
    let p = sk.forward_kinematics(&m).unwrap();
    let mut walked = 0.0f64;
    for f in 0..p.n_frames() {
        let low = p.frame(f).iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
        assert!(low.abs() < 0.5, "frame {f}: the lowest point is {low} mm from the floor");
        walked = walked.max(p.frame(f)[0][2].abs().max(p.frame(f)[0][0].abs()));
    }
    // The root travels: three seconds of walking cover more than a metre.
    assert!(walked > 1000.0, "root moved {walked} mm");
}

/// `cpg retarget`: subject 35's walk as a HOAP-2 walk, the ZMP inside the soles.
#[test]
fn retarget_writes_a_balanced_walk_and_refuses_bad_requests() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("walk.csv");
    let json = dir.path().join("walk.json");
    let asf = cmu("35.asf");
    let (m1, m2) = (cmu("35_01.amc"), cmu("35_02.amc"));
    let o = cpg(&[
        OsStr::new("retarget"),
        OsStr::new("-s"),
        asf.as_os_str(),
        OsStr::new("-m"),
        m1.as_os_str(),
        OsStr::new("-m"),
        m2.as_os_str(),
        OsStr::new("--steps"),
        OsStr::new("8"),
        OsStr::new("-o"),
        csv.as_os_str(),
        OsStr::new("--report"),
        json.as_os_str(),
    ]);
    let err = ok(&o);
    assert!(err.contains("ZMP inside the support polygon in 100.0 %"), "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(header.iter().filter(|h| h.ends_with("_rad")).count(), 25);
    assert!(header.contains(&"zmp_margin_m") && header.contains(&"support"));
    let k = header.iter().position(|h| *h == "zmp_margin_m").unwrap();
    for line in text.lines().skip(1) {
        let m: f64 = line.split(',').nth(k).unwrap().parse().unwrap();
        assert!(m > 0.0, "{line}");
    }
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["params"]["steps"], 8);
    assert!(report["style"].as_array().unwrap().len() >= 6);
    // Bad requests: one message, exit 2, nothing written.
    let bad = dir.path().join("bad.csv");
    for extra in [["--step-scale", "nan"], ["--double-support-share", "0.95"], ["--steps", "1"], ["--steps", "9000000"]]
    {
        let mut args: Vec<&OsStr> = vec![OsStr::new("retarget"), OsStr::new("-s"), asf.as_os_str()];
        args.extend([OsStr::new("-m"), m1.as_os_str(), OsStr::new("-o"), bad.as_os_str()]);
        args.extend(extra.iter().map(OsStr::new));
        let o = cpg(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(!bad.exists(), "{extra:?} wrote a file");
    }
    // A trial that does not travel is not a walk.
    let run = dir.path().join("still.amc");
    let first: String = std::fs::read_to_string(&m1).unwrap().lines().take(3 + 30 * 29).collect::<Vec<_>>().join("\n");
    std::fs::write(&run, first + "\n").unwrap();
    let o = cpg(&[
        OsStr::new("retarget"),
        OsStr::new("-s"),
        asf.as_os_str(),
        OsStr::new("-m"),
        run.as_os_str(),
        OsStr::new("-o"),
        bad.as_os_str(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("not a walk") || e.contains("no full stride"), "{e}");
}

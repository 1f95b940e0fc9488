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
    // The directory must exist: -o creates none (hardening2.rs checks the refusal).
    std::fs::create_dir(dir.path().join("sub")).unwrap();
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

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn ok(o: &Output) -> String {
    let (out, err) = text(o);
    assert!(o.status.success(), "failed:\n{out}\n{err}");
    out + &err
}

/// The tested example: train → generate (CSV and AMC) → hoap2 → evaluate.
#[test]
fn example_config_trains_generates_and_drives_hoap2() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("walk22.cpg");
    let config = repo().join("examples/walk22.toml");
    let log = ok(&cpg(&["train".as_ref(), "--config".as_ref(), config.as_os_str(), "-o".as_ref(), model.as_os_str()]));
    assert!(log.contains("trained in"), "{log}");

    let csv = dir.path().join("walk.csv");
    ok(&cpg(&[
        "generate".as_ref(),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "5".as_ref(),
        "-o".as_ref(),
        csv.as_os_str(),
    ]));
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1 + 600, "5 s at 120 Hz");
    assert!(lines[0].starts_with("time_s,lfemur.ry_deg,lfemur.rz_deg,lfemur.rx_deg,"), "{}", lines[0]);
    // Hip flexion stays in a walking range (35_02: about −30…+20 degrees).
    let col = lines[0].split(',').position(|c| c == "lfemur.rx_deg").unwrap();
    for l in &lines[1..] {
        let v: f64 = l.split(',').nth(col).unwrap().parse().unwrap();
        assert!((-60.0..40.0).contains(&v), "lfemur.rx {v}");
    }

    let amc = dir.path().join("walk.amc");
    ok(&cpg(&[
        "generate".as_ref(),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "--format".as_ref(),
        "amc".as_ref(),
        "-o".as_ref(),
        amc.as_os_str(),
    ]));
    let sk = cpg_mocap::Skeleton::from_file(cmu("35.asf")).unwrap();
    let m = cpg_mocap::Motion::from_amc_file(&amc, &sk, 120.0).unwrap();
    assert_eq!(m.n_frames(), 120);
    assert_eq!(m.n_channels(), 62, "every skeleton channel is written (the model remembers its skeleton)");

    let joints = dir.path().join("hoap2.csv");
    let log = ok(&cpg(&[
        "hoap2".as_ref(),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "2".as_ref(),
        "--rate-hz".as_ref(),
        "1000".as_ref(),
        "--urdf".as_ref(),
        repo().join("assets/hoap2/hoap2.urdf").as_os_str(),
        "-o".as_ref(),
        joints.as_os_str(),
    ]));
    assert!(log.contains("lleg_joint_4"), "clamp table printed: {log}");
    let text = std::fs::read_to_string(&joints).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    // time_s, then the 22 joints' angles (rad), velocities (rad/s) and accelerations (rad/s²).
    assert_eq!(header.len(), 1 + 3 * 22);
    assert_eq!(header[0], "time_s");
    assert!(header[1..23].iter().all(|h| h.ends_with("_rad")));
    // 2 s at 1 kHz is 2000 rows.
    assert_eq!(lines.len() - 1, 2000);
    let robot = cpg_robot::Robot::from_urdf_file(&repo().join("assets/hoap2/hoap2.urdf")).unwrap();
    for l in &lines[1..] {
        for (h, v) in header[1..23].iter().zip(l.split(',').skip(1)) {
            let j = robot.joint(h.trim_end_matches("_rad")).unwrap();
            let v: f64 = v.parse().unwrap();
            assert!(v >= j.lower_rad - 1e-6 && v <= j.upper_rad + 1e-6, "{h} = {v} outside its limits");
        }
    }

    let log = ok(&cpg(&["evaluate".as_ref(), "-m".as_ref(), model.as_os_str(), "--seconds".as_ref(), "60".as_ref()]));
    assert!(log.contains("period at the end") && log.contains("push") && log.contains("converged"), "{log}");
    let json = ok(&cpg(&[
        "evaluate".as_ref(),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "60".as_ref(),
        "--json".as_ref(),
    ]));
    let v: serde_json::Value = serde_json::from_str(json.trim_end_matches(|c| c != ']')).unwrap();
    assert_eq!(v.as_array().map(|a| a.len()), Some(1), "one teacher");
    assert!(v[0]["stability"]["end"]["amplitude"].as_array().is_some_and(|a| a.len() == 22));
}

#[test]
fn config_and_model_errors_say_what_is_valid() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    let base = std::fs::read_to_string(repo().join("experiments/e1-paper.toml")).unwrap();
    let fix_paths = |s: String| {
        s.replace("../data/cmu35/35.asf", &cmu("35.asf").display().to_string())
            .replace("../data/cmu35/35_01.amc", &cmu("35_01.amc").display().to_string())
    };
    std::fs::write(&bad, fix_paths(base.replace("\"lfemur.rx\"", "\"lfemur.rq\""))).unwrap();
    let o =
        cpg(&["train".as_ref(), "-c".as_ref(), bad.as_os_str(), "-o".as_ref(), dir.path().join("m.cpg").as_os_str()]);
    let err = text(&o).1;
    assert_eq!(o.status.code(), Some(2));
    assert!(err.contains("data.channels") && err.contains("'lfemur.rq' is not a channel"), "{err}");
    std::fs::write(&bad, fix_paths(base.replace("seed = 1", "seed = 1\nleak = 0.2"))).unwrap();
    let err = text(&cpg(&["train".as_ref(), "-c".as_ref(), bad.as_os_str()])).1;
    assert!(err.contains("unknown field `leak`") && err.contains("reservoir"), "{err}");
    // A field of the wrong shape names the field, its line and what it takes, in the file's words.
    std::fs::write(
        &bad,
        fix_paths(base.replace("penalty_log10 = { start = 5, step = 0.1, stop = -8 }", "penalty_log10 = [1, -8]")),
    )
    .unwrap();
    let err = text(&cpg(&["train".as_ref(), "-c".as_ref(), bad.as_os_str()])).1;
    let line = base.lines().position(|l| l.starts_with("penalty_log10")).unwrap() + 1;
    assert!(
        err.contains("`training.penalty_log10`")
            && err.contains("{start, step, stop}")
            && err.contains(&format!("bad.toml:{line}")),
        "{err}"
    );
    assert!(!err.contains("PenaltyRange"), "no internal type names: {err}");
    std::fs::write(&bad, fix_paths(base.replace("seed = 1", "seed = 1\nleak_rate = 1.5"))).unwrap();
    let err = text(&cpg(&["train".as_ref(), "-c".as_ref(), bad.as_os_str()])).1;
    assert!(err.contains("leak_rate") && err.contains("(0, 1]"), "{err}");
    let junk = dir.path().join("junk.cpg");
    std::fs::write(&junk, b"not a model").unwrap();
    let err = text(&cpg(&[
        "generate".as_ref(),
        "-m".as_ref(),
        junk.as_os_str(),
        "-o".as_ref(),
        dir.path().join("x.csv").as_os_str(),
    ]))
    .1;
    assert!(err.contains("not a cpg model file"), "{err}");
    assert!(!dir.path().join("x.csv").exists());
}

/// Two gaits with control inputs: a multi-segment config, `--control` and `--control-file`.
#[test]
fn control_inputs_from_values_and_files() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("gaits.toml");
    std::fs::write(
        &config,
        format!(
            r#"
[data]
skeleton = "{asf}"
channels = ["lfemur.rx"]
controls = ["u_walk", "u_run"]
loop_cycles = 1
samples_per_segment = 1000

[[data.segments]]
motion = "{walk}"
controls = [1, 0]

[[data.segments]]
motion = "{run}"
controls = [0, 1]

[reservoir]
n_neurons = 200

[training]
noise_draws = 1
penalty_log10 = {{ start = 1, step = 1, stop = -4 }}

[output]
model = "gaits.cpg"
"#,
            asf = cmu("35.asf").display(),
            walk = cmu("35_01.amc").display(),
            run = cmu("35_17.amc").display()
        ),
    )
    .unwrap();
    // This small two-gait model validates worse than 1 (it is here for the control plumbing,
    // not its rhythm), so `train` needs --allow-unstable to write it.
    let log = ok(&cpg(&["train".as_ref(), "-c".as_ref(), config.as_os_str(), "--allow-unstable".as_ref()]));
    assert!(log.contains("written anyway (--allow-unstable)") || !log.contains("warning: "), "{log}");
    let model = dir.path().join("gaits.cpg");
    assert!(model.is_file(), "the model lands beside the config");

    let out = dir.path().join("a.csv");
    let run = |extra: &[&std::ffi::OsStr]| {
        let mut a: Vec<&std::ffi::OsStr> = vec![
            "generate".as_ref(),
            "-m".as_ref(),
            model.as_os_str(),
            "--seconds".as_ref(),
            "2".as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
        ];
        a.extend_from_slice(extra);
        cpg(&a)
    };
    // The model has two control inputs: they must be given, two of them.
    let o = run(&[]);
    assert!(text(&o).1.contains("control inputs [u_walk, u_run]"), "{}", text(&o).1);
    let o = run(&["--control".as_ref(), "1".as_ref()]);
    assert!(text(&o).1.contains("1 control values; the model's control inputs are [u_walk, u_run]"), "{}", text(&o).1);
    ok(&run(&["--control".as_ref(), "0,1".as_ref()]));
    let constant = std::fs::read_to_string(&out).unwrap();
    assert_eq!(constant.lines().count(), 1 + 240);

    let file = dir.path().join("u.csv");
    std::fs::write(&file, "u_walk,u_run\n0,1\n").unwrap();
    ok(&run(&["--control-file".as_ref(), file.as_os_str()]));
    assert_eq!(std::fs::read_to_string(&out).unwrap(), constant, "a one-row file holds its values like --control");
    std::fs::write(&file, "u_run,u_walk\n0,1\n").unwrap();
    let o = run(&["--control-file".as_ref(), file.as_os_str()]);
    assert!(text(&o).1.contains("u.csv:1: header [u_run, u_walk]"), "{}", text(&o).1);
    std::fs::write(&file, "u_walk,u_run\n0,1\n0,x\n").unwrap();
    let o = run(&["--control-file".as_ref(), file.as_os_str()]);
    assert!(text(&o).1.contains("u.csv:3: expected 2 finite numbers"), "{}", text(&o).1);
}

/// `cpg train --config experiments/e4.toml` writes exactly the model the
/// report's E4 trains for its first seed.
#[test]
fn cpg_train_reproduces_the_reports_model() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("e4.cpg");
    let config = repo().join("experiments/e4.toml");
    ok(&cpg(&["train".as_ref(), "-c".as_ref(), config.as_os_str(), "-o".as_ref(), out.as_os_str()]));
    let c = cpg_lab::Config::load(&config).unwrap();
    let (_, models) =
        cpg_lab::experiment::train_seeds(&c, &[c.reservoir.seed], 2, &cpg_lab::experiment::Quiet).unwrap();
    assert_eq!(std::fs::read(&out).unwrap(), models[0].to_bytes().unwrap());
}

/// `cpg tune` finds settings that keep the rhythm from a deliberately poor
/// start, and writes them as a configuration `cpg train` takes.
#[test]
fn tune_finds_a_stable_configuration_from_a_poor_start() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tuned.toml");
    let config = repo().join("examples/poor-femur.toml");
    let args = [
        "tune",
        "-c",
        config.to_str().unwrap(),
        "--budget",
        "6",
        "--seeds",
        "2",
        "--seconds",
        "60",
        "-o",
        out.to_str().unwrap(),
    ];
    let log = ok(&cpg(&args.map(std::ffi::OsStr::new)));
    let table: Vec<&str> = log
        .lines()
        .filter(|l| {
            l.trim_start().starts_with("base") || l.trim_start().chars().next().is_some_and(|c| c.is_ascii_digit())
        })
        .collect();
    let base =
        table.iter().find(|l| l.trim_start().starts_with("base")).expect("the starting configuration is in the table");
    assert!(base.contains(" 0/2"), "the poor start passes on no seed: {base}");
    assert!(table[0].contains(" 2/2"), "the best candidate passes on both seeds:\n{log}");
    // The written configuration trains a model that keeps the rhythm.
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("# Written by `cpg tune`"), "{text}");
    let model = dir.path().join("tuned.cpg");
    ok(&cpg(&["train".as_ref(), "-c".as_ref(), out.as_os_str(), "-o".as_ref(), model.as_os_str()]));
    let log = ok(&cpg(&["evaluate".as_ref(), "-m".as_ref(), model.as_os_str(), "--seconds".as_ref(), "60".as_ref()]));
    assert!(log.contains("accurate") && log.contains("): yes"), "{log}");
    // Same search on one thread, same result.
    let again = dir.path().join("again.toml");
    let args2 = [
        "tune",
        "-c",
        config.to_str().unwrap(),
        "--budget",
        "6",
        "--seeds",
        "2",
        "--seconds",
        "60",
        "-o",
        again.to_str().unwrap(),
    ];
    ok(&Command::new(env!("CARGO_BIN_EXE_cpg")).args(args2).env("RAYON_NUM_THREADS", "1").output().unwrap());
    let strip = |t: &str| t.lines().filter(|l| !l.contains("Train it with")).collect::<Vec<_>>().join("\n");
    assert_eq!(strip(&std::fs::read_to_string(&again).unwrap()), strip(&text));
}

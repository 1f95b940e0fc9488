//! The defects of the hardening audit, one test per kind: each command that
//! once panicked, hung, allocated without bound, wrote inf/NaN or destroyed a
//! file now exits 2 with one clear message (or does the right thing).

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use cpg_mocap::data::{Subject, find};

fn cmu(file: &str) -> PathBuf {
    find(Subject::S35, file).unwrap_or_else(|e| panic!("{e}"))
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn tiny(file: &str) -> PathBuf {
    repo().join("crates/mocap/test_data").join(file)
}

fn cpg<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cpg")).args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Fails unless `o` exited 2 with exactly one `error:` line containing every one of `needles`.
fn fails_with(o: &Output, needles: &[&str]) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "exit {:?}: {err}", o.status.code());
    assert_eq!(err.matches("error:").count(), 1, "one message: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "expected {n:?} in: {err}");
    }
    err
}

/// experiments/e1.toml with absolute data paths and `edits` (old, new) applied, written to `dir/name`.
fn e1_config(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut s = std::fs::read_to_string(repo().join("experiments/e1.toml")).unwrap();
    s = s
        .replace("../data/cmu35/35.asf", &cmu("35.asf").display().to_string())
        .replace("../data/cmu35/35_01.amc", &cmu("35_01.amc").display().to_string());
    for (a, b) in edits {
        assert!(s.contains(a), "{a} not in e1.toml");
        s = s.replacen(a, b, 1);
    }
    let p = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p
}

/// The edits of experiments/e1.toml that make its model small and quick: 80 neurons, a coarse penalty grid.
const SMALL: [(&str, &str); 2] = [
    ("seed = 1\n", "seed = 1\nn_neurons = 80\n"),
    ("penalty_log10 = { start = 1, step = 0.1, stop = -8 }", "penalty_log10 = { start = 1, step = 1, stop = -8 }"),
];

/// A small, quick model of the left femur, trained once for these tests.
fn model() -> &'static Path {
    static MODEL: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &MODEL
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let c = e1_config(dir.path(), "small.toml", &SMALL);
            let m = dir.path().join("small.cpg");
            let o = cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), m.as_os_str()]);
            assert!(o.status.success(), "{}", stderr(&o));
            (dir, m)
        })
        .1
}

fn generate_to(out: &Path, seconds: &str) -> Output {
    let s = format!("--seconds={seconds}");
    cpg(&[OsStr::new("generate"), "-m".as_ref(), model().as_os_str(), s.as_ref(), "-o".as_ref(), out.as_os_str()])
}

#[test]
fn dash_is_standard_output_and_a_symlink_fifo_or_device_is_never_replaced() {
    let dir = tempfile::tempdir().unwrap();
    // `-` is standard output, and no file named `-` appears.
    let o = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("generate"),
            "-m".as_ref(),
            model().as_os_str(),
            "--seconds".as_ref(),
            "1".as_ref(),
            "-o".as_ref(),
            "-".as_ref(),
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8(o.stdout).unwrap();
    assert!(out.starts_with("time_s,lfemur.rx_deg\n") && out.lines().count() == 121, "{out}");
    assert!(!dir.path().join("-").exists());

    // A symlink: its target is written, the link stays a link.
    let target = dir.path().join("real.csv");
    std::fs::write(&target, "old").unwrap();
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink("real.csv", &link).unwrap();
    assert!(generate_to(&link, "1").status.success());
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(std::fs::read_to_string(&target).unwrap().starts_with("time_s"));

    // A device stays a device.
    assert!(generate_to(Path::new("/dev/null"), "1").status.success());
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device());

    // A FIFO is written in place: a reader gets the CSV, the FIFO stays.
    let fifo = dir.path().join("pipe");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let f2 = fifo.clone();
    let reader = std::thread::spawn(move || std::fs::read_to_string(f2).unwrap());
    assert!(generate_to(&fifo, "1").status.success());
    assert_eq!(reader.join().unwrap().lines().count(), 121);
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());

    // /dev/stdout redirected to a file writes that file in place (same inode), not a replacement.
    let redirected = dir.path().join("redirected.csv");
    let file = std::fs::File::create(&redirected).unwrap();
    use std::os::unix::fs::MetadataExt;
    let inode = std::fs::metadata(&redirected).unwrap().ino();
    let o = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("generate"),
            "-m".as_ref(),
            model().as_os_str(),
            "--seconds".as_ref(),
            "1".as_ref(),
            "-o".as_ref(),
            "/dev/stdout".as_ref(),
        ])
        .stdout(file)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::metadata(&redirected).unwrap().ino(), inode);
    assert_eq!(std::fs::read_to_string(&redirected).unwrap().lines().count(), 121);

    // A directory is refused before any work.
    fails_with(&generate_to(dir.path(), "1"), &["is a directory"]);
}

#[test]
fn temporary_files_go_on_interrupt_and_stale_ones_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.csv");
    // A stale temporary file of a process that no longer runs is removed by the next write.
    let stale = dir.path().join(".big.csv.4294967294.tmp");
    std::fs::write(&stale, "left by a killed run").unwrap();
    // A day at 120 Hz: long enough to catch the write in progress.
    let mut child = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("generate"),
            "-m".as_ref(),
            model().as_os_str(),
            "--seconds".as_ref(),
            "86400".as_ref(),
            "-o".as_ref(),
            out.as_os_str(),
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let ours = dir.path().join(format!(".big.csv.{}.tmp", child.id()));
    let start = std::time::Instant::now();
    while !ours.exists() {
        assert!(start.elapsed().as_secs() < 120, "the temporary file never appeared");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    assert!(!stale.exists(), "the stale temporary file was removed");
    assert!(Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap().success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    assert!(!ours.exists(), "the interrupted run removed its temporary file");
    assert!(!out.exists(), "nothing was written");
}

#[test]
fn frame_numbers_cannot_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let amc = dir.path().join("wrap.amc");
    let text = std::fs::read_to_string(tiny("tiny.amc")).unwrap();
    // tiny.amc has CRLF line ends.
    std::fs::write(&amc, text.replacen("\n1\r\n", "\n18446744073709551615\r\n", 1).replacen("\n2\r\n", "\n0\r\n", 1))
        .unwrap();
    for cmd in ["inspect", "fk"] {
        let mut args: Vec<&OsStr> =
            vec![cmd.as_ref(), amc.as_os_str(), "-s".as_ref(), tiny("tiny.asf").into_os_string().leak()];
        let o_path = dir.path().join("o.csv");
        if cmd == "fk" {
            args.extend([OsStr::new("-o"), o_path.as_os_str()]);
        }
        fails_with(&cpg(&args), &["wrap.amc:4:1", "18446744073709551615", "a frame number from 0 to 1000000000"]);
    }
}

#[test]
fn requested_work_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    for s in ["1e18", "1e12", "1e300", "0", "-1", "nan"] {
        fails_with(&generate_to(&out, s), &["--seconds", "at most 86400"]);
    }
    fails_with(
        &cpg(&[OsStr::new("evaluate"), "-m".as_ref(), model().as_os_str(), "--seconds".as_ref(), "1e18".as_ref()]),
        &["--seconds 1e18", "at most 86400"],
    );
    let o = cpg(&[OsStr::new("evaluate"), "-m".as_ref(), model().as_os_str(), "--seconds".as_ref(), "1.01".as_ref()]);
    let err = fails_with(&o, &["too short"]);
    assert!(!err.contains("NaN") && !String::from_utf8_lossy(&o.stdout).contains("NaN"));
    assert!(!out.exists());
}

#[test]
fn config_sizes_are_checked_before_anything_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "penalty_log10 = { start = 1, step = 0.1, stop = -8 }",
            "penalty_log10 = { start = 1, step = 1e-9, stop = -8 }",
            &["training.penalty_log10", "at most 1000"],
        ),
        ("noise_draws = 1\n", "noise_draws = 1000000000\n", &["training.noise_draws", "1 to 100"]),
        (
            "noise_draws = 1\n",
            "noise_draws = 1\nvalidation_samples = 1000000000\n",
            &["training.validation_samples", "1 to 2000000"],
        ),
        (
            "samples_per_segment = 2200",
            "samples_per_segment = 10000000000",
            &["data.samples_per_segment", "1 to 2000000"],
        ),
        ("rate_hz = 120 ", "rate_hz = 1e20 ", &["data.rate_hz", "expected 1 to 100000 Hz"]),
        ("rate_hz = 120 ", "rate_hz = 0.001 ", &["data.rate_hz", "expected 1 to 100000 Hz"]),
        (
            "washout = 200",
            "washout = 9223372036854775807\nvalidation_samples = 9223372036854775807",
            &["training.washout", "0 to 2000000"],
        ),
        ("long_run_s = 900 ", "long_run_s = 1e300 ", &["experiment.test.stability.long_run_s"]),
    ];
    for (k, (a, b, needles)) in cases.iter().enumerate() {
        let c = e1_config(dir.path(), &format!("c{k}.toml"), &[(a, b)]);
        let m = dir.path().join("m.cpg");
        let o = cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), m.as_os_str()]);
        let err = fails_with(&o, needles);
        assert!(err.contains(&format!("c{k}.toml")), "names the file: {err}");
        assert!(!err.contains("preparing the data"), "checked before the data is read: {err}");
        assert!(!m.exists());
    }
    // A size that passes the checks but not the memory budget: the estimate is given.
    let c = e1_config(dir.path(), "big.toml", &[("seed = 1\n", "seed = 1\nn_neurons = 20000\n")]);
    fails_with(
        &cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str()]),
        &["20000 neurons", "MiB", "the limit is 4096 MiB"],
    );
    // The same bounds hold with loop_cycles = 0 and the nmse score.
    let c = e1_config(
        dir.path(),
        "rec.toml",
        &[
            ("loop_cycles = 1 ", "loop_cycles = 0 "),
            ("washout = 200", "washout = 9223372036854775807\nvalidation_samples = 9223372036854775807"),
        ],
    );
    fails_with(&cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str()]), &["training.washout"]);
}

#[test]
fn extreme_finite_mocap_values_are_rejected_where_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let asf = std::fs::read_to_string(tiny("tiny.asf")).unwrap();
    let amc = std::fs::read_to_string(tiny("tiny.amc")).unwrap();
    let write = |name: &str, s: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, s).unwrap();
        p
    };
    let long = write("long.asf", asf.replacen("length 7.5", "length 1e308", 1));
    let unit = write("unit.asf", asf.replacen("length 0.45", "length 1e-308", 1));
    let root = write("root.amc", amc.replacen("root 1 2 3", "root 1e308 2 3", 1));
    let angle = write("angle.amc", amc.replacen("femur -10", "femur -1e308", 1));
    let out = dir.path().join("p.csv");
    let fk = |a: &Path, s: &Path| {
        cpg(&[OsStr::new("fk"), a.as_os_str(), "-s".as_ref(), s.as_os_str(), "-o".as_ref(), out.as_os_str()])
    };
    let line_of = |text: &str, pat: &str| text.lines().position(|l| l.contains(pat)).unwrap() + 1;
    fails_with(
        &fk(&tiny("tiny.amc"), &long),
        &[&format!("long.asf:{}:", line_of(&asf, "length 7.5")), "'1e308' is out of range", "within ±1000000"],
    );
    fails_with(
        &fk(&tiny("tiny.amc"), &unit),
        &[&format!("unit.asf:{}:", line_of(&asf, "length 0.45")), "at least 1e-6", "1e-308"],
    );
    fails_with(&fk(&root, &tiny("tiny.asf")), &["root.amc:5:6", "'1e308' is out of range"]);
    fails_with(&fk(&angle, &tiny("tiny.asf")), &["angle.amc:6:7", "'-1e308' is out of range"]);
    assert!(!out.exists());
}

#[test]
fn divergence_fails_training_unless_allowed_and_generate_warns() {
    let dir = tempfile::tempdir().unwrap();
    let c = e1_config(
        dir.path(),
        "div.toml",
        &[
            ("seed = 1\n", "seed = 1\nspectral_radius = 1.6\nfeedback = { fraction = 1, scale = 1.5 }\n"),
            (
                "penalty_log10 = { start = 1, step = 0.1, stop = -8 }",
                "penalty_log10 = { start = -7, step = 0.5, stop = -8 }",
            ),
            ("teacher_noise = 0.1 ", "teacher_noise = 0 "),
            ("score = \"orbit\"", "score = \"nmse\""),
            ("[training.orbit]", "[experiment.note]"),
        ],
    );
    // [training.orbit]'s lines now sit in an unknown table: drop them.
    let text = std::fs::read_to_string(&c).unwrap();
    let kept: Vec<&str> = {
        let mut skip = false;
        text.lines()
            .filter(|l| {
                if l.starts_with('[') {
                    skip = *l == "[experiment.note]";
                }
                !skip
            })
            .collect()
    };
    std::fs::write(&c, kept.join("\n")).unwrap();
    let m = dir.path().join("div.cpg");
    let o = cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), m.as_os_str()]);
    fails_with(
        &o,
        &["the best validation score is", "worse than 1", "Nothing was written", "--allow-unstable", "cpg tune"],
    );
    assert!(!m.exists());
    let o = cpg(&[
        OsStr::new("train"),
        "-c".as_ref(),
        c.as_os_str(),
        "-o".as_ref(),
        m.as_os_str(),
        "--allow-unstable".as_ref(),
    ]);
    assert!(o.status.success() && stderr(&o).contains("written anyway (--allow-unstable)"), "{}", stderr(&o));
    let o = cpg(&[
        OsStr::new("generate"),
        "-m".as_ref(),
        m.as_os_str(),
        "--seconds".as_ref(),
        "30".as_ref(),
        "-o".as_ref(),
        "/dev/null".as_ref(),
    ]);
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("warning: lfemur.rx spans") && stderr(&o).contains("beyond the training data's"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn messages_are_short_clear_and_said_once() {
    let dir = tempfile::tempdir().unwrap();
    // An I/O error is said once.
    let none = dir.path().join("none.cpg");
    let err = fails_with(
        &cpg(&[OsStr::new("generate"), "-m".as_ref(), none.as_os_str(), "-o".as_ref(), "-".as_ref()]),
        &["none.cpg", "No such file or directory"],
    );
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    // A 5 MB bad token is quoted shortened.
    let asf = std::fs::read_to_string(tiny("tiny.asf")).unwrap();
    let huge = dir.path().join("huge.asf");
    std::fs::write(&huge, asf.replacen("length 7.5", &format!("length 7{}", "x".repeat(5_000_000)), 1)).unwrap();
    let err = fails_with(&cpg(&[OsStr::new("inspect"), huge.as_os_str()]), &["huge.asf", "bytes in all"]);
    assert!(err.len() < 400, "{} bytes", err.len());
    // A UTF-8 byte-order mark is accepted (ASF and config).
    let bom = dir.path().join("bom.asf");
    std::fs::write(&bom, format!("\u{feff}{asf}")).unwrap();
    let o = cpg(&[OsStr::new("inspect"), bom.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let c = e1_config(dir.path(), "bom.toml", &[("# E1", "\u{feff}# E1")]);
    let o = cpg(&[
        OsStr::new("tune"),
        "-c".as_ref(),
        c.as_os_str(),
        "--budget".as_ref(),
        "0".as_ref(),
        "-o".as_ref(),
        dir.path().as_os_str(),
    ]);
    let err = stderr(&o);
    assert!(
        err.contains("is a directory") && !err.contains('\u{feff}'),
        "the config parsed, the output was refused: {err}"
    );
    // An unwritable output is found before training.
    let file = dir.path().join("plain");
    std::fs::write(&file, "").unwrap();
    let c = e1_config(dir.path(), "e1.toml", &[]);
    let err = fails_with(
        &cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), file.join("m.cpg").as_os_str()]),
        &["plain"],
    );
    assert!(!err.contains("training a"), "{err}");
    // A corrupt payload is described in words, not as a Rust value.
    let bytes = std::fs::read(model()).unwrap();
    let cut = cpg_reservoir::TrainedCpg::frame_payload(&bytes[28..bytes.len() - 100]);
    let bad = dir.path().join("cut.cpg");
    std::fs::write(&bad, cut).unwrap();
    let err = fails_with(
        &cpg(&[OsStr::new("generate"), "-m".as_ref(), bad.as_os_str(), "-o".as_ref(), "-".as_ref()]),
        &["cut.cpg", "corrupt payload"],
    );
    assert!(!err.contains('{') && !err.contains("UnexpectedEnd"), "{err}");
    // A control name that a --control-file header could never match is refused.
    let c = e1_config(
        dir.path(),
        "ctl.toml",
        &[("channels = [\"lfemur.rx\"]", "channels = [\"lfemur.rx\"]\ncontrols = [\"speed,gait\"]")],
    );
    fails_with(&cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str()]), &["data.controls[0]", "without commas"]);
}

// Round three of the audit: what the simulator era's surfaces and a new user hit first.

/// A URDF nested 20,000 elements deep overflowed the stack; it is refused
/// with the file and the line where the nesting passes the bound.
#[test]
fn a_deeply_nested_urdf_is_refused_not_a_stack_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("deep.urdf");
    std::fs::write(
        &urdf,
        format!("<robot name=\"r\">\n{}{}</robot>", "<link name=\"a\">".repeat(20_000), "</link>".repeat(20_000)),
    )
    .unwrap();
    let out = dir.path().join("h.csv");
    let o = cpg(&[
        OsStr::new("hoap2"),
        "--model".as_ref(),
        model().as_os_str(),
        "--urdf".as_ref(),
        urdf.as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    fails_with(&o, &["deep.urdf", "line 2", "nested more than 64 deep"]);
    assert!(!out.exists());
}

/// An ASF of 100,000 bones parsed for minutes (no cap, a quadratic check);
/// the bone past the cap is refused where it is.
#[test]
fn an_asf_beyond_the_bone_cap_is_refused_where_it_passes_it() {
    let dir = tempfile::tempdir().unwrap();
    let asf = dir.path().join("big.asf");
    let mut s = String::from(
        ":version 1.10\n:name big\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n:bonedata\n",
    );
    for i in 0..100_000 {
        s.push_str(&format!(
            "  begin\n    id {}\n    name b{i}\n    direction 0 1 0\n    length 1\n    axis 0 0 0 XYZ\n  end\n",
            i + 1
        ));
    }
    std::fs::write(&asf, s).unwrap();
    fails_with(&cpg(&[OsStr::new("inspect"), asf.as_os_str()]), &["big.asf:70013", "at most 10000 bones"]);
}

/// `cpg view --seconds 86400` computed three minutes of free run before
/// refusing the page's size; it is refused first, saying how long a page of
/// this model can be.
#[test]
fn a_page_too_long_is_refused_before_the_free_run_saying_how_long_one_can_be() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.html");
    let o = cpg(&[
        OsStr::new("view"),
        "--model".as_ref(),
        model().as_os_str(),
        "--seconds".as_ref(),
        "86400".as_ref(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    fails_with(&o, &["86400 s", "at most", "s of this model"]);
    assert!(!out.exists());
}

/// Control lines faster than the ticks (`yes 1,0 | cpg stream --rate-hz 1`)
/// were queued without bound (gigabytes, ticks late by tens of seconds):
/// only the newest values are kept, and the report says how many were replaced.
#[test]
fn stream_keeps_only_the_newest_controls_in_bounded_memory() {
    use std::io::Write;
    // A small model with one control input, `u`.
    let dir = tempfile::tempdir().unwrap();
    let with_u = [
        ("channels = [\"lfemur.rx\"]", "channels = [\"lfemur.rx\"]\ncontrols = [\"u\"]"),
        ("label = \"walk (35_01)\"", "label = \"walk (35_01)\"\ncontrols = [1.0]"),
    ];
    let c = e1_config(dir.path(), "u.toml", &[&with_u[..], &SMALL[..]].concat());
    let m = dir.path().join("u.cpg");
    let o = cpg(&[
        OsStr::new("train"),
        "-c".as_ref(),
        c.as_os_str(),
        "-o".as_ref(),
        m.as_os_str(),
        "--allow-unstable".as_ref(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut child = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([OsStr::new("stream"), "--model".as_ref(), m.as_os_str(), "--rate-hz".as_ref(), "2".as_ref()])
        .args(["--seconds", "3"])
        .env("CPG_REPORT_PEAK_RSS", "1")
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || {
        let chunk = "u=1\n".repeat(4096);
        while stdin.write_all(chunk.as_bytes()).is_ok() {}
    });
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(String::from_utf8_lossy(&o.stdout).lines().count(), 1 + 6, "a header and one line per tick");
    let peak_mb: f64 = err
        .lines()
        .find_map(|l| l.split("peak resident memory: ").nth(1))
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no peak memory line in: {err}"));
    assert!(peak_mb < 64.0, "{peak_mb} MB: {err}");
    assert!(err.contains("control line(s) were replaced by newer ones"), "{err}");
}

/// `cpg generate -o - | head` said "error: -: Broken pipe" and exited 2; a
/// reader that has gone is not an error.
#[test]
fn a_closed_pipe_ends_quietly() {
    use std::io::BufRead;
    for args in [
        vec![OsStr::new("generate"), "-m".as_ref(), model().as_os_str(), "--seconds".as_ref(), "600".as_ref()],
        vec![
            OsStr::new("fk"),
            cmu("35_01.amc").into_os_string().leak(),
            "--skeleton".as_ref(),
            cmu("35.asf").into_os_string().leak(),
        ],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_cpg"))
            .args(&args)
            .args(["-o", "-"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let mut first = String::new();
        std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
        assert!(!first.is_empty());
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        assert!(o.status.success() && !err.contains("error"), "{args:?}: exit {:?}: {err}", o.status.code());
    }
}

/// A misspelt channel gets the closest name as a hint.
#[test]
fn a_misspelt_channel_gets_the_closest_name() {
    let dir = tempfile::tempdir().unwrap();
    let c = e1_config(dir.path(), "typo.toml", &[("channels = [\"lfemur.rx\"]", "channels = [\"lfemr.rx\"]")]);
    let o =
        cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), dir.path().join("m.cpg").as_os_str()]);
    fails_with(&o, &["'lfemr.rx' is not a channel of the motion (did you mean 'lfemur.rx'?)"]);
}

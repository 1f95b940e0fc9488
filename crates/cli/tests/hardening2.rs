//! The defects of the second hardening audit (BVH, `cpg stream`, `cpg view`
//! and the outputs): each case once aborted, lost input, wrote the wrong
//! thing or said something false, and now does the right thing.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use cpg_mocap::data::{Subject, find};

fn cmu(file: &str) -> PathBuf {
    find(Subject::S35, file).unwrap_or_else(|e| panic!("{e}"))
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cpg<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cpg")).args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

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

/// A BVH figure of a hip and two legs, `frames` frames long, in centimetres.
fn bvh(frames: usize, newline: &str, frame_time: &str) -> String {
    let mut s = [
        "HIERARCHY",
        "ROOT Hips",
        "{",
        "  OFFSET 0 0 0",
        "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "  JOINT LeftUpLeg",
        "  {",
        "    OFFSET 10 -90 0",
        "    CHANNELS 3 Zrotation Xrotation Yrotation",
        "    End Site",
        "    {",
        "      OFFSET 0 -90 0",
        "    }",
        "  }",
        "  JOINT RightUpLeg",
        "  {",
        "    OFFSET -10 -90 0",
        "    CHANNELS 3 Zrotation Xrotation Yrotation",
        "    End Site",
        "    {",
        "      OFFSET 0 -90 0",
        "    }",
        "  }",
        "}",
        "MOTION",
    ]
    .join(newline);
    s.push_str(newline);
    s.push_str(&format!("Frames: {frames}{newline}{frame_time}{newline}"));
    for k in 0..frames {
        let a = (k % 120) as f64 * 0.5;
        s.push_str(&format!("0.00 180.00 {k}.00 0.00 0.00 0.00 0.00 {a:.2} 0.00 0.00 {:.2} 0.00{newline}", -a));
    }
    s
}

/// A BVH of many frames is read in memory within three times its decoded
/// values (the lexer once kept about 25 times the file's size).
#[test]
fn a_large_bvh_is_read_within_three_times_its_decoded_values() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("long.bvh");
    let frames = 400_000;
    std::fs::write(&p, bvh(frames, "\n", "Frame Time: 0.00833333")).unwrap();
    let file_mib = std::fs::metadata(&p).unwrap().len() as f64 / (1 << 20) as f64;
    let decoded_mib = (frames * 12 * 8) as f64 / (1 << 20) as f64;
    let o = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([OsStr::new("inspect"), p.as_os_str()])
        .env("CPG_REPORT_PEAK_RSS", "1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let peak = cpg_lab::memory::parse_report(&stderr(&o)).expect("the peak is reported");
    // What a process of cpg holds before reading anything (the binary, the allocator).
    let base = {
        let o =
            Command::new(env!("CARGO_BIN_EXE_cpg")).arg("--version").env("CPG_REPORT_PEAK_RSS", "1").output().unwrap();
        cpg_lab::memory::parse_report(&stderr(&o)).unwrap_or(0.0)
    };
    assert!(
        peak - base <= 3.0 * decoded_mib,
        "{file_mib:.1} MiB of BVH, {decoded_mib:.1} MiB of values: peak {peak:.1} MiB ({base:.1} MiB at rest)"
    );
}

/// Classic Mac line endings get a hint; `Frame Time:0.0083` reads as `Frames:240` does.
#[test]
fn bvh_headers_and_line_endings_say_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let cr = dir.path().join("cr.bvh");
    std::fs::write(&cr, bvh(10, "\r", "Frame Time: 0.00833333")).unwrap();
    fails_with(&cpg(&[OsStr::new("inspect"), cr.as_os_str()]), &["carriage return alone", "LF or CRLF"]);
    let joined = dir.path().join("joined.bvh");
    std::fs::write(&joined, bvh(10, "\n", "Frame Time:0.00833333")).unwrap();
    let o = cpg(&[OsStr::new("inspect"), joined.as_os_str()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let crlf = dir.path().join("crlf.bvh");
    std::fs::write(&crlf, bvh(10, "\r\n", "Frame Time: 0.00833333")).unwrap();
    assert!(cpg(&[OsStr::new("inspect"), crlf.as_os_str()]).status.success());
}

/// `-o` into a directory that does not exist is an error, and nothing is created.
#[test]
fn an_output_in_a_missing_directory_is_refused_and_nothing_is_created() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("no/such/dir/points.csv");
    let o = cpg(&[
        OsStr::new("fk"),
        cmu("35_01.amc").as_os_str(),
        "--skeleton".as_ref(),
        cmu("35.asf").as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
    ]);
    fails_with(&o, &["does not exist"]);
    assert!(!dir.path().join("no").exists(), "a directory was created");
}

/// An extension that names another format is refused, not written in the wrong one.
#[test]
fn an_extension_that_names_another_format_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let fk = |out: &Path| {
        cpg(&[
            OsStr::new("fk"),
            cmu("35_01.amc").as_os_str(),
            "--skeleton".as_ref(),
            cmu("35.asf").as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ])
    };
    fails_with(&fk(&dir.path().join("points.gif")), &[".gif", "csv, npy"]);
    assert!(!dir.path().join("points.gif").exists());
    assert!(fk(&dir.path().join("points.dat")).status.success(), "an extension that names no format is the user's");
    let model = dir.path().join("m.cpg");
    let o = cpg(&[
        OsStr::new("train"),
        "-c".as_ref(),
        repo().join("examples/walk22.toml").as_os_str(),
        "-o".as_ref(),
        model.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = cpg(&[
        OsStr::new("view"),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "-o".as_ref(),
        dir.path().join("x.npy").as_os_str(),
    ]);
    fails_with(&o, &[".npy", "html, gif"]);
    let o = cpg(&[
        OsStr::new("generate"),
        "-m".as_ref(),
        model.as_os_str(),
        "--seconds".as_ref(),
        "1".as_ref(),
        "--format".as_ref(),
        "csv".as_ref(),
        "-o".as_ref(),
        dir.path().join("x.amc").as_os_str(),
    ]);
    fails_with(&o, &[".amc", "csv"]);
}

/// Control characters in a name reach the terminal escaped.
#[test]
fn control_characters_in_names_are_escaped_in_messages() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("evil\u{1b}[2J\u{7}.amc");
    std::fs::write(&p, b"garbage").unwrap();
    let o = cpg(&[OsStr::new("inspect"), p.as_os_str(), "--skeleton".as_ref(), cmu("35.asf").as_os_str()]);
    let err = stderr(&o);
    assert!(!err.contains('\u{1b}') && !err.contains('\u{7}'), "raw control bytes: {err:?}");
    assert!(err.contains("\\u{1b}"), "{err}");
}

fn e5_model(dir: &Path) -> PathBuf {
    let model = dir.join("e5.cpg");
    let mut s = std::fs::read_to_string(repo().join("experiments/e5-extension.toml")).unwrap();
    for f in ["35.asf", "35_01.amc", "35_17.amc"] {
        s = s.replace(&format!("../data/cmu35/{f}"), &cmu(f).display().to_string());
    }
    s = s.replace("n_neurons = 600", "n_neurons = 100").replace("../assets/", &format!("{}/assets/", repo().display()));
    let c = dir.join("e5.toml");
    std::fs::write(&c, s).unwrap();
    let o = cpg(&[
        OsStr::new("train"),
        "-c".as_ref(),
        c.as_os_str(),
        "-o".as_ref(),
        model.as_os_str(),
        "--allow-unstable".as_ref(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    model
}

/// An endless line on standard input is skipped in bounded memory, a line
/// that is not UTF-8 is reported, and the lines after both still apply.
#[test]
fn stream_skips_endless_and_binary_lines_and_keeps_reading() {
    let dir = tempfile::tempdir().unwrap();
    let model = e5_model(dir.path());
    let mut child = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([
            OsStr::new("stream"),
            "-m".as_ref(),
            model.as_os_str(),
            "--no-pacing".as_ref(),
            "--rate-hz".as_ref(),
            "120".as_ref(),
        ])
        .env("CPG_REPORT_PEAK_RSS", "1")
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut sin = child.stdin.take().unwrap();
        sin.write_all(&vec![b'0'; 64 << 20]).unwrap();
        sin.write_all(b"\n\xff\xfe u_walk=0\nnot=numbers\nu_walk=0 u_run=1\n").unwrap();
    }
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("line 1:") && err.contains("longer than 4096"), "{err}");
    assert!(err.contains("line 2: not UTF-8"), "{err}");
    assert!(err.contains("line 3:"), "a bad control line is reported: {err}");
    assert!(!err.contains("line 4:"), "the last line applies: {err}");
    let peak = cpg_lab::memory::parse_report(&err).expect("the peak is reported");
    assert!(peak < 48.0, "a 64 MiB line was held in memory: peak {peak} MiB");
}

/// SIGTERM while streaming: what went out is said, then the lateness report.
#[test]
fn an_interrupted_stream_says_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let model = e5_model(dir.path());
    let out = dir.path().join("out.csv");
    let child = Command::new(env!("CARGO_BIN_EXE_cpg"))
        .args([OsStr::new("stream"), "-m".as_ref(), model.as_os_str(), "--rate-hz".as_ref(), "1000".as_ref()])
        .stdin(Stdio::piped())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    let lines = std::fs::read_to_string(&out).unwrap().lines().count() - 1;
    assert!(lines > 100, "{lines} lines: {err}");
    assert!(!err.contains("nothing was written"), "{err}");
    assert!(
        err.contains(&format!("interrupted: {lines} line(s) of commands went to standard output")),
        "{lines}: {err}"
    );
    assert!(err.contains("lateness"), "the lateness report follows: {err}");
    assert_eq!(o.status.code(), Some(130));
}

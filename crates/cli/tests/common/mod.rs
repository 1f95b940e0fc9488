//! Helpers shared by the integration tests that run `cpg` from the repository root.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)] // each test binary uses a part; tests fail loudly

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The workspace root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A subject-35 file (fetched by `cargo xtask test`).
pub fn cmu(file: &str) -> PathBuf {
    cpg_mocap::data::find(cpg_mocap::data::Subject::S35, file).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `cpg` in the workspace root.
pub fn cpg<S: AsRef<OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cpg")).args(args).current_dir(repo()).output().unwrap()
}

/// Standard error of a run that must have succeeded.
pub fn ok(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "failed: {err}");
    err
}

/// examples/walk22.toml trained once per test binary: 22 channels of a walk,
/// mapped to the HOAP-2's 22 arm and leg joints.
pub fn walk22() -> &'static Path {
    static M: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &M.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("walk22.cpg");
        let c = repo().join("examples/walk22.toml");
        ok(&cpg(&[OsStr::new("train"), "-c".as_ref(), c.as_os_str(), "-o".as_ref(), model.as_os_str()]));
        (dir, model)
    })
    .1
}

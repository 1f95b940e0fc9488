//! Shared helpers for the end-to-end tests: where the CMU files are and what
//! the project manifest says about them. A missing file is a test failure,
//! never a skip: run `cargo xtask fetch-data` first (the README's test command does).

#![allow(clippy::expect_used, clippy::unwrap_used, clippy::panic)] // test support code: failing loudly is the point

use std::path::{Path, PathBuf};

use cpg_mocap::data::{self, Subject};
use cpg_mocap::{Motion, Skeleton};

/// CMU capture rate.
pub const CMU_RATE_HZ: f64 = 120.0;

/// One row of `data/cmu*/MANIFEST.tsv`.
#[derive(Debug, Clone)]
pub struct ManifestEntry {
    /// Path relative to the subject directory.
    pub file: String,
    /// Size in bytes, when known.
    pub bytes: Option<u64>,
    /// SHA-256, when known.
    pub sha256: Option<String>,
    /// Frame count, for AMC files.
    pub frames: Option<usize>,
    /// `official` or `unverified`.
    pub status: String,
}

/// The workspace root.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Reads a subject's manifest from the repository.
pub fn manifest(subject: Subject) -> Vec<ManifestEntry> {
    let dir = match subject {
        Subject::S35 => "data/cmu35",
        Subject::S86 => "data/cmu86",
        Subject::OtherBvh => "data/cmu-bvh",
    };
    let text = std::fs::read_to_string(workspace_root().join(dir).join("MANIFEST.tsv")).expect("manifest");
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("file\t") && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let opt = |s: &str| (s != "-").then(|| s.to_owned());
            ManifestEntry {
                file: f[0].to_owned(),
                bytes: opt(f[1]).map(|s| s.parse().expect("bytes")),
                sha256: opt(f[2]),
                frames: opt(f[3]).map(|s| s.parse().expect("frames")),
                status: f[4].to_owned(),
            }
        })
        .collect()
}

/// Path of a subject-35 file; panics with the places searched when it is missing.
pub fn cmu35(file: &str) -> PathBuf {
    data::find(Subject::S35, file).unwrap_or_else(|e| panic!("{e}"))
}

/// The subject-35 skeleton.
pub fn skeleton35() -> Skeleton {
    Skeleton::from_file(cmu35("35.asf")).unwrap_or_else(|e| panic!("{e}"))
}

/// A subject-35 trial at 120 Hz.
pub fn motion35(skeleton: &Skeleton, file: &str) -> Motion {
    Motion::from_amc_file(cmu35(file), skeleton, CMU_RATE_HZ).unwrap_or_else(|e| panic!("{e}"))
}

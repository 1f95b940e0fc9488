//! Finding the CMU data files at run time.
//!
//! The motion files are never part of the repository. They are looked up, in
//! order, in `$CPG_DATA_DIR`, then in `data/cmu35/` (or `data/cmu86/`) in the
//! current directory and in each of its ancestors, the way git finds `.git`:
//! from anywhere inside a checkout whose `data/` has been filled (`cargo xtask
//! fetch-data`), the files are found. The first directory that holds the
//! requested file wins. This crate knows nothing else about where a checkout is.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// A CMU subject whose files the project knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Subject {
    /// Subject 35: walking and running.
    S35,
    /// Subject 86: long multi-activity sequences.
    S86,
    /// Other people (CMU subjects 07, 09 and 16) in BVH: walks and a run.
    OtherBvh,
}

impl Subject {
    /// The directory name under `data/`: `cmu35`, `cmu86`, `cmu-bvh`.
    pub fn dir_name(self) -> &'static str {
        match self {
            Subject::S35 => "cmu35",
            Subject::S86 => "cmu86",
            Subject::OtherBvh => "cmu-bvh",
        }
    }
}

/// Directories searched for a subject's files, in order.
pub fn search_dirs(subject: Subject) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    if let Some(d) = std::env::var_os("CPG_DATA_DIR") {
        dirs.push(PathBuf::from(d));
    }
    if let Ok(cwd) = std::env::current_dir() {
        dirs.extend(cwd.ancestors().map(|a| a.join("data").join(subject.dir_name())));
    }
    dirs
}

/// Finds one file of a subject (`35_01.amc`, `35.asf`, `partial/35_14.amc`).
pub fn find(subject: Subject, file: &str) -> Result<PathBuf> {
    find_in(&search_dirs(subject), file)
}

/// Finds `file` in the first of `dirs` that holds it.
pub fn find_in(dirs: &[PathBuf], file: &str) -> Result<PathBuf> {
    for d in dirs {
        let p = d.join(file);
        if p.is_file() {
            return Ok(clean(&p));
        }
    }
    Err(Error::DataNotFound {
        what: format!("CMU file '{file}' (run `cargo xtask fetch-data` or set CPG_DATA_DIR)"),
        tried: dirs.iter().map(|d| clean(&d.join(file))).collect(),
    })
}

fn clean(p: &Path) -> PathBuf {
    p.canonicalize().unwrap_or_else(|_| p.to_owned())
}

//! Finding the CMU data files at run time.
//!
//! The motion files are never part of the repository. They are looked up, in
//! order, in `$CPG_DATA_DIR`, in `data/cmu35/` (relative to the working
//! directory, then to the workspace root), and in `../shared/data/cmu/35`
//! (the read-only share beside the project). The first directory that holds
//! the requested file wins.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// A CMU subject whose files the project knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Subject {
    /// Subject 35: walking and running.
    S35,
    /// Subject 86: long multi-activity sequences.
    S86,
}

impl Subject {
    fn dirs(self) -> (&'static str, &'static str) {
        match self {
            Subject::S35 => ("data/cmu35", "../shared/data/cmu/35"),
            Subject::S86 => ("data/cmu86", "../shared/data/cmu/86"),
        }
    }
}

/// Directories searched for a subject's files, in order.
pub fn search_dirs(subject: Subject) -> Vec<PathBuf> {
    let (local, shared) = subject.dirs();
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut dirs = Vec::new();
    if let Some(d) = std::env::var_os("CPG_DATA_DIR") {
        dirs.push(PathBuf::from(d));
    }
    dirs.push(PathBuf::from(local));
    dirs.push(workspace.join(local));
    dirs.push(PathBuf::from(shared));
    dirs.push(workspace.join(shared));
    dirs
}

/// Finds one file of a subject (`35_01.amc`, `35.asf`, `partial/35_14.amc`).
pub fn find(subject: Subject, file: &str) -> Result<PathBuf> {
    let dirs = search_dirs(subject);
    for d in &dirs {
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

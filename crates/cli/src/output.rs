//! Where output goes, and writing it without ever destroying what is there.
//!
//! - `-` is standard output.
//! - A regular file (or a new path) is written atomically: a temporary file
//!   beside it (`.NAME.PID.tmp`), then a rename, so the path holds either the
//!   old file or the complete new one.
//! - A symlink is followed (up to 40 links) and its target written atomically;
//!   the link itself stays.
//! - A device, FIFO or socket is written in place, never replaced; so is a
//!   path through /dev or /proc (`/dev/stdout`, `/proc/self/fd/1`), appending.
//! - A directory is refused.
//!
//! Temporary files are registered while they exist: SIGINT and SIGTERM remove
//! them before the process exits (see [`install_signal_cleanup`]), and a later
//! write to the same path removes those of processes that no longer run.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, bail};

/// Temporary files being written right now.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// On SIGINT or SIGTERM, removes every temporary file being written, then
/// exits with status 130.
pub fn install_signal_cleanup() {
    // If a handler cannot be installed, writing still works; only the cleanup is lost.
    let _ = ctrlc::set_handler(|| {
        for tmp in pending().drain(..) {
            let _ = std::fs::remove_file(tmp);
        }
        eprintln!("interrupted: nothing was written");
        std::process::exit(130);
    });
}

/// What an output path names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Destination {
    /// `-`.
    Stdout,
    /// A device, FIFO or socket: written in place.
    InPlace(PathBuf),
    /// A regular file or a new one (symlinks resolved): written atomically.
    File(PathBuf),
}

impl Destination {
    /// Resolves `path`, following symlinks, and refuses directories.
    pub fn of(path: &Path) -> anyhow::Result<Destination> {
        if path.as_os_str() == "-" {
            return Ok(Destination::Stdout);
        }
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => bail!("{} is a directory: give a file name", path.display()),
            Ok(m) if !m.is_file() => Ok(Destination::InPlace(path.to_owned())),
            // /dev/stdout, /proc/self/fd/N and the like name open files: write through them.
            Ok(_) if through_dev_or_proc(path) => Ok(Destination::InPlace(path.to_owned())),
            Ok(_) => Ok(Destination::File(
                std::fs::canonicalize(path).with_context(|| format!("resolving {}", path.display()))?,
            )),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Destination::File(dangling_target(path)?)),
            Err(e) => Err(e).with_context(|| format!("looking at {}", path.display())),
        }
    }

    /// How messages name it.
    pub fn describe(&self) -> String {
        match self {
            Destination::Stdout => "standard output".into(),
            Destination::InPlace(p) | Destination::File(p) => p.display().to_string(),
        }
    }
}

/// Fails early, before long work, when `path` cannot be written: a
/// directory, or a file whose directory cannot be created or written.
pub fn check_writable(path: &Path) -> anyhow::Result<Destination> {
    let d = Destination::of(path)?;
    if let Destination::File(p) = &d {
        let dir = parent(p);
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let probe = dir.join(format!(".cpg-write-test.{}", std::process::id()));
        std::fs::File::create(&probe).with_context(|| format!("{} is not writable", dir.display()))?;
        let _ = std::fs::remove_file(&probe);
    }
    Ok(d)
}

/// Whether `path`, or a link on the way to its target, lies under /dev or /proc.
fn through_dev_or_proc(path: &Path) -> bool {
    let special = |p: &Path| p.starts_with("/dev") || p.starts_with("/proc");
    let mut p = path.to_owned();
    for _ in 0..40 {
        if special(&p) {
            return true;
        }
        match std::fs::read_link(&p) {
            Ok(target) => {
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                }
            }
            Err(_) => return false,
        }
    }
    false
}

/// Where a path that does not exist yet will be created: itself, or, for a
/// symlink whose target is missing, that target (links followed up to 40 deep).
fn dangling_target(path: &Path) -> anyhow::Result<PathBuf> {
    let mut p = path.to_owned();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&p).with_context(|| format!("reading the link {}", p.display()))?;
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    bail!("{}: more than 40 symbolic links in a chain", path.display())
}

fn parent(p: &Path) -> &Path {
    p.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Writes `fill`'s output to `path` as the module docs describe.
pub fn write_output(path: &Path, fill: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>) -> anyhow::Result<()> {
    match Destination::of(path)? {
        Destination::Stdout => {
            let out = std::io::stdout();
            let mut w = std::io::BufWriter::new(out.lock());
            fill(&mut w)?;
            w.flush()?;
            Ok(())
        }
        Destination::InPlace(p) => {
            let f = std::fs::OpenOptions::new()
                .append(true)
                .open(&p)
                .with_context(|| format!("opening {}", p.display()))?;
            let mut w = std::io::BufWriter::new(f);
            fill(&mut w)?;
            w.flush().with_context(|| format!("writing {}", p.display()))
        }
        Destination::File(p) => write_atomic(&p, fill),
    }
}

/// Writes a regular file atomically (see the module docs).
fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let dir = parent(path);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    remove_stale(dir, &name);
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    pending().push(tmp.clone());
    let result = (|| {
        let f = std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
        let mut w = std::io::BufWriter::new(f);
        fill(&mut w)?;
        let f = w.into_inner().map_err(|e| e.into_error()).with_context(|| format!("writing {}", tmp.display()))?;
        f.sync_all().with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    pending().retain(|p| p != &tmp);
    result
}

/// Removes `.NAME.PID.tmp` files beside `NAME` whose process no longer runs
/// (Linux: no `/proc/PID`; elsewhere nothing is removed).
fn remove_stale(dir: &Path, name: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let prefix = format!(".{name}.");
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(pid) = file.to_str().and_then(|f| f.strip_prefix(&prefix)).and_then(|r| r.strip_suffix(".tmp")) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else { continue };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

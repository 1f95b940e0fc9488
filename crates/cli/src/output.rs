//! Where output goes: `cpg_io`'s destinations (`-` is standard output, files
//! atomically, symlinks' targets, devices and FIFOs in place, directories
//! and missing directories refused), plus what the program does on SIGINT
//! and SIGTERM.
//!
//! On a signal, temporary files being written are removed. A command that
//! has already sent output somewhere (`cpg stream`) registers itself with
//! [`interruptible`]: the signal then only raises [`interrupted`], and the
//! command ends as it would at its last tick, saying what it wrote.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

pub use cpg_io::Destination;

/// Set by a signal while a command that ends by itself is running.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// A command that ends by itself on a signal is running.
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// On SIGINT or SIGTERM: when a command registered with [`interruptible`]
/// runs, tells it to stop; otherwise removes every temporary file being
/// written, says so, and exits with status 130.
pub fn install_signal_cleanup() {
    // If a handler cannot be installed, writing still works; only the cleanup is lost.
    let _ = ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) {
            INTERRUPTED.store(true, Ordering::SeqCst);
            return;
        }
        let removed = cpg_io::pending_temporaries();
        for tmp in &removed {
            let _ = std::fs::remove_file(tmp);
        }
        eprintln!(
            "interrupted: {}",
            if removed.is_empty() {
                "no file was being written".to_owned()
            } else {
                format!("{} unfinished file(s) removed, the old ones left as they were", removed.len())
            }
        );
        std::process::exit(130);
    });
}

/// From now on a signal stops the running command through [`interrupted`] instead of exiting.
pub fn interruptible() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// A signal arrived while an [`interruptible`] command ran.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Fails early, before long work, when `path` cannot be written.
pub fn check_writable(path: &Path) -> anyhow::Result<Destination> {
    Ok(cpg_io::check_writable(path)?)
}

/// Writes `fill`'s output to `path` as `cpg_io::write_output` does.
pub fn write_output(path: &Path, fill: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>) -> anyhow::Result<()> {
    cpg_io::write_output(path, fill)
}

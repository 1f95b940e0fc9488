//! # cpg-io
//!
//! Reading and writing files without surprises, for every crate of cpg:
//!
//! - [`read_bounded`] reads at most a stated number of bytes, whatever the
//!   file's metadata says (`/dev/zero` and a growing pipe are refused at the
//!   bound, not after filling the memory).
//! - [`write_output`] writes where an output path points: `-` is standard
//!   output; a regular file (or a new path) is written atomically, to a
//!   temporary file beside it (`.NAME.PID.tmp`) renamed over it, so the path
//!   holds either the old file or the whole new one; a symlink is followed
//!   (up to 40 links) and its target written, the link kept; a device, FIFO
//!   or socket, or a path through /dev or /proc (`/dev/stdout`), is written
//!   in place, never replaced; a directory is refused, and so is a path whose
//!   directory does not exist (nothing is created on the way).
//! - [`write_file`] is the same for bytes that must land in a regular file
//!   (model files): a device or FIFO there is refused too.
//!
//! Temporary files are registered while they exist ([`pending_temporaries`]):
//! a program's signal handler removes them before it exits, and a later write
//! to the same path removes those of processes that no longer run (Linux).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What can go wrong.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The system refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// More bytes than allowed.
    #[error("{}: larger than {max_bytes} bytes, the most this program reads from such a file", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The bound.
        max_bytes: u64,
    },
    /// The path cannot be written as asked.
    #[error("{}: {reason}", path.display())]
    NotWritable {
        /// The path.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// The crate's result.
pub type Result<T> = std::result::Result<T, Error>;

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io { path: path.to_owned(), source }
}

/// Reads `path` whole, refusing it as soon as it holds more than `max_bytes`.
pub fn read_bounded(path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(io(path))?;
    read_bounded_from(file, path, max_bytes)
}

/// [`read_bounded`] on an open reader; `path` names it in errors.
pub fn read_bounded_from(r: impl Read, path: &Path, max_bytes: u64) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    r.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes).map_err(io(path))?;
    if bytes.len() as u64 > max_bytes {
        return Err(Error::TooLarge { path: path.to_owned(), max_bytes });
    }
    Ok(bytes)
}

/// Reads exactly `n` bytes of `r`, or fails naming `path` (for a length a header declares).
pub fn read_exact_bytes(r: &mut impl Read, path: &Path, n: usize) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let got = r.take(n as u64).read_to_end(&mut bytes).map_err(io(path))?;
    if got < n {
        return Err(Error::Io {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::UnexpectedEof, format!("{got} of {n} bytes")),
        });
    }
    Ok(bytes)
}

/// Temporary files being written right now.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// The temporary files being written now, removed from the registry: what a
/// signal handler deletes before the program exits.
pub fn pending_temporaries() -> Vec<PathBuf> {
    pending().drain(..).collect()
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
    /// Resolves `path`, following symlinks; refuses a directory and a path
    /// whose directory does not exist.
    pub fn of(path: &Path) -> Result<Destination> {
        if path.as_os_str() == "-" {
            return Ok(Destination::Stdout);
        }
        let refuse = |reason: &str| Err(Error::NotWritable { path: path.to_owned(), reason: reason.into() });
        match std::fs::metadata(path) {
            Ok(m) if m.is_dir() => refuse("is a directory: give a file name"),
            Ok(m) if !m.is_file() => Ok(Destination::InPlace(path.to_owned())),
            // /dev/stdout, /proc/self/fd/N and the like name open files: write through them.
            Ok(_) if through_dev_or_proc(path) => Ok(Destination::InPlace(path.to_owned())),
            Ok(_) => Ok(Destination::File(std::fs::canonicalize(path).map_err(io(path))?)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let target = dangling_target(path)?;
                let dir = parent(&target);
                if !dir.is_dir() {
                    return Err(Error::NotWritable {
                        path: path.to_owned(),
                        reason: format!("the directory {} does not exist (create it first)", dir.display()),
                    });
                }
                Ok(Destination::File(target))
            }
            Err(e) => Err(io(path)(e)),
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
/// directory, a missing directory, or one that cannot be written.
pub fn check_writable(path: &Path) -> Result<Destination> {
    let d = Destination::of(path)?;
    if let Destination::File(p) = &d {
        let dir = parent(p);
        let probe = dir.join(format!(".cpg-write-test.{}", std::process::id()));
        std::fs::File::create(&probe).map_err(|source| Error::NotWritable {
            path: path.to_owned(),
            reason: format!("its directory {} cannot be written ({source})", dir.display()),
        })?;
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
fn dangling_target(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_owned();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&p).map_err(io(&p))?;
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(Error::NotWritable { path: path.to_owned(), reason: "more than 40 symbolic links in a chain".into() })
}

fn parent(p: &Path) -> &Path {
    p.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Writes `fill`'s output where `path` points (see the crate docs).
pub fn write_output<E: From<Error>>(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    match Destination::of(path)? {
        Destination::Stdout => {
            let out = std::io::stdout();
            let mut w = std::io::BufWriter::new(out.lock());
            fill(&mut w)?;
            w.flush().map_err(io(Path::new("standard output")))?;
            Ok(())
        }
        Destination::InPlace(p) => {
            let f = std::fs::OpenOptions::new().append(true).open(&p).map_err(io(&p))?;
            let mut w = std::io::BufWriter::new(f);
            fill(&mut w)?;
            w.flush().map_err(io(&p))?;
            Ok(())
        }
        Destination::File(p) => write_atomic(&p, fill),
    }
}

/// `path` with `.` and `..` resolved without touching the file system (the
/// one path normaliser): `..` removes the component before it, is dropped
/// at the root (whose parent is itself) and kept at the start of a relative
/// path (`../x` stays).
pub fn lexical(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.components().next_back() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                _ => out.push(".."),
            },
            other => out.push(other),
        }
    }
    out
}

/// Writes `bytes` to the regular file `path` atomically: a new file or a
/// regular one (a symlink's target), never a device, FIFO or directory.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    match Destination::of(path)? {
        Destination::File(p) => write_atomic(&p, |w: &mut dyn Write| w.write_all(bytes).map_err(io(path))),
        _ => Err(Error::NotWritable {
            path: path.to_owned(),
            reason: "not a regular file: this is saved only to a regular file".into(),
        }),
    }
}

/// Writes a regular file atomically (see the crate docs).
fn write_atomic<E: From<Error>>(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    let dir = parent(path);
    let name = temp_stem(&path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
    remove_stale(dir, &name);
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    pending().push(tmp.clone());
    let result = (|| {
        let f = std::fs::File::create(&tmp).map_err(io(&tmp))?;
        let mut w = std::io::BufWriter::new(f);
        fill(&mut w)?;
        let f = w.into_inner().map_err(|e| io(&tmp)(e.into_error()))?;
        f.sync_all().map_err(io(&tmp))?;
        std::fs::rename(&tmp, path).map_err(io(path))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    pending().retain(|p| p != &tmp);
    result
}

/// The most bytes of an output's name its temporary's name keeps: with the
/// dot, the process id and `.tmp`, the temporary's name stays within the 255
/// bytes file systems allow whenever the output's own name does.
const TEMP_STEM_BYTES: usize = 200;

/// The part of an output's file name its temporary file is named after: the
/// name itself, or for a long one its first bytes (on a character boundary)
/// and a hash of the whole, so that two long names differing only at their
/// ends get different temporaries.
fn temp_stem(name: &str) -> String {
    if name.len() <= TEMP_STEM_BYTES {
        return name.to_owned();
    }
    let mut cut = TEMP_STEM_BYTES - 17;
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    // FNV-1a: stable across runs and builds, unlike the standard hasher.
    let hash = name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
    format!("{}~{hash:016x}", &name[..cut])
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

/// The name among `candidates` closest to `name` in spelling, for an error's
/// hint ("did you mean …?"): the fewest single-character insertions,
/// deletions, substitutions or swaps of neighbours, compared without case;
/// `None` when even the closest needs more than a third of the name's
/// characters changed (at least 2 allowed), or when it is ambiguous. The one
/// rule every crate's unknown-name error uses.
pub fn closest_name<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let a: Vec<char> = name.to_lowercase().chars().collect();
    let limit = (a.len() / 3).max(2);
    let mut best: Option<(&str, usize)> = None;
    let mut tie = false;
    for c in candidates {
        let b: Vec<char> = c.to_lowercase().chars().collect();
        if a.len().abs_diff(b.len()) > limit {
            continue;
        }
        let d = edit_distance(&a, &b);
        if d > limit {
            continue;
        }
        match best {
            Some((_, bd)) if d > bd => {}
            Some((_, bd)) if d == bd => tie = true,
            _ => {
                best = Some((c, d));
                tie = false;
            }
        }
    }
    best.filter(|_| !tie).map(|(c, _)| c)
}

/// Optimal string alignment distance (Levenshtein with swaps of neighbours).
fn edit_distance(a: &[char], b: &[char]) -> usize {
    let w = b.len() + 1;
    let mut d = vec![0usize; (a.len() + 1) * w];
    for i in 0..=a.len() {
        for j in 0..=b.len() {
            d[i * w + j] = if i == 0 {
                j
            } else if j == 0 {
                i
            } else {
                let cost = usize::from(a[i - 1] != b[j - 1]);
                let mut v = (d[(i - 1) * w + j] + 1).min(d[i * w + j - 1] + 1).min(d[(i - 1) * w + j - 1] + cost);
                if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                    v = v.min(d[(i - 2) * w + j - 2] + 1);
                }
                v
            };
        }
    }
    d[a.len() * w + b.len()]
}

/// `" (did you mean 'X'?)"` when [`closest_name`] finds one, else nothing: the hint as messages append it.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    closest_name(name, candidates).map(|c| format!(" (did you mean '{c}'?)")).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    #[test]
    fn the_closest_name_is_a_typo_away_or_none() {
        let names = ["lfemur.rx", "rfemur.rx", "ltibia.rx", "root.tx", "u_walk", "u_run"];
        assert_eq!(closest_name("lfemr.rx", names), Some("lfemur.rx"));
        assert_eq!(closest_name("LFEMUR.RX", names), Some("lfemur.rx"));
        assert_eq!(closest_name("ltbiia.rx", names), Some("ltibia.rx"), "a swap of neighbours is one edit");
        assert_eq!(closest_name("u_wlak", names), Some("u_walk"));
        assert_eq!(closest_name("xfemur.rx", names), None, "as close to lfemur as to rfemur: no guess");
        assert_eq!(closest_name("head.rz", names), None, "nothing close");
        assert_eq!(did_you_mean("u_rn", names), " (did you mean 'u_run'?)");
        assert_eq!(did_you_mean("zzz", names), "");
    }

    #[test]
    fn paths_are_normalised_lexically() {
        let l = |p: &str| lexical(Path::new(p)).display().to_string();
        assert_eq!(l("/a/b/../c/./d"), "/a/c/d");
        assert_eq!(l("/../x"), "/x");
        assert_eq!(l("../x/../y"), "../y");
        assert_eq!(l("a/../../b"), "../b");
        assert_eq!(l("./a/./b/"), "a/b");
    }

    #[test]
    fn a_bounded_read_stops_at_the_bound_whatever_the_metadata_says() {
        let e = read_bounded(Path::new("/dev/zero"), 1 << 20).expect_err("/dev/zero is endless");
        assert!(matches!(e, Error::TooLarge { max_bytes, .. } if max_bytes == 1 << 20), "{e}");
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("f");
        std::fs::write(&p, b"12345").unwrap();
        assert_eq!(read_bounded(&p, 5).unwrap(), b"12345");
        assert!(read_bounded(&p, 4).is_err());
    }

    /// A 250-byte output name once gave a temporary name over 255 bytes, so
    /// the write failed; the temporary's name is bounded, the output keeps its own.
    #[test]
    fn a_long_output_name_is_written_whole() {
        let d = tempfile::tempdir().unwrap();
        for name in ["a".repeat(250), format!("{}é.csv", "b".repeat(246))] {
            let p = d.path().join(&name);
            write_file(&p, b"x").unwrap();
            assert_eq!(std::fs::read(&p).unwrap(), b"x", "{} bytes", name.len());
        }
        let left: Vec<_> = std::fs::read_dir(d.path()).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(left.len(), 2, "no temporary left: {left:?}");
        assert_ne!(temp_stem(&"c".repeat(300)), temp_stem(&format!("{}d", "c".repeat(299))));
        assert!(temp_stem(&"é".repeat(150)).len() <= TEMP_STEM_BYTES);
    }

    #[test]
    fn a_missing_directory_is_an_error_and_nothing_is_created() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("no/such/dir/x.csv");
        let e = write_file(&p, b"x").expect_err("the directory is missing");
        assert!(e.to_string().contains("does not exist"), "{e}");
        assert!(!d.path().join("no").exists(), "nothing was created on the way");
    }

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("m.bin");
        std::fs::write(&p, b"old").unwrap();
        let r: Result<()> = write_output(&p, |w| {
            w.write_all(b"half").map_err(io(Path::new("x")))?;
            Err(Error::NotWritable { path: p.clone(), reason: "disk full".into() })
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        let left: Vec<_> = std::fs::read_dir(d.path()).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(left.len(), 1, "{left:?}");
        write_file(&p, b"new").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert!(write_file(Path::new("/dev/null"), b"x").is_err(), "a device is not a regular file");
        assert!(write_file(d.path(), b"x").is_err(), "a directory is refused");
    }
}

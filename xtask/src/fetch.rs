//! `cargo xtask fetch-data`: copy or download the CMU files and verify them.

use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use sha2::{Digest, Sha256};

/// Arguments of `fetch-data`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which data set: 35 (walk/run), 86 (skeleton; its long AMC trials are
    /// downloaded when reachable), bvh (other people's walks and a run, CMU
    /// subjects 07, 09 and 16 in BVH: data/cmu-bvh), or all.
    #[arg(long, default_value = "all", value_parser = ["35", "86", "bvh", "all"])]
    subject: String,
    /// Copy from this directory instead of the default source.
    #[arg(long)]
    from: Option<PathBuf>,
    /// Download from this base URL (the subject number and file name are appended)
    /// even when a local copy exists.
    #[arg(long, num_args = 0..=1, default_missing_value = CMU_BASE_URL)]
    download: Option<String>,
    /// Directory to fill instead of data/cmuSUBJECT (data/cmu-bvh).
    #[arg(long)]
    dest: Option<PathBuf>,
    /// Do not draw progress bars.
    #[arg(long)]
    quiet: bool,
}

impl Args {
    /// Both subjects from the default source, without progress bars.
    pub fn quiet_all() -> Args {
        Args { subject: "all".into(), from: None, download: None, dest: None, quiet: true }
    }
}

/// The record of optional files that could not be fetched, in the data directory.
pub const UNAVAILABLE: &str = ".unavailable";

/// Where CMU serves its files.
pub const CMU_BASE_URL: &str = "http://mocap.cs.cmu.edu/subjects";

/// One row of a MANIFEST.tsv.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// Path relative to the subject directory (`35_01.amc`, `partial/35_14.amc`).
    pub file: String,
    /// Expected size, when known.
    pub bytes: Option<u64>,
    /// Expected SHA-256 in hex, when known.
    pub sha256: Option<String>,
    /// `official` (must match on download too) or `unverified`.
    pub official: bool,
    /// Where CMU serves the file.
    pub url: String,
}

impl Entry {
    /// Files with neither size nor hash are optional: failing to get them is a warning.
    pub fn optional(&self) -> bool {
        self.bytes.is_none() && self.sha256.is_none()
    }
}

/// Parses a MANIFEST.tsv.
pub fn parse_manifest(path: &Path) -> anyhow::Result<Vec<Entry>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.starts_with("file\t") || line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split('\t').collect();
        if f.len() != 7 {
            bail!("{}:{}: expected 7 tab-separated fields, found {}", path.display(), i + 1, f.len());
        }
        let opt = |s: &str| (s != "-").then(|| s.to_owned());
        out.push(Entry {
            file: f[0].to_owned(),
            bytes: opt(f[1])
                .map(|s| s.parse())
                .transpose()
                .with_context(|| format!("{}:{}: bad byte count '{}'", path.display(), i + 1, f[1]))?,
            sha256: opt(f[2]),
            official: match f[4] {
                "official" => true,
                "unverified" => false,
                other => bail!("{}:{}: status '{other}', expected official or unverified", path.display(), i + 1),
            },
            url: f[6].to_owned(),
        });
    }
    Ok(out)
}

/// Where a file comes from.
#[derive(Debug, Clone)]
pub enum Source {
    /// A directory laid out like the subject directory.
    Dir(PathBuf),
    /// Download: the entry's URL, with `CMU_BASE_URL` replaced by this base.
    Http(String),
}

/// What happened to one file.
#[derive(Debug, PartialEq)]
pub enum Outcome {
    /// Already present and verified.
    Present,
    /// Fetched and verified against the manifest.
    Verified,
    /// Fetched; no official hash to check it against.
    Unverified,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let subjects: &[&str] = match args.subject.as_str() {
        "35" => &["35"],
        "86" => &["86"],
        "bvh" => &["bvh"],
        _ => &["35", "86", "bvh"],
    };
    let mut failures = Vec::new();
    for s in subjects {
        // A CMU subject's files (data/cmu35, ../shared/data/cmu/35), or the other people's BVH set.
        let (data_dir, shared) = match *s {
            "bvh" => (crate::root().join("data/cmu-bvh"), crate::root().join("../shared/data/cmu-bvh")),
            _ => (crate::root().join(format!("data/cmu{s}")), crate::root().join(format!("../shared/data/cmu/{s}"))),
        };
        let entries = parse_manifest(&data_dir.join("MANIFEST.tsv"))?;
        let dest = args.dest.clone().unwrap_or(data_dir);
        let source = match (&args.download, &args.from) {
            (Some(url), _) => Source::Http(url.clone()),
            (None, Some(dir)) => Source::Dir(dir.clone()),
            (None, None) if shared.is_dir() => Source::Dir(shared),
            (None, None) => Source::Http(CMU_BASE_URL.to_owned()),
        };
        let total: u64 = entries.iter().filter_map(|e| e.bytes).sum();
        let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(total) };
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{bar:30}] {bytes}/{total_bytes} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(format!("subject {s}"));
        let (mut n_ok, mut n_new, mut n_unverified) = (0, 0, 0);
        // Optional files that could not be had once are not asked for again
        // (unless --download asks explicitly): the record says so.
        let record = dest.join(UNAVAILABLE);
        let known_missing: Vec<String> = if args.download.is_some() {
            Vec::new()
        } else {
            std::fs::read_to_string(&record)
                .map(|t| t.lines().map(|l| l.split('\t').next().unwrap_or("").to_owned()).collect())
                .unwrap_or_default()
        };
        let mut missing: Vec<(String, String)> = Vec::new();
        let mut skipped = 0;
        for e in &entries {
            bar.set_message(e.file.clone());
            if e.optional() && known_missing.contains(&e.file) && !dest.join(&e.file).is_file() {
                skipped += 1;
                continue;
            }
            // A file the directory does not hold (86_01.amc) is downloaded from CMU.
            let src = match &source {
                Source::Dir(d) if !d.join(&e.file).is_file() => Source::Http(CMU_BASE_URL.to_owned()),
                s => s.clone(),
            };
            match fetch_one(e, &src, &dest, &bar) {
                Ok(Outcome::Present) => n_ok += 1,
                Ok(Outcome::Verified) => n_new += 1,
                Ok(Outcome::Unverified) => n_unverified += 1,
                Err(err) if e.optional() => missing.push((e.file.clone(), format!("{err:#}"))),
                Err(err) => {
                    bar.suspend(|| eprintln!("error: {}: {err:#}", e.file));
                    failures.push(e.file.clone());
                }
            }
        }
        bar.finish_and_clear();
        if !missing.is_empty() {
            let names: Vec<&str> = missing.iter().map(|m| m.0.as_str()).collect();
            eprintln!(
                "note: optional {} could not be fetched ({}). The report runs without them; to use them, put them in {} (they are checked against MANIFEST.tsv). Not asking the network for them again: delete {} or run `cargo xtask fetch-data --download` to retry.",
                names.join(", "),
                missing[0].1,
                dest.display(),
                record.display()
            );
            let text: String =
                missing.iter().map(|(f, why)| format!("{f}\t{}\n", why.replace(['\n', '\t'], " "))).collect();
            if let Err(e) = std::fs::create_dir_all(&dest).and_then(|_| std::fs::write(&record, text)) {
                eprintln!("warning: could not write {}: {e}", record.display());
            }
        }
        if skipped > 0 && !args.quiet {
            eprintln!(
                "subject {s}: {skipped} optional file(s) skipped, known to be unavailable ({})",
                record.display()
            );
        }
        let from = match &source {
            Source::Dir(d) => d.display().to_string(),
            Source::Http(u) => u.clone(),
        };
        eprintln!(
            "subject {s}: {n_ok} already present, {n_new} fetched and verified, {n_unverified} fetched without an official hash; source {from}; into {}",
            dest.display()
        );
    }
    if !failures.is_empty() {
        bail!("{} file(s) could not be fetched: {}", failures.len(), failures.join(", "));
    }
    Ok(())
}

/// Streams a file's bytes through SHA-256, returning (size, hex digest).
fn hash_file(path: &Path) -> std::io::Result<(u64, String)> {
    let mut f = File::open(path)?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    let mut n = 0u64;
    loop {
        let k = f.read(&mut buf)?;
        if k == 0 {
            break;
        }
        h.update(&buf[..k]);
        n += k as u64;
    }
    Ok((n, hex(&h.finalize())))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Whether a size and hash satisfy the manifest (only what it states is checked).
fn check(e: &Entry, size: u64, sha: &str) -> anyhow::Result<()> {
    if let Some(want) = e.bytes
        && size != want
    {
        bail!("size {size} bytes, manifest says {want} (truncated or wrong file)");
    }
    if let Some(want) = &e.sha256
        && sha != want
    {
        bail!("sha256 {sha}, manifest says {want} (corrupt or wrong file)");
    }
    Ok(())
}

/// Fetches one file into `dest`, atomically: it is written to a temporary
/// file, verified, and only then renamed into place.
pub fn fetch_one(e: &Entry, source: &Source, dest: &Path, bar: &ProgressBar) -> anyhow::Result<Outcome> {
    let target = dest.join(&e.file);
    if target.is_file() {
        let (size, sha) = hash_file(&target)?;
        if check(e, size, &sha).is_ok() && (e.bytes.is_some() || e.sha256.is_some() || size > 0) {
            bar.inc(e.bytes.unwrap_or(0));
            return Ok(Outcome::Present);
        }
    }
    let dir = target.parent().unwrap_or(dest);
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let tmp = dir.join(format!(".{}.part", e.file.replace('/', "_")));
    let result = transfer(e, source, &tmp, bar).and_then(|(size, sha, downloaded)| {
        // A download of a file without an official hash cannot be checked.
        let verify = e.official || !downloaded;
        if verify {
            check(e, size, &sha)?;
        } else if size == 0 {
            bail!("empty file");
        }
        std::fs::rename(&tmp, &target).with_context(|| format!("moving into {}", target.display()))?;
        Ok(if verify && (e.sha256.is_some()) { Outcome::Verified } else { Outcome::Unverified })
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Copies or downloads into `tmp`; returns (size, sha256, was_downloaded).
fn transfer(e: &Entry, source: &Source, tmp: &Path, bar: &ProgressBar) -> anyhow::Result<(u64, String, bool)> {
    let mut out = File::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut h = Sha256::new();
    let mut n = 0u64;
    let mut pump = |r: &mut dyn Read| -> anyhow::Result<()> {
        let mut buf = vec![0u8; 1 << 16];
        loop {
            let k = r.read(&mut buf)?;
            if k == 0 {
                return Ok(());
            }
            h.update(&buf[..k]);
            out.write_all(&buf[..k])?;
            n += k as u64;
            bar.inc(k as u64);
        }
    };
    let downloaded = match source {
        Source::Dir(d) => {
            let p = d.join(&e.file);
            let mut f = File::open(&p).with_context(|| format!("opening {}", p.display()))?;
            pump(&mut f).with_context(|| format!("reading {}", p.display()))?;
            false
        }
        Source::Http(base) => {
            let url = e.url.replacen(CMU_BASE_URL, base.trim_end_matches('/'), 1);
            let agent: ureq::Agent =
                ureq::Agent::config_builder().timeout_global(Some(Duration::from_secs(120))).build().into();
            let resp = agent.get(&url).call().with_context(|| format!("GET {url}"))?;
            let announced = resp.body().content_length();
            let mut body = resp.into_body().into_reader();
            pump(&mut body).with_context(|| format!("GET {url}: connection broke after {n} bytes"))?;
            if let Some(len) = announced
                && len != n
            {
                bail!("GET {url}: server announced {len} bytes, sent {n}");
            }
            true
        }
    };
    out.sync_all()?;
    Ok((n, hex(&h.finalize()), downloaded))
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, BufReader};
    use std::net::TcpListener;

    use super::*;

    const GOOD: &[u8] = b"#!OML:ASF\r\n:FULLY-SPECIFIED\r\n:DEGREES\r\n1\r\nroot 0 0 0 0 0 0\r\n";

    fn sha(b: &[u8]) -> String {
        hex(&Sha256::digest(b))
    }

    /// An HTTP/1.1 server on 127.0.0.1 that serves a fixed set of responses,
    /// then stops. Paths: /s/35/good.amc, /s/35/truncated.amc (announces the
    /// full length, sends half), /s/35/corrupt.amc (one byte changed), anything else 404.
    fn serve(n_requests: usize) -> String {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        std::thread::spawn(move || {
            for stream in listener.incoming().take(n_requests) {
                let mut s = stream.unwrap();
                let mut first = String::new();
                let mut r = BufReader::new(s.try_clone().unwrap());
                r.read_line(&mut first).unwrap();
                loop {
                    let mut h = String::new();
                    if r.read_line(&mut h).unwrap() == 0 || h == "\r\n" {
                        break;
                    }
                }
                let path = first.split_whitespace().nth(1).unwrap_or("").to_owned();
                let head =
                    |len: usize| format!("HTTP/1.1 200 OK\r\nContent-Length: {len}\r\nConnection: close\r\n\r\n");
                match path.as_str() {
                    "/s/35/good.amc" => {
                        s.write_all(head(GOOD.len()).as_bytes()).unwrap();
                        s.write_all(GOOD).unwrap();
                    }
                    "/s/35/truncated.amc" => {
                        s.write_all(head(GOOD.len()).as_bytes()).unwrap();
                        s.write_all(&GOOD[..GOOD.len() / 2]).unwrap();
                    }
                    "/s/35/corrupt.amc" => {
                        let mut bad = GOOD.to_vec();
                        bad[5] ^= 0x20;
                        s.write_all(head(bad.len()).as_bytes()).unwrap();
                        s.write_all(&bad).unwrap();
                    }
                    _ => s
                        .write_all(b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
                        .unwrap(),
                }
            }
        });
        format!("http://{addr}/s")
    }

    fn entry(file: &str) -> Entry {
        Entry {
            file: file.into(),
            bytes: Some(GOOD.len() as u64),
            sha256: Some(sha(GOOD)),
            official: true,
            url: format!("{CMU_BASE_URL}/35/{file}"),
        }
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
    }

    #[test]
    fn download_good_truncated_corrupt_and_missing() {
        let base = serve(4);
        let dest = tempfile::tempdir().unwrap();
        let bar = ProgressBar::hidden();
        let src = Source::Http(base);
        assert_eq!(fetch_one(&entry("good.amc"), &src, dest.path(), &bar).unwrap(), Outcome::Verified);
        assert_eq!(std::fs::read(dest.path().join("good.amc")).unwrap(), GOOD);

        let err = fetch_one(&entry("truncated.amc"), &src, dest.path(), &bar).unwrap_err();
        assert!(format!("{err:#}").contains("truncated.amc"), "{err:#}");
        let err = fetch_one(&entry("corrupt.amc"), &src, dest.path(), &bar).unwrap_err();
        assert!(format!("{err:#}").contains("sha256"), "{err:#}");
        let err = fetch_one(&entry("missing.amc"), &src, dest.path(), &bar).unwrap_err();
        assert!(format!("{err:#}").contains("404"), "{err:#}");
        // Only the good file is there: no partial or temporary files.
        assert_eq!(leftovers(dest.path()), ["good.amc"]);
    }

    #[test]
    fn copy_verifies_and_skips_present_files() {
        let src = tempfile::tempdir().unwrap();
        let dest = tempfile::tempdir().unwrap();
        std::fs::write(src.path().join("good.amc"), GOOD).unwrap();
        std::fs::write(src.path().join("short.amc"), &GOOD[..10]).unwrap();
        let bar = ProgressBar::hidden();
        let s = Source::Dir(src.path().to_owned());
        assert_eq!(fetch_one(&entry("good.amc"), &s, dest.path(), &bar).unwrap(), Outcome::Verified);
        assert_eq!(fetch_one(&entry("good.amc"), &s, dest.path(), &bar).unwrap(), Outcome::Present);
        let err = fetch_one(&entry("short.amc"), &s, dest.path(), &bar).unwrap_err();
        assert!(format!("{err:#}").contains("size 10 bytes"), "{err:#}");
        assert!(fetch_one(&entry("absent.amc"), &s, dest.path(), &bar).is_err());
        assert_eq!(leftovers(dest.path()), ["good.amc"]);
        // A corrupted file in place is replaced by a verified copy.
        std::fs::write(dest.path().join("good.amc"), b"tampered").unwrap();
        assert_eq!(fetch_one(&entry("good.amc"), &s, dest.path(), &bar).unwrap(), Outcome::Verified);
        assert_eq!(std::fs::read(dest.path().join("good.amc")).unwrap(), GOOD);
    }

    #[test]
    fn project_manifests_parse() {
        let m35 = parse_manifest(&crate::root().join("data/cmu35/MANIFEST.tsv")).unwrap();
        assert_eq!(m35.len(), 29);
        assert_eq!(m35.iter().filter(|e| !e.official).count(), 9);
        let m86 = parse_manifest(&crate::root().join("data/cmu86/MANIFEST.tsv")).unwrap();
        assert_eq!(m86.iter().map(|e| e.file.as_str()).collect::<Vec<_>>(), ["86.asf", "86_01.amc", "86_02.amc"]);
        let bvh = parse_manifest(&crate::root().join("data/cmu-bvh/MANIFEST.tsv")).unwrap();
        assert_eq!(bvh.iter().map(|e| e.file.as_str()).collect::<Vec<_>>(), ["07_06.bvh", "16_21.bvh", "09_07.bvh"]);
        assert!(bvh.iter().all(|e| e.official && e.sha256.is_some() && e.bytes.is_some()));
    }
}

//! `cargo xtask ci` and `cargo xtask test`.

use anyhow::{Context, bail};

use crate::process::{cmd, output};

/// The layering rules: a crate, and the packages that must never appear among
/// its normal (non-dev) dependencies, direct or transitive.
const RULES: &[(&str, &[&str])] = &[
    (
        "cpg-io",
        &[
            "faer",
            "rayon",
            "nalgebra",
            "anyhow",
            "cpg-mocap",
            "cpg-reservoir",
            "cpg-regression",
            "cpg-robot",
            "cpg-cli",
            "cpg-compare",
            "cpg-lab",
            "cpg-view",
        ],
    ),
    (
        "cpg-mocap",
        &[
            "faer",
            "rayon",
            "nalgebra",
            "anyhow",
            "cpg-reservoir",
            "cpg-regression",
            "cpg-robot",
            "cpg-cli",
            "cpg-compare",
            "cpg-lab",
        ],
    ),
    ("cpg-regression", &["cpg-reservoir", "cpg-mocap", "cpg-robot", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-reservoir", &["cpg-mocap", "cpg-robot", "cpg-cli", "cpg-compare", "cpg-lab", "anyhow"]),
    ("cpg-robot", &["cpg-reservoir", "cpg-regression", "cpg-cli", "cpg-lab", "anyhow", "faer", "rayon"]),
    ("cpg-dmp", &["cpg-reservoir", "cpg-centralized", "cpg-compare", "cpg-robot", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-centralized", &["cpg-reservoir", "cpg-dmp", "cpg-compare", "cpg-robot", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-compare", &["cpg-robot", "cpg-cli", "cpg-lab", "anyhow"]),
    (
        "cpg-view",
        &[
            "cpg-reservoir",
            "cpg-regression",
            "cpg-lab",
            "cpg-cli",
            "cpg-compare",
            "anyhow",
            "faer",
            "rayon",
            "plotters",
        ],
    ),
    ("cpg-lab", &["cpg-cli", "anyhow", "clap", "indicatif", "plotters"]),
    ("cpg-python", &["cpg-cli", "anyhow", "clap", "indicatif", "plotters"]),
];

/// Checks the layering rules with `cargo tree`.
pub fn layering() -> anyhow::Result<()> {
    let metadata = output("cargo", &["metadata", "--no-deps", "--format-version", "1"])?;
    let mut broken = Vec::new();
    for (krate, forbidden) in RULES {
        if !metadata.contains(&format!("\"name\":\"{krate}\"")) {
            broken.push(format!("{krate} is named in the layering rules but is not a package of the workspace"));
            continue;
        }
        let tree = output("cargo", &["tree", "-p", krate, "-e", "normal", "--prefix", "none", "--format", "{p}"])?;
        let deps: Vec<&str> = tree.lines().filter_map(|l| l.split_whitespace().next()).collect();
        for f in *forbidden {
            if deps.contains(f) {
                broken.push(format!("{krate} depends on {f}"));
            }
        }
        eprintln!("layering: {krate} ok ({} packages in its tree)", deps.len());
    }
    for (file, line, name, n) in long_functions(&crate::root())? {
        broken.push(format!("{file}:{line}: fn {name} has {n} lines; at most {MAX_FUNCTION_LINES} in a library crate"));
    }
    if !broken.is_empty() {
        bail!("layering rules broken (see ARCHITECTURE.md):\n  {}", broken.join("\n  "));
    }
    Ok(())
}

/// The longest a function of a library crate may be, lines.
const MAX_FUNCTION_LINES: usize = 120;

/// Functions of the library crates (every crate but the app) longer than
/// [`MAX_FUNCTION_LINES`]: `(file, line, name, lines)`. A function runs from
/// its `fn` line to the closing brace at the same indentation; the SIMD
/// kernels written by `macro_rules!` are the stated exception (see kernel.rs).
pub fn long_functions(root: &std::path::Path) -> anyhow::Result<Vec<(String, usize, String, usize)>> {
    let mut files = Vec::new();
    let mut stack = vec![root.join("crates")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).with_context(|| format!("reading {}", d.display()))? {
            let p = e?.path();
            if p.is_dir() {
                let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                if !(d.ends_with("crates") && name == "cli") && name != "tests" && name != "target" {
                    stack.push(p);
                }
            } else if p.extension().is_some_and(|x| x == "rs") && p.components().any(|c| c.as_os_str() == "src") {
                files.push(p);
            }
        }
    }
    files.sort();
    let mut out = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f)?;
        let lines: Vec<&str> = text.lines().collect();
        let mut in_macro: Option<usize> = None;
        for (i, l) in lines.iter().enumerate() {
            let indent = l.len() - l.trim_start().len();
            if l.starts_with("macro_rules!") {
                in_macro = Some(indent);
            } else if in_macro.is_some_and(|m| indent == m && l.trim() == "}") {
                in_macro = None;
            }
            if in_macro.is_some() {
                continue;
            }
            let t = l.trim_start();
            let t = t.strip_prefix("pub(crate) ").or_else(|| t.strip_prefix("pub ")).unwrap_or(t);
            let t = t.strip_prefix("const ").unwrap_or(t);
            let t = t.strip_prefix("unsafe ").unwrap_or(t);
            let Some(rest) = t.strip_prefix("fn ") else { continue };
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            // A declaration without a body (a trait's) ends at its `;`.
            let signature_end = lines[i..].iter().find(|x| x.contains('{') || x.trim_end().ends_with(';'));
            if signature_end.is_some_and(|x| !x.contains('{')) {
                continue;
            }
            let close = format!("{}}}", &l[..indent]);
            if let Some(j) = lines[i + 1..].iter().position(|x| *x == close) {
                let n = j + 2;
                if n > MAX_FUNCTION_LINES {
                    let rel = f.strip_prefix(root).unwrap_or(&f).display().to_string();
                    out.push((rel, i + 1, name, n));
                }
            }
        }
    }
    Ok(out)
}

pub fn run() -> anyhow::Result<()> {
    let mut times: Vec<(&str, f64)> = Vec::new();
    let result = run_steps(&mut times);
    // The times, whatever happened: what ran, and how long.
    eprintln!("\ncargo xtask ci, time per step:");
    for (name, s) in &times {
        eprintln!("  {name:<34} {:>7.1} s", s);
    }
    eprintln!("  {:<34} {:>7.1} s", "total", times.iter().map(|t| t.1).sum::<f64>());
    result
}

fn run_steps(times: &mut Vec<(&'static str, f64)>) -> anyhow::Result<()> {
    let mut step = |name: &'static str, f: &mut dyn FnMut() -> anyhow::Result<()>| -> anyhow::Result<()> {
        let t = std::time::Instant::now();
        let r = f();
        times.push((name, t.elapsed().as_secs_f64()));
        r.with_context(|| format!("ci step `{name}`"))
    };
    step("fmt", &mut || cmd("cargo", &["fmt", "--all", "--", "--check"], &[]))?;
    step("clippy", &mut || cmd("cargo", &["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"], &[]))?;
    step("layering", &mut layering)?;
    step("doc", &mut || cmd("cargo", &["doc", "--workspace", "--no-deps"], &[("RUSTDOCFLAGS", "-D warnings")]))?;
    step("test (build and run)", &mut || test(&[]))?;
    step("python (wheel and pytest)", &mut crate::python::run)?;
    // A fixed seed: the same inputs on every CI run from a fresh clone.
    step("fuzz (build and smoke run)", &mut || {
        crate::fuzz::run(CI_FUZZ_SECONDS, &[], Some(1), crate::fuzz::Build::Smoke)
    })
}

/// Seconds each fuzz target runs in `cargo xtask ci`: a smoke run (the
/// corpus and every kept crash replay in `cargo test`; long runs are
/// `cargo xtask fuzz --seconds N`).
const CI_FUZZ_SECONDS: u64 = 5;

/// Fetches the data when it is missing, then runs every test.
pub fn test(extra: &[String]) -> anyhow::Result<()> {
    let args = crate::fetch::Args::quiet_all();
    crate::fetch::run(&args).context("fetching the CMU data the tests need")?;
    // The release profile: the tests reuse what `cargo xtask` (which runs
    // optimised) compiled, and the Python wheel reuses theirs.
    let mut a = vec!["test", "--workspace", "--release"];
    a.extend(extra.iter().map(String::as_str));
    cmd("cargo", &a, &[])
}

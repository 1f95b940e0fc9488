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
            "cpg-hoap2",
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
            "cpg-hoap2",
            "cpg-cli",
            "cpg-compare",
            "cpg-lab",
        ],
    ),
    ("cpg-regression", &["cpg-reservoir", "cpg-mocap", "cpg-hoap2", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-reservoir", &["cpg-mocap", "cpg-hoap2", "cpg-cli", "cpg-compare", "cpg-lab", "anyhow"]),
    ("cpg-hoap2", &["cpg-reservoir", "cpg-regression", "cpg-cli", "cpg-lab", "anyhow", "faer", "rayon"]),
    ("cpg-dmp", &["cpg-reservoir", "cpg-centralized", "cpg-compare", "cpg-hoap2", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-centralized", &["cpg-reservoir", "cpg-dmp", "cpg-compare", "cpg-hoap2", "cpg-cli", "cpg-lab", "anyhow"]),
    ("cpg-compare", &["cpg-hoap2", "cpg-cli", "cpg-lab", "anyhow"]),
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
    if !broken.is_empty() {
        bail!("layering rules broken (see ARCHITECTURE.md):\n  {}", broken.join("\n  "));
    }
    Ok(())
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
    step("fuzz (build and smoke run)", &mut || crate::fuzz::run(CI_FUZZ_SECONDS, &[], Some(1)))
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

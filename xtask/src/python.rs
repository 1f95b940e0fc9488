//! `cargo xtask python`: installs the Python package (crates/python) into a
//! virtual environment of its own, with what its tests need from the
//! package registry (maturin, pytest, numpy, mujoco, optuna, mypy), checks
//! its stubs against the compiled module (`mypy.stubtest`) and runs its tests.

use anyhow::{Context, bail};

use crate::process::cmd;

/// What the tests need from PyPI, beside the package's own dependencies.
const TEST_PACKAGES: [&str; 6] =
    ["maturin>=1.7,<2", "pytest>=7", "numpy>=1.21", "mujoco>=3.2", "optuna>=3", "mypy==2.4.1"];

/// The environment: `target/python-venv` (never committed).
pub fn venv() -> anyhow::Result<std::path::PathBuf> {
    let root = crate::root();
    let venv = root.join("target").join("python-venv");
    let python = venv.join("bin").join("python");
    if !python.exists() {
        let found =
            ["python3", "python"].into_iter().find(|p| std::process::Command::new(p).arg("--version").output().is_ok());
        let Some(base) = found else { bail!("no python3 on PATH: the Python package needs Python 3.9 or later") };
        cmd(base, &["-m", "venv", &venv.display().to_string()], &[])?;
    }
    let py = python.display().to_string();
    let mut args = vec!["-m", "pip", "install", "--quiet", "--disable-pip-version-check"];
    args.extend(TEST_PACKAGES);
    cmd(&py, &args, &[]).context("installing the test dependencies from PyPI")?;
    Ok(venv)
}

/// Builds the package's wheel (and the `cpg` command its tests compare
/// with) and installs it into the environment; returns the environment's
/// python. The wheel is built by maturin in the workspace's target directory
/// and release profile, so it reuses what the tests already compiled (see
/// the feature pins in crates/python/Cargo.toml).
pub fn install() -> anyhow::Result<std::path::PathBuf> {
    let venv = venv()?;
    let py = venv.join("bin").join("python");
    let venv_dir = venv.display().to_string();
    // The `cpg` command as the workspace's tests build it: built alone
    // (`-p cpg-cli`) its dependencies would resolve other features and
    // compile a second time.
    cmd("cargo", &["test", "--release", "--quiet", "--workspace", "--no-run"], &[])?;
    let wheels = crate::root().join("target").join("wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    let maturin = venv.join("bin").join("maturin").display().to_string();
    let out = wheels.display().to_string();
    cmd(
        &maturin,
        &["build", "--release", "--quiet", "-m", "crates/python/Cargo.toml", "--out", &out],
        &[("VIRTUAL_ENV", venv_dir.as_str())],
    )
    .context("building the cpg wheel (maturin)")?;
    let wheel = std::fs::read_dir(&wheels)
        .with_context(|| format!("reading {out}"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .with_context(|| format!("maturin wrote no wheel into {out}"))?;
    let wheel = wheel.display().to_string();
    cmd(
        &py.display().to_string(),
        &["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--force-reinstall", "--no-deps", &wheel],
        &[],
    )
    .context("installing the cpg wheel")?;
    Ok(py)
}

/// Builds and installs the package, checks its stubs, then runs pytest on
/// `crates/python/tests` (the `cpg` command they compare with is built first).
pub fn run() -> anyhow::Result<()> {
    crate::fetch::run(&crate::fetch::Args::quiet_all()).context("fetching the CMU data the tests need")?;
    let py = install()?.display().to_string();
    let venv_dir = crate::root().join("target").join("python-venv").display().to_string();
    // The hand-written stubs must say what the compiled module holds.
    cmd(&py, &["-m", "mypy.stubtest", "cpg._cpg", "--ignore-missing-stub"], &[("VIRTUAL_ENV", venv_dir.as_str())])
        .context("the stubs crates/python/python/cpg/_cpg.pyi disagree with the module (mypy.stubtest)")?;
    let bin = crate::release_binary("cpg");
    let bin = bin.display().to_string();
    cmd(
        &py,
        &["-m", "pytest", "-q", "crates/python/tests"],
        &[("CPG_BIN", bin.as_str()), ("VIRTUAL_ENV", venv_dir.as_str())],
    )
}

"""Shared fixtures: the checkout, the CMU files, a trained femur model."""

import os
import pathlib
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]


def cmu(name: str) -> pathlib.Path:
    """A subject-35 file (`cargo xtask fetch-data` puts them in data/cmu35)."""
    for d in [os.environ.get("CPG_DATA_DIR"), ROOT / "data" / "cmu35", ROOT.parent / "shared" / "data" / "cmu" / "35"]:
        if d and (pathlib.Path(d) / name).is_file():
            return pathlib.Path(d) / name
    pytest.fail(f"{name} not found: run `cargo xtask fetch-data` first")


def cpg_binary() -> pathlib.Path:
    """The `cpg` command built by cargo (CPG_BIN, else target/debug or target/release)."""
    for p in [os.environ.get("CPG_BIN"), ROOT / "target" / "debug" / "cpg", ROOT / "target" / "release" / "cpg"]:
        if p and pathlib.Path(p).is_file():
            return pathlib.Path(p)
    found = shutil.which("cpg")
    if found:
        return pathlib.Path(found)
    pytest.fail("the cpg command is not built: run `cargo build -p cpg-cli` (or set CPG_BIN)")


@pytest.fixture(scope="session")
def walk():
    import cpg

    return cpg.read_motion(cmu("35_01.amc"), skeleton=cmu("35.asf"))


@pytest.fixture(scope="session")
def femur_model(walk):
    import cpg

    return cpg.fit(walk.select(["lfemur.rx"]).values, walk.rate_hz, channels=["hip_deg"])

//! Every input a fuzz target ever crashed on (`fuzz/regressions/<target>/`)
//! and every seed of its corpus (`fuzz/seeds/<target>/`), run through the
//! same checks as the fuzz binaries (`fuzz/checks.rs`). `cargo xtask fuzz`
//! copies each new crash into `fuzz/regressions`, so it stays fixed.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

#[path = "../fuzz/checks.rs"]
mod checks;

use std::path::{Path, PathBuf};

/// A fuzz target's check.
type Check = fn(&[u8]);

const TARGETS: [(&str, Check); 7] = [
    ("asf", checks::asf),
    ("amc", checks::amc),
    ("bvh", checks::bvh),
    ("config", checks::config),
    ("model", checks::model),
    ("control_csv", checks::control_csv),
    ("urdf", checks::urdf),
];

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

fn inputs(kind: &str, target: &str) -> Vec<PathBuf> {
    let dir = fuzz_dir().join(kind).join(target);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        assert!(kind == "regressions", "{} is missing", dir.display());
        return Vec::new(); // no crash kept for this target yet (git keeps no empty folders)
    };
    let mut v: Vec<PathBuf> =
        entries.map(|e| e.unwrap().path()).filter(|p| p.file_name().is_some_and(|n| n != ".gitkeep")).collect();
    v.sort();
    v
}

#[test]
fn every_kept_crash_and_seed_now_passes_its_check() {
    let mut n_regressions = 0;
    for (target, check) in TARGETS {
        let seeds = inputs("seeds", target);
        assert!(!seeds.is_empty(), "fuzz/seeds/{target} has no seed input");
        for path in inputs("regressions", target).into_iter().chain(seeds) {
            let bytes = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| check(&bytes));
            assert!(outcome.is_ok(), "{}: the {target} check panicked", path.display());
            n_regressions += path.components().any(|c| c.as_os_str() == "regressions") as usize;
        }
    }
    assert!(n_regressions >= 2, "the crashes found so far are kept: {n_regressions}");
}

/// The seeds reach deep: each is accepted by its parser (a seed that is
/// rejected at the first byte would teach the fuzzer nothing).
#[test]
fn seeds_are_valid_inputs() {
    let sk = cpg_mocap::parse_asf("tiny.asf", checks::TINY_ASF).unwrap();
    for p in inputs("seeds", "asf") {
        cpg_mocap::parse_asf("seed.asf", &std::fs::read(&p).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
    for p in inputs("seeds", "amc") {
        cpg_mocap::parse_amc("seed.amc", &std::fs::read(&p).unwrap(), &sk, 120.0)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
    for p in inputs("seeds", "config") {
        let text = std::fs::read_to_string(&p).unwrap();
        cpg_lab::Config::from_toml(&text, &p, Path::new(".")).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
    for p in inputs("seeds", "model") {
        let framed = cpg_reservoir::TrainedCpg::frame_payload(&std::fs::read(&p).unwrap());
        cpg_reservoir::TrainedCpg::from_bytes(&framed, &p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
    let names: Vec<String> = checks::CONTROL_NAMES.iter().map(|s| s.to_string()).collect();
    for p in inputs("seeds", "control_csv") {
        let text = std::fs::read_to_string(&p).unwrap();
        cpg_lab::ControlSchedule::parse_csv(&text, &p, &names).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
    for p in inputs("seeds", "urdf") {
        let text = std::fs::read_to_string(&p).unwrap();
        cpg_robot::Robot::from_urdf_str(&text, &p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    }
}

/// The model seed is the payload of a small model trained here, so it
/// follows the model format: `UPDATE_SNAPSHOTS=1` rewrites it after a format change.
#[test]
fn the_model_seed_is_a_current_model() {
    use cpg_reservoir::*;
    let cfg = ReservoirConfig { n_neurons: 12, ..ReservoirConfig::wyffels_schrauwen_2009() }.check().unwrap();
    let res = Reservoir::new(&cfg, 3).unwrap();
    let wave = |n: usize, k0: usize| (k0..k0 + n).map(|k| 1.5 * (k as f64 / 4.0).sin()).collect::<Vec<_>>();
    let data = TrainingData::nmse(
        Sequence::outputs_only(wave(400, 0)),
        Sequence::outputs_only(wave(400, 0)),
        Sequence::outputs_only(wave(100, 400)),
    );
    let settings = TrainSettings {
        washout: 100,
        penalties: cpg_regression::PenaltyGrid::log10_range(0.0, 1.0, -4.0).unwrap(),
        n_noise_draws: 1,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let tr = train(&res, &data, &settings).unwrap();
    let out = vec![OutputChannel { name: "wave".into(), mean: 0.0, std: 1.0 }];
    let m = TrainedCpg::new(res, tr, settings, Scoring::default(), out, vec![], "1.5 sin(k/4)".into(), 120.0).unwrap();
    let bytes = m.to_bytes().unwrap();
    let payload = &bytes[28..];
    let path = fuzz_dir().join("seeds/model/sine-12.payload");
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(&path, payload).unwrap();
    }
    let kept = std::fs::read(&path).unwrap_or_default();
    let stale = || format!("{} is not the current model's payload: run with UPDATE_SNAPSHOTS=1", path.display());
    // This build's format reads the kept payload and writes it back to the same bytes.
    let back =
        TrainedCpg::from_bytes(&TrainedCpg::frame_payload(&kept), &path).unwrap_or_else(|e| panic!("{}: {e}", stale()));
    assert!(back.to_bytes().unwrap()[28..] == kept[..], "{}", stale());
    // And it is the model trained above: the same layout and configuration,
    // the trained numbers equal up to their last bits (the f64 linear algebra
    // of the ridge fit rounds differently on another instruction set).
    assert_eq!(kept.len(), payload.len(), "{}", stale());
    assert_eq!(back.reservoir.config(), m.reservoir.config(), "{}", stale());
    let close = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()).max(1e-12))
    };
    assert!(close(&back.readout.weights, &m.readout.weights), "{}: readout weights", stale());
    assert!(close(&back.readout.bias, &m.readout.bias), "{}: readout bias", stale());
    assert!(close(&back.start_state, &m.start_state), "{}: start state", stale());
    checks::model(payload);
}

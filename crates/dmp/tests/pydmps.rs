//! Our rhythmic DMP against pydmps 0.2 (reference values written by
//! scripts/pydmps_reference.sh; this test needs no Python).

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_dmp::{DmpConfig, RhythmicDmp};
use serde_json::Value;

fn fixture() -> Value {
    serde_json::from_str(include_str!("../test_data/pydmps_0_2.json")).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn assert_close(what: &str, ours: &[f64], theirs: &[f64], tol: f64) {
    assert_eq!(ours.len(), theirs.len(), "{what}: lengths");
    let scale = theirs.iter().map(|v| v.abs()).fold(1.0, f64::max);
    let worst = ours.iter().zip(theirs).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst <= tol * scale, "{what}: largest difference {worst:e} (scale {scale})");
}

#[test]
fn rollouts_match_pydmps() {
    let f = fixture();
    for case in f["cases"].as_array().unwrap() {
        let name = case["name"].as_str().unwrap();
        let n_dofs = case["n_dofs"].as_u64().unwrap() as usize;
        let cfg = DmpConfig::pydmps(case["n_basis"].as_u64().unwrap() as usize, case["dt"].as_f64().unwrap());
        assert_eq!(cfg.timesteps() as u64, case["timesteps"].as_u64().unwrap(), "{name}: timesteps");
        let mut dmp = RhythmicDmp::imitate(cfg, &floats(&case["demo"]), n_dofs).unwrap();
        assert_close(&format!("{name}: goal"), dmp.goal(), &floats(&case["goal"]), 1e-12);
        assert_close(&format!("{name}: weights"), dmp.weights(), &floats(&case["weights"]), 1e-9);
        let one = dmp.rollout(None, 1.0);
        assert_close(&format!("{name}: one period"), &one, &floats(&case["rollout_one_period"]), 1e-9);
        let two = dmp.rollout(Some(2 * cfg.timesteps()), 1.0);
        assert_close(&format!("{name}: two periods"), &two, &floats(&case["rollout_two_periods"]), 1e-9);
        let fast = dmp.rollout(None, 2.0);
        assert_close(&format!("{name}: tau 2"), &fast, &floats(&case["rollout_tau_2"]), 1e-9);
    }
}

/// methods.md §3.6: 100 basis functions smooth away windows with several cycles.
#[test]
fn accuracy_falls_with_cycles_per_window_as_in_pydmps() {
    let f = fixture();
    let t_demo = 1300;
    for row in f["cycles_100_basis"].as_array().unwrap() {
        let k = row["cycles"].as_u64().unwrap() as f64;
        let want = row["rel_rmse"].as_f64().unwrap();
        let y: Vec<f64> =
            (0..t_demo).map(|j| (2.0 * std::f64::consts::PI * k * j as f64 / (t_demo - 1) as f64).sin()).collect();
        let cfg = DmpConfig::pydmps(100, 2.0 * std::f64::consts::PI / t_demo as f64);
        let mut dmp = RhythmicDmp::imitate(cfg, &y, 1).unwrap();
        let out = dmp.rollout(None, 1.0);
        // The resampled demonstration pydmps compares with: sample t at phase t·dt.
        let spacing = 2.0 * std::f64::consts::PI / (t_demo - 1) as f64;
        let path: Vec<f64> = (0..out.len())
            .map(|t| {
                let q = t as f64 * cfg.dt;
                let j = ((q / spacing) as usize).min(t_demo - 2);
                y[j] + (q - j as f64 * spacing) / spacing * (y[j + 1] - y[j])
            })
            .collect();
        let mse = out.iter().zip(&path).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / out.len() as f64;
        let m = path.iter().sum::<f64>() / path.len() as f64;
        let sd = (path.iter().map(|v| (v - m).powi(2)).sum::<f64>() / path.len() as f64).sqrt();
        let ours = mse.sqrt() / sd;
        assert!((ours / want - 1.0).abs() < 1e-6, "{k} cycles: ours {ours}, pydmps {want}");
    }
}

#[test]
fn bad_input_is_rejected() {
    assert!(RhythmicDmp::imitate(DmpConfig::pydmps(0, 0.01), &[0.0, 1.0], 1).is_err());
    assert!(RhythmicDmp::imitate(DmpConfig::pydmps(10, 0.0), &[0.0, 1.0], 1).is_err());
    assert!(RhythmicDmp::imitate(DmpConfig::pydmps(10, 0.01), &[0.0, f64::NAN], 1).is_err());
    assert!(RhythmicDmp::imitate(DmpConfig::pydmps(10, 0.01), &[0.0, 1.0, 2.0], 2).is_err());
    assert!(RhythmicDmp::imitate(DmpConfig::pydmps(10, 0.01), &[0.0], 1).is_err());
}

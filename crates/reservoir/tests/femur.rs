//! A reduced experiment 1 of wyffels & Schrauwen (2009) on the real CMU file:
//! the paper's 300-neuron reservoir learns the left femur of 35_01.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_mocap::cycle::{best_loop, estimate_period, tile};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton, ZScore};
use cpg_reservoir::*;

/// Bound on the median, over reservoir seeds 1–5, of the free-run NMSE over
/// the first 500 steps (4.2 s, three gait cycles). For a sinusoid, a pure
/// phase error φ costs NMSE = 2(1 − cos φ), so 0.1 allows at most an 18° phase
/// slip (a twentieth of a cycle) and no gross shape or amplitude error.
/// ReservoirPy 0.4.2 with the same reservoir reached 0.009–0.086 over six
/// seeds (../shared/research/anchors.md). Single seeds vary: over seeds 1–10
/// we measured 0.0095–0.53 (median 0.043), so the median is what is bounded.
const MEDIAN_NMSE_BOUND: f64 = 0.1;
/// Every seed must at least beat predicting the mean (NMSE 1).
const WORST_NMSE_BOUND: f64 = 1.0;

#[test]
fn learned_femur_pattern_tracks_the_teacher_and_stays_finite() {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let m = Motion::from_amc_file(find(Subject::S35, "35_01.amc").unwrap(), &sk, 120.0).unwrap();
    let femur = m.select(&["lfemur.rx"]).unwrap();
    let z = ZScore::fit(&femur).unwrap();
    let x = z.apply(&femur).unwrap().values().to_vec();
    let period = estimate_period(&x, 60, 250).unwrap();
    assert!((period - 135.0).abs() < 2.0, "gait period {period} frames");
    let lp = best_loop(&x, 1, period, 1).unwrap();
    let cycle = &x[lp.start..lp.start + lp.len];
    let train_len = 2200;
    let data = TrainingData {
        train: Sequence::outputs_only(tile(cycle, 1, train_len, 0)),
        warmup: Sequence::outputs_only(tile(cycle, 1, train_len, 0)),
        validation: Sequence::outputs_only(tile(cycle, 1, 500, train_len)),
    };
    let settings = TrainSettings::wyffels_schrauwen_2009();
    let mut all = Vec::new();
    for seed in 1..=5 {
        let res = Reservoir::new(&ReservoirConfig::wyffels_schrauwen_2009().check().unwrap(), seed).unwrap();
        let tr = train(&res, &data, &settings).unwrap();
        let out = vec![OutputChannel { name: "lfemur.rx".into(), mean: z.mean[0], std: z.std[0] }];
        let model = TrainedCpg::new(res, tr, settings.clone(), out, vec![], "35_01 lfemur.rx".into(), 120.0).unwrap();
        let mut g = Generator::new(&model);
        let teacher = tile(cycle, 1, 500, train_len);
        let mut se = 0.0;
        for t in &teacher {
            g.step(&[]).unwrap();
            se += (g.normalised_output()[0] - t).powi(2);
        }
        let mean = teacher.iter().sum::<f64>() / 500.0;
        let var = teacher.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / 500.0;
        let nmse = se / 500.0 / var;
        eprintln!("seed {seed}: penalty {:e}, first-500 NMSE {nmse:.4}", model.provenance.chosen_penalty);
        assert!(nmse < WORST_NMSE_BOUND, "seed {seed}: first-500 free-run NMSE {nmse}");
        all.push(nmse);
        // The generator errors out on any non-finite value, so finishing is the check.
        for _ in 500..100_000 {
            let y = g.step(&[]).unwrap()[0];
            assert!((-90.0..90.0).contains(&y), "femur angle {y} deg");
        }
    }
    all.sort_by(f64::total_cmp);
    assert!(all[2] < MEDIAN_NMSE_BOUND, "median first-500 NMSE {} over seeds 1–5: {all:?}", all[2]);
}

//! Trains the paper's CPG on the left femur of CMU 35_01 and reports free-run quality.
//! `cargo run --release -p cpg-reservoir --example femur [seed] [f32|f64]`

#![allow(clippy::unwrap_used, clippy::expect_used)] // an example: fail loudly

use cpg_mocap::cycle::{align_to_cycle, best_loop, estimate_period, half_range};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton, ZScore};
use cpg_reservoir::*;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(42);
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let m = Motion::from_amc_file(find(Subject::S35, "35_01.amc").unwrap(), &sk, 120.0).unwrap();
    let femur = m.select(&["lfemur.rx"]).unwrap();
    let z = ZScore::fit(&femur).unwrap();
    let x = z.apply(&femur).unwrap().values().to_vec();
    let period = estimate_period(&x, 60, 250).unwrap();
    let lp = best_loop(&x, 1, period, 1).unwrap();
    let cycle = &x[lp.start..lp.start + lp.len];
    println!("period {period:.2}, loop {lp:?}");
    let tile = |n: usize, off: usize| -> Vec<f64> { (0..n).map(|k| cycle[(k + off) % cycle.len()]).collect() };
    let train_len = 2200;
    let mut cfg = ReservoirConfig::wyffels_schrauwen_2009();
    if args.get(2).map(String::as_str) == Some("f64") {
        cfg.precision = Precision::F64;
    }
    let cfg = cfg.check().unwrap();
    let t0 = std::time::Instant::now();
    let res = Reservoir::new(&cfg, seed).unwrap();
    println!("build {:?}, raw radius {:.3}", t0.elapsed(), res.raw_spectral_radius());
    let data = TrainingData {
        train: Sequence::outputs_only(tile(train_len, 0)),
        warmup: Sequence::outputs_only(tile(train_len, 0)),
        validation: Sequence::outputs_only(tile(500, train_len)),
    };
    let mut settings = TrainSettings::wyffels_schrauwen_2009();
    if let Some(top) = args.get(3) {
        let top: f64 = top.parse().unwrap();
        settings.penalties = cpg_regression::PenaltyGrid::log10_range(top, 0.1, top - 9.0).unwrap();
    }
    let t0 = std::time::Instant::now();
    let tr = train(&res, &data, &settings).unwrap();
    println!(
        "train {:?}: chosen {} (penalty {:e}) nmse {:.4}, train nmse {:.2e}",
        t0.elapsed(),
        tr.chosen,
        settings.penalties.values()[tr.chosen],
        tr.curve[tr.chosen].nmse,
        tr.train_nmse
    );
    for p in tr.curve.iter().step_by(10) {
        println!("  penalty {:>8.1e}: {:.4}", p.penalty, p.nmse);
    }
    let model = TrainedCpg::new(
        res,
        tr,
        settings,
        vec![OutputChannel { name: "lfemur.rx".into(), mean: z.mean[0], std: z.std[0] }],
        vec![],
        "35_01".into(),
        120.0,
    )
    .unwrap();
    let mut g = Generator::new(&model);
    let total = 108_000;
    let t0 = std::time::Instant::now();
    let out: Vec<f64> = (0..total)
        .map(|_| {
            g.step(&[]).unwrap();
            g.normalised_output()[0]
        })
        .collect();
    println!(
        "free run {total} steps: {:?} ({:.2} µs/step)",
        t0.elapsed(),
        t0.elapsed().as_secs_f64() * 1e6 / total as f64
    );
    let teacher = tile(500, train_len);
    let nmse500 = out[..500].iter().zip(&teacher).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / 500.0;
    println!("first-500 NMSE {:.4}", nmse500);
    let end = &out[total - 1200..];
    let p_end = estimate_period(end, 60, 250).unwrap();
    println!(
        "end: period {p_end:.2} (teacher {:.2}), half range {:.3} (teacher {:.3})",
        lp.len,
        half_range(end),
        half_range(cycle)
    );
    let (shift, nm) = align_to_cycle(end, cycle, 1);
    println!("end aligned NMSE {nm:.4} (shift {shift})");
}

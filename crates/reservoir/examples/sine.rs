//! Jaeger's sine task through the paper's reservoir: prints the validation curve and the free run.
#![allow(clippy::unwrap_used)]
use cpg_mocap::cycle::{estimate_period, half_range};
use cpg_regression::PenaltyGrid;
use cpg_reservoir::*;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let n: usize = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(100);
    let amp: f64 = a.get(2).map(|s| s.parse().unwrap()).unwrap_or(1.5);
    let noise: f64 = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(1e-3);
    let sine = |len: usize, off: usize| (off..off + len).map(|k| amp * (k as f64 / 4.0).sin()).collect::<Vec<_>>();
    let cfg = ReservoirConfig { n_neurons: n, ..ReservoirConfig::wyffels_schrauwen_2009() }.check().unwrap();
    let res = Reservoir::new(&cfg, 1).unwrap();
    let data = TrainingData::nmse(
        Sequence::outputs_only(sine(1200, 0)),
        Sequence::outputs_only(sine(1200, 0)),
        Sequence::outputs_only(sine(300, 1200)),
    );
    let settings = TrainSettings {
        washout: 200,
        penalties: PenaltyGrid::log10_range(1.0, 0.5, -8.0).unwrap(),
        noise_variance: noise,
        n_noise_draws: 2,
        noise_seed: 7,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let tr = train(&res, &data, &settings).unwrap();
    for p in &tr.curve {
        print!("{:.0e}:{:.3} ", p.penalty, p.nmse);
    }
    println!("\ntrain nmse {:e}", tr.train_nmse);
    let m = TrainedCpg::new(
        res,
        tr,
        settings,
        Scoring::default(),
        vec![OutputChannel { name: "s".into(), mean: 0.0, std: 1.0 }],
        vec![],
        String::new(),
        1.0,
    )
    .unwrap();
    let mut g = Generator::new(&m);
    let out: Vec<f64> = (0..100_000).map(|_| g.step(&[]).unwrap()[0]).collect();
    println!("first 30: {:?}", out[..30].iter().map(|v| (v * 100.0).round() / 100.0).collect::<Vec<_>>());
    let last = &out[98_000..];
    println!("end period {:?} amp {:.3}", estimate_period(last, 15, 40), half_range(last));
}

//! `cargo xtask bench`: speed of the reservoir CPG, each figure beside a
//! measured floor (the time to stream the weight matrix once). The data is
//! E1's, prepared from `experiments/e1-paper.toml`.

use std::hint::black_box;
use std::time::{Duration, Instant};

use cpg_lab::prepare::{Prepared, prepare};
use cpg_mocap::cycle::estimate_period;
use cpg_regression::{PenaltyGrid, RidgePath};
use cpg_reservoir::{
    Candidate, Generator, Precision, Reservoir, ReservoirConfig, TrainSettings, TrainedCpg, harvest,
    teacher_forced_states, train, validate,
};

/// Median time of one call of `f`: calls are batched so that a sample lasts
/// at least 5 ms, and up to 15 samples (or 3 s) are taken after a warm-up call.
fn measure(mut f: impl FnMut()) -> Duration {
    f();
    let t = Instant::now();
    f();
    let once = t.elapsed().max(Duration::from_nanos(1));
    let per_sample = (Duration::from_millis(5).as_nanos() / once.as_nanos()).max(1) as u32;
    let mut samples = Vec::new();
    let start = Instant::now();
    while samples.len() < 15 && (samples.len() < 3 || start.elapsed() < Duration::from_secs(3)) {
        let t = Instant::now();
        for _ in 0..per_sample {
            f();
        }
        samples.push(t.elapsed() / per_sample);
    }
    samples.sort();
    samples[samples.len() / 2]
}

/// Sums every weight once, 16 lanes wide: the memory-bound floor of a step.
fn stream<T: Copy + Default + std::ops::Add<Output = T>>(w: &[T]) -> T {
    let (chunks, tail) = w.as_chunks::<16>();
    let mut acc = [T::default(); 16];
    for c in chunks {
        for l in 0..16 {
            acc[l] = acc[l] + c[l];
        }
    }
    let mut s = tail.iter().fold(T::default(), |a, &b| a + b);
    for a in acc {
        s = s + a;
    }
    s
}

fn fmt(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 1e-3 {
        format!("{:.2} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

struct Row {
    what: String,
    time: Duration,
    floor: Option<Duration>,
    /// Network steps (one state vector, one update) in the measured call.
    steps: f64,
    target: &'static str,
    verdict: String,
}

fn config(n: usize, precision: Precision) -> anyhow::Result<cpg_reservoir::CheckedConfig> {
    Ok(ReservoirConfig { n_neurons: n, precision, ..ReservoirConfig::wyffels_schrauwen_2009() }.check()?)
}

fn model(res: Reservoir, f: &Prepared, settings: &TrainSettings) -> anyhow::Result<TrainedCpg> {
    let tr = train(&res, &f.data, settings)?;
    Ok(TrainedCpg::new(
        res,
        tr,
        settings.clone(),
        f.data.scoring.clone(),
        f.outputs.clone(),
        vec![],
        f.description.clone(),
        120.0,
    )?)
}

pub fn run() -> anyhow::Result<()> {
    let e1 = cpg_lab::Config::load(&crate::root().join("experiments/e1-paper.toml"))?;
    let f = prepare(&e1)?;
    let cycle =
        f.teachers.first().map(|t| t.cycle.clone()).ok_or_else(|| anyhow::anyhow!("E1 has no teacher cycle"))?;
    let threads = rayon::current_num_threads();
    println!("cargo xtask bench: {threads} threads, median of up to 15 samples each\n");
    let mut rows = Vec::new();
    let quick = TrainSettings {
        penalties: PenaltyGrid::log10_range(1.0, 1.0, -1.0)?,
        n_noise_draws: 1,
        ..TrainSettings::wyffels_schrauwen_2009()
    };

    for (n, precision) in [(300, Precision::F32), (300, Precision::F64), (2000, Precision::F32), (2000, Precision::F64)]
    {
        let res = Reservoir::new(&config(n, precision)?, 1)?;
        let floor = match precision {
            Precision::F32 => {
                let w: Vec<f32> = res.w().iter().map(|&v| v as f32).collect();
                measure(|| {
                    black_box(stream(black_box(&w)));
                })
            }
            Precision::F64 => {
                let w = res.w().to_vec();
                measure(|| {
                    black_box(stream(black_box(&w)));
                })
            }
        };
        let tag = format!("N={n} {precision:?}").to_lowercase();
        rows.push(Row {
            what: format!("floor: stream W once ({tag})"),
            time: floor,
            floor: Some(floor),
            steps: 1.0,
            target: "",
            verdict: String::new(),
        });
        let m = model(res.clone(), &f, &quick)?;
        let mut g = Generator::new(&m);
        let step = measure(|| {
            black_box(g.step(&[]).map(|y| y[0]).unwrap_or(f64::NAN));
        });
        let (target, verdict) = if n == 300 && precision == Precision::F32 {
            let ok = step <= Duration::from_micros(10) && step <= floor * 2;
            ("<= 10 µs and <= 2× floor", if ok { "met".into() } else { "MISSED".into() })
        } else {
            ("", String::new())
        };
        rows.push(Row {
            what: format!("free-run step ({tag})"),
            time: step,
            floor: Some(floor),
            steps: 1.0,
            target,
            verdict,
        });
        if n == 300 {
            let seq = cpg_reservoir::Sequence::outputs_only(f.data.train.outputs[..2000].to_vec());
            let x0 = vec![0.0; n];
            let h = measure(|| {
                black_box(teacher_forced_states(&res, &x0, &seq).map(|s| s.len()).unwrap_or(0));
            });
            rows.push(Row {
                what: format!("teacher-forced harvest, 2000 steps ({tag})"),
                time: h,
                floor: Some(floor),
                steps: 2000.0,
                target: "",
                verdict: String::new(),
            });

            // The sweep: all 91 penalties from one factorisation, each validated by a
            // 500-step noisy free run.
            let data = &f.data;
            let hv = harvest(&res, &data.train, 200)?;
            for draws in [1, 5] {
                let settings = TrainSettings { n_noise_draws: draws, ..TrainSettings::wyffels_schrauwen_2009() };
                let t =
                    measure(|| {
                        let path = RidgePath::new(hv.states.as_ref(), hv.targets.as_ref()).ok();
                        let candidates: Vec<Candidate> =
                            path.iter()
                                .flat_map(|p| {
                                    settings.penalties.values().iter().filter_map(|&l| {
                                        p.solve(l).ok().map(|readout| Candidate { penalty: l, readout })
                                    })
                                })
                                .collect();
                        black_box(validate(&res, &candidates, data, &settings).map(|c| c.0.len()).ok());
                    });
                let (target, verdict) = if draws == 1 && precision == Precision::F32 {
                    ("< 0.5 s", if t < Duration::from_millis(500) { "met".into() } else { "MISSED".into() })
                } else {
                    ("", String::new())
                };
                rows.push(Row {
                    what: format!("91-penalty sweep, 500-step noisy validation, {draws} draw(s) ({tag})"),
                    time: t,
                    floor: Some(floor),
                    steps: (91 * 500 * draws) as f64,
                    target,
                    verdict,
                });
            }
            let settings = TrainSettings::wyffels_schrauwen_2009();
            let t = measure(|| {
                black_box(train(&res, data, &settings).map(|t| t.penalty).ok());
            });
            rows.push(Row {
                what: format!("training end to end, E1, 5 draws ({tag})"),
                time: t,
                floor: Some(floor),
                steps: (2199 + 91 * 5 * 500 + 2200) as f64,
                target: "",
                verdict: String::new(),
            });
        }
    }
    println!("| what | time | per network step, × floor | target | verdict |");
    println!("|---|---:|---:|---|---|");
    for r in &rows {
        let ratio =
            r.floor.map(|fl| format!("{:.2}", r.time.as_secs_f64() / r.steps / fl.as_secs_f64())).unwrap_or_default();
        println!("| {} | {} | {} | {} | {} |", r.what, fmt(r.time), ratio, r.target, r.verdict);
    }

    // Accuracy of the two precisions on E1 (seed 1): same reservoir, same data.
    println!("\nPrecision on E1 (35_01 lfemur.rx, seed 1, paper settings):");
    println!(
        "| precision | chosen penalty | first-500 NMSE | max |f32 − f64| over 500 steps (deg) | period at 100k (frames) | half range at 100k (z) |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    let teacher = f.data.validation.outputs.clone();
    let var = {
        let m = teacher.iter().sum::<f64>() / 500.0;
        teacher.iter().map(|t| (t - m).powi(2)).sum::<f64>() / 500.0
    };
    let mut runs = Vec::new();
    for precision in [Precision::F32, Precision::F64] {
        let m = model(Reservoir::new(&config(300, precision)?, 1)?, &f, &TrainSettings::wyffels_schrauwen_2009())?;
        let mut g = Generator::new(&m);
        let mut out = Vec::with_capacity(100_000);
        let mut norm = Vec::with_capacity(100_000);
        for _ in 0..100_000 {
            out.push(g.step(&[])?[0]);
            norm.push(g.normalised_output()[0]);
        }
        let nmse = norm[..500].iter().zip(&teacher).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / 500.0 / var;
        let end = &norm[100_000 - 1200..];
        let period = estimate_period(end, 60, 250).unwrap_or(f64::NAN);
        runs.push((precision, m.provenance.chosen_penalty, nmse, out, period, cpg_mocap::cycle::half_range(end)));
    }
    let diff = runs[0].3[..500].iter().zip(&runs[1].3[..500]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    for (p, pen, nmse, _, period, hr) in &runs {
        println!("| {p:?} | {pen:e} | {nmse:.4} | {diff:.2e} | {period:.2} | {hr:.3} |");
    }
    println!("\nteacher cycle: {} frames, half range {:.3} (z)", cycle.len(), cpg_mocap::cycle::half_range(&cycle));
    Ok(())
}

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

pub fn run(vs_reservoirpy: bool) -> anyhow::Result<()> {
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
    tune_throughput()?;
    if vs_reservoirpy {
        side_by_side(&e1, &f)?;
    }
    Ok(())
}

/// `cpg tune`'s throughput: configurations (each trained and judged on one
/// seed) per minute, on every core, from `examples/poor-femur.toml`.
fn tune_throughput() -> anyhow::Result<()> {
    let base = cpg_lab::Config::load(&crate::root().join("examples/poor-femur.toml"))?;
    let s = cpg_lab::tune::TuneSettings { budget: 7, seeds: 1, long_run_s: 60.0, ..Default::default() };
    let t = Instant::now();
    let r = cpg_lab::tune::tune(&base, &s, &cpg_lab::experiment::Quiet)?;
    let minutes = t.elapsed().as_secs_f64() / 60.0;
    println!(
        "\ncpg tune (examples/poor-femur.toml, {} configurations × {} seed, {} s judged runs + a push, {} threads): {:.1} s, {:.1} configurations per minute; best passed on {} of {} seeds",
        r.candidates.len(),
        s.seeds,
        s.long_run_s,
        rayon::current_num_threads(),
        minutes * 60.0,
        r.candidates.len() as f64 / minutes,
        r.best().map_or(0, |b| b.passed),
        s.seeds
    );
    Ok(())
}

/// One E1 pipeline of ours, phase by phase, on the same data as ReservoirPy's.
struct Pipeline {
    init_s: f64,
    harvest_s: f64,
    sweep_s: f64,
    free_run_s: f64,
    total_s: f64,
    penalty: f64,
    first500_nmse: f64,
    tail: Vec<f64>,
}

const FREE_RUN_STEPS: usize = 100_000;

fn ours(e1: &cpg_lab::Config, f: &Prepared, precision: Precision) -> anyhow::Result<Pipeline> {
    let mut rc = cpg_lab::train::reservoir_config(e1, 1)?;
    rc.precision = precision;
    let settings = cpg_lab::train::train_settings(e1)?;
    let all = Instant::now();
    let t = Instant::now();
    let res = Reservoir::new(&rc.check()?, e1.reservoir.seed)?;
    let init_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    black_box(harvest(&res, &f.data.train, settings.washout)?);
    let harvest_s = t.elapsed().as_secs_f64();
    // `train` harvests again, then solves and validates every penalty.
    let t = Instant::now();
    let tr = train(&res, &f.data, &settings)?;
    let sweep_s = (t.elapsed().as_secs_f64() - harvest_s).max(0.0);
    let penalty = tr.penalty;
    let m = TrainedCpg::new(
        res,
        tr,
        settings,
        f.data.scoring.clone(),
        f.outputs.clone(),
        vec![],
        f.description.clone(),
        e1.data.rate_hz,
    )?;
    let mut g = Generator::new(&m);
    let mut norm = vec![0.0; FREE_RUN_STEPS];
    let t = Instant::now();
    for v in norm.iter_mut() {
        g.step(&[])?;
        *v = g.normalised_output()[0];
    }
    let free_run_s = t.elapsed().as_secs_f64();
    let total_s = all.elapsed().as_secs_f64();
    let target = &f.data.validation.outputs;
    Ok(Pipeline {
        init_s,
        harvest_s,
        sweep_s,
        free_run_s,
        total_s,
        penalty,
        first500_nmse: nmse(&norm[..target.len()], target),
        tail: norm[FREE_RUN_STEPS - 1200..].to_vec(),
    })
}

fn nmse(y: &[f64], t: &[f64]) -> f64 {
    let m = t.iter().sum::<f64>() / t.len() as f64;
    let var = t.iter().map(|v| (v - m).powi(2)).sum::<f64>() / t.len() as f64;
    y.iter().zip(t).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / t.len() as f64 / var
}

/// E1 with ReservoirPy 0.4.2 and with cpg, in one run, on the same data:
/// `scripts/reservoirpy_e1.sh` gets the prepared sequences as JSON. The two
/// OpenBLAS variables this machine sets (which select an older, slower
/// kernel) are removed for that one command, so the rival runs at its best.
fn side_by_side(e1: &cpg_lab::Config, f: &Prepared) -> anyhow::Result<()> {
    use anyhow::Context;
    let settings = cpg_lab::train::train_settings(e1)?;
    let rc = cpg_lab::train::reservoir_config(e1, 1)?;
    let input = serde_json::json!({
        "n_neurons": rc.n_neurons,
        "leak_rate": rc.leak_rate,
        "spectral_radius": rc.spectral_radius,
        "connectivity": rc.connectivity,
        "feedback_scale": rc.feedback.scale,
        "seed": e1.reservoir.seed,
        "train": f.data.train.outputs,
        "warmup": f.data.warmup.outputs,
        "validation": f.data.validation.outputs,
        "washout": settings.washout,
        "penalties": settings.penalties.values(),
        "noise_variance": settings.noise_variance,
        "noise_draws": settings.n_noise_draws,
        "free_run_steps": FREE_RUN_STEPS,
    });
    let dir = tempfile_dir()?;
    let path = dir.join("e1.json");
    std::fs::write(&path, serde_json::to_vec(&input)?)?;
    println!(
        "\nE1 side by side with ReservoirPy 0.4.2 (same data and settings, one run; OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset for ReservoirPy, BLAS 1 thread) …"
    );
    let out = std::process::Command::new("bash")
        .arg(crate::root().join("scripts/reservoirpy_e1.sh"))
        .arg(&path)
        .env_remove("OPENBLAS_CORETYPE")
        .env_remove("OPENBLAS_L2_SIZE")
        .stderr(std::process::Stdio::inherit())
        .output()
        .context("running scripts/reservoirpy_e1.sh")?;
    let _ = std::fs::remove_dir_all(&dir);
    anyhow::ensure!(out.status.success(), "scripts/reservoirpy_e1.sh failed ({})", out.status);
    let rp: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("reading the JSON scripts/reservoirpy_e1.sh printed")?;
    let num = |k: &str| rp[k].as_f64().ok_or_else(|| anyhow::anyhow!("ReservoirPy's result has no number `{k}`"));
    let (f32p, f64p) = (ours(e1, f, Precision::F32)?, ours(e1, f, Precision::F64)?);
    println!(
        "| phase | ReservoirPy {} (numpy {}) | cpg f64 | cpg f32 | ReservoirPy ÷ cpg f32 |",
        rp["versions"]["reservoirpy"].as_str().unwrap_or("?"),
        rp["versions"]["numpy"].as_str().unwrap_or("?")
    );
    println!("|---|---:|---:|---:|---:|");
    let rows: [(&str, f64, f64, f64); 5] = [
        ("build the reservoir", num("init_s")?, f64p.init_s, f32p.init_s),
        ("harvest (teacher forcing)", num("harvest_s")?, f64p.harvest_s, f32p.harvest_s),
        (
            "91 penalties: ridge solves + noisy 500-step validations",
            num("sweep_s")? + num("retrain_s")?,
            f64p.sweep_s,
            f32p.sweep_s,
        ),
        ("free run, 100,000 steps", num("free_run_s")?, f64p.free_run_s, f32p.free_run_s),
        ("the whole pipeline", num("total_s")?, f64p.total_s, f32p.total_s),
    ];
    for (what, r, a, b) in rows {
        println!("| {what} | {} | {} | {} | {:.0}× |", secs(r), secs(a), secs(b), r / b.max(1e-12));
    }
    let step = |s: f64| format!("{:.2} µs", s / FREE_RUN_STEPS as f64 * 1e6);
    println!(
        "| per free-run step | {} (numpy by hand: {:.2} µs) | {} | {} | {:.0}× |",
        step(num("free_run_s")?),
        num("numpy_step_s")? * 1e6,
        step(f64p.free_run_s),
        step(f32p.free_run_s),
        num("free_run_s")? / f32p.free_run_s.max(1e-12)
    );
    let tail: Vec<f64> =
        rp["free_run"].as_array().map(|a| a.iter().filter_map(|v| v.as_f64()).collect()).unwrap_or_default();
    println!("\n| result | ReservoirPy | cpg f64 | cpg f32 |");
    println!("|---|---:|---:|---:|");
    println!("| chosen penalty | {:e} | {:e} | {:e} |", num("chosen_penalty")?, f64p.penalty, f32p.penalty);
    println!(
        "| NMSE of the first 500 free-run steps | {:.4} | {:.4} | {:.4} |",
        num("first500_nmse")?,
        f64p.first500_nmse,
        f32p.first500_nmse
    );
    let period = |y: &[f64]| estimate_period(y, 60, 250).map_or("none".to_owned(), |p| format!("{p:.2}"));
    let hr = |y: &[f64]| if y.is_empty() { f64::NAN } else { cpg_mocap::cycle::half_range(y) };
    println!(
        "| period over the last 1200 steps (frames) | {} | {} | {} |",
        period(&tail),
        period(&f64p.tail),
        period(&f32p.tail)
    );
    println!(
        "| half range over the last 1200 steps (z) | {:.3} | {:.3} | {:.3} |",
        hr(&tail),
        hr(&f64p.tail),
        hr(&f32p.tail)
    );
    println!("(the reservoirs differ: each tool draws its own weights from the same recipe)");
    Ok(())
}

fn secs(s: f64) -> String {
    fmt(Duration::from_secs_f64(s.max(0.0)))
}

fn tempfile_dir() -> anyhow::Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("cpg-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}

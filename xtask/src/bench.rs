//! `cargo xtask bench`: speed and memory of the reservoir CPG, each figure
//! beside a floor measured in the same run.
//!
//! Five parts, in order: many streams per pass (batched free runs beside the
//! multiply-add and weight-streaming floors), one stream on both cores, the
//! E1 pipeline against ReservoirPy (`--vs-reservoirpy`), the throughput
//! users feel (`cpg tune`, the full evaluation) and peak memory. The data is
//! E1's, prepared from `experiments/e1-paper.toml`.

use std::hint::black_box;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, ensure};
use pulp::{Simd, WithSimd};

use cpg_lab::prepare::{Prepared, prepare};
use cpg_mocap::cycle::estimate_period;
use cpg_regression::{PenaltyGrid, RidgePath};
use cpg_reservoir::batch::{Run, free_runs};
use cpg_reservoir::{
    Candidate, Generator, Precision, Reservoir, ReservoirConfig, TrainSettings, TrainedCpg, harvest,
    teacher_forced_states, train, train_on, validate,
};

/// `cargo xtask bench` options.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Also run E1's whole pipeline (harvest, 91-penalty sweep with one noise
    /// draw, retrain, 100,000-step free run to CSV) with ReservoirPy 0.4.2 and
    /// with cpg (`cpg train` + `cpg generate`), alternating, one pair per seed.
    /// ReservoirPy runs in its own venv (`scripts/reservoirpy_e1.sh`, created
    /// from PyPI on first use) with OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset.
    #[arg(long)]
    vs_reservoirpy: bool,
    /// Pairs of the side-by-side run (seeds 1 to PAIRS).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=20))]
    pairs: u64,
    /// The single-stream step (N = 300, f32, µs) that the many-stream targets
    /// are multiples of. The default is the issue's figure for main at
    /// d59c6ec, measured on an AVX-512 machine; on another machine, give
    /// d59c6ec's own figure measured there (its `cargo xtask bench`, row
    /// "free-run step (n=300 f32)").
    #[arg(long, default_value_t = BASELINE_STEP_US, value_name = "µs")]
    baseline_step_us: f64,
    /// Leave out the timed full evaluation (`cargo xtask evaluate` with 10
    /// seeds everywhere, the longest part of the bench: 16 minutes on a
    /// two-core AVX-512 machine with the whole body, longer on AVX2).
    #[arg(long)]
    no_evaluate: bool,
}

/// The single-stream step of the issue's baseline (main at d59c6ec, N = 300,
/// f32, on the AVX-512 machine the issue was measured on), µs.
const BASELINE_STEP_US: f64 = 5.93;
/// The E1 pipeline's peak memory at d59c6ec, MiB: the memory target is 2× it.
const BASELINE_E1_MIB: f64 = 17.6;
/// Free-run steps of the E1 pipeline.
const FREE_RUN_STEPS: usize = 100_000;

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

/// Median of three timed calls (for calls of a tenth of a second or more).
fn median3(mut f: impl FnMut()) -> Duration {
    let mut t: Vec<Duration> = (0..3)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed()
        })
        .collect();
    t.sort();
    t[1]
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

/// The floor of streaming `w` once on `threads` (1 or 2) cores: with two,
/// each core streams its own half from its own caches, so the floor is one
/// core streaming the larger half (timing the two halves through a thread
/// pool would measure waking a worker, not the memory).
fn stream_time<T: Copy + Default + std::ops::Add<Output = T>>(w: &[T], threads: usize) -> Duration {
    let part = if threads < 2 { w } else { &w[..w.len().div_ceil(2)] };
    measure(|| {
        black_box(stream(black_box(part)));
    })
}

/// `steps` exchanges of the row-split run with no work between: two threads,
/// each publishing its half of an `n`-neuron state (`T` values) behind a
/// lock on its own cache lines, raising its step counter, spinning on the
/// other's and copying the other half in, as `run_split` does.
fn exchange<T: Copy + Default + Send>(n: usize, steps: usize) {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    #[repr(align(128))]
    struct Line<X>(X);
    let half = n / 2;
    let boxes: [[Line<Mutex<Vec<T>>>; 2]; 2] =
        core::array::from_fn(|_| core::array::from_fn(|_| Line(Mutex::new(vec![T::default(); half]))));
    let done = [Line(AtomicUsize::new(0)), Line(AtomicUsize::new(0))];
    let side = |t: usize| {
        let mut x = vec![T::default(); 2 * half];
        for s in 0..steps {
            let slot = (s + 1) % 2;
            if let Ok(mut m) = boxes[t][slot].0.lock() {
                m.copy_from_slice(&x[t * half..(t + 1) * half]);
            }
            done[t].0.store(s + 1, Ordering::Release);
            while done[1 - t].0.load(Ordering::Acquire) < s + 1 {
                std::hint::spin_loop();
            }
            if let Ok(m) = boxes[1 - t][slot].0.lock() {
                x[(1 - t) * half..(2 - t) * half].copy_from_slice(&m);
            }
        }
        black_box(x);
    };
    std::thread::scope(|sc| {
        sc.spawn(|| side(1));
        side(0);
    });
}

/// Twelve independent chains of fused multiply-adds on full vectors: the
/// machine's multiply-add peak. Returns a checksum and the lanes per vector.
struct Fma {
    iters: usize,
    double: bool,
}

impl WithSimd for Fma {
    type Output = (f64, usize);

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> (f64, usize) {
        if self.double {
            let (a, b) = (simd.splat_f64s(0.999_999), simd.splat_f64s(1e-9));
            let mut acc = [simd.splat_f64s(1.0); 12];
            for _ in 0..self.iters {
                for x in acc.iter_mut() {
                    *x = simd.mul_add_f64s(*x, a, b);
                }
            }
            let s = acc.iter().fold(simd.splat_f64s(0.0), |s, &x| simd.add_f64s(s, x));
            (simd.reduce_sum_f64s(s), size_of::<S::f64s>() / 8)
        } else {
            let (a, b) = (simd.splat_f32s(0.999_999), simd.splat_f32s(1e-9));
            let mut acc = [simd.splat_f32s(1.0); 12];
            for _ in 0..self.iters {
                for x in acc.iter_mut() {
                    *x = simd.mul_add_f32s(*x, a, b);
                }
            }
            let s = acc.iter().fold(simd.splat_f32s(0.0), |s, &x| simd.add_f32s(s, x));
            (f64::from(simd.reduce_sum_f32s(s)), size_of::<S::f32s>() / 4)
        }
    }
}

/// The multiply-add peak on `threads` cores at once, flop/s (best of three).
fn fma_peak(double: bool, threads: usize) -> f64 {
    let iters = 20_000_000;
    let once = || pulp::Arch::new().dispatch(Fma { iters: black_box(iters), double });
    let lanes = once().1;
    (0..3)
        .map(|_| {
            let t = Instant::now();
            std::thread::scope(|s| {
                let hs: Vec<_> = (1..threads).map(|_| s.spawn(|| black_box(once()))).collect();
                black_box(once());
                for h in hs {
                    let _ = h.join();
                }
            });
            (threads * iters * 12 * lanes * 2) as f64 / t.elapsed().as_secs_f64()
        })
        .fold(0.0, f64::max)
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

fn secs(s: f64) -> String {
    fmt(Duration::from_secs_f64(s.max(0.0)))
}

fn rate(r: f64) -> String {
    if r >= 1e6 {
        format!("{:.2} M", r / 1e6)
    } else if r >= 1e4 {
        format!("{:.0} k", r / 1e3)
    } else {
        format!("{r:.0}")
    }
}

fn verdict(ok: bool) -> &'static str {
    if ok { "met" } else { "MISSED" }
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

/// Stream-steps per second of `k` free runs of `m` advancing together on `threads` cores.
fn batched_rate(m: &TrainedCpg, k: usize, threads: usize) -> anyhow::Result<f64> {
    let n = m.reservoir.n_neurons() as f64;
    let steps = ((1.5e10 / (2.0 * n * n * k as f64)) as usize).clamp(50, 20_000);
    let none: Vec<f64> = Vec::new();
    let runs: Vec<Run<'_>> = (0..k).map(|_| Run::new(m, &none, steps)).collect();
    let mut failed = None;
    let t = median3(|| {
        for r in free_runs(&runs, threads) {
            if let Err(e) = r {
                failed = Some(e);
            }
        }
    });
    if let Some(e) = failed {
        anyhow::bail!("a benchmark run diverged: {e}");
    }
    Ok((k * steps) as f64 / t.as_secs_f64())
}

/// A child process's outcome.
struct Ran {
    stdout: Vec<u8>,
    wall_s: f64,
    peak_mib: Option<f64>,
}

/// Runs `cmd` to its end with the peak-memory report asked for; standard
/// error is passed through (indented) when `echo`, and kept for errors.
fn run_child(cmd: &mut Command, what: &str, echo: bool) -> anyhow::Result<Ran> {
    cmd.env(cpg_lab::memory::REPORT_PEAK_RSS, "1").stdout(Stdio::piped()).stderr(Stdio::piped());
    let t = Instant::now();
    let mut child = cmd.spawn().with_context(|| format!("starting {what}"))?;
    let mut out = child.stdout.take().context("no standard output")?;
    let err = child.stderr.take().context("no standard error")?;
    let reader = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    let mut lines = Vec::new();
    for line in BufReader::new(err).lines() {
        let Ok(line) = line else { break };
        if echo {
            eprintln!("      | {line}");
        }
        lines.push(line);
    }
    let status = child.wait().with_context(|| format!("waiting for {what}"))?;
    let wall_s = t.elapsed().as_secs_f64();
    let stdout = reader.join().map_err(|_| anyhow::anyhow!("reading {what}'s output failed"))?;
    let stderr = lines.join("\n");
    ensure!(
        status.success(),
        "{what} failed ({status}):\n{}",
        stderr.lines().rev().take(15).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n")
    );
    Ok(Ran { stdout, wall_s, peak_mib: cpg_lab::memory::parse_report(&stderr) })
}

fn mib(m: Option<f64>) -> String {
    m.map_or("?".into(), |m| format!("{m:.1} MiB"))
}

use cpg_lab::stats::median;

fn range(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)))
}

/// Peaks of the child processes, for the memory table.
#[derive(Default)]
struct Memory {
    rows: Vec<(String, Option<f64>)>,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let e1 = cpg_lab::Config::load(&crate::root().join("experiments/e1-paper.toml"))?;
    let f = prepare(&e1)?;
    let threads = crate::cores();
    println!("cargo xtask bench: {threads} threads\n");
    let cpg = build_cli()?;
    let dir = tempfile_dir()?;
    let result = run_in(args, &e1, &f, &cpg, &dir);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn run_in(args: &Args, e1: &cpg_lab::Config, f: &Prepared, cpg: &Path, dir: &Path) -> anyhow::Result<()> {
    let threads = crate::cores();
    let mut memory = Memory::default();
    let models = many_streams(f, threads, args.baseline_step_us)?;
    one_stream(&models)?;
    split_rule(f)?;
    phases(f)?;
    precision_table(f)?;
    let e1_peaks = e1_pipeline(e1, f, cpg, dir, args.vs_reservoirpy.then_some(args.pairs))?;
    let most = |v: &dyn Fn(&E1Peaks) -> Option<f64>| -> Option<f64> {
        e1_peaks.iter().map(v).try_fold(f64::NEG_INFINITY, |a, b| b.map(|b| a.max(b)))
    };
    let runs = if e1_peaks.len() == 1 { String::new() } else { format!(", largest of {} runs", e1_peaks.len()) };
    memory.rows.push((format!("`cpg train` (E1, one noise draw{runs})"), most(&|p| p.train)));
    memory.rows.push((format!("`cpg generate` (E1, 100,000 steps to CSV{runs})"), most(&|p| p.generate)));
    if e1_peaks.iter().any(|p| p.reservoirpy.is_some()) {
        memory
            .rows
            .push((format!("ReservoirPy 0.4.2, the same pipeline in one process{runs}"), most(&|p| p.reservoirpy)));
    }
    let e1_max = most(&|p| p.train.zip(p.generate).map(|(a, b)| a.max(b)));
    tune_throughput(cpg, dir, &mut memory)?;
    big_models(cpg, dir, &mut memory)?;
    closed_loop(cpg, dir)?;
    if !args.no_evaluate {
        evaluation(dir, &mut memory)?;
    }
    println!("\n## 5. Peak resident memory (VmHWM of each process)\n");
    println!("| process | peak | target | verdict |");
    println!("|---|---:|---|---|");
    for (what, peak) in &memory.rows {
        println!("| {what} | {} | | |", mib(*peak));
    }
    let limit = 2.0 * BASELINE_E1_MIB;
    println!(
        "| the E1 pipeline (the larger of the two) | {} | ≤ {limit:.1} MiB (2× d59c6ec's {BASELINE_E1_MIB} MiB) | {} |",
        mib(e1_max),
        e1_max.map_or("?", |m| verdict(m <= limit))
    );
    Ok(())
}

/// Part 1: K streams through one W per pass, beside the floors.
fn many_streams(
    f: &Prepared,
    threads: usize,
    baseline_step_us: f64,
) -> anyhow::Result<Vec<(usize, Precision, TrainedCpg)>> {
    println!("## 1. Many streams per pass\n");
    let peaks: Vec<(f64, f64)> = [1, threads.max(2)]
        .iter()
        .map(|&t| (fma_peak(false, t.min(threads.max(1))), fma_peak(true, t.min(threads.max(1)))))
        .collect();
    let cores = [1usize, threads.clamp(1, 2)];
    println!("Multiply-add floor (12 chains of fused multiply-adds on full vectors, best of 3):\n");
    println!("| cores | f32 Gflop/s | f64 Gflop/s |");
    println!("|---:|---:|---:|");
    for (c, (a, b)) in cores.iter().zip(&peaks) {
        println!("| {c} | {:.0} | {:.0} |", a / 1e9, b / 1e9);
    }
    let quick = TrainSettings {
        penalties: PenaltyGrid::log10_range(1.0, 1.0, -1.0)?,
        n_noise_draws: 1,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let baseline = 1e6 / baseline_step_us;
    let source = if baseline_step_us == BASELINE_STEP_US {
        "the issue's figure, measured on an AVX-512 machine; give `--baseline-step-us` with d59c6ec's step on this one"
    } else {
        "given by --baseline-step-us"
    };
    println!(
        "\nBatched free runs (`cpg_reservoir::batch::free_runs`, K runs of one model from E1's data, median of 3). The floor of a cell is the lower of two rates: streaming W once per pass (measured; on two cores, one core streaming its half) and the multiply-add peak (2 N² flop per stream-step). Targets: at K ≥ 32, N = 300, f32, at least 2.5× d59c6ec's single stream ({:.0} k stream-steps/s, {baseline_step_us:.2} µs a step: {source}) on one core and 5× on two.\n",
        baseline / 1e3,
    );
    println!(
        "| N | precision | K | cores | stream-steps/s | Gflop/s | floor | % of floor | × this build's single stream, 1 core | × d59c6ec | target | verdict |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|");
    let mut models = Vec::new();
    for (n, precision) in [(300, Precision::F32), (300, Precision::F64), (2000, Precision::F32), (2000, Precision::F64)]
    {
        let res = Reservoir::new(&config(n, precision)?, 1)?;
        let stream_s: Vec<f64> = cores
            .iter()
            .map(|&c| match precision {
                Precision::F32 => {
                    let w: Vec<f32> = res.w().iter().map(|&v| v as f32).collect();
                    stream_time(&w, c).as_secs_f64()
                }
                Precision::F64 => stream_time(&res.w(), c).as_secs_f64(),
            })
            .collect();
        let m = model(res, f, &quick)?;
        let flop = 2.0 * (n * n) as f64;
        let mut single = f64::NAN;
        for k in [1usize, 8, 32, 128] {
            for (ci, &c) in cores.iter().enumerate() {
                if ci == 1 && cores[1] == cores[0] {
                    continue;
                }
                let r = batched_rate(&m, k, c)?;
                if k == 1 && c == 1 {
                    single = r;
                }
                let peak = if precision == Precision::F32 { peaks[ci].0 } else { peaks[ci].1 };
                let floor = (k as f64 / stream_s[ci]).min(peak / flop);
                let (target, ok) = if n == 300 && precision == Precision::F32 && k >= 32 {
                    let want = if c == 1 { 2.5 } else { 5.0 };
                    (format!("≥ {want}× d59c6ec"), Some(r / baseline >= want))
                } else {
                    (String::new(), None)
                };
                println!(
                    "| {n} | {} | {k} | {c} | {} | {:.0} | {} | {:.0} % | {:.2} | {} | {target} | {} |",
                    format!("{precision:?}").to_lowercase(),
                    rate(r),
                    r * flop / 1e9,
                    rate(floor),
                    100.0 * r / floor,
                    r / single,
                    if n == 300 && precision == Precision::F32 {
                        format!("{:.2}", r / baseline)
                    } else {
                        String::new()
                    },
                    ok.map_or("", verdict)
                );
            }
        }
        models.push((n, precision, m));
    }
    Ok(models)
}

/// Part 2: one stream, one core against both (the step split by rows).
fn one_stream(models: &[(usize, Precision, TrainedCpg)]) -> anyhow::Result<()> {
    println!("\n## 2. One stream, both cores\n");
    println!(
        "A step split by rows over two cores: each core holds half of W in its own cache and the halves of the state are exchanged after every step. Sync cost: the same exchange between two threads with no work between (publish a half state, raise a counter, spin on the other's, copy its half in), per step, median of 3 runs of 20,000 exchanges; the rest of the split step is each core's half of the work.\n"
    );
    println!(
        "| N | precision | one core (`Generator::step`) | two cores (split) | speed-up | sync cost (share of the split step) | outputs 1 vs 2 cores | target | verdict |"
    );
    println!("|---:|---|---:|---:|---:|---:|---|---|---|");
    for (n, precision, m) in models {
        let mut g = Generator::new(m);
        let one = measure(|| {
            black_box(g.step(&[]).map(|y| y[0]).unwrap_or(f64::NAN));
        })
        .as_secs_f64();
        let steps = if *n <= 300 { 20_000 } else { 2_000 };
        let none: Vec<f64> = Vec::new();
        let runs = [Run::new(m, &none, steps)];
        let mut outs = Vec::new();
        let two = median3(|| outs = free_runs(&runs, 2)).as_secs_f64() / steps as f64;
        let split: Vec<f64> = outs.into_iter().next().context("no run")??;
        let alone: Vec<f64> = free_runs(&runs, 1).into_iter().next().context("no run")??;
        let mut g = Generator::new(m);
        let mut stepped = Vec::with_capacity(steps);
        for _ in 0..steps {
            g.step(&[])?;
            stepped.push(g.normalised_output()[0]);
        }
        let exchanges = 20_000;
        let sync = median3(|| match precision {
            Precision::F32 => exchange::<f32>(*n, exchanges),
            Precision::F64 => exchange::<f64>(*n, exchanges),
        })
        .as_secs_f64()
            / exchanges as f64;
        let same = split.iter().map(|v| v.to_bits()).eq(alone.iter().map(|v| v.to_bits()))
            && stepped.iter().map(|v| v.to_bits()).eq(alone.iter().map(|v| v.to_bits()));
        let (target, ok) = if *n == 300 && *precision == Precision::F32 {
            ("≤ 3 µs, bit-identical", Some(two <= 3e-6 && same))
        } else {
            ("bit-identical", Some(same))
        };
        println!(
            "| {n} | {} | {} | {} | {:.2}× | {} ({:.0} %) | {} | {target} | {} |",
            format!("{precision:?}").to_lowercase(),
            secs(one),
            secs(two),
            one / two,
            secs(sync),
            100.0 * sync / two,
            if same { format!("bit-identical over {steps} steps") } else { "DIFFER".into() },
            ok.map_or("", verdict)
        );
    }
    Ok(())
}

/// When one run is split: the Python package's path (`free_runs_on` with one
/// run) on one thread and on two, over reservoir sizes, beside the rule
/// `cpg_lab::measure::SPLIT_MIN_NEURONS` the package applies by default.
fn split_rule(f: &Prepared) -> anyhow::Result<()> {
    use cpg_lab::measure::{RunSpec, SPLIT_MIN_NEURONS, free_runs_on};
    println!("\n## When one run is split (f64, one free run, `threads=None` in Python)\n");
    println!(
        "Seconds a step of one free run through `cpg_lab::measure::free_runs_on` (what `Model.generate` calls), on one thread and split by rows over two, median of 3. The split pays from the smallest N at which it is at least 10 % faster; the default rule splits from N = {SPLIT_MIN_NEURONS}.\n"
    );
    println!("| N | one thread | two threads | speed-up | default (`threads=None`) | the faster |");
    println!("|---:|---:|---:|---:|---|---|");
    let quick = TrainSettings {
        penalties: PenaltyGrid::log10_range(1.0, 1.0, -1.0)?,
        n_noise_draws: 1,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let none = cpg_lab::ControlSchedule::Constant(Vec::new());
    let mut wins_from: Option<usize> = None;
    let mut agree = true;
    for n in [300usize, 600, 1000, 1500, 2000, 3000] {
        let m = model(Reservoir::new(&config(n, Precision::F64)?, 1)?, f, &quick)?;
        let steps = (40_000_000 / (n * n)).clamp(500, 20_000);
        let spec = [RunSpec { model: &m, controls: &none, steps, push: None, noise: None }];
        let time = |threads: usize| -> anyhow::Result<f64> {
            let mut r = Ok(());
            let t = median3(|| {
                if let Err(e) = free_runs_on(&spec, threads).map(|v| v.into_iter().collect::<Result<Vec<_>, _>>()) {
                    r = Err(e);
                }
            });
            r?;
            Ok(t.as_secs_f64() / steps as f64)
        };
        let one = time(1)?;
        let two = time(2)?;
        let split_wins = two * 1.1 <= one;
        if split_wins && wins_from.is_none() {
            wins_from = Some(n);
        }
        let default_splits = n >= SPLIT_MIN_NEURONS;
        // The default is right when it splits exactly where the split is the faster.
        agree &= default_splits == (two < one) || (one / two - 1.0).abs() < 0.1;
        println!(
            "| {n} | {} | {} | {:.2}× | {} | {} |",
            secs(one),
            secs(two),
            one / two,
            if default_splits { "two threads" } else { "one thread" },
            if two < one { "two threads" } else { "one thread" }
        );
    }
    println!(
        "\nOn this machine the split is at least 10 % faster from N = {}; the default rule (N ≥ {SPLIT_MIN_NEURONS}) {} (within 10 % counts as a tie).",
        wins_from.map_or("(none measured)".to_string(), |n| n.to_string()),
        if agree {
            "picks the faster at every size measured"
        } else {
            "picks the slower at some size: revise SPLIT_MIN_NEURONS"
        }
    );
    Ok(())
}

/// The training phases at N = 300, each beside the time to stream W once.
fn phases(f: &Prepared) -> anyhow::Result<()> {
    println!("\n## Training phases (N = 300, all cores)\n");
    let threads = crate::cores();
    println!("| what | time | per network step, × stream-W floor | target | verdict |");
    println!("|---|---:|---:|---|---|");
    for precision in [Precision::F32, Precision::F64] {
        let n = 300;
        let res = Reservoir::new(&config(n, precision)?, 1)?;
        let floor = match precision {
            Precision::F32 => {
                let w: Vec<f32> = res.w().iter().map(|&v| v as f32).collect();
                stream_time(&w, 1)
            }
            Precision::F64 => stream_time(&res.w(), 1),
        }
        .as_secs_f64();
        let tag = format!("{precision:?}").to_lowercase();
        let row = |what: String, t: f64, steps: f64, target: &str, v: &str| {
            println!("| {what} | {} | {:.2} | {target} | {v} |", secs(t), t / steps / floor);
        };
        let seq = cpg_reservoir::Sequence::outputs_only(f.data.train.outputs[..2000].to_vec());
        let x0 = vec![0.0; n];
        let h = measure(|| {
            black_box(teacher_forced_states(&res, &x0, &seq).map(|s| s.len()).unwrap_or(0));
        });
        row(format!("teacher-forced harvest, 2000 steps ({tag})"), h.as_secs_f64(), 2000.0, "", "");
        let data = &f.data;
        let hv = harvest(&res, &data.train, 200)?;
        for draws in [1, 5] {
            let settings = TrainSettings { n_noise_draws: draws, ..TrainSettings::wyffels_schrauwen_2009() };
            let t = measure(|| {
                let path = RidgePath::new(hv.states.as_ref(), hv.targets.as_ref()).ok();
                let candidates: Vec<Candidate> = path
                    .iter()
                    .flat_map(|p| {
                        settings
                            .penalties
                            .values()
                            .iter()
                            .filter_map(|&l| p.solve(l).ok().map(|readout| Candidate { penalty: l, readout }))
                    })
                    .collect();
                black_box(validate(&res, &candidates, data, &settings, threads).map(|c| c.0.len()).ok());
            })
            .as_secs_f64();
            let (target, v) =
                if draws == 1 && precision == Precision::F32 { ("< 0.5 s", verdict(t < 0.5)) } else { ("", "") };
            row(
                format!("91-penalty sweep, 500-step noisy validation, {draws} draw(s) ({tag})"),
                t,
                (91 * 500 * draws) as f64,
                target,
                v,
            );
        }
        let settings = TrainSettings::wyffels_schrauwen_2009();
        let t = measure(|| {
            black_box(train_on(&res, data, &settings, threads).map(|t| t.penalty).ok());
        })
        .as_secs_f64();
        row(format!("training end to end, E1, 5 draws ({tag})"), t, (2199 + 91 * 5 * 500 + 2200) as f64, "", "");
    }
    Ok(())
}

/// Accuracy of the two precisions on E1 (seed 1): same reservoir, same data.
fn precision_table(f: &Prepared) -> anyhow::Result<()> {
    println!("\nPrecision on E1 (35_01 lfemur.rx, seed 1, paper settings):\n");
    println!(
        "| precision | chosen penalty | first-500 NMSE | max |f32 − f64| over 500 steps (deg) | period at 100k (frames) | half range at 100k (z) |"
    );
    println!("|---|---:|---:|---:|---:|---:|");
    let teacher = &f.data.validation.outputs;
    let mut runs = Vec::new();
    for precision in [Precision::F32, Precision::F64] {
        let m = model(Reservoir::new(&config(300, precision)?, 1)?, f, &TrainSettings::wyffels_schrauwen_2009())?;
        let mut g = Generator::new(&m);
        let mut out = Vec::with_capacity(FREE_RUN_STEPS);
        let mut norm = Vec::with_capacity(FREE_RUN_STEPS);
        for _ in 0..FREE_RUN_STEPS {
            out.push(g.step(&[])?[0]);
            norm.push(g.normalised_output()[0]);
        }
        let end = &norm[FREE_RUN_STEPS - 1200..];
        let period = estimate_period(end, 60, 250).unwrap_or(f64::NAN);
        runs.push((
            precision,
            m.provenance.chosen_penalty,
            nmse(&norm[..teacher.len()], teacher),
            out,
            period,
            cpg_mocap::cycle::half_range(end),
        ));
    }
    let diff = runs[0].3[..500].iter().zip(&runs[1].3[..500]).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    for (p, pen, nmse, _, period, hr) in &runs {
        println!("| {p:?} | {pen:e} | {nmse:.4} | {diff:.2e} | {period:.2} | {hr:.3} |");
    }
    Ok(())
}

fn nmse(y: &[f64], t: &[f64]) -> f64 {
    cpg_regression::nmse(y, t, 1)
}

/// Builds `cpg` (release) and returns its path.
fn build_cli() -> anyhow::Result<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let st = Command::new(cargo)
        .args(["build", "--release", "--quiet", "-p", "cpg-cli"])
        .current_dir(crate::root())
        .status()
        .context("building cpg")?;
    ensure!(st.success(), "building cpg failed ({st})");
    let exe = crate::release_binary("cpg");
    ensure!(exe.is_file(), "{} is missing after the build", exe.display());
    Ok(exe)
}

/// E1's configuration for one seed of the side-by-side run: the paper's
/// protocol with one noise draw, every path absolute, the model into `dir`.
fn e1_config(dir: &Path, seed: u64) -> anyhow::Result<(PathBuf, PathBuf)> {
    let src = crate::root().join("experiments/e1-paper.toml");
    let text = std::fs::read_to_string(&src).with_context(|| format!("reading {}", src.display()))?;
    let mut v: toml::Table = toml::from_str(&text).with_context(|| format!("parsing {}", src.display()))?;
    let base = src.parent().context("no parent")?.to_path_buf();
    let abs = |p: &toml::Value| -> anyhow::Result<toml::Value> {
        let s = p.as_str().context("a path is not a string")?;
        Ok(toml::Value::String(base.join(s).display().to_string()))
    };
    let data = v.get_mut("data").and_then(|d| d.as_table_mut()).context("no [data]")?;
    let sk = abs(data.get("skeleton").context("no data.skeleton")?)?;
    data.insert("skeleton".into(), sk);
    for seg in data.get_mut("segments").and_then(|s| s.as_array_mut()).context("no [[data.segments]]")? {
        let t = seg.as_table_mut().context("a segment is not a table")?;
        let m = abs(t.get("motion").context("no motion")?)?;
        t.insert("motion".into(), m);
    }
    v.get_mut("reservoir")
        .and_then(|r| r.as_table_mut())
        .context("no [reservoir]")?
        .insert("seed".into(), toml::Value::Integer(i64::try_from(seed)?));
    v.get_mut("training")
        .and_then(|r| r.as_table_mut())
        .context("no [training]")?
        .insert("noise_draws".into(), toml::Value::Integer(1));
    let model = dir.join(format!("e1-seed{seed}.cpg"));
    v.get_mut("output")
        .and_then(|r| r.as_table_mut())
        .context("no [output]")?
        .insert("model".into(), toml::Value::String(model.display().to_string()));
    v.remove("experiment");
    let path = dir.join(format!("e1-seed{seed}.toml"));
    std::fs::write(&path, toml::to_string(&v)?)?;
    Ok((path, model))
}

/// One E1 pipeline of cpg as a user runs it: `cpg train`, then `cpg generate`
/// of 100,000 steps to CSV.
struct CpgE1 {
    train: Ran,
    generate: Ran,
    penalty: f64,
    first500_nmse: f64,
}

fn cpg_e1(cpg: &Path, dir: &Path, seed: u64, teacher: &[f64]) -> anyhow::Result<CpgE1> {
    let (cfg, model) = e1_config(dir, seed)?;
    let train = run_child(Command::new(cpg).arg("train").arg("--config").arg(&cfg), "cpg train", false)?;
    let csv = dir.join(format!("e1-seed{seed}.csv"));
    let seconds = (FREE_RUN_STEPS as f64 / 120.0).to_string();
    let generate = run_child(
        Command::new(cpg).arg("generate").arg("--model").arg(&model).args(["--seconds", &seconds]).arg("-o").arg(&csv),
        "cpg generate",
        false,
    )?;
    let m = TrainedCpg::load(&model)?;
    let text = std::fs::read_to_string(&csv)?;
    let values: Vec<f64> =
        text.lines().filter_map(|l| l.split(',').next_back().and_then(|v| v.trim().parse::<f64>().ok())).collect();
    ensure!(
        values.len() == FREE_RUN_STEPS,
        "{} holds {} values, expected {FREE_RUN_STEPS}",
        csv.display(),
        values.len()
    );
    let o = m.outputs.first().context("the model has no output")?;
    let norm: Vec<f64> = values[..teacher.len()].iter().map(|v| (v - o.mean) / o.std).collect();
    Ok(CpgE1 { train, generate, penalty: m.provenance.chosen_penalty, first500_nmse: nmse(&norm, teacher) })
}

/// Peak memory of one run of the E1 pipeline, MiB.
struct E1Peaks {
    train: Option<f64>,
    generate: Option<f64>,
    reservoirpy: Option<f64>,
}

/// Part 3 (and the E1 rows of part 5): the E1 pipeline, alone or side by
/// side with ReservoirPy. Returns the peaks of every run (one alone, one per
/// pair beside ReservoirPy).
fn e1_pipeline(
    e1: &cpg_lab::Config,
    f: &Prepared,
    cpg: &Path,
    dir: &Path,
    pairs: Option<u64>,
) -> anyhow::Result<Vec<E1Peaks>> {
    let teacher = &f.data.validation.outputs;
    let Some(pairs) = pairs else {
        println!(
            "\n## 3. E1 pipeline (cpg train + cpg generate, seed 1; `--vs-reservoirpy` runs it beside ReservoirPy)\n"
        );
        let r = cpg_e1(cpg, dir, 1, teacher)?;
        println!(
            "`cpg train` {} + `cpg generate` {} = {}; chosen penalty {:e}, first-500 NMSE {:.4}",
            secs(r.train.wall_s),
            secs(r.generate.wall_s),
            secs(r.train.wall_s + r.generate.wall_s),
            r.penalty,
            r.first500_nmse
        );
        return Ok(vec![E1Peaks { train: r.train.peak_mib, generate: r.generate.peak_mib, reservoirpy: None }]);
    };
    println!(
        "\n## 3. E1 side by side with ReservoirPy 0.4.2 ({pairs} alternating pairs, seeds 1–{pairs})\n\nThe whole pipeline (harvest, 91-penalty sweep with one noise draw of variance {}, retrain, 100,000-step free run written to CSV). cpg: `cpg train` + `cpg generate`, processes on every core. ReservoirPy: `scripts/reservoirpy_e1.py` in one process, BLAS on one thread (two BLAS threads beside the Python loop are slower), OPENBLAS_CORETYPE and OPENBLAS_L2_SIZE unset. Wall times of whole processes (start-up and imports included); ReservoirPy's own timer of the pipeline beside it.\n",
        e1.training.noise_variance
    );
    let script = crate::root().join("scripts/reservoirpy_e1.sh");
    let st = Command::new("bash")
        .arg(&script)
        .arg("--setup")
        .env_remove("OPENBLAS_CORETYPE")
        .env_remove("OPENBLAS_L2_SIZE")
        .status()
        .context("running scripts/reservoirpy_e1.sh --setup")?;
    ensure!(st.success(), "scripts/reservoirpy_e1.sh --setup failed ({st})");
    let settings = cpg_lab::train::train_settings(e1)?;
    let rc = cpg_lab::train::reservoir_config(e1, 1)?;
    struct Pair {
        seed: u64,
        cpg: CpgE1,
        rp_wall_s: f64,
        rp_total_s: f64,
        rp_penalty: f64,
        rp_nmse: f64,
        rp_peak_mib: Option<f64>,
        rp_rows: usize,
    }
    let mut all = Vec::new();
    for seed in 1..=pairs {
        let csv = dir.join(format!("rp-seed{seed}.csv"));
        let input = serde_json::json!({
            "n_neurons": rc.n_neurons,
            "leak_rate": rc.leak_rate,
            "spectral_radius": rc.spectral_radius,
            "connectivity": rc.connectivity,
            "feedback_scale": rc.feedback.scale,
            "seed": seed,
            "train": f.data.train.outputs,
            "warmup": f.data.warmup.outputs,
            "validation": f.data.validation.outputs,
            "washout": settings.washout,
            "penalties": settings.penalties.values(),
            "noise_variance": settings.noise_variance,
            "noise_draws": 1,
            "free_run_steps": FREE_RUN_STEPS,
            "csv": csv.display().to_string(),
            "numpy_floor": false,
        });
        let json = dir.join(format!("rp-seed{seed}.json"));
        std::fs::write(&json, serde_json::to_vec(&input)?)?;
        let rp = || -> anyhow::Result<(Ran, serde_json::Value)> {
            let ran = run_child(
                Command::new("bash")
                    .arg(&script)
                    .arg(&json)
                    .env_remove("OPENBLAS_CORETYPE")
                    .env_remove("OPENBLAS_L2_SIZE"),
                "scripts/reservoirpy_e1.sh",
                false,
            )?;
            let v: serde_json::Value =
                serde_json::from_slice(&ran.stdout).context("reading the JSON scripts/reservoirpy_e1.py printed")?;
            Ok((ran, v))
        };
        let ((rp_ran, rp), ours) = if seed % 2 == 1 {
            let ours = cpg_e1(cpg, dir, seed, teacher)?;
            (rp()?, ours)
        } else {
            let r = rp()?;
            (r, cpg_e1(cpg, dir, seed, teacher)?)
        };
        let num = |k: &str| rp[k].as_f64().ok_or_else(|| anyhow::anyhow!("ReservoirPy's result has no number `{k}`"));
        let rows = std::fs::read_to_string(&csv).map(|t| t.lines().count()).unwrap_or(0);
        let p = Pair {
            seed,
            rp_wall_s: rp_ran.wall_s,
            rp_total_s: num("total_s")?,
            rp_penalty: num("chosen_penalty")?,
            rp_nmse: num("first500_nmse")?,
            rp_peak_mib: rp["peak_rss_kib"].as_f64().map(|k| k / 1024.0),
            rp_rows: rows,
            cpg: ours,
        };
        eprintln!(
            "  pair {seed}: cpg {:.2} s, ReservoirPy {:.2} s",
            p.cpg.train.wall_s + p.cpg.generate.wall_s,
            p.rp_wall_s
        );
        all.push(p);
    }
    println!(
        "| seed | first | cpg train | cpg generate | cpg total | ReservoirPy process | ReservoirPy pipeline (own timer) | ratio (processes) | penalty cpg | penalty ReservoirPy | first-500 NMSE cpg | ReservoirPy | peak cpg train / generate | peak ReservoirPy |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for p in &all {
        let ours = p.cpg.train.wall_s + p.cpg.generate.wall_s;
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.1}× | {:e} | {:e} | {:.4} | {:.4} | {} / {} | {} |",
            p.seed,
            if p.seed % 2 == 1 { "cpg" } else { "ReservoirPy" },
            secs(p.cpg.train.wall_s),
            secs(p.cpg.generate.wall_s),
            secs(ours),
            secs(p.rp_wall_s),
            secs(p.rp_total_s),
            p.rp_wall_s / ours,
            p.cpg.penalty,
            p.rp_penalty,
            p.cpg.first500_nmse,
            p.rp_nmse,
            mib(p.cpg.train.peak_mib),
            mib(p.cpg.generate.peak_mib),
            mib(p.rp_peak_mib),
        );
        ensure!(p.rp_rows >= FREE_RUN_STEPS, "ReservoirPy wrote {} rows, expected {FREE_RUN_STEPS}", p.rp_rows);
    }
    let ratios: Vec<f64> = all.iter().map(|p| p.rp_wall_s / (p.cpg.train.wall_s + p.cpg.generate.wall_s)).collect();
    let own: Vec<f64> = all.iter().map(|p| p.rp_total_s / (p.cpg.train.wall_s + p.cpg.generate.wall_s)).collect();
    let (lo, hi) = range(&ratios);
    let (olo, ohi) = range(&own);
    let r = median(&ratios);
    println!(
        "\ncpg is {r:.1}× faster than ReservoirPy (median of {pairs} pairs, range {lo:.1}–{hi:.1}×; against ReservoirPy's own timer of its pipeline, without Python's start-up: {:.1}×, range {olo:.1}–{ohi:.1}×). Target ≥ 15×: {}.",
        median(&own),
        verdict(r >= 15.0)
    );
    let lp = |v: Vec<f64>| range(&v.iter().map(|x| x.log10()).collect::<Vec<_>>());
    let (ca, cb) = lp(all.iter().map(|p| p.cpg.penalty).collect());
    let (ra, rb) = lp(all.iter().map(|p| p.rp_penalty).collect());
    let overlap = ca <= rb && ra <= cb;
    let cn: Vec<f64> = all.iter().map(|p| p.cpg.first500_nmse).collect();
    let rn: Vec<f64> = all.iter().map(|p| p.rp_nmse).collect();
    let (cna, cnb) = range(&cn);
    let (rna, rnb) = range(&rn);
    let spread = (cnb - cna).max(rnb - rna);
    let gap = (median(&cn) - median(&rn)).abs();
    println!(
        "Chosen penalties: cpg 10^{ca:.1}…10^{cb:.1}, ReservoirPy 10^{ra:.1}…10^{rb:.1} ({}). First-500 NMSE: cpg median {:.4} (range {cna:.4}–{cnb:.4}), ReservoirPy median {:.4} (range {rna:.4}–{rnb:.4}); the medians differ by {gap:.4}, {} the larger spread across seeds ({spread:.4}).",
        if overlap { "the regions overlap" } else { "the regions do NOT overlap" },
        median(&cn),
        median(&rn),
        if gap <= spread { "within" } else { "OUTSIDE" }
    );
    println!("(the reservoirs differ: each tool draws its own weights from the same recipe and seed)");
    ensure!(!all.is_empty(), "no pair ran");
    Ok(all
        .iter()
        .map(|p| E1Peaks { train: p.cpg.train.peak_mib, generate: p.cpg.generate.peak_mib, reservoirpy: p.rp_peak_mib })
        .collect())
}

/// Part 4a: `cpg tune` at the E1 size with the long-run objective.
fn tune_throughput(cpg: &Path, dir: &Path, memory: &mut Memory) -> anyhow::Result<()> {
    let (budget, seeds, seconds) = (8, 10, 900);
    println!(
        "\n## 4. Throughput\n\n`cpg tune --config experiments/e1.toml --budget {budget} --seeds {seeds} --seconds {seconds}` (each configuration trained on {seeds} seeds and judged by {seeds} × {} steps plus the push):\n",
        seconds * 120
    );
    let out = dir.join("tuned.toml");
    let ran = run_child(
        Command::new(cpg)
            .arg("tune")
            .arg("--config")
            .arg(crate::root().join("experiments/e1.toml"))
            .args(["--budget", &budget.to_string(), "--seeds", &seeds.to_string(), "--seconds", &seconds.to_string()])
            .arg("--json")
            .arg("-o")
            .arg(&out),
        "cpg tune",
        false,
    )?;
    let v: serde_json::Value = serde_json::from_slice(&ran.stdout).context("reading cpg tune's JSON")?;
    let n = v["candidates"].as_array().map_or(0, Vec::len);
    let best = v["candidates"][0]["passed"].as_u64().unwrap_or(0);
    println!(
        "{n} configurations in {} on {} cores: **{:.1} configurations per minute** (best passed on {best} of {seeds} seeds)",
        secs(ran.wall_s),
        crate::cores(),
        n as f64 / (ran.wall_s / 60.0)
    );
    memory.rows.push((format!("`cpg tune` ({n} configurations × {seeds} seeds)"), ran.peak_mib));
    Ok(())
}

/// Training the largest models as a user does (`cpg train`, a process on
/// every core): E6's 2,000 neurons and the whole body's 59 channels, whose
/// target is a minute.
fn big_models(cpg: &Path, dir: &Path, memory: &mut Memory) -> anyhow::Result<()> {
    const WHOLE_BODY_TARGET_S: f64 = 60.0;
    println!("\nTraining the largest models (`cpg train`, one process on {} cores):\n", crate::cores());
    println!("| configuration | wall time | target | verdict |");
    println!("|---|---:|---|---|");
    for (name, target) in [("e6.toml", None), ("whole-body.toml", Some(WHOLE_BODY_TARGET_S))] {
        let out = dir.join(name.replace(".toml", ".cpg"));
        let ran = run_child(
            Command::new(cpg)
                .arg("train")
                .arg("--config")
                .arg(crate::root().join("experiments").join(name))
                .arg("-o")
                .arg(&out),
            "cpg train",
            false,
        )?;
        println!(
            "| `experiments/{name}` | {} | {} | {} |",
            secs(ran.wall_s),
            target.map_or(String::new(), |t| format!("≤ {t:.0} s")),
            target.map_or("", |t| verdict(ran.wall_s <= t))
        );
        memory.rows.push((format!("`cpg train` (`experiments/{name}`)"), ran.peak_mib));
    }
    Ok(())
}

/// The script that times the closed loop: the walk's CPG (seed 1) with the
/// feedback, 60 s on flat ground at 1 kHz in one process, beside MuJoCo's
/// steps alone (the floor: physics, no controller) for as many steps.
const CLOSED_LOOP_PY: &str = r#"
import json, sys, time
import mujoco, numpy as np
import cpg
from cpg.sim import Gains, read_trajectory, simulate
walk = read_trajectory(sys.argv[1])
model = cpg.train(sys.argv[2], seed=1)
gains = Gains.from_json(open(sys.argv[3]).read())
t0 = time.perf_counter()
r = simulate(*walk, seconds=60.0, gains=gains, cpg_model=model)
loop_s = time.perf_counter() - t0
m = mujoco.MjModel.from_xml_string(cpg.hoap2_mjcf())
d = mujoco.MjData(m)
mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
t0 = time.perf_counter()
for _ in range(int(round(r["upright_s"] / m.opt.timestep))):
    mujoco.mj_step(m, d)
physics_s = time.perf_counter() - t0
print(json.dumps({"sim_s": r["upright_s"], "loop_s": loop_s, "physics_s": physics_s, "fell": r["fell"]}))
"#;

/// Part 4b: the HOAP-2's closed loop in MuJoCo, against real time and against the physics alone.
fn closed_loop(cpg: &Path, dir: &Path) -> anyhow::Result<()> {
    println!("\n## The closed loop in MuJoCo (one core)\n");
    let py = crate::python::install()?;
    let root = crate::root();
    let walk = dir.join("walk.csv");
    let config = root.join("experiments/hoap2-walk.toml");
    let c = cpg_lab::Config::load(&config)?;
    let Some(cpg_lab::config::ExperimentTest::Walking(t)) = c.experiment.as_ref().map(|e| &e.test) else {
        anyhow::bail!("{}: not a walking experiment", config.display())
    };
    crate::report::walking::plan_start_walk(cpg, &c, t.start_steps, &walk)?;
    let ran = run_child(
        Command::new(&py).arg("-c").arg(CLOSED_LOOP_PY).arg(&walk).arg(&config).arg(&t.gains),
        "the closed loop",
        false,
    )?;
    let v: serde_json::Value = serde_json::from_slice(&ran.stdout).context("reading the closed loop's JSON")?;
    let (sim, loop_s, physics) = (
        v["sim_s"].as_f64().unwrap_or(0.0),
        v["loop_s"].as_f64().unwrap_or(f64::NAN),
        v["physics_s"].as_f64().unwrap_or(f64::NAN),
    );
    println!("| what | simulated | wall | × real time | target | verdict |");
    println!("|---|---:|---:|---:|---|---|");
    println!(
        "| the CPG with feedback at 1 kHz (`cpg.sim.simulate`, the generator stepped inside the loop){} | {sim:.1} s | {} | {:.1}× | ≥ 20× | {} |",
        if v["fell"].as_bool() == Some(true) { " — it fell" } else { "" },
        secs(loop_s),
        sim / loop_s,
        verdict(sim / loop_s >= 20.0)
    );
    println!(
        "| MuJoCo's steps alone, as many (the floor) | {sim:.1} s | {} | {:.1}× | | |",
        secs(physics),
        sim / physics
    );
    Ok(())
}

/// Part 4c: the full evaluation, timed section by section.
fn evaluation(dir: &Path, memory: &mut Memory) -> anyhow::Result<()> {
    let out = dir.join("report");
    println!("\n`cargo xtask evaluate` (10 seeds in every experiment), its own progress below:\n");
    let exe = std::env::current_exe().context("finding the xtask binary")?;
    let ran = run_child(Command::new(exe).arg("evaluate").arg("--out").arg(&out), "cargo xtask evaluate", true)?;
    let metrics: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json"))?)?;
    // The sections as the report's `run.seconds` lists them: [name, wall seconds] in the order they ran.
    let sections: Vec<(String, f64)> = metrics["run"]["seconds"]
        .as_array()
        .context("metrics.json has no run.seconds")?
        .iter()
        .map(|e| (e[0].as_str().unwrap_or("?").to_owned(), e[1].as_f64().unwrap_or(f64::NAN)))
        .collect();
    println!("\n| section | time |");
    println!("|---|---:|");
    for (k, v) in &sections {
        println!("| `{k}` | {} |", secs(*v));
    }
    // Issue 49's budget for the whole body (ridge on 10 seeds and FORCE beside it).
    const WHOLE_BODY_SECTION_S: f64 = 300.0;
    let body: f64 = sections.iter().filter(|(k, _)| k.contains("whole-body")).map(|(_, v)| v).sum();
    println!(
        "| the whole body's section (`experiments/whole-body*.toml`) | {} (target ≤ {:.0} min: {}) |",
        secs(body),
        WHOLE_BODY_SECTION_S / 60.0,
        verdict(body <= WHOLE_BODY_SECTION_S)
    );
    println!(
        "| **the whole evaluation** | **{}** (target ≤ 10 min: {}) |",
        secs(ran.wall_s),
        verdict(ran.wall_s <= 600.0)
    );
    memory.rows.push(("`cargo xtask evaluate`".into(), ran.peak_mib));
    Ok(())
}

fn tempfile_dir() -> anyhow::Result<PathBuf> {
    let d = std::env::temp_dir().join(format!("cpg-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}

//! The experiments of wyffels & Schrauwen (2009) on CMU subject 35. Today:
//! E1 (learned femur pattern) with its long-run check; the others come with
//! the experiments issue.

use std::path::{Path, PathBuf};

use anyhow::Context;
use cpg_mocap::cycle::{align_to_cycle, best_loop, estimate_period, half_range, tile};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton, ZScore};
use cpg_reservoir::{
    Generator, OutputChannel, Reservoir, ReservoirConfig, Sequence, TrainSettings, TrainedCpg, TrainingData, train,
};

/// Teacher-forced training samples of E1 (after a 200-step washout: 2000 used).
pub const E1_TRAIN_LEN: usize = 2200;
/// Validation free-run length (the paper's 500 samples).
pub const E1_VALIDATION_LEN: usize = 500;

/// One seamless gait cycle of 35_01 `lfemur.rx`, z-scored, and its normalisation.
pub struct Femur {
    /// The cycle, z-scored.
    pub cycle: Vec<f64>,
    /// Mean of the channel over the whole trial, degrees.
    pub mean_deg: f64,
    /// Standard deviation over the whole trial, degrees.
    pub std_deg: f64,
    /// Period estimated by autocorrelation, frames.
    pub period: f64,
    /// First frame of the loop in the trial.
    pub start: usize,
    /// Seam jump of the loop beyond a typical step (z units).
    pub seam_excess: f64,
}

/// Loads 35_01 and cuts the most seamless single gait cycle out of its
/// `lfemur.rx` channel (the whole 358-frame trial repeated would jump by 2.65σ
/// at every seam).
pub fn femur() -> anyhow::Result<Femur> {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf")?)?;
    let m = Motion::from_amc_file(find(Subject::S35, "35_01.amc")?, &sk, 120.0)?;
    let f = m.select(&["lfemur.rx"])?;
    let z = ZScore::fit(&f)?;
    let x = z.apply(&f)?.values().to_vec();
    let period = estimate_period(&x, 60, 250).context("no gait period found in 35_01 lfemur.rx")?;
    let lp = best_loop(&x, 1, period, 1).context("no seamless loop found in 35_01 lfemur.rx")?;
    Ok(Femur {
        cycle: x[lp.start..lp.start + lp.len].to_vec(),
        mean_deg: z.mean[0],
        std_deg: z.std[0],
        period,
        start: lp.start,
        seam_excess: lp.seam_excess,
    })
}

/// E1's data: the cycle tiled for training and warm-up, its continuation for validation.
pub fn e1_data(f: &Femur) -> TrainingData {
    TrainingData {
        train: Sequence::outputs_only(tile(&f.cycle, 1, E1_TRAIN_LEN, 0)),
        warmup: Sequence::outputs_only(tile(&f.cycle, 1, E1_TRAIN_LEN, 0)),
        validation: Sequence::outputs_only(tile(&f.cycle, 1, E1_VALIDATION_LEN, E1_TRAIN_LEN)),
    }
}

/// Trains E1 with the paper's reservoir and validation.
pub fn train_e1(f: &Femur, seed: u64, settings: &TrainSettings) -> anyhow::Result<TrainedCpg> {
    let res = Reservoir::new(&ReservoirConfig::wyffels_schrauwen_2009().check()?, seed)?;
    let tr = train(&res, &e1_data(f), settings)?;
    let out = vec![OutputChannel { name: "lfemur.rx".into(), mean: f.mean_deg, std: f.std_deg }];
    let data = format!(
        "CMU 35_01 lfemur.rx at 120 Hz, z-scored (mean {:.3}°, std {:.3}°); one gait cycle (frames {}..{}, period {:.2}, seam {:.3} z above a typical step) tiled to {E1_TRAIN_LEN} samples, washout {}, validation = the next {E1_VALIDATION_LEN}",
        f.mean_deg,
        f.std_deg,
        f.start,
        f.start + f.cycle.len(),
        f.period,
        f.seam_excess,
        settings.washout
    );
    Ok(TrainedCpg::new(res, tr, settings.clone(), out, vec![], data, 120.0)?)
}

/// `cargo xtask train`.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Which experiment (only E1 so far).
    #[arg(long, default_value = "e1", value_parser = ["e1", "E1"])]
    experiment: String,
    /// Reservoir seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory for the model files.
    #[arg(long, default_value = "models")]
    out: PathBuf,
}

pub fn run_train(args: &TrainArgs) -> anyhow::Result<()> {
    let f = femur()?;
    let settings = TrainSettings::wyffels_schrauwen_2009();
    let t = std::time::Instant::now();
    let m = train_e1(&f, args.seed, &settings)?;
    let train_s = t.elapsed().as_secs_f64();
    let dir = if args.out.is_absolute() { args.out.clone() } else { crate::root().join(&args.out) };
    let path = dir.join(format!("e1-seed{}.cpg", args.seed));
    m.save(&path)?;
    let p = &m.provenance;
    println!("E1, seed {}: trained in {train_s:.2} s → {}", args.seed, rel(&path));
    println!("  data: {}", p.data);
    println!(
        "  chosen penalty {:e} of {} (validation NMSE {:.3}), one-step training NMSE {:.2e}",
        p.chosen_penalty,
        p.validation_curve.len(),
        p.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min),
        p.train_nmse
    );
    let curve: Vec<String> =
        p.validation_curve.iter().step_by(10).map(|v| format!("{:.0e}→{:.2}", v.penalty, v.nmse)).collect();
    println!("  validation curve (every 10th): {}", curve.join("  "));

    // Free run from the trained start state.
    let mut g = Generator::new(&m);
    let n = 108_000;
    let mut y = Vec::with_capacity(n);
    for _ in 0..n {
        g.step(&[])?;
        y.push(g.normalised_output()[0]);
    }
    let teacher = tile(&f.cycle, 1, E1_VALIDATION_LEN, E1_TRAIN_LEN);
    let var = {
        let mu = teacher.iter().sum::<f64>() / teacher.len() as f64;
        teacher.iter().map(|t| (t - mu).powi(2)).sum::<f64>() / teacher.len() as f64
    };
    let nmse = y.iter().zip(&teacher).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / teacher.len() as f64 / var;
    let end = &y[n - 1200..];
    let period = estimate_period(end, 60, 250).unwrap_or(f64::NAN);
    let (_, end_nmse) = align_to_cycle(end, &f.cycle, 1);
    println!("  free run: first-500 NMSE {nmse:.4}");
    println!(
        "  after {n} steps (900 s): period {period:.2} frames (teacher {}), half range {:.3} (teacher {:.3}, z units), phase-aligned NMSE of the last 10 s {end_nmse:.4}",
        f.cycle.len(),
        half_range(end),
        half_range(&f.cycle)
    );
    Ok(())
}

fn rel(p: &Path) -> String {
    p.strip_prefix(crate::root()).unwrap_or(p).display().to_string()
}

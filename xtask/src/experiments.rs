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
    Ok(TrainedCpg::new(res, tr, settings.clone(), out, vec![], data, 120.0)?.with_reference_cycle(f.cycle.clone())?)
}

/// `cargo xtask train`.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Which experiment: e1 (also the model of E2 and E3), e4, e5, e6, or all.
    #[arg(long, default_value = "e1", value_parser = ["e1", "e2", "e3", "e4", "e5", "e6", "all"], ignore_case = true)]
    experiment: String,
    /// Reservoir seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Directory for the model files.
    #[arg(long, default_value = "models")]
    out: PathBuf,
}

pub fn run_train(args: &TrainArgs) -> anyhow::Result<()> {
    let which = args.experiment.to_ascii_lowercase();
    let dir = if args.out.is_absolute() { args.out.clone() } else { crate::root().join(&args.out) };
    let settings = TrainSettings::wyffels_schrauwen_2009();
    let save = |name: &str, m: TrainedCpg, t: std::time::Instant| -> anyhow::Result<()> {
        let path = dir.join(format!("{name}-seed{}.cpg", args.seed));
        m.save(&path)?;
        println!(
            "{name}: trained in {:.2} s, penalty {:e} → {}",
            t.elapsed().as_secs_f64(),
            m.provenance.chosen_penalty,
            rel(&path)
        );
        Ok(())
    };
    if matches!(which.as_str(), "e4" | "all") {
        let t = std::time::Instant::now();
        save("e4", train_e4(&femur()?, args.seed, &settings)?, t)?;
    }
    if matches!(which.as_str(), "e5" | "all") {
        let t = std::time::Instant::now();
        save("e5", train_e5(&gaits()?, args.seed, &settings)?, t)?;
    }
    if matches!(which.as_str(), "e6" | "all") {
        let t = std::time::Instant::now();
        let s6 = TrainSettings { n_noise_draws: 2, ..settings.clone() };
        save("e6", train_e6(&walk22()?, 2000, args.seed, &s6)?, t)?;
    }
    if !matches!(which.as_str(), "e1" | "e2" | "e3" | "all") {
        return Ok(());
    }
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

// ---------------------------------------------------------------------------
// E4–E6 and the shared pieces.

use cpg_reservoir::Coupling;

/// A loop of one channel of a CMU trial, z-scored with the given statistics.
pub fn channel_cycle(trial: &str, channel: &str, mean: f64, std: f64) -> anyhow::Result<(Vec<f64>, f64)> {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf")?)?;
    let m = Motion::from_amc_file(find(Subject::S35, trial)?, &sk, 120.0)?;
    let x: Vec<f64> = m.column(channel)?.iter().map(|v| (v - mean) / std).collect();
    // From 0.4 s: on a 1.4 s running trial a shorter floor lets a sub-harmonic win.
    let hi = (x.len() / 2).min(250);
    let period = estimate_period(&x, 48, hi).with_context(|| format!("no period in {trial} {channel}"))?;
    let lp = best_loop(&x, 1, period, 1).with_context(|| format!("no loop in {trial} {channel}"))?;
    Ok((x[lp.start..lp.start + lp.len].to_vec(), period))
}

/// Reads a periodic table at a fractional position (linear interpolation, wrapping).
pub fn periodic_at(cycle: &[f64], pos: f64) -> f64 {
    let p = cycle.len() as f64;
    let q = pos.rem_euclid(p);
    let i0 = q.floor() as usize % cycle.len();
    let i1 = (i0 + 1) % cycle.len();
    let t = q - q.floor();
    cycle[i0] + t * (cycle[i1] - cycle[i0])
}

/// A smooth random control in [lo, hi]: knots every `every` samples, cosine-interpolated.
pub fn smooth_random(n: usize, every: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    // A small deterministic generator (xorshift) keeps xtask free of rand.
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let knots: Vec<f64> = (0..=n / every + 1).map(|_| lo + (hi - lo) * next()).collect();
    (0..n)
        .map(|k| {
            let (i, t) = (k / every, (k % every) as f64 / every as f64);
            let w = 0.5 - 0.5 * (std::f64::consts::PI * t).cos();
            knots[i] * (1.0 - w) + knots[i + 1] * w
        })
        .collect()
}

/// The femur cycle played at rate `u[k]` (u = 6: six times the original frequency).
pub fn rate_modulated(cycle: &[f64], u: &[f64], start: f64) -> (Vec<f64>, f64) {
    let mut pos = start;
    let mut out = Vec::with_capacity(u.len());
    for r in u {
        out.push(periodic_at(cycle, pos));
        pos += r;
    }
    (out, pos)
}

/// E4: one control input u ∈ [1, 6] to 25 % of the neurons.
pub const E4_INPUT: Coupling = Coupling { fraction: 0.25, scale: 0.05 };

pub fn train_e4(f: &Femur, seed: u64, settings: &TrainSettings) -> anyhow::Result<TrainedCpg> {
    let mut c = ReservoirConfig::wyffels_schrauwen_2009();
    c.inputs = vec![E4_INPUT];
    let res = Reservoir::new(&c.check()?, seed)?;
    let u = smooth_random(21_000, 700, 1.0, 6.0, 4);
    let (y, _) = rate_modulated(&f.cycle, &u, 0.0);
    let train_seq = Sequence { outputs: y[..20_000].to_vec(), controls: u[..20_000].to_vec() };
    let data = TrainingData {
        warmup: train_seq.clone(),
        train: train_seq,
        validation: Sequence { outputs: y[20_000..].to_vec(), controls: u[20_000..].to_vec() },
    };
    let tr = train(&res, &data, settings)?;
    let out = vec![OutputChannel { name: "lfemur.rx".into(), mean: f.mean_deg, std: f.std_deg }];
    let m = TrainedCpg::new(res, tr, settings.clone(), out, vec!["u_rate".into()], "E4: 35_01 lfemur.rx cycle resampled at a smoothly varying rate u ∈ [1, 6] (20,000 training + 1,000 validation samples)".into(), 120.0)?;
    Ok(m.with_reference_cycle(f.cycle.clone())?)
}

/// E5's two gaits, z-scored together.
pub struct Gaits {
    pub walk: Vec<f64>,
    pub run: Vec<f64>,
    pub mean_deg: f64,
    pub std_deg: f64,
}

pub fn gaits() -> anyhow::Result<Gaits> {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf")?)?;
    let w = Motion::from_amc_file(find(Subject::S35, "35_01.amc")?, &sk, 120.0)?.select(&["lfemur.rx"])?;
    let r = Motion::from_amc_file(find(Subject::S35, "35_17.amc")?, &sk, 120.0)?.select(&["lfemur.rx"])?;
    let z = ZScore::fit(&w.concat(&r)?)?;
    let (walk, _) = channel_cycle("35_01.amc", "lfemur.rx", z.mean[0], z.std[0])?;
    let (run, _) = channel_cycle("35_17.amc", "lfemur.rx", z.mean[0], z.std[0])?;
    Ok(Gaits { walk, run, mean_deg: z.mean[0], std_deg: z.std[0] })
}

pub fn train_e5(g: &Gaits, seed: u64, settings: &TrainSettings) -> anyhow::Result<TrainedCpg> {
    let mut c = ReservoirConfig::wyffels_schrauwen_2009();
    c.n_neurons = 600;
    c.inputs = vec![Coupling { fraction: 0.5, scale: 0.2 }; 2];
    let res = Reservoir::new(&c.check()?, seed)?;
    let mut outputs = tile(&g.walk, 1, 1000, 0);
    outputs.extend(tile(&g.run, 1, 1000, 0));
    let mut controls = [1.0, 0.0].repeat(1000);
    controls.extend([0.0, 1.0].repeat(1000));
    let train_seq = Sequence { outputs, controls };
    let data = TrainingData {
        warmup: train_seq.clone(),
        train: train_seq,
        validation: Sequence { outputs: tile(&g.run, 1, 500, 1000), controls: [0.0, 1.0].repeat(500) },
    };
    let tr = train(&res, &data, settings)?;
    let out = vec![OutputChannel { name: "lfemur.rx".into(), mean: g.mean_deg, std: g.std_deg }];
    let m = TrainedCpg::new(res, tr, settings.clone(), out, vec!["u_walk".into(), "u_run".into()], "E5: 1,000 samples of the 35_01 walking femur cycle (u_walk = 1) then 1,000 of the 35_17 running cycle (u_run = 1), z-scored together; validated running".into(), 120.0)?;
    Ok(m)
}

/// E6's 22 channels: the HOAP-2 map's, in its order.
pub const E6_CHANNELS: [&str; 22] = [
    "lfemur.ry",
    "lfemur.rz",
    "lfemur.rx",
    "ltibia.rx",
    "lfoot.rx",
    "lfoot.rz",
    "rfemur.ry",
    "rfemur.rz",
    "rfemur.rx",
    "rtibia.rx",
    "rfoot.rx",
    "rfoot.rz",
    "lhumerus.rx",
    "lhumerus.rz",
    "lhumerus.ry",
    "lradius.rx",
    "lwrist.ry",
    "rhumerus.rx",
    "rhumerus.rz",
    "rhumerus.ry",
    "rradius.rx",
    "rwrist.ry",
];

/// E6 data: 35_02, 22 channels z-scored, one seamless cycle.
pub struct Walk22 {
    pub cycle: Vec<f64>,
    pub data: Vec<f64>,
    pub outputs: Vec<OutputChannel>,
}

pub fn walk22() -> anyhow::Result<Walk22> {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf")?)?;
    let m = Motion::from_amc_file(find(Subject::S35, "35_02.amc")?, &sk, 120.0)?.select(&E6_CHANNELS)?;
    let z = ZScore::fit(&m)?;
    let x = z.apply(&m)?.values().to_vec();
    let femur: Vec<f64> = x.iter().skip(2).step_by(22).copied().collect();
    let period = estimate_period(&femur, 60, 200).context("no period in 35_02")?;
    let lp = best_loop(&x, 22, period, 1).context("no loop in 35_02")?;
    let outputs = E6_CHANNELS
        .iter()
        .enumerate()
        .map(|(k, n)| OutputChannel { name: (*n).into(), mean: z.mean[k], std: z.std[k] })
        .collect();
    Ok(Walk22 { cycle: x[lp.start * 22..(lp.start + lp.len) * 22].to_vec(), data: x, outputs })
}

pub fn train_e6(w: &Walk22, n_neurons: usize, seed: u64, settings: &TrainSettings) -> anyhow::Result<TrainedCpg> {
    let mut c = ReservoirConfig::wyffels_schrauwen_2009();
    c.n_neurons = n_neurons;
    c.n_outputs = 22;
    c.feedback = Coupling { fraction: 0.65, scale: 0.11 };
    let res = Reservoir::new(&c.check()?, seed)?;
    let train_seq = Sequence::outputs_only(tile(&w.cycle, 22, E1_TRAIN_LEN, 0));
    let data = TrainingData {
        warmup: train_seq.clone(),
        train: train_seq,
        validation: Sequence::outputs_only(tile(&w.cycle, 22, E1_VALIDATION_LEN, E1_TRAIN_LEN)),
    };
    let tr = train(&res, &data, settings)?;
    let m = TrainedCpg::new(
        res,
        tr,
        settings.clone(),
        w.outputs.clone(),
        vec![],
        format!(
            "E6: 22 arm and leg channels of 35_02, z-scored, one seamless cycle of {} frames tiled",
            w.cycle.len() / 22
        ),
        120.0,
    )?;
    Ok(m.with_reference_cycle(w.cycle.clone())?)
}

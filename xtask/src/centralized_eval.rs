//! `cargo xtask evaluate-centralized`: the second generator family and the DMP
//! baseline on marker positions (issue 5, non-segmented part so far).
//!
//! Positions: forward kinematics of 35_01 (358 frames), 31 points × 3
//! coordinates in mm. Measures (our definitions; the paper's are unknown):
//! mean 3-D distance over points and frames (mm); relative integral error =
//! mean over coordinates of Σ|x − x̂| / Σ|x − x̄|; ErrABS = mean over
//! coordinates of the mean |x − x̂| (mm).

use std::f64::consts::PI;
use std::time::Instant;

use cpg_centralized::{Basis, CentralizedNet, aicc, search_frequencies};
use cpg_dmp::{DmpConfig, RhythmicDmp};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton};

const RATE: f64 = 120.0;

struct Errors {
    mean_mm: f64,
    rel_integral: f64,
    err_abs_mm: f64,
}

fn errors(x: &[f64], y: &[f64], d: usize) -> Errors {
    let t = x.len() / d;
    let mut dist = 0.0;
    for k in 0..t {
        for p in 0..d / 3 {
            let s: f64 = (0..3).map(|c| (x[k * d + 3 * p + c] - y[k * d + 3 * p + c]).powi(2)).sum();
            dist += s.sqrt();
        }
    }
    let (mut rel, mut abs) = (0.0, 0.0);
    for c in 0..d {
        let col: Vec<f64> = x.iter().skip(c).step_by(d).copied().collect();
        let m = col.iter().sum::<f64>() / t as f64;
        let num: f64 = (0..t).map(|k| (x[k * d + c] - y[k * d + c]).abs()).sum();
        let den: f64 = col.iter().map(|v| (v - m).abs()).sum::<f64>().max(1e-12);
        rel += num / den;
        abs += num / t as f64;
    }
    Errors { mean_mm: dist / (t * d / 3) as f64, rel_integral: rel / d as f64, err_abs_mm: abs / d as f64 }
}

pub fn run() -> anyhow::Result<()> {
    let start = Instant::now();
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf")?)?;
    let m = Motion::from_amc_file(find(Subject::S35, "35_01.amc")?, &sk, RATE)?;
    let p = sk.forward_kinematics(&m)?;
    let d = p.names.len() * 3;
    let x: Vec<f64> = p.points_mm.iter().flat_map(|q| q.iter().copied()).collect();
    let t = x.len() / d;
    println!("35_01: {t} frames × {} points × 3 coordinates (mm), {:.2} s", p.names.len(), t as f64 / RATE);
    // Frequencies are searched on three markers (root z, both ankles' heights) and transferred.
    let marker = |name: &str, c: usize| -> usize { p.point_index(name).unwrap_or(0) * 3 + c };
    let few = [marker("root", 2), marker("ltibia", 1), marker("rtibia", 1)];
    let xr = &x;
    let sub: Vec<f64> = (0..t).flat_map(|k| few.iter().map(move |&c| xr[k * d + c])).collect();
    println!(
        "| model | mean 3-D error (mm) | relative integral error | ErrABS (mm) | AICc (per coordinate) | frequencies (Hz) |"
    );
    println!("|---|---:|---:|---:|---:|---|");
    for centers in 1..=3usize {
        // Grids: 40 frequencies for one or two centers, 16 for three (560 combinations).
        let n_grid = if centers == 3 { 16 } else { 40 };
        let grid: Vec<f64> = (0..n_grid).map(|k| 0.05 + 2.45 * k as f64 / (n_grid - 1) as f64).collect();
        for n in [16usize, 25, 49, 100] {
            let side = (n as f64).powf(1.0 / centers as f64);
            let basis = Basis::Rbf { b: side.sqrt() };
            let w = search_frequencies(centers, &grid, n, basis, &sub, few.len(), RATE)?;
            let net = CentralizedNet::fit(w.clone(), n, basis, &x, d, RATE)?;
            let y = net.generate(t, RATE);
            let e = errors(&x, &y, d);
            let rss = net.rss(&x, RATE) / d as f64;
            let hz: Vec<String> = w.iter().map(|w| format!("{:.3}", w / (2.0 * PI))).collect();
            println!(
                "| {centers} center(s) / {n} satellites | {:.1} | {:.4} | {:.1} | {:.0} | {} |",
                e.mean_mm,
                e.rel_integral,
                e.err_abs_mm,
                aicc(rss, t, n + 1 + centers),
                hz.join(", ")
            );
        }
    }
    // pydmps-style DMP, 100 basis functions, the whole trial as one period, one step per frame.
    let cfg = DmpConfig::pydmps(100, 2.0 * PI / t as f64);
    let mut dmp = RhythmicDmp::imitate(cfg, &x, d)?;
    let mut y = dmp.rollout(Some(t), 1.0);
    y.truncate(x.len());
    let e = errors(&x, &y, d);
    println!(
        "| DMP, 100 basis functions | {:.1} | {:.4} | {:.1} | — | one period = the trial |",
        e.mean_mm, e.rel_integral, e.err_abs_mm
    );
    println!("| reservoir CPG | n/a: trained on joint angles, not positions | | | | |");
    println!("\n({:.0} s)", start.elapsed().as_secs_f64());
    Ok(())
}

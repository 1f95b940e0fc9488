//! From a configuration to training data: read, select, normalise, loop, tile.

use anyhow::{Context, bail};
use cpg_mocap::cycle::{autocorrelation, best_loop, estimate_period, tile};
use cpg_mocap::{Motion, Skeleton, ZScore};
use cpg_reservoir::{OutputChannel, Sequence, TrainingData};

use crate::config::Config;

/// Training data with what the model keeps of it.
pub struct Prepared {
    pub data: TrainingData,
    pub outputs: Vec<OutputChannel>,
    /// One period of the last segment's loop (normalised), when loops are used.
    pub reference_cycle: Option<Vec<f64>>,
    pub description: String,
}

/// The period of a multi-channel signal: the estimate of the channel whose
/// autocorrelation at its own period is highest (the most regular channel),
/// searched from 0.3 s to 2.5 s or half the signal.
fn period(x: &[f64], d: usize, rate_hz: f64) -> Option<(f64, usize)> {
    let t = x.len() / d;
    let lo = (0.3 * rate_hz) as usize;
    let hi = ((2.5 * rate_hz) as usize).min(t / 2);
    (0..d)
        .filter_map(|c| {
            let col: Vec<f64> = x.iter().skip(c).step_by(d).copied().collect();
            let p = estimate_period(&col, lo, hi)?;
            Some((p, c, autocorrelation(&col, p.round() as usize)))
        })
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map(|(p, c, _)| (p, c))
}

pub fn prepare(c: &Config) -> anyhow::Result<Prepared> {
    let sk = Skeleton::from_file(&c.data.skeleton)?;
    let names: Vec<&str> = c.data.channels.iter().map(String::as_str).collect();
    let d = names.len();
    let u = c.data.controls.len();
    let mut parts = Vec::new();
    for s in &c.data.segments {
        let m = Motion::from_amc_file(&s.motion, &sk, c.data.rate_hz)?;
        let m = m.select(&names).with_context(|| format!("selecting channels of {}", s.motion.display()))?;
        let m = match s.frames {
            Some([a, b]) => m.slice(a, b).with_context(|| format!("frames of {}", s.motion.display()))?,
            None => m,
        };
        parts.push(m);
    }
    let all = parts.iter().skip(1).try_fold(parts[0].clone(), |acc, m| acc.concat(m))?;
    let z = ZScore::fit(&all)?;
    let mut outputs = Vec::new();
    let mut controls = Vec::new();
    let mut reference_cycle = None;
    let mut notes = Vec::new();
    let v = c.training.validation_samples;
    let (train, validation);
    if c.data.loop_cycles > 0 {
        let mut last = None;
        for (k, (m, s)) in parts.iter().zip(&c.data.segments).enumerate() {
            let x = z.apply(m)?.values().to_vec();
            let (p, ch) = period(&x, d, c.data.rate_hz)
                .with_context(|| format!("segment {}: no rhythm found (is the motion periodic and > 0.6 s?)", k + 1))?;
            let lp = best_loop(&x, d, p, c.data.loop_cycles).with_context(|| {
                format!(
                    "segment {}: {} cycles of {p:.1} frames do not fit its {} frames",
                    k + 1,
                    c.data.loop_cycles,
                    m.n_frames()
                )
            })?;
            let cycle = x[lp.start * d..(lp.start + lp.len) * d].to_vec();
            notes.push(format!(
                "segment {} ({}): period {p:.1} frames (from {}), loop frames {}..{}, seam excess {:.3}",
                k + 1,
                c.data.segments[k].motion.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
                c.data.channels[ch],
                lp.start,
                lp.start + lp.len,
                lp.seam_excess
            ));
            outputs.extend(tile(&cycle, d, c.data.samples_per_segment, 0));
            for _ in 0..c.data.samples_per_segment {
                controls.extend_from_slice(&s.controls);
            }
            last = Some((cycle, s.controls.clone()));
        }
        let Some((cycle, ctl)) = last else { bail!("no segments") };
        let val = tile(&cycle, d, v, c.data.samples_per_segment);
        validation = Sequence { outputs: val, controls: ctl.repeat(v) };
        train = Sequence { outputs, controls };
        reference_cycle = Some(cycle);
    } else {
        for (m, s) in parts.iter().zip(&c.data.segments) {
            outputs.extend_from_slice(z.apply(m)?.values());
            for _ in 0..m.n_frames() {
                controls.extend_from_slice(&s.controls);
            }
        }
        let t = outputs.len() / d;
        if v + c.training.washout + 2 > t {
            bail!("{t} samples cannot hold a washout of {} and {v} validation samples", c.training.washout);
        }
        validation = Sequence { outputs: outputs[(t - v) * d..].to_vec(), controls: controls[(t - v) * u..].to_vec() };
        train = Sequence { outputs: outputs[..(t - v) * d].to_vec(), controls: controls[..(t - v) * u].to_vec() };
        notes.push(format!("segments used as recorded; the last {v} samples validate"));
    }
    let outputs_meta = c
        .data
        .channels
        .iter()
        .enumerate()
        .map(|(k, name)| OutputChannel { name: name.clone(), mean: z.mean[k], std: z.std[k] })
        .collect();
    let description = format!(
        "{} channel(s) [{}] at {} Hz from {}; z-scored; {}",
        d,
        c.data.channels.join(", "),
        c.data.rate_hz,
        c.data.segments.iter().map(|s| s.motion.display().to_string()).collect::<Vec<_>>().join(", "),
        notes.join("; ")
    );
    Ok(Prepared {
        data: TrainingData { warmup: train.clone(), train, validation },
        outputs: outputs_meta,
        reference_cycle,
        description,
    })
}

//! From a configuration to training data: read the motions, select and
//! normalise the channels, cut seamless loops, build the training sequence
//! (blocks, repeats, morphs or a tempo), the validation run and the teachers.

use std::f64::consts::PI;
use std::path::Path;

use cpg_mocap::cycle::{autocorrelation, best_loop, estimate_period, half_range, tile};
use cpg_mocap::{Channel, Motion, Skeleton, ZScore};
use cpg_reservoir::{Hold, OrbitStay, OutputChannel, Score, Scoring, Sequence, Teacher, TrainingData};

use crate::config::{Config, MAX_TRAINING_SAMPLES, MAX_VALIDATION_STEPS, OrbitSection, TempoSection};
use crate::error::{Error, Result};

/// The period of one segment and the loop cut from it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SegmentCycle {
    /// The segment's label.
    pub label: String,
    /// Frames in the segment.
    pub frames: usize,
    /// Period estimated by autocorrelation, frames (0: a standing posture).
    pub period_frames: f64,
    /// The channel whose rhythm gave the period.
    pub period_channel: String,
    /// First frame of the loop in the segment.
    pub loop_start: usize,
    /// Frames in the loop.
    pub loop_len: usize,
    /// Seam jump beyond a typical step, standard deviations.
    pub seam_excess: f64,
    /// Whether the period is one stride, from both legs (`None`: the motion
    /// has no left/right hip pair to check with).
    pub stride: Option<StrideCheck>,
}

/// Whether a gait period is one stride: both hips have it as their own
/// period, and the right one moves half a cycle behind the left (each leg
/// swings once per stride). A period that were half a stride or two strides
/// would fail one of the two.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StrideCheck {
    /// The left hip's channel.
    pub left: String,
    /// The right hip's channel.
    pub right: String,
    /// The left hip's own period, frames.
    pub left_period_frames: f64,
    /// The right hip's own period, frames.
    pub right_period_frames: f64,
    /// How far the right hip trails the left, cycles of the segment's period, in (−0.5, 0.5].
    pub right_lag_cycles: f64,
    /// Both periods within 3 % of the segment's and the lag within 0.1 cycle of a half.
    pub confirmed: bool,
}

/// Hip channels that say whether a period is a stride, by naming convention (CMU ASF, BVH).
const HIP_PAIRS: [(&str, &str); 3] =
    [("lfemur.rx", "rfemur.rx"), ("LeftUpLeg.rx", "RightUpLeg.rx"), ("LeftHip.rx", "RightHip.rx")];

/// Checks the period `p` (frames) of motion `m` with its hips, searching periods in `[lo, hi]` frames.
pub fn stride_check(m: &Motion, p: f64, lo: usize, hi: usize) -> Option<StrideCheck> {
    let names = m.channel_names();
    let (l, r) = HIP_PAIRS.iter().find(|(l, r)| names.iter().any(|n| n == l) && names.iter().any(|n| n == r))?;
    let (a, b) = (m.column(l).ok()?, m.column(r).ok()?);
    let t = a.len();
    let hi = hi.min(t - t / 4);
    let lp = estimate_period(&a, lo.max(2), hi)?;
    let rp = estimate_period(&b, lo.max(2), hi)?;
    let shift = cpg_mocap::cycle::lag(&a, &b, (p / 2.0).ceil() as usize + 1) / p;
    let wrapped = 0.5 - (0.5 - shift).rem_euclid(1.0);
    let close = |x: f64| (x / p - 1.0).abs() < 0.03;
    Some(StrideCheck {
        left: l.to_string(),
        right: r.to_string(),
        left_period_frames: lp,
        right_period_frames: rp,
        right_lag_cycles: wrapped,
        confirmed: close(lp) && close(rp) && (wrapped.abs() - 0.5).abs() < 0.1,
    })
}

/// Training data and what the model keeps of it.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Training, warm-up and validation sequences, and the validation score.
    pub data: TrainingData,
    /// The output channels with their normalisation.
    pub outputs: Vec<OutputChannel>,
    /// The rhythms the model is taught, one per control setting.
    pub teachers: Vec<Teacher>,
    /// One entry per segment when loops are cut.
    pub cycles: Vec<SegmentCycle>,
    /// Each segment as recorded, normalised (`frames × D`).
    pub segments: Vec<Vec<f64>>,
    /// The skeleton's ASF text (for BVH motions, written from the hierarchy), if any.
    pub skeleton_asf: Option<String>,
    /// The parsed skeleton, if any.
    pub skeleton: Option<Skeleton>,
    /// One line describing the data (stored in the model).
    pub description: String,
    /// Things the user should know (a possible harmonic, a large seam).
    pub notes: Vec<String>,
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

fn column(x: &[f64], d: usize, c: usize) -> Vec<f64> {
    x.iter().skip(c).step_by(d).copied().collect()
}

/// The gait period of a multi-channel signal (`t × d`): the estimate of the
/// given channel, or of the channel whose autocorrelation at its own period
/// is highest. The search runs from `lo` frames up to `hi` or three quarters
/// of the signal, so that a trial shorter than two strides still shows one
/// full stride. Returns (period, channel, autocorrelation at the period).
pub fn gait_period(x: &[f64], d: usize, lo: usize, hi: usize, channel: Option<usize>) -> Option<(f64, usize, f64)> {
    let t = x.len() / d.max(1);
    let hi = hi.min(t - t / 4);
    let one = |c: usize| {
        let col = column(x, d, c);
        let p = estimate_period(&col, lo.max(2), hi)?;
        Some((p, c, autocorrelation(&col, p.round() as usize)))
    };
    match channel {
        Some(c) => one(c),
        None => (0..d).filter_map(one).max_by(|a, b| a.2.total_cmp(&b.2)),
    }
}

/// A phase-continuous blend from cycle `a` to cycle `b` (normalised, `p × d`),
/// or one cycle played on: sample at phase `ph` (in cycles) with weight `w` of `b`.
fn blend_at(a: &[f64], b: &[f64], d: usize, ph: f64, w: f64, out: &mut Vec<f64>) {
    let (pa, pb) = (a.len() / d, b.len() / d);
    for c in 0..d {
        let va = periodic(a, pa, d, ph * pa as f64, c);
        let vb = if w > 0.0 { periodic(b, pb, d, ph * pb as f64, c) } else { 0.0 };
        out.push((1.0 - w) * va + w * vb);
    }
}

pub(crate) fn periodic(cycle: &[f64], p: usize, d: usize, pos: f64, c: usize) -> f64 {
    let q = pos.rem_euclid(p as f64);
    let i0 = (q.floor() as usize).min(p - 1);
    let i1 = (i0 + 1) % p;
    let t = q - i0 as f64;
    cycle[i0 * d + c] + t * (cycle[i1 * d + c] - cycle[i0 * d + c])
}

fn cosine(t: f64) -> f64 {
    0.5 - 0.5 * (PI * t.clamp(0.0, 1.0)).cos()
}

/// A cycle rotated so that it starts at the maximum of channel 0.
fn rotate_to_max(cycle: &[f64], d: usize) -> Vec<f64> {
    let p = cycle.len() / d;
    let top = (0..p).fold(0, |b, k| if cycle[k * d] > cycle[b * d] { k } else { b });
    (0..p).flat_map(|k| cycle[((top + k) % p) * d..((top + k) % p + 1) * d].iter().copied()).collect()
}

/// A smooth random control in `[lo, hi]`: knots every `every` samples, joined
/// by cosine blends. Deterministic (xorshift from `seed`).
pub fn smooth_random(n: usize, every: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let every = every.max(1);
    let knots: Vec<f64> = (0..=n / every + 1).map(|_| lo + (hi - lo) * next()).collect();
    (0..n)
        .map(|k| {
            let (i, t) = (k / every, (k % every) as f64 / every as f64);
            let w = 0.5 - 0.5 * (PI * t).cos();
            knots[i] * (1.0 - w) + knots[i + 1] * w
        })
        .collect()
}

/// Motions to learn from, one per segment of a configuration, as read (every
/// channel they have, cut to the segment's frames): what [`prepare`] reads
/// from the files, or what a caller holding the data in memory gives
/// [`prepare_recorded`].
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The skeleton the motions belong to and its ASF text, if any (a model
    /// trained without one cannot be drawn or exported as AMC or BVH).
    pub skeleton: Option<(Skeleton, String)>,
    /// One motion per `[[data.segments]]` entry, at `data.rate_hz`.
    pub parts: Vec<Motion>,
}

/// Reads the motion files of a configuration: AMC with the ASF skeleton, or
/// BVH; with `[data.retarget]`, the robot's walk retargeted from the trials.
pub fn read_recorded(c: &Config) -> Result<Recorded> {
    let d_sec = &c.data;
    if let Some(r) = &d_sec.retarget {
        return retargeted(c, r);
    }
    let n_bvh = d_sec.segments.iter().filter(|s| cpg_mocap::is_bvh(&s.motion)).count();
    if n_bvh > 0 && n_bvh < d_sec.segments.len() {
        return Err(c.error("data.segments", "mixes BVH and AMC motions; give one kind"));
    }
    match (&d_sec.skeleton, n_bvh > 0) {
        (None, false) => {
            return Err(
                c.error("data.skeleton", "is missing: AMC motions need their ASF skeleton (skeleton = \"35.asf\")")
            );
        }
        (Some(_), true) => {
            return Err(c.error("data.skeleton", "is given, but BVH motions carry their own skeleton: leave it out"));
        }
        _ => {}
    }
    let cut = |m: Motion, s: &crate::config::SegmentSection| -> Result<Motion> {
        Ok(match s.frames {
            Some([a, b]) => m.slice(a, b)?,
            None => m,
        })
    };
    let mut parts = Vec::new();
    let skeleton = match &d_sec.skeleton {
        Some(path) => {
            let bytes = cpg_mocap::read_bounded(path, cpg_mocap::MAX_INPUT_BYTES)?;
            let sk = cpg_mocap::parse_asf(&path.display().to_string(), &bytes).map_err(cpg_mocap::Error::from)?;
            for s in &d_sec.segments {
                parts.push(cut(Motion::from_amc_file(&s.motion, &sk, d_sec.rate_hz)?, s)?);
            }
            // parse_asf accepted the bytes, so they are UTF-8.
            (sk, String::from_utf8_lossy(&bytes).into_owned())
        }
        None => {
            let opts = cpg_mocap::BvhOptions { length_unit_mm: d_sec.bvh_unit_mm };
            let mut first: Option<Skeleton> = None;
            for (k, s) in d_sec.segments.iter().enumerate() {
                let b = cpg_mocap::Bvh::from_file(&s.motion, &opts)?;
                let rate = b.motion.sample_rate_hz();
                if (rate - d_sec.rate_hz).abs() > 1e-3 * d_sec.rate_hz {
                    return Err(c.error(
                        "data.rate_hz",
                        format!(
                            "is {} Hz, but {} holds frames every {} s ({rate} Hz): set data.rate_hz = {rate}",
                            d_sec.rate_hz,
                            s.motion.display(),
                            b.frame_time_s
                        ),
                    ));
                }
                match &first {
                    Some(sk) if sk.bones != b.skeleton.bones || sk.root != b.skeleton.root => {
                        return Err(c.error(
                            &format!("data.segments[{k}].motion"),
                            format!("{}: its hierarchy differs from the first segment's", s.motion.display()),
                        ));
                    }
                    Some(_) => {}
                    None => first = Some(b.skeleton.clone()),
                }
                let m = Motion::new(b.motion.channels().to_vec(), b.motion.values().to_vec(), d_sec.rate_hz)?;
                parts.push(cut(m, s)?);
            }
            let sk = first.ok_or_else(|| Error::Unusable("no segments".into()))?;
            let asf = cpg_mocap::write_asf(&sk);
            (sk, asf)
        }
    };
    Ok(Recorded { skeleton: Some(skeleton), parts })
}

/// One motion per segment: the HOAP-2's steady stride retargeted from the
/// trials at the segment's tempo, repeated, channels `JOINT.rx` in degrees.
fn retargeted(c: &Config, r: &crate::config::RetargetSection) -> Result<Recorded> {
    use crate::retarget::{RetargetOptions, human_walk, retarget};
    let bvh = cpg_mocap::BvhOptions { length_unit_mm: c.data.bvh_unit_mm };
    let given = r.profile.as_ref().map(cpg_mocap::profile::Profile::from_file).transpose()?;
    let mut trials = Vec::with_capacity(r.trials.len());
    for path in &r.trials {
        let rec = cpg_mocap::read_recording(path, c.data.skeleton.as_deref(), Some(r.trial_rate_hz), &bvh)?;
        let points = cpg_mocap::profile::Profile::for_skeleton(&rec.skeleton, given.as_ref())?;
        trials.push((rec.skeleton.forward_kinematics(&rec.motion)?, points));
    }
    let human = human_walk(&trials)?;
    let robot = cpg_robot::Robot::hoap2()?;
    let mass =
        cpg_robot::physics::MassModel::from_urdf(&robot, cpg_robot::assets::HOAP2_URDF, Path::new("hoap2.urdf"))?;
    let mut parts = Vec::with_capacity(c.data.segments.len());
    for (k, s) in c.data.segments.iter().enumerate() {
        let o = RetargetOptions {
            step_scale: r.step_scale,
            lift_scale: r.lift_scale,
            arm_scale: r.arm_scale,
            double_support_share: r.double_support_share,
            steps: r.steps,
            rate_hz: c.data.rate_hz,
            tempo: s.tempo.unwrap_or(1.0),
            ..RetargetOptions::default()
        };
        let (_, plan, _) = retarget(&human, &robot, &mass, &o)?;
        let (a, b) = plan.steady_stride;
        let d = plan.joints.len();
        let channels: Vec<Channel> =
            plan.joints.iter().map(|j| Channel { bone: j.clone(), dof: cpg_mocap::Dof::Rx }).collect();
        if s.stand {
            // The pose the walk starts from, held for as long as the strides last.
            let frames = (b - a).max(1) * r.strides;
            let pose = &plan.q_rad[..d];
            let values: Vec<f64> = std::iter::repeat_n(pose, frames).flatten().map(|v| v.to_degrees()).collect();
            parts.push(Motion::new(channels, values, c.data.rate_hz)?);
            continue;
        }
        if b <= a + 1 {
            return Err(c.error(
                &format!("data.segments[{k}]"),
                format!(
                    "the retargeted walk has no steady stride in {} steps: plan more (data.retarget.steps)",
                    r.steps
                ),
            ));
        }
        let stride = &plan.q_rad[a * d..b * d];
        let values: Vec<f64> = std::iter::repeat_n(stride, r.strides).flatten().map(|v| v.to_degrees()).collect();
        parts.push(Motion::new(channels, values, c.data.rate_hz)?);
    }
    Ok(Recorded { skeleton: None, parts })
}

/// `m` with the channels at indices `rates` replaced by their rate of change
/// per second (central differences, one-sided at the ends): what a channel of
/// `data.velocity` is learnt as.
pub fn as_rates(m: &Motion, rates: &[usize]) -> Result<Motion> {
    if rates.is_empty() {
        return Ok(m.clone());
    }
    let d = m.channels().len();
    let t = m.n_frames();
    let rate = m.sample_rate_hz();
    let x = m.values();
    let mut v = x.to_vec();
    if t >= 2 {
        for &c in rates {
            for k in 0..t {
                let (a, b) = (k.saturating_sub(1), (k + 1).min(t - 1));
                v[k * d + c] = (x[b * d + c] - x[a * d + c]) * rate / (b - a) as f64;
            }
        }
    } else {
        rates.iter().for_each(|&c| v[c] = 0.0);
    }
    Ok(Motion::new(m.channels().to_vec(), v, rate)?)
}

/// The motions of a configuration, with the channels selected and normalised.
struct Read {
    channels: Vec<String>,
    parts: Vec<Motion>,
    z: ZScore,
    /// Channels that never move in the data (normalised in their own units).
    still: Vec<String>,
    labels: Vec<String>,
}

fn select(c: &Config, rec: &Recorded) -> Result<Read> {
    let d_sec = &c.data;
    if rec.parts.len() != d_sec.segments.len() {
        return Err(Error::Shape(format!(
            "{} motions for {} [[data.segments]] entries",
            rec.parts.len(),
            d_sec.segments.len()
        )));
    }
    let all: Vec<String> = match &rec.skeleton {
        Some((sk, _)) => crate::channels::all_channels(sk),
        None => rec.parts.first().map(Motion::channel_names).unwrap_or_default(),
    };
    let mut channels = crate::channels::expand_in(&d_sec.channels, &all).map_err(|m| c.error("data.channels", m))?;
    let mut rates = Vec::with_capacity(d_sec.velocity.len());
    for n in &d_sec.velocity {
        let k = channels.iter().position(|x| x == n).ok_or_else(|| {
            c.error("data.velocity", format!("'{n}' is not one of the learnt channels (data.channels)"))
        })?;
        if rates.contains(&k) {
            return Err(c.error("data.velocity", format!("names '{n}' twice")));
        }
        rates.push(k);
    }
    let names: Vec<&str> = channels.iter().map(String::as_str).collect();
    let mut parts = Vec::with_capacity(rec.parts.len());
    for (k, m) in rec.parts.iter().enumerate() {
        if m.sample_rate_hz() != d_sec.rate_hz {
            return Err(Error::Shape(format!(
                "segment {}: {} Hz, the configuration says {} Hz (data.rate_hz)",
                k + 1,
                m.sample_rate_hz(),
                d_sec.rate_hz
            )));
        }
        parts.push(as_rates(&m.select(&names)?, &rates)?);
    }
    for &k in &rates {
        channels[k].push_str(cpg_reservoir::VELOCITY_SUFFIX);
    }
    let all = parts.iter().skip(1).try_fold(parts[0].clone(), |acc, m| acc.concat(m))?;
    let (mut z, still) = ZScore::fit_holding_still(&all);
    if d_sec.normalise == crate::config::Normalise::Rhythm {
        rhythm_std(&parts, &still, &mut z.std);
    }
    let still = still.into_iter().map(|k| channels[k].clone()).collect();
    let labels = d_sec
        .segments
        .iter()
        .map(|s| {
            s.label.clone().unwrap_or_else(|| match s.tempo {
                Some(t) => format!("walk ×{t}"),
                None if s.stand && s.motion.as_os_str().is_empty() => "stand".into(),
                None => file_name(&s.motion),
            })
        })
        .collect();
    Ok(Read { channels, parts, z, still, labels })
}

/// Segment `k`'s standing posture (normalised, `x` its frames): one frame,
/// the mean of the segment's; a rate channel held at 0 (a posture does not
/// travel); with a skeleton and the root's height learnt, on the floor the
/// gaits walk on.
fn posture(
    c: &Config,
    r: &Read,
    k: usize,
    x: &[f64],
    recorded: &[Motion],
    skeleton: Option<&Skeleton>,
    notes: &mut Vec<String>,
) -> Result<Vec<f64>> {
    let d = r.channels.len();
    let t = x.len() / d.max(1);
    let mut pose: Vec<f64> = (0..d)
        .map(|c| {
            if r.channels[c].ends_with(cpg_reservoir::VELOCITY_SUFFIX) {
                -r.z.mean[c] / r.z.std[c]
            } else {
                column(x, d, c).iter().sum::<f64>() / t.max(1) as f64
            }
        })
        .collect();
    let height = r.channels.iter().position(|ch| ch == "root.ty");
    if let (Some(sk), Some(ty)) = (skeleton, height) {
        let gaits: Vec<&Motion> =
            recorded.iter().zip(&c.data.segments).filter(|(_, s)| !s.stand).map(|(m, _)| m).collect();
        if let Some(lift_mm) = posture_lift_mm(sk, &recorded[k], &gaits)? {
            pose[ty] += lift_mm / sk.mm_per_unit() / r.z.std[ty];
            notes.push(format!(
                "segment {}: the posture (the mean frame) {} by {:.1} mm so that its lower foot stands on the floor the other segments' feet walk on",
                r.labels[k],
                if lift_mm >= 0.0 { "raised" } else { "lowered" },
                lift_mm.abs()
            ));
        }
    }
    Ok(pose)
}

/// How far (mm) the mean frame of `motion` must rise for its lower foot to
/// stand on the floor of `gaits` ([`crate::measure::floors`] of their
/// [`crate::measure::feet`]): the most any foot lies below its floor.
/// `None` without a gait or a foot point.
fn posture_lift_mm(sk: &Skeleton, motion: &Motion, gaits: &[&Motion]) -> Result<Option<f64>> {
    if gaits.is_empty() {
        return Ok(None);
    }
    let (n, w) = (motion.n_frames().max(1), motion.channels().len());
    let mean: Vec<f64> = (0..w).map(|c| motion.values().iter().skip(c).step_by(w).sum::<f64>() / n as f64).collect();
    // The channels a motion lacks (a BVH's, a test's) are 0, as its writers put them.
    let fk = |m: &Motion| sk.complete(m).and_then(|m| sk.forward_kinematics(&m));
    let pose = fk(&Motion::new(motion.channels().to_vec(), mean, motion.sample_rate_hz())?)?;
    let walked = gaits.iter().map(|m| fk(m)).collect::<std::result::Result<Vec<_>, _>>()?;
    let feet = crate::measure::feet(sk);
    let floors = crate::measure::floors(&walked, &feet);
    Ok(feet
        .iter()
        .zip(&floors)
        .filter_map(|(name, floor)| pose.point_index(name).map(|i| floor - pose.points_mm[i][1]))
        .reduce(f64::max))
}

/// One seamless loop per segment (normalised, rotated to start at the
/// reference channel's maximum when blocks are morphed), and what was found.
fn loops(
    c: &Config,
    r: &Read,
    recorded: &[Motion],
    skeleton: Option<&Skeleton>,
    notes: &mut Vec<String>,
) -> Result<(Vec<Vec<f64>>, Vec<SegmentCycle>)> {
    let d_sec = &c.data;
    let d = r.channels.len();
    let rate = d_sec.rate_hz;
    let period_channel =
        match &d_sec.period_channel {
            Some(name) => Some(r.channels.iter().position(|x| x == name).ok_or_else(|| {
                c.error("data.period_channel", format!("'{name}' is not one of the learnt channels"))
            })?),
            None => None,
        };
    let lo = (d_sec.period_s[0] * rate).round() as usize;
    let hi = (d_sec.period_s[1] * rate).round() as usize;
    let (mut loops, mut cycles) = (Vec::new(), Vec::new());
    for (k, m) in r.parts.iter().enumerate() {
        let label = &r.labels[k];
        let x = r.z.apply(m)?.values().to_vec();
        let t = m.n_frames();
        if d_sec.segments[k].stand {
            // A posture that is a frame of a rhythm is set once the rhythm's teacher is built.
            let pose = if d_sec.segments[k].stand_from.is_some() {
                vec![0.0; d]
            } else {
                posture(c, r, k, &x, recorded, skeleton, notes)?
            };
            loops.push(pose);
            cycles.push(SegmentCycle {
                label: label.clone(),
                frames: t,
                period_frames: 0.0,
                period_channel: String::new(),
                loop_start: 0,
                loop_len: 1,
                seam_excess: 0.0,
                stride: None,
            });
            continue;
        }
        let (p, ch, _) = gait_period(&x, d, lo, hi, period_channel).ok_or_else(|| {
            Error::Unusable(format!(
                "segment {} ({label}): no rhythm found between {} and {} s in its {t} frames (is the motion periodic?)",
                k + 1,
                d_sec.period_s[0],
                d_sec.period_s[1]
            ))
        })?;
        let lp = best_loop(&x, d, p, d_sec.loop_cycles).ok_or_else(|| {
            Error::Unusable(format!(
                "segment {} ({label}): {} cycle(s) of {p:.1} frames do not fit its {t} frames",
                k + 1,
                d_sec.loop_cycles
            ))
        })?;
        if lp.seam_excess > d_sec.max_seam_excess {
            return Err(Error::Unusable(format!(
                "segment {} ({label}): the best loop of {} cycle(s) of {p:.1} frames jumps {:.2} σ beyond a typical step at its seam (data.max_seam_excess = {}); the period may be a harmonic: try data.period_s, data.period_channel or data.loop_cycles",
                k + 1,
                d_sec.loop_cycles,
                lp.seam_excess,
                d_sec.max_seam_excess
            )));
        }
        let stride = recorded.get(k).and_then(|m| stride_check(m, p, lo, hi));
        if 2.0 * p > (t - t / 4) as f64 && d_sec.loop_cycles == 1 {
            notes.push(match &stride {
                Some(s) if s.confirmed => format!(
                    "segment {} ({label}): {t} frames hold {:.1} periods of {p:.1}, too few to see a second stride in the rhythm alone; both legs confirm one stride ({} has its own period {:.1} frames, {} {:.1}, and the two are {:.2} cycle apart)",
                    k + 1,
                    t as f64 / p,
                    s.left,
                    s.left_period_frames,
                    s.right,
                    s.right_period_frames,
                    s.right_lag_cycles.abs()
                ),
                _ => format!(
                    "segment {} ({label}): {t} frames hold {:.1} periods of {p:.1}, too few to rule out that the true stride is twice as long, and no left/right hip pair confirms it; check the loop in a figure",
                    k + 1,
                    t as f64 / p
                ),
            });
        }
        let mut cycle = x[lp.start * d..(lp.start + lp.len) * d].to_vec();
        if d_sec.segments[k].group.is_some() {
            // Averaged with the group's other trials at their own phases, the seam would stay a jump.
            cycle = closed_seam(&cycle, d);
        }
        loops.push(if d_sec.morph_s > 0.0 { rotate_to_max(&cycle, d) } else { cycle });
        cycles.push(SegmentCycle {
            label: label.clone(),
            frames: t,
            period_frames: p,
            period_channel: r.channels[ch].clone(),
            loop_start: lp.start,
            loop_len: lp.len,
            seam_excess: lp.seam_excess,
            stride,
        });
    }
    Ok((loops, cycles))
}

/// One teacher per segment, but one per group of segments (`group`): the
/// average of the group's loops, each resampled to the group's median period
/// and shifted to the phase that best matches the first's.
fn teachers_of(c: &Config, labels: &[String], loops: &[Vec<f64>], d: usize, notes: &mut Vec<String>) -> Vec<Teacher> {
    let segs = &c.data.segments;
    let mut out = Vec::new();
    for i in c.data.teacher_segments() {
        let s = &segs[i];
        let Some(g) = &s.group else {
            out.push(Teacher {
                label: labels[i].clone(),
                controls: s.controls.clone(),
                cycle: loops[i].clone(),
                rate: 1.0,
            });
            continue;
        };
        let members: Vec<&[f64]> =
            segs.iter().zip(loops).filter(|(x, _)| x.group.as_ref() == Some(g)).map(|(_, l)| l.as_slice()).collect();
        let mut periods: Vec<usize> = members.iter().map(|l| l.len() / d).collect();
        periods.sort_unstable();
        let len =
            crate::stats::median(&periods.iter().map(|&p| p as f64).collect::<Vec<_>>()).round().max(2.0) as usize;
        let resampled: Vec<Vec<f64>> = members
            .iter()
            .map(|l| {
                let p = l.len() / d;
                (0..len)
                    .flat_map(|k| (0..d).map(move |ch| periodic(l, p, d, k as f64 * p as f64 / len as f64, ch)))
                    .collect()
            })
            .collect();
        let mut mean = vec![0.0; len * d];
        for r in &resampled {
            let shift = best_shift(&resampled[0], r, d);
            for (k, v) in mean.iter_mut().enumerate() {
                *v += r[((k / d + shift) % len) * d + k % d];
            }
        }
        mean.iter_mut().for_each(|v| *v /= members.len() as f64);
        // Averaging shrinks a channel whose swing is out of phase between
        // trials (the hands, the neck): each channel's swing about its mean
        // is scaled back to the median of the trials' half ranges.
        let mut scales = Vec::with_capacity(d);
        for ch in 0..d {
            let mut own: Vec<f64> = resampled.iter().map(|r| half_range(&column(r, d, ch))).collect();
            own.sort_by(f64::total_cmp);
            let target = crate::stats::median(&own);
            let col = column(&mean, d, ch);
            let now = half_range(&col);
            let scale = if now > 1e-9 && target > 1e-9 { target / now } else { 1.0 };
            let centre = col.iter().sum::<f64>() / len as f64;
            for k in 0..len {
                let v = &mut mean[k * d + ch];
                *v = centre + scale * (*v - centre);
            }
            scales.push(scale);
        }
        let widest = scales.iter().copied().fold(1.0, f64::max);
        notes.push(format!(
            "group {g}: {} trials (periods {}–{} frames), each loop closed at its seam, averaged into one cycle of {len} frames, each channel's swing scaled to the trials' median half range (by up to {widest:.2}×)",
            members.len(),
            periods[0],
            periods[periods.len() - 1]
        ));
        out.push(Teacher { label: g.clone(), controls: s.controls.clone(), cycle: mean, rate: 1.0 });
    }
    out
}

/// A loop (`p × d`) whose seam is closed: each channel's step from its
/// last frame back to its first made the mean of the steps beside it (the
/// first and the last), the difference spread linearly over the loop. A
/// trial's loop cut from a short recording (a run's 1.8 strides) jumps at
/// its seam; averaged with others at another phase, each jump would stay a
/// step faster than the person ever moved.
fn closed_seam(l: &[f64], d: usize) -> Vec<f64> {
    let p = l.len() / d.max(1);
    let mut out = l.to_vec();
    if p < 3 {
        return out;
    }
    for ch in 0..d {
        let at = |k: usize| l[k * d + ch];
        let expected = 0.5 * ((at(1) - at(0)) + (at(p - 1) - at(p - 2)));
        let excess = (at(0) - at(p - 1)) - expected;
        for k in 0..p {
            out[k * d + ch] += excess * k as f64 / (p - 1) as f64;
        }
    }
    out
}

/// The circular shift (frames) of `b` closest to `a`, both `len × d`.
fn best_shift(a: &[f64], b: &[f64], d: usize) -> usize {
    let len = a.len() / d;
    let cost = |s: usize| -> f64 {
        (0..len).map(|k| (0..d).map(|ch| (a[k * d + ch] - b[((k + s) % len) * d + ch]).powi(2)).sum::<f64>()).sum()
    };
    (0..len)
        .fold((0, f64::INFINITY), |best, s| {
            let e = cost(s);
            if e < best.1 { (s, e) } else { best }
        })
        .0
}

/// Training, warm-up and the paper's validation continuation of a sequence.
struct Sequences {
    train: Sequence,
    warmup: Sequence,
    nmse_validation: Sequence,
}

/// The loop of the single segment played at a smoothly varying rate.
fn tempo_sequences(c: &Config, tp: &TempoSection, cycle: &[f64], d: usize) -> Result<(Sequences, Vec<Teacher>)> {
    let v = c.training.validation_samples;
    let n = tp.samples + v;
    if n > MAX_TRAINING_SAMPLES {
        return Err(Error::Bound(format!(
            "data.tempo.samples + training.validation_samples = {n}; at most {MAX_TRAINING_SAMPLES}"
        )));
    }
    let rates = smooth_random(n, tp.knot_every, tp.range[0], tp.range[1], tp.seed);
    let p = cycle.len() / d;
    let mut outs = Vec::with_capacity(n * d);
    let mut pos = 0.0;
    for r in &rates {
        for ch in 0..d {
            outs.push(periodic(cycle, p, d, pos, ch));
        }
        pos += r;
    }
    let train = Sequence { outputs: outs[..tp.samples * d].to_vec(), controls: rates[..tp.samples].to_vec() };
    let nmse_validation = Sequence { outputs: outs[tp.samples * d..].to_vec(), controls: rates[tp.samples..].to_vec() };
    let teachers = tp
        .teachers
        .iter()
        .map(|&r| Teacher { label: format!("{} = {r}", tp.control), controls: vec![r], cycle: cycle.to_vec(), rate: r })
        .collect();
    Ok((Sequences { warmup: train.clone(), train, nmse_validation }, teachers))
}

/// A standing posture that is a frame of a rhythm (`stand_from`): the
/// teachers' indices and the frame (of the rhythm's cycle).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Warp {
    posture: usize,
    rhythm: usize,
    frame: usize,
}

/// How the training sequence passes between blocks besides the morphs: the
/// time-warped starts and stops of postures that are frames of rhythms, and
/// the rate channels (index, mean, std) whose values follow the pace.
struct Blends<'a> {
    warps: &'a [Warp],
    rates: &'a [(usize, f64, f64)],
}

impl Blends<'_> {
    /// Frame `frame` (normalised) with its rate channels at `pace` of their value.
    fn paced(&self, frame: &mut [f64], pace: f64) {
        for &(k, mean, std) in self.rates {
            frame[k] = ((frame[k] * std + mean) * pace - mean) / std;
        }
    }
}

/// Segment blocks, repeated, with optional phase-continuous morphs between them.
fn block_sequences(c: &Config, teachers: &[Teacher], d: usize, orbit: bool, blends: &Blends<'_>) -> Result<Sequences> {
    let d_sec = &c.data;
    let loops: Vec<&[f64]> = teachers.iter().map(|t| t.cycle.as_slice()).collect();
    let u = d_sec.controls.len();
    let v = c.training.validation_samples;
    let order: Vec<usize> = d_sec.sequence.clone().unwrap_or_else(|| (0..loops.len()).collect());
    if let Some(&k) = order.iter().find(|&&k| k >= loops.len()) {
        return Err(c.error("data.sequence", format!("names teacher {k}; there are {}", loops.len())));
    }
    let n_seg = order.len();
    let spb = d_sec.samples_per_segment;
    let morph = (d_sec.morph_s * d_sec.rate_hz).round() as usize;
    let blocks = n_seg * d_sec.repeats;
    let longest = loops.iter().map(|l| l.len() / d).max().unwrap_or(0);
    let total = blocks * spb + (blocks - 1) * (morph + if blends.warps.is_empty() { 0 } else { 2 * longest });
    if total > MAX_TRAINING_SAMPLES {
        return Err(Error::Bound(format!(
            "the training sequence would have {total} samples (segments × repeats × samples_per_segment + morphs); at most {MAX_TRAINING_SAMPLES}"
        )));
    }
    let frames = |i: usize| (loops[i].len() / d) as f64;
    let is_posture = |i: usize| loops[i].len() == d;
    let mut outs = Vec::with_capacity(total * d);
    let mut ctls = Vec::with_capacity(total * u);
    let mut first_block = None;
    // The segment and phase (in cycles) where the sequence stands.
    let mut last = (0usize, 0.0f64);
    for b in 0..blocks {
        let i = order[b % n_seg];
        let seg = &teachers[i];
        if morph == 0 {
            outs.extend(tile(loops[i], d, spb, 0));
            last = (i, spb as f64 / frames(i));
        } else {
            let mut ph = if b == 0 { 0.0 } else { last.1 };
            for _ in 0..spb {
                blend_at(loops[i], loops[i], d, ph, 0.0, &mut outs);
                ph += 1.0 / frames(i);
            }
            last = (i, ph);
        }
        for _ in 0..spb {
            ctls.extend_from_slice(&seg.controls);
        }
        if b == 0 {
            first_block = Some(Sequence { outputs: outs.clone(), controls: ctls.clone() });
        }
        if b + 1 < blocks && morph > 0 {
            let j = order[(b + 1) % n_seg];
            let warp = blends.warps.iter().find(|w| (w.posture, w.rhythm) == (i, j) || (w.posture, w.rhythm) == (j, i));
            if let Some(w) = warp {
                let before = outs.len() / d;
                last = time_warp(w, i, &loops, d, morph, last.1, blends, &mut outs);
                // The controls ramp by a cosine over `morph` steps from the transition's start
                // (a stop may take longer: the new controls hold until it lands).
                for k in 0..outs.len() / d - before {
                    let wk = cosine(k as f64 / morph as f64);
                    for (a, b) in seg.controls.iter().zip(&teachers[j].controls) {
                        ctls.push((1.0 - wk) * a + wk * b);
                    }
                }
                continue;
            }
            let mut ph = last.1;
            for k in 0..morph {
                let w = cosine(k as f64 / morph as f64);
                blend_at(loops[i], loops[j], d, ph, w, &mut outs);
                for (a, b) in seg.controls.iter().zip(&teachers[j].controls) {
                    ctls.push((1.0 - w) * a + w * b);
                }
                // Into or out of a posture the rhythm keeps its own pace
                // while it grows or fades; between rhythms the period blends.
                ph += 1.0
                    / match (is_posture(i), is_posture(j)) {
                        (true, false) => frames(j),
                        (false, true) => frames(i),
                        _ => (1.0 - w) * frames(i) + w * frames(j),
                    };
            }
            last = (j, ph);
        }
    }
    let (li, lph) = last;
    let nmse_out = if morph == 0 {
        tile(loops[li], d, v, spb)
    } else {
        let mut o = Vec::with_capacity(v * d);
        for k in 0..v {
            blend_at(loops[li], loops[li], d, lph + k as f64 / frames(li), 0.0, &mut o);
        }
        o
    };
    let nmse_validation = Sequence { outputs: nmse_out, controls: teachers[li].controls.repeat(v) };
    let train = Sequence { outputs: outs, controls: ctls };
    let warmup = if orbit { first_block.unwrap_or_else(|| train.clone()) } else { train.clone() };
    Ok(Sequences { train, warmup, nmse_validation })
}

/// Each standing posture with `stand_from`: made the frame of its rhythm's
/// teacher cycle where both feet are lowest (the highest of the two
/// [`crate::measure::feet`] above its floor least; without a skeleton, the
/// cycle's first frame), its rate channels at 0 (a posture does not travel);
/// and the warps the training sequence makes between the two.
fn stand_in_rhythms(
    c: &Config,
    r: &Read,
    teachers: &mut [Teacher],
    skeleton: Option<&Skeleton>,
    recorded: &[Motion],
    notes: &mut Vec<String>,
) -> Result<Vec<Warp>> {
    let segs = c.data.teacher_segments();
    let d = r.channels.len();
    let mut warps = Vec::new();
    for (posture, &i) in segs.iter().enumerate() {
        let Some(from) = &c.data.segments[i].stand_from else { continue };
        let rhythm = segs
            .iter()
            .position(|&j| {
                let s = &c.data.segments[j];
                !s.stand && (s.group.as_ref() == Some(from) || r.labels[j] == *from || s.label.as_ref() == Some(from))
            })
            .ok_or_else(|| {
                c.error(&format!("data.segments[{i}].stand_from"), format!("'{from}' is not a rhythm's name"))
            })?;
        let cycle = teachers[rhythm].cycle.clone();
        let frame = match skeleton {
            Some(sk) => double_support(c, r, sk, &cycle, recorded)?,
            None => 0,
        };
        let mut pose = cycle[frame * d..(frame + 1) * d].to_vec();
        for (k, v) in pose.iter_mut().enumerate() {
            if r.channels[k].ends_with(cpg_reservoir::VELOCITY_SUFFIX) {
                *v = -r.z.mean[k] / r.z.std[k];
            }
        }
        teachers[posture].cycle = pose;
        notes.push(format!(
            "segment {}: the posture is frame {frame} of {from}'s cycle of {} frames (both feet lowest), and the training sequence starts and stops {from} there by its pace (time-warped, not blended)",
            r.labels[i],
            cycle.len() / d
        ));
        warps.push(Warp { posture, rhythm, frame });
    }
    Ok(warps)
}

/// The frame of `cycle` (normalised, `r`'s channels) where the higher of the
/// two feet stands lowest above its floor (the floors of the recorded rhythms).
fn double_support(c: &Config, r: &Read, sk: &Skeleton, cycle: &[f64], recorded: &[Motion]) -> Result<usize> {
    let d = r.channels.len();
    let n = cycle.len() / d;
    let names: Vec<cpg_mocap::Channel> = r
        .channels
        .iter()
        .map(|ch| {
            let unit = ch.strip_suffix(cpg_reservoir::VELOCITY_SUFFIX).unwrap_or(ch);
            cpg_mocap::Channel::parse(unit)
                .ok_or_else(|| Error::name(ch, format!("'{ch}' is not a mocap channel (bone.dof)")))
        })
        .collect::<Result<_>>()?;
    // In units, the travel left out (it does not change a foot's height).
    let units: Vec<f64> = (0..n * d)
        .map(|k| {
            let ch = k % d;
            if r.channels[ch].ends_with(cpg_reservoir::VELOCITY_SUFFIX) {
                0.0
            } else {
                cycle[k] * r.z.std[ch] + r.z.mean[ch]
            }
        })
        .collect();
    let motion = sk.complete(&Motion::new(names, units, c.data.rate_hz)?)?;
    let pos = sk.forward_kinematics(&motion)?;
    let gaits: Vec<cpg_mocap::Positions> = recorded
        .iter()
        .zip(&c.data.segments)
        .filter(|(_, s)| !s.stand)
        .map(|(m, _)| sk.complete(m).and_then(|m| sk.forward_kinematics(&m)))
        .collect::<std::result::Result<_, _>>()?;
    let names = crate::measure::feet(sk);
    let floors = crate::measure::floors(&gaits, &names);
    let feet: Vec<(usize, f64)> =
        names.iter().zip(&floors).filter_map(|(f, &floor)| pos.point_index(f).map(|i| (i, floor))).collect();
    let higher = |k: usize| feet.iter().map(|&(i, floor)| pos.frame(k)[i][1] - floor).fold(f64::NEG_INFINITY, f64::max);
    Ok((0..n).min_by(|&a, &b| higher(a).total_cmp(&higher(b))).unwrap_or(0))
}

/// The training sequence between a posture and the rhythm it is a frame of,
/// time-warped (appended to `outs`, normalised), leaving teacher `from` at
/// `phase` (in cycles): out of the posture the rhythm's pace grows from 0 to
/// 1 by a cosine over `morph` steps, starting at the posture's frame; into
/// it the pace falls by a cosine from wherever the rhythm is, over as long
/// as it takes to end exactly on that frame (at least `morph` steps, less
/// than `morph` plus two cycles). The rate channels follow the pace. Returns
/// the teacher and phase (in cycles) where the sequence stands.
#[allow(clippy::too_many_arguments)] // the sequence's state, passed through
fn time_warp(
    w: &Warp,
    from: usize,
    loops: &[&[f64]],
    d: usize,
    morph: usize,
    phase: f64,
    blends: &Blends<'_>,
    outs: &mut Vec<f64>,
) -> (usize, f64) {
    let cycle = loops[w.rhythm];
    let p = (cycle.len() / d) as f64;
    let target = w.frame as f64 / p;
    let mut frame = Vec::with_capacity(d);
    let mut emit = |ph: f64, pace: f64, outs: &mut Vec<f64>| {
        frame.clear();
        blend_at(cycle, cycle, d, ph, 0.0, &mut frame);
        blends.paced(&mut frame, pace);
        outs.extend_from_slice(&frame);
    };
    let rising = |k: usize| cosine(k as f64 / morph as f64);
    if from == w.posture {
        let mut ph = target;
        for k in 0..morph {
            emit(ph, rising(k), outs);
            ph += rising(k) / p;
        }
        return (w.rhythm, ph);
    }
    // Into the posture: from where the sequence is, whatever its phase, the pace
    // falls by a cosine over as many steps as it takes to cover the distance to the
    // posture's frame (at least `morph` steps: the next such frame a slow stop can reach).
    let mut dist = (target - phase).rem_euclid(1.0) * p;
    if 2.0 * dist < morph as f64 {
        dist += p;
    }
    let steps = (2.0 * dist).round().max(1.0) as usize;
    let falling = |k: usize| 1.0 - cosine(k as f64 / steps as f64);
    // The sum of the pace over the ramp is the distance (in frames) up to rounding: scaled to land exactly.
    let covered: f64 = (0..steps).map(falling).sum();
    let scale = if covered > 0.0 { dist / covered } else { 1.0 };
    let mut ph = phase;
    for k in 0..steps {
        let r = falling(k);
        emit(ph, r, outs);
        ph += scale * r / p;
    }
    (w.posture, 0.0)
}

/// The segments as recorded, the last `validation_samples` validating.
fn recorded_sequences(c: &Config, r: &Read, notes: &mut Vec<String>) -> Result<Sequences> {
    let (d, u, v) = (r.channels.len(), c.data.controls.len(), c.training.validation_samples);
    let mut outs = Vec::new();
    let mut ctls = Vec::new();
    for (m, s) in r.parts.iter().zip(&c.data.segments) {
        outs.extend_from_slice(r.z.apply(m)?.values());
        for _ in 0..m.n_frames() {
            ctls.extend_from_slice(&s.controls);
        }
    }
    let t = outs.len() / d;
    if c.training.score == crate::config::ScoreKind::Orbit {
        return Err(Error::Unusable(
            "score = \"orbit\" needs looped segments (loop_cycles >= 1) to know each rhythm".into(),
        ));
    }
    if v + c.training.washout + 2 > t {
        return Err(Error::Shape(format!(
            "{t} samples cannot hold a washout of {} and {v} validation samples",
            c.training.washout
        )));
    }
    notes.push(format!("segments used as recorded; the last {v} samples validate"));
    let train = Sequence { outputs: outs[..(t - v) * d].to_vec(), controls: ctls[..(t - v) * u].to_vec() };
    Ok(Sequences {
        nmse_validation: Sequence { outputs: outs[(t - v) * d..].to_vec(), controls: ctls[(t - v) * u..].to_vec() },
        warmup: train.clone(),
        train,
    })
}

/// Each channel's standard deviation within the segments `parts`, pooled
/// (each segment's own mean taken out), written into `std` for every
/// channel that moves within a segment and is not among `still`.
fn rhythm_std(parts: &[Motion], still: &[usize], std: &mut [f64]) {
    let n = std.len();
    let (mut var, mut count) = (vec![0.0; n], 0.0);
    for p in parts {
        let t = p.n_frames() as f64;
        let mut mean = vec![0.0; n];
        for f in 0..p.n_frames() {
            for (s, v) in mean.iter_mut().zip(p.frame(f)) {
                *s += v / t;
            }
        }
        for f in 0..p.n_frames() {
            for ((s, v), mu) in var.iter_mut().zip(p.frame(f)).zip(&mean) {
                *s += (v - mu) * (v - mu);
            }
        }
        count += t;
    }
    for (k, v) in var.iter().enumerate() {
        let sd = (v / count).sqrt();
        if !still.contains(&k) && sd > 1e-12 * (1.0 + std[k]) {
            std[k] = sd;
        }
    }
}

/// Reads, normalises and loops the data of a configuration.
pub fn prepare(c: &Config) -> Result<Prepared> {
    prepare_recorded(c, read_recorded(c)?)
}

/// [`prepare`] with the motions already in memory (the configuration's
/// `data.skeleton` and segment files are not read; its channels, controls,
/// loops and training settings apply as they would to the files').
pub fn prepare_recorded(c: &Config, rec: Recorded) -> Result<Prepared> {
    let r = select(c, &rec)?;
    let d = r.channels.len();
    let u = c.data.controls.len();
    let orbit = c.training.score == crate::config::ScoreKind::Orbit;
    let mut notes = Vec::new();
    if !r.still.is_empty() {
        notes.push(format!(
            "{} channel(s) never move in the data and are learnt as constants, in their own units: {}",
            r.still.len(),
            r.still.join(", ")
        ));
    }
    let (seqs, cycles, teachers) = if c.data.loop_cycles == 0 {
        (recorded_sequences(c, &r, &mut notes)?, Vec::new(), Vec::new())
    } else {
        let (loops, cycles) = loops(c, &r, &rec.parts, rec.skeleton.as_ref().map(|s| &s.0), &mut notes)?;
        let (seqs, teachers) = match &c.data.tempo {
            Some(tp) => tempo_sequences(c, tp, &loops[0], d)?,
            None => {
                let mut teachers = teachers_of(c, &r.labels, &loops, d, &mut notes);
                let skeleton = rec.skeleton.as_ref().map(|s| &s.0);
                let warps = stand_in_rhythms(c, &r, &mut teachers, skeleton, &rec.parts, &mut notes)?;
                let rates: Vec<(usize, f64, f64)> = (0..d)
                    .filter(|&k| r.channels[k].ends_with(cpg_reservoir::VELOCITY_SUFFIX))
                    .map(|k| (k, r.z.mean[k], r.z.std[k]))
                    .collect();
                (block_sequences(c, &teachers, d, orbit, &Blends { warps: &warps, rates: &rates })?, teachers)
            }
        };
        (seqs, cycles, teachers)
    };
    let (validation, scoring) = if orbit {
        let o = c
            .training
            .orbit
            .as_ref()
            .ok_or_else(|| Error::Unusable("score = \"orbit\" needs [training.orbit]".into()))?;
        let w = &seqs.warmup.controls;
        let visited = match (&o.rates, &c.data.tempo, teachers.first()) {
            (Some(rates), Some(tp), Some(base)) => rates
                .iter()
                .map(|&r| Teacher {
                    label: format!("{} = {r}", tp.control),
                    controls: vec![r],
                    cycle: base.cycle.clone(),
                    rate: r,
                })
                .collect(),
            _ => teachers.clone(),
        };
        orbit_run(o, &visited, d, u, c.data.rate_hz, &w[w.len().saturating_sub(u)..])?
    } else {
        (seqs.nmse_validation, Scoring::default())
    };
    let found: Vec<String> = cycles
        .iter()
        .map(|cy| {
            if cy.period_frames == 0.0 {
                return format!("segment {}: a posture held (the mean of its {} frames)", cy.label, cy.frames);
            }
            format!(
                "segment {}: period {:.1} frames (from {}), loop frames {}..{}, seam excess {:.3}",
                cy.label,
                cy.period_frames,
                cy.period_channel,
                cy.loop_start,
                cy.loop_start + cy.loop_len,
                cy.seam_excess
            )
        })
        .chain(notes.iter().filter(|n| n.starts_with("segments used")).cloned())
        .collect();
    let description = format!(
        "{d} channel(s) [{}] at {} Hz from {}; z-scored; {}",
        r.channels.join(", "),
        c.data.rate_hz,
        r.labels.join(", "),
        found.join("; ")
    );
    let outputs = r
        .channels
        .iter()
        .enumerate()
        .map(|(k, name)| OutputChannel { name: name.clone(), mean: r.z.mean[k], std: r.z.std[k] })
        .collect();
    Ok(Prepared {
        data: TrainingData { train: seqs.train, warmup: seqs.warmup, validation, scoring },
        outputs,
        teachers,
        cycles,
        segments: r
            .parts
            .iter()
            .map(|m| r.z.apply(m).map(|m| m.values().to_vec()))
            .collect::<std::result::Result<_, _>>()?,
        skeleton_asf: rec.skeleton.as_ref().map(|s| s.1.clone()),
        skeleton: rec.skeleton.map(|s| s.0),
        description,
        notes,
    })
}

/// The orbit validation run: the teachers visited in turn, each held for
/// `stay_s` after a cosine ramp, each scored from `settle_s` after arrival to
/// the end of its stay; the push (if any) in the first stay.
fn orbit_run(
    o: &OrbitSection,
    teachers: &[Teacher],
    d: usize,
    u: usize,
    rate: f64,
    start_controls: &[f64],
) -> Result<(Sequence, Scoring)> {
    let seq: Vec<usize> = o.sequence.clone().unwrap_or_else(|| (0..teachers.len()).collect());
    if seq.is_empty() {
        return Err(Error::Unusable("training.orbit.sequence is empty".into()));
    }
    if let Some(&k) = seq.iter().find(|&&k| k >= teachers.len()) {
        return Err(Error::Bound(format!(
            "training.orbit.sequence names teacher {k}; there are {} (0-based)",
            teachers.len()
        )));
    }
    let steps = |s: f64| (s * rate).round() as usize;
    let (stay, ramp, settle) = (steps(o.stay_s), steps(o.ramp_s), steps(o.settle_s));
    let total_est = seq.len() * (stay + ramp);
    if total_est > MAX_VALIDATION_STEPS {
        return Err(Error::Bound(format!(
            "the orbit validation run would have {total_est} steps; at most {MAX_VALIDATION_STEPS} (shorten training.orbit.stay_s)"
        )));
    }
    let mut outs = Vec::new();
    let mut ctls = Vec::new();
    let mut stays = Vec::new();
    let mut prev = start_controls.to_vec();
    for &k in &seq {
        let t = &teachers[k];
        let p = t.cycle.len() / d;
        if prev != t.controls && ramp > 0 {
            for s in 0..ramp {
                let w = cosine(s as f64 / ramp as f64);
                ctls.extend(prev.iter().zip(&t.controls).map(|(a, b)| (1.0 - w) * a + w * b));
                for c in 0..d {
                    outs.push(periodic(&t.cycle, p, d, s as f64 * t.rate, c));
                }
            }
        }
        let arrive = outs.len() / d;
        for s in 0..stay {
            ctls.extend_from_slice(&t.controls);
            for c in 0..d {
                outs.push(periodic(&t.cycle, p, d, s as f64 * t.rate, c));
            }
        }
        let end = arrive + stay;
        stays.push(OrbitStay { end, window: stay - settle, cycle: t.cycle.clone(), rate: t.rate });
        prev = t.controls.clone();
    }
    debug_assert_eq!(ctls.len(), outs.len() / d * u);
    let holds = match &o.push {
        Some(push) => {
            let t = &teachers[seq[0]];
            let values: Vec<f64> = (0..d)
                .map(|c| t.cycle.iter().skip(c).step_by(d).copied().fold(f64::NEG_INFINITY, f64::max) + push.above_max)
                .collect();
            let first_arrive = stays[0].end - stay;
            vec![Hold { from: first_arrive + steps(push.at_s), len: steps(push.hold_s).max(1), values }]
        }
        None => Vec::new(),
    };
    Ok((Sequence { outputs: outs, controls: ctls }, Scoring { score: Score::Orbit(stays), holds }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use cpg_mocap::Channel;

    fn hips(right_lag_frames: f64, right_period: f64) -> Motion {
        let channels = vec![Channel::parse("lfemur.rx").unwrap(), Channel::parse("rfemur.rx").unwrap()];
        let values: Vec<f64> = (0..400)
            .flat_map(|k| {
                let k = k as f64;
                let w = 2.0 * PI / 120.0;
                [20.0 * (w * k).sin(), 20.0 * (2.0 * PI / right_period * (k - right_lag_frames)).sin()]
            })
            .collect();
        Motion::new(channels, values, 120.0).unwrap()
    }

    /// Two channels over 400 frames: `a.rx` a sine of `period` frames from
    /// `phase` (radians), `b.rx` held at 3.
    fn trial(period: f64, phase: f64) -> Motion {
        let channels = vec![Channel::parse("a.rx").unwrap(), Channel::parse("b.rx").unwrap()];
        let values = (0..400).flat_map(|k| [10.0 * (2.0 * PI * k as f64 / period + phase).sin(), 3.0]).collect();
        Motion::new(channels, values, 120.0).unwrap()
    }

    const GROUPED: &str = r#"
[data]
channels = ["a.rx", "b.rx"]
controls = ["u_walk"]
samples_per_segment = 300
morph_s = 1
period_s = [0.5, 1.5]
period_channel = "a.rx"
[[data.segments]]
motion = "x.amc"
stand = true
controls = [0]
[[data.segments]]
motion = "y.amc"
controls = [1]
group = "walk"
[[data.segments]]
motion = "z.amc"
controls = [1]
group = "walk"
[reservoir]
n_neurons = 20
[training]
score = "orbit"
[training.orbit]
sequence = [0, 1, 0]
[output]
model = "m.cpg"
"#;

    /// Two legs of two bones each (thigh and foot, 8 units long) hanging from the root.
    const LEGS_ASF: &str = ":version 1.10\n:name legs\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n   position 0 0 0\n   orientation 0 0 0\n:bonedata\n  begin\n     id 1\n     name lfemur\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n    dof rx\n  end\n  begin\n     id 2\n     name lfoot\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n  end\n  begin\n     id 3\n     name rfemur\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n    dof rx\n  end\n  begin\n     id 4\n     name rfoot\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n  end\n:hierarchy\n  begin\n    root lfemur rfemur\n    lfemur lfoot\n    rfemur rfoot\n  end\n";

    #[test]
    fn a_posture_sunk_below_the_gaits_floor_is_raised_onto_it() {
        let toml = GROUPED
            .replace(r#"channels = ["a.rx", "b.rx"]"#, r#"channels = ["root.ty", "lfemur.rx", "rfemur.rx"]"#)
            .replace(r#"period_channel = "a.rx""#, r#"period_channel = "lfemur.rx""#)
            .replacen(
                "group = \"walk\"\n[[data.segments]]\nmotion = \"z.amc\"\ncontrols = [1]\ngroup = \"walk\"\n",
                "",
                1,
            );
        let c = Config::from_toml(&toml, Path::new("g.toml"), Path::new(".")).unwrap();
        let sk = cpg_mocap::parse_asf("legs.asf", LEGS_ASF.as_bytes()).unwrap();
        let ch = ["root.ty", "lfemur.rx", "rfemur.rx"].map(|s| Channel::parse(s).unwrap()).to_vec();
        // Standing: legs straight down, the root sunk half a unit (28 mm) below where the walk carries it.
        let stand = Motion::new(ch.clone(), [-0.5, 0.0, 0.0].repeat(200), 120.0).unwrap();
        let walk: Vec<f64> = (0..400)
            .flat_map(|k| {
                let a = 30.0 * (2.0 * PI * k as f64 / 100.0).sin();
                [0.0, a, -a]
            })
            .collect();
        let walk = Motion::new(ch, walk, 120.0).unwrap();
        let p =
            prepare_recorded(&c, Recorded { skeleton: Some((sk.clone(), LEGS_ASF.into())), parts: vec![stand, walk] })
                .unwrap();
        // The walk's feet are lowest with the legs straight: 32 units below the root.
        let height_mm = p.outputs[0].to_units(p.teachers[0].cycle[0]) * sk.mm_per_unit();
        assert!(height_mm.abs() < 1.5, "the posture's root at {height_mm} mm; the walk's at 0");
        assert!(
            p.notes.iter().any(|n| n.contains("raised by 28.") && n.contains("stands on the floor")),
            "{:?}",
            p.notes
        );
    }

    #[test]
    fn a_closed_seam_steps_like_its_neighbours_and_a_rhythm_is_scaled_by_itself() {
        // A ramp 0, 1, …, 9 looped jumps −9 at its seam; closed, its seam steps +1 as its
        // first and last steps did, the −10 spread over the loop.
        let ramp: Vec<f64> = (0..10).map(f64::from).collect();
        let c = closed_seam(&ramp, 1);
        assert!((c[0] - c[9] - 1.0).abs() < 1e-12, "{c:?}");
        assert_eq!(c[0], 0.0, "the first frame is kept");
        assert!((c[9] - (-1.0)).abs() < 1e-12, "{c:?}");
        // A loop already seamless is left as it is.
        let sine: Vec<f64> = (0..40).map(|k| (2.0 * PI * k as f64 / 40.0).sin()).collect();
        let s = closed_seam(&sine, 1);
        assert!(s.iter().zip(&sine).all(|(a, b)| (a - b).abs() < 5e-3), "a smooth loop barely moves");
        // Two segments: a channel swinging ±1 about 10 in one and about −10 in the other.
        let ch = |s: &str| Channel::parse(s).unwrap();
        let part = |centre: f64| {
            let v: Vec<f64> = (0..100).map(|k| centre + (2.0 * PI * k as f64 / 20.0).sin()).collect();
            Motion::new(vec![ch("a.rx")], v, 100.0).unwrap()
        };
        let parts = [part(10.0), part(-10.0)];
        let all = parts[0].concat(&parts[1]).unwrap();
        let (z, still) = ZScore::fit_holding_still(&all);
        assert!(z.std[0] > 9.0, "the total standard deviation is the gap's: {}", z.std[0]);
        let mut std = z.std.clone();
        rhythm_std(&parts, &still, &mut std);
        assert!((std[0] - 0.5f64.sqrt()).abs() < 1e-9, "the rhythm's own: {}", std[0]);
    }

    #[test]
    fn a_velocity_channel_is_its_rate_per_second() {
        // x grows 0.5 per frame at 10 Hz: 5 per second, at the ends too; y is kept.
        let ch = |s: &str| Channel::parse(s).unwrap();
        let values: Vec<f64> = (0..6).flat_map(|k| [0.5 * k as f64, k as f64 * k as f64]).collect();
        let m = Motion::new(vec![ch("root.tz"), ch("root.ty")], values.clone(), 10.0).unwrap();
        let r = as_rates(&m, &[0]).unwrap();
        let v = r.values();
        assert!((0..6).all(|k| (v[2 * k] - 5.0).abs() < 1e-12), "{v:?}");
        assert_eq!(
            (0..6).map(|k| v[2 * k + 1]).collect::<Vec<_>>(),
            (0..6).map(|k| values[2 * k + 1]).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_group_of_trials_is_one_teacher_and_a_still_channel_is_held() {
        let c = Config::from_toml(GROUPED, Path::new("g.toml"), Path::new(".")).unwrap();
        let parts = vec![trial(100.0, 0.0), trial(100.0, 1.0), trial(110.0, 2.5)];
        let p = prepare_recorded(&c, Recorded { skeleton: None, parts }).unwrap();
        let labels: Vec<&str> = p.teachers.iter().map(|t| t.label.as_str()).collect();
        assert_eq!(labels, ["x.amc", "walk"]);
        let walk = &p.teachers[1].cycle;
        assert_eq!(walk.len(), 2 * 105, "the median of periods 100 and 110 frames");
        // Aligned in phase before averaging: the mean keeps the trials' amplitude (10 units over a std of ~7).
        let a: Vec<f64> = walk.iter().step_by(2).copied().collect();
        let half = (a.iter().cloned().fold(f64::MIN, f64::max) - a.iter().cloned().fold(f64::MAX, f64::min)) / 2.0;
        let std = p.outputs[0].std;
        assert!((half * std - 10.0).abs() < 0.5, "half range {} units", half * std);
        assert!(walk.iter().skip(1).step_by(2).all(|&v| v == 0.0), "b.rx never moves: 0 in its own units");
        assert_eq!((p.outputs[1].mean, p.outputs[1].std), (3.0, 1.0));
        assert!(p.notes.iter().any(|n| n.contains("never move") && n.contains("b.rx")), "{:?}", p.notes);
        assert!(p.notes.iter().any(|n| n.starts_with("group walk: 2 trials")), "{:?}", p.notes);
        let mixed = GROUPED.replacen("controls = [1]\ngroup", "controls = [0.5]\ngroup", 1);
        let e = Config::from_toml(&mixed, Path::new("g.toml"), Path::new(".")).unwrap_err().to_string();
        assert!(e.contains("data.segments[2].group") && e.contains("same controls"), "{e}");
    }

    #[test]
    fn both_hips_confirm_a_stride_and_refuse_a_half_one() {
        let walk = stride_check(&hips(60.0, 120.0), 120.0, 60, 250).unwrap();
        assert!(walk.confirmed && (walk.right_lag_cycles.abs() - 0.5).abs() < 0.02, "{walk:?}");
        // The legs in phase: 120 frames would be half a stride of a hopping gait.
        let hop = stride_check(&hips(0.0, 120.0), 120.0, 60, 250).unwrap();
        assert!(!hop.confirmed, "{hop:?}");
        // A right hip with another period.
        let odd = stride_check(&hips(60.0, 100.0), 120.0, 60, 250).unwrap();
        assert!(!odd.confirmed, "{odd:?}");
    }
}

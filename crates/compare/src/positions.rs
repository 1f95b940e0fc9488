//! Marker positions: the 31 skeleton points of forward kinematics, in mm.
//!
//! The paper's "31 markers" are taken to be the root and the 30 bone end
//! points of the CMU skeleton (methods.md §1.7), so a frame has 93 coordinates.

use cpg_mocap::{Motion, Positions, Skeleton};

use crate::{Error, Result};

/// Frame-major coordinates `T × 3P` of `p`.
pub fn flatten(p: &Positions) -> Vec<f64> {
    p.points_mm.iter().flat_map(|q| q.iter().copied()).collect()
}

/// World positions of `motion` (mm), flattened.
pub fn world(sk: &Skeleton, motion: &Motion) -> Result<Vec<f64>> {
    Ok(flatten(&sk.forward_kinematics(motion)?))
}

/// Body-frame positions (mm), flattened: the root's six channels are set to 0
/// before forward kinematics, so the pelvis stays at the origin facing +z.
/// Trials that start in different places and directions become comparable.
pub fn body_frame(sk: &Skeleton, motion: &Motion) -> Result<Vec<f64>> {
    let names = motion.channel_names();
    let d = names.len();
    let roots: Vec<usize> = (0..d).filter(|&c| names[c].starts_with("root.")).collect();
    let mut v = motion.values().to_vec();
    for frame in v.chunks_exact_mut(d) {
        for &c in &roots {
            frame[c] = 0.0;
        }
    }
    let m = Motion::new(motion.channels().to_vec(), v, motion.sample_rate_hz())?;
    world(sk, &m)
}

/// A copy of the first `T` frames of `template` whose channels `names` are
/// replaced by `values` (`T × names.len()`, frame-major): how a generator of
/// joint angles is turned into a whole-body motion. The other channels keep
/// the template's values.
pub fn with_channels(template: &Motion, names: &[String], values: &[f64]) -> Result<Motion> {
    if names.is_empty() || values.is_empty() || !values.len().is_multiple_of(names.len()) {
        return Err(Error::Data(format!("{} values are not frames of {} channels", values.len(), names.len())));
    }
    let t = values.len() / names.len();
    if t > template.n_frames() {
        return Err(Error::Data(format!("{t} generated frames but the template has only {}", template.n_frames())));
    }
    let idx = names.iter().map(|n| template.channel_index(n)).collect::<std::result::Result<Vec<_>, _>>()?;
    let d = template.n_channels();
    let mut v = template.values()[..t * d].to_vec();
    for (frame, generated) in v.chunks_exact_mut(d).zip(values.chunks_exact(names.len())) {
        for (&c, &x) in idx.iter().zip(generated) {
            frame[c] = x;
        }
    }
    Ok(Motion::new(template.channels().to_vec(), v, template.sample_rate_hz())?)
}

fn heading(frame: &[[f64; 3]], left: usize, right: usize) -> f64 {
    let (l, r) = (frame[left], frame[right]);
    (l[2] - r[2]).atan2(l[0] - r[0])
}

/// Glues trials end to end into one sequence whose root path is continuous:
/// each trial is turned about the vertical axis so that its first heading
/// (the right-to-left hip direction) equals the previous trial's last, and
/// moved so that its first root position is the previous last one (the
/// height is kept). The posture still changes at a join, as it does when one
/// recording follows another. Returns the flattened positions and the first
/// frame of each trial.
pub fn glue(parts: &[Positions]) -> Result<(Vec<f64>, Vec<usize>)> {
    let first = parts.first().ok_or_else(|| Error::Data("nothing to glue".into()))?;
    let names = &first.names;
    let p = names.len();
    let find = |n: &str| {
        names.iter().position(|x| x == n).ok_or_else(|| Error::Data(format!("the skeleton has no point '{n}'")))
    };
    let (root, left, right) = (find("root")?, find("lhipjoint")?, find("rhipjoint")?);
    let mut out: Vec<[f64; 3]> = Vec::new();
    let mut starts = Vec::with_capacity(parts.len());
    for (k, part) in parts.iter().enumerate() {
        if part.names != *names {
            return Err(Error::Data(format!("trial {k} has different points than trial 0")));
        }
        if part.n_frames() == 0 {
            return Err(Error::Data(format!("trial {k} is empty")));
        }
        starts.push(out.len() / p);
        let Some(prev) = out.len().checked_sub(p).map(|i| out[i..].to_vec()) else {
            out.extend_from_slice(&part.points_mm);
            continue;
        };
        let f0 = part.frame(0);
        let a = heading(&prev, left, right) - heading(f0, left, right);
        let (s, c) = a.sin_cos();
        let o = f0[root];
        let target = prev[root];
        out.extend(part.points_mm.iter().map(|q| {
            let (x, z) = (q[0] - o[0], q[2] - o[2]);
            [target[0] + x * c - z * s, q[1], target[2] + x * s + z * c]
        }));
    }
    Ok((out.iter().flat_map(|q| q.iter().copied()).collect(), starts))
}

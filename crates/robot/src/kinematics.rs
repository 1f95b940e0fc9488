//! HOAP-2 forward kinematics (nalgebra) and the measures of a gait: how far
//! the feet swing and lift, the cycle period and the phase between the legs.

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::{Error, JointTrajectory, Result, Robot};

impl Robot {
    /// The pose of every joint's child link in the frame of the root link
    /// (the trunk), for angles `q_rad` of the joints named in `names`; other joints are at 0.
    pub fn link_poses(&self, names: &[String], q_rad: &[f64]) -> Result<Vec<Isometry3<f64>>> {
        if names.len() != q_rad.len() {
            return Err(Error::Input(format!("{} joint names for {} angles", names.len(), q_rad.len())));
        }
        let angle = |joint: &str| names.iter().position(|n| n == joint).map(|k| q_rad[k]).unwrap_or(0.0);
        let mut pose: Vec<Option<Isometry3<f64>>> = vec![None; self.joints.len()];
        // Parents before children: at most one pass per level of the tree.
        for _ in 0..self.joints.len() {
            let mut progressed = false;
            for (k, j) in self.joints.iter().enumerate() {
                if pose[k].is_some() {
                    continue;
                }
                let parent = match self.joints.iter().position(|p| p.child == j.parent) {
                    None => Some(Isometry3::identity()),
                    Some(p) => pose[p],
                };
                let Some(parent) = parent else { continue };
                let axis = Unit::new_normalize(Vector3::from(j.axis));
                let local = Isometry3::from_parts(
                    Translation3::from(Vector3::from(j.origin_m)),
                    UnitQuaternion::from_axis_angle(&axis, angle(&j.name)),
                );
                pose[k] = Some(parent * local);
                progressed = true;
            }
            if !progressed {
                break;
            }
        }
        pose.into_iter()
            .zip(&self.joints)
            .map(|(p, j)| {
                p.ok_or_else(|| Error::Input(format!("joint '{}' is not connected to the root link", j.name)))
            })
            .collect()
    }

    /// Where a point fixed in the child link of `joint` is, in the trunk frame, for each frame of `t`.
    pub fn path(&self, t: &JointTrajectory, joint: &str, offset_m: [f64; 3]) -> Result<Vec<[f64; 3]>> {
        let k = self.joints.iter().position(|j| j.name == joint).ok_or_else(|| Error::UnknownJoint {
            name: joint.to_owned(),
            valid: self.joints.iter().map(|j| j.name.clone()).collect(),
        })?;
        let d = t.joints.len();
        (0..t.n_frames())
            .map(|f| {
                let poses = self.link_poses(&t.joints, &t.values_rad[f * d..(f + 1) * d])?;
                let p = poses[k] * Point3::from(offset_m);
                Ok([p.x, p.y, p.z])
            })
            .collect()
    }
}

/// The measures of a gait from the paths of the two feet.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Gait {
    /// Forward excursion of a foot relative to the body (max − min), metres, both feet averaged.
    pub excursion_m: f64,
    /// Vertical excursion of a foot (max − min), metres, both feet averaged.
    pub lift_m: f64,
    /// Mean time between upward crossings of the left foot's forward mean, seconds.
    pub period_s: f64,
    /// Lag of the right foot behind the left, in cycles (0.5: antiphase).
    pub left_right_phase: f64,
}

/// Gait measures of two foot paths sampled at `rate_hz`; `forward` and `up`
/// are the axes (0, 1, 2) of the paths' frame. `None` without one full cycle
/// (two upward crossings of the left foot's forward mean).
pub fn gait(left: &[[f64; 3]], right: &[[f64; 3]], rate_hz: f64, forward: usize, up: usize) -> Option<Gait> {
    let axis = |p: &[[f64; 3]], a: usize| p.iter().map(|q| q[a]).collect::<Vec<f64>>();
    let range =
        |v: &[f64]| v.iter().fold(f64::NEG_INFINITY, |m, x| m.max(*x)) - v.iter().fold(f64::INFINITY, |m, x| m.min(*x));
    let (lx, rx) = (axis(left, forward), axis(right, forward));
    let mean = lx.iter().sum::<f64>() / lx.len().max(1) as f64;
    let ups: Vec<usize> = (1..lx.len()).filter(|&i| lx[i - 1] < mean && lx[i] >= mean).collect();
    if ups.len() < 2 {
        return None;
    }
    let period_frames = (ups[ups.len() - 1] - ups[0]) as f64 / (ups.len() - 1) as f64;
    // Right behind left: the lag of the best correlation over one cycle.
    let p = period_frames.round() as usize;
    let n = lx.len().saturating_sub(p);
    let mut best = (f64::NEG_INFINITY, 0);
    for lag in 0..p {
        let c: f64 = (0..n).map(|i| (lx[i] - mean) * (rx[i + lag] - mean)).sum();
        if c > best.0 {
            best = (c, lag);
        }
    }
    Some(Gait {
        excursion_m: (range(&lx) + range(&rx)) / 2.0,
        lift_m: (range(&axis(left, up)) + range(&axis(right, up))) / 2.0,
        period_s: period_frames / rate_hz,
        left_right_phase: best.1 as f64 / period_frames,
    })
}

#[cfg(test)]
mod tests {
    use super::gait;

    #[test]
    fn two_feet_in_antiphase_measure_as_such() {
        let rate = 100.0;
        let foot = |shift: f64| -> Vec<[f64; 3]> {
            (0..500)
                .map(|k| {
                    let ph = 2.0 * std::f64::consts::PI * (k as f64 / 125.0 + shift);
                    [0.1 * ph.sin(), 0.0, 0.02 * ph.cos().max(0.0)]
                })
                .collect()
        };
        let g = gait(&foot(0.0), &foot(0.5), rate, 0, 2).unwrap();
        assert!((g.period_s - 1.25).abs() < 0.02, "{g:?}");
        assert!((g.excursion_m - 0.2).abs() < 1e-3 && (g.lift_m - 0.02).abs() < 1e-3, "{g:?}");
        assert!((g.left_right_phase - 0.5).abs() < 0.02, "{g:?}");
    }
}

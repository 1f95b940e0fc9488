//! A figure that stands on the floor: root translation for motions that have none.

use crate::{Channel, Dof, Motion, Result, Skeleton};

impl Skeleton {
    /// Every channel of this skeleton in AMC order: the root's, then each bone's.
    pub fn all_channels(&self) -> Vec<Channel> {
        let mut ch: Vec<Channel> = self.root.order.iter().map(|&dof| Channel { bone: "root".into(), dof }).collect();
        for b in &self.bones {
            ch.extend(b.dofs.iter().map(|&dof| Channel { bone: b.name.clone(), dof }));
        }
        ch
    }

    /// `motion` with every channel of the skeleton (those it lacks are 0)
    /// and, when it has no root translation, one that puts the figure on the
    /// floor and walks it: each frame's lowest point (a foot, in the y-up
    /// skeleton frame) touches height 0, and the root moves horizontally so
    /// that this point does not slide from the previous frame to this one.
    /// A motion that has root translation keeps it.
    pub fn ground(&self, motion: &Motion) -> Result<Motion> {
        self.ground_or_complete(motion, true)
    }

    /// `motion` with every channel of the skeleton; those it lacks are 0.
    pub fn complete(&self, motion: &Motion) -> Result<Motion> {
        self.ground_or_complete(motion, false)
    }

    fn ground_or_complete(&self, motion: &Motion, ground: bool) -> Result<Motion> {
        let all = self.all_channels();
        let n = motion.n_frames();
        let src: Vec<Option<usize>> = all.iter().map(|c| motion.channels().iter().position(|m| m == c)).collect();
        let mut values = vec![0.0; n * all.len()];
        for f in 0..n {
            let row = &motion.values()[f * motion.channels().len()..(f + 1) * motion.channels().len()];
            for (k, s) in src.iter().enumerate() {
                if let Some(s) = s {
                    values[f * all.len() + k] = row[*s];
                }
            }
        }
        let translation = |dof: Dof| all.iter().position(|c| c.bone == "root" && c.dof == dof);
        let (Some(tx), Some(ty), Some(tz)) = (translation(Dof::Tx), translation(Dof::Ty), translation(Dof::Tz)) else {
            return Motion::new(all, values, motion.sample_rate_hz());
        };
        if !ground || [tx, ty, tz].iter().any(|&k| src[k].is_some()) {
            return Motion::new(all, values, motion.sample_rate_hz());
        }
        // Kinematics with the root at the origin, then the root placed frame by frame.
        let at_origin = Motion::new(all.clone(), values.clone(), motion.sample_rate_hz())?;
        let p = self.forward_kinematics(&at_origin)?;
        let mm = self.mm_per_unit();
        let (mut x, mut z) = (0.0, 0.0);
        for f in 0..n {
            let pts = p.frame(f);
            let (low, point) = pts
                .iter()
                .enumerate()
                .skip(1)
                .map(|(i, q)| (i, *q))
                .fold((0, pts[0]), |(bi, b), (i, q)| if q[1] < b[1] { (i, q) } else { (bi, b) });
            if f > 0 {
                let before = p.frame(f - 1)[low];
                x -= (point[0] - before[0]) / mm;
                z -= (point[2] - before[2]) / mm;
            }
            let row = &mut values[f * all.len()..(f + 1) * all.len()];
            row[tx] = x;
            row[ty] = -point[1] / mm;
            row[tz] = z;
        }
        Motion::new(all, values, motion.sample_rate_hz())
    }
}

#[cfg(test)]
mod tests {
    use crate::{Channel, Motion, parse_asf};

    #[test]
    fn the_lowest_point_touches_the_floor_and_a_planted_foot_does_not_slide() {
        let sk = parse_asf("tiny.asf", include_bytes!("../test_data/tiny.asf")).unwrap();
        // The femur swings back and forth; no root channels.
        let ch = vec![Channel::parse("femur.rx").unwrap()];
        let vals: Vec<f64> = (0..60).map(|k| 25.0 * (k as f64 / 6.0).sin()).collect();
        let m = Motion::new(ch, vals, 120.0).unwrap();
        let g = sk.ground(&m).unwrap();
        assert_eq!(g.channels().len(), sk.all_channels().len());
        let p = sk.forward_kinematics(&g).unwrap();
        for f in 0..p.n_frames() {
            let low = p.frame(f).iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
            assert!(low.abs() < 1e-9, "frame {f}: lowest point at {low} mm");
        }
        // The lowest point of each frame is where it was in the frame before.
        for f in 1..p.n_frames() {
            let i = (0..p.names.len()).min_by(|&a, &b| p.frame(f)[a][1].total_cmp(&p.frame(f)[b][1])).unwrap();
            let (a, b) = (p.frame(f - 1)[i], p.frame(f)[i]);
            assert!((a[0] - b[0]).abs() < 1e-9 && (a[2] - b[2]).abs() < 1e-9, "frame {f}: slid");
        }
    }
}

//! Forward kinematics with the Acclaim convention.
//!
//! A bone's rotation relative to its parent is `C · M · C⁻¹`, where `C` is the
//! bone's `axis` frame (for order XYZ, `C = Rz(az)·Ry(ay)·Rx(ax)`) and `M` is
//! the product of the frame's DOF rotations, the first listed DOF applied first
//! (for `dof rx ry rz`, `M = Rz·Ry·Rx`). The world rotation of a bone is its
//! parent's world rotation times that. The bone's end point is its start point
//! (the parent's end, or the root position) plus the world rotation applied to
//! `direction · length` (direction normalised to unit length). The root translation is `position + (tx, ty, tz)`.

use crate::error::{Error, Result};
use crate::{AxisOrder, Dof, Motion, Skeleton};

pub(crate) type M3 = [[f64; 3]; 3];

const I3: M3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

pub(crate) fn rot(axis: usize, deg: f64) -> M3 {
    let (s, c) = deg.to_radians().sin_cos();
    match axis {
        0 => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        1 => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        _ => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
    }
}

pub(crate) fn mul(a: &M3, b: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    r
}

pub(crate) fn transpose(a: &M3) -> M3 {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = a[j][i];
        }
    }
    r
}

fn apply(a: &M3, v: [f64; 3]) -> [f64; 3] {
    [
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    ]
}

/// The axis frame `C` for angles in degrees applied in `order`.
pub(crate) fn axis_frame(angles_deg: [f64; 3], order: AxisOrder) -> M3 {
    let mut c = I3;
    for &a in &order.0 {
        c = mul(&rot(a, angles_deg[a]), &c);
    }
    c
}

/// World positions of the root and of every bone's end point.
#[derive(Debug, Clone, PartialEq)]
pub struct Positions {
    /// Point names: `root`, then the bones in ASF order.
    pub names: Vec<String>,
    /// Points per frame, frame-major: `points_mm[frame * names.len() + point]`, in millimetres.
    pub points_mm: Vec<[f64; 3]>,
    /// Sample rate of the motion, Hz.
    pub sample_rate_hz: f64,
}

impl Positions {
    /// Number of frames.
    pub fn n_frames(&self) -> usize {
        self.points_mm.len() / self.names.len()
    }

    /// The points of one frame.
    ///
    /// # Panics
    /// When `frame_idx >= n_frames()`.
    #[track_caller]
    pub fn frame(&self, frame_idx: usize) -> &[[f64; 3]] {
        let n = self.names.len();
        &self.points_mm[frame_idx * n..(frame_idx + 1) * n]
    }

    /// Index of a point by name.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
}

/// Forward kinematics of one skeleton for frames given one at a time, set
/// up once (which column of a frame drives which degree of freedom, the
/// bones' frames and directions): [`Kinematics::frame`] allocates nothing,
/// for a loop that poses a figure at every tick. The same arithmetic as
/// [`Skeleton::forward_kinematics`], bit for bit.
#[derive(Debug, Clone)]
pub struct Kinematics {
    root_cols: Vec<(Dof, usize)>,
    bone_cols: Vec<Vec<(Dof, usize)>>,
    scale: f64,
    root_position: [f64; 3],
    c_root: M3,
    frames_c: Vec<(M3, M3)>,
    unit_dirs: Vec<[f64; 3]>,
    lengths: Vec<f64>,
    parents: Vec<Option<usize>>,
    order: Vec<usize>,
    names: Vec<String>,
    world: Vec<M3>,
    ends: Vec<[f64; 3]>,
    points: Vec<[f64; 3]>,
}

impl Kinematics {
    /// Kinematics of `skeleton` for frames whose columns are `channels`
    /// (every degree of freedom of the skeleton must be among them).
    pub fn new(skeleton: &Skeleton, channels: &[crate::Channel]) -> Result<Kinematics> {
        let find = |bone: &str, dof: Dof| channels.iter().position(|c| c.bone == bone && c.dof == dof);
        let mut missing = Vec::new();
        let mut cols_of = |bone: &str, dofs: &[Dof]| -> Vec<(Dof, usize)> {
            dofs.iter()
                .filter_map(|&d| {
                    let c = find(bone, d);
                    if c.is_none() {
                        missing.push(format!("{bone}.{}", d.as_str()));
                    }
                    c.map(|k| (d, k))
                })
                .collect()
        };
        let root_cols = cols_of("root", &skeleton.root.order);
        let bone_cols: Vec<Vec<(Dof, usize)>> = skeleton.bones.iter().map(|b| cols_of(&b.name, &b.dofs)).collect();
        if !missing.is_empty() {
            return Err(Error::SkeletonMismatch {
                skeleton: skeleton.name.clone(),
                detail: format!("motion lacks channels {}", missing.join(", ")),
            });
        }
        let frames_c = skeleton
            .bones
            .iter()
            .map(|b| {
                let c = axis_frame(b.axis_deg, b.axis_order);
                (c, transpose(&c))
            })
            .collect();
        // ASF directions are rounded to six digits: normalise them so that
        // every bone keeps exactly its declared length.
        let unit_dirs = skeleton
            .bones
            .iter()
            .map(|b| {
                let n = b.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
                if n > 0.0 { b.direction.map(|x| x / n) } else { [0.0; 3] }
            })
            .collect();
        let n = skeleton.bones.len();
        let mut names = vec!["root".to_owned()];
        names.extend(skeleton.bones.iter().map(|b| b.name.clone()));
        Ok(Kinematics {
            root_cols,
            bone_cols,
            scale: skeleton.mm_per_unit(),
            root_position: skeleton.root.position,
            c_root: axis_frame(skeleton.root.orientation_deg, skeleton.root.axis),
            frames_c,
            unit_dirs,
            lengths: skeleton.bones.iter().map(|b| b.length).collect(),
            parents: skeleton.bones.iter().map(|b| b.parent).collect(),
            order: skeleton.topological_order(),
            names,
            world: vec![I3; n],
            ends: vec![[0.0; 3]; n],
            points: vec![[0.0; 3]; n + 1],
        })
    }

    /// The points' names: `root`, then the bones in ASF order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// World positions (mm) of the root and every bone end for one frame
    /// (`row`: one value per column of the channels given to [`Kinematics::new`]).
    pub fn frame(&mut self, row: &[f64]) -> &[[f64; 3]] {
        let mut pos = self.root_position;
        let mut m = I3;
        for &(d, k) in &self.root_cols {
            if d.is_rotation() {
                m = mul(&rot(d.axis(), row[k]), &m);
            } else {
                pos[d.axis()] += row[k];
            }
        }
        let g_root = mul(&mul(&self.c_root, &m), &transpose(&self.c_root));
        for &b in &self.order {
            let mut m = I3;
            for &(d, k) in &self.bone_cols[b] {
                if d.is_rotation() {
                    m = mul(&rot(d.axis(), row[k]), &m);
                }
            }
            let (c, ct) = &self.frames_c[b];
            let local = mul(&mul(c, &m), ct);
            let (parent_rot, start) = match self.parents[b] {
                Some(p) => (self.world[p], self.ends[p]),
                None => (g_root, pos),
            };
            self.world[b] = mul(&parent_rot, &local);
            let off = apply(&self.world[b], self.unit_dirs[b].map(|x| x * self.lengths[b]));
            self.ends[b] = [start[0] + off[0], start[1] + off[1], start[2] + off[2]];
        }
        let scale = self.scale;
        self.points[0] = pos.map(|x| x * scale);
        for (p, e) in self.points[1..].iter_mut().zip(&self.ends) {
            *p = e.map(|x| x * scale);
        }
        &self.points
    }
}

impl Skeleton {
    /// Computes world positions (mm) of the root and every bone end for each frame.
    ///
    /// The motion must carry every DOF of the skeleton.
    pub fn forward_kinematics(&self, motion: &Motion) -> Result<Positions> {
        let mut k = Kinematics::new(self, motion.channels())?;
        let n_pts = self.bones.len() + 1;
        let mut points = Vec::with_capacity(motion.n_frames() * n_pts);
        for f in 0..motion.n_frames() {
            points.extend_from_slice(k.frame(motion.frame(f)));
        }
        Ok(Positions { names: k.names, points_mm: points, sample_rate_hz: motion.sample_rate_hz() })
    }
}

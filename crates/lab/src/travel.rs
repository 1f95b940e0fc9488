//! The figure's horizontal travel carried by its feet.
//!
//! A model that learns the root's horizontal translation as a rate
//! (`data.velocity` with `root.tx` and `root.tz`) and has a skeleton with
//! feet ([`crate::measure::feet`]) does not travel by that rate alone: while
//! a foot is on the ground the figure moves so that its lower foot stays
//! where it is (the stance foot bears the weight, so it does not slide), and
//! only with both feet in the air (a run's flight) does the learnt rate carry
//! it. So a figure whose legs stand still does not travel, by construction,
//! and no rate the network learnt can drag a stance foot along the floor.
//!
//! [`FeetTravel`] does it one frame at a time and allocates nothing after it
//! is built: the same for a whole run ([`FeetTravel::apply_run`]), a stream's
//! ticks and a step-by-step generator. The lower foot bears the weight unless
//! it is more than [`FLIGHT_MM`] above its floor, the
//! [`crate::measure::FLOOR_QUANTILE`] of its heights in the model's taught
//! rhythms: a foot point is the ball of the foot, which stands about 15 mm
//! up while its heel is down (a walk's double support, a standing figure),
//! and about 30 mm or more only in a run's flight.
//!
//! The same pass cleans the feet up (footskate cleanup, after Kovar,
//! Schreiner & Gleicher 2002): a generator's legs can drag a foot along the
//! ground (a swing that does not lift, a stop that slides a foot back into
//! the posture), which no travel of the figure removes. Each foot whose
//! ball comes down ([`crate::measure::CONTACT_MM`] over its floor) slower
//! than [`PLANT_MM_S`] is planted where it lands, and its leg (the hip's and
//! the knee's rotations) is solved by inverse kinematics to keep it there
//! while the generator keeps it down; one that comes down faster, or whose
//! plant the generated leg has left by more than [`REACH_MM`], is a dragged
//! swing and is lifted [`CLEAR_MM`] clear of the ground until the generated
//! foot slows down. A correction left when a foot lifts fades by
//! [`CARRY_DECAY`] a frame. Only the legs' rotations of the frame change;
//! [`FeetTravel::raw`] gives the travel without the cleanup.

use cpg_mocap::{Channel, Dof, Kinematics, Skeleton};
use cpg_reservoir::TrainedCpg;

use crate::error::Result;

/// Above this height over its floor the lower foot bears no weight: the
/// figure is in flight and travels by its learnt rate, mm.
pub const FLIGHT_MM: f64 = 30.0;

/// A foot coming down slower than this is planted where it lands; faster, it is a dragged swing, mm/s.
pub const PLANT_MM_S: f64 = 250.0;
/// A plant is let go when the generated foot has moved this far from it on the ground, mm.
pub const REACH_MM: f64 = 100.0;
/// A dragged swing is lifted this far above the ground's band ([`crate::measure::CONTACT_MM`]), mm.
pub const CLEAR_MM: f64 = 8.0;
/// The share of a lifted foot's correction kept from one frame to the next.
pub const CARRY_DECAY: f64 = 0.85;
/// Inverse kinematics stops within this distance of its target, mm.
const IK_TOLERANCE_MM: f64 = 0.1;
/// Inverse kinematics' iterations at most per frame and foot.
const IK_ITERATIONS: usize = 12;
/// The finite difference of a joint's rotation for the Jacobian, degrees.
const IK_DELTA_DEG: f64 = 1e-3;
/// The largest change of a joint's rotation per iteration, degrees.
const IK_STEP_DEG: f64 = 5.0;

/// One leg's cleanup: the rotations it may change and the foot's plant.
#[derive(Debug, Clone)]
struct Leg {
    /// (row index, output index) of each rotation of the hip's and the knee's bones.
    dofs: Vec<(usize, usize)>,
    /// Where the foot is planted (world x, z), mm.
    anchor: Option<[f64; 2]>,
    /// The correction of the foot (x, y, z) from where the generator puts it, mm.
    carry: [f64; 3],
    /// The generated foot's world place (x, z) on the previous frame, mm.
    prev_world: Option<[f64; 2]>,
}

/// The travel a model's feet give its figure (see the module).
#[derive(Debug, Clone)]
pub struct FeetTravel {
    kin: Kinematics,
    /// Every degree of freedom of the skeleton, in its units: the frame being posed.
    row: Vec<f64>,
    /// (output index, row index) of each channel the model generates.
    from_output: Vec<(usize, usize)>,
    /// The row's horizontal root translation, which the feet decide.
    row_tx: usize,
    row_tz: usize,
    /// The output frame's `root.tx` and `root.tz` (integrated rates).
    out_tx: usize,
    out_tz: usize,
    /// Each foot's point and floor, mm.
    feet: Vec<(usize, f64)>,
    /// Millimetres per length unit of the skeleton.
    mm_per_unit: f64,
    /// State: the feet relative to the root on the previous frame, and which was lower and on the ground.
    prev_feet: [[f64; 3]; 2],
    prev_anchor: Option<usize>,
    /// The learnt position on the previous frame and the travel so far, mm.
    prev_learnt: [f64; 2],
    shift: [f64; 2],
    started: bool,
    /// Each foot's leg for the cleanup; empty without it.
    legs: Vec<Leg>,
    /// Seconds per frame.
    dt_s: f64,
}

impl FeetTravel {
    /// The feet's travel for `m`, when it has one: a skeleton with both
    /// feet ([`crate::measure::feet`]), and the root's horizontal translation learnt as rates.
    pub fn for_model(m: &TrainedCpg) -> Result<Option<FeetTravel>> {
        let Some(asf) = &m.skeleton_asf else { return Ok(None) };
        let find = |n: &str| m.outputs.iter().position(|o| o.integrates() == Some(n));
        let (Some(out_tx), Some(out_tz)) = (find("root.tx"), find("root.tz")) else { return Ok(None) };
        let sk =
            cpg_mocap::parse_asf("the skeleton stored in the model", asf.as_bytes()).map_err(cpg_mocap::Error::from)?;
        let feet = crate::measure::feet(&sk);
        if feet.iter().any(|f| sk.bone_index(f).is_none()) {
            return Ok(None);
        }
        let floors = teacher_floors(m, &sk, &feet)?;
        let mut t = FeetTravel::new(m, &sk, out_tx, out_tz, &feet, &floors)?;
        t.legs = legs(m, &sk, &t)?;
        Ok(Some(t))
    }

    /// The same travel without the feet's cleanup: the generator's legs as they are.
    pub fn raw(mut self) -> FeetTravel {
        self.legs.clear();
        self
    }

    fn new(
        m: &TrainedCpg,
        sk: &Skeleton,
        out_tx: usize,
        out_tz: usize,
        names: &[String],
        floors: &[f64],
    ) -> Result<FeetTravel> {
        let all = sk.all_channels();
        let kin = Kinematics::new(sk, &all)?;
        let outputs = crate::run::mocap_channels(m)?;
        let from_output: Vec<(usize, usize)> =
            outputs.iter().enumerate().filter_map(|(k, c)| all.iter().position(|a| a == c).map(|r| (k, r))).collect();
        let at = |dof: Dof| all.iter().position(|c| *c == Channel { bone: "root".into(), dof }).unwrap_or(0);
        let feet = names
            .iter()
            .zip(floors)
            .filter_map(|(f, &floor)| kin.names().iter().position(|n| n == f).map(|i| (i, floor)))
            .collect();
        Ok(FeetTravel {
            row: vec![0.0; all.len()],
            from_output,
            row_tx: at(Dof::Tx),
            row_tz: at(Dof::Tz),
            out_tx,
            out_tz,
            feet,
            mm_per_unit: sk.mm_per_unit(),
            kin,
            prev_feet: [[0.0; 3]; 2],
            prev_anchor: None,
            prev_learnt: [0.0; 2],
            shift: [0.0; 2],
            started: false,
            legs: Vec::new(),
            dt_s: 1.0 / m.provenance.sample_rate_hz,
        })
    }

    /// Starts again from a run's first frame.
    pub fn reset(&mut self) {
        self.started = false;
        self.prev_anchor = None;
        for l in &mut self.legs {
            l.anchor = None;
            l.carry = [0.0; 3];
            l.prev_world = None;
        }
    }

    /// One frame of the model's output in units (rates integrated, as a run
    /// gives them): its `root.tx` and `root.tz` replaced by the feet's travel.
    pub fn apply(&mut self, frame: &mut [f64]) {
        let learnt = [frame[self.out_tx] * self.mm_per_unit, frame[self.out_tz] * self.mm_per_unit];
        for &(k, r) in &self.from_output {
            self.row[r] = frame[k];
        }
        // The feet relative to the root's horizontal place.
        self.row[self.row_tx] = 0.0;
        self.row[self.row_tz] = 0.0;
        let points = self.kin.frame(&self.row);
        let root = points[0];
        let mut feet = [[0.0; 3]; 2];
        for (f, &(i, _)) in feet.iter_mut().zip(&self.feet) {
            *f = [points[i][0] - root[0], points[i][1], points[i][2] - root[2]];
        }
        if !self.started {
            self.shift = learnt;
            self.started = true;
        } else {
            // The lower foot on the ground on the previous frame stays where it was;
            // with no foot on the ground the learnt rate carries the figure.
            let step = match self.prev_anchor {
                Some(a) => [self.prev_feet[a][0] - feet[a][0], self.prev_feet[a][2] - feet[a][2]],
                None => [learnt[0] - self.prev_learnt[0], learnt[1] - self.prev_learnt[1]],
            };
            self.shift = [self.shift[0] + step[0], self.shift[1] + step[1]];
        }
        self.prev_anchor = self
            .feet
            .iter()
            .enumerate()
            .map(|(j, &(_, floor))| (j, feet[j][1] - floor))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .filter(|&(_, h)| h <= FLIGHT_MM)
            .map(|(j, _)| j);
        self.prev_feet = feet;
        self.prev_learnt = learnt;
        frame[self.out_tx] = self.shift[0] / self.mm_per_unit;
        frame[self.out_tz] = self.shift[1] / self.mm_per_unit;
        let legs = self.legs.len();
        for (j, &g) in feet.iter().enumerate().take(legs) {
            self.clean(j, g, frame);
        }
    }

    /// Foot `j` (generated at `g`, relative to the root's horizontal place)
    /// planted, lifted or let be (see the module); its leg's rotations in
    /// `frame` changed to match.
    fn clean(&mut self, j: usize, g: [f64; 3], frame: &mut [f64]) {
        let (point, floor) = self.feet[j];
        let shift = self.shift;
        let world = [g[0] + shift[0], g[2] + shift[1]];
        let leg = &mut self.legs[j];
        let speed = leg.prev_world.map_or(0.0, |p| (world[0] - p[0]).hypot(world[1] - p[1]) / self.dt_s);
        leg.prev_world = Some(world);
        let down = g[1] - floor <= crate::measure::CONTACT_MM;
        if !down {
            leg.anchor = None;
        } else if let Some(a) = leg.anchor {
            let want = [a[0] - shift[0], a[1] - shift[1]];
            if (want[0] - g[0]).hypot(want[1] - g[2]) <= REACH_MM {
                leg.carry = [want[0] - g[0], 0.0, want[1] - g[2]];
            } else {
                leg.anchor = None;
            }
        }
        let mut target = g;
        if down && leg.anchor.is_none() && speed <= PLANT_MM_S {
            // Planted where the (corrected) foot is.
            leg.carry[1] = 0.0;
            leg.anchor = Some([world[0] + leg.carry[0], world[1] + leg.carry[2]]);
        } else if leg.anchor.is_none() {
            leg.carry = leg.carry.map(|c| c * CARRY_DECAY);
            if down {
                // A dragged swing: lifted clear of the ground.
                target[1] = floor + crate::measure::CONTACT_MM + CLEAR_MM;
                leg.carry[1] = 0.0;
            }
        }
        target = [target[0] + leg.carry[0], target[1] + leg.carry[1], target[2] + leg.carry[2]];
        if (0..3).map(|i| (target[i] - g[i]).powi(2)).sum::<f64>().sqrt() <= IK_TOLERANCE_MM {
            return;
        }
        solve_leg(&mut self.kin, &mut self.row, &self.legs[j].dofs, point, target);
        for &(r, k) in &self.legs[j].dofs {
            frame[k] = self.row[r];
        }
    }

    /// Every frame of a run (`T × d`, units, rates integrated), from its start.
    pub fn apply_run(&mut self, y: &mut [f64], d: usize) {
        self.reset();
        for frame in y.chunks_exact_mut(d) {
            self.apply(frame);
        }
    }
}

/// The foot point `point` (relative to the root's horizontal place) moved to
/// `target` by the rotations `dofs` of `row`: damped least squares on a
/// Jacobian by finite differences, a few iterations. Allocates nothing for
/// up to four rotations; more are not solved.
fn solve_leg(kin: &mut Kinematics, row: &mut [f64], dofs: &[(usize, usize)], point: usize, target: [f64; 3]) {
    const N: usize = 4;
    if dofs.is_empty() || dofs.len() > N {
        return;
    }
    let at = |kin: &mut Kinematics, row: &[f64]| {
        let p = kin.frame(row);
        [p[point][0] - p[0][0], p[point][1], p[point][2] - p[0][2]]
    };
    for _ in 0..IK_ITERATIONS {
        let p = at(kin, row);
        let e = [target[0] - p[0], target[1] - p[1], target[2] - p[2]];
        if (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt() <= IK_TOLERANCE_MM {
            return;
        }
        // J: 3 × n, mm per degree.
        let mut jac = [[0.0; N]; 3];
        for (c, &(r, _)) in dofs.iter().enumerate() {
            let keep = row[r];
            row[r] = keep + IK_DELTA_DEG;
            let q = at(kin, row);
            row[r] = keep;
            for i in 0..3 {
                jac[i][c] = (q[i] - p[i]) / IK_DELTA_DEG;
            }
        }
        // Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e.
        let lambda2 = 1.0;
        let mut a = [[0.0; 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                a[i][k] =
                    (0..dofs.len()).map(|c| jac[i][c] * jac[k][c]).sum::<f64>() + if i == k { lambda2 } else { 0.0 };
            }
        }
        let Some(w) = solve3(&a, e) else { return };
        for (c, &(r, _)) in dofs.iter().enumerate() {
            let dq = (0..3).map(|i| jac[i][c] * w[i]).sum::<f64>();
            row[r] += dq.clamp(-IK_STEP_DEG, IK_STEP_DEG);
        }
    }
}

/// `a x = b` for a 3 × 3 `a` by Cramer's rule; `None` when it is singular.
fn solve3(a: &[[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !d.is_finite() || d.abs() < 1e-12 {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut m = *a;
        for i in 0..3 {
            m[i][c] = b[i];
        }
        *xc = det(&m) / d;
    }
    Some(x)
}

/// The legs the cleanup may move: for each foot of `t` (left, right), the
/// rotations of the hip's and the knee's bones by the skeleton's profile
/// ([`cpg_mocap::profile`]), when the model generates all of them; none
/// otherwise (the travel without a cleanup).
fn legs(m: &TrainedCpg, sk: &Skeleton, t: &FeetTravel) -> Result<Vec<Leg>> {
    let Some(resolved) = cpg_mocap::profile::Profile::detect(sk).and_then(|p| p.resolve(sk).ok()) else {
        return Ok(Vec::new());
    };
    let all = sk.all_channels();
    let outputs = crate::run::mocap_channels(m)?;
    let mut legs = Vec::new();
    for side in &resolved.sides {
        let mut dofs = Vec::new();
        for bone in [&side.hip_bone, &side.knee_bone] {
            for (r, c) in all.iter().enumerate().filter(|(_, c)| &c.bone == bone && c.dof.is_rotation()) {
                match outputs.iter().position(|o| o == c) {
                    Some(k) => dofs.push((r, k)),
                    None => return Ok(Vec::new()),
                }
            }
        }
        if dofs.is_empty() || dofs.len() > 4 {
            return Ok(Vec::new());
        }
        legs.push(Leg { dofs, anchor: None, carry: [0.0; 3], prev_world: None });
    }
    // The legs in the order of the feet.
    if legs.len() != t.feet.len() {
        return Ok(Vec::new());
    }
    Ok(legs)
}

/// The run `y` (units, rates integrated) of `m` carried by its feet, when the
/// model travels by them ([`FeetTravel::for_model`]); otherwise as it is.
pub fn feet_led(m: &TrainedCpg, y: &mut [f64]) -> Result<()> {
    if let Some(mut t) = FeetTravel::for_model(m)? {
        t.apply_run(y, m.outputs.len());
    }
    Ok(())
}

/// Each foot's floor in the model's taught rhythms (postures aside): the
/// [`crate::measure::FLOOR_QUANTILE`] of its heights, mm.
fn teacher_floors(m: &TrainedCpg, sk: &Skeleton, feet: &[String]) -> Result<Vec<f64>> {
    let d = m.outputs.len();
    let channels = crate::run::mocap_channels(m)?;
    let all = sk.all_channels();
    let mut positions = Vec::new();
    for t in m.teachers.iter().filter(|t| !t.is_posture(d)) {
        let units = cpg_reservoir::to_units(&m.outputs, &t.cycle);
        let n = units.len() / d;
        let mut full = vec![0.0; n * all.len()];
        for (k, c) in channels.iter().enumerate() {
            if let Some(r) = all.iter().position(|a| a == c) {
                for f in 0..n {
                    full[f * all.len() + r] = units[f * d + k];
                }
            }
        }
        let motion = cpg_mocap::Motion::new(all.clone(), full, m.provenance.sample_rate_hz)?;
        positions.push(sk.forward_kinematics(&motion)?);
    }
    Ok(crate::measure::floors(&positions, feet))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One leg: a thigh (rx, ry, rz) and a shin (rx), each 8 units long,
    /// straight down from the root.
    const LEG_ASF: &str = ":version 1.10\n:name leg\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n   position 0 0 0\n   orientation 0 0 0\n:bonedata\n  begin\n     id 1\n     name lfemur\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n    dof rx ry rz\n  end\n  begin\n     id 2\n     name ltibia\n     direction 0 -1 0\n     length 8.0\n     axis 0 0 0  XYZ\n    dof rx\n  end\n:hierarchy\n  begin\n    root lfemur\n    lfemur ltibia\n  end\n";

    fn leg() -> (Kinematics, Vec<f64>, Vec<(usize, usize)>, usize) {
        let sk = cpg_mocap::parse_asf("leg.asf", LEG_ASF.as_bytes()).unwrap();
        let all = sk.all_channels();
        let kin = Kinematics::new(&sk, &all).unwrap();
        let dofs: Vec<(usize, usize)> = all
            .iter()
            .enumerate()
            .filter(|(_, c)| c.bone != "root" && c.dof.is_rotation())
            .map(|(r, _)| (r, r))
            .collect();
        let foot = kin.names().iter().position(|n| n == "ltibia").unwrap();
        (kin, vec![0.0; all.len()], dofs, foot)
    }

    fn foot_at(kin: &mut Kinematics, row: &[f64], foot: usize) -> [f64; 3] {
        let p = kin.frame(row);
        [p[foot][0] - p[0][0], p[foot][1], p[foot][2] - p[0][2]]
    }

    #[test]
    fn inverse_kinematics_puts_the_foot_where_it_is_asked_and_no_further() {
        let (mut kin, mut row, dofs, foot) = leg();
        let mm = 1000.0 / 0.45 * 0.0254;
        let start = foot_at(&mut kin, &row, foot);
        assert!((start[1] + 16.0 * mm).abs() < 1e-6, "the foot straight down, 16 units: {start:?}");
        // 60 mm forward and 40 mm up from the straight leg: within reach.
        let target = [0.0, start[1] + 40.0, start[2] + 60.0];
        solve_leg(&mut kin, &mut row, &dofs, foot, target);
        let got = foot_at(&mut kin, &row, foot);
        let miss = (0..3).map(|i| (got[i] - target[i]).powi(2)).sum::<f64>().sqrt();
        assert!(miss <= IK_TOLERANCE_MM, "missed by {miss} mm: {got:?}");
        // Out of reach (a metre below the hip): the leg stretches towards it, finite, no step beyond the bound.
        let mut far = row.clone();
        let before = far.clone();
        solve_leg(&mut kin, &mut far, &dofs, foot, [0.0, -1000.0 - 16.0 * mm, 0.0]);
        assert!(far.iter().all(|v| v.is_finite()));
        for &(r, _) in &dofs {
            assert!((far[r] - before[r]).abs() <= IK_STEP_DEG * IK_ITERATIONS as f64 + 1e-9);
        }
        // Nothing to solve without rotations, or with more than four.
        let mut same = row.clone();
        solve_leg(&mut kin, &mut same, &[], foot, target);
        assert_eq!(same, row);
    }

    #[test]
    fn a_singular_system_has_no_solution_and_a_regular_one_its_own() {
        assert_eq!(solve3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]], [1.0, 2.0, 3.0]), None);
        let x = solve3(&[[2.0, 0.0, 0.0], [0.0, 4.0, 0.0], [1.0, 0.0, 1.0]], [2.0, 8.0, 4.0]).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12 && (x[2] - 3.0).abs() < 1e-12, "{x:?}");
    }
}

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

use cpg_mocap::{Channel, Dof, Kinematics, Skeleton};
use cpg_reservoir::TrainedCpg;

use crate::error::Result;

/// Above this height over its floor the lower foot bears no weight: the
/// figure is in flight and travels by its learnt rate, mm.
pub const FLIGHT_MM: f64 = 30.0;

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
        Ok(Some(FeetTravel::new(m, &sk, out_tx, out_tz, &feet, &floors)?))
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
        })
    }

    /// Starts again from a run's first frame.
    pub fn reset(&mut self) {
        self.started = false;
        self.prev_anchor = None;
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
    }

    /// Every frame of a run (`T × d`, units, rates integrated), from its start.
    pub fn apply_run(&mut self, y: &mut [f64], d: usize) {
        self.reset();
        for frame in y.chunks_exact_mut(d) {
            self.apply(frame);
        }
    }
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

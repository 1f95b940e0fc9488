//! Walking in physics (issue 29): the HOAP-2 in MuJoCo, driven by the
//! paper's joint-angle copy, by the retargeted walk played open loop, and by
//! the CPG learnt from the retargeted walk without and with balance
//! feedback; flat ground, pushes and a tempo change, over reservoir seeds.
//!
//! The simulation runs in the Python package (`python -m cpg.walk_eval`,
//! MuJoCo from the package registry); this module reads what it measured,
//! judges it against the targets and builds the report's section. Every
//! aggregate is computed here, from the runs, once.

mod section;

use serde::{Deserialize, Serialize};

use super::claim::{Claim, Measure, Source, Verdict};
use crate::error::{Error, Result};
use crate::stats::Proportion;

/// One simulated run, as `cpg.sim.simulate` measures it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimRun {
    /// Seconds asked for.
    pub seconds: f64,
    /// Seconds until the fall (the whole run when it did not fall).
    pub upright_s: f64,
    /// It fell (the trunk below 60 % of its standing height or tilted beyond 45°).
    pub fell: bool,
    /// The trunk's advance along the walking direction, m.
    pub forward_m: f64,
    /// Its sideways drift, m.
    pub lateral_m: f64,
    /// The trunk's heading at the end, degrees (0: straight ahead).
    pub heading_deg: f64,
    /// Forward speed while upright, m/s.
    pub speed_m_s: f64,
    /// The same in leg lengths per second.
    pub speed_leg_lengths_s: f64,
    /// The largest servo torque, N·m.
    pub max_torque_nm: f64,
    /// Mechanical work of the servos over weight × distance (`None`: it did not move).
    pub cost_of_transport: Option<f64>,
    /// Pushes survived (upright 2 s after each).
    pub pushes_survived: usize,
    /// Pushes given.
    pub pushes_total: usize,
    /// When a CPG took over from the planned start walk, s (`None`: no CPG).
    #[serde(default)]
    pub handover_s: Option<f64>,
    /// When the CPG was told to stop (its `u_walk` to 0), s.
    #[serde(default)]
    pub stop_at_s: Option<f64>,
    /// How far the trunk moved from 3 s after the stop's ramp to the end, m
    /// (`None`: no stop, or it fell first).
    #[serde(default)]
    pub moved_after_stop_m: Option<f64>,
    /// The trunk's path at 50 Hz: `[t_s, x_m, y_m, z_m]` (recorded runs only).
    #[serde(default)]
    pub trunk_path: Vec<[f64; 4]>,
    /// The soles' contact forces at 50 Hz: `[t_s, left_n, right_n]` (recorded runs only).
    #[serde(default)]
    pub contacts_n: Vec<[f64; 3]>,
    /// The servoed joints, in the order of the angles in `poses` (recorded runs only).
    #[serde(default)]
    pub pose_joints: Vec<String>,
    /// The body at 50 Hz: `[t_s, x_m, y_m, z_m, qw, qx, qy, qz, angle_rad…]`,
    /// the trunk's position and orientation, then every joint of `pose_joints`.
    #[serde(default, skip_serializing)]
    pub poses: Vec<Vec<f64>>,
}

impl SimRun {
    /// Reads a run `cpg-sim -o` wrote; `file` names it in errors.
    pub fn from_json(text: &str, file: &std::path::Path) -> Result<SimRun> {
        serde_json::from_str(text)
            .map_err(|e| Error::data_file(file, Some(e.line()), format!("not a cpg-sim run: {e}")))
    }

    /// The recorded body as a scene to watch: the HOAP-2 where the physics
    /// put it (`cpg view --sim`, the report's walking page), its first
    /// `seconds` (all of it: `None`).
    pub fn scene(&self, title: &str, seconds: Option<f64>) -> Result<cpg_view::Scene> {
        let d = self.pose_joints.len();
        if self.poses.len() < 2 || d == 0 {
            return Err(Error::Unusable(
                "the run holds no body poses (cpg-sim records them with -o, cpg.walk_eval for the first seed)".into(),
            ));
        }
        if let Some(k) = self.poses.iter().position(|p| p.len() != 8 + d) {
            return Err(Error::Shape(format!("pose {k} has {} values; expected 8 + {d}", self.poses[k].len())));
        }
        let robot = cpg_robot::Robot::hoap2()?;
        let rate = 1.0 / (self.poses[1][0] - self.poses[0][0]);
        if !(rate.is_finite() && rate > 0.0) {
            return Err(Error::Shape("the poses' times do not increase".into()));
        }
        let n = seconds.map_or(self.poses.len(), |s| ((s * rate).round() as usize).clamp(1, self.poses.len()));
        let poses = &self.poses[..n];
        let base: Vec<([f64; 3], [f64; 4])> =
            poses.iter().map(|p| ([p[1], p[2], p[3]], [p[4], p[5], p[6], p[7]])).collect();
        let q: Vec<f64> = poses.iter().flat_map(|p| p[8..].iter().copied()).collect();
        let fig =
            cpg_view::Figure::robot_posed(&crate::scene::robot_label(&robot), &robot, &self.pose_joints, &q, &base)
                .map_err(crate::scene::view_error)?
                .with_note(format!(
                    "simulated in MuJoCo: {:.1} s upright, {:.2} m forward, heading {:+.1}°",
                    self.upright_s, self.forward_m, self.heading_deg
                ));
        cpg_view::Scene::new(title, rate, vec![fig]).map_err(crate::scene::view_error)
    }
}

/// A walker's three runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Conditions {
    /// Flat ground.
    pub flat: SimRun,
    /// Pushes every few seconds, the directions in turn.
    pub pushes: SimRun,
    /// A tempo change half-way.
    pub tempo: SimRun,
    /// Told to stop half-way and stand (a CPG with a `u_walk` input).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop: Option<SimRun>,
}

/// A CPG judged as every model is (`Model.evaluate`, `cpg evaluate`): a long
/// free run and the paper's push at one control setting it was taught.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Judgement {
    /// The teacher (`walk ×1.15`).
    pub teacher: String,
    /// Its control values.
    pub controls: Vec<f64>,
    /// The long run.
    pub stability: JudgedRun,
    /// The push.
    pub recovery: crate::measure::Recovery,
}

/// What a long free run gave (the fields of [`crate::measure::Stability`] this section reads).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JudgedRun {
    /// Steps run.
    pub steps: usize,
    /// Period and amplitudes at the end within the tolerances of the teacher's.
    pub accurate: bool,
    /// The rhythm no longer changed after the first minute (a posture: it is still).
    pub converged: bool,
    /// Present when the teacher is a posture (standing): how far and how much it moved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub posture: Option<serde_json::Value>,
}

/// One reservoir seed's CPG, without and with feedback.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedRuns {
    /// The reservoir seed.
    pub seed: u64,
    /// Seconds its training took.
    pub fit_s: f64,
    /// The model, as the package shows it.
    pub model: String,
    /// Its long free runs and pushes, at each tempo it was taught.
    #[serde(default)]
    pub judged: Vec<Judgement>,
    /// The CPG alone.
    pub cpg: Conditions,
    /// The CPG with the searched feedback gains.
    #[serde(rename = "cpg+feedback")]
    pub cpg_feedback: Conditions,
}

/// What `python -m cpg.walk_eval` wrote.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WalkEval {
    /// The retargeted walk (the start of every run).
    pub trajectory: String,
    /// The CPG's training configuration.
    pub config: Option<String>,
    /// The feedback gains.
    pub gains: serde_json::Value,
    /// Seconds per run.
    pub seconds: f64,
    /// Seconds between pushes.
    pub push_every_s: f64,
    /// Each push's change of the trunk's velocity, m/s.
    pub push_mps: f64,
    /// The tempo change half-way (a factor on the stride rate).
    pub tempo: f64,
    /// Seconds of its cosine ramp.
    pub tempo_ramp_s: f64,
    /// Seconds of the stop's cosine ramp (runs recorded before it was a
    /// setting ramped over 2 s).
    #[serde(default = "two_seconds")]
    pub stop_ramp_s: f64,
    /// The paper's joint-angle copy, if it ran.
    #[serde(default)]
    pub copy_run: Option<Conditions>,
    /// The retargeted walk played open loop.
    pub open_loop: Conditions,
    /// The retargeted walk with the feedback.
    #[serde(rename = "open_loop+feedback")]
    pub open_loop_feedback: Conditions,
    /// Every seed's CPG.
    pub seeds: Vec<SeedRuns>,
    /// Seconds the simulations took.
    pub wall_s: f64,
    /// Seconds of each CPG's judged free run.
    #[serde(default)]
    pub judge_s: f64,
}

/// The most seeds read from one evaluation.
pub const MAX_SEEDS: usize = 1000;

impl WalkEval {
    /// Reads `walk_eval`'s JSON; `file` names it in errors.
    pub fn from_json(text: &str, file: &std::path::Path) -> Result<WalkEval> {
        let e: WalkEval = serde_json::from_str(text)
            .map_err(|e| Error::data_file(file, Some(e.line()), format!("not a walk_eval result: {e}")))?;
        if e.seeds.is_empty() || e.seeds.len() > MAX_SEEDS {
            return Err(Error::data_file(file, None, format!("{} seeds; expected 1 to {MAX_SEEDS}", e.seeds.len())));
        }
        Ok(e)
    }
}

/// One row of the table: a walker in one condition, over its runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// Which walker.
    pub walker: String,
    /// Which condition (`flat`, `pushes`, `tempo`).
    pub condition: String,
    /// Runs upright to the end.
    pub upright: Proportion,
    /// Seconds upright.
    pub upright_s: Vec<f64>,
    /// Forward advance, m.
    pub forward_m: Vec<f64>,
    /// Heading at the end, degrees.
    pub heading_deg: Vec<f64>,
    /// Forward speed, m/s.
    pub speed_m_s: Vec<f64>,
    /// Forward speed, leg lengths per second.
    pub speed_leg_lengths_s: Vec<f64>,
    /// The largest torque, N·m.
    pub max_torque_nm: Vec<f64>,
    /// Cost of transport (runs that moved).
    pub cost_of_transport: Vec<f64>,
    /// Pushes survived, of pushes given (over the runs).
    pub pushes: Proportion,
}

impl Row {
    fn of(walker: &str, condition: &str, runs: &[&SimRun]) -> Row {
        let v = |f: fn(&SimRun) -> f64| runs.iter().map(|r| f(r)).collect::<Vec<f64>>();
        Row {
            walker: walker.to_owned(),
            condition: condition.to_owned(),
            upright: Proportion::count(runs.iter().map(|r| !r.fell)),
            upright_s: v(|r| r.upright_s),
            forward_m: v(|r| r.forward_m),
            heading_deg: v(|r| r.heading_deg),
            speed_m_s: v(|r| r.speed_m_s),
            speed_leg_lengths_s: v(|r| r.speed_leg_lengths_s),
            max_torque_nm: v(|r| r.max_torque_nm),
            cost_of_transport: runs.iter().filter_map(|r| r.cost_of_transport).collect(),
            pushes: Proportion::new(
                runs.iter().map(|r| r.pushes_survived).sum(),
                runs.iter().map(|r| r.pushes_total).sum(),
            ),
        }
    }
}

/// The targets of issue 29, as numbers.
pub mod targets {
    /// Share of seeds upright for the whole run.
    pub const UPRIGHT_SHARE: f64 = 0.9;
    /// Forward advance of each upright run of [`RUN_S`], m (shorter runs
    /// need the same average speed: see [`forward_needed_m`]).
    pub const FORWARD_M: f64 = 3.0;
    /// The run length the targets are stated for, s.
    pub const RUN_S: f64 = 60.0;
    /// Largest heading drift, degrees.
    pub const HEADING_DEG: f64 = 15.0;
    /// Share of pushes survived.
    pub const PUSHES_SHARE: f64 = 0.8;

    /// The advance a run of `seconds` needs: [`FORWARD_M`] in [`RUN_S`],
    /// at the same average speed.
    pub fn forward_needed_m(seconds: f64) -> f64 {
        FORWARD_M * seconds / RUN_S
    }
}

/// Walking in physics, judged.
#[derive(Debug, Clone, Serialize)]
pub struct WalkingResult {
    /// The configuration and how its CPG was trained.
    pub header: super::Header,
    /// What was simulated.
    pub eval: WalkEval,
    /// Every walker in every condition.
    pub rows: Vec<Row>,
    /// The targets, each with its verdict.
    pub claims: Vec<Claim>,
}

fn two_seconds() -> f64 {
    2.0
}

fn claim(c: &str, measured: Vec<Measure>, verdict: Verdict) -> Claim {
    Claim {
        experiment: "Walking".into(),
        claim: c.into(),
        sources: vec![Source::Inferred {
            text: "not in the papers: wyffels & Schrauwen (2009) leave walking on the robot as future work; the targets are issue 29's".into(),
        }],
        protocol: "extension".into(),
        differs: vec!["the gait is retargeted to the robot (ZMP preview control) and the CPG has a tempo input and a walk/stand input".into()],
        measured,
        verdict,
    }
}

/// Judges the evaluation `eval` of configuration `c` (an `[experiment.test.walking]`).
pub fn judge(c: &crate::Config, eval: WalkEval) -> Result<WalkingResult> {
    let prep = crate::prepare::prepare(c)?;
    let n = crate::train::reservoir_config(c, prep.outputs.len())?.n_neurons;
    Ok(WalkingResult::of(super::header(c, &prep, n)?, eval))
}

/// Whether a run walked: upright to the end, far enough, straight enough.
fn walked(r: &SimRun) -> bool {
    !r.fell && r.forward_m >= targets::forward_needed_m(r.seconds) && r.heading_deg.abs() <= targets::HEADING_DEG
}

impl super::Experiment for WalkingResult {
    fn figure(&self) -> &'static str {
        "beyond the paper"
    }
    fn header(&self) -> &super::Header {
        &self.header
    }
    fn claims(&self) -> &[Claim] {
        &self.claims
    }
    fn table(&self) -> &[Measure] {
        &[]
    }
    fn seed_models(&self) -> Vec<&super::SeedModel> {
        Vec::new()
    }
    fn passed(&self) -> (usize, usize) {
        (self.eval.seeds.iter().filter(|s| walked(&s.cpg_feedback.flat)).count(), self.eval.seeds.len())
    }
    fn target(&self) -> &'static str {
        "walked with feedback: upright, 3 m per 60 s, within ±15°"
    }
    fn section(all: &[&Self], ctx: &super::doc::Context) -> Result<super::doc::Section> {
        let mut s = super::doc::Section::default();
        for r in all {
            section::section(&mut s, r, ctx);
        }
        Ok(s)
    }
}

impl WalkingResult {
    /// Judges an evaluation of the configuration `header` describes.
    pub fn of(header: super::Header, eval: WalkEval) -> WalkingResult {
        let mut rows = Vec::new();
        let mut add = |walker: &str, c: &[&Conditions]| {
            for (name, pick) in [
                ("flat", (|x: &Conditions| &x.flat) as fn(&Conditions) -> &SimRun),
                ("pushes", |x: &Conditions| &x.pushes),
                ("tempo", |x: &Conditions| &x.tempo),
            ] {
                rows.push(Row::of(walker, name, &c.iter().map(|x| pick(x)).collect::<Vec<_>>()));
            }
        };
        if let Some(c) = &eval.copy_run {
            add("the paper's joint-angle copy", &[c]);
        }
        add("the retargeted walk, open loop", &[&eval.open_loop]);
        add("the retargeted walk, open loop with feedback", &[&eval.open_loop_feedback]);
        add("the CPG, no feedback", &eval.seeds.iter().map(|s| &s.cpg).collect::<Vec<_>>());
        add("the CPG with feedback", &eval.seeds.iter().map(|s| &s.cpg_feedback).collect::<Vec<_>>());
        for (walker, pick) in [
            ("the CPG, no feedback", (|s: &SeedRuns| &s.cpg) as fn(&SeedRuns) -> &Conditions),
            ("the CPG with feedback", |s: &SeedRuns| &s.cpg_feedback),
        ] {
            let stops: Vec<&SimRun> = eval.seeds.iter().filter_map(|s| pick(s).stop.as_ref()).collect();
            if !stops.is_empty() {
                rows.push(Row::of(walker, "stop", &stops));
            }
        }
        let mut claims = claims(&eval);
        claims.extend(stop_claim(&eval));
        WalkingResult { header, eval, rows, claims }
    }
}

/// Told to stop half-way, the CPG with feedback stands: upright to the end
/// (`None` when no run stopped).
fn stop_claim(e: &WalkEval) -> Option<Claim> {
    let stops: Vec<&SimRun> = e.seeds.iter().filter_map(|s| s.cpg_feedback.stop.as_ref()).collect();
    let at = stops.first()?.stop_at_s?;
    let n = stops.len();
    let need = (targets::UPRIGHT_SHARE * n as f64 - 1e-9).ceil() as usize;
    let up = Proportion::count(stops.iter().map(|r| !r.fell));
    let moved: Vec<f64> = stops.iter().filter(|r| !r.fell).filter_map(|r| r.moved_after_stop_m).collect();
    let mut measured = vec![Measure::count(format!("seeds upright to the end after the stop at {at:.0} s"), up)];
    if !moved.is_empty() {
        measured.push(Measure::spread(
            "the trunk's travel while standing (from 3 s after the ramp's end to the end)",
            &moved.iter().map(|m| 1000.0 * m).collect::<Vec<_>>(),
            "mm",
            0,
        ));
    }
    Some(claim(
        "it stops by its input and stands",
        measured,
        Verdict::new(
            up.k >= need,
            false,
            format!(
                "at least {need} of {n} seeds stay upright to the end when the walk input u_walk falls to 0 at {at:.0} s (a {}-s cosine ramp){}",
                e.stop_ramp_s,
                if up.k >= need { String::new() } else { format!("; missed by {} seed(s)", need - up.k) }
            ),
        ),
    ))
}

/// The walk's CPG judged as every model is: long free runs and the paper's
/// push at every setting it was taught.
fn rhythm_claim(e: &WalkEval, need: usize) -> Claim {
    let n = e.seeds.len();
    let judged: Vec<&Judgement> = e.seeds.iter().flat_map(|s| &s.judged).collect();
    let long = Proportion::count(
        e.seeds.iter().map(|s| !s.judged.is_empty() && s.judged.iter().all(|j| j.stability.accurate)),
    );
    let back = Proportion::count(
        e.seeds.iter().map(|s| !s.judged.is_empty() && s.judged.iter().all(|j| j.recovery.orbit_s.is_some())),
    );
    let back_s: Vec<f64> = judged.iter().filter_map(|j| j.recovery.orbit_s).collect();
    let stands = judged.iter().any(|j| j.stability.posture.is_some());
    claim(
        if stands {
            "the walk's CPG keeps its rhythm at every tempo it was taught and holds its standing pose, and recovers after a push"
        } else {
            "the walk's CPG keeps its rhythm at every tempo it was taught, and recovers after a push"
        },
        vec![
            Measure::count(format!("seeds accurate after {:.0} s at every setting", e.judge_s), long),
            Measure::count("seeds back on the orbit after the paper's push at every setting", back),
            Measure::spread("time back on the orbit", &back_s, "s", 2),
        ],
        Verdict::new(
            long.k >= need && back.k >= need,
            false,
            format!(
                "at least {need} of {n} seeds are accurate (period within 1 %, amplitudes within 5 %{}) after {:.0} s of free run and back on the teacher's orbit after the paper's push, at every setting they were taught{}",
                if stands {
                    format!("; standing: every joint within {}° of the pose", crate::measure::POSTURE_TOLERANCE)
                } else {
                    String::new()
                },
                e.judge_s,
                if long.k >= need && back.k >= need {
                    String::new()
                } else {
                    format!("; missed by {} seed(s)", need.saturating_sub(long.k.min(back.k)))
                }
            ),
        ),
    )
}

/// The targets' verdicts, on the CPG with feedback.
fn claims(e: &WalkEval) -> Vec<Claim> {
    use targets::*;
    let n = e.seeds.len();
    let runs = |f: fn(&Conditions) -> &SimRun| e.seeds.iter().map(|s| f(&s.cpg_feedback)).collect::<Vec<&SimRun>>();
    let flat = runs(|c| &c.flat);
    let walked = flat.iter().filter(|r| walked(r)).count();
    let need = (UPRIGHT_SHARE * n as f64 - 1e-9).ceil() as usize;
    let up = Proportion::count(flat.iter().map(|r| !r.fell));
    let pushes = runs(|c| &c.pushes);
    let p =
        Proportion::new(pushes.iter().map(|r| r.pushes_survived).sum(), pushes.iter().map(|r| r.pushes_total).sum());
    let share = if p.n > 0 { p.k as f64 / p.n as f64 } else { 0.0 };
    let tempo = runs(|c| &c.tempo);
    let tempo_up = Proportion::count(tempo.iter().map(|r| !r.fell));
    let forward: Vec<f64> = flat.iter().map(|r| r.forward_m).collect();
    let heading: Vec<f64> = flat.iter().map(|r| r.heading_deg.abs()).collect();
    vec![
        rhythm_claim(e, need),
        claim(
            "the CPG walks the robot: upright, forward, straight",
            vec![
                Measure::count(format!("seeds upright for the whole {:.0} s", e.seconds), up),
                Measure::spread("forward advance", &forward, "m", 2),
                Measure::spread("|heading| at the end", &heading, "°", 1),
                Measure::number(
                    format!(
                        "seeds upright, at least {:.1} m forward and within ±{HEADING_DEG}°",
                        forward_needed_m(e.seconds)
                    ),
                    walked as f64,
                    "",
                    0,
                ),
            ],
            Verdict::new(
                walked >= need,
                false,
                format!(
                    "at least {need} of {n} seeds ({:.0} %) stay upright for the whole run on flat ground, at least {:.1} m forward ({FORWARD_M} m in {RUN_S} s, the same speed over this run's {:.0} s), the heading within ±{HEADING_DEG}°{}",
                    100.0 * UPRIGHT_SHARE,
                    forward_needed_m(e.seconds),
                    e.seconds,
                    if walked >= need { String::new() } else { format!("; missed by {} seed(s)", need - walked) }
                ),
            ),
        ),
        claim(
            "it survives pushes",
            vec![Measure::count(format!("pushes of {} m/s survived", e.push_mps), p)],
            Verdict::new(
                p.n > 0 && share >= PUSHES_SHARE,
                false,
                format!(
                    "at least {:.0} % of the pushes ({} m/s over 0.1 s, every {} s, the directions in turn) leave the robot upright 2 s later{}",
                    100.0 * PUSHES_SHARE,
                    e.push_mps,
                    e.push_every_s,
                    if share >= PUSHES_SHARE {
                        String::new()
                    } else {
                        format!("; missed by {:.1} percentage points", 100.0 * (PUSHES_SHARE - share))
                    }
                ),
            ),
        ),
        claim(
            "it changes its tempo by its input without falling",
            vec![Measure::count(format!("seeds upright through the tempo change to ×{}", e.tempo), tempo_up)],
            Verdict::new(
                tempo_up.k >= need,
                false,
                format!(
                    "at least {need} of {n} seeds stay upright when the tempo input moves to ×{} half-way{}",
                    e.tempo,
                    if tempo_up.k >= need {
                        String::new()
                    } else {
                        format!("; missed by {} seed(s)", need - tempo_up.k)
                    }
                ),
            ),
        ),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(fell: bool, forward_m: f64, heading_deg: f64, pushes: (usize, usize)) -> SimRun {
        SimRun {
            seconds: 60.0,
            upright_s: if fell { 10.0 } else { 60.0 },
            fell,
            forward_m,
            lateral_m: 0.0,
            heading_deg,
            speed_m_s: forward_m / 60.0,
            speed_leg_lengths_s: forward_m / 60.0 / 0.2355,
            max_torque_nm: 5.0,
            cost_of_transport: Some(1.0),
            pushes_survived: pushes.0,
            pushes_total: pushes.1,
            handover_s: Some(11.0),
            stop_at_s: None,
            moved_after_stop_m: None,
            trunk_path: Vec::new(),
            contacts_n: Vec::new(),
            pose_joints: Vec::new(),
            poses: Vec::new(),
        }
    }

    fn header() -> crate::experiment::Header {
        crate::experiment::Header {
            id: "Walking".into(),
            title: "the HOAP-2 in MuJoCo".into(),
            protocol: crate::config::Protocol::Extension,
            method: String::new(),
            config: "experiments/hoap2-walk.toml".into(),
            cycles: Vec::new(),
            notes: Vec::new(),
            score: crate::config::ScoreKind::Orbit,
            noise_variance: 0.0,
            penalty_grid: (91, 4.0, -5.0),
            n_neurons: 600,
            differs: Vec::new(),
            conditions: crate::experiment::conditions::Conditions {
                validation: Vec::new(),
                tuned: Vec::new(),
                test: Vec::new(),
            },
            warnings: Vec::new(),
        }
    }

    fn conditions(r: SimRun) -> Conditions {
        Conditions { flat: r.clone(), pushes: r.clone(), tempo: r, stop: None }
    }

    fn eval(seeds: Vec<SimRun>) -> WalkEval {
        WalkEval {
            trajectory: "walk.csv".into(),
            config: None,
            gains: serde_json::json!({}),
            seconds: 60.0,
            push_every_s: 5.0,
            push_mps: 0.2,
            tempo: 1.1,
            tempo_ramp_s: 3.0,
            stop_ramp_s: 3.0,
            copy_run: None,
            open_loop: conditions(run(true, 0.1, 0.0, (0, 0))),
            open_loop_feedback: conditions(run(false, 3.0, 1.0, (0, 0))),
            seeds: seeds
                .into_iter()
                .enumerate()
                .map(|(k, r)| SeedRuns {
                    seed: k as u64 + 1,
                    fit_s: 1.0,
                    model: String::new(),
                    judged: vec![Judgement {
                        teacher: "walk ×1".into(),
                        controls: vec![1.0],
                        stability: JudgedRun { steps: 1000, accurate: true, converged: true, posture: None },
                        recovery: crate::measure::Recovery {
                            orbit_s: Some(0.2),
                            own_orbit_s: Some(0.2),
                            unpushed_on_orbit: true,
                            twin_s: None,
                            phase_shift_cycles: 0.0,
                        },
                    }],
                    cpg: conditions(r.clone()),
                    cpg_feedback: conditions(r),
                })
                .collect(),
            wall_s: 1.0,
            judge_s: 900.0,
        }
    }

    #[test]
    fn the_targets_are_judged_with_what_they_missed_by() {
        let good = |_| run(false, 3.7, 2.0, (11, 12));
        let r = WalkingResult::of(header(), eval((0..10).map(good).collect()));
        assert!(r.claims.iter().all(|c| c.verdict.passed()), "{:?}", r.claims);
        let mut seeds: Vec<SimRun> = (0..10).map(good).collect();
        seeds[0] = run(true, 1.0, 2.0, (1, 12));
        seeds[1] = run(false, 3.5, 20.0, (12, 12));
        let r = WalkingResult::of(header(), eval(seeds));
        assert!(r.claims[0].verdict.passed(), "every seed keeps its rhythm");
        assert!(!r.claims[1].verdict.passed());
        assert!(r.claims[1].verdict.rule.contains("missed by 1 seed"), "{}", r.claims[1].verdict.rule);
        // 108 of 120 pushes: 90 %, still above 80 %.
        assert!(r.claims[2].verdict.passed());
        assert_eq!(r.rows.len(), 4 * 3);
    }

    #[test]
    fn a_stop_is_judged_by_the_runs_that_stood() {
        let mut e = eval((0..10).map(|_| run(false, 3.7, 2.0, (11, 12))).collect());
        assert!(stop_claim(&e).is_none(), "no stop runs, no claim");
        for (k, s) in e.seeds.iter_mut().enumerate() {
            let fell = k < 2;
            let stop = SimRun {
                stop_at_s: Some(30.0),
                moved_after_stop_m: (!fell).then_some(0.01),
                ..run(fell, 2.0, 1.0, (0, 0))
            };
            s.cpg_feedback.stop = Some(stop);
        }
        let c = stop_claim(&e).unwrap();
        assert!(!c.verdict.passed(), "8 of 10 stood; 9 are needed");
        assert!(c.verdict.rule.contains("missed by 1 seed") && c.verdict.rule.contains("30 s"), "{}", c.verdict.rule);
        e.seeds[0].cpg_feedback.stop.as_mut().unwrap().fell = false;
        assert!(stop_claim(&e).unwrap().verdict.passed());
        let r = WalkingResult::of(header(), e);
        assert_eq!(r.rows.iter().filter(|r| r.condition == "stop").count(), 1, "a row for the CPG with feedback");
    }

    #[test]
    fn a_shorter_run_needs_the_same_speed_not_the_same_distance() {
        let short = |forward_m| SimRun { seconds: 20.0, ..run(false, forward_m, 2.0, (0, 0)) };
        assert!(walked(&short(1.05)), "1.05 m in 20 s is faster than 3 m in 60 s");
        assert!(!walked(&short(0.95)));
        assert!(!walked(&run(false, 2.9, 2.0, (0, 0))), "a 60-s run needs the whole 3 m");
    }

    /// The gait diagram once showed the planned start walk (0–10 s), not the
    /// CPG, which takes over later: it shows 10 s from the hand-over.
    #[test]
    fn the_gait_diagram_shows_the_cpg_s_own_strides() {
        let r = run(false, 3.7, 2.0, (0, 0));
        assert_eq!(section::gait_window(&r), (11.0, 21.0));
        assert_eq!(section::gait_window(&SimRun { handover_s: None, ..r }), (0.0, 10.0));
    }

    #[test]
    fn a_file_that_is_not_an_evaluation_says_where() {
        let e = WalkEval::from_json("{\n \"seeds\": 3\n}", std::path::Path::new("w.json")).unwrap_err();
        assert!(matches!(e, Error::DataFile { line: Some(_), .. }), "{e:?}");
        assert!(e.to_string().starts_with("w.json:"), "{e}");
    }
}

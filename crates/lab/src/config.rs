//! The training and experiment configuration (TOML), documented for users in
//! `docs/config.md`.
//!
//! Paths are relative to the file that names them. Unknown keys are errors,
//! so a misspelt option is reported instead of silently ignored, and every
//! error names the field in the file's own words (`training.penalty_log10`)
//! and its line.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::retarget::{MAX_TEMPO, MIN_TEMPO};

/// The largest configuration file read, bytes.
pub const MAX_CONFIG_BYTES: usize = 1 << 20;
/// The most `[[data.segments]]` a configuration has.
pub const MAX_SEGMENTS: usize = 1000;
/// Most samples a training sequence may have (per output channel): bounds
/// `data.samples_per_segment` times the blocks, `data.tempo.samples` and
/// the training section's sample counts.
pub const MAX_TRAINING_SAMPLES: usize = 2_000_000;
/// Most steps of a validation run (`[training.orbit]`).
pub const MAX_VALIDATION_STEPS: usize = 200_000;
/// Most penalties in a grid (`training.penalty_log10`).
pub const MAX_PENALTIES: usize = 1000;
/// Most noise draws per candidate (`training.noise_draws`).
pub const MAX_NOISE_DRAWS: usize = 100;

/// A whole configuration file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// What to learn.
    pub data: DataSection,
    /// The reservoir: a preset plus the parameters given over it (the
    /// reservoir crate's own schema, [`cpg_reservoir::ReservoirSettings`]).
    #[serde(default)]
    pub reservoir: cpg_reservoir::ReservoirSettings,
    /// How the readout and its penalty are chosen.
    #[serde(default)]
    pub training: TrainingSection,
    /// Where the model goes.
    pub output: OutputSection,
    /// The test protocol run by the report on this model (optional).
    pub experiment: Option<ExperimentSection>,
    /// The file this configuration was read from (not a key of the file).
    #[serde(skip)]
    pub source: PathBuf,
}

/// `[data]`: the motion, the channels to learn, and how they become a training sequence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSection {
    /// The ASF skeleton of AMC motions (BVH motions carry their own: leave it out).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skeleton: Option<PathBuf>,
    /// Millimetres per length unit of BVH motions (default: inferred from the figure's size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bvh_unit_mm: Option<f64>,
    /// Capture rate of the motions, Hz (AMC does not store it; a BVH file's frame time must agree).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Channels to learn: names (`lfemur.rx`), globs (`lfemur.*`) or groups
    /// (`legs`, `arms`, `hoap2`); they become the CPG's outputs, in this order.
    pub channels: Vec<String>,
    /// Names of the control inputs (empty: none).
    #[serde(default)]
    pub controls: Vec<String>,
    /// One or more motion segments, each with constant control values.
    pub segments: Vec<SegmentSection>,
    /// Cut a seamless loop of this many gait cycles out of each segment and
    /// repeat it (0: use the segments as recorded).
    #[serde(default = "default_cycles")]
    pub loop_cycles: usize,
    /// With loops: samples of each segment's repeated loop in one block of the training sequence.
    #[serde(default = "default_samples")]
    pub samples_per_segment: usize,
    /// With loops: how many times the sequence of segment blocks is repeated.
    #[serde(default = "default_repeats")]
    pub repeats: usize,
    /// With loops: the teachers' blocks in this order (each repeated
    /// `repeats` times), so that every switch a test asks for is taught
    /// (default: each teacher in turn).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sequence: Option<Vec<usize>>,
    /// With loops: seconds of phase-continuous blend from one segment's cycle
    /// to the next between blocks, while the controls ramp (0: blocks abut).
    #[serde(default)]
    pub morph_s: f64,
    /// Shortest and longest gait period searched, seconds.
    #[serde(default = "default_period")]
    pub period_s: [f64; 2],
    /// The channel whose rhythm sets the period (default: the most regular one).
    pub period_channel: Option<String>,
    /// Channels (of `channels`) learnt as their rate of change per second,
    /// integrated back on output (`root.tz`: the figure travels).
    #[serde(default)]
    pub velocity: Vec<String>,
    /// Largest seam excess of a loop (in standard deviations) accepted.
    #[serde(default = "default_seam")]
    pub max_seam_excess: f64,
    /// How each channel is scaled for learning ([`Normalise`]).
    #[serde(default, skip_serializing_if = "Normalise::is_total")]
    pub normalise: Normalise,
    /// Play one segment's loop at a smoothly varying rate set by a control input.
    pub tempo: Option<TempoSection>,
    /// Learn the HOAP-2's walk retargeted from these human trials instead of
    /// the motions themselves: each segment is the robot's steady stride at
    /// the segment's `tempo`, its channels `JOINT.rx` in degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retarget: Option<RetargetSection>,
}

/// `[data.retarget]`: the human walk the robot's gait is retargeted from
/// (`cpg retarget`, docs/hoap2-walk.md), and the retargeting options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetargetSection {
    /// Walking trials (AMC with `data.skeleton`, or BVH) at `data.rate_hz`.
    pub trials: Vec<PathBuf>,
    /// Capture rate of the trials, Hz (the robot's gait is planned at `data.rate_hz`).
    #[serde(default = "default_rate")]
    pub trial_rate_hz: f64,
    /// Steps planned per segment (the steady stride is taken near the end).
    #[serde(default = "default_retarget_steps")]
    pub steps: usize,
    /// The robot's step as a share of the human's at the robot's leg length.
    #[serde(default = "default_step_scale")]
    pub step_scale: f64,
    /// The swing lift as a share of the human's at the robot's leg length.
    #[serde(default = "default_lift_scale")]
    pub lift_scale: f64,
    /// The arms' swing as a share of the human's.
    #[serde(default = "default_one")]
    pub arm_scale: f64,
    /// The share of a step on both feet (default: the human's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub double_support_share: Option<f64>,
    /// Strides of the steady walk repeated to make each segment's motion.
    #[serde(default = "default_retarget_strides")]
    pub strides: usize,
    /// The trials' skeleton profile file (`cpg_mocap::profile`; default:
    /// the built-in profile their skeleton fits, CMU's ASF or BVH).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<PathBuf>,
}

/// `[[data.segments]]`: one motion file (or a part of it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SegmentSection {
    /// The motion file: AMC (with `data.skeleton`) or BVH (none with `[data.retarget]`).
    #[serde(default, skip_serializing_if = "is_empty_path")]
    pub motion: PathBuf,
    /// Control values held during this segment, one per control input.
    #[serde(default)]
    pub controls: Vec<f64>,
    /// Frame range `[start, end)`, 0-based (default: all).
    pub frames: Option<[usize; 2]>,
    /// A name for reports (default: the file name).
    pub label: Option<String>,
    /// With `[data.retarget]`: the walk's tempo (1: the person's stride
    /// period; 1.2: strides 1.2 times as fast, steps as long).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tempo: Option<f64>,
    /// A standing posture, not a rhythm: the segment is learnt as one
    /// posture the generator holds still (a fixed point). With
    /// `[data.retarget]`, the robot's standing pose the walk starts from (no
    /// tempo); otherwise the mean frame of the motion (or of `frames`),
    /// with a skeleton and `root.ty` among the channels put on the floor
    /// the other segments' feet walk on ([`crate::measure::floors`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub stand: bool,
    /// Segments of one group are trials of one gait and one teacher (what
    /// training loops, validation visits and evaluation judges): the average
    /// of their loops, each time-normalised to the group's median period and
    /// aligned in phase with the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<String>,
    /// With `stand`: the posture is a frame of the named rhythm (a group's or
    /// a segment's label), the one where both feet are lowest (double
    /// support), and the training blends into and out of it are time-warped:
    /// the rhythm's pace grows from 0 out of that frame and falls back to 0
    /// onto it, the motion as recorded, only slower (no amplitude blend, so no
    /// foot is dragged along the floor).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stand_from: Option<String>,
}

/// `[data.tempo]`: the loop played at a rate `u(t)` that drifts smoothly
/// between knots; the control input named `control` carries `u`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TempoSection {
    /// The control input that carries the rate.
    pub control: String,
    /// Lowest and highest rate (1: as recorded).
    pub range: [f64; 2],
    /// Samples between random knots of the rate.
    #[serde(default = "default_knot_every")]
    pub knot_every: usize,
    /// Training samples.
    pub samples: usize,
    /// Seed of the knots.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Rates at which the model is judged (its teachers).
    pub teachers: Vec<f64>,
}

/// `[training]`: washout, the penalty grid and how candidates are validated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingSection {
    /// Teacher-forced steps discarded before regression.
    #[serde(default = "default_washout")]
    pub washout: usize,
    /// Length of the validation free run, samples (the `nmse` score).
    #[serde(default = "default_validation")]
    pub validation_samples: usize,
    /// Variance of the state noise during validation.
    #[serde(default = "default_noise")]
    pub noise_variance: f64,
    /// Noise realisations per candidate.
    #[serde(default = "default_draws")]
    pub noise_draws: usize,
    /// Seed of the validation noise.
    #[serde(default = "default_seed")]
    pub noise_seed: u64,
    /// Penalties `10^start, 10^(start−step), …, 10^stop`.
    #[serde(default = "default_penalties")]
    pub penalty_log10: PenaltyRange,
    /// `nmse` (the paper's) or `orbit` (ours).
    #[serde(default)]
    pub score: ScoreKind,
    /// Standard deviation of noise on the fed-back teacher while harvesting (normalised units; 0: none).
    #[serde(default)]
    pub teacher_noise: f64,
    /// Take the largest penalty scoring within this fraction of the best (0: the best).
    #[serde(default)]
    pub prefer_larger_within: f64,
    /// Settings of the `orbit` score.
    pub orbit: Option<OrbitSection>,
    /// How the readout is learnt.
    #[serde(default)]
    pub trainer: Trainer,
    /// FORCE's settings (with `trainer = "force"`).
    #[serde(default)]
    pub force: cpg_reservoir::ForceSettings,
    /// Rounds of ridge training on the network's own output (none by default).
    #[serde(default)]
    pub self_fed: cpg_reservoir::SelfFed,
}

/// How the readout is learnt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trainer {
    /// Batch ridge regression on the teacher-forced states, every penalty of
    /// `penalty_log10` validated (the paper's).
    #[default]
    Ridge,
    /// FORCE (Sussillo & Abbott 2009): recursive least squares online while
    /// the network runs on its own fed-back output; `penalty_log10` is the
    /// grid of α (the inverse correlation starts at I / α), each validated.
    Force,
}

impl Default for TrainingSection {
    fn default() -> Self {
        TrainingSection {
            washout: default_washout(),
            validation_samples: default_validation(),
            noise_variance: default_noise(),
            noise_draws: default_draws(),
            noise_seed: default_seed(),
            penalty_log10: default_penalties(),
            score: ScoreKind::default(),
            teacher_noise: 0.0,
            prefer_larger_within: 0.0,
            orbit: None,
            trainer: Trainer::default(),
            force: cpg_reservoir::ForceSettings::default(),
            self_fed: cpg_reservoir::SelfFed::default(),
        }
    }
}

/// A log-spaced penalty grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, expecting = "a table {start, step, stop}, e.g. { start = 1, step = 0.1, stop = -8 }")]
pub struct PenaltyRange {
    /// log10 of the first penalty.
    pub start: f64,
    /// Step between log10 values (> 0).
    pub step: f64,
    /// log10 of the last penalty.
    pub stop: f64,
}

/// `[training.orbit]`: the validation run visits each teacher's control
/// setting in turn and scores how close it stays to that teacher's orbit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitSection {
    /// Seconds each setting is held.
    #[serde(default = "default_stay")]
    pub stay_s: f64,
    /// Seconds of cosine ramp from one setting to the next.
    #[serde(default = "default_ramp")]
    pub ramp_s: f64,
    /// Scoring starts this long after a setting is reached, seconds.
    #[serde(default = "default_settle")]
    pub settle_s: f64,
    /// Teachers visited, by index (default: all, in order); with `rates`,
    /// indices into `rates`.
    pub sequence: Option<Vec<usize>>,
    /// With `[data.tempo]`: the rates the validation run visits instead of
    /// the model's teachers (so that it need not hold any rate a test holds).
    pub rates: Option<Vec<f64>>,
    /// A push during the first stay.
    pub push: Option<PushSection>,
}

/// The paper's perturbation: the fed-back output held at an outlier.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PushSection {
    /// When the hold starts, seconds.
    #[serde(default = "default_push_at")]
    pub at_s: f64,
    /// How long the output is held, seconds.
    #[serde(default = "default_push_hold")]
    pub hold_s: f64,
    /// The held value: the teacher cycle's maximum plus this many standard deviations.
    #[serde(default = "default_push_above")]
    pub above_max: f64,
}

impl PushSection {
    /// Checks the ranges: a start within an hour, a hold within a minute, a finite height.
    fn check(&self) -> std::result::Result<(), String> {
        if !(self.at_s.is_finite() && (0.0..=3600.0).contains(&self.at_s)) {
            return Err(format!("at_s = {}; expected 0 to 3600 s", self.at_s));
        }
        if !(self.hold_s.is_finite() && (0.0..=60.0).contains(&self.hold_s)) {
            return Err(format!("hold_s = {}; expected 0 to 60 s", self.hold_s));
        }
        if !(self.above_max.is_finite() && self.above_max.abs() <= 100.0) {
            return Err(format!("above_max = {}; expected -100 to 100 standard deviations", self.above_max));
        }
        Ok(())
    }
}

impl ExperimentSection {
    /// The E6 test, if this is one.
    pub fn coupling(&self) -> Option<&CouplingTestSection> {
        if let ExperimentTest::Coupling(k) = &self.test { Some(k) } else { None }
    }

    /// Bounds every count and duration of the test protocol: (field, message) on failure.
    fn check(&self) -> std::result::Result<(), (String, String)> {
        let fail = |f: &str, m: String| Err((format!("experiment.{f}"), m));
        if !(1..=1000).contains(&self.seeds) {
            return fail("seeds", format!("{}; expected 1 to 1000", self.seeds));
        }
        if !(1..=1000).contains(&self.quick_seeds) {
            return fail("quick_seeds", format!("{}; expected 1 to 1000", self.quick_seeds));
        }
        self.test.check()
    }
}

impl Default for PushSection {
    fn default() -> Self {
        PushSection { at_s: default_push_at(), hold_s: default_push_hold(), above_max: default_push_above() }
    }
}

/// `[output]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSection {
    /// The model file to write.
    pub model: PathBuf,
}

/// `experiment.protocol`: whose protocol a configuration follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// The paper's.
    Paper,
    /// Ours: the paper's mechanism with our validation and training choices.
    Ours,
    /// An extension of the paper's mechanism.
    Extension,
    /// A variant tried.
    Tried,
}

impl Protocol {
    /// The name a configuration file writes.
    pub fn as_str(self) -> &'static str {
        match self {
            Protocol::Paper => "paper",
            Protocol::Ours => "ours",
            Protocol::Extension => "extension",
            Protocol::Tried => "tried",
        }
    }
}

impl std::str::FromStr for Protocol {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Protocol, String> {
        [Protocol::Paper, Protocol::Ours, Protocol::Extension, Protocol::Tried]
            .into_iter()
            .find(|p| p.as_str() == s)
            .ok_or_else(|| format!("'{s}'; valid: paper, ours, extension, tried"))
    }
}

impl std::fmt::Display for Protocol {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// `data.normalise`: the standard deviation each channel is divided by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Normalise {
    /// The paper's: its standard deviation over all the data.
    #[default]
    Total,
    /// Its standard deviation within each segment, pooled (each segment's
    /// own mean taken out): a channel whose mean differs between gaits (a
    /// hand held higher in a walk than in a run) is scaled by its rhythm,
    /// not by the gap, so every channel's rhythm weighs alike in the
    /// regression, its penalty and the teacher's noise.
    Rhythm,
}

impl Normalise {
    /// The paper's scaling.
    pub fn is_total(&self) -> bool {
        *self == Normalise::Total
    }
}

/// `training.score`: how a penalty is validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScoreKind {
    /// The paper's: the NMSE of a noisy free run against the teacher.
    #[default]
    Nmse,
    /// Ours: the distance of a free run to each teacher's orbit ([`OrbitSection`]).
    Orbit,
}

impl ScoreKind {
    /// The name a configuration file writes.
    pub fn as_str(self) -> &'static str {
        match self {
            ScoreKind::Nmse => "nmse",
            ScoreKind::Orbit => "orbit",
        }
    }
}

impl std::str::FromStr for ScoreKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<ScoreKind, String> {
        [ScoreKind::Nmse, ScoreKind::Orbit]
            .into_iter()
            .find(|k| k.as_str() == s)
            .ok_or_else(|| format!("'{s}'; valid: nmse (the paper's), orbit"))
    }
}

impl std::fmt::Display for ScoreKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// `[experiment]`: the test protocol the report runs on this configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSection {
    /// Short name (`E1`).
    pub id: String,
    /// Title for the report.
    pub title: String,
    /// `paper`, `ours`, `extension` or `tried`.
    pub protocol: Protocol,
    /// One line on what this configuration tries (for the report's table of what was tried).
    pub method: Option<String>,
    /// The configuration of the same experiment with the paper's protocol,
    /// which the report compares this one with (what differs, setting by setting).
    pub paper_config: Option<PathBuf>,
    /// Reservoir seeds `seed, seed + 1, …` tried.
    #[serde(default = "default_seeds")]
    pub seeds: u64,
    /// Seeds in a quick run.
    #[serde(default = "default_quick_seeds")]
    pub quick_seeds: u64,
    /// The test the experiment runs: one table named by its kind.
    pub test: ExperimentTest,
    /// Quantities chosen outside validation (by hand or by a search) and
    /// what they were chosen on: each is compared with the test's conditions
    /// as validation's are.
    #[serde(default)]
    pub tuned: Vec<TunedSection>,
}

/// `[[experiment.tuned]]`: a quantity chosen outside validation, and where.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TunedSection {
    /// What was chosen, as the configuration names it (`reservoir.inputs`, `experiment.test.walking.gains`).
    pub key: String,
    /// How it was chosen, in words (`searched on Optuna, docs/hoap2-walk.md`).
    pub how: String,
    /// The reservoir seeds whose runs the choice was made on (empty: none named).
    #[serde(default)]
    pub seeds: Vec<u64>,
    /// Physics runs the choice was made on (a walking search): their length, seconds.
    pub run_s: Option<f64>,
    /// Their pushes: every how many seconds (with `push_mps`).
    pub push_every_s: Option<f64>,
    /// Their pushes' change of the trunk's velocity, m/s.
    pub push_mps: Option<f64>,
    /// Their tempo change half-way (a factor), with a ramp of `tempo_ramp_s`.
    pub tempo: Option<f64>,
    /// The tempo change's ramp, seconds.
    pub tempo_ramp_s: Option<f64>,
}

/// `[experiment.test.KIND]`: the test an experiment runs, one kind per
/// configuration. A new kind is a variant here, its section type and its
/// module in `experiment`; the compiler points to every place that
/// dispatches over the kinds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ExperimentTest {
    /// E1–E3: long free run and perturbation.
    Stability(StabilitySection),
    /// E4: frequency modulation.
    Frequency(FrequencySection),
    /// E5: gait switching.
    Gaits(GaitsSection),
    /// E6: phase coupling of many outputs.
    Coupling(CouplingTestSection),
    /// Walking in physics: the HOAP-2 in MuJoCo on the configuration's CPG.
    Walking(WalkingSection),
    /// The whole body: standing, walking and running in one generator,
    /// judged against trials training never read.
    WholeBody(WholeBodySection),
}

impl ExperimentTest {
    /// The kind's name, as the file writes it (`stability`).
    pub fn kind(&self) -> &'static str {
        match self {
            ExperimentTest::Stability(_) => "stability",
            ExperimentTest::Frequency(_) => "frequency",
            ExperimentTest::Gaits(_) => "gaits",
            ExperimentTest::Coupling(_) => "coupling",
            ExperimentTest::Walking(_) => "walking",
            ExperimentTest::WholeBody(_) => "whole_body",
        }
    }

    /// Checks the kind's settings; an error names the key below `experiment.test.KIND`.
    fn check(&self) -> std::result::Result<(), (String, String)> {
        match self {
            ExperimentTest::Stability(t) => t.check(),
            ExperimentTest::Frequency(t) => t.check(),
            ExperimentTest::Gaits(t) => t.check(),
            ExperimentTest::Coupling(t) => t.check(),
            ExperimentTest::Walking(t) => t.check(),
            ExperimentTest::WholeBody(t) => t.check(),
        }
        .map_err(|(k, m)| (format!("experiment.test.{}.{k}", self.kind()), m))
    }

    /// The paths the test names (a robot's files, the walking's gains).
    fn paths_mut(&mut self) -> Vec<&mut PathBuf> {
        fn robot(r: Option<&mut RobotSection>) -> Vec<&mut PathBuf> {
            r.map(|r| vec![&mut r.urdf, &mut r.map]).unwrap_or_default()
        }
        match self {
            ExperimentTest::Stability(_) | ExperimentTest::Frequency(_) => Vec::new(),
            ExperimentTest::Gaits(t) => robot(t.robot.as_mut()),
            ExperimentTest::Coupling(t) => robot(t.robot.as_mut()),
            ExperimentTest::Walking(t) => {
                let mut v = vec![&mut t.gains];
                v.extend(t.copy_config.as_mut());
                v
            }
            ExperimentTest::WholeBody(t) => {
                let mut v: Vec<&mut PathBuf> = t.held_out.iter_mut().flat_map(|h| h.motions.iter_mut()).collect();
                v.extend(robot(t.robot.as_mut()));
                v
            }
        }
    }
}

/// The longest run a test asks for, seconds (a day).
const DAY_S: f64 = 86_400.0;

/// `v` within `lo..=hi` seconds, or the error for key `k`.
fn seconds_within(k: &str, v: f64, lo: f64, hi: f64) -> std::result::Result<(), (String, String)> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err((k.to_owned(), format!("{v}; expected {lo} to {hi} s")))
    }
}

/// `[experiment.test.stability]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StabilitySection {
    /// Length of the long free run, seconds.
    #[serde(default = "default_long")]
    pub long_run_s: f64,
    /// The same in a quick run.
    #[serde(default = "default_quick_long")]
    pub quick_long_run_s: f64,
    /// Samples of the first free-run window compared step by step with the teacher.
    #[serde(default = "default_first")]
    pub first_samples: usize,
    /// The perturbation.
    #[serde(default)]
    pub push: PushSection,
}

impl StabilitySection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        seconds_within("long_run_s", self.long_run_s, 1.0, DAY_S)?;
        seconds_within("quick_long_run_s", self.quick_long_run_s, 1.0, DAY_S)?;
        if !(1..=MAX_TRAINING_SAMPLES).contains(&self.first_samples) {
            return Err(("first_samples".into(), format!("{}; expected 1 to 2000000", self.first_samples)));
        }
        self.push.check().map_err(|m| ("push".to_owned(), m))
    }
}

/// `[experiment.test.frequency]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrequencySection {
    /// Control values held one after the other.
    pub plateaus: Vec<f64>,
    /// Seconds each plateau is held.
    #[serde(default = "default_plateau_hold")]
    pub hold_s: f64,
    /// Seconds of cosine ramp between plateaus.
    #[serde(default = "default_plateau_ramp")]
    pub ramp_s: f64,
    /// The paper's Fig. 3 test: `[time_s, value]` knots joined by cosine ramps.
    pub figure: Vec<[f64; 2]>,
}

impl FrequencySection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        if self.plateaus.is_empty() || self.plateaus.len() > 1000 || self.plateaus.iter().any(|v| !v.is_finite()) {
            return Err(("plateaus".into(), "needs 1 to 1000 finite values".into()));
        }
        seconds_within("hold_s", self.hold_s, 0.0, 3600.0)?;
        seconds_within("ramp_s", self.ramp_s, 0.0, 3600.0)?;
        if self.figure.len() > 1000 || self.figure.iter().flatten().any(|v| !v.is_finite() || v.abs() > DAY_S) {
            return Err(("figure".into(), "needs at most 1000 finite [time_s, value] knots".into()));
        }
        Ok(())
    }
}

/// `[experiment.test.gaits]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaitsSection {
    /// Times of the two switches (to the second teacher and back), seconds.
    pub switch_at_s: [f64; 2],
    /// Seconds of cosine ramp of a smooth switch.
    #[serde(default = "default_ramp")]
    pub ramp_s: f64,
    /// Length of the test run, seconds.
    pub run_s: f64,
    /// A switch has settled when the output is within this many standard
    /// deviations of the new gait's orbit for a cycle.
    #[serde(default = "default_threshold")]
    pub threshold_sd: f64,
    /// The robot the first seed's smooth switching run is shown on (optional).
    pub robot: Option<RobotSection>,
}

impl GaitsSection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        seconds_within("run_s", self.run_s, 1.0, DAY_S)?;
        seconds_within("ramp_s", self.ramp_s, 0.0, 3600.0)?;
        for (k, t) in self.switch_at_s.iter().enumerate() {
            seconds_within(&format!("switch_at_s[{k}]"), *t, 0.0, self.run_s)?;
        }
        if !(self.threshold_sd.is_finite() && self.threshold_sd > 0.0 && self.threshold_sd <= 100.0) {
            return Err(("threshold_sd".into(), format!("{}; expected above 0 and at most 100", self.threshold_sd)));
        }
        Ok(())
    }
}

/// `[experiment.test.coupling]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingTestSection {
    /// Length of the free run, seconds.
    pub run_s: f64,
    /// The same in a quick run.
    pub quick_run_s: f64,
    /// Reservoir size in a quick run.
    pub quick_neurons: usize,
    /// The channel the others are phased against.
    pub reference: String,
    /// Channels drawn as phase portraits against the reference.
    pub portraits: Vec<String>,
    /// The robot the generated joints are mapped onto (optional).
    pub robot: Option<RobotSection>,
}

impl CouplingTestSection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        seconds_within("run_s", self.run_s, 1.0, DAY_S)?;
        seconds_within("quick_run_s", self.quick_run_s, 1.0, DAY_S)?;
        if !(1..=cpg_reservoir::MAX_NEURONS).contains(&self.quick_neurons) {
            return Err((
                "quick_neurons".into(),
                format!("{}; expected 1 to {}", self.quick_neurons, cpg_reservoir::MAX_NEURONS),
            ));
        }
        Ok(())
    }
}

/// `[experiment.test.walking]`: the HOAP-2 in MuJoCo (the Python package's
/// simulator, `python -m cpg.walk_eval`) driven by the configuration's CPG,
/// one model per seed, from the walk `[data.retarget]` plans; beside it the
/// paper's joint-angle copy and the planned walk played open loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WalkingSection {
    /// Seconds of each simulated run.
    #[serde(default = "default_walk_s")]
    pub run_s: f64,
    /// The same in a quick run.
    #[serde(default = "default_quick_walk_s")]
    pub quick_run_s: f64,
    /// Seconds between pushes.
    #[serde(default = "default_push_every_s")]
    pub push_every_s: f64,
    /// Each push's change of the trunk's velocity, m/s (over 0.1 s).
    #[serde(default = "default_push_mps")]
    pub push_mps: f64,
    /// The tempo change half-way through the third run (a factor on the tempo input).
    #[serde(default = "default_walk_tempo")]
    pub tempo: f64,
    /// Seconds of the cosine ramp of the tempo change.
    #[serde(default = "default_tempo_ramp_s")]
    pub tempo_ramp_s: f64,
    /// Seconds of the cosine ramp of the stop (a model with a `u_walk` input
    /// told to stop half-way through a fourth run).
    #[serde(default = "default_stop_ramp_s")]
    pub stop_ramp_s: f64,
    /// Seconds of each CPG's free run at each tempo it was taught, judged as every model is.
    #[serde(default = "default_long")]
    pub judge_s: f64,
    /// The same in a quick run.
    #[serde(default = "default_quick_long")]
    pub quick_judge_s: f64,
    /// Steps of the planned walk the runs start from (the CPG takes over at its 10th left touch-down).
    #[serde(default = "default_start_steps")]
    pub start_steps: usize,
    /// The balance feedback's gains (JSON of `cpg.sim.Gains`, found by `python -m cpg.sim_search`).
    pub gains: PathBuf,
    /// The paper's protocol beside it: a configuration whose channels the HOAP-2 map copies onto the robot.
    pub copy_config: Option<PathBuf>,
}

fn default_walk_s() -> f64 {
    60.0
}
fn default_quick_walk_s() -> f64 {
    20.0
}
fn default_push_every_s() -> f64 {
    5.0
}
fn default_push_mps() -> f64 {
    0.2
}
fn default_walk_tempo() -> f64 {
    1.1
}
fn default_tempo_ramp_s() -> f64 {
    3.0
}
fn default_stop_ramp_s() -> f64 {
    3.0
}
fn default_start_steps() -> usize {
    110
}

impl WalkingSection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        seconds_within("run_s", self.run_s, 1.0, DAY_S)?;
        seconds_within("quick_run_s", self.quick_run_s, 1.0, DAY_S)?;
        seconds_within("push_every_s", self.push_every_s, 0.5, 3600.0)?;
        if !(self.push_mps.is_finite() && (0.0..=5.0).contains(&self.push_mps)) {
            return Err(("push_mps".into(), format!("{}; expected 0 to 5 m/s", self.push_mps)));
        }
        if !(self.tempo.is_finite() && (0.5..=2.0).contains(&self.tempo)) {
            return Err(("tempo".into(), format!("{}; expected 0.5 to 2", self.tempo)));
        }
        seconds_within("tempo_ramp_s", self.tempo_ramp_s, 0.0, 60.0)?;
        seconds_within("stop_ramp_s", self.stop_ramp_s, 0.0, 60.0)?;
        seconds_within("judge_s", self.judge_s, 10.0, DAY_S)?;
        seconds_within("quick_judge_s", self.quick_judge_s, 10.0, DAY_S)?;
        if !(12..=MAX_RETARGET_STEPS).contains(&self.start_steps) {
            return Err(("start_steps".into(), format!("{}; expected 12 to {MAX_RETARGET_STEPS}", self.start_steps)));
        }
        Ok(())
    }
}

/// `[experiment.test.whole_body]`: one generator that stands, walks and runs,
/// selected by its control inputs; each gait judged against recorded trials
/// that training never read, the states switched in one free run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WholeBodySection {
    /// Seconds of each state's free run with its inputs held.
    #[serde(default = "default_long")]
    pub run_s: f64,
    /// The same in a quick run.
    #[serde(default = "default_quick_body_s")]
    pub quick_run_s: f64,
    /// The last seconds of the standing run over which every channel must stay within 1° of the posture.
    #[serde(default = "default_stand_s")]
    pub stand_s: f64,
    /// Per gait (a teacher's label), the trials it is judged against.
    pub held_out: Vec<HeldOutSection>,
    /// The switching run: the teachers visited in turn (indices, a group counting once).
    pub sequence: Vec<usize>,
    /// Seconds each state of the switching run is held.
    pub stay_s: f64,
    /// Seconds of the cosine ramp of the inputs at each switch.
    pub ramp_s: f64,
    /// The robot the switching run is shown on (optional).
    pub robot: Option<RobotSection>,
}

/// Trials of one gait that training never read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeldOutSection {
    /// The teacher they judge (its label: a group's name).
    pub teacher: String,
    /// The trials (AMC with `data.skeleton`, at `data.rate_hz`).
    pub motions: Vec<PathBuf>,
}

fn default_quick_body_s() -> f64 {
    90.0
}
fn default_stand_s() -> f64 {
    60.0
}

/// Most held-out trials of one gait.
pub const MAX_HELD_OUT: usize = 100;

impl WholeBodySection {
    fn check(&self) -> std::result::Result<(), (String, String)> {
        seconds_within("run_s", self.run_s, 20.0, DAY_S)?;
        seconds_within("quick_run_s", self.quick_run_s, 20.0, DAY_S)?;
        seconds_within("stand_s", self.stand_s, 1.0, self.quick_run_s.min(self.run_s))?;
        seconds_within("stay_s", self.stay_s, 1.0, 3600.0)?;
        seconds_within("ramp_s", self.ramp_s, 0.0, self.stay_s)?;
        if self.held_out.is_empty() || self.held_out.len() > 100 {
            return Err(("held_out".into(), format!("{} gaits; expected 1 to 100", self.held_out.len())));
        }
        for (k, h) in self.held_out.iter().enumerate() {
            if !(2..=MAX_HELD_OUT).contains(&h.motions.len()) {
                return Err((
                    format!("held_out[{k}].motions"),
                    format!(
                        "{} trials; expected 2 to {MAX_HELD_OUT} (their spread among themselves is the yardstick)",
                        h.motions.len()
                    ),
                ));
            }
        }
        if !(2..=100).contains(&self.sequence.len()) {
            return Err(("sequence".into(), format!("{} states; expected 2 to 100", self.sequence.len())));
        }
        Ok(())
    }
}

/// A robot description and the channel map onto its joints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSection {
    /// The URDF file.
    pub urdf: PathBuf,
    /// The channel-to-joint map (TSV).
    pub map: PathBuf,
}

fn default_rate() -> f64 {
    120.0
}
fn is_empty_path(p: &Path) -> bool {
    p.as_os_str().is_empty()
}

fn default_retarget_steps() -> usize {
    20
}

fn default_retarget_strides() -> usize {
    4
}

fn default_step_scale() -> f64 {
    0.2
}

fn default_lift_scale() -> f64 {
    0.4
}

fn default_one() -> f64 {
    1.0
}

fn default_cycles() -> usize {
    1
}
fn default_samples() -> usize {
    2200
}
fn default_repeats() -> usize {
    1
}
fn default_period() -> [f64; 2] {
    [0.3, 2.5]
}
fn default_seam() -> f64 {
    0.5
}
fn default_knot_every() -> usize {
    700
}
fn default_seed() -> u64 {
    1
}
fn default_washout() -> usize {
    200
}
fn default_validation() -> usize {
    500
}
fn default_noise() -> f64 {
    1e-3
}
fn default_draws() -> usize {
    5
}
fn default_penalties() -> PenaltyRange {
    PenaltyRange { start: 1.0, step: 0.1, stop: -8.0 }
}
fn default_stay() -> f64 {
    10.0
}
fn default_ramp() -> f64 {
    1.0
}
fn default_settle() -> f64 {
    6.5
}
fn default_push_at() -> f64 {
    2.0
}
fn default_push_hold() -> f64 {
    0.05
}
fn default_push_above() -> f64 {
    2.0
}
fn default_seeds() -> u64 {
    10
}
fn default_quick_seeds() -> u64 {
    3
}
fn default_long() -> f64 {
    900.0
}
fn default_quick_long() -> f64 {
    200.0
}
fn default_first() -> usize {
    500
}
fn default_plateau_hold() -> f64 {
    8.0
}
fn default_plateau_ramp() -> f64 {
    2.0
}
fn default_threshold() -> f64 {
    0.25
}

/// `path` relative to `dir`, through `..` where needed; both are made absolute first.
pub fn relative_to(path: &Path, dir: &Path) -> PathBuf {
    let abs = |p: &Path| std::path::absolute(p).map(|a| cpg_io::lexical(&a)).unwrap_or_else(|_| p.to_owned());
    let (p, d) = (abs(path), abs(dir));
    let (pc, dc): (Vec<_>, Vec<_>) = (p.components().collect(), d.components().collect());
    let common = pc.iter().zip(&dc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return p;
    }
    let mut out = PathBuf::new();
    for _ in common..dc.len() {
        out.push("..");
    }
    for c in &pc[common..] {
        out.push(c);
    }
    out
}

/// The directory relative paths in `path` are resolved against.
pub(crate) fn base_dir(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// Reads a configuration file: bounded in size, UTF-8.
pub(crate) fn read_text(path: &Path) -> Result<String> {
    let bad = |message: String| Error::Config { file: path.to_owned(), line: None, field: String::new(), message };
    // Bounded whatever the metadata says: /dev/zero reports a length of 0.
    let bytes = cpg_io::read_bounded(path, MAX_CONFIG_BYTES as u64).map_err(|e| match e {
        cpg_io::Error::Io { path, source } => Error::Io { path, source },
        cpg_io::Error::TooLarge { .. } => {
            bad(format!("larger than {MAX_CONFIG_BYTES} bytes, the most a configuration has"))
        }
        other => bad(other.to_string()),
    })?;
    let text = String::from_utf8(bytes)
        .map_err(|e| bad(format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to())))?;
    // A byte-order mark (some Windows editors write one) is not part of the TOML.
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_owned(),
        None => text,
    })
}

/// Deserialises TOML text into `T`; errors name the field path and the line.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, file: &Path) -> Result<T> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let bad = |line: Option<usize>, field: String, message: String| Error::Config {
        file: file.to_owned(),
        line,
        field,
        message,
    };
    let de = toml::de::Deserializer::parse(text)
        .map_err(|e| bad(e.span().map(|s| line_of(text, s.start)), String::new(), e.message().to_owned()))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = e.path().to_string();
        let inner = e.into_inner();
        let line = inner.span().map(|s| line_of(text, s.start));
        bad(line, if field == "." { String::new() } else { field }, inner.message().to_owned())
    })
}

/// Line (1-based) of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

impl DataSection {
    /// The segments the model's teachers come from, in the teachers' order:
    /// each segment without a `group`, and each group at its first segment
    /// (the group's trials are one teacher). The one reading of "teacher k"
    /// for training, validation's layout and the report.
    pub fn teacher_segments(&self) -> Vec<usize> {
        (0..self.segments.len())
            .filter(|&i| match &self.segments[i].group {
                None => true,
                Some(g) => !self.segments[..i].iter().any(|x| x.group.as_ref() == Some(g)),
            })
            .collect()
    }

    /// Checks the `[data.retarget]` section against the segments.
    fn check_retarget(&self) -> std::result::Result<(), (String, String)> {
        let bad = |f: String, m: &str| Err((f, m.to_owned()));
        let Some(r) = &self.retarget else {
            for (k, s) in self.segments.iter().enumerate() {
                if s.motion.as_os_str().is_empty() {
                    return bad(format!("data.segments[{k}].motion"), "is missing: name an AMC or BVH file");
                }
                if s.tempo.is_some() {
                    return bad(format!("data.segments[{k}].tempo"), "is used only with [data.retarget]");
                }
            }
            if self.tempo.is_some() && self.segments.iter().any(|s| s.stand) {
                return bad("data.tempo".into(), "plays a rhythm; a standing segment (stand = true) has none");
            }
            return Ok(());
        };
        if r.trials.is_empty() || r.trials.len() > MAX_SEGMENTS {
            return bad("data.retarget.trials".into(), &format!("needs 1 to {MAX_SEGMENTS} walking trials"));
        }
        if self.tempo.is_some() {
            return bad("data.tempo".into(), "cannot be combined with [data.retarget] (give each segment a tempo)");
        }
        if !(r.trial_rate_hz.is_finite() && (1.0..=10_000.0).contains(&r.trial_rate_hz)) {
            return bad("data.retarget.trial_rate_hz".into(), "expected 1 to 10000 Hz");
        }
        if !(6..=MAX_RETARGET_STEPS).contains(&r.steps) {
            return bad("data.retarget.steps".into(), &format!("{}; expected 6 to {MAX_RETARGET_STEPS}", r.steps));
        }
        if !(1..=50).contains(&r.strides) {
            return bad("data.retarget.strides".into(), &format!("{}; expected 1 to 50", r.strides));
        }
        for (k, s) in self.segments.iter().enumerate() {
            if !s.motion.as_os_str().is_empty() {
                return bad(
                    format!("data.segments[{k}].motion"),
                    "is given, but with [data.retarget] a segment is the robot's walk: give its tempo instead",
                );
            }
            match s.tempo {
                Some(_) if s.stand => {
                    return bad(
                        format!("data.segments[{k}].tempo"),
                        "is given, but a standing segment (stand = true) has no tempo",
                    );
                }
                None if s.stand => {}
                Some(t) if t.is_finite() && (MIN_TEMPO..=MAX_TEMPO).contains(&t) => {}
                Some(t) => {
                    return bad(
                        format!("data.segments[{k}].tempo"),
                        &format!("{t}; expected {MIN_TEMPO} to {MAX_TEMPO} (1: the person's stride period)"),
                    );
                }
                None => return bad(format!("data.segments[{k}].tempo"), "is missing (1: the person's stride period)"),
            }
        }
        Ok(())
    }
}

/// The most steps `[data.retarget]` plans per segment.
pub const MAX_RETARGET_STEPS: usize = 400;

impl Config {
    /// An error about `field` of this configuration.
    pub fn error(&self, field: &str, message: impl Into<String>) -> Error {
        Error::Config { file: self.source.clone(), line: None, field: field.to_owned(), message: message.into() }
    }

    /// Parses configuration text. `file` names it in errors; relative paths
    /// are resolved against `base` (the file's directory).
    pub fn from_toml(text: &str, file: &Path, base: &Path) -> Result<Config> {
        let mut c: Config = parse_toml(text, file)?;
        let fix = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = base.join(&*p);
            }
        };
        c.source = file.to_owned();
        c.paths_mut().into_iter().for_each(fix);
        c.check(file)?;
        Ok(c)
    }

    /// Every path of the configuration (resolved against the file's
    /// directory when read, written relative to the new one).
    fn paths_mut(&mut self) -> Vec<&mut PathBuf> {
        let mut out: Vec<&mut PathBuf> = Vec::new();
        out.extend(self.data.skeleton.as_mut());
        out.push(&mut self.output.model);
        out.extend(self.data.segments.iter_mut().map(|s| &mut s.motion).filter(|m| !m.as_os_str().is_empty()));
        if let Some(r) = self.data.retarget.as_mut() {
            out.extend(r.trials.iter_mut());
            out.extend(r.profile.as_mut());
        }
        if let Some(e) = self.experiment.as_mut() {
            out.extend(e.paper_config.as_mut());
            out.extend(e.test.paths_mut());
        }
        out
    }

    /// The configuration as TOML for a file in `dir`: every path is written
    /// relative to `dir` (absolute when it has no common root with it).
    pub fn to_toml(&self, dir: &Path) -> Result<String> {
        let mut c = self.clone();
        for p in c.paths_mut() {
            *p = relative_to(p, dir);
        }
        toml::to_string(&c).map_err(|e| self.error("", format!("cannot be written as TOML: {e}")))
    }

    /// Reads and checks a configuration file; relative paths are resolved against its directory.
    pub fn load(path: &Path) -> Result<Config> {
        let text = read_text(path)?;
        Config::from_toml(&text, path, base_dir(path))
    }

    /// Checks what serde cannot: lengths that must agree, ranges, names.
    /// Every size taken from the file is bounded here, before any data is
    /// read or allocated.
    fn check(&self, file: &Path) -> Result<()> {
        let bad =
            |(field, message): (String, String)| Error::Config { file: file.to_owned(), line: None, field, message };
        self.data.check().map_err(bad)?;
        self.training.check_sizes().map_err(bad)?;
        self.data.check_tempo().map_err(bad)?;
        // The reservoir's own checks, before any data is read (one output
        // stands for the data's; their count is checked when they are known).
        self.reservoir
            .resolve(1, &self.data.controls)
            .and_then(|r| r.check())
            .map_err(|e| bad((format!("reservoir.{}", e.field), format!("{}; {}", e.value, e.expected))))?;
        self.training.check(self.data.tempo.is_some()).map_err(bad)?;
        if let Some(e) = &self.experiment {
            e.check().map_err(bad)?;
        }
        Ok(())
    }
}

/// A check's failure: the key as the file writes it, and what is wrong.
type Failure = (String, String);

fn fail<T>(field: &str, message: impl Into<String>) -> std::result::Result<T, Failure> {
    Err((field.to_owned(), message.into()))
}

/// `v` within `lo..=hi`, or the failure of key `field`.
fn count_within(field: &str, v: usize, lo: usize, hi: usize) -> std::result::Result<(), Failure> {
    if (lo..=hi).contains(&v) { Ok(()) } else { fail(field, format!("{v}; expected {lo} to {hi}")) }
}

impl DataSection {
    /// The channels, segments, rates, controls and sizes of `[data]`.
    fn check(&self) -> std::result::Result<(), Failure> {
        let d = self;
        if d.channels.is_empty() {
            return fail("data.channels", "is empty; name at least one channel such as \"lfemur.rx\"");
        }
        if d.segments.is_empty() {
            return fail("data.segments", "needs at least one [[data.segments]] with a motion file");
        }
        let (lo_hz, hi_hz) = (cpg_reservoir::MIN_SAMPLE_RATE_HZ, cpg_reservoir::MAX_SAMPLE_RATE_HZ);
        if !(d.rate_hz.is_finite() && (lo_hz..=hi_hz).contains(&d.rate_hz)) {
            return fail("data.rate_hz", format!("{}; expected {lo_hz} to {hi_hz} Hz", d.rate_hz));
        }
        for (k, name) in d.controls.iter().enumerate() {
            if name.is_empty() || name.chars().any(|c| c == ',' || c == '=' || c.is_whitespace() || c.is_control()) {
                return fail(
                    &format!("data.controls[{k}]"),
                    format!("{name:?}: a control name is a non-empty word without commas, '=' or spaces"),
                );
            }
            if d.controls[..k].contains(name) {
                return fail(&format!("data.controls[{k}]"), format!("'{name}' is named twice"));
            }
        }
        if let Some(u) = d.bvh_unit_mm
            && !(u.is_finite() && (1e-6..=1e6).contains(&u))
        {
            return fail("data.bvh_unit_mm", format!("{u}; expected 1e-6 to 1e6 mm per BVH length unit"));
        }
        d.check_retarget()?;
        d.check_segment_controls()?;
        let [lo, hi] = d.period_s;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo < hi && hi <= 60.0) {
            return fail("data.period_s", format!("[{lo}, {hi}]; expected 0 < shortest < longest <= 60 s"));
        }
        if !(d.morph_s.is_finite() && (0.0..=10.0).contains(&d.morph_s)) {
            return fail("data.morph_s", format!("{}; expected 0 to 10 s", d.morph_s));
        }
        if !(d.max_seam_excess.is_finite() && d.max_seam_excess >= 0.0) {
            return fail("data.max_seam_excess", format!("{}; expected a number >= 0", d.max_seam_excess));
        }
        d.check_sizes()
    }

    /// Each segment's control values: one per control input (none with a tempo), finite.
    fn check_segment_controls(&self) -> std::result::Result<(), Failure> {
        let d = self;
        let tempo = d.tempo.is_some();
        for (k, s) in d.segments.iter().enumerate() {
            let expected = if tempo { 0 } else { d.controls.len() };
            if s.controls.len() != expected {
                return fail(
                    &format!("data.segments[{k}].controls"),
                    format!(
                        "has {} values; {} ({})",
                        s.controls.len(),
                        if tempo {
                            "with [data.tempo] the control comes from the tempo, so give none".to_owned()
                        } else {
                            format!("[data] controls names {}", d.controls.len())
                        },
                        d.controls.join(", ")
                    ),
                );
            }
            if let Some(k2) = s.controls.iter().position(|v| !v.is_finite()) {
                return fail(&format!("data.segments[{k}].controls[{k2}]"), "is not a finite number");
            }
        }
        Ok(())
    }

    /// The counts and the training sequence's length, within [`MAX_TRAINING_SAMPLES`].
    fn check_sizes(&self) -> std::result::Result<(), Failure> {
        let d = self;
        let max_samples = MAX_TRAINING_SAMPLES;
        count_within("data.repeats", d.repeats, 1, 10_000)?;
        count_within("data.loop_cycles", d.loop_cycles, 0, 100)?;
        count_within("data.samples_per_segment", d.samples_per_segment, 1, max_samples)?;
        count_within("data.segments", d.segments.len(), 1, MAX_SEGMENTS)?;
        for (k, s) in d.segments.iter().enumerate() {
            let Some(g) = &s.group else { continue };
            let f = format!("data.segments[{k}].group");
            if s.stand || d.loop_cycles == 0 || d.tempo.is_some() || d.retarget.is_some() {
                return fail(
                    &f,
                    "groups trials of a rhythm: it needs looped motions (loop_cycles >= 1), not a standing segment, [data.tempo] or [data.retarget]",
                );
            }
            if g.trim().is_empty() || g.len() > 100 {
                return fail(&f, "expected a name of 1 to 100 characters");
            }
            let first = d.segments.iter().find(|x| x.group.as_ref() == Some(g)).map(|x| &x.controls);
            if first != Some(&s.controls) {
                return fail(&f, format!("'{g}': every trial of a group holds the same controls"));
            }
        }
        for (k, s) in d.segments.iter().enumerate() {
            let Some(from) = &s.stand_from else { continue };
            let f = format!("data.segments[{k}].stand_from");
            if !s.stand || d.retarget.is_some() {
                return fail(
                    &f,
                    "names the rhythm a standing segment (stand = true) is a frame of; not with [data.retarget]",
                );
            }
            let rhythm = |x: &SegmentSection| {
                !x.stand && (x.group.as_deref() == Some(from.as_str()) || x.label.as_deref() == Some(from.as_str()))
            };
            if !d.segments.iter().any(rhythm) {
                return fail(&f, format!("'{from}' is neither the group nor the label of a rhythm segment"));
            }
        }
        if let Some(seq) = &d.sequence {
            let n = self.teacher_segments().len();
            if seq.is_empty() || seq.len() > MAX_SEGMENTS {
                return fail("data.sequence", format!("{} entries; expected 1 to {MAX_SEGMENTS}", seq.len()));
            }
            if let Some(k) = seq.iter().find(|&&k| k >= n) {
                return fail("data.sequence", format!("names teacher {k}; there are {n} (0-based; a group is one)"));
            }
        }
        if let Some(k) = d.segments.iter().position(|s| s.stand) {
            if d.loop_cycles == 0 {
                return fail(
                    &format!("data.segments[{k}].stand"),
                    "needs looped segments (loop_cycles >= 1): a posture is held, not played as recorded",
                );
            }
            if d.segments.iter().all(|s| s.stand) {
                return fail("data.segments", "are all standing (stand = true); give at least one rhythm");
            }
        }
        if d.loop_cycles > 0 && d.tempo.is_none() {
            // The training sequence's length is known from the file alone: bounded before any motion is read.
            // (A time-warped stop lasts at most two cycles, of at most period_s[1], beyond its ramp.)
            let per = d.sequence.as_ref().map_or(d.segments.len(), Vec::len);
            let blocks = per.saturating_mul(d.repeats);
            let morph = (d.morph_s * d.rate_hz).round() as usize;
            let warped = d.segments.iter().any(|s| s.stand_from.is_some());
            let cycle = if warped { 2 * (d.period_s[1] * d.rate_hz).ceil() as usize } else { 0 };
            let total = blocks
                .saturating_mul(d.samples_per_segment)
                .saturating_add(blocks.saturating_sub(1).saturating_mul(morph.saturating_add(cycle)));
            if total > max_samples {
                return fail(
                    "data.samples_per_segment",
                    format!(
                        "the training sequence would have {total} samples ({} segments × {} repeats × {} samples, plus blends); at most {max_samples}",
                        d.segments.len(),
                        d.repeats,
                        d.samples_per_segment
                    ),
                );
            }
        }
        if let Some(t) = &d.tempo {
            count_within("data.tempo.samples", t.samples, 1, max_samples)?;
            count_within("data.tempo.knot_every", t.knot_every, 1, max_samples)?;
            if t.teachers.len() > 100 {
                return fail("data.tempo.teachers", format!("{} rates; at most 100", t.teachers.len()));
            }
        }
        Ok(())
    }

    /// `[data.tempo]` against the rest of `[data]`.
    fn check_tempo(&self) -> std::result::Result<(), Failure> {
        let d = self;
        let Some(t) = &d.tempo else { return Ok(()) };
        if d.controls != [t.control.clone()] {
            return fail(
                "data.tempo.control",
                format!("'{}': with a tempo, [data] controls must be exactly [\"{}\"]", t.control, t.control),
            );
        }
        if d.segments.len() != 1 || d.loop_cycles == 0 {
            return fail("data.tempo", "plays one segment's loop: give one segment and loop_cycles >= 1");
        }
        let [a, b] = t.range;
        if !(a.is_finite() && b.is_finite() && 0.0 < a && a <= b && b <= 100.0) {
            return fail("data.tempo.range", format!("[{a}, {b}]; expected 0 < low <= high <= 100"));
        }
        if t.teachers.is_empty() || t.teachers.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return fail("data.tempo.teachers", "needs one or more rates > 0");
        }
        if t.knot_every == 0 {
            return fail("data.tempo.knot_every", "must be at least 1");
        }
        Ok(())
    }
}

impl TrainingSection {
    /// The counts of `[training]`, within their bounds.
    fn check_sizes(&self) -> std::result::Result<(), Failure> {
        count_within("training.washout", self.washout, 0, MAX_TRAINING_SAMPLES)?;
        count_within("training.validation_samples", self.validation_samples, 1, MAX_TRAINING_SAMPLES)?;
        count_within("training.noise_draws", self.noise_draws, 1, MAX_NOISE_DRAWS)
    }

    /// The penalty grid, the score and its settings, the noises; `tempo`:
    /// the data has a `[data.tempo]`.
    fn check(&self, tempo: bool) -> std::result::Result<(), Failure> {
        let t = self;
        let p = t.penalty_log10;
        if !(p.start.is_finite() && p.stop.is_finite() && p.step.is_finite() && p.step > 0.0) {
            return fail("training.penalty_log10", "needs finite {start, step, stop} with step > 0");
        }
        let n_penalties = ((p.start - p.stop).abs() / p.step).floor() + 1.0;
        if n_penalties.is_nan() || n_penalties > MAX_PENALTIES as f64 {
            return fail(
                "training.penalty_log10",
                format!("gives {n_penalties} penalties; at most {} (use a larger step)", MAX_PENALTIES),
            );
        }
        if !(p.start.abs() <= 300.0 && p.stop.abs() <= 300.0) {
            return fail("training.penalty_log10", "start and stop must lie within -300 to 300");
        }
        match t.score {
            ScoreKind::Nmse if t.orbit.is_some() => {
                return fail("training.orbit", "is used only with score = \"orbit\"");
            }
            ScoreKind::Nmse => {}
            ScoreKind::Orbit => match &t.orbit {
                Some(o) => o.check(tempo)?,
                None => return fail("training.orbit", "score = \"orbit\" needs a [training.orbit] section"),
            },
        }
        if !(t.noise_variance.is_finite() && t.noise_variance >= 0.0) {
            return fail("training.noise_variance", format!("{}; expected a number >= 0", t.noise_variance));
        }
        if !(t.teacher_noise.is_finite() && (0.0..=10.0).contains(&t.teacher_noise)) {
            return fail("training.teacher_noise", format!("{}; expected 0 to 10", t.teacher_noise));
        }
        if !(t.prefer_larger_within.is_finite() && (0.0..=100.0).contains(&t.prefer_larger_within)) {
            return fail("training.prefer_larger_within", format!("{}; expected 0 to 100", t.prefer_larger_within));
        }
        if let Some(push) = t.orbit.as_ref().and_then(|o| o.push.as_ref()) {
            push.check().map_err(|m| ("training.orbit.push".to_owned(), m))?;
        }
        if !(1..=100).contains(&t.force.every) {
            return fail("training.force.every", format!("{}; expected 1 to 100 steps", t.force.every));
        }
        if !(1..=100).contains(&t.force.passes) {
            return fail("training.force.passes", format!("{}; expected 1 to 100", t.force.passes));
        }
        let sf = t.self_fed;
        if sf.rounds > 10 {
            return fail("training.self_fed.rounds", format!("{}; expected 0 to 10", sf.rounds));
        }
        if sf.rounds > 0 {
            for (key, v) in [("free_steps", sf.free_steps), ("forced_steps", sf.forced_steps)] {
                if !(1..=100_000).contains(&v) {
                    return fail(&format!("training.self_fed.{key}"), format!("{v}; expected 1 to 100000 steps"));
                }
            }
            if t.trainer == Trainer::Force {
                return fail("training.self_fed", "is a ridge regression's; FORCE already learns on its own output");
            }
        }
        Ok(())
    }
}

impl OrbitSection {
    /// The stays, ramps and rates of `[training.orbit]`; `tempo`: the data has a `[data.tempo]`.
    fn check(&self, tempo: bool) -> std::result::Result<(), Failure> {
        let o = self;
        for (name, v) in [("stay_s", o.stay_s), ("ramp_s", o.ramp_s), ("settle_s", o.settle_s)] {
            if !(v.is_finite() && (0.0..=600.0).contains(&v)) {
                return fail(&format!("training.orbit.{name}"), format!("{v}; expected 0 to 600 s"));
            }
        }
        if let Some(r) = &o.rates {
            if !tempo {
                return fail("training.orbit.rates", "needs [data.tempo] (rates of its loop)");
            }
            if r.is_empty() || r.len() > 100 || r.iter().any(|v| !(v.is_finite() && *v > 0.0 && *v <= 100.0)) {
                return fail("training.orbit.rates", "needs 1 to 100 rates above 0 and at most 100");
            }
        }
        if o.settle_s >= o.stay_s {
            return fail(
                "training.orbit.settle_s",
                format!("{} leaves nothing to score in a stay of {} s", o.settle_s, o.stay_s),
            );
        }
        Ok(())
    }
}

//! A trained CPG and its file format.
//!
//! File layout (all integers little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 0..8 | magic `CPGMODEL` |
//! | 8..12 | format version (u32), currently 5 (versions 2 to 4 are read too) |
//! | 12..20 | payload length in bytes (u64) |
//! | 20..28 | FNV-1a 64 checksum of the payload |
//! | 28.. | payload: bincode 2 (standard config) of the model with its configuration, provenance and weights |
//!
//! Version 3 stores W at spectral radius 1 (the dynamics scale `W·x` by the
//! radius); version 2 stored W already scaled, and reading one divides it by
//! the radius (exact at radius 1, the last bit may differ otherwise).
//!
//! The header is checked before anything is decoded, so random bytes, a
//! truncated copy or a flipped bit give a clear error, never a panic or a
//! half-built model. After decoding, every shape is checked again.

use std::path::Path;

use cpg_regression::Readout;
use serde::{Deserialize, Serialize};

use crate::config::ReservoirConfig;
use crate::error::{Error, Result};
use crate::reservoir::Reservoir;
use crate::train::{Scoring, TrainSettings, Training, ValidationPoint};

/// Magic bytes that open every model file.
pub const MAGIC: &[u8; 8] = b"CPGMODEL";
/// The format version this build writes and reads. Version 5 stores the
/// training settings as JSON text too (versions 2 to 4 stored them as fixed
/// bincode fields, `SettingsV4`); version 4 stores the reservoir's
/// configuration as JSON text (self-describing: a parameter added later
/// reads as its default from older files); versions 2 and 3 stored it as
/// fixed bincode fields, and version 2 stored W scaled by the spectral radius.
pub const FORMAT_VERSION: u32 = 5;
/// The oldest format version this build reads.
const OLDEST_VERSION: u32 = 2;
/// The largest sample rate a model may have, Hz.
pub const MAX_SAMPLE_RATE_HZ: f64 = 100_000.0;
/// The smallest sample rate a model may have, Hz.
pub const MIN_SAMPLE_RATE_HZ: f64 = 1.0;

/// Whether `name` can name a channel or a control input of a model file:
/// 1 to 128 characters, no comma, quote or control character (CSV headers
/// and control lines carry the names). The error says what is expected.
pub fn check_name(name: &str) -> std::result::Result<(), String> {
    if name.is_empty() || name.chars().count() > 128 || name.chars().any(|c| c.is_control() || c == ',' || c == '"') {
        return Err(format!(
            "channel or control name {name:?}: expected 1 to 128 characters, no comma, quote or control character"
        ));
    }
    Ok(())
}
/// Largest magnitude of an output's mean or standard deviation.
const MAX_NORMALISATION: f64 = 1e6;
const HEADER: usize = 28;

/// Decodes a payload with a bound on what its length prefixes may claim: a
/// few times the payload's own size (in steps), so that a corrupt length
/// (a string of 2^56 bytes in a 260-byte file) is an error, not an allocation.
fn decode_payload<C: serde::de::DeserializeOwned, S: serde::de::DeserializeOwned>(
    payload: &[u8],
) -> std::result::Result<(Payload<C, S>, usize), bincode::error::DecodeError> {
    use bincode::config::standard;
    use bincode::serde::decode_from_slice;
    const MIB: usize = 1 << 20;
    match payload.len() {
        n if n <= MIB => decode_from_slice(payload, standard().with_limit::<{ 4 * MIB }>()),
        n if n <= 16 * MIB => decode_from_slice(payload, standard().with_limit::<{ 64 * MIB }>()),
        n if n <= 256 * MIB => decode_from_slice(payload, standard().with_limit::<{ 1024 * MIB }>()),
        _ => decode_from_slice(payload, standard().with_limit::<{ 16 * 1024 * MIB }>()),
    }
}

/// Says in words what a bincode decoding error means (its own `Display` is its `Debug`).
fn decode_error(e: &bincode::error::DecodeError) -> String {
    use bincode::error::DecodeError as D;
    match e {
        D::UnexpectedEnd { additional } => format!("it ends {additional} byte(s) too early"),
        D::LimitExceeded => "a length in it exceeds the decoder's limit".into(),
        D::InvalidIntegerType { .. } | D::OutsideUsizeRange(_) | D::NonZeroTypeIsZero { .. } => {
            "an integer in it is out of range".into()
        }
        D::UnexpectedVariant { type_name, found, .. } => format!("variant {found} of {type_name} does not exist"),
        D::Utf8 { inner } => format!("a name in it is not UTF-8 ({inner})"),
        D::InvalidCharEncoding(_) => "a character in it is not valid UTF-8".into(),
        D::InvalidBooleanValue(b) => format!("byte {b} stands where a boolean (0 or 1) belongs"),
        D::ArrayLengthMismatch { required, found } => format!("an array has {found} elements, {required} expected"),
        D::OtherString(m) => m.clone(),
        D::Other(m) => (*m).to_owned(),
        _ => "the bytes do not decode as a model".into(),
    }
}

/// The largest model file read, bytes (4 GiB: the memory budget of training).
pub const MAX_MODEL_BYTES: u64 = 4 << 30;

/// Name and normalisation of one output channel: the network works on
/// `(value − mean) / std`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputChannel {
    /// Channel name (for mocap: `lfemur.rx`).
    pub name: String,
    /// Mean subtracted before training.
    pub mean: f64,
    /// Standard deviation divided by before training.
    pub std: f64,
}

/// The suffix of a channel learnt as its rate of change: `root.tz/s` is the
/// root's z translation per second. What a model generates in units is
/// integrated back into the channel itself (`root.tz`), from 0 at the first
/// step, so that a figure travels ([`Generator`](crate::Generator),
/// [`integrate_in_place`]); normalised outputs stay rates.
pub const VELOCITY_SUFFIX: &str = "/s";

impl OutputChannel {
    /// The channel this one's rate integrates into (`root.tz` for
    /// `root.tz/s`), or `None` for a channel learnt as it is.
    pub fn integrates(&self) -> Option<&str> {
        self.name.strip_suffix(VELOCITY_SUFFIX)
    }

    /// The name of what the model generates for this channel in units: the
    /// integrated channel for a rate, else the channel's own name.
    pub fn unit_name(&self) -> &str {
        self.integrates().unwrap_or(&self.name)
    }

    /// A normalised value `z` in this channel's units: `z · std + mean`
    /// (the one de-normalisation; a multiply and an add, never fused, so
    /// every caller gets the same bits).
    #[inline]
    pub fn to_units(&self, z: f64) -> f64 {
        z * self.std + self.mean
    }
}

/// Frame-major normalised values (`frames × outputs.len()`) in the
/// channels' units, in place.
pub fn to_units_in_place(outputs: &[OutputChannel], y: &mut [f64]) {
    let d = outputs.len().max(1);
    for (k, v) in y.iter_mut().enumerate() {
        if let Some(o) = outputs.get(k % d) {
            *v = o.to_units(*v);
        }
    }
}

/// Frame-major values in units (`frames × outputs.len()`, from
/// [`to_units_in_place`]) with every rate channel ([`VELOCITY_SUFFIX`])
/// integrated in place at `rate_hz`, from 0: position(k) = position(k − 1) +
/// rate(k) / rate_hz, as the [`Generator`](crate::Generator) integrates step
/// by step (the same bits).
pub fn integrate_in_place(outputs: &[OutputChannel], y: &mut [f64], rate_hz: f64) {
    let d = outputs.len();
    if d == 0 {
        return;
    }
    for (c, o) in outputs.iter().enumerate() {
        if o.integrates().is_none() {
            continue;
        }
        let mut position = 0.0;
        for v in y.iter_mut().skip(c).step_by(d) {
            position += *v / rate_hz;
            *v = position;
        }
    }
}

/// [`to_units_in_place`] on a copy.
pub fn to_units(outputs: &[OutputChannel], y: &[f64]) -> Vec<f64> {
    let mut out = y.to_vec();
    to_units_in_place(outputs, &mut out);
    out
}

/// Where a model came from and how its penalty was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Free text describing the data (files, channels, rate, preprocessing).
    pub data: String,
    /// Training settings.
    pub settings: TrainSettings,
    /// The chosen ridge penalty.
    pub chosen_penalty: f64,
    /// Every candidate's validation score, in grid order.
    pub validation_curve: Vec<ValidationPoint>,
    /// One-step NMSE on the training states.
    pub train_nmse: f64,
    /// How the validation runs were scored and pushed.
    pub scoring: Scoring,
    /// Sample rate of the data, Hz.
    pub sample_rate_hz: f64,
    /// Version of cpg-reservoir that trained the model.
    pub crate_version: String,
}

/// One rhythm the model was taught: what it should generate while its control
/// inputs hold `controls`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Teacher {
    /// A name for reports (`walk (35_01)`).
    pub label: String,
    /// The control values of this rhythm (empty without control inputs).
    pub controls: Vec<f64>,
    /// One period, frame-major `p × D`, in normalised units; a single frame
    /// is a posture to hold still (standing), not a rhythm.
    pub cycle: Vec<f64>,
    /// Teacher frames per generated step: 1 for the motion as recorded, `u`
    /// for the cycle played `u` times as fast.
    pub rate: f64,
}

impl Teacher {
    /// Frames in one period of the cycle.
    pub fn period_frames(&self, n_outputs: usize) -> usize {
        self.cycle.len() / n_outputs.max(1)
    }

    /// The period in generated steps (`period_frames / rate`).
    pub fn period_steps(&self, n_outputs: usize) -> f64 {
        self.period_frames(n_outputs) as f64 / self.rate
    }

    /// A posture held still (a one-frame cycle), not a rhythm.
    pub fn is_posture(&self, n_outputs: usize) -> bool {
        self.period_frames(n_outputs) == 1
    }
}

/// A trained reservoir CPG: weights, readout, start state, channel names and provenance.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainedCpg {
    /// The reservoir (configuration, seed, weights).
    pub reservoir: Reservoir,
    /// The trained readout.
    pub readout: Readout,
    /// State at the end of the teacher-forced warm-up: generation starts here.
    pub start_state: Vec<f64>,
    /// Output channels with their normalisation.
    pub outputs: Vec<OutputChannel>,
    /// Names of the control inputs.
    pub controls: Vec<String>,
    /// Provenance.
    pub provenance: Provenance,
    /// The rhythms it was taught, one per control setting, when the training
    /// signal was periodic: what stability checks compare against.
    pub teachers: Vec<Teacher>,
    /// The ASF text of the skeleton the channels belong to, when they came
    /// from motion capture: what exports to AMC need.
    pub skeleton_asf: Option<String>,
}

/// The serialisable form of a model (the payload of a file): `C` is the
/// configuration's form, JSON text from version 4 on, [`ConfigV3`] before;
/// `S` the training settings' form, JSON text from version 5 on, [`SettingsV4`] before.
#[derive(Serialize, Deserialize)]
struct Payload<C, S> {
    config: C,
    seed: u64,
    w: Vec<f64>,
    w_feedback: Vec<f64>,
    w_input: Vec<f64>,
    bias: Vec<f64>,
    raw_spectral_radius: f64,
    readout: Readout,
    start_state: Vec<f64>,
    outputs: Vec<OutputChannel>,
    controls: Vec<String>,
    provenance: StoredProvenance<S>,
    teachers: Vec<Teacher>,
    skeleton_asf: Option<String>,
}

/// [`Provenance`] as a file stores it, the settings in the form `S` (the fields in the same order).
#[derive(Serialize, Deserialize)]
struct StoredProvenance<S> {
    data: String,
    settings: S,
    chosen_penalty: f64,
    validation_curve: Vec<ValidationPoint>,
    train_nmse: f64,
    scoring: Scoring,
    sample_rate_hz: f64,
    crate_version: String,
}

/// The training settings as versions 2 to 4 stored them: bincode fields in
/// this order. Frozen: only for reading and writing old files.
#[derive(Serialize, Deserialize)]
struct SettingsV4 {
    washout: usize,
    penalties: cpg_regression::PenaltyGrid,
    noise_variance: f64,
    n_noise_draws: usize,
    noise_seed: u64,
    teacher_noise: f64,
    prefer_larger_within: f64,
}

/// The reservoir configuration as versions 2 and 3 stored it: bincode
/// fields in this order. Frozen: only for reading old files.
#[derive(Serialize, Deserialize)]
struct ConfigV3 {
    n_neurons: usize,
    connectivity: f64,
    spectral_radius: f64,
    leak_rate: f64,
    bias_range: [f64; 2],
    feedback: crate::config::Coupling,
    inputs: Vec<crate::config::Coupling>,
    n_outputs: usize,
    activation: crate::config::Activation,
    precision: crate::config::Precision,
    tempo_input: Option<usize>,
}

/// `from` in the form `To`, field by field by name (the two configuration
/// forms share their fields' names; serde's values keep every bit).
fn convert<From: Serialize, To: serde::de::DeserializeOwned>(from: &From) -> std::result::Result<To, String> {
    serde_json::to_value(from).and_then(serde_json::from_value).map_err(|e| format!("its reservoir configuration: {e}"))
}

impl<C, S> Payload<C, S> {
    /// The same payload with its configuration and settings turned into other forms.
    fn map<D, T>(
        self,
        f: impl FnOnce(C) -> std::result::Result<D, String>,
        g: impl FnOnce(S) -> std::result::Result<T, String>,
    ) -> std::result::Result<Payload<D, T>, String> {
        let p = self.provenance;
        Ok(Payload {
            config: f(self.config)?,
            seed: self.seed,
            w: self.w,
            w_feedback: self.w_feedback,
            w_input: self.w_input,
            bias: self.bias,
            raw_spectral_radius: self.raw_spectral_radius,
            readout: self.readout,
            start_state: self.start_state,
            outputs: self.outputs,
            controls: self.controls,
            provenance: StoredProvenance {
                data: p.data,
                settings: g(p.settings)?,
                chosen_penalty: p.chosen_penalty,
                validation_curve: p.validation_curve,
                train_nmse: p.train_nmse,
                scoring: p.scoring,
                sample_rate_hz: p.sample_rate_hz,
                crate_version: p.crate_version,
            },
            teachers: self.teachers,
            skeleton_asf: self.skeleton_asf,
        })
    }
}

/// The payload's bytes (bincode, standard configuration).
fn encode<C: Serialize, S: Serialize>(file: &Payload<C, S>) -> Result<Vec<u8>> {
    bincode::serde::encode_to_vec(file, bincode::config::standard())
        .map_err(|e| Error::Shape(format!("encoding the model: {e}")))
}

/// The training settings from their JSON text (version 5 on).
fn settings_from_json(text: String) -> std::result::Result<TrainSettings, String> {
    serde_json::from_str(&text).map_err(|e| format!("its training settings: {e}"))
}

/// Decodes the payload of a file of format `version` (2 to [`FORMAT_VERSION`]).
fn decode_versioned(
    payload: &[u8],
    version: u32,
) -> std::result::Result<(Payload<ReservoirConfig, TrainSettings>, usize), String> {
    let config_json =
        |text: String| serde_json::from_str(&text).map_err(|e| format!("its reservoir configuration: {e}"));
    let settings_v4 = |s: SettingsV4| convert(&s).map_err(|e| format!("its training settings: {e}"));
    match version {
        5.. => {
            let (f, used) = decode_payload::<String, String>(payload).map_err(|e| decode_error(&e))?;
            Ok((f.map(config_json, settings_from_json)?, used))
        }
        4 => {
            let (f, used) = decode_payload::<String, SettingsV4>(payload).map_err(|e| decode_error(&e))?;
            Ok((f.map(config_json, settings_v4)?, used))
        }
        _ => {
            let (f, used) = decode_payload::<ConfigV3, SettingsV4>(payload).map_err(|e| decode_error(&e))?;
            Ok((f.map(|c| convert(&c), settings_v4)?, used))
        }
    }
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

impl TrainedCpg {
    /// Assembles a model from a training result, checking that every part fits.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        reservoir: Reservoir,
        training: Training,
        settings: TrainSettings,
        scoring: Scoring,
        outputs: Vec<OutputChannel>,
        controls: Vec<String>,
        data: String,
        sample_rate_hz: f64,
    ) -> Result<TrainedCpg> {
        let provenance = Provenance {
            data,
            chosen_penalty: training.penalty,
            settings,
            validation_curve: training.curve,
            train_nmse: training.train_nmse,
            scoring,
            sample_rate_hz,
            crate_version: env!("CARGO_PKG_VERSION").into(),
        };
        let m = TrainedCpg {
            reservoir,
            readout: training.readout,
            start_state: training.start_state,
            outputs,
            controls,
            provenance,
            teachers: Vec::new(),
            skeleton_asf: None,
        };
        m.check()?;
        Ok(m)
    }

    /// Attaches the rhythms the model was taught (normalised cycles, frame-major `period × D`).
    pub fn with_teachers(mut self, teachers: Vec<Teacher>) -> Result<TrainedCpg> {
        self.teachers = teachers;
        self.check()?;
        Ok(self)
    }

    /// Attaches the skeleton (ASF text) the output channels belong to.
    pub fn with_skeleton(mut self, asf: String) -> TrainedCpg {
        self.skeleton_asf = Some(asf);
        self
    }

    /// The teacher whose control values are nearest to `controls` (Euclidean), if any.
    pub fn teacher_for(&self, controls: &[f64]) -> Option<&Teacher> {
        let dist = |t: &Teacher| t.controls.iter().zip(controls).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
        self.teachers.iter().min_by(|a, b| dist(a).total_cmp(&dist(b)))
    }

    fn check(&self) -> Result<()> {
        let (n, d, u) = (self.reservoir.n_neurons(), self.reservoir.n_outputs(), self.reservoir.n_inputs());
        let r = &self.readout;
        if r.n_features != n || r.weights.len() != n * d || r.bias.len() != d {
            return Err(Error::Shape(format!(
                "readout is {}×{} with {} biases, the reservoir needs {d}×{n}",
                r.weights.len() / r.n_features.max(1),
                r.n_features,
                r.bias.len()
            )));
        }
        if self.start_state.len() != n {
            return Err(Error::Shape(format!("start state has {} values, expected {n}", self.start_state.len())));
        }
        if self.outputs.len() != d {
            return Err(Error::Shape(format!("{} output channels for {d} outputs", self.outputs.len())));
        }
        if self.controls.len() != u {
            return Err(Error::Shape(format!("{} control names for {u} inputs", self.controls.len())));
        }
        let finite = r.weights.iter().chain(&r.bias).chain(&self.start_state).all(|v| v.is_finite());
        if !finite {
            return Err(Error::Shape("non-finite readout or start state".into()));
        }
        for o in &self.outputs {
            let ok = o.mean.is_finite()
                && o.std.is_finite()
                && o.std > 0.0
                && o.mean.abs() <= MAX_NORMALISATION
                && o.std <= MAX_NORMALISATION;
            if !ok {
                return Err(Error::Shape(format!(
                    "output '{}' has mean {} and standard deviation {}; expected finite values, std > 0, both at most {MAX_NORMALISATION:e} in magnitude",
                    o.name, o.mean, o.std
                )));
            }
        }
        for name in self.outputs.iter().map(|o| &o.name).chain(&self.controls) {
            check_name(name).map_err(Error::Shape)?;
        }
        let rate = self.provenance.sample_rate_hz;
        if !(rate.is_finite() && (MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&rate)) {
            return Err(Error::Shape(format!(
                "sample rate {rate} Hz; expected {MIN_SAMPLE_RATE_HZ} to {MAX_SAMPLE_RATE_HZ} Hz"
            )));
        }
        for t in &self.teachers {
            let ok = t.cycle.len() >= d
                && t.cycle.len().is_multiple_of(d)
                && t.cycle.iter().all(|v| v.is_finite())
                && t.controls.len() == u
                && t.controls.iter().all(|v| v.is_finite())
                && t.rate.is_finite()
                && t.rate > 0.0;
            if !ok {
                return Err(Error::Shape(format!(
                    "teacher '{}': expected a cycle (or a one-frame posture) of whole finite frames of {d} values, {u} finite control values and a rate > 0",
                    t.label
                )));
            }
        }
        Ok(())
    }

    /// Serialises the model into the file format of an older `version`
    /// (2 to 4, for an older cpg to read) or the current one. Version 2
    /// stored W scaled by the spectral radius. A setting the old format
    /// cannot record (training on the own output) is an error, not dropped.
    pub fn to_bytes_version(&self, version: u32) -> Result<Vec<u8>> {
        if version == FORMAT_VERSION {
            return self.to_bytes();
        }
        if !(OLDEST_VERSION..FORMAT_VERSION).contains(&version) {
            return Err(Error::Shape(format!(
                "format version {version}; this build writes versions {OLDEST_VERSION} to {FORMAT_VERSION}"
            )));
        }
        let s = &self.provenance.settings;
        if s.self_fed != crate::train::SelfFed::default() {
            return Err(Error::Shape(format!(
                "format version {version} cannot record training on the model's own output (version 5 can)"
            )));
        }
        let settings: SettingsV4 = convert(s).map_err(Error::Shape)?;
        let c = self.reservoir.config();
        let payload = if version == 4 {
            let config = serde_json::to_string(c)
                .map_err(|e| Error::Shape(format!("encoding the model's configuration: {e}")))?;
            encode(&self.payload(config, settings))?
        } else {
            let rho = if version == 2 { c.spectral_radius } else { 1.0 };
            let config: ConfigV3 = convert(c).map_err(Error::Shape)?;
            let mut file = self.payload(config, settings);
            file.w.iter_mut().for_each(|v| *v *= rho);
            encode(&file)?
        };
        let mut out = TrainedCpg::frame_payload(&payload);
        out[8..12].copy_from_slice(&version.to_le_bytes());
        Ok(out)
    }

    /// The model's parts in the file's form, with `config` and `settings`.
    fn payload<C, S>(&self, config: C, settings: S) -> Payload<C, S> {
        let p = &self.provenance;
        Payload {
            config,
            seed: self.reservoir.seed(),
            w: self.reservoir.w_unit().to_vec(),
            w_feedback: self.reservoir.w_feedback().to_vec(),
            w_input: self.reservoir.w_input().to_vec(),
            bias: self.reservoir.bias().to_vec(),
            raw_spectral_radius: self.reservoir.raw_spectral_radius(),
            readout: self.readout.clone(),
            start_state: self.start_state.clone(),
            outputs: self.outputs.clone(),
            controls: self.controls.clone(),
            provenance: StoredProvenance {
                data: p.data.clone(),
                settings,
                chosen_penalty: p.chosen_penalty,
                validation_curve: p.validation_curve.clone(),
                train_nmse: p.train_nmse,
                scoring: p.scoring.clone(),
                sample_rate_hz: p.sample_rate_hz,
                crate_version: p.crate_version.clone(),
            },
            teachers: self.teachers.clone(),
            skeleton_asf: self.skeleton_asf.clone(),
        }
    }

    /// Serialises the model into the file format.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let json = |what: &str, v: serde_json::Result<String>| {
            v.map_err(|e| Error::Shape(format!("encoding the model's {what}: {e}")))
        };
        let config = json("configuration", serde_json::to_string(self.reservoir.config()))?;
        let settings = json("training settings", serde_json::to_string(&self.provenance.settings))?;
        Ok(TrainedCpg::frame_payload(&encode(&self.payload(config, settings))?))
    }

    /// A model file around `payload`: the magic bytes, the format version,
    /// the payload's length and checksum, then the payload. The fuzz targets
    /// use it to reach the decoder and the field checks past the checksum.
    pub fn frame_payload(payload: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER + payload.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&fnv1a(payload).to_le_bytes());
        out.extend_from_slice(payload);
        out
    }

    /// Parses the file format; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<TrainedCpg> {
        let bad = |reason: String| Error::ModelFile { path: path.to_owned(), reason };
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(bad("not a cpg model file (the first 8 bytes are not `CPGMODEL`)".into()));
        }
        if bytes.len() < HEADER {
            return Err(bad(format!("truncated: {} bytes, the header alone has {HEADER}", bytes.len())));
        }
        let word = |a: usize, b: usize| -> [u8; 8] {
            let mut w = [0u8; 8];
            w[..b - a].copy_from_slice(&bytes[a..b]);
            w
        };
        let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if !(OLDEST_VERSION..=FORMAT_VERSION).contains(&version) {
            return Err(bad(format!(
                "format version {version}; this build of cpg reads versions {OLDEST_VERSION} to {FORMAT_VERSION} (retrain or use a matching cpg)"
            )));
        }
        let len = u64::from_le_bytes(word(12, 20));
        let sum = u64::from_le_bytes(word(20, 28));
        let payload = &bytes[HEADER..];
        if payload.len() as u64 != len {
            return Err(bad(format!(
                "truncated or padded: the header announces {len} payload bytes, the file has {}",
                payload.len()
            )));
        }
        if fnv1a(payload) != sum {
            return Err(bad("corrupt: the payload checksum does not match".into()));
        }
        let (f, used) = decode_versioned(payload, version).map_err(|e| bad(format!("corrupt payload: {e}")))?;
        if used != payload.len() {
            return Err(bad(format!("corrupt payload: {} trailing bytes", payload.len() - used)));
        }
        let mut w = f.w;
        if version == 2 && f.config.spectral_radius != 1.0 {
            let rho = f.config.spectral_radius;
            if !(rho.is_finite() && rho > 0.0) {
                return Err(bad(format!("inconsistent model: spectral radius {rho}")));
            }
            w.iter_mut().for_each(|v| *v /= rho);
        }
        let reservoir =
            Reservoir::from_parts(f.config, f.seed, w, f.w_feedback, f.w_input, f.bias, f.raw_spectral_radius)
                .map_err(|e| bad(format!("inconsistent model: {e}")))?;
        let m = TrainedCpg {
            reservoir,
            readout: f.readout,
            start_state: f.start_state,
            outputs: f.outputs,
            controls: f.controls,
            provenance: Provenance {
                data: f.provenance.data,
                settings: f.provenance.settings,
                chosen_penalty: f.provenance.chosen_penalty,
                validation_curve: f.provenance.validation_curve,
                train_nmse: f.provenance.train_nmse,
                scoring: f.provenance.scoring,
                sample_rate_hz: f.provenance.sample_rate_hz,
                crate_version: f.provenance.crate_version,
            },
            teachers: f.teachers,
            skeleton_asf: f.skeleton_asf,
        };
        m.check().map_err(|e| bad(format!("inconsistent model: {e}")))?;
        Ok(m)
    }

    /// Writes the model to `path` atomically (a temporary file beside it, then a rename).
    ///
    /// A symlink is followed and its target replaced, the link kept; a path
    /// that names a device, FIFO or directory, or whose directory does not
    /// exist, is refused (write [`TrainedCpg::to_bytes`] there yourself).
    pub fn save(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes()?;
        cpg_io::write_file(path, &bytes).map_err(|e| io_error(path, e))
    }

    /// Reads a model file: the header first, then exactly the payload it
    /// declares (at most [`MAX_MODEL_BYTES`]), so that neither a device that
    /// never ends nor a file that lies about its size is read past its header.
    pub fn load(path: &Path) -> Result<TrainedCpg> {
        use std::io::Read as _;
        let bad = |reason: String| Error::ModelFile { path: path.to_owned(), reason };
        let mut f = std::fs::File::open(path).map_err(|source| Error::Io { path: path.to_owned(), source })?;
        let head = cpg_io::read_bounded_from((&mut f).take(HEADER as u64), path, HEADER as u64)
            .map_err(|e| io_error(path, e))?;
        if head.len() < 8 || &head[..8] != MAGIC {
            return Err(bad("not a cpg model file (the first 8 bytes are not `CPGMODEL`)".into()));
        }
        if head.len() < HEADER {
            return Err(bad(format!("truncated: {} bytes, the header alone has {HEADER}", head.len())));
        }
        let mut w = [0u8; 8];
        w.copy_from_slice(&head[12..20]);
        let len = u64::from_le_bytes(w);
        if len > MAX_MODEL_BYTES - HEADER as u64 {
            return Err(bad(format!(
                "the header announces {len} payload bytes; a model file holds at most {MAX_MODEL_BYTES}"
            )));
        }
        // One byte more than announced tells a padded file from a whole one.
        let rest = cpg_io::read_bounded_from(f, path, len + 1).map_err(|e| match e {
            cpg_io::Error::TooLarge { .. } => {
                bad(format!("padded: more bytes follow the {len} payload bytes the header announces"))
            }
            other => io_error(path, other),
        })?;
        let mut bytes = head;
        bytes.extend_from_slice(&rest);
        TrainedCpg::from_bytes(&bytes, path)
    }
}

/// A `cpg_io` error as this crate's.
fn io_error(path: &Path, e: cpg_io::Error) -> Error {
    match e {
        cpg_io::Error::Io { path, source } => Error::Io { path, source },
        // The path is said once: `cpg_io`'s own message already starts with it.
        cpg_io::Error::NotWritable { reason, .. } => Error::ModelFile { path: path.to_owned(), reason },
        other => Error::ModelFile { path: path.to_owned(), reason: other.to_string() },
    }
}

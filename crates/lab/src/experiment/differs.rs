//! What a configuration changes against the paper's protocol, setting by
//! setting, read from the two files (the effective values: a preset's
//! defaults count as set), so that the report's "what differs" is never
//! written by hand.

use serde::Serialize;
use serde_json::Value;

use crate::config::{Config, PenaltyRange};
use crate::error::Result;
use crate::train::reservoir_config;

/// The penalty grid the paper states: `10^(1:−0.1:−8)`.
pub const PAPER_PENALTY_GRID: PenaltyRange = PenaltyRange { start: 1.0, step: 0.1, stop: -8.0 };

/// One setting that differs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// The key, as the configuration names it (`training.teacher_noise`).
    pub key: String,
    /// What it is, in words.
    pub what: String,
    /// Its value under the paper's protocol.
    pub paper: String,
    /// Its value here.
    pub this: String,
}

impl Difference {
    /// `what: paper → this`.
    pub fn describe(&self) -> String {
        format!("{}: {} → {}", self.what, self.paper, self.this)
    }
}

/// Words for the keys a reader meets most.
fn what(key: &str) -> String {
    let words = match key {
        "training.teacher_noise" => "noise on the fed-back teacher while harvesting (σ, normalised)",
        "training.score" => "validation score",
        "training.noise_variance" => "validation state-noise variance",
        "training.noise_draws" => "validation noise draws",
        "training.validation_samples" => "validation run (samples)",
        "training.penalty_log10" => "penalty grid",
        "training.prefer_larger_within" => "penalty choice: the largest scoring within (1 + x) × the best",
        "training.self_fed.rounds" => "rounds of ridge training on the network's own output",
        "training.self_fed.free_steps" => "steps fed by the network's own output per stretch",
        "training.self_fed.forced_steps" => "teacher-forced steps before each such stretch",
        "training.orbit" => "orbit validation run",
        "training.orbit.push" => "push in the validation run",
        "training.orbit.rates" => "rates the validation visits",
        "training.orbit.sequence" => "settings the validation visits, in order",
        "training.orbit.stay_s" => "validation stay at each setting (s)",
        "training.orbit.ramp_s" => "validation ramp between settings (s)",
        "training.orbit.settle_s" => "validation scoring starts after (s)",
        "reservoir.tempo_input" => "control input that scales the leak rate (index)",
        "reservoir.inputs" => "control input couplings",
        "reservoir.leak_rate" => "leak rate",
        "reservoir.n_neurons" => "neurons",
        "reservoir.feedback" => "output feedback coupling",
        "reservoir.spectral_radius" => "spectral radius",
        "data.normalise" => {
            "each channel divided by its standard deviation (total: over all the data; rhythm: within each segment)"
        }
        "data.morph_s" => "blend between segments in the training sequence (s)",
        "data.repeats" => "training blocks repeated",
        "data.samples_per_segment" => "samples per training block",
        "data.segments" => "segments",
        _ => return key.to_owned(),
    };
    words.to_owned()
}

/// A JSON value written as a TOML reader would expect it.
fn toml_like(v: &Value) -> String {
    match v {
        Value::Null => "none".into(),
        Value::Bool(b) => b.to_string(),
        Value::Number(n) => n.as_f64().map_or_else(|| n.to_string(), |x| format!("{x}")),
        Value::String(s) => s.clone(),
        Value::Array(a) => format!("[{}]", a.iter().map(toml_like).collect::<Vec<_>>().join(", ")),
        Value::Object(o) => format!(
            "{{ {} }}",
            o.iter()
                .filter(|(_, v)| !v.is_null())
                .map(|(k, v)| format!("{k} = {}", toml_like(v)))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Keys whose table is one setting (printed whole).
const WHOLE: [&str; 1] = ["training.penalty_log10"];

/// Leaves of `v` under `prefix`: objects are opened (but those of [`WHOLE`]),
/// arrays and scalars are leaves.
fn leaves(prefix: &str, v: &Value, out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(o) if !WHOLE.contains(&prefix) => {
            for (k, x) in o {
                leaves(&format!("{prefix}.{k}"), x, out);
            }
        }
        other => out.push((prefix.to_owned(), other.clone())),
    }
}

/// The settings of `c` that decide its model: the effective reservoir, the
/// data's shape (not its file names) and the training.
fn settings(c: &Config) -> Result<Value> {
    let rc = reservoir_config(c, 1)?;
    let mut data = serde_json::to_value(&c.data).unwrap_or(Value::Null);
    if let Some(segs) = data.get_mut("segments").and_then(Value::as_array_mut) {
        for s in segs {
            if let Some(o) = s.as_object_mut() {
                o.remove("motion");
                o.remove("label");
            }
        }
    }
    if let Some(o) = data.as_object_mut() {
        o.remove("skeleton");
    }
    Ok(serde_json::json!({
        "data": data,
        "reservoir": serde_json::to_value(&rc).unwrap_or(Value::Null),
        "training": serde_json::to_value(&c.training).unwrap_or(Value::Null),
    }))
}

/// Every setting in which `this` differs from `paper` taken with the
/// penalty grid the paper states (a paper-protocol configuration may widen
/// its grid; that is its own difference, see [`paper_protocol_differences`]),
/// in key order. Where one side has a whole table the other lacks
/// (`training.orbit`), the table is one difference.
pub fn differences(paper: &Config, this: &Config) -> Result<Vec<Difference>> {
    let mut stated = paper.clone();
    stated.training.penalty_log10 = PAPER_PENALTY_GRID;
    let (a, b) = (settings(&stated)?, settings(this)?);
    let (mut la, mut lb) = (Vec::new(), Vec::new());
    for top in ["data", "reservoir", "training"] {
        leaves(top, &a[top], &mut la);
        leaves(top, &b[top], &mut lb);
    }
    let mut keys: Vec<String> = la.iter().chain(&lb).map(|(k, _)| k.clone()).collect();
    keys.sort();
    keys.dedup();
    let find =
        |l: &[(String, Value)], k: &str| -> Option<Value> { l.iter().find(|(x, _)| x == k).map(|(_, v)| v.clone()) };
    // A table present on one side only is reported once, at its own key.
    let mut out: Vec<Difference> = Vec::new();
    for k in keys {
        let (va, vb) = (find(&la, &k), find(&lb, &k));
        if va == vb {
            continue;
        }
        let table_of = |side: &[(String, Value)], other: &Value| -> Option<String> {
            // `k` lies inside a table that `side` has and `other` has as null.
            let mut parts: Vec<&str> = k.split('.').collect();
            while parts.len() > 1 {
                parts.pop();
                let parent = parts.join(".");
                let lacks = other.pointer(&format!("/{}", parent.replace('.', "/"))).is_some_and(Value::is_null);
                if lacks && side.iter().any(|(x, _)| x.starts_with(&format!("{parent}."))) {
                    return Some(parent);
                }
            }
            None
        };
        let key = table_of(&lb, &a).or_else(|| table_of(&la, &b)).unwrap_or_else(|| k.clone());
        let ptr = format!("/{}", key.replace('.', "/"));
        let (pa, pb) =
            (a.pointer(&ptr).cloned().unwrap_or(Value::Null), b.pointer(&ptr).cloned().unwrap_or(Value::Null));
        if out.iter().any(|d| d.key == key) {
            continue;
        }
        let show = |v: &Value| match (key.as_str(), serde_json::from_value::<PenaltyRange>(v.clone())) {
            ("training.penalty_log10", Ok(r)) => grid(r),
            _ => toml_like(v),
        };
        out.push(Difference { what: what(&key), paper: show(&pa), this: show(&pb), key });
    }
    Ok(out)
}

/// What a configuration of the paper's protocol changes against what the
/// paper states: its penalty grid (the only setting of the protocol the
/// paper gives that the configurations change).
pub fn paper_protocol_differences(c: &Config, cycles: &[crate::prepare::SegmentCycle]) -> Vec<Difference> {
    let mut out = Vec::new();
    let g = c.training.penalty_log10;
    if g != PAPER_PENALTY_GRID {
        out.push(Difference {
            key: "training.penalty_log10".into(),
            what: "penalty grid".into(),
            paper: grid(PAPER_PENALTY_GRID),
            this: grid(g),
        });
    }
    // The paper concatenates each recording as it is (E1: "one set containing
    // 358 samples"); a loop cut from it is one seamless stride repeated.
    let looped: Vec<&crate::prepare::SegmentCycle> = cycles.iter().filter(|s| s.loop_len > 0).collect();
    if c.data.loop_cycles >= 1 && !looped.is_empty() {
        let each = |f: &dyn Fn(&crate::prepare::SegmentCycle) -> String| {
            looped.iter().map(|s| f(s)).collect::<Vec<_>>().join("; ")
        };
        out.push(Difference {
            key: "data.loop_cycles".into(),
            what: "training set".into(),
            paper: format!(
                "each recording whole, concatenated ({})",
                each(&|s| format!("{}: {} samples", s.label, s.frames))
            ),
            this: format!(
                "a seamless loop of {} gait cycle(s) cut from each and repeated ({})",
                c.data.loop_cycles,
                each(&|s| format!("{}: {} frames from {}", s.label, s.loop_len, s.loop_start))
            ),
        });
    }
    out
}

/// A grid as the paper writes it: `10^(1:−0.1:−8)`.
fn grid(r: PenaltyRange) -> String {
    format!("10^({}:−{}:{})", r.start, r.step, r.stop).replace(":-", ":−")
}

//! Training on arrays in memory (the Python package's `cpg.fit`): the
//! segments' values, the channels' and control inputs' names, checked where
//! they enter; the configuration is a preset (`presets/fit-one.toml` for one
//! segment, `presets/fit-several.toml` for several, our protocol of
//! `experiments/e1.toml` and `experiments/e5-extension.toml`, which a test
//! keeps equal) with the caller's overrides.

use std::path::Path;

use cpg_reservoir::TrainedCpg;

use crate::config::{Config, MAX_SEGMENTS, MAX_TRAINING_SAMPLES};
use crate::error::{Error, Result};

/// The preset for one segment.
pub const PRESET_ONE: &str = include_str!("../presets/fit-one.toml");
/// The preset for several segments.
pub const PRESET_SEVERAL: &str = include_str!("../presets/fit-several.toml");

/// One segment: `n` frames × `d` channels, row-major, and its control values.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Frame-major values.
    pub values: Vec<f64>,
    /// Frames.
    pub n: usize,
    /// Channels.
    pub d: usize,
    /// Control values held during the segment.
    pub controls: Vec<f64>,
}

/// What to train on and how.
#[derive(Debug, Clone, PartialEq)]
pub struct FitRequest {
    /// The segments (one or more; the same channels each).
    pub segments: Vec<Segment>,
    /// How the caller names the segments in messages (`y`, `segments[2]`).
    pub labels: Vec<String>,
    /// Frames per second.
    pub rate_hz: f64,
    /// The channels' names (default `y0`, `y1`, …).
    pub channels: Option<Vec<String>>,
    /// The control inputs' names (default `u0`, `u1`, …).
    pub control_names: Option<Vec<String>>,
    /// The reservoir seed.
    pub seed: u64,
    /// Settings over the preset: the sections `data`, `reservoir`, `training`.
    pub overrides: Option<toml::Table>,
    /// Threads the validation runs on (the model does not depend on it).
    pub threads: usize,
}

/// The preset for `segments` segments, as a TOML table.
pub fn preset(segments: usize) -> toml::Table {
    let text = if segments > 1 { PRESET_SEVERAL } else { PRESET_ONE };
    // The presets are this crate's files: a test parses both.
    text.parse().unwrap_or_default()
}

/// Merges `over` into `base`, table by table.
pub fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// A configuration from a TOML table (a Python dict, the caller's overrides);
/// `name` names it in errors, relative paths are resolved against `base`.
/// Errors name the key as the caller wrote it and no line: the text parsed
/// is this function's, not the caller's.
pub fn config_from_table(t: &toml::Table, name: &str, base: &Path) -> Result<Config> {
    let text = toml::to_string(t).map_err(|e| Error::Unusable(e.to_string()))?;
    Config::from_toml(&text, Path::new(name), base).map_err(|e| match e {
        Error::Config { file, field, message, .. } => Error::Config { file, line: None, field, message },
        other => other,
    })
}

/// Whether `name` can be a control input's name (the configuration's rule
/// and the model file's).
pub fn check_control_name(name: &str) -> std::result::Result<(), String> {
    cpg_reservoir::check_name(name)?;
    if name.chars().any(|c| c == '=' || c.is_whitespace()) {
        return Err(format!("control name {name:?}: expected a word without '=' or spaces"));
    }
    Ok(())
}

/// The channels' names, checked: one per column, each valid and named once.
fn channel_names(r: &FitRequest, d: usize) -> Result<Vec<String>> {
    let names = r.channels.clone().unwrap_or_else(|| (0..d).map(|k| format!("y{k}")).collect());
    if names.len() != d {
        return Err(Error::Shape(format!("channels: {} names for {d} columns", names.len())));
    }
    for (k, n) in names.iter().enumerate() {
        cpg_reservoir::check_name(n).map_err(|e| Error::name(n, format!("channels[{k}]: {e}")))?;
        if names[..k].contains(n) {
            return Err(Error::name(n, format!("channels[{k}]: {n:?} is named twice")));
        }
    }
    Ok(names)
}

/// Checks the segments: the same channels, enough frames, finite values
/// within the mocap bound, at most [`MAX_TRAINING_SAMPLES`] frames in all.
fn check_segments(r: &FitRequest, names: &[String]) -> Result<()> {
    let d = names.len();
    let mut total = 0usize;
    for (k, s) in r.segments.iter().enumerate() {
        let which = &r.labels[k];
        if s.d != d {
            return Err(Error::Shape(format!("{which} has {} channels; {} has {d}", s.d, r.labels[0])));
        }
        if s.n < 4 {
            return Err(Error::Shape(format!("{which} has {} frames; a rhythm needs many more", s.n)));
        }
        let max = cpg_mocap::MAX_MAGNITUDE;
        if let Some(i) = s.values.iter().position(|x| !(x.is_finite() && x.abs() <= max)) {
            return Err(Error::Bound(format!(
                "{which}: the value at frame {}, channel {} ({}) is {}; expected finite values within ±{max}",
                i / d,
                i % d,
                names[i % d],
                s.values[i]
            )));
        }
        total += s.n;
    }
    if total > MAX_TRAINING_SAMPLES {
        return Err(Error::Bound(format!("{total} frames in all; at most {MAX_TRAINING_SAMPLES}")));
    }
    Ok(())
}

/// The configuration of a fit: the preset, the data as `inner` channels, the overrides.
fn fit_config(r: &FitRequest, inner: &[cpg_mocap::Channel], cnames: &[String]) -> Result<Config> {
    let mut table = preset(r.segments.len());
    let seg_tables: Vec<toml::Value> = r
        .segments
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let mut t = toml::Table::new();
            t.insert("motion".into(), toml::Value::String(format!("y[{k}]")));
            t.insert("label".into(), toml::Value::String(r.labels[k].clone()));
            t.insert(
                "controls".into(),
                toml::Value::Array(s.controls.iter().map(|v| toml::Value::Float(*v)).collect()),
            );
            toml::Value::Table(t)
        })
        .collect();
    let strings = |v: Vec<String>| toml::Value::Array(v.into_iter().map(toml::Value::String).collect());
    let data: toml::Table = [
        ("rate_hz".to_owned(), toml::Value::Float(r.rate_hz)),
        ("channels".to_owned(), strings(inner.iter().map(|c| c.to_string()).collect())),
        ("controls".to_owned(), strings(cnames.to_vec())),
        ("segments".to_owned(), toml::Value::Array(seg_tables)),
    ]
    .into_iter()
    .collect();
    merge(&mut table, [("data".to_owned(), toml::Value::Table(data))].into_iter().collect());
    let output: toml::Table = [("model".to_owned(), toml::Value::String("fit.cpg".into()))].into_iter().collect();
    merge(&mut table, [("output".to_owned(), toml::Value::Table(output))].into_iter().collect());
    if let Some(over) = &r.overrides {
        if let Some(key) = over.keys().find(|k| !["data", "reservoir", "training"].contains(&k.as_str())) {
            return Err(Error::name(
                key,
                format!("config: `{key}`; fit takes the sections data, reservoir and training"),
            ));
        }
        merge(&mut table, over.clone());
    }
    let here = std::env::current_dir().unwrap_or_else(|_| Path::new(".").to_owned());
    let mut c = config_from_table(&table, "config", &here)?;
    // Set here, not in the TOML: a seed may be any 64-bit whole number.
    c.reservoir.seed = r.seed;
    Ok(c)
}

/// Checks a request before any work: the counts, names and values.
pub fn check(r: &FitRequest) -> Result<()> {
    let n = r.segments.len();
    if n == 0 || n > MAX_SEGMENTS {
        return Err(Error::Bound(format!("segments: {n} arrays; expected 1 to {MAX_SEGMENTS}")));
    }
    if r.labels.len() != n {
        return Err(Error::Shape(format!("{} labels for {n} segments", r.labels.len())));
    }
    let names = channel_names(r, r.segments[0].d)?;
    check_segments(r, &names)?;
    let u = r.segments[0].controls.len();
    let cnames = r.control_names.clone().unwrap_or_else(|| (0..u).map(|k| format!("u{k}")).collect());
    if r.segments.iter().any(|s| s.controls.len() != u) || cnames.len() != u {
        return Err(Error::Control(
            "controls: every segment needs one value per control input (and one name each)".into(),
        ));
    }
    for (k, c) in cnames.iter().enumerate() {
        check_control_name(c).map_err(|e| Error::name(c, format!("control_names[{k}]: {e}")))?;
    }
    Ok(())
}

/// Trains a model on the request's arrays (z-scoring inside); the model
/// carries the caller's channel names.
pub fn fit(r: FitRequest) -> Result<TrainedCpg> {
    check(&r)?;
    let d = r.segments[0].d;
    let names = channel_names(&r, d)?;
    let u = r.segments[0].controls.len();
    let cnames = r.control_names.clone().unwrap_or_else(|| (0..u).map(|k| format!("u{k}")).collect());
    // Inside, the columns are channels c0.rx, c1.rx, … (the motion format's
    // `bone.dof`); the model carries the caller's names.
    let inner: Vec<cpg_mocap::Channel> =
        (0..d).map(|k| cpg_mocap::Channel { bone: format!("c{k}"), dof: cpg_mocap::Dof::Rx }).collect();
    let c = fit_config(&r, &inner, &cnames)?;
    let parts: Vec<cpg_mocap::Motion> = r
        .segments
        .into_iter()
        .map(|s| cpg_mocap::Motion::new(inner.clone(), s.values, r.rate_hz))
        .collect::<std::result::Result<_, _>>()?;
    let trained = crate::prepare::prepare_recorded(&c, crate::prepare::Recorded { skeleton: None, parts })
        .and_then(|p| crate::in_pool(r.threads, || crate::train::train_prepared(&c, &p, c.reservoir.seed, r.threads)));
    let mut m = trained.map_err(|e| in_callers_names(e, &names))?;
    for (o, n) in m.outputs.iter_mut().zip(&names) {
        o.name.clone_from(n);
    }
    Ok(m)
}

/// An error that names the inner columns (`c3.rx`) in the caller's names.
fn in_callers_names(e: Error, names: &[String]) -> Error {
    let text = e.to_string();
    let mut msg = text.clone();
    for (k, n) in names.iter().enumerate().rev() {
        msg = msg.replace(&format!("c{k}.rx"), n);
    }
    if msg == text { e } else { Error::Unusable(msg) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_presets_parse() {
        for (text, n) in [(PRESET_ONE, 1), (PRESET_SEVERAL, 2)] {
            let t: toml::Table = text.parse().expect("a preset parses");
            assert_eq!(preset(n), t);
            assert!(t.contains_key("training") && t.contains_key("data"));
        }
    }
}

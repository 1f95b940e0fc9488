//! Control inputs over time.

use std::f64::consts::PI;
use std::path::Path;

use crate::error::{Error, Result};

/// Most rows of a control table.
pub const MAX_TABLE_ROWS: usize = 10_000_000;

/// The values of a model's control inputs at every step.
#[derive(Debug, Clone, PartialEq)]
pub enum ControlSchedule {
    /// The same values every step.
    Constant(Vec<f64>),
    /// One row per step (`width` values each); after the last row it is held.
    Table {
        /// Values per row.
        width: usize,
        /// Row-major values.
        rows: Vec<f64>,
    },
    /// Knots `(time_s, values)` in time order, joined by cosine ramps: from
    /// one knot to the next the values blend as `½ − ½·cos(π·s)`, `s` the
    /// fraction of the interval. Two knots with the same values hold them;
    /// two knots at the same time jump. Before the first knot its values
    /// hold, after the last knot the last values hold.
    Knots(Vec<(f64, Vec<f64>)>),
}

impl ControlSchedule {
    /// No control inputs.
    pub fn none() -> ControlSchedule {
        ControlSchedule::Constant(Vec::new())
    }

    /// Number of control values per step.
    pub fn width(&self) -> usize {
        match self {
            ControlSchedule::Constant(v) => v.len(),
            ControlSchedule::Table { width, .. } => *width,
            ControlSchedule::Knots(k) => k.first().map_or(0, |(_, v)| v.len()),
        }
    }

    /// Plateaus of one control: each value held `hold_s`, cosine ramps of `ramp_s` between them.
    pub fn plateaus(values: &[f64], hold_s: f64, ramp_s: f64) -> ControlSchedule {
        let mut knots = Vec::new();
        let mut t = 0.0;
        for (i, &v) in values.iter().enumerate() {
            if i > 0 {
                t += ramp_s;
            }
            knots.push((t, vec![v]));
            t += hold_s;
            knots.push((t, vec![v]));
        }
        ControlSchedule::Knots(knots)
    }

    /// Checks the values: finite, the right width, knots in time order.
    pub fn check(&self, width: usize) -> Result<()> {
        let bad = |m: String| Err(Error::Control(m));
        match self {
            ControlSchedule::Constant(v) if v.len() != width => {
                bad(format!("{} control values for {width} control inputs", v.len()))
            }
            ControlSchedule::Constant(v) if v.iter().any(|x| !x.is_finite()) => {
                bad("a control value is not finite".into())
            }
            ControlSchedule::Table { width: w, rows } if *w != width || (width > 0 && rows.is_empty()) => {
                bad(format!("a control table of {w} columns for {width} control inputs"))
            }
            ControlSchedule::Knots(k) => {
                if k.iter().any(|(_, v)| v.len() != width) {
                    return bad(format!("every knot needs {width} control values"));
                }
                if k.iter().any(|(t, v)| !t.is_finite() || v.iter().any(|x| !x.is_finite())) {
                    return bad("a knot time or value is not finite".into());
                }
                if k.windows(2).any(|w| w[1].0 < w[0].0) {
                    return bad("knots must be in time order".into());
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Writes the values at `step` (time `step / rate_hz`) into `out`. No allocation.
    pub fn fill(&self, step: usize, rate_hz: f64, out: &mut [f64]) {
        match self {
            ControlSchedule::Constant(v) => out.copy_from_slice(v),
            ControlSchedule::Table { width, rows } => {
                if *width == 0 {
                    return;
                }
                let n = rows.len() / width;
                let r = step.min(n.saturating_sub(1));
                out.copy_from_slice(&rows[r * width..(r + 1) * width]);
            }
            ControlSchedule::Knots(k) => {
                let t = step as f64 / rate_hz;
                let Some(i) = k.iter().rposition(|(ti, _)| *ti <= t) else {
                    if let Some((_, v)) = k.first() {
                        out.copy_from_slice(v);
                    }
                    return;
                };
                match k.get(i + 1) {
                    None => out.copy_from_slice(&k[i].1),
                    Some((t1, v1)) => {
                        let (t0, v0) = (&k[i].0, &k[i].1);
                        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                        let w = 0.5 - 0.5 * (PI * s).cos();
                        for ((o, a), b) in out.iter_mut().zip(v0).zip(v1) {
                            *o = (1.0 - w) * a + w * b;
                        }
                    }
                }
            }
        }
    }

    /// The values at every step of `0..n`, row-major.
    pub fn rows(&self, n: usize, rate_hz: f64) -> Vec<f64> {
        let w = self.width();
        let mut out = vec![0.0; n * w];
        if w > 0 {
            for (k, row) in out.chunks_exact_mut(w).enumerate() {
                self.fill(k, rate_hz, row);
            }
        }
        out
    }

    /// `1,0` → constant values (one per name in `names`).
    pub fn parse_values(text: &str, names: &[String]) -> Result<ControlSchedule> {
        let vals: Option<Vec<f64>> =
            text.split(',').map(|s| s.trim().parse::<f64>().ok().filter(|x| x.is_finite())).collect();
        let vals = vals.ok_or_else(|| {
            Error::Control(format!("control values '{text}': expected {} comma-separated finite numbers", names.len()))
        })?;
        if vals.len() != names.len() {
            return Err(Error::Control(format!(
                "{} control values; the model's control inputs are [{}]",
                vals.len(),
                names.join(", ")
            )));
        }
        Ok(ControlSchedule::Constant(vals))
    }

    /// Applies one line of control values to `current` (one value per name):
    /// either every value in order (`1, 0` or `1 0`), or `name=value` pairs
    /// (`u_run=1`, several separated by commas or spaces) that change only
    /// the inputs they name.
    pub fn parse_update(text: &str, names: &[String], current: &mut [f64]) -> Result<()> {
        let tokens: Vec<&str> = text.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect();
        let finite = |t: &str| t.parse::<f64>().ok().filter(|x| x.is_finite());
        if !tokens.iter().any(|t| t.contains('=')) {
            let vals: Option<Vec<f64>> = tokens.iter().map(|t| finite(t)).collect();
            let vals = vals.filter(|v| v.len() == names.len()).ok_or_else(|| {
                Error::Control(format!(
                    "'{}': expected {} finite numbers ([{}]) or name=value pairs",
                    short(text),
                    names.len(),
                    names.join(", ")
                ))
            })?;
            current.copy_from_slice(&vals);
            return Ok(());
        }
        let mut next = current.to_vec();
        for t in tokens {
            let (name, value) = t.split_once('=').ok_or_else(|| {
                Error::Control(format!("'{}': mixes bare numbers with name=value pairs", short(text)))
            })?;
            let k = names.iter().position(|n| n == name).ok_or_else(|| {
                Error::name(
                    name,
                    format!(
                        "'{}' is not a control input{}; the model's are [{}]",
                        short(name),
                        cpg_io::did_you_mean(name, names.iter().map(String::as_str)),
                        names.join(", ")
                    ),
                )
            })?;
            next[k] = finite(value)
                .ok_or_else(|| Error::Control(format!("{name}={}: expected a finite number", short(value))))?;
        }
        current.copy_from_slice(&next);
        Ok(())
    }

    /// A CSV whose header names the control inputs (in the model's order),
    /// then one row of values per step. `file` names the source in errors.
    pub fn parse_csv(text: &str, file: &Path, names: &[String]) -> Result<ControlSchedule> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
        let (_, head) = lines.next().ok_or_else(|| Error::data_file(file, None, "empty file"))?;
        let header: Vec<&str> = head.split(',').map(str::trim).collect();
        if header != names {
            return Err(Error::data_file(
                file,
                Some(1),
                format!(
                    "header [{}]; the model's control inputs are [{}]",
                    short(&header.join(", ")),
                    names.join(", ")
                ),
            ));
        }
        let u = names.len();
        let mut rows = Vec::new();
        for (i, l) in lines {
            if rows.len() / u.max(1) >= MAX_TABLE_ROWS {
                return Err(Error::data_file(file, None, format!("more than {MAX_TABLE_ROWS} rows")));
            }
            let row: Option<Vec<f64>> =
                l.split(',').map(|s| s.trim().parse::<f64>().ok().filter(|x| x.is_finite())).collect();
            let row = row.ok_or_else(|| {
                Error::data_file(file, Some(i + 1), format!("expected {u} finite numbers, found '{}'", short(l)))
            })?;
            if row.len() != u {
                return Err(Error::data_file(file, Some(i + 1), format!("{} values, expected {u}", row.len())));
            }
            rows.extend(row);
        }
        if rows.is_empty() {
            return Err(Error::data_file(file, None, "no rows after the header"));
        }
        Ok(ControlSchedule::Table { width: u, rows })
    }
}

/// At most 60 characters of `s`, for messages.
pub(crate) fn short(s: &str) -> String {
    if s.chars().count() <= 60 { s.to_owned() } else { format!("{}…", s.chars().take(60).collect::<String>()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn knots_hold_ramp_and_jump() {
        let k = ControlSchedule::Knots(vec![
            (0.0, vec![1.0]),
            (1.0, vec![1.0]),
            (2.0, vec![3.0]),
            (3.0, vec![3.0]),
            (3.0, vec![0.0]),
        ]);
        let at = |s: f64| {
            let mut o = [0.0];
            k.fill((s * 100.0).round() as usize, 100.0, &mut o);
            o[0]
        };
        assert_eq!(at(0.5), 1.0);
        assert!((at(1.5) - 2.0).abs() < 1e-12);
        assert_eq!(at(2.5), 3.0);
        assert_eq!(at(3.0), 0.0);
        assert_eq!(at(10.0), 0.0);
        let p = ControlSchedule::plateaus(&[1.0, 2.0], 2.0, 1.0);
        let mut o = [0.0];
        p.fill(250, 100.0, &mut o);
        assert!((o[0] - 1.5).abs() < 1e-12);
    }

    #[test]
    fn csv_errors_name_the_line() {
        let names = vec!["u_walk".to_string(), "u_run".to_string()];
        let e = ControlSchedule::parse_csv("u_walk,u_run\n1,0\n1,x\n", Path::new("u.csv"), &names).unwrap_err();
        assert_eq!(e.to_string(), "u.csv:3: expected 2 finite numbers, found '1,x'");
        assert!(matches!(&e, Error::DataFile { line: Some(3), file, .. } if file == Path::new("u.csv")), "{e:?}");
        let t = ControlSchedule::parse_csv("u_walk,u_run\n1,0\n0,1\n", Path::new("u.csv"), &names).unwrap();
        let mut o = [0.0; 2];
        t.fill(5, 120.0, &mut o);
        assert_eq!(o, [0.0, 1.0]);
    }

    #[test]
    fn a_caller_can_tell_the_errors_apart() {
        let names = vec!["u_walk".to_string(), "u_run".to_string()];
        let mut cur = [0.0; 2];
        let e = ControlSchedule::parse_update("u_jog=1", &names, &mut cur).unwrap_err();
        assert!(matches!(&e, Error::Name { name, .. } if name == "u_jog"), "{e:?}");
        assert_eq!(e.to_string(), "'u_jog' is not a control input; the model's are [u_walk, u_run]");
        let e = ControlSchedule::parse_values("1", &names).unwrap_err();
        assert!(matches!(e, Error::Control(_)), "{e:?}");
        let e = ControlSchedule::parse_csv("", Path::new("u.csv"), &names).unwrap_err();
        assert!(matches!(e, Error::DataFile { line: None, .. }), "{e:?}");
    }
}

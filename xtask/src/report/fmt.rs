//! Number formats and a markdown builder shared by every section.

/// Markdown text built line by line.
#[derive(Debug, Default)]
pub struct Md(pub String);

impl Md {
    pub fn line(&mut self, s: impl AsRef<str>) {
        self.0.push_str(s.as_ref());
        self.0.push('\n');
    }

    pub fn blank(&mut self) {
        self.0.push('\n');
    }

    /// A table: header cells, alignment per column (`l` or `r`), rows.
    pub fn table(&mut self, head: &[&str], align: &str, rows: &[Vec<String>]) {
        self.line(format!("| {} |", head.join(" | ")));
        let a: Vec<&str> = align.chars().map(|c| if c == 'r' { "---:" } else { "---" }).collect();
        self.line(format!("|{}|", a.join("|")));
        for r in rows {
            self.line(format!("| {} |", r.join(" | ")));
        }
        self.blank();
    }
}

use cpg_lab::experiment::claim::{Decision, Source, Value, Verdict};
pub use cpg_lab::experiment::pen;

/// A time in seconds, or `never`.
pub fn secs(x: Option<f64>) -> String {
    x.map_or("never".into(), |v| format!("{v:.2} s"))
}

/// A period in frames, or `decayed`.
pub fn frames(x: Option<f64>) -> String {
    x.map_or("decayed".into(), |v| format!("{v:.2}"))
}

/// `reproduced`, `not reproduced`, `not run`; `(at the limit)` when a
/// comparison that decided it was closer than the printed digits.
pub fn verdict(v: &Verdict) -> String {
    let word = match v.decision {
        Decision::Reproduced => "reproduced",
        Decision::NotReproduced => "not reproduced",
        Decision::NotRun => "not run",
    };
    if v.at_limit { format!("{word} (at the limit)") } else { word.to_owned() }
}

/// A measured value as printed: counts with their 95 % interval, spreads
/// as median (range; n), numbers with their unit.
pub fn value(v: &Value) -> String {
    let unit = |u: &str| if u.is_empty() { String::new() } else { format!(" {u}") };
    match v {
        Value::Count(p) => {
            format!("{} of {} (95 % interval {:.0}–{:.0} %)", p.k, p.n, 100.0 * p.low, 100.0 * p.high)
        }
        Value::Spread { spread: s, unit: u, digits } => {
            if s.n == 0 {
                "—".into()
            } else if s.n == 1 {
                format!("{:.*}{} (n = 1)", digits, s.median, unit(u))
            } else {
                format!("{:.*}{} ({:.*}–{:.*}; n = {})", digits, s.median, unit(u), digits, s.min, digits, s.max, s.n)
            }
        }
        Value::Number { value, unit: u, digits } => format!("{value:.*}{}", digits, unit(u)),
        Value::Text { text } => text.clone(),
    }
}

/// The paper's words (quoted, with where) or our reading (marked inferred).
pub fn sources(s: &[Source]) -> String {
    s.iter()
        .map(|x| match x {
            Source::Quote(q) => format!("“{}” ({})", q.text, q.place),
            Source::Inferred { text } => format!("inferred: {text}"),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `yes` / `no`.
pub fn yes(ok: bool) -> &'static str {
    if ok { "yes" } else { "no" }
}

/// A markdown anchor of a heading text (GitHub's rule, enough for our headings).
pub fn anchor(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c)
            } else if c == ' ' {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(pen(0.012589254117941675), "1.26e-2");
        assert_eq!(pen(10.0), "1.00e1");
        assert_eq!(frames(None), "decayed");
        assert_eq!(secs(Some(0.7916)), "0.79 s");
        assert_eq!(anchor("E1–E3: the left femur"), "e1e3-the-left-femur");
    }
}

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

/// A penalty: `1.26e-2`, `1.00e1`.
pub fn pen(x: f64) -> String {
    if x == 0.0 { "0".into() } else { format!("{x:.2e}") }
}

/// A time in seconds, or `never`.
pub fn secs(x: Option<f64>) -> String {
    x.map_or("never".into(), |v| format!("{v:.2} s"))
}

/// A period in frames, or `decayed`.
pub fn frames(x: Option<f64>) -> String {
    x.map_or("decayed".into(), |v| format!("{v:.2}"))
}

/// `reproduced` / `not reproduced`.
pub fn verdict(ok: bool) -> &'static str {
    if ok { "reproduced" } else { "not reproduced" }
}

/// `yes` / `no`.
pub fn yes(ok: bool) -> &'static str {
    if ok { "yes" } else { "no" }
}

/// The median of `v` (NaN when empty).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Lowest and highest of `v`.
pub fn span(v: impl IntoIterator<Item = f64>) -> (f64, f64) {
    v.into_iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
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

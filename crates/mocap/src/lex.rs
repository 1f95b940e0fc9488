//! Line and token scanning shared by the ASF and AMC parsers.

use crate::error::{ParseError, ParseErrorKind};

/// One whitespace-separated token with its 1-based column.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tok<'a> {
    pub text: &'a str,
    pub column: usize,
}

/// A non-blank, non-comment line.
#[derive(Debug, Clone)]
pub(crate) struct Line<'a> {
    pub number: usize,
    pub text: &'a str,
    pub toks: Vec<Tok<'a>>,
}

/// Turns bytes into text, rejecting anything that is not UTF-8 and lines
/// that end in a carriage return alone (they would read as one long line).
pub(crate) fn text<'a>(file: &str, bytes: &'a [u8]) -> Result<&'a str, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let off = e.valid_up_to();
        let line = bytes[..off].iter().filter(|&&b| b == b'\n').count() + 1;
        ParseError { file: file.to_owned(), line, column: 0, kind: ParseErrorKind::NotUtf8 { byte_offset: off } }
    })?;
    // A CR that no LF follows, before the first LF (or in a file without one): CR-only line ends.
    let first_lf = bytes.iter().position(|&b| b == b'\n').unwrap_or(bytes.len());
    if bytes[..first_lf].iter().enumerate().any(|(i, &b)| b == b'\r' && i + 1 < first_lf) {
        return Err(ParseError { file: file.to_owned(), line: 1, column: 0, kind: ParseErrorKind::CrOnlyLineEnds });
    }
    Ok(text)
}

/// Splits a line into tokens. `(` and `)` count as whitespace so that ASF
/// limit intervals `(-160.0 20.0)` tokenise into plain numbers.
pub(crate) fn tokens(line: &str) -> Vec<Tok<'_>> {
    let mut out = Vec::new();
    let mut start: Option<(usize, usize)> = None; // (byte, column)
    let mut column = 0;
    for (i, c) in line.char_indices() {
        column += 1;
        let sep = c.is_whitespace() || c == '(' || c == ')';
        match (sep, start) {
            (true, Some((b, col))) => {
                out.push(Tok { text: &line[b..i], column: col });
                start = None;
            }
            (false, None) => start = Some((i, column)),
            _ => {}
        }
    }
    if let Some((b, col)) = start {
        out.push(Tok { text: &line[b..], column: col });
    }
    out
}

/// Iterates the meaningful lines of a text (CRLF or LF), skipping blank lines
/// and `#` comments. Every line yielded has at least one token. A UTF-8
/// byte-order mark at the start (as some Windows editors write) is skipped.
pub(crate) fn lines(text: &str) -> impl Iterator<Item = Line<'_>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.split('\n').enumerate().filter_map(|(i, raw)| {
        let t = raw.strip_suffix('\r').unwrap_or(raw);
        let trimmed = t.trim_start();
        if trimmed.starts_with('#') {
            return None;
        }
        // A line of only whitespace and parentheses has no tokens: skip it too,
        // so that every line handed to a parser has a first token.
        let toks = tokens(t);
        if toks.is_empty() {
            return None;
        }
        Some(Line { number: i + 1, text: t, toks })
    })
}

/// The largest magnitude of any number in an ASF or AMC file: a million
/// degrees or length units. Beyond it no motion is meant, and products of such
/// values (kinematics, z-scores) would overflow to infinity.
pub const MAX_MAGNITUDE: f64 = 1e6;

/// Error helper bound to one file name.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'f> {
    pub file: &'f str,
}

impl Ctx<'_> {
    pub fn err(&self, line: usize, column: usize, kind: ParseErrorKind) -> ParseError {
        ParseError { file: self.file.to_owned(), line, column, kind: clip_kind(kind) }
    }

    /// Parses a finite number.
    pub fn num(&self, line: usize, tok: Tok<'_>, expected: &'static str) -> Result<f64, ParseError> {
        self.num_or_inf(line, tok, expected, false)
    }

    /// Parses a number; `allow_inf` admits `inf`/`-inf` (ASF limits), never NaN.
    pub fn num_or_inf(
        &self,
        line: usize,
        tok: Tok<'_>,
        expected: &'static str,
        allow_inf: bool,
    ) -> Result<f64, ParseError> {
        let v: f64 = tok.text.parse().map_err(|_| {
            self.err(line, tok.column, ParseErrorKind::BadNumber { token: tok.text.to_owned(), expected })
        })?;
        if v.is_nan() || (v.is_infinite() && !(allow_inf && tok.text.to_ascii_lowercase().contains("inf"))) {
            return Err(self.err(line, tok.column, ParseErrorKind::NonFinite { token: tok.text.to_owned() }));
        }
        if v.is_finite() && v.abs() > MAX_MAGNITUDE {
            return Err(self.err(
                line,
                tok.column,
                ParseErrorKind::OutOfRange { token: tok.text.to_owned(), expected, max: MAX_MAGNITUDE },
            ));
        }
        Ok(v)
    }

    /// Takes exactly `n` numbers after the keyword token.
    pub fn nums<const N: usize>(&self, l: &Line<'_>, expected: &'static str) -> Result<[f64; N], ParseError> {
        let vals = &l.toks[1..];
        if vals.len() < N {
            return Err(self.err(
                l.number,
                0,
                ParseErrorKind::Arity { keyword: l.toks[0].text.to_owned(), expected: N, found: vals.len() },
            ));
        }
        let mut out = [0.0; N];
        for (o, t) in out.iter_mut().zip(vals) {
            *o = self.num(l.number, *t, expected)?;
        }
        if vals.len() > N {
            return Err(self.err(
                l.number,
                vals[N].column,
                ParseErrorKind::Arity { keyword: l.toks[0].text.to_owned(), expected: N, found: vals.len() },
            ));
        }
        Ok(out)
    }
}

/// The longest piece of input quoted in a message, in characters.
const MAX_QUOTED_CHARS: usize = 60;

/// Shortens quoted input to [`MAX_QUOTED_CHARS`], saying how long it was,
/// so that a 50 MB token does not become a 50 MB message.
pub(crate) fn clip(s: String) -> String {
    match s.char_indices().nth(MAX_QUOTED_CHARS) {
        None => s,
        Some((cut, _)) => format!("{}… ({} bytes in all)", &s[..cut], s.len()),
    }
}

fn clip_kind(kind: ParseErrorKind) -> ParseErrorKind {
    use ParseErrorKind as K;
    match kind {
        K::Unexpected { expected, found } => K::Unexpected { expected, found: clip(found) },
        K::BadNumber { token, expected } => K::BadNumber { token: clip(token), expected },
        K::NonFinite { token } => K::NonFinite { token: clip(token) },
        K::OutOfRange { token, expected, max } => K::OutOfRange { token: clip(token), expected, max },
        K::Arity { keyword, expected, found } => K::Arity { keyword: clip(keyword), expected, found },
        K::UnknownDof(t) => K::UnknownDof(clip(t)),
        K::UnknownAxisOrder(t) => K::UnknownAxisOrder(clip(t)),
        K::UnknownBone(t) => K::UnknownBone(clip(t)),
        K::DuplicateBone(t) => K::DuplicateBone(clip(t)),
        K::MissingField { bone, field } => K::MissingField { bone: clip(bone), field },
        K::LimitsCount { bone, expected, found } => K::LimitsCount { bone: clip(bone), expected, found },
        K::WrongValueCount { bone, found, declared } => K::WrongValueCount { bone: clip(bone), found, declared },
        K::DuplicateInFrame { bone, frame } => K::DuplicateInFrame { bone: clip(bone), frame },
        K::NoDofBone(t) => K::NoDofBone(clip(t)),
        other => other,
    }
}

#[cfg(test)]
mod clip_tests {
    use super::*;

    #[test]
    fn long_tokens_are_shortened_and_short_ones_kept() {
        assert_eq!(clip("lfemur".into()), "lfemur");
        let long = "x".repeat(5_000_000);
        let c = clip(long);
        assert!(c.len() < 100, "{}", c.len());
        assert!(c.ends_with("(5000000 bytes in all)"), "{c}");
        // A multi-byte character at the cut is not split.
        let c = clip("é".repeat(100));
        assert!(c.starts_with(&"é".repeat(60)) && c.contains("200 bytes"), "{c}");
    }
}

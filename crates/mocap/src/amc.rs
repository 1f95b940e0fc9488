//! The AMC (Acclaim Motion Capture) parser and writer.

use std::fmt::Write as _;

use crate::error::{Error, ParseError, ParseErrorKind as K, Result};
use crate::lex::{self, Ctx};
use crate::{Channel, Motion, Skeleton};

/// The largest frame number accepted (CMU trials have a few thousand frames;
/// the bound keeps `previous + 1` from overflowing).
pub const MAX_FRAME_NUMBER: usize = 1_000_000_000;

/// Parses AMC text against a skeleton. `file` names the source in errors;
/// `sample_rate_hz` is the capture rate (CMU: 120), which AMC does not store.
///
/// Every bone that carries DOFs must appear exactly once per frame, with one
/// value per DOF; frames must be numbered consecutively. `:RADIANS` files are
/// converted to degrees. Channel order follows the bone lines of the first frame.
pub fn parse_amc(file: &str, bytes: &[u8], skeleton: &Skeleton, sample_rate_hz: f64) -> Result<Motion> {
    let text = lex::text(file, bytes)?;
    let cx = Ctx { file };
    let last_line = text.split('\n').count();
    let mut lines = lex::lines(text).peekable();
    if lines.peek().is_none() {
        return Err(cx.err(1, 0, K::Empty { expected: "AMC frames" }).into());
    }
    let mut radians = false;
    // Header keywords.
    while let Some(l) = lines.peek() {
        let t = l.toks[0];
        if !t.text.starts_with(':') {
            break;
        }
        match t.text.to_ascii_uppercase().as_str() {
            ":FULLY-SPECIFIED" => {}
            ":DEGREES" => radians = false,
            ":RADIANS" => radians = true,
            _ => {
                return Err(cx
                    .err(
                        l.number,
                        t.column,
                        K::Unexpected {
                            expected: "':FULLY-SPECIFIED', ':DEGREES' or ':RADIANS'".into(),
                            found: t.text.into(),
                        },
                    )
                    .into());
            }
        }
        lines.next();
    }
    let mut f = Frames { radians, ..Frames::new(cx, skeleton) };
    for l in lines {
        let first = l.toks[0];
        if first.text.bytes().all(|b| b.is_ascii_digit()) {
            f.frame_number(&l)?;
        } else {
            f.bone_line(&l)?;
        }
    }
    let Some(last) = f.frame_no else {
        return Err(cx.err(last_line, 0, K::NoFrames).into());
    };
    f.finish(last, f.frame_line)?;
    Motion::new(f.channels, f.values, sample_rate_hz).map_err(|e| match e {
        Error::InvalidArgument(m) => Error::InvalidArgument(format!("{file}: {m}")),
        other => other,
    })
}

/// The frames of an AMC file as they are read.
struct Frames<'a> {
    cx: Ctx<'a>,
    skeleton: &'a Skeleton,
    /// `:RADIANS`: rotations are converted to degrees.
    radians: bool,
    /// Column layout, fixed by the first frame: (bone name, first column).
    layout: Vec<(String, usize)>,
    /// Where each bone of `layout` is in it (lines are looked up in constant time).
    slots: std::collections::HashMap<String, usize>,
    /// The skeleton's bones by name, `root` among them: their degrees of freedom.
    dofs: std::collections::HashMap<&'a str, &'a [crate::Dof]>,
    channels: Vec<Channel>,
    values: Vec<f64>,
    /// The frame being read.
    frame_no: Option<usize>,
    first_frame_no: usize,
    /// Its values, and which bones it has given.
    row: Vec<f64>,
    seen: Vec<bool>,
    /// The line of its number.
    frame_line: usize,
}

impl<'a> Frames<'a> {
    fn new(cx: Ctx<'a>, skeleton: &'a Skeleton) -> Frames<'a> {
        Frames {
            cx,
            skeleton,
            radians: false,
            layout: Vec::new(),
            slots: std::collections::HashMap::new(),
            dofs: std::iter::once(("root", skeleton.root.order.as_slice()))
                .chain(skeleton.bones.iter().map(|b| (b.name.as_str(), b.dofs.as_slice())))
                .collect(),
            channels: Vec::new(),
            values: Vec::new(),
            frame_no: None,
            first_frame_no: 0,
            row: Vec::new(),
            seen: Vec::new(),
            frame_line: 0,
        }
    }

    /// Ends frame `frame` (numbered at `line`): every bone with DOFs given once.
    fn finish(&mut self, frame: usize, line: usize) -> std::result::Result<(), ParseError> {
        let n_bones_with_dofs = self.skeleton.bones.iter().filter(|b| !b.dofs.is_empty()).count() + 1;
        let missing: Vec<String> =
            self.layout.iter().zip(self.seen.iter()).filter(|(_, s)| !**s).map(|((b, _), _)| b.clone()).collect();
        if !missing.is_empty() || self.layout.len() < n_bones_with_dofs {
            let mut bones = missing;
            let have: Vec<&str> = self.layout.iter().map(|(b, _)| b.as_str()).collect();
            if !have.contains(&"root") {
                bones.push("root".into());
            }
            bones.extend(
                self.skeleton
                    .bones
                    .iter()
                    .filter(|b| !b.dofs.is_empty() && !have.contains(&b.name.as_str()))
                    .map(|b| b.name.clone()),
            );
            return Err(ParseError {
                file: self.cx.file.into(),
                line,
                column: 0,
                kind: K::MissingInFrame { frame, bones },
            });
        }
        debug_assert_eq!(self.row.len(), self.channels.len());
        self.values.extend_from_slice(&self.row);
        self.seen.iter_mut().for_each(|s| *s = false);
        Ok(())
    }

    /// A frame number alone on its line: the previous frame ends, numbers are consecutive.
    fn frame_number(&mut self, l: &lex::Line<'_>) -> Result<()> {
        let (cx, first) = (self.cx, l.toks[0]);
        if l.toks.len() != 1 {
            return Err(cx
                .err(
                    l.number,
                    l.toks[1].column,
                    K::Unexpected { expected: "a frame number alone on its line".into(), found: l.toks[1].text.into() },
                )
                .into());
        }
        let n: usize = first.text.parse().ok().filter(|&n| n <= MAX_FRAME_NUMBER).ok_or_else(|| {
            cx.err(
                l.number,
                first.column,
                K::BadNumber { token: first.text.into(), expected: "a frame number from 0 to 1000000000" },
            )
        })?;
        match self.frame_no {
            None => self.first_frame_no = n,
            Some(prev) => {
                self.finish(prev, self.frame_line)?;
                if n != prev + 1 {
                    return Err(cx.err(l.number, first.column, K::FrameNumber { expected: prev + 1, found: n }).into());
                }
            }
        }
        self.frame_no = Some(n);
        self.frame_line = l.number;
        Ok(())
    }

    /// A bone's values within the current frame.
    fn bone_line(&mut self, l: &lex::Line<'_>) -> Result<()> {
        let (cx, first) = (self.cx, l.toks[0]);
        let Some(frame) = self.frame_no else {
            return Err(cx
                .err(
                    l.number,
                    first.column,
                    K::Unexpected { expected: "a frame number".into(), found: first.text.into() },
                )
                .into());
        };
        let name = first.text;
        let dofs = *self.dofs.get(name).ok_or_else(|| cx.err(l.number, first.column, K::UnknownBone(name.into())))?;
        if dofs.is_empty() {
            return Err(cx.err(l.number, first.column, K::NoDofBone(name.into())).into());
        }
        let vals = &l.toks[1..];
        if vals.len() != dofs.len() {
            return Err(cx
                .err(
                    l.number,
                    first.column,
                    K::WrongValueCount { bone: name.into(), found: vals.len(), declared: dofs.to_vec() },
                )
                .into());
        }
        let slot = match self.slots.get(name) {
            Some(&s) => s,
            None if frame == self.first_frame_no => {
                self.slots.insert(name.to_owned(), self.layout.len());
                self.layout.push((name.to_owned(), self.channels.len()));
                self.channels.extend(dofs.iter().map(|&dof| Channel { bone: name.to_owned(), dof }));
                self.row.resize(self.channels.len(), 0.0);
                self.seen.push(false);
                self.layout.len() - 1
            }
            None => {
                // A bone that the first frame did not have: the first frame was incomplete.
                return Err(cx
                    .err(
                        self.frame_line,
                        0,
                        K::Unexpected {
                            expected: format!("bone '{name}' in the first frame as in frame {frame}"),
                            found: "nothing".into(),
                        },
                    )
                    .into());
            }
        };
        if self.seen[slot] {
            return Err(cx.err(l.number, first.column, K::DuplicateInFrame { bone: name.into(), frame }).into());
        }
        self.seen[slot] = true;
        let col = self.layout[slot].1;
        for (k, t) in vals.iter().enumerate() {
            let mut v = cx.num(l.number, *t, "a channel value")?;
            if self.radians && dofs[k].is_rotation() {
                v = v.to_degrees();
            }
            self.row[col + k] = v;
        }
        Ok(())
    }
}

/// Writes a motion as AMC text (`:FULLY-SPECIFIED`, `:DEGREES`), frames numbered from 1.
///
/// Bones appear in the order of their first channel in the motion; every bone
/// with DOFs in the skeleton is written, and channels the motion does not
/// have are written as 0 (the zero pose). Values use the shortest text that
/// reads back to the same `f64`, so `parse_amc(write_amc(m)) == m` for a full motion.
pub fn write_amc(skeleton: &Skeleton, motion: &Motion) -> Result<String> {
    // What is written must parse back: every value within the parser's range.
    if let Some(k) = motion.values().iter().position(|v| v.abs() > crate::MAX_MAGNITUDE) {
        let c = &motion.channels()[k % motion.channels().len()];
        return Err(Error::InvalidArgument(format!(
            "frame {}, channel {c}: {:e} is beyond ±{} and could not be read back",
            k / motion.channels().len() + 1,
            motion.values()[k],
            crate::MAX_MAGNITUDE
        )));
    }
    let mut bones: Vec<&str> = Vec::new();
    for c in motion.channels() {
        let Some(dofs) = skeleton.dofs_of(&c.bone) else {
            return Err(Error::SkeletonMismatch {
                skeleton: skeleton.name.clone(),
                detail: format!("no bone '{}'", c.bone),
            });
        };
        if !dofs.contains(&c.dof) {
            return Err(Error::SkeletonMismatch {
                skeleton: skeleton.name.clone(),
                detail: format!("bone '{}' has no dof {}", c.bone, c.dof.as_str()),
            });
        }
        if !bones.contains(&c.bone.as_str()) {
            bones.push(&c.bone);
        }
    }
    if !bones.contains(&"root") {
        bones.insert(0, "root");
    }
    for b in &skeleton.bones {
        if !b.dofs.is_empty() && !bones.contains(&b.name.as_str()) {
            bones.push(&b.name);
        }
    }
    // Column of each (bone, dof) in the motion, or None.
    let plan: Vec<(&str, Vec<Option<usize>>)> = bones
        .iter()
        .map(|&b| {
            let dofs = skeleton.dofs_of(b).unwrap_or(&[]);
            let cols = dofs.iter().map(|&d| motion.channels().iter().position(|c| c.bone == b && c.dof == d)).collect();
            (b, cols)
        })
        .collect();
    let mut out = String::new();
    out.push_str("#!OML:ASF written by cpg-mocap\n:FULLY-SPECIFIED\n:DEGREES\n");
    for f in 0..motion.n_frames() {
        let row = motion.frame(f);
        let _ = writeln!(out, "{}", f + 1);
        for (b, cols) in &plan {
            out.push_str(b);
            for c in cols {
                let _ = write!(out, " {}", c.map_or(0.0, |k| row[k]));
            }
            out.push('\n');
        }
    }
    Ok(out)
}

//! BVH (Biovision Hierarchy) reading and writing.
//!
//! A BVH file holds a joint hierarchy (offsets, channels per joint) and the
//! motion (one line of channel values per frame, a frame time). Reading turns
//! it into this crate's [`Skeleton`] and [`Motion`], so everything that works
//! on ASF/AMC (forward kinematics, grounding, training, AMC export) works on
//! BVH too:
//!
//! - Each BVH joint `J` becomes a bone named `J` that starts at `J` and
//!   carries `J`'s rotation channels (`J.rx`, `J.ry`, `J.rz`, in degrees). Its
//!   vector is the offset of `J`'s only child (joint or End Site), so that its
//!   end is that child, as an ASF bone's end is its child's start. A joint with
//!   several children gets a zero-length bone, and every child whose offset is
//!   not zero hangs from a link bone `J_to_CHILD` (`J_end` for an End Site)
//!   that has no channels; these keep every position exact.
//! - The root joint's channels are named `root.tx`, `root.ty`, `root.tz`,
//!   `root.rx`, … as in AMC; its OFFSET is the skeleton's root position.
//! - A joint's rotation is the product of its rotation channels in the order
//!   the file lists them, the first one outermost (`Zrotation Yrotation
//!   Xrotation` is `Rz·Ry·Rx`): any order per joint is read. Position channels
//!   are accepted on the root only.
//! - BVH states no length unit. It is given ([`BvhOptions::length_unit_mm`])
//!   or inferred from the size of the figure in its rest pose: a figure
//!   0.5–3 units tall is in metres, 20–45 in CMU's ASF units (inches / 0.45,
//!   as the public CMU conversions keep them), 45–100 in inches, 100–300 in
//!   centimetres and 500–3,000 in millimetres; any other size is an error that
//!   asks for the unit.
//!
//! [`write_bvh`] writes any skeleton and motion: one joint per bone, at the
//! bone's start, with `Zrotation Yrotation Xrotation` channels (the root also
//! `Xposition Yposition Zposition`), lengths in centimetres, angles chosen
//! continuous from frame to frame; its forward kinematics equals the AMC's.

use std::fmt::Write as _;

use crate::error::{Error, ParseError, ParseErrorKind as K, Result};
use crate::kinematics::{M3, axis_frame, mul, rot, transpose};
use crate::lex::{self, Ctx, Line, Tok};
use crate::{AngleUnit, AxisOrder, Bone, Channel, Dof, Motion, Root, Skeleton, Units};

/// Most joints (and End Sites) in one hierarchy.
pub const MAX_BVH_JOINTS: usize = 10_000;
/// Most frames of one BVH motion.
pub const MAX_BVH_FRAMES: usize = 10_000_000;
/// Shortest and longest frame time accepted, seconds (100 kHz to 1 Hz).
pub const FRAME_TIME_RANGE_S: (f64, f64) = (1e-5, 1.0);

/// How a BVH file is read.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BvhOptions {
    /// Millimetres per length unit of the file; `None`: inferred from the
    /// figure's size (see the module documentation).
    pub length_unit_mm: Option<f64>,
}

/// A BVH file read into a skeleton and a motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// The hierarchy as a skeleton (bones as described in the module documentation).
    pub skeleton: Skeleton,
    /// Every channel of the file, in file order, at `1 / frame time` Hz
    /// (rounded to a whole number of Hz when within 0.01 % of one).
    pub motion: Motion,
    /// Millimetres per length unit.
    pub length_unit_mm: f64,
    /// Whether the unit was inferred from the figure's size.
    pub unit_inferred: bool,
    /// The frame time the file states, seconds.
    pub frame_time_s: f64,
}

/// One joint of the hierarchy as read.
#[derive(Debug, Clone)]
struct Node {
    name: String,
    parent: Option<usize>,
    offset: [f64; 3],
    /// The file's channels, in file order.
    channels: Vec<Dof>,
    end_site: bool,
}

/// Tokens of the text with their line numbers, in order, read a line at a
/// time (a BVH file's frames are most of it: they are never held as tokens).
struct Stream<'a, I: Iterator<Item = Line<'a>>> {
    lines: I,
    current: Option<Line<'a>>,
    tok: usize,
    last_line: usize,
}

impl<'a, I: Iterator<Item = Line<'a>>> Stream<'a, I> {
    fn new(mut lines: I, last_line: usize) -> Self {
        let current = lines.next();
        Stream { lines, current, tok: 0, last_line }
    }

    fn peek(&self) -> Option<(usize, Tok<'a>)> {
        self.current.as_ref().map(|l| (l.number, l.toks[self.tok]))
    }

    fn next(&mut self) -> Option<(usize, Tok<'a>)> {
        let t = self.peek()?;
        self.tok += 1;
        if self.current.as_ref().is_some_and(|l| self.tok >= l.toks.len()) {
            self.current = self.lines.next();
            self.tok = 0;
        }
        Some(t)
    }

    /// The next token, which must exist.
    fn take(&mut self, cx: &Ctx<'_>, expected: &str) -> Result<(usize, Tok<'a>), ParseError> {
        self.next().ok_or_else(|| cx.err(self.last_line, 0, K::UnexpectedEof { expected: expected.into() }))
    }

    /// The next token, which must be `word` (case-insensitive).
    fn expect(&mut self, cx: &Ctx<'_>, word: &str) -> Result<usize, ParseError> {
        let (n, t) = self.take(cx, &format!("'{word}'"))?;
        if !t.text.eq_ignore_ascii_case(word) {
            return Err(cx.err(n, t.column, K::Unexpected { expected: format!("'{word}'"), found: t.text.into() }));
        }
        Ok(n)
    }

    /// The next token: `word` followed by a value, written `word value` or `wordvalue`.
    fn value_after(&mut self, cx: &Ctx<'_>, word: &str, expected: &str) -> Result<(usize, Tok<'a>), ParseError> {
        let (n, t) = self.take(cx, &format!("'{word}'"))?;
        if t.text.eq_ignore_ascii_case(word) {
            return self.take(cx, expected);
        }
        match t.text.get(..word.len()) {
            Some(head) if head.eq_ignore_ascii_case(word) && t.text.len() > word.len() => {
                Ok((n, Tok { text: &t.text[word.len()..], column: t.column + word.chars().count() }))
            }
            _ => Err(cx.err(n, t.column, K::Unexpected { expected: format!("'{word}'"), found: t.text.into() })),
        }
    }
}

fn channel_dof(s: &str) -> Option<Dof> {
    Some(match s.to_ascii_lowercase().as_str() {
        "xposition" => Dof::Tx,
        "yposition" => Dof::Ty,
        "zposition" => Dof::Tz,
        "xrotation" => Dof::Rx,
        "yrotation" => Dof::Ry,
        "zrotation" => Dof::Rz,
        _ => return None,
    })
}

/// Parses the HIERARCHY section: the joints in file order.
fn hierarchy<'a, I: Iterator<Item = Line<'a>>>(cx: &Ctx<'_>, s: &mut Stream<'a, I>) -> Result<Vec<Node>, ParseError> {
    s.expect(cx, "HIERARCHY")?;
    s.expect(cx, "ROOT")?;
    let mut nodes: Vec<Node> = Vec::new();
    // The joints whose braces are open, innermost last.
    let mut open: Vec<usize> = Vec::new();
    let mut pending: Option<(Option<usize>, String, bool)> = Some((None, String::new(), false));
    let mut root_named = false;
    loop {
        // A joint header was read: its name (unless an End Site), then `{`, OFFSET, CHANNELS.
        if let Some((parent, _, end_site)) = pending.take() {
            let name = if end_site {
                let p = parent.map_or("root", |p| nodes[p].name.as_str());
                format!("{p}_end")
            } else {
                let (n, t) = s.take(cx, "a joint name")?;
                // Names that ASF, channel names or a hierarchy line could not carry are refused.
                let bad = t.text == "{"
                    || t.text.starts_with(['#', ':'])
                    || t.text.chars().any(|c| c.is_control())
                    || ["begin", "end"].iter().any(|w| t.text.eq_ignore_ascii_case(w));
                if bad {
                    return Err(cx.err(
                        n,
                        t.column,
                        K::Unexpected {
                            expected: "a joint name (printable, not starting with # or :, not begin or end)".into(),
                            found: t.text.into(),
                        },
                    ));
                }
                if nodes.iter().any(|x| !x.end_site && x.name == t.text) || (root_named && t.text == "root") {
                    return Err(cx.err(n, t.column, K::DuplicateBone(t.text.into())));
                }
                t.text.to_owned()
            };
            root_named = true;
            if nodes.len() >= MAX_BVH_JOINTS {
                let (n, _) = s.peek().unwrap_or((s.last_line, Tok { text: "", column: 0 }));
                return Err(cx.err(
                    n,
                    0,
                    K::Unexpected { expected: format!("at most {MAX_BVH_JOINTS} joints"), found: "more".into() },
                ));
            }
            s.expect(cx, "{")?;
            s.expect(cx, "OFFSET")?;
            let mut offset = [0.0; 3];
            for o in &mut offset {
                let (n, t) = s.take(cx, "an offset")?;
                *o = cx.num(n, t, "an offset")?;
            }
            let channels = if end_site { Vec::new() } else { joint_channels(cx, s, parent.is_some())? };
            nodes.push(Node { name, parent, offset, channels, end_site });
            open.push(nodes.len() - 1);
        }
        // Inside the innermost open joint: a child, an End Site, or `}`.
        let (n, t) = s.take(cx, "'JOINT', 'End Site' or '}'")?;
        let here = open.last().copied();
        match t.text.to_ascii_uppercase().as_str() {
            "}" => {
                open.pop();
                if open.is_empty() {
                    return Ok(nodes);
                }
            }
            "JOINT" if here.is_some_and(|h| !nodes[h].end_site) => pending = Some((here, String::new(), false)),
            "END" if here.is_some_and(|h| !nodes[h].end_site) => {
                s.expect(cx, "Site")?;
                pending = Some((here, String::new(), true));
            }
            _ => {
                let expected = if here.is_some_and(|h| nodes[h].end_site) {
                    "'}' (an End Site has only an OFFSET)"
                } else {
                    "'JOINT', 'End Site' or '}'"
                };
                return Err(cx.err(n, t.column, K::Unexpected { expected: expected.into(), found: t.text.into() }));
            }
        }
    }
}

/// A joint's `CHANNELS` line: the count and each channel once (a `child`
/// joint has rotations only; positions are read on the root).
fn joint_channels<'a, I: Iterator<Item = Line<'a>>>(
    cx: &Ctx<'_>,
    s: &mut Stream<'a, I>,
    child: bool,
) -> Result<Vec<Dof>, ParseError> {
    let mut channels = Vec::new();
    s.expect(cx, "CHANNELS")?;
    let (n, t) = s.take(cx, "a channel count")?;
    let count: usize = t.text.parse().ok().filter(|&c| c <= 6).ok_or_else(|| {
        cx.err(n, t.column, K::Unexpected { expected: "a channel count from 0 to 6".into(), found: t.text.into() })
    })?;
    for _ in 0..count {
        let (n, t) = s.take(cx, "a channel name")?;
        let d = channel_dof(t.text).ok_or_else(|| {
            cx.err(
                n,
                t.column,
                K::Unexpected {
                    expected: "Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation".into(),
                    found: t.text.into(),
                },
            )
        })?;
        if channels.contains(&d) {
            return Err(cx.err(
                n,
                t.column,
                K::Unexpected { expected: "each channel once per joint".into(), found: t.text.into() },
            ));
        }
        if child && !d.is_rotation() {
            return Err(cx.err(
                n,
                t.column,
                K::Unexpected {
                    expected: "rotation channels (position channels are read on the root only)".into(),
                    found: t.text.into(),
                },
            ));
        }
        channels.push(d);
    }
    Ok(channels)
}

/// Millimetres per unit for a figure `size` units across (see the module documentation).
pub fn infer_length_unit_mm(size: f64) -> Option<f64> {
    const TABLE: [(f64, f64, f64); 5] = [
        (0.5, 3.0, 1000.0),
        (20.0, 45.0, 25.4 / 0.45),
        (45.0, 100.0, 25.4),
        (100.0, 300.0, 10.0),
        (500.0, 3000.0, 1.0),
    ];
    TABLE.iter().find(|(lo, hi, _)| (*lo..*hi).contains(&size)).map(|t| t.2)
}

/// Parses BVH text. `file` names the source in errors.
pub fn parse_bvh(file: &str, bytes: &[u8], opts: &BvhOptions) -> Result<Bvh> {
    let text = lex::text(file, bytes)?;
    let cx = Ctx { file };
    let last_line = text.split('\n').count();
    let mut s = Stream::new(lex::lines(text), last_line);
    if s.peek().is_none() {
        return Err(cx.err(1, 0, K::Empty { expected: "a BVH hierarchy and motion" }).into());
    }
    let nodes = hierarchy(&cx, &mut s)?;
    let n_channels: usize = nodes.iter().map(|n| n.channels.len()).sum();
    // MOTION, Frames: N, Frame Time: t (each colon may touch its value).
    s.expect(&cx, "MOTION")?;
    let frames_tok = s.value_after(&cx, "Frames:", "a frame count")?;
    let n_frames: usize =
        frames_tok.1.text.parse().ok().filter(|&f| (1..=MAX_BVH_FRAMES).contains(&f)).ok_or_else(|| {
            cx.err(
                frames_tok.0,
                frames_tok.1.column,
                K::Unexpected {
                    expected: format!("a frame count from 1 to {MAX_BVH_FRAMES}"),
                    found: frames_tok.1.text.into(),
                },
            )
        })?;
    s.expect(&cx, "Frame")?;
    let (ft_line, ft) = s.value_after(&cx, "Time:", "a frame time")?;
    let frame_time_s = cx.num(ft_line, ft, "a frame time in seconds")?;
    if !(FRAME_TIME_RANGE_S.0..=FRAME_TIME_RANGE_S.1).contains(&frame_time_s) {
        return Err(cx
            .err(
                ft_line,
                ft.column,
                K::Unexpected {
                    expected: format!(
                        "a frame time from {} to {} s (100 kHz to 1 Hz)",
                        FRAME_TIME_RANGE_S.0, FRAME_TIME_RANGE_S.1
                    ),
                    found: ft.text.into(),
                },
            )
            .into());
    }
    // The frames: one line each, after the frame time's line, parsed as they come.
    if s.tok != 0 {
        let (n, t) = s.peek().unwrap_or((ft_line, ft));
        return Err(cx
            .err(
                n,
                t.column,
                K::Unexpected { expected: "the end of the line after the frame time".into(), found: t.text.into() },
            )
            .into());
    }
    let values = frame_values(&cx, s, n_frames, n_channels)?;
    let unit = length_unit(file, opts, &nodes)?;
    let skeleton = skeleton_of(file, &nodes, unit.0);
    let mut channels = Vec::with_capacity(n_channels);
    for n in &nodes {
        let bone = if n.parent.is_none() { "root" } else { n.name.as_str() };
        channels.extend(n.channels.iter().map(|&dof| Channel { bone: bone.to_owned(), dof }));
    }
    let mut rate = 1.0 / frame_time_s;
    if (rate - rate.round()).abs() <= 1e-4 * rate {
        rate = rate.round();
    }
    let motion = if channels.is_empty() {
        // A hierarchy without channels still has a pose: one constant root channel keeps the frames.
        Motion::new(vec![Channel { bone: "root".into(), dof: Dof::Tx }], vec![0.0; n_frames], rate)?
    } else {
        Motion::new(channels, values, rate)?
    };
    Ok(Bvh { skeleton, motion, length_unit_mm: unit.0, unit_inferred: unit.1, frame_time_s })
}

/// The frames after the frame time's line: `n_frames` lines of `n_channels` values each, and nothing after.
fn frame_values<'a, I: Iterator<Item = Line<'a>>>(
    cx: &Ctx<'_>,
    mut s: Stream<'a, I>,
    n_frames: usize,
    n_channels: usize,
) -> Result<Vec<f64>> {
    let last_line = s.last_line;
    let mut values = Vec::with_capacity(n_frames.saturating_mul(n_channels).min(1 << 24));
    let mut frames = 0usize;
    for l in s.current.take().into_iter().chain(s.lines) {
        if frames == n_frames {
            return Err(cx
                .err(
                    l.number,
                    l.toks[0].column,
                    K::Unexpected {
                        expected: format!("the end of the file after the {n_frames} frame(s) 'Frames:' declares"),
                        found: l.toks[0].text.into(),
                    },
                )
                .into());
        }
        if l.toks.len() != n_channels {
            return Err(cx
                .err(
                    l.number,
                    l.toks.get(n_channels).map_or(0, |t| t.column),
                    K::Arity { keyword: format!("frame {}", frames + 1), expected: n_channels, found: l.toks.len() },
                )
                .into());
        }
        for t in &l.toks {
            values.push(cx.num(l.number, *t, "a channel value")?);
        }
        frames += 1;
    }
    if frames < n_frames {
        return Err(cx
            .err(
                last_line,
                0,
                K::UnexpectedEof {
                    expected: format!("{n_frames} frames as 'Frames:' says; the file ends after {frames}"),
                },
            )
            .into());
    }
    Ok(values)
}

/// The length unit in millimetres: given (and bounded) or inferred from the rest pose's size; whether it was inferred.
fn length_unit(file: &str, opts: &BvhOptions, nodes: &[Node]) -> Result<(f64, bool)> {
    Ok(match opts.length_unit_mm {
        Some(u) if !(u.is_finite() && (1e-6..=1e6).contains(&u)) => {
            return Err(Error::InvalidArgument(format!(
                "{file}: length unit {u} mm; expected 1e-6 to 1e6 mm per BVH unit"
            )));
        }
        Some(u) => (u, false),
        None => {
            let size = rest_size(nodes);
            let u = infer_length_unit_mm(size).ok_or_else(|| {
                Error::InvalidArgument(format!(
                    "{file}: the figure is {size:.3} units across in its rest pose, which matches no length unit (metres 0.5–3, CMU units 20–45, inches 45–100, centimetres 100–300, millimetres 500–3000); give the unit in millimetres (bvh_unit_mm)"
                ))
            })?;
            (u, true)
        }
    })
}

/// The largest extent of the rest pose along any axis, file units.
fn rest_size(nodes: &[Node]) -> f64 {
    let mut pos: Vec<[f64; 3]> = Vec::with_capacity(nodes.len());
    for n in nodes {
        let base = n.parent.map_or([0.0; 3], |p| pos[p]);
        pos.push([base[0] + n.offset[0], base[1] + n.offset[1], base[2] + n.offset[2]]);
    }
    (0..3)
        .map(|a| {
            let lo = pos.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let hi = pos.iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max);
            hi - lo
        })
        .fold(0.0, f64::max)
}

/// The skeleton of a hierarchy, lengths in file units (`unit_mm` per unit).
fn skeleton_of(file: &str, nodes: &[Node], unit_mm: f64) -> Skeleton {
    let children = |j: usize| -> Vec<usize> { (0..nodes.len()).filter(|&c| nodes[c].parent == Some(j)).collect() };
    let rot_dofs = |n: &Node| -> Vec<Dof> { n.channels.iter().rev().filter(|d| d.is_rotation()).copied().collect() };
    let root = &nodes[0];
    let mut order: Vec<Dof> = root.channels.iter().filter(|d| !d.is_rotation()).copied().collect();
    order.extend(rot_dofs(root));
    let mut bones: Vec<Bone> = Vec::new();
    let bone = |name: String, v: [f64; 3], dofs: Vec<Dof>, parent: Option<usize>, id: usize| {
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        Bone {
            id: id as u32,
            name,
            direction: if len > 0.0 { v.map(|x| x / len) } else { [0.0; 3] },
            length: len,
            axis_deg: [0.0; 3],
            axis_order: AxisOrder::XYZ,
            dofs,
            limits: Vec::new(),
            parent,
        }
    };
    // The bone each joint's children hang from, set as joints are placed (parents first in file order).
    let mut hang: Vec<Option<usize>> = vec![None; nodes.len()];
    // Link bones take names no joint and no other link has.
    let mut taken: std::collections::HashSet<String> =
        nodes.iter().filter(|n| !n.end_site).map(|n| n.name.clone()).collect();
    taken.insert("root".into());
    let mut fresh = |base: String| -> String {
        let mut name = base.clone();
        let mut k = 2;
        while taken.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        taken.insert(name.clone());
        name
    };
    for (j, n) in nodes.iter().enumerate() {
        // Where this joint's own bone (or, for an End Site, nothing) starts: the bone it hangs from.
        let from = match n.parent {
            None => None,
            Some(p) => {
                let parent_bone = hang[p];
                let siblings = children(p);
                let zero = n.offset.iter().all(|v| *v == 0.0);
                if p == 0 || siblings.len() > 1 {
                    // The parent's bone (if any) has zero length: a link carries a non-zero offset.
                    if zero {
                        parent_bone
                    } else if n.end_site {
                        let name = fresh(format!("{}_end", if p == 0 { "root" } else { nodes[p].name.as_str() }));
                        bones.push(bone(name, n.offset, Vec::new(), parent_bone, bones.len() + 1));
                        None
                    } else {
                        let name =
                            fresh(format!("{}_to_{}", if p == 0 { "root" } else { nodes[p].name.as_str() }, n.name));
                        bones.push(bone(name, n.offset, Vec::new(), parent_bone, bones.len() + 1));
                        Some(bones.len() - 1)
                    }
                } else {
                    // The only child: the parent's bone already ends here.
                    parent_bone
                }
            }
        };
        if n.end_site || j == 0 {
            continue;
        }
        let kids = children(j);
        let v = if kids.len() == 1 { nodes[kids[0]].offset } else { [0.0; 3] };
        bones.push(bone(n.name.clone(), v, rot_dofs(n), from, bones.len() + 1));
        hang[j] = Some(bones.len() - 1);
    }
    Skeleton {
        name: std::path::Path::new(file)
            .file_stem()
            .map_or_else(|| file.to_owned(), |s| s.to_string_lossy().into_owned()),
        version: "1.10".into(),
        units: Units { mass: 1.0, length: 25.4 / unit_mm, angle: AngleUnit::Deg },
        documentation: format!("read from the BVH file {file} ({unit_mm} mm per unit)"),
        root: Root { order, axis: AxisOrder::XYZ, position: root.offset, orientation_deg: [0.0; 3] },
        bones,
    }
}

/// `Rz(a)·Ry(b)·Rx(c)` of a rotation matrix, degrees, as the two solutions
/// (the second with `b` mirrored through 90°).
fn zyx(m: &M3) -> [[f64; 3]; 2] {
    let sb = (-m[2][0]).clamp(-1.0, 1.0);
    let b = sb.asin();
    let (a, c) = if sb.abs() < 1.0 - 1e-12 {
        (m[1][0].atan2(m[0][0]), m[2][1].atan2(m[2][2]))
    } else {
        // Gimbal lock: only a − c (or a + c) is defined; put it all in a.
        ((-m[0][1]).atan2(m[1][1]), 0.0)
    };
    let d = [a.to_degrees(), b.to_degrees(), c.to_degrees()];
    [d, [d[0] + 180.0, 180.0 - d[1], d[2] + 180.0]]
}

/// `x` plus the multiple of 360 that brings it nearest to `near`.
fn unwrap(x: f64, near: f64) -> f64 {
    x + 360.0 * ((near - x) / 360.0).round()
}

/// Writes `motion` on `skeleton` as BVH text (lengths in centimetres). The
/// channels the motion lacks are 0; the frame time is `1 / rate`.
pub fn write_bvh(skeleton: &Skeleton, motion: &Motion) -> Result<String> {
    let sk = skeleton;
    let full = sk.complete(motion)?;
    let cm = sk.mm_per_unit() / 10.0;
    let n = full.n_frames();
    let col = |bone: &str, dof: Dof| full.channels().iter().position(|c| c.bone == bone && c.dof == dof);
    // The rotation of each bone (and of the root) relative to its parent in every frame: C·M·C⁻¹.
    let local = |f: usize, dofs: &[Dof], bone: &str, axis: [f64; 3], order: AxisOrder| -> M3 {
        let row = full.frame(f);
        let mut m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for &d in dofs.iter().filter(|d| d.is_rotation()) {
            if let Some(k) = col(bone, d) {
                m = mul(&rot(d.axis(), row[k]), &m);
            }
        }
        let c = axis_frame(axis, order);
        mul(&mul(&c, &m), &transpose(&c))
    };
    // Joints: the root, then the bones depth-first (parents before children, file order among siblings).
    let order = sk.topological_order();
    let kids = |p: Option<usize>| -> Vec<usize> { (0..sk.bones.len()).filter(|&b| sk.bones[b].parent == p).collect() };
    let unit_vec = |b: &Bone| -> [f64; 3] {
        let l = b.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
        if l > 0.0 { b.direction.map(|x| x / l * b.length * cm) } else { [0.0; 3] }
    };
    let mut too_large: Option<f64> = None;
    let mut num = |x: f64| -> String {
        if x.is_nan() || x.abs() > crate::MAX_MAGNITUDE {
            too_large.get_or_insert(x);
        }
        let s = format!("{x:.9}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" || s.is_empty() { "0".to_owned() } else { s.to_owned() }
    };
    let mut out = String::from(
        "HIERARCHY\nROOT root\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n",
    );
    // Depth-first text with an explicit stack: (bone, depth, closing?).
    let mut stack: Vec<(usize, usize, bool)> = kids(None).into_iter().rev().map(|b| (b, 1, false)).collect();
    let mut joint_order = Vec::with_capacity(sk.bones.len());
    while let Some((b, depth, closing)) = stack.pop() {
        let tabs = "\t".repeat(depth);
        if closing {
            let _ = writeln!(out, "{tabs}}}");
            continue;
        }
        let bone = &sk.bones[b];
        joint_order.push(b);
        // A bone starts where its parent ends (a root child: at the root).
        let off = bone.parent.map_or([0.0; 3], |p| unit_vec(&sk.bones[p]));
        let _ = writeln!(out, "{tabs}JOINT {}\n{tabs}{{", bone.name);
        let _ = writeln!(out, "{tabs}\tOFFSET {} {} {}", num(off[0]), num(off[1]), num(off[2]));
        let _ = writeln!(out, "{tabs}\tCHANNELS 3 Zrotation Yrotation Xrotation");
        stack.push((b, depth, true));
        let children = kids(Some(b));
        if children.is_empty() {
            let v = unit_vec(bone);
            let _ = writeln!(
                out,
                "{tabs}\tEnd Site\n{tabs}\t{{\n{tabs}\t\tOFFSET {} {} {}\n{tabs}\t}}",
                num(v[0]),
                num(v[1]),
                num(v[2])
            );
        }
        for c in children.into_iter().rev() {
            stack.push((c, depth + 1, false));
        }
    }
    debug_assert_eq!(joint_order.len(), order.len());
    out.push_str("}\nMOTION\n");
    let _ = writeln!(out, "Frames: {n}\nFrame Time: {}", num(1.0 / full.sample_rate_hz()));
    // Angles per joint, continuous in time: (root first) [a, b, c] of the previous frame.
    let mut previous: Vec<Option<[f64; 3]>> = vec![None; joint_order.len() + 1];
    let root_t = [Dof::Tx, Dof::Ty, Dof::Tz].map(|d| col("root", d));
    let mut line = String::new();
    for f in 0..n {
        line.clear();
        let row = full.frame(f);
        for (a, k) in root_t.iter().enumerate() {
            let t = k.map_or(0.0, |k| row[k]);
            let _ = write!(line, "{} ", num((sk.root.position[a] + t) * cm));
        }
        let mut joint = |slot: usize, m: &M3, line: &mut String| {
            let [s1, s2] = zyx(m);
            let pick = match previous[slot] {
                None => s1,
                Some(p) => {
                    let near = |s: [f64; 3]| [unwrap(s[0], p[0]), unwrap(s[1], p[1]), unwrap(s[2], p[2])];
                    let (u1, u2) = (near(s1), near(s2));
                    let dist = |u: [f64; 3]| (0..3).map(|i| (u[i] - p[i]).abs()).sum::<f64>();
                    if dist(u2) < dist(u1) { u2 } else { u1 }
                }
            };
            previous[slot] = Some(pick);
            let _ = write!(line, "{} {} {} ", num(pick[0]), num(pick[1]), num(pick[2]));
        };
        joint(0, &local(f, &sk.root.order, "root", sk.root.orientation_deg, sk.root.axis), &mut line);
        for (slot, &b) in joint_order.iter().enumerate() {
            let bone = &sk.bones[b];
            joint(slot + 1, &local(f, &bone.dofs, &bone.name, bone.axis_deg, bone.axis_order), &mut line);
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    if let Some(x) = too_large {
        return Err(Error::InvalidArgument(format!(
            "a BVH value would be {x:e}, beyond ±{} and not readable back",
            crate::MAX_MAGNITUDE
        )));
    }
    Ok(out)
}

impl Bvh {
    /// Reads and parses a BVH file.
    pub fn from_file(path: impl AsRef<std::path::Path>, opts: &BvhOptions) -> Result<Bvh> {
        let path = path.as_ref();
        let bytes = crate::read_bounded(path, crate::MAX_INPUT_BYTES)?;
        parse_bvh(&crate::file_label(path), &bytes, opts)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn euler_angles_come_back_from_their_matrix() {
        for &(a, b, c) in &[(10.0, 20.0, 30.0), (-170.0, 80.0, 5.0), (45.0, -89.0, 120.0), (0.0, 90.0, 0.0)] {
            let m = mul(&mul(&rot(2, a), &rot(1, b)), &rot(0, c));
            for s in zyx(&m) {
                let back = mul(&mul(&rot(2, s[0]), &rot(1, s[1])), &rot(0, s[2]));
                for i in 0..3 {
                    for j in 0..3 {
                        assert!((back[i][j] - m[i][j]).abs() < 1e-9, "{a} {b} {c}: {s:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn units_are_inferred_from_the_figure_size() {
        assert_eq!(infer_length_unit_mm(1.7), Some(1000.0));
        assert_eq!(infer_length_unit_mm(170.0), Some(10.0));
        assert_eq!(infer_length_unit_mm(1700.0), Some(1.0));
        assert_eq!(infer_length_unit_mm(67.0), Some(25.4));
        assert!((infer_length_unit_mm(30.0).unwrap() - 56.444).abs() < 1e-3);
        assert_eq!(infer_length_unit_mm(10.0), None);
    }
}

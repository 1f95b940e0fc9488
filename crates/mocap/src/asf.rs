//! The ASF (Acclaim Skeleton File) parser.

use crate::error::{ParseError, ParseErrorKind as K};
use crate::lex::{self, Ctx, Line};
use crate::{AngleUnit, AxisOrder, Bone, Dof, Root, Skeleton, Units};

/// The most bones an ASF skeleton may have (as many as a BVH's joints,
/// [`crate::bvh::MAX_BVH_JOINTS`]; a human figure has about 30).
pub const MAX_ASF_BONES: usize = 10_000;

/// Parses ASF text. `file` names the source in error messages. Time and
/// memory grow linearly with the text; more than [`MAX_ASF_BONES`] bones
/// are refused at the first bone beyond them.
pub fn parse_asf(file: &str, bytes: &[u8]) -> Result<Skeleton, ParseError> {
    let text = lex::text(file, bytes)?;
    let cx = Ctx { file };
    let lines: Vec<Line<'_>> = lex::lines(text).collect();
    if lines.is_empty() {
        return Err(cx.err(1, 0, K::Empty { expected: "an ASF skeleton" }));
    }
    let last_line = text.split('\n').count();
    let mut sk = Skeleton {
        name: String::new(),
        version: String::new(),
        units: Units { mass: 1.0, length: 1.0, angle: AngleUnit::Deg },
        documentation: String::new(),
        root: Root { order: Vec::new(), axis: AxisOrder::XYZ, position: [0.0; 3], orientation_deg: [0.0; 3] },
        bones: Vec::new(),
    };
    let mut seen_root = false;
    let mut seen_bones = false;
    let mut seen_hier = false;
    let mut parents: Vec<Option<Option<usize>>> = Vec::new();
    let mut index: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    let mut i = 0;
    while i < lines.len() {
        let l = &lines[i];
        let kw = l.toks[0];
        if !kw.text.starts_with(':') {
            return Err(cx.err(
                l.number,
                kw.column,
                K::Unexpected { expected: "a section keyword such as ':bonedata'".into(), found: kw.text.into() },
            ));
        }
        i += 1;
        match kw.text {
            ":version" => sk.version = rest_of(l),
            ":name" => sk.name = rest_of(l),
            ":units" => parse_units(&cx, &lines, &mut i, &mut sk.units)?,
            ":documentation" => {
                let mut doc = Vec::new();
                while i < lines.len() && !is_section(&lines[i]) {
                    doc.push(lines[i].text.trim());
                    i += 1;
                }
                sk.documentation = doc.join("\n");
            }
            ":root" => {
                seen_root = true;
                parse_root(&cx, &lines, &mut i, &mut sk.root)?;
            }
            ":bonedata" => {
                seen_bones = true;
                parse_bonedata(&cx, &lines, &mut i, &mut sk.bones, &mut index, last_line)?;
                parents = vec![None; sk.bones.len()];
            }
            ":hierarchy" => {
                seen_hier = true;
                if !seen_bones {
                    return Err(cx.err(l.number, 0, K::MissingSection(":bonedata (before :hierarchy)")));
                }
                parse_hierarchy(&cx, &lines, &mut i, &index, &mut parents, last_line)?;
            }
            other => {
                return Err(cx.err(
                    l.number,
                    kw.column,
                    K::Unexpected {
                        expected: "one of :version :name :units :documentation :root :bonedata :hierarchy".into(),
                        found: other.into(),
                    },
                ));
            }
        }
    }
    if !seen_root {
        return Err(cx.err(last_line, 0, K::MissingSection(":root")));
    }
    if !seen_bones {
        return Err(cx.err(last_line, 0, K::MissingSection(":bonedata")));
    }
    if !seen_hier {
        return Err(cx.err(last_line, 0, K::MissingSection(":hierarchy")));
    }
    if let Some(orphan) = sk.bones.iter().zip(&parents).find(|(_, p)| p.is_none()) {
        return Err(cx.err(last_line, 0, K::Hierarchy(format!("bone '{}' has no parent", orphan.0.name))));
    }
    for (b, p) in sk.bones.iter_mut().zip(parents) {
        b.parent = p.flatten();
    }
    sk.finish().map_err(|msg| cx.err(last_line, 0, K::Hierarchy(msg)))?;
    Ok(sk)
}

/// The lines of `:units`, from line `i` to the next section.
fn parse_units(cx: &Ctx<'_>, lines: &[Line<'_>], i: &mut usize, units: &mut Units) -> Result<(), ParseError> {
    while *i < lines.len() && !is_section(&lines[*i]) {
        let u = &lines[*i];
        *i += 1;
        let key = u.toks[0];
        let val = u
            .toks
            .get(1)
            .ok_or_else(|| cx.err(u.number, 0, K::Arity { keyword: key.text.into(), expected: 1, found: 0 }))?;
        match key.text {
            "mass" => units.mass = positive(cx, u.number, *val, "a mass unit of at least 1e-6")?,
            "length" => units.length = positive(cx, u.number, *val, "a length unit of at least 1e-6")?,
            "angle" => {
                units.angle = match val.text.to_ascii_lowercase().as_str() {
                    "deg" | "degrees" => AngleUnit::Deg,
                    "rad" | "radians" => AngleUnit::Rad,
                    _ => {
                        return Err(cx.err(
                            u.number,
                            val.column,
                            K::Unexpected { expected: "'deg' or 'rad'".into(), found: val.text.into() },
                        ));
                    }
                }
            }
            other => {
                return Err(cx.err(
                    u.number,
                    key.column,
                    K::Unexpected { expected: "'mass', 'length' or 'angle'".into(), found: other.into() },
                ));
            }
        }
    }
    Ok(())
}

/// The lines of `:root`, from line `i` to the next section.
fn parse_root(cx: &Ctx<'_>, lines: &[Line<'_>], i: &mut usize, root: &mut Root) -> Result<(), ParseError> {
    while *i < lines.len() && !is_section(&lines[*i]) {
        let r = &lines[*i];
        *i += 1;
        match r.toks[0].text {
            "order" => {
                let mut order = Vec::new();
                for t in &r.toks[1..] {
                    order.push(
                        Dof::parse(t.text).ok_or_else(|| cx.err(r.number, t.column, K::UnknownDof(t.text.into())))?,
                    );
                }
                check_unique_dofs(cx, r, &order)?;
                root.order = order;
            }
            "axis" => root.axis = axis_order(cx, r, 1)?,
            "position" => root.position = cx.nums::<3>(r, "a root position coordinate")?,
            "orientation" => {
                root.orientation_deg = cx.nums::<3>(r, "a root orientation angle")?;
            }
            other => {
                return Err(cx.err(
                    r.number,
                    r.toks[0].column,
                    K::Unexpected {
                        expected: "'order', 'axis', 'position' or 'orientation'".into(),
                        found: other.into(),
                    },
                ));
            }
        }
    }
    Ok(())
}

/// The bones of `:bonedata`, from line `i` to the next section.
fn parse_bonedata(
    cx: &Ctx<'_>,
    lines: &[Line<'_>],
    i: &mut usize,
    bones: &mut Vec<Bone>,
    index: &mut std::collections::HashMap<String, usize>,
    last_line: usize,
) -> Result<(), ParseError> {
    while *i < lines.len() && !is_section(&lines[*i]) {
        let b = &lines[*i];
        if bones.len() >= MAX_ASF_BONES {
            return Err(cx.err(
                b.number,
                0,
                K::Unexpected {
                    expected: format!("at most {MAX_ASF_BONES} bones"),
                    found: format!("bone {}", MAX_ASF_BONES + 1),
                },
            ));
        }
        if b.toks[0].text != "begin" {
            return Err(cx.err(
                b.number,
                b.toks[0].column,
                K::Unexpected { expected: "'begin'".into(), found: b.toks[0].text.into() },
            ));
        }
        *i += 1;
        let bone = parse_bone(cx, lines, i, b.number, last_line)?;
        if bone.name == "root" || index.contains_key(&bone.name) {
            return Err(cx.err(b.number, 0, K::DuplicateBone(bone.name)));
        }
        index.insert(bone.name.clone(), bones.len());
        bones.push(bone);
    }
    Ok(())
}

fn is_section(l: &Line<'_>) -> bool {
    l.toks[0].text.starts_with(':')
}

fn rest_of(l: &Line<'_>) -> String {
    l.toks[1..].iter().map(|t| t.text).collect::<Vec<_>>().join(" ")
}

fn positive(cx: &Ctx<'_>, line: usize, t: lex::Tok<'_>, what: &'static str) -> Result<f64, ParseError> {
    let v = cx.num(line, t, what)?;
    // Units are divided by: below 1e-6 the scale factor itself leaves the range of any file's numbers.
    if v < 1e-6 {
        return Err(cx.err(line, t.column, K::Unexpected { expected: what.into(), found: t.text.into() }));
    }
    Ok(v)
}

fn axis_order(cx: &Ctx<'_>, l: &Line<'_>, idx: usize) -> Result<AxisOrder, ParseError> {
    let t = l
        .toks
        .get(idx)
        .ok_or_else(|| cx.err(l.number, 0, K::UnexpectedEof { expected: "an axis order such as XYZ".into() }))?;
    AxisOrder::parse(t.text).ok_or_else(|| cx.err(l.number, t.column, K::UnknownAxisOrder(t.text.into())))
}

fn check_unique_dofs(cx: &Ctx<'_>, l: &Line<'_>, dofs: &[Dof]) -> Result<(), ParseError> {
    for (k, d) in dofs.iter().enumerate() {
        if dofs[..k].contains(d) {
            return Err(cx.err(
                l.number,
                l.toks[k + 1].column,
                K::Unexpected { expected: "each degree of freedom once".into(), found: d.as_str().into() },
            ));
        }
    }
    Ok(())
}

fn parse_bone(
    cx: &Ctx<'_>,
    lines: &[Line<'_>],
    i: &mut usize,
    begin_line: usize,
    last_line: usize,
) -> Result<Bone, ParseError> {
    let mut id = None;
    let mut name: Option<String> = None;
    let mut direction = None;
    let mut length = None;
    let mut axis = None;
    let mut dofs = Vec::new();
    let mut limits: Vec<(f64, f64)> = Vec::new();
    let mut dof_line = begin_line;
    loop {
        let Some(l) = lines.get(*i) else {
            return Err(cx.err(last_line, 0, K::UnexpectedEof { expected: "'end' closing the bone block".into() }));
        };
        *i += 1;
        let kw = l.toks[0];
        match kw.text {
            "end" => break,
            "id" => {
                let t = l
                    .toks
                    .get(1)
                    .ok_or_else(|| cx.err(l.number, 0, K::Arity { keyword: "id".into(), expected: 1, found: 0 }))?;
                id = Some(t.text.parse::<u32>().map_err(|_| {
                    cx.err(l.number, t.column, K::BadNumber { token: t.text.into(), expected: "a bone id" })
                })?);
            }
            "name" => {
                let t = l
                    .toks
                    .get(1)
                    .ok_or_else(|| cx.err(l.number, 0, K::Arity { keyword: "name".into(), expected: 1, found: 0 }))?;
                name = Some(t.text.to_owned());
            }
            "direction" => direction = Some(cx.nums::<3>(l, "a direction component")?),
            "length" => {
                let [v] = cx.nums::<1>(l, "a bone length")?;
                if v < 0.0 {
                    return Err(cx.err(
                        l.number,
                        l.toks[1].column,
                        K::Unexpected { expected: "a length >= 0".into(), found: l.toks[1].text.into() },
                    ));
                }
                length = Some(v);
            }
            "axis" => {
                if l.toks.len() != 5 {
                    return Err(cx.err(
                        l.number,
                        0,
                        K::Arity { keyword: "axis".into(), expected: 4, found: l.toks.len() - 1 },
                    ));
                }
                let mut a = [0.0; 3];
                for (v, t) in a.iter_mut().zip(&l.toks[1..4]) {
                    *v = cx.num(l.number, *t, "an axis angle")?;
                }
                axis = Some((a, axis_order(cx, l, 4)?));
            }
            "dof" => {
                dof_line = l.number;
                dofs.clear();
                for t in &l.toks[1..] {
                    dofs.push(
                        Dof::parse(t.text).ok_or_else(|| cx.err(l.number, t.column, K::UnknownDof(t.text.into())))?,
                    );
                }
                check_unique_dofs(cx, l, &dofs)?;
            }
            "limits" => limits = parse_limits(cx, lines, i, l)?,
            "bodymass" | "cofmass" => {}
            other => {
                return Err(cx.err(
                    l.number,
                    kw.column,
                    K::Unexpected {
                        expected: "one of id name direction length axis dof limits end".into(),
                        found: other.into(),
                    },
                ));
            }
        }
    }
    let name = name.ok_or_else(|| {
        cx.err(begin_line, 0, K::MissingField { bone: format!("(block at line {begin_line})"), field: "name" })
    })?;
    let missing = |field| cx.err(begin_line, 0, K::MissingField { bone: name.clone(), field });
    let direction = direction.ok_or_else(|| missing("direction"))?;
    let length = length.ok_or_else(|| missing("length"))?;
    let (axis_deg, axis_order) = axis.ok_or_else(|| missing("axis"))?;
    if !limits.is_empty() && limits.len() != dofs.len() {
        return Err(cx.err(dof_line, 0, K::LimitsCount { bone: name, expected: dofs.len(), found: limits.len() }));
    }
    Ok(Bone { id: id.unwrap_or(0), name, direction, length, axis_deg, axis_order, dofs, limits, parent: None })
}

/// A bone's `limits` line `l` and its continuation lines (from line `i`):
/// one `(min max)` pair per DOF.
fn parse_limits(cx: &Ctx<'_>, lines: &[Line<'_>], i: &mut usize, l: &Line<'_>) -> Result<Vec<(f64, f64)>, ParseError> {
    let mut vals: Vec<f64> = Vec::new();
    for t in &l.toks[1..] {
        vals.push(cx.num_or_inf(l.number, *t, "a limit", true)?);
    }
    // Continuation lines are the ones that start with '(' .
    while let Some(c) = lines.get(*i) {
        if !c.text.trim_start().starts_with('(') {
            break;
        }
        *i += 1;
        for t in &c.toks {
            vals.push(cx.num_or_inf(c.number, *t, "a limit", true)?);
        }
    }
    if !vals.len().is_multiple_of(2) {
        return Err(cx.err(
            l.number,
            0,
            K::Unexpected { expected: "limits as (min max) pairs".into(), found: format!("{} numbers", vals.len()) },
        ));
    }
    let limits: Vec<(f64, f64)> = vals.chunks_exact(2).map(|p| (p[0], p[1])).collect();
    if let Some(bad) = limits.iter().find(|(lo, hi)| lo > hi) {
        return Err(cx.err(
            l.number,
            0,
            K::Unexpected { expected: "limits with min <= max".into(), found: format!("({} {})", bad.0, bad.1) },
        ));
    }
    Ok(limits)
}

fn parse_hierarchy(
    cx: &Ctx<'_>,
    lines: &[Line<'_>],
    i: &mut usize,
    index: &std::collections::HashMap<String, usize>,
    parents: &mut [Option<Option<usize>>],
    last_line: usize,
) -> Result<(), ParseError> {
    let Some(b) = lines.get(*i) else {
        return Err(cx.err(last_line, 0, K::UnexpectedEof { expected: "'begin' of the hierarchy".into() }));
    };
    if b.toks[0].text != "begin" {
        return Err(cx.err(
            b.number,
            b.toks[0].column,
            K::Unexpected { expected: "'begin'".into(), found: b.toks[0].text.into() },
        ));
    }
    *i += 1;
    loop {
        let Some(l) = lines.get(*i) else {
            return Err(cx.err(last_line, 0, K::UnexpectedEof { expected: "'end' closing the hierarchy".into() }));
        };
        *i += 1;
        if l.toks[0].text == "end" {
            return Ok(());
        }
        let parent = match l.toks[0].text {
            "root" => None,
            n => Some(*index.get(n).ok_or_else(|| cx.err(l.number, l.toks[0].column, K::UnknownBone(n.into())))?),
        };
        for t in &l.toks[1..] {
            let c = *index.get(t.text).ok_or_else(|| cx.err(l.number, t.column, K::UnknownBone(t.text.into())))?;
            if parents[c].is_some() {
                return Err(cx.err(l.number, t.column, K::Hierarchy(format!("bone '{}' has two parents", t.text))));
            }
            parents[c] = Some(parent);
        }
    }
}

/// Writes a skeleton as ASF text that [`parse_asf`] reads back to the same
/// skeleton (angles in degrees; numbers in their shortest exact form).
pub fn write_asf(sk: &Skeleton) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("# ASF written by cpg-mocap\n:version 1.10\n");
    let _ = writeln!(s, ":name {}", if sk.name.trim().is_empty() { "skeleton" } else { sk.name.trim() });
    let _ = writeln!(s, ":units\n  mass {}\n  length {}\n  angle deg", sk.units.mass, sk.units.length);
    s.push_str(":documentation\n");
    for line in sk.documentation.lines() {
        // A line that would read as a section or a comment is indented text only.
        let line = line.trim_start_matches([':', '#']).trim();
        if !line.is_empty() {
            let _ = writeln!(s, "  {line}");
        }
    }
    let order: Vec<String> = sk.root.order.iter().map(|d| d.as_str().to_ascii_uppercase()).collect();
    let [px, py, pz] = sk.root.position;
    let [ox, oy, oz] = sk.root.orientation_deg;
    let _ = writeln!(
        s,
        ":root\n   order {}\n   axis {}\n   position {px} {py} {pz}\n   orientation {ox} {oy} {oz}",
        order.join(" "),
        sk.root.axis.as_string()
    );
    s.push_str(":bonedata\n");
    for (k, b) in sk.bones.iter().enumerate() {
        let [dx, dy, dz] = b.direction;
        let [ax, ay, az] = b.axis_deg;
        let _ = writeln!(
            s,
            "  begin\n     id {}\n     name {}\n     direction {dx} {dy} {dz}\n     length {}\n     axis {ax} {ay} {az} {}",
            if b.id == 0 { k as u32 + 1 } else { b.id },
            b.name,
            b.length,
            b.axis_order.as_string()
        );
        if !b.dofs.is_empty() {
            let dofs: Vec<&str> = b.dofs.iter().map(|d| d.as_str()).collect();
            let _ = writeln!(s, "    dof {}", dofs.join(" "));
            for (i, (lo, hi)) in b.limits.iter().enumerate() {
                let _ = writeln!(s, "    {}({lo} {hi})", if i == 0 { "limits " } else { "       " });
            }
        }
        s.push_str("  end\n");
    }
    s.push_str(":hierarchy\n  begin\n");
    let children = |p: Option<usize>| -> Vec<&str> {
        sk.bones.iter().filter(|b| b.parent == p).map(|b| b.name.as_str()).collect()
    };
    let top = children(None);
    if !top.is_empty() {
        let _ = writeln!(s, "    root {}", top.join(" "));
    }
    for (k, b) in sk.bones.iter().enumerate() {
        let c = children(Some(k));
        if !c.is_empty() {
            let _ = writeln!(s, "    {} {}", b.name, c.join(" "));
        }
    }
    s.push_str("  end\n");
    s
}

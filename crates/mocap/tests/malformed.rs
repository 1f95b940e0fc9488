//! A corpus of malformed ASF/AMC files written for these tests. Each must give
//! the expected error kind on the expected line, and none may panic.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_mocap::{ParseErrorKind as K, Skeleton, parse_amc, parse_asf};

const ASF: &str = include_str!("../test_data/tiny.asf");
const AMC: &str = include_str!("../test_data/tiny.amc");

fn skeleton() -> Skeleton {
    parse_asf("tiny.asf", ASF.as_bytes()).unwrap()
}

/// Replaces the first occurrence of `from` in the ASF text.
fn asf_with(from: &str, to: &str) -> String {
    assert!(ASF.contains(from), "fixture lacks {from:?}");
    ASF.replacen(from, to, 1)
}

fn amc_with(from: &str, to: &str) -> String {
    assert!(AMC.contains(from), "fixture lacks {from:?}");
    AMC.replacen(from, to, 1)
}

fn asf_err(text: &str) -> (K, usize) {
    match parse_asf("bad.asf", text.as_bytes()) {
        Ok(_) => panic!("accepted malformed ASF:\n{text}"),
        Err(e) => {
            assert!(e.to_string().starts_with(&format!("bad.asf:{}", e.line)), "{e}");
            (e.kind, e.line)
        }
    }
}

fn amc_err(text: &[u8]) -> (K, usize) {
    match parse_amc("bad.amc", text, &skeleton(), 120.0) {
        Ok(_) => panic!("accepted malformed AMC:\n{}", String::from_utf8_lossy(text)),
        Err(cpg_mocap::Error::Parse(e)) => (e.kind, e.line),
        Err(other) => panic!("not a parse error: {other}"),
    }
}

type Case<T> = (&'static str, T, fn(&K) -> bool, usize);

#[test]
fn fixtures_are_valid() {
    let sk = skeleton();
    assert_eq!(sk.bones.len(), 3);
    assert_eq!(sk.bones[1].limits[0], (-160.0, 20.0));
    let m = parse_amc("tiny.amc", AMC.as_bytes(), &sk, 120.0).unwrap();
    assert_eq!(m.n_frames(), 2);
    assert_eq!(
        m.channel_names(),
        [
            "root.tx", "root.ty", "root.tz", "root.rx", "root.ry", "root.rz", "femur.rx", "femur.ry", "femur.rz",
            "tibia.rx"
        ]
    );
    assert_eq!(m.column("femur.rx").unwrap(), [-10.0, -12.0]);
}

#[test]
fn malformed_asf_corpus() {
    let before_hierarchy = ASF.split(":hierarchy").next().unwrap();
    let cases: Vec<Case<String>> = vec![
        ("empty", String::new(), |k| matches!(k, K::Empty { .. }), 1),
        ("comments only", "# nothing\n\n".into(), |k| matches!(k, K::Empty { .. }), 1),
        ("text before a section", format!("hello\n{ASF}"), |k| matches!(k, K::Unexpected { .. }), 1),
        ("unknown section", asf_with(":documentation", ":docs"), |k| matches!(k, K::Unexpected { .. }), 8),
        ("bad length unit", asf_with("length 0.45", "length abc"), |k| matches!(k, K::BadNumber { .. }), 6),
        ("zero length unit", asf_with("length 0.45", "length 0"), |k| matches!(k, K::Unexpected { .. }), 6),
        ("bad angle unit", asf_with("angle deg", "angle grad"), |k| matches!(k, K::Unexpected { .. }), 7),
        (
            "unknown root dof",
            asf_with("order TX TY TZ RX RY RZ", "order TX TY TQ"),
            |k| matches!(k, K::UnknownDof(_)),
            11,
        ),
        ("bad axis order", asf_with("axis XYZ", "axis XXY"), |k| matches!(k, K::UnknownAxisOrder(_)), 12),
        (
            "short position",
            asf_with("position 0 0 0", "position 0 0"),
            |k| matches!(k, K::Arity { expected: 3, found: 2, .. }),
            13,
        ),
        ("nan direction", asf_with("direction 0 -1 0", "direction 0 NaN 0"), |k| matches!(k, K::NonFinite { .. }), 19),
        ("huge number", asf_with("length 2.0", "length 1e999"), |k| matches!(k, K::NonFinite { .. }), 20),
        ("negative length", asf_with("length 2.0", "length -2.0"), |k| matches!(k, K::Unexpected { .. }), 20),
        ("bad dof", asf_with("dof rx ry rz", "dof rx ry rw"), |k| matches!(k, K::UnknownDof(_)), 29),
        ("repeated dof", asf_with("dof rx ry rz", "dof rx rx rz"), |k| matches!(k, K::Unexpected { .. }), 29),
        (
            "limits count",
            asf_with("           (-60.0 70.0)\n", ""),
            |k| matches!(k, K::LimitsCount { expected: 3, found: 2, .. }),
            29,
        ),
        ("odd limits", asf_with("(-60.0 70.0)", "(-60.0)"), |k| matches!(k, K::Unexpected { .. }), 30),
        ("inverted limits", asf_with("(-10.0 170.0)", "(170.0 -10.0)"), |k| matches!(k, K::Unexpected { .. }), 41),
        ("missing name", asf_with("     name hip\n", ""), |k| matches!(k, K::MissingField { field: "name", .. }), 16),
        (
            "missing axis",
            asf_with("     axis 0 0 0  XYZ\n", ""),
            |k| matches!(k, K::MissingField { field: "axis", .. }),
            16,
        ),
        ("duplicate bone", asf_with("name tibia", "name femur"), |k| matches!(k, K::DuplicateBone(_)), 34),
        ("unknown bone field", asf_with("     id 2\n", "     colour red\n"), |k| matches!(k, K::Unexpected { .. }), 24),
        (
            "unterminated bone",
            before_hierarchy.replace("limits (-10.0 170.0)\n  end", "limits (-10.0 170.0)"),
            |k| matches!(k, K::UnexpectedEof { .. }),
            0,
        ),
        ("unknown hierarchy bone", asf_with("femur tibia", "femur fibula"), |k| matches!(k, K::UnknownBone(_)), 47),
        ("two parents", asf_with("femur tibia", "femur tibia\n    hip tibia"), |k| matches!(k, K::Hierarchy(_)), 48),
        ("orphan bone", asf_with("    femur tibia\n", ""), |k| matches!(k, K::Hierarchy(_)), 0),
        (
            "cycle",
            asf_with("root hip\n    hip femur", "root hip\n    tibia femur"),
            |k| matches!(k, K::Hierarchy(_)),
            0,
        ),
        ("no hierarchy", before_hierarchy.to_owned(), |k| matches!(k, K::MissingSection(":hierarchy")), 0),
        (
            "unterminated hierarchy",
            format!("{before_hierarchy}:hierarchy\n  begin\n    root hip\n"),
            |k| matches!(k, K::UnexpectedEof { .. }),
            0,
        ),
    ];
    for (name, text, want, line) in cases {
        let (kind, got_line) = asf_err(&text);
        assert!(want(&kind), "{name}: unexpected error kind {kind:?}");
        // Errors about the whole file point at its last line.
        let want_line = if line == 0 { text.split('\n').count() } else { line };
        assert_eq!(got_line, want_line, "{name}: {kind}");
    }
}

#[test]
fn malformed_amc_corpus() {
    let cases: Vec<Case<Vec<u8>>> = vec![
        ("empty", Vec::new(), |k| matches!(k, K::Empty { .. }), 1),
        (
            "binary garbage",
            vec![0xff, 0xfe, 0x00, 0x12, b'\n', 0x80],
            |k| matches!(k, K::NotUtf8 { byte_offset: 0 }),
            1,
        ),
        ("garbage after text", [AMC.as_bytes(), &[0xc3, 0x28]].concat(), |k| matches!(k, K::NotUtf8 { .. }), 12),
        ("header only", b":FULLY-SPECIFIED\n:DEGREES\n".to_vec(), |k| matches!(k, K::NoFrames), 3),
        ("bad header", amc_with(":DEGREES", ":GRADIANS").into_bytes(), |k| matches!(k, K::Unexpected { .. }), 3),
        ("bone before frame", amc_with("1\r\nroot", "root").into_bytes(), |k| matches!(k, K::Unexpected { .. }), 4),
        (
            "wrong value count",
            amc_with("femur -10 2 3", "femur -10 2").into_bytes(),
            |k| matches!(k, K::WrongValueCount { found: 2, .. }),
            6,
        ),
        (
            "too many values",
            amc_with("tibia 20", "tibia 20 1").into_bytes(),
            |k| matches!(k, K::WrongValueCount { found: 2, .. }),
            7,
        ),
        ("unknown bone", amc_with("tibia 20", "fibula 20").into_bytes(), |k| matches!(k, K::UnknownBone(_)), 7),
        (
            "bone without dofs",
            amc_with("tibia 20", "tibia 20\r\nhip 1").into_bytes(),
            |k| matches!(k, K::NoDofBone(_)),
            8,
        ),
        ("non-numeric value", amc_with("tibia 25", "tibia x25").into_bytes(), |k| matches!(k, K::BadNumber { .. }), 11),
        ("nan value", amc_with("tibia 25", "tibia nan").into_bytes(), |k| matches!(k, K::NonFinite { .. }), 11),
        ("inf value", amc_with("tibia 25", "tibia -inf").into_bytes(), |k| matches!(k, K::NonFinite { .. }), 11),
        (
            "overflowing value",
            amc_with("tibia 25", "tibia 1e400").into_bytes(),
            |k| matches!(k, K::NonFinite { .. }),
            11,
        ),
        (
            "skipped frame",
            amc_with("2\r\n", "3\r\n").into_bytes(),
            |k| matches!(k, K::FrameNumber { expected: 2, found: 3 }),
            8,
        ),
        (
            "repeated frame",
            amc_with("2\r\n", "1\r\n").into_bytes(),
            |k| matches!(k, K::FrameNumber { expected: 2, found: 1 }),
            8,
        ),
        (
            "huge frame number",
            amc_with("2\r\n", "99999999999999999999999\r\n").into_bytes(),
            |k| matches!(k, K::BadNumber { .. }),
            8,
        ),
        (
            "duplicate bone in frame",
            amc_with("tibia 20", "tibia 20\r\ntibia 21").into_bytes(),
            |k| matches!(k, K::DuplicateInFrame { frame: 1, .. }),
            8,
        ),
        (
            "missing bone in last frame",
            AMC.trim_end().rsplit_once('\n').unwrap().0.as_bytes().to_vec(),
            |k| matches!(k, K::MissingInFrame { frame: 2, .. }),
            8,
        ),
        (
            "missing bone in first frame",
            amc_with("tibia 20\r\n", "").into_bytes(),
            |k| matches!(k, K::MissingInFrame { frame: 1, .. }),
            4,
        ),
        (
            "truncated line",
            AMC.as_bytes()[..AMC.len() - 5].to_vec(),
            |k| matches!(k, K::WrongValueCount { found: 0, .. }),
            11,
        ),
        ("frame number with junk", amc_with("2\r\n", "2 x\r\n").into_bytes(), |k| matches!(k, K::Unexpected { .. }), 8),
    ];
    for (name, bytes, want, line) in cases {
        let (kind, got_line) = amc_err(&bytes);
        assert!(want(&kind), "{name}: unexpected error kind {kind:?}");
        assert_eq!(got_line, line, "{name}: {kind}");
    }
}

#[test]
fn error_message_names_file_line_and_expectation() {
    let text = amc_with("femur -10 2 3", "femur -10 2");
    let err = parse_amc("35_01.amc", text.as_bytes(), &skeleton(), 120.0).unwrap_err();
    assert_eq!(err.to_string(), "35_01.amc:6:1: bone 'femur' has 2 values, skeleton declares 3 (rx ry rz)");
}

#[test]
fn radians_are_converted_to_degrees() {
    let text = amc_with(":DEGREES", ":RADIANS").replace("tibia 20", "tibia 1");
    let m = parse_amc("r.amc", text.as_bytes(), &skeleton(), 120.0).unwrap();
    assert!((m.column("tibia.rx").unwrap()[0] - 57.295_779_513_082_32).abs() < 1e-12);
    assert_eq!(m.column("root.tx").unwrap()[0], 1.0, "translations are not angles");
}

#[test]
fn lf_and_crlf_parse_alike() {
    let sk = skeleton();
    let crlf = parse_amc("a.amc", AMC.as_bytes(), &sk, 120.0).unwrap();
    let lf = parse_amc("a.amc", AMC.replace("\r\n", "\n").as_bytes(), &sk, 120.0).unwrap();
    assert_eq!(crlf, lf);
}

#[test]
fn a_line_of_parentheses_is_skipped_not_a_crash() {
    let text = asf_with(":documentation\n", ":documentation\n(\n");
    assert!(parse_asf("p.asf", text.as_bytes()).is_ok());
}

/// A chain of `n` bones, each the child of the one before, each with one
/// rotation; and an AMC of `frames` frames for it.
fn chain(n: usize, frames: usize) -> (String, String) {
    let mut asf = String::from(
        ":version 1.10\n:name chain\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n:bonedata\n",
    );
    for i in 0..n {
        asf.push_str(&format!(
            "  begin\n    id {}\n    name b{i}\n    direction 0 1 0\n    length 1\n    axis 0 0 0 XYZ\n    dof rx\n  end\n",
            i + 1
        ));
    }
    asf.push_str(":hierarchy\n  begin\n    root b0\n");
    for i in 1..n {
        asf.push_str(&format!("    b{} b{i}\n", i - 1));
    }
    asf.push_str("  end\n");
    let mut amc = String::from(":FULLY-SPECIFIED\n:DEGREES\n");
    for f in 1..=frames {
        amc.push_str(&format!("{f}\nroot 0 0 0 0 0 0\n"));
        for i in 0..n {
            amc.push_str(&format!("b{i} 1\n"));
        }
    }
    (asf, amc)
}

/// An ASF of 100,000 bones once took over two minutes (a quadratic name
/// check, and no cap where BVH has one): bones beyond the cap are refused at
/// the first one, naming its line; a skeleton at the cap parses, its AMC too,
/// with every lookup by name in constant time.
#[test]
fn bones_beyond_the_cap_are_refused_at_the_first_and_the_cap_itself_parses() {
    let (asf, _) = chain(cpg_mocap::MAX_ASF_BONES + 1, 0);
    let (kind, line) = asf_err(&asf);
    assert!(matches!(&kind, K::Unexpected { expected, .. } if expected.contains("at most 10000 bones")), "{kind:?}");
    assert_eq!(line, 12 + 8 * cpg_mocap::MAX_ASF_BONES + 1, "the line of the bone beyond the cap");
    let (asf, amc) = chain(cpg_mocap::MAX_ASF_BONES, 2);
    let sk = parse_asf("chain.asf", asf.as_bytes()).unwrap();
    assert_eq!(sk.bones.len(), cpg_mocap::MAX_ASF_BONES);
    assert_eq!(sk.topological_order().len(), sk.bones.len());
    assert_eq!(sk.bones[9_999].parent, Some(9_998));
    let m = parse_amc("chain.amc", amc.as_bytes(), &sk, 120.0).unwrap();
    assert_eq!((m.n_frames(), m.n_channels()), (2, 6 + cpg_mocap::MAX_ASF_BONES));
}

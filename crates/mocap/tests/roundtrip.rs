//! Property tests: the AMC writer and parser are inverses, motion utilities
//! keep their algebra, and no input makes the parsers panic.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_mocap::{Channel, Motion, Skeleton, ZScore, parse_amc, parse_asf, write_amc};
use proptest::prelude::*;

const ASF: &str = include_str!("../test_data/tiny.asf");
const AMC: &str = include_str!("../test_data/tiny.amc");

fn skeleton() -> Skeleton {
    parse_asf("tiny.asf", ASF.as_bytes()).unwrap()
}

fn full_channels(sk: &Skeleton) -> Vec<Channel> {
    let mut ch: Vec<Channel> = sk.root.order.iter().map(|&dof| Channel { bone: "root".into(), dof }).collect();
    for b in &sk.bones {
        ch.extend(b.dofs.iter().map(|&dof| Channel { bone: b.name.clone(), dof }));
    }
    ch
}

/// Values spanning every magnitude an AMC file may hold (up to ±`MAX_MAGNITUDE`), down to subnormal-adjacent ones.
fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        -360.0..360.0f64,
        (-cpg_mocap::MAX_MAGNITUDE..=cpg_mocap::MAX_MAGNITUDE),
        (-1e-300..1e-300f64),
        Just(cpg_mocap::MAX_MAGNITUDE),
        Just(0.0),
        Just(-0.0),
    ]
}

/// Beyond the range the parser reads, writing refuses instead of writing a file that cannot be read.
#[test]
fn values_beyond_the_readable_range_are_not_written() {
    let sk = skeleton();
    let ch = full_channels(&sk);
    let mut values = vec![1.0; ch.len()];
    values[3] = 1e300;
    let m = Motion::new(ch, values, 120.0).unwrap();
    let e = write_amc(&sk, &m).unwrap_err().to_string();
    assert!(e.contains("frame 1") && e.contains("1e300"), "{e}");
}

proptest! {
    #[test]
    fn amc_write_parse_round_trip(frames in 1usize..12, seed in prop::collection::vec(value(), 10 * 12)) {
        let sk = skeleton();
        let ch = full_channels(&sk);
        let values = seed[..frames * ch.len()].to_vec();
        let m = Motion::new(ch, values, 120.0).unwrap();
        let text = write_amc(&sk, &m).unwrap();
        let back = parse_amc("w.amc", text.as_bytes(), &sk, 120.0).unwrap();
        // Bit-exact, -0.0 included.
        prop_assert_eq!(back.channels(), m.channels());
        for (a, b) in back.values().iter().zip(m.values()) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn parsers_never_panic_on_mutated_files(pos in 0usize..400, len in 0usize..20, junk in prop::collection::vec(any::<u8>(), 0..20)) {
        for base in [ASF.as_bytes(), AMC.as_bytes()] {
            let p = pos.min(base.len());
            let end = (p + len).min(base.len());
            let mutated = [&base[..p], &junk[..], &base[end..]].concat();
            let _ = parse_asf("m.asf", &mutated);
            let _ = parse_amc("m.amc", &mutated, &skeleton(), 120.0);
            let _ = parse_amc("m.amc", &base[..p], &skeleton(), 120.0);
        }
    }

    #[test]
    fn zscore_inverts(values in prop::collection::vec(-100.0..100.0f64, 4..40)) {
        let n = values.len() / 2 * 2;
        let ch = vec![Channel::parse("a.rx").unwrap(), Channel::parse("b.ry").unwrap()];
        let m = Motion::new(ch, values[..n].to_vec(), 60.0).unwrap();
        if let Ok(z) = ZScore::fit(&m) {
            let back = z.invert(&z.apply(&m).unwrap()).unwrap();
            for (a, b) in back.values().iter().zip(m.values()) {
                prop_assert!((a - b).abs() <= 1e-9 * (1.0 + b.abs()));
            }
        }
    }
}

fn ramp(n: usize) -> Motion {
    Motion::new(vec![Channel::parse("x.rx").unwrap()], (0..n).map(|k| k as f64).collect(), 120.0).unwrap()
}

#[test]
fn resample_at_constant_rate_interpolates_linearly() {
    let m = ramp(10);
    let r = m.resample_by_rate(&[0.5; 5], 0.0, false).unwrap();
    assert_eq!(r.values(), [0.0, 0.5, 1.0, 1.5, 2.0]);
    let fast = m.resample_by_rate(&[2.0; 4], 1.0, false).unwrap();
    assert_eq!(fast.values(), [1.0, 3.0, 5.0, 7.0]);
    assert!(m.resample_by_rate(&[3.0; 5], 0.0, false).is_err(), "reads past the end");
}

#[test]
fn periodic_resampling_wraps_through_the_seam() {
    let m = ramp(4); // loop 0 1 2 3 | 0 1 ...
    let r = m.resample_by_rate(&[1.5; 4], 0.0, true).unwrap();
    // positions 0, 1.5, 3.0, 4.5 -> 0, 1.5, 3, (between frame 0 and 1) 0.5
    assert_eq!(r.values(), [0.0, 1.5, 3.0, 0.5]);
    let seam = m.resample_by_rate(&[3.5, 1.0], 0.0, true).unwrap();
    assert_eq!(seam.values(), [0.0, 1.5], "position 3.5 lies halfway between the last and the first frame");
    assert!(m.resample_by_rate(&[1.0, f64::NAN], 0.0, true).is_err());
    assert!(m.resample_by_rate(&[1.0, -1.0], 0.0, true).is_err());
}

#[test]
fn select_slice_concat_repeat() {
    let sk = skeleton();
    let m = parse_amc("tiny.amc", AMC.as_bytes(), &sk, 120.0).unwrap();
    let s = m.select(&["tibia.rx", "femur.rx"]).unwrap();
    assert_eq!(s.values(), [20.0, -10.0, 25.0, -12.0]);
    let err = m.select(&["femur.rq"]).unwrap_err().to_string();
    assert!(err.contains("unknown channel 'femur.rq'") && err.contains("femur.rx"), "{err}");
    let two = s.slice(1, 2).unwrap().concat(&s.slice(0, 1).unwrap()).unwrap();
    assert_eq!(two.values(), [25.0, -12.0, 20.0, -10.0]);
    assert_eq!(s.repeat(3).unwrap().n_frames(), 6);
    assert!(s.slice(1, 1).is_err());
    assert!(s.concat(&m).is_err());
    assert!(ZScore::fit(&m).is_err(), "root.ry is constant in the fixture");
}

#[test]
fn a_channel_that_never_moves_is_held_in_its_own_units() {
    let sk = skeleton();
    let m = parse_amc("tiny.amc", AMC.as_bytes(), &sk, 120.0).unwrap();
    let (z, still) = ZScore::fit_holding_still(&m);
    let names = m.channel_names();
    let ry = names.iter().position(|c| c == "root.ry").unwrap();
    assert!(still.contains(&ry), "root.ry is constant in the fixture: {still:?}");
    assert!(!still.contains(&names.iter().position(|c| c == "femur.rx").unwrap()));
    assert_eq!(z.std[ry], 1.0);
    let n = z.apply(&m).unwrap();
    assert!((0..n.n_frames()).all(|f| n.frame(f)[ry] == 0.0), "a still channel normalises to 0");
    assert_eq!(z.invert(&n).unwrap().values(), m.values(), "and comes back as it was");
}

#[test]
fn motion_rejects_non_finite_values() {
    let ch = vec![Channel::parse("x.rx").unwrap()];
    assert!(Motion::new(ch.clone(), vec![1.0, f64::NAN], 120.0).is_err());
    assert!(Motion::new(ch.clone(), vec![1.0], 0.0).is_err());
    assert!(Motion::new(ch, vec![1.0], f64::INFINITY).is_err());
}

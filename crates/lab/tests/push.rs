//! How each family answers a push, by the one recovery measure of `cpg_lab::measure`.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::f64::consts::PI;

use cpg_centralized::{Basis, CentralizedNet};
use cpg_compare::{CentralizedCpg, Clock, DmpCpg};
use cpg_dmp::{DmpConfig, RhythmicDmp};
use cpg_lab::experiment::families::held_runs;
use cpg_lab::measure::recovery;

const RATE: f64 = 120.0;

/// 1.2 Hz with a harmonic: one period is 100 frames.
fn rhythm(t: usize) -> Vec<f64> {
    (0..t)
        .map(|k| {
            let s = 2.0 * PI * 1.2 * k as f64 / RATE;
            s.sin() + 0.3 * (2.0 * s + 0.5).sin()
        })
        .collect()
}

#[test]
fn clocks_are_back_at_once_the_dmp_later_both_in_phase() {
    let x = rhythm(400);
    let cycle = x[..100].to_vec();
    let net = CentralizedNet::fit(vec![2.0 * PI * 1.2], 16, Basis::Rbf { b: 2.0 }, &x, 1, RATE).unwrap();
    let (at, hold, total) = (240, 6, 240 + 6 + 2000);
    // Held at +3 for 50 ms (6 steps) after 2 s.
    let c = CentralizedCpg::new(net, Clock::Phase, RATE).unwrap();
    let (a, b) = held_runs(&c, &[3.0], at, hold, total).unwrap();
    let r_clock = recovery(&a, &b, 1, &cycle, at + hold, RATE).unwrap();
    // A clock-driven network has nothing to remember: from the first window
    // after the release it is on the orbit and on its twin.
    assert_eq!(r_clock.orbit_s, Some(0.0));
    assert_eq!(r_clock.twin_s, Some(0.0));
    assert!(r_clock.phase_shift_cycles.abs() < 0.005);
    let dmp = RhythmicDmp::imitate(DmpConfig::pydmps(100, 2.0 * PI / 100.0), &cycle, 1).unwrap();
    let dg = DmpCpg::new(dmp, 1.0, 1.0 / RATE).unwrap();
    let (a, b) = held_runs(&dg, &[3.0], at, hold, total).unwrap();
    let r_dmp = recovery(&a, &b, 1, &cycle, at + hold, RATE).unwrap();
    // The DMP's spring–damper pulls back to the same clock: later, but in phase.
    let rd = r_dmp.twin_s.unwrap();
    assert!(rd > 0.0 && rd < 2.0, "DMP back on its twin after {rd} s");
    assert!(r_dmp.orbit_s.unwrap() <= rd + 1e-12, "on the orbit no later than on the twin: {r_dmp:?}");
    assert!(r_dmp.phase_shift_cycles.abs() < 0.005);
    // Too short a run after the release is refused.
    assert!(recovery(&a[..300], &b[..300], 1, &cycle, 246, RATE).is_err());
}

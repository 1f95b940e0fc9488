//! Centralized networks on signals whose answer is known.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::f64::consts::PI;

use cpg_centralized::*;

const RATE: f64 = 120.0;

/// `T × 2` samples: coordinate 0 = sin(2π f1 t) + 0.4 sin(2π f2 t + 1), coordinate 1 = cos(2π f1 t) − 0.3 cos(2π f2 t).
fn signal(t: usize, f1: f64, f2: f64) -> Vec<f64> {
    (0..t)
        .flat_map(|k| {
            let s = k as f64 / RATE;
            [
                (2.0 * PI * f1 * s).sin() + 0.4 * (2.0 * PI * f2 * s + 1.0).sin(),
                (2.0 * PI * f1 * s).cos() - 0.3 * (2.0 * PI * f2 * s).cos(),
            ]
        })
        .collect()
}

fn rel_err(net: &CentralizedNet, x: &[f64]) -> f64 {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    let var: f64 = x.iter().map(|v| (v - m).powi(2)).sum();
    (net.rss(x, RATE) / var).sqrt()
}

#[test]
fn one_center_fits_a_periodic_signal_and_finds_its_frequency() {
    // Harmonics 0.9 and 1.8 Hz: periodic with period 1/0.9 s.
    let x = signal(1300, 0.9, 1.8);
    let net = CentralizedNet::fit(vec![2.0 * PI * 0.9], 25, Basis::Rbf { b: 2.0 }, &x, 2, RATE).unwrap();
    let e = rel_err(&net, &x);
    assert!(e < 0.01, "relative error {e}");
    let grid: Vec<f64> = (2..=20).map(|k| k as f64 * 0.1).collect();
    let w = search_frequencies(1, &grid, 25, Basis::Rbf { b: 2.0 }, &x[..600], 2, RATE).unwrap();
    let f = w[0] / (2.0 * PI);
    assert!((f - 0.9).abs() < 0.01, "found {f} Hz");
}

#[test]
fn two_centers_beat_one_on_a_quasi_periodic_signal() {
    // Incommensurate 0.7 and 1.13 Hz over 10.8 s: one clock cannot represent it.
    let x = signal(1300, 0.7, 1.13);
    let one = CentralizedNet::fit(vec![2.0 * PI * 0.7], 49, Basis::Rbf { b: 2.0 }, &x, 2, RATE).unwrap();
    let two =
        CentralizedNet::fit(vec![2.0 * PI * 0.7, 2.0 * PI * 1.13], 49, Basis::Rbf { b: 1.0 }, &x, 2, RATE).unwrap();
    let (e1, e2) = (rel_err(&one, &x), rel_err(&two, &x));
    assert!(e1 > 0.2, "one center fits too well: {e1}");
    assert!(e2 < 0.05 && e2 < e1 / 5.0, "two centers: {e2} vs one: {e1}");
    // AICc with n samples per coordinate and k = N + 1 + M prefers the better model.
    let n = 1300;
    assert!(aicc(two.rss(&x, RATE) / 2.0, n, 49 + 1 + 2) < aicc(one.rss(&x, RATE) / 2.0, n, 49 + 1 + 1));
    // Frequencies searched on the first coordinate alone transfer to the other
    // ("learned from a few markers"). Over a finite window two slow centers can
    // act as a non-repeating clock, so the search need not return 0.7 and
    // 1.13 Hz: what it must return is frequencies that serve every coordinate.
    let grid: Vec<f64> = (3..=15).map(|k| k as f64 * 0.1).collect();
    let first: Vec<f64> = x.iter().step_by(2).copied().collect();
    let second: Vec<f64> = x.iter().skip(1).step_by(2).copied().collect();
    let w = search_frequencies(2, &grid, 49, Basis::Rbf { b: 1.0 }, &first, 1, RATE).unwrap();
    let transferred = CentralizedNet::fit(w, 49, Basis::Rbf { b: 1.0 }, &second, 1, RATE).unwrap();
    let e = rel_err(&transferred, &second);
    assert!(e < 0.05, "second coordinate with the first's frequencies: relative error {e}");
}

#[test]
fn harmonic_and_polynomial_bases_work() {
    let x = signal(600, 0.9, 1.8);
    let h = CentralizedNet::fit(vec![2.0 * PI * 0.9], 4, Basis::Harmonic { b: 1.0 }, &x, 2, RATE).unwrap();
    // cos(j φ) cannot make the sine parts: a harmonic basis of cosines fits only the even part.
    assert!(rel_err(&h, &x) < 0.9);
    let ramp: Vec<f64> = (0..300).map(|k| 2.0 + 0.5 * k as f64 / RATE).collect();
    let p = CentralizedNet::fit(vec![1.0], 3, Basis::Polynomial, &ramp, 1, RATE).unwrap();
    assert!(p.rss(&ramp, RATE) < 1e-12, "a line is a degree-1 polynomial");
}

#[test]
fn switched_networks_are_continuous_at_the_boundaries() {
    let a = signal(480, 0.9, 1.8);
    let b = signal(480, 1.5, 3.0);
    let na = CentralizedNet::fit(vec![2.0 * PI * 0.9], 25, Basis::Rbf { b: 2.0 }, &a, 2, RATE).unwrap();
    let nb = CentralizedNet::fit(vec![2.0 * PI * 1.5], 25, Basis::Rbf { b: 2.0 }, &b, 2, RATE).unwrap();
    let sw = Switched { boundaries_s: vec![0.0, 4.0, 8.0], beta: 20.0, nets: vec![na, nb] };
    let mut w = [0.0; 2];
    for k in 0..960 {
        sw.windows(k as f64 / RATE, &mut w);
        assert!((w[0] + w[1] - 1.0).abs() < 1e-12, "windows sum to 1");
    }
    let y = sw.generate(960, RATE);
    let steps: Vec<f64> = (1..960).map(|k| (y[2 * k] - y[2 * k - 2]).abs()).collect();
    let typical = steps[..400].iter().copied().fold(0.0, f64::max);
    let at_switch = steps[440..520].iter().copied().fold(0.0, f64::max);
    // Segment b runs at 1.5 Hz: its steps are up to 1.7× larger than a's; the glue adds no jump beyond that.
    assert!(at_switch < 2.5 * typical, "largest step at the switch {at_switch} vs {typical}");
}

#[test]
fn aicc_and_bad_input() {
    assert_eq!(aicc(1.0, 10, 9), f64::INFINITY);
    assert!(aicc(1.0, 100, 5) < aicc(2.0, 100, 5));
    assert!(CentralizedNet::fit(vec![1.0], 0, Basis::Rbf { b: 1.0 }, &[0.0, 1.0], 1, RATE).is_err());
    assert!(CentralizedNet::fit(vec![1.0], 3, Basis::Rbf { b: 1.0 }, &[0.0, f64::NAN], 1, RATE).is_err());
    assert!(CentralizedNet::fit(vec![], 3, Basis::Rbf { b: 1.0 }, &[0.0, 1.0], 1, RATE).is_err());
    assert!(search_frequencies(3, &[1.0, 2.0], 4, Basis::Rbf { b: 1.0 }, &[0.0, 1.0, 0.0], 1, RATE).is_err());
}

#[test]
fn hopf_centers_follow_the_phase_form_and_return_to_their_cycle() {
    let x = signal(600, 0.7, 1.13);
    let net =
        CentralizedNet::fit(vec![2.0 * PI * 0.7, 2.0 * PI * 1.13], 49, Basis::Rbf { b: 2.6 }, &x, 2, 60.0).unwrap();
    let mut hopf = HopfCenters::new(net.omega_rad_s.clone());
    let (mut sat_a, mut sat_b, mut ph) = (vec![0.0; 49], vec![0.0; 49], vec![0.0; 2]);
    let mut worst: f64 = 0.0;
    for k in 1..=600 {
        hopf.advance(1.0 / 60.0);
        hopf.phases(&mut ph);
        net.satellites_at_phases(&ph, &mut sat_a);
        net.satellites(k as f64 / 60.0, &mut sat_b);
        worst = sat_a.iter().zip(&sat_b).map(|(a, b)| (a - b).abs()).fold(worst, f64::max);
    }
    // On the unit circle the closed-form advance is the phase form, up to rounding.
    assert!(worst < 1e-9, "Hopf vs phase form: {worst}");
    // Pushed to half the radius at a quarter turn, the center keeps that phase
    // and returns to its cycle (radial rate 2/s: 1 % left after about 2.5 s).
    hopf.phases(&mut ph);
    let before = ph[0];
    hopf.set_state(0, [0.0, 0.5]);
    hopf.phases(&mut ph);
    let jump = (ph[0] - before).rem_euclid(2.0 * PI);
    assert!(hopf.off_cycle() > 0.49);
    for _ in 0..180 {
        hopf.advance(1.0 / 60.0);
    }
    assert!(hopf.off_cycle() < 0.01, "still {:.4} off the cycle after 3 s", hopf.off_cycle());
    assert!(jump > 0.0 && jump < 2.0 * PI);
}

#[test]
fn the_residual_of_a_fit_is_the_residual_of_its_output() {
    let x = signal(900, 0.7, 1.13);
    for (w, n, b) in [(vec![2.0 * PI * 0.7], 25, 2.0), (vec![2.0 * PI * 0.7, 2.0 * PI * 1.13], 49, 1.0)] {
        let (net, rss) = CentralizedNet::fit_rss(w.clone(), n, Basis::Rbf { b }, &x, 2, RATE).unwrap();
        let again = net.rss(&x, RATE);
        assert!((rss - again).abs() <= 1e-9 * again.max(1e-12), "{rss} vs {again}");
        assert_eq!(net, CentralizedNet::fit(w, n, Basis::Rbf { b }, &x, 2, RATE).unwrap());
    }
}

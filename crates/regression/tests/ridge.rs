//! Ridge regression and the sweep against their definitions.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_regression::{Error, PenaltyGrid, RidgePath, nmse, ridge_direct, sweep, sweep_chunked};
use faer::Mat;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A noisy linear problem with correlated features (like reservoir states).
fn problem(t: usize, n: usize, d: usize, seed: u64) -> (Mat<f64>, Mat<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let base = Mat::from_fn(t, 3, |_, _| rng.random_range(-1.0..1.0));
    let mix = Mat::from_fn(3, n, |_, _| rng.random_range(-1.0..1.0));
    let x = Mat::from_fn(t, n, |i, j| {
        let s: f64 = (0..3).map(|k| base[(i, k)] * mix[(k, j)]).sum();
        (s + 0.05 * rng.random_range(-1.0..1.0)).tanh() + 0.3
    });
    let w = Mat::from_fn(n, d, |_, _| rng.random_range(-1.0..1.0));
    let y = Mat::from_fn(t, d, |i, j| {
        (0..n).map(|k| x[(i, k)] * w[(k, j)]).sum::<f64>() + 2.0 + 0.1 * rng.random_range(-1.0..1.0)
    });
    (x, y)
}

#[test]
fn solution_satisfies_the_normal_equations() {
    let (x, y) = problem(400, 40, 3, 1);
    let path = RidgePath::new(x.as_ref(), y.as_ref()).unwrap();
    for &alpha in &[1e-6, 1e-2, 1.0, 10.0] {
        let r = path.solve(alpha).unwrap();
        // Centred data: (X̃ᵀX̃ + αI) w = X̃ᵀỹ for each output.
        let n = x.ncols();
        let xm: Vec<f64> = (0..n).map(|j| (0..x.nrows()).map(|i| x[(i, j)]).sum::<f64>() / x.nrows() as f64).collect();
        for o in 0..y.ncols() {
            let ym = (0..y.nrows()).map(|i| y[(i, o)]).sum::<f64>() / y.nrows() as f64;
            let w = &r.weights[o * n..(o + 1) * n];
            let mut worst: f64 = 0.0;
            let mut scale: f64 = 0.0;
            for a in 0..n {
                let mut lhs = alpha * w[a];
                let mut rhs = 0.0;
                for i in 0..x.nrows() {
                    let xa = x[(i, a)] - xm[a];
                    let pred: f64 = (0..n).map(|b| (x[(i, b)] - xm[b]) * w[b]).sum();
                    lhs += xa * pred;
                    rhs += xa * (y[(i, o)] - ym);
                }
                worst = worst.max((lhs - rhs).abs());
                scale = scale.max(rhs.abs());
            }
            assert!(worst <= 1e-8 * scale.max(1.0), "alpha {alpha}: residual {worst} vs scale {scale}");
            // The bias makes the fit exact in the mean.
            let b = ym - (0..n).map(|a| xm[a] * w[a]).sum::<f64>();
            assert!((r.bias[o] - b).abs() < 1e-9);
        }
    }
}

#[test]
fn path_equals_one_solve_per_penalty_on_the_whole_grid() {
    let (x, y) = problem(300, 30, 2, 2);
    let path = RidgePath::new(x.as_ref(), y.as_ref()).unwrap();
    let grid = PenaltyGrid::wyffels_2009();
    for &p in grid.values() {
        let a = path.solve(p).unwrap();
        let b = ridge_direct(x.as_ref(), y.as_ref(), p).unwrap();
        let scale = b.weight_norm().max(1.0);
        let diff = a.weights.iter().zip(&b.weights).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
        assert!(diff <= 1e-6 * scale, "penalty {p:e}: weights differ by {diff} (norm {scale})");
        for (u, v) in a.bias.iter().zip(&b.bias) {
            assert!((u - v).abs() <= 1e-6 * scale);
        }
    }
}

#[test]
fn weight_norm_never_grows_with_the_penalty_and_bias_is_unpenalised() {
    let (x, y) = problem(200, 25, 1, 3);
    let path = RidgePath::new(x.as_ref(), y.as_ref()).unwrap();
    let grid = PenaltyGrid::wyffels_2009();
    // The grid runs from large to small penalties: norms must not decrease along it.
    let norms: Vec<f64> = grid.values().iter().map(|&p| path.solve(p).unwrap().weight_norm()).collect();
    for k in 1..norms.len() {
        assert!(norms[k] >= norms[k - 1] * (1.0 - 1e-12), "norm fell from {} to {} at {k}", norms[k - 1], norms[k]);
    }
    let huge = path.solve(1e12).unwrap();
    let ym = (0..y.nrows()).map(|i| y[(i, 0)]).sum::<f64>() / y.nrows() as f64;
    assert!(huge.weight_norm() < 1e-6);
    assert!((huge.bias[0] - ym).abs() < 1e-6, "a huge penalty leaves the mean, not zero");
}

#[test]
fn paper_grid_has_91_values_from_10_to_1e_minus_8() {
    let g = PenaltyGrid::wyffels_2009();
    assert_eq!(g.len(), 91);
    assert_eq!(g.values()[0], 10.0);
    assert!((g.values()[90] - 1e-8).abs() < 1e-22);
    assert!((g.values()[10] - 1.0).abs() < 1e-15);
    // The same range written as a range gives the same bits (a config file
    // and the preset must train the same model).
    let r = PenaltyGrid::log10_range(1.0, 0.1, -8.0).unwrap();
    assert_eq!(r.values(), g.values());
    let quarter = PenaltyGrid::log10_range(1.0, 0.25, -8.0).unwrap();
    assert_eq!(quarter.len(), 37);
    assert_eq!(quarter.values()[4], 1.0);
    assert!(PenaltyGrid::log10_range(1.0, 1e-9, -8.0).is_err(), "a 9-billion-value grid is refused");
    assert!(PenaltyGrid::new(vec![]).is_err());
    assert!(PenaltyGrid::new(vec![1.0, -1.0]).is_err());
}

#[test]
fn sweep_results_are_in_order_and_independent_of_threads_and_chunks() {
    let (x, y) = problem(200, 20, 1, 4);
    let path = RidgePath::new(x.as_ref(), y.as_ref()).unwrap();
    let grid = PenaltyGrid::wyffels_2009();
    let score = |_: usize, p: f64| path.solve(p).unwrap().weight_norm();
    let reference: Vec<f64> = grid.values().iter().map(|&p| path.solve(p).unwrap().weight_norm()).collect();
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let got = pool.install(|| sweep(&grid, score));
        assert_eq!(got, reference, "{threads} threads");
        for chunk in [1, 7, 91, 500] {
            let got = pool.install(|| sweep_chunked(91, chunk, |r| r.map(|i| reference[i]).collect()));
            assert_eq!(got, reference, "{threads} threads, chunks of {chunk}");
        }
    }
}

#[test]
fn nmse_is_zero_for_a_perfect_fit_and_one_for_the_mean() {
    let target = [1.0, 10.0, 2.0, 20.0, 3.0, 30.0];
    assert_eq!(nmse(&target, &target, 2), 0.0);
    let mean = [2.0, 20.0, 2.0, 20.0, 2.0, 20.0];
    assert!((nmse(&mean, &target, 2) - 1.0).abs() < 1e-12);
    assert_eq!(nmse(&[f64::NAN, 1.0, 1.0, 1.0, 1.0, 1.0], &target, 2), f64::INFINITY);
}

#[test]
fn a_still_output_adds_its_squared_error_in_its_own_units() {
    // Output 0 never moves (0 throughout); output 1 is fitted exactly.
    let target = [0.0, 1.0, 0.0, -1.0];
    let off = [0.1, 1.0, -0.1, -1.0];
    assert!((nmse(&off, &target, 2) - 0.01 / 2.0).abs() < 1e-15, "{}", nmse(&off, &target, 2));
    // A target with a rounding-level wobble is still too: no division by ~1e-30.
    let wobble = [1e-16, 1.0, -1e-16, -1.0];
    assert!(nmse(&off, &wobble, 2) < 0.01);
}

#[test]
fn bad_input_is_an_error() {
    let (x, y) = problem(50, 5, 1, 5);
    let mut bad = x.clone();
    bad[(7, 3)] = f64::NAN;
    assert_eq!(
        RidgePath::new(bad.as_ref(), y.as_ref()).unwrap_err(),
        Error::NonFinite { what: "feature matrix", row: 7, col: 3 }
    );
    let short = Mat::<f64>::zeros(49, 1);
    assert!(matches!(RidgePath::new(x.as_ref(), short.as_ref()), Err(Error::Shape(_))));
    let path = RidgePath::new(x.as_ref(), y.as_ref()).unwrap();
    assert_eq!(path.solve(-1.0).unwrap_err(), Error::InvalidPenalty(-1.0));
    assert!(path.solve(f64::NAN).is_err());
}

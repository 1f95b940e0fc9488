//! The common step interface, the measures and the Table 1 code path.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use std::f64::consts::PI;

use cpg_centralized::{Basis, CentralizedNet};
use cpg_compare::fit::{Spec, starts_from_paper, table1};
use cpg_compare::measures::{align, errors, per_coordinate};
use cpg_compare::positions::glue;
use cpg_compare::{CentralizedCpg, Clock, DmpCpg, PatternGenerator, ReservoirCpg, run};
use cpg_dmp::{DmpConfig, RhythmicDmp};
use cpg_mocap::data::{Subject, find};
use cpg_mocap::{Motion, Skeleton};
use cpg_regression::PenaltyGrid;
use cpg_reservoir::{
    OutputChannel, Reservoir, ReservoirConfig, Scoring, Sequence, TrainSettings, TrainedCpg, TrainingData, train,
};

/// Two points moving on circles; the model is the data shifted by (3, 4, 0) mm.
#[test]
fn measures_on_a_known_offset() {
    let t = 50;
    let x: Vec<f64> = (0..t)
        .flat_map(|k| {
            let a = k as f64 * 0.3;
            [100.0 * a.cos(), 50.0, 100.0 * a.sin(), 20.0 * a.sin(), 900.0, 0.0]
        })
        .collect();
    let y: Vec<f64> = x.iter().enumerate().map(|(i, v)| v + [3.0, 4.0, 0.0][i % 3]).collect();
    let e = errors(&x, &y, 6).unwrap();
    assert!((e.mean_mm - 5.0).abs() < 1e-12);
    // ErrABS averages |3|, |4|, |0| over the six coordinates.
    assert!((e.err_abs_mm - 14.0 / 6.0).abs() < 1e-12);
    // The constant coordinates (y of both points, z of the second) are left out of the relative errors.
    let per = per_coordinate(&x, &y, 6).unwrap();
    assert!(per[1].is_nan() && per[4].is_nan() && per[5].is_nan());
    assert!(per[0] > 0.0 && per[3] > 0.0 && per[2] == 0.0);
    assert!((e.rel_l1 - (per[0] + per[2] + per[3]) / 3.0).abs() < 1e-12);
    // Alignment finds the shift of a delayed copy.
    let long: Vec<f64> = [vec![0.0; 7 * 6], x.clone(), vec![0.0; 6 * 6]].concat();
    let (s, e) = align(&long, &x, 6, 13).unwrap();
    assert_eq!(s, 7);
    assert_eq!(e.mean_mm, 0.0);
    // Bad input is refused, not panicked on.
    assert!(errors(&x, &y[..y.len() - 6], 6).is_err());
    assert!(errors(&x, &y, 4).is_err());
    let mut bad = y.clone();
    bad[17] = f64::NAN;
    let msg = errors(&x, &bad, 6).unwrap_err().to_string();
    assert!(msg.contains("frame 2, coordinate 5"), "{msg}");
    assert!(align(&x, &x, 6, 1).is_err());
}

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

fn reservoir_model() -> TrainedCpg {
    // The signal at 1 Hz steps: one period is 100 samples.
    let data = TrainingData::nmse(
        Sequence::outputs_only(rhythm(1500)),
        Sequence::outputs_only(rhythm(1500)),
        Sequence::outputs_only(rhythm(1800)[1500..].to_vec()),
    );
    let settings = TrainSettings {
        washout: 200,
        penalties: PenaltyGrid::log10_range(1.0, 0.5, -8.0).unwrap(),
        noise_variance: 1e-4,
        n_noise_draws: 2,
        noise_seed: 7,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let res = Reservoir::new(&ReservoirConfig::wyffels_schrauwen_2009().check().unwrap(), 1).unwrap();
    let tr = train(&res, &data, &settings).unwrap();
    let out = vec![OutputChannel { name: "rhythm".into(), mean: 0.0, std: 1.0 }];
    TrainedCpg::new(res, tr, settings, Scoring::default(), out, vec![], "test rhythm".into(), RATE).unwrap()
}

#[test]
fn every_family_runs_through_the_same_interface() {
    let x = rhythm(400);
    let cycle = x[..100].to_vec();
    let net = CentralizedNet::fit(vec![2.0 * PI * 1.2], 16, Basis::Rbf { b: 2.0 }, &x, 1, RATE).unwrap();
    let dmp = RhythmicDmp::imitate(DmpConfig::pydmps(100, 2.0 * PI / 100.0), &cycle, 1).unwrap();
    let model = reservoir_model();

    // The trait gives exactly what each crate gives on its own.
    let mut c = CentralizedCpg::new(net.clone(), Clock::Phase, RATE).unwrap();
    assert_eq!(run(&mut c, 400).unwrap(), net.generate(400, RATE));
    let mut h = CentralizedCpg::new(net.clone(), Clock::Hopf, RATE).unwrap();
    let hy = run(&mut h, 400).unwrap();
    assert!(hy.iter().zip(net.generate(400, RATE)).all(|(a, b)| (a - b).abs() < 1e-9));
    let mut dg = DmpCpg::new(dmp.clone(), 1.0, 1.0 / RATE).unwrap();
    assert_eq!(run(&mut dg, 300).unwrap(), dmp.clone().rollout(Some(300), 1.0));
    let mut rg = ReservoirCpg::new(model.clone(), vec![]).unwrap();
    let mut own = cpg_reservoir::Generator::new(&model);
    let ry = run(&mut rg, 300).unwrap();
    for v in &ry {
        assert_eq!(*v, own.step(&[]).unwrap()[0]);
    }
    // Wrong shapes are errors.
    assert!(c.step(&mut [0.0; 2]).is_err());
    assert!(ReservoirCpg::new(model.clone(), vec![1.0]).is_err());

    // After a reset, a generator starts over.
    c.reset();
    assert_eq!(run(&mut c, 400).unwrap(), net.generate(400, RATE));
}

fn positions(trial: &str, frames: usize) -> cpg_mocap::Positions {
    let sk = Skeleton::from_file(find(Subject::S35, "35.asf").unwrap()).unwrap();
    let m = Motion::from_amc_file(find(Subject::S35, trial).unwrap(), &sk, RATE).unwrap();
    let m = m.slice(0, frames.min(m.n_frames())).unwrap();
    sk.forward_kinematics(&m).unwrap()
}

/// The Table 1 code path (the paper runs it on 86_01, which is not always
/// available) on a subject-35 stand-in: a walk glued to a run.
#[test]
fn table1_path_on_a_subject_35_stand_in() {
    let parts = [positions("35_01.amc", 240), positions("35_17.amc", 167)];
    let (x, starts) = glue(&parts).unwrap();
    assert_eq!(starts, vec![0, 240]);
    let d = 93;
    // The glued root path is continuous on the floor (the height is the data's own):
    // its horizontal step at the join is no larger than the steps inside a trial.
    let root_step =
        |k: usize| -> f64 { [0, 2].iter().map(|&c| (x[k * d + c] - x[(k - 1) * d + c]).powi(2)).sum::<f64>().sqrt() };
    let typical = (1..240).map(root_step).fold(0.0, f64::max);
    assert!(root_step(240) <= typical, "root jumps {} mm at the join (largest step inside: {typical})", root_step(240));
    // The paper's 1-based boundaries, scaled to this sequence.
    let starts = starts_from_paper(&[1, 241, 407]).unwrap();
    assert_eq!(starts, vec![0, 240, 407]);
    let names = &parts[0].names;
    let marker = |n: &str, c: usize| names.iter().position(|x| x == n).unwrap() * 3 + c;
    let control = [marker("root", 2), marker("ltibia", 1), marker("rtibia", 1)];
    let specs = [Spec::new(1, 16), Spec::new(2, 25)];
    let rows = table1(&x, d, RATE, &starts, &specs, &control, 60.0).unwrap();
    assert_eq!(rows.len(), 2);
    for (spec, row) in specs.iter().zip(&rows) {
        assert_eq!(row.per_segment.len(), 2);
        assert_eq!(row.output.len(), x.len());
        for e in &row.per_segment {
            assert!(e.rel_l1 > 0.0 && e.rel_l1 < 0.5, "{spec:?}: {e:?}");
            assert!(e.mean_mm < 100.0, "{spec:?}: {e:?}");
        }
        // The sigmoid window spreads the change of posture at the join over
        // several frames: the glued output never steps as far as the data does.
        assert!(row.worst_jump_mm < row.data_jump_mm, "{spec:?}: {} vs {}", row.worst_jump_mm, row.data_jump_mm);
    }
    // Same inputs, same table (the specs run in parallel).
    let again = table1(&x, d, RATE, &starts, &specs, &control, 60.0).unwrap();
    assert_eq!(again[1].output, rows[1].output);
    // Boundaries outside the data are refused.
    assert!(table1(&x, d, RATE, &[0, 240, 500], &specs, &control, 60.0).is_err());
}

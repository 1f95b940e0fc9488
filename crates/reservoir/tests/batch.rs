//! Batched free runs against the generator they must equal bit for bit:
//! whatever the other runs, their number, their order and the thread count.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_regression::PenaltyGrid;
use cpg_reservoir::batch::{Controls, Run, free_runs};
use cpg_reservoir::*;

fn sine(len: usize, offset: usize) -> Vec<f64> {
    (offset..offset + len).map(|k| 1.5 * (k as f64 / 4.0).sin()).collect()
}

/// A model with one control input (constant 1 while training) whose
/// reservoir differs from the base only in the scalars a batch shares `Ŵ` across.
fn model(n: usize, seed: u64, precision: Precision, tweak: impl Fn(&mut ReservoirConfig)) -> TrainedCpg {
    let mut c = ReservoirConfig {
        n_neurons: n,
        precision,
        inputs: vec![Coupling { fraction: 0.5, scale: 0.2, center: 1.0 }],
        ..ReservoirConfig::wyffels_schrauwen_2009()
    };
    tweak(&mut c);
    let res = Reservoir::new(&c.check().unwrap(), seed).unwrap();
    let seq = |len, off| Sequence { outputs: sine(len, off), controls: vec![1.0; len] };
    let data = TrainingData::nmse(seq(800, 0), seq(800, 0), seq(200, 800));
    let settings = TrainSettings {
        washout: 100,
        penalties: PenaltyGrid::log10_range(0.0, 1.0, -6.0).unwrap(),
        n_noise_draws: 1,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let tr = train(&res, &data, &settings).unwrap();
    let out = vec![OutputChannel { name: "sine".into(), mean: 0.0, std: 1.0 }];
    TrainedCpg::new(res, tr, settings, Scoring::default(), out, vec!["u".into()], "sine".into(), 120.0).unwrap()
}

/// A control that ramps: 1 for 100 steps, then up to 1.4.
struct Ramp;
impl Controls for Ramp {
    fn fill(&self, step: usize, out: &mut [f64]) {
        out[0] = 1.0 + 0.4 * ((step as f64 - 100.0) / 300.0).clamp(0.0, 1.0);
    }
}

/// What the generator gives for a run: normalised outputs, step by step.
fn stepped(run: &Run<'_>) -> Result<Vec<f64>> {
    let mut g = Generator::new(run.model);
    if let Some((v, seed)) = run.noise {
        g.set_state_noise(v, seed);
    }
    let mut u = vec![0.0; run.model.controls.len()];
    let mut y = Vec::new();
    for k in 0..run.steps {
        run.controls.fill(k, &mut u);
        match run.hold {
            Some(h) if (h.from..h.from + h.len).contains(&k) => g.step_clamped(&u, &h.values)?,
            _ => g.step(&u)?,
        };
        y.extend_from_slice(g.normalised_output());
    }
    Ok(y)
}

fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn batched_runs_equal_generator_runs_whatever_the_company_order_and_threads() {
    for precision in [Precision::F32, Precision::F64] {
        let base = model(64, 3, precision, |_| {});
        let models = [
            base.clone(),
            model(64, 3, precision, |c| c.spectral_radius = 0.85),
            model(64, 3, precision, |c| c.leak_rate = 0.5),
            model(64, 3, precision, |c| c.feedback.scale = 0.1),
            model(64, 3, precision, |c| c.inputs[0].scale = 0.35),
            model(64, 3, precision, |c| c.bias_range = [-0.1, 0.2]),
            model(64, 4, precision, |_| {}), // another W: a batch of its own
        ];
        for m in &models[1..6] {
            assert!(m.reservoir.shares_w_with(&base.reservoir), "only scalars differ");
        }
        assert!(!models[6].reservoir.shares_w_with(&base.reservoir));
        let hold = Hold { from: 50, len: 6, values: vec![3.0] };
        let constant = vec![1.0];
        let mut runs = Vec::new();
        for m in &models {
            runs.push(Run::new(m, &constant, 400));
            runs.push(Run { hold: Some(&hold), ..Run::new(m, &constant, 300) });
            runs.push(Run { noise: Some((1e-4, 11)), ..Run::new(m, &Ramp, 500) });
        }
        let want: Vec<Vec<f64>> = runs.iter().map(|r| stepped(r).unwrap()).collect();
        for threads in [1, 2, 3] {
            let got = free_runs(&runs, threads);
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(same(g.as_ref().unwrap(), w), "{precision:?}, run {k}, {threads} threads");
            }
        }
        // Reversed, and each alone.
        let reversed: Vec<Run<'_>> = runs.iter().rev().copied().collect();
        for (g, w) in free_runs(&reversed, 2).iter().zip(want.iter().rev()) {
            assert!(same(g.as_ref().unwrap(), w), "{precision:?}, reversed");
        }
        for (r, w) in runs.iter().zip(&want) {
            assert!(same(free_runs(std::slice::from_ref(r), 1)[0].as_ref().unwrap(), w), "{precision:?}, alone");
        }
        // The radius really acts: the runs differ.
        assert!(!same(&want[0], &want[3]));
    }
}

#[test]
fn one_long_run_split_over_two_cores_gives_the_same_bits() {
    for precision in [Precision::F32, Precision::F64] {
        let m = model(300, 5, precision, |_| {});
        let hold = Hold { from: 1000, len: 6, values: vec![-3.0] };
        let level = vec![1.2];
        let runs = [
            Run::new(&m, &Ramp, 3000),
            Run { hold: Some(&hold), ..Run::new(&m, &Ramp, 2500) },
            Run::new(&m, &level, 1200),
            Run { noise: Some((1e-5, 3)), ..Run::new(&m, &level, 1500) },
        ];
        let want: Vec<Vec<f64>> = runs.iter().map(|r| stepped(r).unwrap()).collect();
        for (run, want) in runs.iter().zip(&want) {
            for threads in [1, 2] {
                let got = free_runs(std::slice::from_ref(run), threads);
                assert!(same(got[0].as_ref().unwrap(), want), "{precision:?}, {threads} threads");
            }
        }
        // Fewer than four runs together: the noise-free ones split by rows, the noisy one not.
        for k in [2, 3] {
            let got = free_runs(&runs[4 - k..], 2);
            for (g, w) in got.iter().zip(&want[4 - k..]) {
                assert!(same(g.as_ref().unwrap(), w), "{precision:?}, {k} runs together");
            }
        }
        // A split run that diverges ends as an error; its twin runs on to its end.
        let wild = vec![f64::NAN];
        let got = free_runs(&[Run::new(&m, &wild, 1000), Run::new(&m, &level, 1200)], 2);
        assert!(matches!(got[0], Err(Error::Diverged { .. })), "{precision:?}: {:?}", got[0].as_ref().err());
        assert!(same(got[1].as_ref().unwrap(), &want[2]), "{precision:?}, beside a diverging run");
    }
}

#[test]
fn a_diverging_run_is_an_error_and_its_company_is_not() {
    let m = model(64, 3, Precision::F32, |_| {});
    let wild = vec![f64::MAX];
    let calm = vec![1.0];
    let got = free_runs(&[Run::new(&m, &calm, 200), Run::new(&m, &wild, 200), Run::new(&m, &calm, 100)], 1);
    assert!(matches!(got[1], Err(Error::Diverged { .. })), "{:?}", got[1].as_ref().err());
    assert!(same(got[0].as_ref().unwrap(), &stepped(&Run::new(&m, &calm, 200)).unwrap()));
    assert_eq!(got[2].as_ref().unwrap().len(), 100);
    let bad = Hold { from: 0, len: 1, values: vec![1.0, 2.0] };
    let got = free_runs(&[Run { hold: Some(&bad), ..Run::new(&m, &calm, 10) }], 1);
    assert!(matches!(got[0], Err(Error::Shape(_))));
}

#[test]
fn steps_of_a_batch_allocate_nothing() {
    let models: Vec<TrainedCpg> =
        (0..3).map(|k| model(64, 3, Precision::F32, |c| c.leak_rate = 0.3 + 0.1 * k as f64)).collect();
    let calm = vec![1.0];
    let count = |steps: usize| {
        let runs: Vec<Run<'_>> =
            models.iter().map(|m| Run { noise: Some((1e-4, 1)), ..Run::new(m, &calm, steps) }).collect();
        allocation_counter::measure(|| {
            std::hint::black_box(free_runs(&runs, 1));
        })
        .count_total
    };
    // Everything is allocated before the first step: ten times the steps,
    // the same allocations.
    assert_eq!(count(100), count(1000));
    let mut g = Generator::new(&models[0]);
    g.set_state_noise(1e-4, 1);
    let steps = allocation_counter::measure(|| {
        for _ in 0..1000 {
            std::hint::black_box(g.step(&[1.0]).unwrap());
        }
    });
    assert_eq!(steps.count_total, 0, "a generator step allocates nothing");
}

#[test]
fn older_model_files_are_read_as_they_were_written() {
    let path = std::path::Path::new("old.cpg");
    for rho in [1.0, 0.8] {
        let m = model(32, 2, Precision::F64, |c| c.spectral_radius = rho);
        let bytes = m.to_bytes().unwrap();
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), FORMAT_VERSION);
        assert_eq!(TrainedCpg::from_bytes(&bytes, path).unwrap(), m);
        // Version 3 stored the configuration as fixed bincode fields.
        let v3 = m.to_bytes_version(3).unwrap();
        assert_eq!(u32::from_le_bytes(v3[8..12].try_into().unwrap()), 3);
        assert_ne!(v3, bytes);
        assert_eq!(TrainedCpg::from_bytes(&v3, path).unwrap(), m, "a version 3 file is read exactly");
        // Version 4 stored the training settings as fixed bincode fields.
        let v4 = m.to_bytes_version(4).unwrap();
        assert_eq!(u32::from_le_bytes(v4[8..12].try_into().unwrap()), 4);
        assert_ne!(v4, bytes);
        assert_eq!(TrainedCpg::from_bytes(&v4, path).unwrap(), m, "a version 4 file is read exactly");
        // Version 2 also stored W scaled by the radius.
        let old = TrainedCpg::from_bytes(&m.to_bytes_version(2).unwrap(), path).unwrap();
        let err: f64 =
            old.reservoir.w_unit().iter().zip(m.reservoir.w_unit()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        if rho == 1.0 {
            assert_eq!(old, m, "at radius 1 a version 2 file is read exactly");
        } else {
            assert!(err < 1e-15, "{err}");
        }
        let mut v9 = bytes.clone();
        v9[8..12].copy_from_slice(&9u32.to_le_bytes());
        let e = TrainedCpg::from_bytes(&v9, path).unwrap_err().to_string();
        assert!(e.contains("format version 9") && e.contains("reads versions 2 to"), "{e}");
        assert!(m.to_bytes_version(9).is_err());
    }
}

/// A model file written by the last build of format version 3 (the fuzz
/// seed's payload before version 4) still loads, and its configuration is
/// the one it was trained with.
#[test]
fn a_file_from_the_last_version_3_build_loads() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let payload = std::fs::read(dir.join("sine-12-v3.payload")).unwrap();
    let mut bytes = TrainedCpg::frame_payload(&payload);
    bytes[8..12].copy_from_slice(&3u32.to_le_bytes());
    let m = TrainedCpg::from_bytes(&bytes, &dir.join("sine-12-v3.payload")).unwrap();
    let c = m.reservoir.config();
    assert_eq!(c, &ReservoirConfig { n_neurons: 12, ..ReservoirConfig::wyffels_schrauwen_2009() });
    assert_eq!(m.to_bytes_version(3).unwrap(), bytes, "written back as version 3, the same bytes");
    // From version 4 on the configuration is JSON text, each parameter by name.
    let v5 = m.to_bytes().unwrap();
    let text = String::from_utf8_lossy(&v5);
    assert!(text.contains("\"n_neurons\":12") && text.contains("\"leak_rate\":0.3"), "{text}");
}

/// A model file written by the last build of format version 4 (the fuzz
/// seed's payload before version 5) still loads, its training settings read
/// from their fixed fields; as version 5 they are JSON text, and a setting
/// version 4 could not hold is refused rather than dropped.
#[test]
fn a_file_from_the_last_version_4_build_loads() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let payload = std::fs::read(dir.join("sine-12-v4.payload")).unwrap();
    let mut bytes = TrainedCpg::frame_payload(&payload);
    bytes[8..12].copy_from_slice(&4u32.to_le_bytes());
    let m = TrainedCpg::from_bytes(&bytes, &dir.join("sine-12-v4.payload")).unwrap();
    assert_eq!(m.provenance.settings.washout, 100);
    assert_eq!(m.provenance.settings.self_fed, SelfFed::default());
    assert_eq!(m.to_bytes_version(4).unwrap(), bytes, "written back as version 4, the same bytes");
    let text = String::from_utf8_lossy(&m.to_bytes().unwrap()).into_owned();
    assert!(text.contains("\"washout\":100") && text.contains("\"self_fed\""), "{text}");
    let mut fed = m.clone();
    fed.provenance.settings.self_fed = SelfFed { rounds: 1, free_steps: 60, forced_steps: 60 };
    let back = TrainedCpg::from_bytes(&fed.to_bytes().unwrap(), std::path::Path::new("fed.cpg")).unwrap();
    assert_eq!(back, fed, "version 5 keeps every setting");
    let e = fed.to_bytes_version(4).unwrap_err().to_string();
    assert!(e.contains("cannot record"), "{e}");
}

/// A configuration missing a parameter (a file written before it existed)
/// reads it as the paper's value.
#[test]
fn a_configuration_without_a_parameter_takes_the_papers_value() {
    let c: ReservoirConfig = serde_json::from_str(r#"{"n_neurons": 50, "n_outputs": 2}"#).unwrap();
    assert_eq!(c, ReservoirConfig { n_neurons: 50, n_outputs: 2, ..ReservoirConfig::wyffels_schrauwen_2009() });
    let e = serde_json::from_str::<ReservoirConfig>(r#"{"n_neuron": 50}"#).unwrap_err().to_string();
    assert!(e.contains("unknown field `n_neuron`"), "{e}");
}

/// A channel learnt as its rate (`sine/s`) comes out of the generator
/// integrated, step by step, with the same bits as a batched run's outputs
/// de-normalised and integrated afterwards; the normalised outputs stay rates.
#[test]
fn a_rate_channel_is_integrated_the_same_by_the_generator_and_after_a_run() {
    let mut m = model(60, 3, Precision::F64, |_| {});
    m.outputs[0] = OutputChannel { name: format!("root.tz{VELOCITY_SUFFIX}"), mean: 2.0, std: 0.5 };
    assert_eq!(m.outputs[0].integrates(), Some("root.tz"));
    assert_eq!(m.outputs[0].unit_name(), "root.tz");
    let steps = 300;
    let run = Run { model: &m, controls: &Ramp, steps, hold: None, noise: None };
    let mut batched = free_runs(&[run], 1).pop().unwrap().unwrap();
    let normalised = stepped(&run).unwrap();
    assert!(same(&batched, &normalised), "normalised outputs are the rates, batched or stepped");
    to_units_in_place(&m.outputs, &mut batched);
    integrate_in_place(&m.outputs, &mut batched, 120.0);
    let mut g = Generator::new(&m);
    let mut u = [0.0];
    let integrated: Vec<f64> = (0..steps)
        .map(|k| {
            Ramp.fill(k, &mut u);
            g.step(&u).unwrap()[0]
        })
        .collect();
    assert!(same(&batched, &integrated), "the generator integrates as integrate_in_place does");
    // A mean rate of 2 units/s for 2.5 s travels about 5 units.
    assert!((integrated[steps - 1] - 5.0).abs() < 1.0, "{}", integrated[steps - 1]);
}

/// FORCE learns the sine online on its own output (two passes): its free run
/// follows the sine, the chosen α is one of the grid, and the bits do not
/// depend on the thread count.
#[test]
fn force_learns_a_sine_on_its_own_output() {
    let c = ReservoirConfig {
        n_neurons: 100,
        inputs: vec![Coupling { fraction: 0.5, scale: 0.2, center: 1.0 }],
        ..ReservoirConfig::wyffels_schrauwen_2009()
    };
    let res = Reservoir::new(&c.check().unwrap(), 5).unwrap();
    let seq = |len, off| Sequence { outputs: sine(len, off), controls: vec![1.0; len] };
    let data = TrainingData::nmse(seq(1500, 0), seq(800, 0), seq(200, 800));
    let settings = TrainSettings {
        washout: 100,
        penalties: PenaltyGrid::log10_range(1.0, 1.0, 0.0).unwrap(),
        n_noise_draws: 1,
        noise_variance: 0.0,
        ..TrainSettings::wyffels_schrauwen_2009()
    };
    let force = ForceSettings { every: 1, passes: 2 };
    let tr = train_force_on(&res, &data, &settings, &force, 1).unwrap();
    let again = train_force_on(&res, &data, &settings, &force, 2).unwrap();
    assert_eq!(tr.readout, again.readout, "the same readout on one thread and two");
    assert!([10.0, 1.0].contains(&tr.penalty), "α {}", tr.penalty);
    // The second pass's error before each correction, the transient after its washout included.
    assert!(tr.train_nmse < 0.05, "online error {}", tr.train_nmse);
    let score = tr.curve.iter().find(|v| v.penalty == tr.penalty).unwrap().nmse;
    assert!(score < 0.01, "the free run's NMSE against the sine: {score}");
}

/// A watch on the thread sees the steps and can stop the runs: cancelled,
/// every run of a batch (one thread or split over two) and a training
/// return `Cancelled`; not cancelled, the outputs are the same bits as
/// without a watch, and the steps it counted are at most those run.
#[test]
fn a_watch_counts_steps_and_a_cancelled_one_stops_the_work() {
    use cpg_reservoir::watch::{Watch, set_for_this_thread};
    use std::sync::Arc;
    let m = model(300, 7, Precision::F64, |_| {});
    let steps = 5000;
    let runs = [Run::new(&m, &Ramp, steps), Run::new(&m, &Ramp, steps / 2)];
    let plain: Vec<Vec<f64>> = free_runs(&runs, 2).into_iter().map(|r| r.unwrap()).collect();
    let w = Arc::new(Watch::default());
    set_for_this_thread(Some(w.clone()));
    for threads in [1, 2] {
        let watched: Vec<Vec<f64>> = free_runs(&runs, threads).into_iter().map(|r| r.unwrap()).collect();
        assert_eq!(watched, plain, "a watch changes no bit ({threads} thread(s))");
    }
    let counted = w.steps_done();
    assert!(counted >= 2 * 4096 && counted <= 2 * (steps + steps / 2) as u64, "{counted}");
    w.cancel();
    for threads in [1, 2] {
        for r in free_runs(&runs, threads) {
            assert!(matches!(r, Err(Error::Cancelled)), "{threads} thread(s)");
        }
        // One long run, split by rows over two threads, stops too.
        let long = [Run::new(&m, &Ramp, 20_000)];
        assert!(matches!(free_runs(&long, threads).pop().unwrap(), Err(Error::Cancelled)));
    }
    let res = Reservoir::new(&ReservoirConfig::wyffels_schrauwen_2009().check().unwrap(), 3).unwrap();
    let data = TrainingData::nmse(
        Sequence::outputs_only(sine(800, 0)),
        Sequence::outputs_only(sine(800, 0)),
        Sequence::outputs_only(sine(200, 800)),
    );
    let settings = TrainSettings { washout: 100, n_noise_draws: 1, ..TrainSettings::wyffels_schrauwen_2009() };
    assert!(matches!(train(&res, &data, &settings), Err(Error::Cancelled)));
    // Teacher forcing (the harvest's pass over the training data) stops too.
    let seq = Sequence::outputs_only(sine(800, 0));
    assert!(matches!(
        cpg_reservoir::teacher_forced_states(&res, &vec![0.0; res.config().n_neurons], &seq),
        Err(Error::Cancelled)
    ));
    set_for_this_thread(None);
    assert!(train(&res, &data, &settings).is_ok(), "without the watch the same training works");
}

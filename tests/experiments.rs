//! Every experiment configuration of `experiments/` run at its quick size,
//! each result checked against stated ranges; and the data preparation of
//! the experiments on the real CMU files.

#![allow(clippy::unwrap_used, clippy::expect_used)] // integration tests fail loudly

use cpg_lab::Config;
use cpg_lab::experiment::{self, Options, Outcome, Quiet};
use cpg_reservoir::Generator;
use cpg_tests::workspace_root;

fn config(name: &str) -> Config {
    Config::load(&workspace_root().join("experiments").join(format!("{name}.toml"))).unwrap_or_else(|e| panic!("{e}"))
}

fn quick(name: &str) -> Outcome {
    experiment::run(&config(name), Options { quick: true }, &Quiet).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The running stride of 35_17 (about 88 frames between upward zero
/// crossings of `lfemur.rx`, 167 frames in the trial) is found, not its
/// harmonic: the period search reaches past half the trial.
#[test]
fn running_teacher_is_one_stride_of_35_17() {
    for name in ["e5", "e5-paper"] {
        let p = cpg_lab::prepare::prepare(&config(name)).unwrap();
        let run = &p.cycles[1];
        assert_eq!(run.frames, 167);
        assert!((85.0..95.0).contains(&run.period_frames), "{name}: running period {} frames", run.period_frames);
        assert!((77..=100).contains(&run.loop_len), "{name}: running loop {} frames", run.loop_len);
        assert!(run.seam_excess < 0.1, "{name}: seam {}", run.seam_excess);
        let walk = &p.cycles[0];
        assert!((130.0..142.0).contains(&walk.period_frames), "{name}: walking period {}", walk.period_frames);
    }
}

/// Bound on the median, over reservoir seeds 1–5, of the NMSE of the first
/// 500 free-run steps with the paper's protocol. For a sinusoid, a pure phase
/// error φ costs 2(1 − cos φ), so 0.1 allows at most an 18° phase slip. Over
/// seeds 1–10 we measured 0.0094–0.52 (median 0.046).
const PAPER_MEDIAN_NMSE_BOUND: f64 = 0.1;

/// E1 with the paper's protocol, the configuration the report runs: the
/// pattern is learnt (median over 5 seeds), every seed beats predicting the
/// mean, and 100,000 free-run steps stay finite and within ±90°.
#[test]
fn e1_paper_protocol_learns_the_femur_pattern_and_stays_bounded() {
    let c = config("e1-paper");
    let seeds: Vec<u64> = (1..=5).collect();
    let (p, models) = experiment::train_seeds(&c, &seeds, &Quiet).unwrap();
    let t = &p.teachers[0];
    let warmup = p.data.warmup.len(1);
    let teacher = experiment::stability::continuation(t, 1, warmup, 500);
    let mut nmse: Vec<f64> = Vec::new();
    for (m, seed) in models.iter().zip(&seeds) {
        let mut g = Generator::new(m);
        let first: Vec<f64> = (0..500)
            .map(|_| {
                g.step(&[]).unwrap();
                g.normalised_output()[0]
            })
            .collect();
        let e = experiment::stability::nmse(&first, &teacher, 1);
        assert!(e < 1.0, "seed {seed}: first-500 NMSE {e}");
        nmse.push(e);
        for _ in 500..100_000 {
            let y = g.step(&[]).unwrap()[0];
            assert!((-90.0..90.0).contains(&y), "seed {seed}: femur angle {y} deg");
        }
    }
    nmse.sort_by(f64::total_cmp);
    assert!(nmse[2] < PAPER_MEDIAN_NMSE_BOUND, "median first-500 NMSE over seeds 1–5: {nmse:?}");
}

#[test]
fn e1_both_protocols_at_quick_size() {
    let Outcome::Stability(ours) = quick("e1") else { panic!("e1 is a stability experiment") };
    assert_eq!(ours.seeds.len(), 3);
    for s in &ours.seeds {
        let st = &s.stability;
        assert!(st.accurate && st.converged, "seed {}: {st:?}", s.model.seed);
        assert!(s.first_nmse < 0.01, "seed {}: first-500 NMSE {}", s.model.seed, s.first_nmse);
        assert!(s.recovery.orbit_s.is_some_and(|t| t < 2.0), "seed {}: {:?}", s.model.seed, s.recovery);
        assert!(!s.model.penalty_at_edge);
    }
    assert!(ours.e1_verdict().passed && ours.e2_verdict().passed && ours.e3_verdict().passed);
    let Outcome::Stability(paper) = quick("e1-paper") else { panic!() };
    assert!(paper.median_first_nmse() < PAPER_MEDIAN_NMSE_BOUND);
    // The long run is judged against the same teacher, with the same push.
    assert_eq!(paper.teacher, ours.teacher);
    assert_eq!(paper.push, ours.push);
    assert!((paper.push.held_units[0] - 48.3).abs() < 0.1, "held at {}°", paper.push.held_units[0]);
}

#[test]
fn e4_our_protocol_follows_the_control_from_1_to_6() {
    let Outcome::Frequency(r) = quick("e4") else { panic!("e4 is a frequency experiment") };
    assert!((r.f0_hz - 120.0 / 140.0).abs() < 1e-9, "f0 {}", r.f0_hz);
    for s in &r.seeds {
        for p in s.plateaus.iter().chain(&s.figure) {
            let ratio = p.measured_hz.map_or(0.0, |h| h / p.target_hz);
            assert!(
                (ratio - 1.0).abs() < 0.05 && (p.amplitude_ratio - 1.0).abs() < 0.25,
                "seed {} u = {}: {p:?}",
                s.model.seed,
                p.u
            );
        }
    }
    let Outcome::Frequency(paper) = quick("e4-paper") else { panic!() };
    assert_eq!(paper.seeds[0].plateaus.len(), 6);
    assert_eq!(paper.seeds[0].figure.len(), 3, "the Fig. 3 schedule holds u three times");
}

#[test]
fn e5_our_protocol_switches_gaits_both_ways() {
    let Outcome::Gaits(r) = quick("e5") else { panic!("e5 is a gaits experiment") };
    assert_eq!(r.teachers.len(), 2);
    for s in &r.seeds {
        assert!(s.passed, "seed {}: {s:?}", s.model.seed);
        assert!(s.max_jump_smooth <= r.data_step);
    }
    let Outcome::Gaits(paper) = quick("e5-paper") else { panic!() };
    assert_eq!(paper.teachers, r.teachers, "both protocols learn the same two cycles");
}

#[test]
fn e6_both_protocols_keep_the_phase_coupling() {
    let names = ["e6", "e6-paper"];
    let configs: Vec<Config> = names.iter().map(|n| config(n)).collect();
    assert!(experiment::share_reservoirs(&configs[0], &configs[1]), "E6's two protocols draw the same reservoirs");
    let refs: Vec<&Config> = configs.iter().collect();
    // Run together (one pass over each seed's weights for both), every result
    // is the one each configuration gives alone.
    let together = experiment::run_together(&refs, Options { quick: true }, &Quiet).unwrap();
    for (name, both) in names.into_iter().zip(together) {
        let Outcome::Coupling(r) = quick(name) else { panic!("{name} is a coupling experiment") };
        let Outcome::Coupling(b) = both else { panic!("{name} together is a coupling experiment") };
        assert_eq!(b.seeds, r.seeds, "{name}: every seed's result, alone and together");
        assert_eq!(b.rows, r.rows, "{name}: the first seed's lag table, alone and together");
        assert!(r.seeds.len() >= 2, "{name}: the quick run has several seeds");
        assert_eq!(r.rows.len(), 22);
        assert_eq!(r.header.n_neurons, 600, "{name}: the quick size");
        assert!(r.worst_drift < 0.05, "{name}: drift {}", r.worst_drift);
        assert!(r.median_cycle_nmse < 0.05, "{name}: median NMSE {}", r.median_cycle_nmse);
        let h = r.hoap2.as_ref().expect("E6 maps onto the HOAP-2");
        assert_eq!(h.clamps.joints.len(), 22);
        assert_eq!(r.portraits.len(), 12);
    }
}

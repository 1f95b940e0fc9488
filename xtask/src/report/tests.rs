//! Rendering, pinned: a golden section and summary, every verdict beside its
//! rule, and a decayed run reported without a period. The results here are
//! built by hand, so these tests need no data and no training.
//! `UPDATE_SNAPSHOTS=1 cargo test -p xtask` rewrites the golden files.

use cpg_lab::experiment::conditions::{Condition, Conditions};
use cpg_lab::experiment::differs::Difference;
use cpg_lab::experiment::frequency::{FrequencyResult, FrequencySeed, Plateau};
use cpg_lab::experiment::gaits::{GaitWindow, GaitsResult, GaitsSeed};
use cpg_lab::experiment::stability::{PushInfo, StabilityResult, StabilitySeed};
use cpg_lab::experiment::{Edge, Header, Judged, Outcome, SeedModel};
use cpg_lab::measure::{Recovery, Rhythm, Stability, TeacherShape};
use cpg_lab::prepare::SegmentCycle;
use cpg_reservoir::Teacher;

use cpg_lab::experiment::Experiment;
use cpg_lab::experiment::doc::Context;

use super::fmt::Md;
use super::summary::summary;

/// The text of an experiment's section, as the report writes it (no figures drawn).
fn text<E: Experiment>(rs: &[&E]) -> String {
    let mut md = Md::default();
    md.section(&E::section(rs, &Context::default()).unwrap(), None).unwrap();
    md.0
}

fn seed_model(seed: u64, penalty: f64) -> SeedModel {
    let curve: Vec<(f64, f64)> = (0..91).map(|k| (10f64.powf(1.0 - k as f64 / 10.0), 1.0 + k as f64 / 100.0)).collect();
    SeedModel {
        seed,
        penalty,
        validation_score: 0.5,
        penalty_at_edge: penalty == 10.0,
        edge: (penalty == 10.0).then_some(Edge::Upper),
        curve,
    }
}

fn header(id: &str, protocol: &str, score: &str) -> Header {
    Header {
        id: id.into(),
        title: "a test".into(),
        protocol: protocol.parse().unwrap(),
        method: format!("the {protocol} method"),
        config: format!("experiments/{}.toml", if protocol == "ours" { "e1" } else { "e1-paper" }),
        cycles: vec![SegmentCycle {
            label: "walk (35_01)".into(),
            frames: 358,
            period_frames: 134.94,
            period_channel: "lfemur.rx".into(),
            loop_start: 141,
            loop_len: 135,
            seam_excess: 0.0,
            stride: None,
        }],
        notes: vec!["segment 1 (walk (35_01)): 358 frames hold 2.7 periods of 134.9, too few to see a second stride in the rhythm alone; both legs confirm one stride".into()],
        score: score.parse().unwrap(),
        noise_variance: if score == "nmse" { 1e-3 } else { 0.0 },
        penalty_grid: (91, 1.0, -8.0),
        n_neurons: 300,
        differs: if protocol == "ours" {
            vec![Difference {
                key: "training.teacher_noise".into(),
                what: "noise on the fed-back teacher while harvesting".into(),
                paper: "0".into(),
                this: "0.1".into(),
            }]
        } else {
            Vec::new()
        },
        conditions: Conditions {
            validation: vec![Condition::Push { at_s: 1.3, hold_s: 0.1, above_max: 1.0 }],
            tuned: Vec::new(),
            test: vec![Condition::Push { at_s: 2.0, hold_s: 0.05, above_max: 2.0 }],
        },
        warnings: Vec::new(),
    }
}

fn rhythm(period: Option<f64>, amp: f64) -> Rhythm {
    Rhythm { period_steps: period, amplitude: vec![amp], aligned_nmse: 0.01, decayed: period.is_none() }
}

fn stability_seed(seed: u64, period: Option<f64>, amp: f64, penalty: f64) -> StabilitySeed {
    let accurate = period.is_some_and(|p| (p / 140.0 - 1.0).abs() < 0.01) && (amp / 1.54 - 1.0).abs() < 0.05;
    StabilitySeed {
        model: seed_model(seed, penalty),
        first_nmse: 0.02,
        accurate: Judged { passed: accurate, at_limit: false },
        stability: Stability {
            steps: 108_000,
            teacher: TeacherShape { label: "walk (35_01)".into(), period_steps: 140.0, amplitude: vec![1.54] },
            early: rhythm(Some(140.0), 1.5),
            end: rhythm(period, amp),
            decayed_at_s: period.is_none().then_some(412.5),
            converged: period.is_some(),
            accurate,
            posture: None,
        },
        recovery: Recovery {
            orbit_s: period.map(|_| 0.5),
            own_orbit_s: Some(0.4),
            unpushed_on_orbit: period.is_some(),
            twin_s: None,
            phase_shift_cycles: 0.031,
        },
    }
}

fn stability(protocol: &str) -> StabilityResult {
    let score = if protocol == "ours" { "orbit" } else { "nmse" };
    let seeds = if protocol == "ours" {
        vec![stability_seed(1, Some(140.02), 1.53, 3.16e-2), stability_seed(2, Some(139.98), 1.54, 6.31e-3)]
    } else {
        vec![stability_seed(1, Some(139.14), 1.39, 10.0), stability_seed(2, None, 0.0, 10.0)]
    };
    let mut r = StabilityResult {
        header: header("E1–E3", protocol, score),
        channel: "lfemur.rx".into(),
        long_run_s: 900.0,
        first_samples: 500,
        push: PushInfo {
            at_s: 2.0,
            hold_s: 0.05,
            hold_steps: 6,
            above_max: 2.0,
            held: vec![3.8],
            held_units: vec![48.3],
        },
        teacher: Teacher { label: "walk (35_01)".into(), controls: vec![], cycle: vec![0.0; 140], rate: 1.0 },
        seeds,
        claims: Vec::new(),
        table: Vec::new(),
        fig2: Default::default(),
    };
    r.summarise();
    r
}

fn frequency() -> FrequencyResult {
    let plateau = |u: f64, ok: bool| Plateau {
        u,
        window_s: [4.0, 8.0],
        target_hz: u * 0.857,
        measured_hz: ok.then_some(u * 0.857),
        amplitude_ratio: if ok { 1.0 } else { 0.0 },
        aligned_nmse: 0.01,
        passed: ok,
        at_limit: false,
    };
    let mut r = FrequencyResult {
        header: header("E4", "ours", "orbit"),
        f0_hz: 0.857,
        teacher_amplitude: 1.54,
        plateaus: vec![1.0, 6.0],
        hold_s: 8.0,
        ramp_s: 2.0,
        seeds: vec![FrequencySeed {
            model: seed_model(1, 1e-3),
            plateaus: vec![plateau(1.0, true), plateau(6.0, false)],
            passed: false,
            at_limit: false,
            figure: vec![plateau(6.0, true)],
        }],
        claims: Vec::new(),
        table: Vec::new(),
        fig3: Default::default(),
    };
    r.summarise();
    r
}

fn gaits() -> GaitsResult {
    gaits_with(0.17, false)
}

/// E5 with one seed whose largest step after a smooth switch is `jump` (the data's is 0.197).
fn gaits_with(jump: f64, jump_at_limit: bool) -> GaitsResult {
    let w = |t: &str, p: f64| GaitWindow {
        teacher: t.into(),
        period_steps: Some(p),
        teacher_period_steps: p,
        amplitude_ratio: 1.0,
        passed: true,
        at_limit: false,
    };
    let mut r = GaitsResult {
        header: header("E5", "ours", "orbit"),
        teachers: vec![
            TeacherShape { label: "walk".into(), period_steps: 140.0, amplitude: vec![1.36] },
            TeacherShape { label: "run".into(), period_steps: 86.0, amplitude: vec![1.58] },
        ],
        data_step: 0.197,
        switch_at_s: [8.0, 15.0],
        ramp_s: 1.0,
        run_s: 25.0,
        seeds: vec![GaitsSeed {
            model: seed_model(1, 5e-3),
            first: w("walk", 140.0),
            second: w("run", 86.0),
            first_again: w("walk", 140.0),
            settle_s: [Some(0.35), Some(0.5)],
            max_jump_smooth: jump,
            max_jump_abrupt: 0.5,
            passed: true,
            at_limit: jump_at_limit,
        }],
        claims: Vec::new(),
        table: Vec::new(),
        smooth_runs: Vec::new(),
        fig4: Default::default(),
        view: None,
    };
    r.summarise();
    r
}

fn golden(name: &str, text: &str) {
    let path = crate::root().join("xtask/tests/golden").join(name);
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        return;
    }
    let pinned = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(pinned == text, "{name} changed (UPDATE_SNAPSHOTS=1 to accept):\n--- pinned\n{pinned}\n--- now\n{text}");
}

#[test]
fn the_e1_section_is_pinned() {
    let (paper, ours) = (stability("paper"), stability("ours"));
    golden("e1_section.md", &text(&[&paper, &ours]));
}

#[test]
fn the_summary_table_is_pinned() {
    let outcomes = vec![
        ("experiments/e1-paper.toml".to_owned(), Outcome::Stability(Box::new(stability("paper")))),
        ("experiments/e1.toml".to_owned(), Outcome::Stability(Box::new(stability("ours")))),
        ("experiments/e4.toml".to_owned(), Outcome::Frequency(Box::new(frequency()))),
        ("experiments/e5.toml".to_owned(), Outcome::Gaits(Box::new(gaits()))),
    ];
    let mut md = Md::default();
    summary(&mut md, &outcomes, None);
    golden("summary.md", &md.0);
}

#[test]
fn every_verdict_is_printed_with_its_rule() {
    let (paper, ours) = (stability("paper"), stability("ours"));
    let md = text(&[&paper, &ours]);
    for v in [ours.e1_verdict(), ours.e2_verdict(), ours.e3_verdict()] {
        assert!(md.contains(&v.rule), "the E1–E3 section lacks the rule {:?}", v.rule);
    }
    let f = frequency();
    assert!(text(&[&f]).contains(&f.verdict().rule), "E4 rule missing");
    let g = gaits();
    let md = text(&[&g]);
    assert!(md.contains(&g.verdict().rule), "E5 rule missing");
    assert!(md.contains(&g.spike_verdict().rule), "E5 spike rule missing");
}

#[test]
fn a_decayed_run_has_no_period() {
    let paper = stability("paper");
    let md = text(&[&paper]);
    let row = md.lines().find(|l| l.starts_with("| 2 |")).expect("seed 2's row");
    assert!(row.contains("decayed at 412 s"), "{row}");
    assert!(!row.contains("| 0.00 |") && !row.contains("127."), "no period for a decayed run: {row}");
}

#[test]
fn a_verdict_decided_by_less_than_the_printed_digits_says_so() {
    // E5 seed 9 of an earlier run: 0.19666 against the data's 0.19675, printed 0.197 (0.197).
    let g = gaits_with(0.19666, true);
    let outcomes = vec![("experiments/e5.toml".to_owned(), Outcome::Gaits(Box::new(g)))];
    let mut md = Md::default();
    summary(&mut md, &outcomes, None);
    let row = md.0.lines().find(|l| l.contains("switched smoothly")).expect("the E5 row");
    assert!(row.contains("| reproduced (at the limit) |"), "{row}");
    let clear = gaits_with(0.17, false);
    let outcomes = vec![("experiments/e5.toml".to_owned(), Outcome::Gaits(Box::new(clear)))];
    let mut md = Md::default();
    summary(&mut md, &outcomes, None);
    assert!(!md.0.contains("at the limit)"), "{}", md.0);
}

#[test]
fn the_summary_says_what_each_row_changes_against_the_paper() {
    let outcomes = vec![
        ("experiments/e1-paper.toml".to_owned(), Outcome::Stability(Box::new(stability("paper")))),
        ("experiments/e1.toml".to_owned(), Outcome::Stability(Box::new(stability("ours")))),
    ];
    let mut md = Md::default();
    summary(&mut md, &outcomes, None);
    let ours: Vec<&str> = md.0.lines().filter(|l| l.contains("| ours |")).collect();
    assert_eq!(ours.len(), 3, "{}", md.0);
    for row in ours {
        assert!(row.contains("noise on the fed-back teacher while harvesting: 0 → 0.1"), "{row}");
    }
}

#[test]
fn a_quote_the_paper_does_not_hold_stops_the_report() {
    use cpg_lab::experiment::claim::{Claim, Paper, Quote, Source, Verdict};
    let claim = |text: &'static str| Claim {
        experiment: "Centralized".into(),
        claim: "a test".into(),
        sources: vec![Source::Quote(Quote { paper: Paper::Vakulenko2017, place: "Summary", text })],
        protocol: "reconstructed".into(),
        differs: Vec::new(),
        measured: Vec::new(),
        verdict: Verdict::new(true, false, "a rule"),
    };
    // A sentence an earlier report put in the paper's mouth.
    let made_up = [claim("2 to 3 oscillators were sufficient")];
    let err = super::check_quotes(made_up.iter()).expect_err("the paper does not say it");
    assert!(err.to_string().contains("2 to 3 oscillators"), "{err}");
    let real = [claim(cpg_lab::experiment::claim::AICC_OPTIMUM.text)];
    assert_eq!(super::check_quotes(real.iter()).expect("found"), Some(1));
}

#[test]
fn every_quote_a_claim_can_carry_is_in_its_paper() {
    let dir = super::papers_dir();
    assert!(dir.is_dir(), "the papers' texts are expected at {}", dir.display());
    for q in cpg_lab::experiment::claim::QUOTES {
        let text = std::fs::read_to_string(dir.join(q.paper.file_name())).expect("the paper's text");
        assert!(
            super::squash(&text).contains(&super::squash(q.text)),
            "{} ({}) does not say {:?}",
            q.paper.cite(),
            q.place,
            q.text
        );
    }
}

#[test]
fn medians_in_the_report_are_true_medians() {
    // Two seeds: the E1 median is the mean of their first-sample NMSEs.
    let mut r = stability("ours");
    r.seeds[0].first_nmse = 0.02;
    r.seeds[1].first_nmse = 0.04;
    r.summarise();
    let md = text(&[&r]);
    assert!(md.contains("| 0.0300 (0.0200–0.0400; n = 2) |"), "{md}");
}

#[test]
fn the_run_is_dated_by_the_calendar() {
    assert_eq!(super::civil(0), (1970, 1, 1));
    assert_eq!(super::civil(20_790), (2026, 12, 3));
    assert_eq!(super::civil(11_016), (2000, 2, 29));
    let mut times = super::Times::default();
    times.push("x".into(), &super::Clock::start());
    let info = super::run_info(&times, &super::Clock::start(), Some(3));
    assert!(info.cores >= 1 && !info.cpu.is_empty() && !info.simd.is_empty());
    assert!(info.date_utc.len() == 20 && info.date_utc.ends_with('Z'), "{}", info.date_utc);
    let v = serde_json::to_value(&info).unwrap();
    for k in [
        "commit",
        "date_utc",
        "cpu",
        "cores",
        "simd",
        "threads",
        "seconds",
        "total_s",
        "quotes_checked",
        "load",
        "others_share",
        "cpu_s",
    ] {
        assert!(v.get(k).is_some(), "metrics.json's run lacks {k}");
    }
}

/// The run measures what else the machine did: busy cores of other
/// processes are seen, and the report says its timings are not clean.
#[test]
fn timings_say_when_other_work_shared_the_cores() {
    let clock = super::Clock::start();
    // Another process keeps one core busy for a second.
    let mut busy = std::process::Command::new("sh")
        .args(["-c", "end=$(($(date +%s) + 2)); while [ $(date +%s) -lt $end ]; do :; done"])
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let (_, others) = clock.load();
    // Measured before the child is waited for (then its time would count as this run's).
    let mut times = super::Times::default();
    times.push("e6".into(), &clock);
    let info = super::run_info(&times, &clock, None);
    let _ = busy.kill();
    let _ = busy.wait();
    assert!(others > 0.2, "a busy core of {} is {others}", crate::cores());
    let words = super::load_sentence(&info);
    assert!(words.contains("These timings are not clean") && words.contains("`e6`"), "{words}");
}

/// This run's own CPU time is this run's, not others': the fields of
/// `/proc/self/stat` are counted from the state letter (a parser that
/// skipped it once read stime, cutime, cstime and the priority, so an
/// in-process section showed 0.0 CPU-seconds and "90 %" taken by others);
/// and work done by this process counts as ours.
#[test]
fn this_runs_own_work_counts_as_its_own() {
    let line = "4242 (xtask (x)) R 1 2 3 4 5 6 7 8 9 10 111 22 33 44 20 0 9 0";
    assert_eq!(super::process_ticks(line), Some(111.0 + 22.0 + 33.0 + 44.0));
    // Work until this run's clock has counted half a CPU-second of it: a
    // parser that missed this process's own time never gets there. (However
    // busy the machine, half a second of CPU comes within the minute.)
    let clock = super::Clock::start();
    let give_up = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let mut x = 0u64;
    let ours = loop {
        let lap = std::time::Instant::now() + std::time::Duration::from_millis(50);
        while std::time::Instant::now() < lap {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        let (ours, _) = clock.load();
        if ours >= 0.5 || std::time::Instant::now() > give_up {
            break ours;
        }
    };
    assert!(ours >= 0.5, "a minute of this process's own work counted as {ours} CPU-seconds");
}

/// A section that fails late in the run loses only itself: each finished
/// section's results are kept on disk as they finish, the failure is
/// recorded with its error, and the report says which sections it lacks.
#[test]
fn a_failed_section_is_left_out_and_the_finished_ones_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let mut failed = Vec::new();
    let kept = super::settle(dir.path(), "experiments/e1.toml", Ok(stability("ours")), &mut failed);
    assert!(kept.is_some() && failed.is_empty());
    let saved = std::fs::read_to_string(dir.path().join("results/experiments_e1.toml.json")).unwrap();
    assert!(saved.contains("\"seeds\""), "the finished section's results are on disk");
    let lost: Option<StabilityResult> = super::settle(
        dir.path(),
        "experiments/hoap2-walk.toml",
        Err(anyhow::anyhow!("the simulator was not found")),
        &mut failed,
    );
    assert!(lost.is_none());
    assert_eq!(failed, vec![("experiments/hoap2-walk.toml".to_owned(), "the simulator was not found".to_owned())]);
    let args = <super::Args as clap::FromArgMatches>::from_arg_matches(
        &<super::Args as clap::Args>::augment_args(clap::Command::new("x")).get_matches_from(["x"]),
    )
    .unwrap();
    let r = super::Results {
        main: vec![("experiments/e1.toml".into(), Outcome::Stability(Box::new(kept.unwrap())))],
        tried: Vec::new(),
        families: None,
        times: super::Times::default(),
        failed,
    };
    let info = super::run_info(&super::Times::default(), &super::Clock::start(), None);
    let md = super::render(&args, &r, dir.path(), &info).unwrap();
    assert!(md.contains("1 section(s) of this run failed"), "{md}");
    assert!(md.contains("`experiments/hoap2-walk.toml`: the simulator was not found"), "{md}");
}

/// A rule that cannot apply says so: switch spikes where no seed holds a
/// rhythm (the paper's protocol once scored 0.03 of the teacher's amplitude)
/// are "not applicable: no rhythm", not a verdict.
#[test]
fn a_rule_that_cannot_apply_says_not_applicable() {
    let mut silent = gaits_with(0.17, false);
    for s in &mut silent.seeds {
        s.first.amplitude_ratio = 0.03;
        s.second.amplitude_ratio = 0.03;
    }
    silent.summarise();
    let v = doc_verdict(&silent.claims[1].verdict);
    assert!(v.starts_with("not applicable: no rhythm: 0 of 1 seeds hold both gaits"), "{v}");
    let live = gaits_with(0.17, false);
    assert!(!doc_verdict(&live.claims[1].verdict).contains("not applicable"));
}

fn doc_verdict(v: &cpg_lab::experiment::Verdict) -> String {
    cpg_lab::experiment::doc::verdict(v)
}

/// A verdict that passed at exactly its threshold over seeds says so (E4
/// ours, 8 of 10 with 80 % needed); one with a seed to spare does not.
#[test]
fn a_verdict_at_exactly_its_threshold_says_so() {
    use cpg_lab::experiment::{Judged, verdict_over};
    let j = |k: usize| -> Vec<Judged> { (0..10).map(|i| Judged { passed: i < k, at_limit: false }).collect() };
    let at = doc_verdict(&verdict_over(&j(8), 0.8, "r"));
    assert_eq!(at, "reproduced (at exactly its threshold: 8 of 10 seeds, 8 needed)");
    assert_eq!(doc_verdict(&verdict_over(&j(9), 0.8, "r")), "reproduced");
    assert_eq!(doc_verdict(&verdict_over(&j(10), 1.0, "r")), "reproduced", "all of them: no margin to speak of");
}

/// A median of whole counts that falls between two (41.5 channels) is
/// printed as it is, not rounded to a count no seed had.
#[test]
fn a_median_between_two_counts_keeps_its_half() {
    use cpg_lab::experiment::claim::Measure;
    let m = Measure::spread("channels within 15 %", &[41.0, 42.0, 38.0, 47.0], "of 62", 0);
    assert_eq!(cpg_lab::experiment::doc::value(&m.value), "41.5 of 62 (38–47; n = 4)");
    let m = Measure::spread("error", &[0.1234, 0.4321], "°", 2);
    assert_eq!(
        cpg_lab::experiment::doc::value(&m.value),
        "0.28 ° (0.12–0.43; n = 2)",
        "continuous values round as ever"
    );
}

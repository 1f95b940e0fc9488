//! The report's opening table (every claim of both papers, one row each) and
//! the table of what was tried.

use cpg_lab::experiment::Outcome;
use cpg_lab::experiment::families::FamiliesResult;

use super::fmt::{Md, anchor, median, verdict};
use super::reservoir::protocol_name_pub;

/// One row: claim, the paper's words, protocol, measured, verdict, rule, section link.
struct Row {
    claim: String,
    paper: String,
    protocol: String,
    measured: String,
    verdict: String,
    section: String,
}

fn link(heading: &str) -> String {
    format!("[↓](#{})", anchor(heading))
}

/// The summary table.
pub fn summary(md: &mut Md, outcomes: &[(String, Outcome)], families: Option<&FamiliesResult>, headings: &Headings) {
    let mut rows: Vec<Row> = Vec::new();
    for (_, o) in outcomes {
        let p = protocol_name_pub(o.header());
        match o {
            Outcome::Stability(r) => {
                let n = r.seeds.len();
                rows.push(Row {
                    claim: "E1: the femur pattern is learnt".into(),
                    paper: "\"little difference\" (Fig. 2 top)".into(),
                    protocol: p.clone(),
                    measured: format!(
                        "median first-{} NMSE {:.4} over {n} seeds",
                        r.first_samples,
                        r.median_first_nmse()
                    ),
                    verdict: verdict(r.e1_verdict().passed).into(),
                    section: link(&headings.stability),
                });
                rows.push(Row {
                    claim: format!("E2: stable after {:.0} s", r.long_run_s),
                    paper: "one run, stable after 900 s (Fig. 2 middle)".into(),
                    protocol: p.clone(),
                    measured: format!("{} of {n} seeds accurate, {} converged", r.n_accurate(), r.n_converged()),
                    verdict: verdict(r.e2_verdict().passed).into(),
                    section: link(&headings.stability),
                });
                let med = median(r.seeds.iter().filter_map(|s| s.recovery.orbit_s).collect());
                rows.push(Row {
                    claim: "E3: recovers from a 50 ms push".into(),
                    paper: "\"recovers well\" (Fig. 2 bottom)".into(),
                    protocol: p.clone(),
                    measured: format!(
                        "{} of {n} seeds back on the orbit{}",
                        r.n_recovered(),
                        if med.is_finite() { format!(", median {med:.2} s") } else { String::new() }
                    ),
                    verdict: verdict(r.e3_verdict().passed).into(),
                    section: link(&headings.stability),
                });
            }
            Outcome::Frequency(r) => rows.push(Row {
                claim: "E4: the frequency follows one control input over 1–6×".into(),
                paper: "up to 6× the original frequency (Fig. 3)".into(),
                protocol: p,
                measured: format!(
                    "{} of {} seeds within 5 % of u·f0 and 25 % of the amplitude at every plateau and on the paper's schedule",
                    r.n_passed(),
                    r.seeds.len()
                ),
                verdict: verdict(r.verdict().passed).into(),
                section: link(&headings.frequency),
            }),
            Outcome::Gaits(r) => rows.push(Row {
                claim: "E5: walk and run, switched smoothly by two inputs".into(),
                paper: "smooth transitions both ways (Fig. 4)".into(),
                protocol: p,
                measured: format!("{} of {} seeds pass both gaits and both switches", r.n_passed(), r.seeds.len()),
                verdict: verdict(r.verdict().passed).into(),
                section: link(&headings.gaits),
            }),
            Outcome::Coupling(r) => rows.push(Row {
                claim: "E6: 22 joints stay phase-coupled".into(),
                paper: "\"phase relation remains intact\" (Fig. 5)".into(),
                protocol: p,
                measured: format!(
                    "{} of {} seeds keep every joint's lag drift below 0.05 cycle over {:.0} s (largest: {:.3})",
                    r.n_passed(),
                    r.seeds.len(),
                    r.run_s,
                    r.seeds.iter().map(|s| s.worst_drift).fold(0.0, f64::max)
                ),
                verdict: verdict(r.verdict().passed).into(),
                section: link(&headings.coupling),
            }),
        }
    }
    if let Some(f) = families {
        let ns = &f.non_segmented;
        let two: Vec<&cpg_lab::experiment::families::FitRow> = ns.rows.iter().filter(|r| r.spec.centers == 2).collect();
        let falls = two.windows(2).all(|w| w[1].errors.mean_mm <= w[0].errors.mean_mm * 1.05);
        let (lo, hi) =
            (two.first().map_or(f64::NAN, |r| r.errors.mean_mm), two.last().map_or(f64::NAN, |r| r.errors.mean_mm));
        rows.push(Row {
            claim: "Centralized: error falls with the number of satellites".into(),
            paper: "Table 1, Figs. 13–16".into(),
            protocol: "reconstructed".into(),
            measured: format!(
                "2 centers: {lo:.1} mm at N = {} → {hi:.1} mm at N = {}",
                two.first().map_or(0, |r| r.spec.satellites),
                two.last().map_or(0, |r| r.spec.satellites)
            ),
            verdict: verdict(falls).into(),
            section: link(&headings.families),
        });
        let best = |m: usize| {
            ns.rows.iter().filter(|r| r.spec.centers == m).map(|r| r.errors.mean_mm).fold(f64::INFINITY, f64::min)
        };
        let beats = best(2).min(best(3)) < 0.8 * best(1);
        rows.push(Row {
            claim: "Centralized: 2–3 centers are needed (1 is much worse)".into(),
            paper: "Table 1; \"2 to 3 oscillators were sufficient\"".into(),
            protocol: "reconstructed".into(),
            measured: format!(
                "best 1 / 2 / 3 centers: {:.1} / {:.1} / {:.1} mm; AICc picks {} center(s)",
                best(1),
                best(2),
                best(3),
                ns.aicc_best.centers
            ),
            verdict: verdict(beats).into(),
            section: link(&headings.families),
        });
        let c216 = ns.rows.iter().find(|r| r.spec.centers == 2 && r.spec.satellites == 16).map(|r| r.errors.mean_mm);
        rows.push(Row {
            claim: "Centralized 2/16 beats the DMP on a trial".into(),
            paper: "Fig. 15: DMP 8.7 mm, 2/16 7.9 mm".into(),
            protocol: "reconstructed".into(),
            measured: format!(
                "DMP {:.1} mm, 2/16 {}",
                ns.dmp.0.mean_mm,
                c216.map_or("not fitted".into(), |v| format!("{v:.1} mm"))
            ),
            verdict: verdict(c216.is_some_and(|v| v < ns.dmp.0.mean_mm)).into(),
            section: link(&headings.families),
        });
        rows.push(Row {
            claim: "Table 1 on CMU 86_01".into(),
            paper: "Table 1".into(),
            protocol: "reconstructed".into(),
            measured: match &f.paper {
                Some(t) => format!("{} rows over {} segments", t.rows.len(), t.starts.len() - 1),
                None => "not run: 86_01.amc is not on this machine".into(),
            },
            verdict: if f.paper.is_some() { "see the section".into() } else { "not run".into() },
            section: link(&headings.families),
        });
    }
    md.line("## Summary");
    md.blank();
    md.line("Every claim of both papers, as measured by this run. Each verdict's rule is printed in its section.");
    md.blank();
    let table: Vec<Vec<String>> =
        rows.into_iter().map(|r| vec![r.claim, r.paper, r.protocol, r.measured, r.verdict, r.section]).collect();
    md.table(&["claim", "the paper", "protocol", "measured", "verdict", "section"], "lllllr", &table);
}

/// The headings the summary links to.
pub struct Headings {
    pub stability: String,
    pub frequency: String,
    pub gaits: String,
    pub coupling: String,
    pub families: String,
}

/// What was tried: every configuration run, its method, and how many seeds passed.
pub fn tried(md: &mut Md, runs: &[(String, Outcome)]) {
    md.line("## What we tried");
    md.blank();
    md.line("Every configuration this run trained and tested, the paper's protocol, ours and the variants we tried on the way (`experiments/tried/`), each scored by its experiment's own rule (printed in its section).");
    md.blank();
    let rows: Vec<Vec<String>> = runs
        .iter()
        .map(|(file, o)| {
            let h = o.header();
            let (p, n) = o.passed();
            let what = match o {
                Outcome::Stability(_) => "accurate after the long run",
                Outcome::Frequency(_) => "every plateau passed",
                Outcome::Gaits(_) => "both gaits and switches passed",
                Outcome::Coupling(_) => "phase coupling kept",
            };
            vec![
                h.id.clone(),
                format!("`{file}`"),
                h.method.clone(),
                h.score.clone(),
                format!("{} neurons", h.n_neurons),
                format!("{p} of {n} ({what})"),
            ]
        })
        .collect();
    md.table(
        &["experiment", "configuration", "method and setting", "validation score", "reservoir", "seeds passing"],
        "llllll",
        &rows,
    );
}

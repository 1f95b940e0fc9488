//! The report's opening table (every claim of both papers, one row per
//! claim and configuration) and the table of what was tried. Both format
//! the claims the results carry.

use cpg_lab::experiment::Outcome;
use cpg_lab::experiment::claim::Claim;
use cpg_lab::experiment::doc::{anchor, sources, value, verdict};
use cpg_lab::experiment::families::FamiliesResult;

use super::fmt::Md;

fn link(heading: &str) -> String {
    format!("[↓](#{})", anchor(heading))
}

fn protocol_word(p: &str) -> &str {
    match p {
        "paper" => "the paper's",
        "ours" => "ours",
        "extension" => "our extension",
        other => other,
    }
}

/// One row of the summary.
fn row(c: &Claim, section: &str) -> Vec<String> {
    vec![
        format!("{}: {}", c.experiment, c.claim),
        sources(&c.sources),
        protocol_word(&c.protocol).to_owned(),
        if c.differs.is_empty() { "—".into() } else { c.differs.join("; ") },
        c.measured.iter().map(|m| format!("{}: {}", m.label, value(&m.value))).collect::<Vec<_>>().join("; "),
        verdict(&c.verdict),
        link(section),
    ]
}

/// The summary table.
pub fn summary(md: &mut Md, outcomes: &[(String, Outcome)], families: Option<&FamiliesResult>) {
    let mut rows: Vec<Vec<String>> = Vec::new();
    for (_, o) in outcomes {
        let h = o.experiment().heading();
        rows.extend(o.claims().iter().map(|c| row(c, &h)));
    }
    if let Some(f) = families {
        rows.extend(f.claims.iter().map(|c| row(c, FamiliesResult::HEADING)));
    }

    md.line("## Summary");
    md.blank();
    md.line("Every claim of both papers, as measured by this run, one row per claim and configuration. *The paper* quotes its words exactly (each quote is checked against the text in `shared/papers/` by this run) or, where the surviving text does not say it in words, gives our reading marked *inferred*. *What differs* is read from the configuration files: each setting in which the configuration differs from the paper's protocol (for the paper's protocol, from what the paper states). Each verdict's rule is printed in its section; *at the limit* marks a verdict that a comparison closer than the printed digits decided.");
    md.blank();
    md.table(
        &["claim", "the paper", "protocol", "what differs from the paper", "measured", "verdict", "section"],
        "lllllll",
        &rows,
    );
}

/// What was tried: every configuration run, its method, and how many seeds passed.
pub fn tried(md: &mut Md, runs: &[(String, Outcome)]) {
    md.line("## What we tried");
    md.blank();
    md.line("Every configuration this run trained and tested: the paper's protocol, ours, our extensions and the variants we tried on the way (`experiments/tried/`), each scored by its experiment's own rule (printed in its section) over the seeds it ran.");
    md.blank();
    let rows: Vec<Vec<String>> = runs
        .iter()
        .map(|(file, o)| {
            let h = o.header();
            let (p, n) = o.passed();
            let what = o.experiment().target();
            vec![
                h.id.clone(),
                format!("`{file}`"),
                protocol_word(h.protocol.as_str()).to_owned(),
                h.method.clone(),
                h.score.to_string(),
                format!("{} neurons", h.n_neurons),
                format!("{p} of {n} ({what})"),
            ]
        })
        .collect();
    md.table(
        &[
            "experiment",
            "configuration",
            "protocol",
            "method and setting",
            "validation score",
            "reservoir",
            "seeds passing",
        ],
        "lllllll",
        &rows,
    );
}

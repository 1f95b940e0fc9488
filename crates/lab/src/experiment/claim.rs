//! What the report says about each claim of the two papers, as data: the
//! paper's words (quoted exactly, or marked as our reading where the
//! surviving text does not say it), what was measured (aggregates computed
//! here, once), the rule and the verdict. The report and `metrics.json`
//! format these; they compute nothing.

use serde::Serialize;

use crate::stats::{Proportion, Spread};

/// A source paper, by the file its text is kept in (`shared/papers/`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Paper {
    /// wyffels & Schrauwen (2009), the reservoir-computing CPG.
    WyffelsSchrauwen2009,
    /// Vakulenko et al. (2017), centralized networks (headings, captions and Table 1 survive).
    Vakulenko2017,
}

impl Paper {
    /// The file of its text in `shared/papers/`.
    pub fn file_name(self) -> &'static str {
        match self {
            Paper::WyffelsSchrauwen2009 => "wyffels-schrauwen-2009-rc-cpg.txt",
            Paper::Vakulenko2017 => "vakulenko-2017-centralized-networks.txt",
        }
    }

    /// How the report names it.
    pub fn cite(self) -> &'static str {
        match self {
            Paper::WyffelsSchrauwen2009 => "wyffels & Schrauwen (2009)",
            Paper::Vakulenko2017 => "Vakulenko et al. (2017)",
        }
    }
}

/// Words of a paper, exactly as its text has them (a test finds each one in
/// the file, whitespace aside).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Quote {
    /// Which paper.
    pub paper: Paper,
    /// Where in it (a figure, a section).
    pub place: &'static str,
    /// The words.
    pub text: &'static str,
}

const fn ws(place: &'static str, text: &'static str) -> Quote {
    Quote { paper: Paper::WyffelsSchrauwen2009, place, text }
}

/// E1: Fig. 2's caption on the learnt pattern.
pub const LITTLE_DIFFERENCE: Quote =
    ws("Fig. 2", "We see little difference between the reservoir output and the teacher signal.");
/// E2: Fig. 2's caption on the long run.
pub const AFTER_900_S: Quote = ws(
    "Fig. 2",
    "In the middle graph we see a continuation of the system's output after 900 seconds of running freely. This illustrates the stability capabilities of our system.",
);
/// E3: Fig. 2's caption on the push.
pub const RECOVERS_WELL: Quote = ws("Fig. 2", "We see that the network recovers well after such a perturbation.");
/// E4: the training range of the control input.
pub const SIX_TIMES: Quote = ws(
    "Sec. III-B",
    "This input signal varied between 1 to 6 during training in a smooth way causing a maximal increase of frequency by six times its original frequency.",
);
/// E4: Fig. 3's caption.
pub const SMOOTH_CHANGE: Quote = ws(
    "Fig. 3",
    "The corresponding control input, illustrated with a gray curve, was switched smoothly from a high value to a low value and back to a high value again causing a smooth change in frequency from high to low, to high again.",
);
/// E4: the only change to the reservoir.
pub const ONE_CHANGE: Quote =
    ws("Sec. III-B", "the described control input was connected to 25% of the reservoir neurons");
/// E5: transitions without examples.
pub const NO_TRANSITION_EXAMPLES: Quote = ws(
    "Sec. III-B",
    "Although we gave our system no examples of transition between different gaits during training, we are able to generate smooth transitions which are necessary in robot locomotion control.",
);
/// E5: abrupt switches.
pub const SPIKES: Quote = ws(
    "Sec. III-B",
    "Abrupt change of these control inputs will result in large amplitude spikes of the system's outcome which is not desired.",
);
/// E6: the phase relation.
pub const PHASE_INTACT: Quote = ws("Sec. III-C", "We see that phase relation remains intact.");

const fn vk(place: &'static str, text: &'static str) -> Quote {
    Quote { paper: Paper::Vakulenko2017, place, text }
}

/// Centralized: the AICc optimum.
pub const AICC_OPTIMUM: Quote = vk("Fig. 13", "The global optimum was reached for three centers and 150 satellites.");
/// Centralized: the DMP comparison of Fig. 15.
pub const FIG15_AVERAGES: Quote = vk(
    "Fig. 15",
    "The average over all segments is 8.7 mm for the DMPs, 7.9 mm for two centers and 16 satellites, and 6.7 mm for two centers and 100 satellites.",
);

/// Every quote a claim can carry (the test that finds them in the papers reads this).
pub const QUOTES: [Quote; 12] = [
    LITTLE_DIFFERENCE,
    AFTER_900_S,
    RECOVERS_WELL,
    SIX_TIMES,
    SMOOTH_CHANGE,
    ONE_CHANGE,
    NO_TRANSITION_EXAMPLES,
    SPIKES,
    PHASE_INTACT,
    AICC_OPTIMUM,
    FIG15_AVERAGES,
    // Table 1's caption, for the claims read from its numbers.
    vk(
        "Table 1",
        "Integral relative accuracies of approximations by centralized networks of CMU 86 Trial 1 using different numbers of oscillators and satellites.",
    ),
];

/// Table 1's caption.
pub const TABLE1_CAPTION: Quote = QUOTES[11];

/// Where a claim's words come from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Source {
    /// The paper's words.
    Quote(Quote),
    /// Our reading of the paper, where its surviving text does not say it in words.
    Inferred {
        /// What we read.
        text: String,
    },
}

/// A measured value, as the report prints it.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Value {
    /// Seeds (or trials) that met a condition, with the 95 % interval of the rate.
    Count(Proportion),
    /// The median and range over seeds.
    Spread {
        /// The aggregate.
        spread: Spread,
        /// Unit (`""`, `s`, `mm`, `cycles`).
        unit: String,
        /// Decimals printed.
        digits: usize,
    },
    /// One number.
    Number {
        /// The value.
        value: f64,
        /// Unit.
        unit: String,
        /// Decimals printed.
        digits: usize,
    },
    /// Words (a penalty range, a size).
    Text {
        /// What to print.
        text: String,
    },
}

/// One measured thing: a label and its value.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measure {
    /// What was measured (`seeds accurate after 900 s`).
    pub label: String,
    /// The value.
    pub value: Value,
}

impl Measure {
    /// A count.
    pub fn count(label: impl Into<String>, p: Proportion) -> Measure {
        Measure { label: label.into(), value: Value::Count(p) }
    }

    /// A spread over seeds.
    pub fn spread(label: impl Into<String>, v: &[f64], unit: &str, digits: usize) -> Measure {
        Measure { label: label.into(), value: Value::Spread { spread: Spread::of(v), unit: unit.into(), digits } }
    }

    /// One number.
    pub fn number(label: impl Into<String>, value: f64, unit: &str, digits: usize) -> Measure {
        Measure { label: label.into(), value: Value::Number { value, unit: unit.into(), digits } }
    }

    /// Words.
    pub fn text(label: impl Into<String>, text: impl Into<String>) -> Measure {
        Measure { label: label.into(), value: Value::Text { text: text.into() } }
    }
}

/// What a verdict decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// The rule held.
    Reproduced,
    /// It did not.
    NotReproduced,
    /// The test could not run (its data is missing).
    NotRun,
    /// The rule cannot apply to what ran (a switch's spikes where there is
    /// no rhythm to switch between): the verdict's note says why.
    NotApplicable,
}

/// Whether a claim was reproduced, and the rule that says so.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The decision.
    pub decision: Decision,
    /// Some comparison that decided it was closer than the report prints
    /// (so the decision could flip with the last digit).
    pub at_limit: bool,
    /// The rule, as printed beside the verdict.
    pub rule: String,
    /// What the verdict's word alone does not say: that it passed at exactly
    /// its threshold over seeds, or why the rule could not apply.
    pub note: Option<String>,
}

impl Verdict {
    /// A verdict from whether the rule held.
    pub fn new(passed: bool, at_limit: bool, rule: impl Into<String>) -> Verdict {
        Verdict {
            decision: if passed { Decision::Reproduced } else { Decision::NotReproduced },
            at_limit,
            rule: rule.into(),
            note: None,
        }
    }

    /// A test that did not run.
    pub fn not_run(rule: impl Into<String>) -> Verdict {
        Verdict { decision: Decision::NotRun, at_limit: false, rule: rule.into(), note: None }
    }

    /// A rule that cannot apply to what ran, and why (`no rhythm: …`).
    pub fn not_applicable(why: impl Into<String>, rule: impl Into<String>) -> Verdict {
        Verdict { decision: Decision::NotApplicable, at_limit: false, rule: rule.into(), note: Some(why.into()) }
    }

    /// The rule held.
    pub fn passed(&self) -> bool {
        self.decision == Decision::Reproduced
    }
}

/// A verdict over seeds: at least `fraction` of the `n` seeds (rounded up)
/// passed. `passed` seeds pass, of which `passed_at_limit` only by less than
/// the printed digits, and `failed_at_limit` failing seeds missed by as
/// little: the verdict is at the limit when those could change it.
pub fn over_seeds(
    passed: usize,
    n: usize,
    fraction: f64,
    passed_at_limit: usize,
    failed_at_limit: usize,
) -> (bool, bool) {
    let needed = seeds_needed(n, fraction);
    let ok = n > 0 && passed >= needed;
    let fragile = if ok { passed - passed_at_limit.min(passed) < needed } else { passed + failed_at_limit >= needed };
    (ok, fragile && n > 0)
}

/// Seeds of `n` that must pass for a share of `fraction`.
pub fn seeds_needed(n: usize, fraction: f64) -> usize {
    (fraction * n as f64 - 1e-9).ceil() as usize
}

/// One claim of a paper as this run measured it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Claim {
    /// The experiment (`E2`, `Centralized`).
    pub experiment: String,
    /// The claim in our words.
    pub claim: String,
    /// The paper's words or our reading of it.
    pub sources: Vec<Source>,
    /// `paper`, `ours`, `extension`, `tried` or `reconstructed`.
    pub protocol: String,
    /// What differs from the paper's protocol, one item each (empty: nothing the paper states).
    pub differs: Vec<String>,
    /// What was measured.
    pub measured: Vec<Measure>,
    /// The verdict and its rule.
    pub verdict: Verdict,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_verdict_over_seeds_is_at_the_limit_only_when_the_close_seeds_could_change_it() {
        // 8 of 10 at 80 %: passes; one of them by a hair makes it fragile.
        assert_eq!(over_seeds(8, 10, 0.8, 0, 0), (true, false));
        assert_eq!(over_seeds(8, 10, 0.8, 1, 0), (true, true));
        assert_eq!(over_seeds(9, 10, 0.8, 1, 0), (true, false));
        // 7 of 10 fails; one near miss could make it pass.
        assert_eq!(over_seeds(7, 10, 0.8, 0, 1), (false, true));
        assert_eq!(over_seeds(6, 10, 0.8, 0, 1), (false, false));
        assert_eq!(over_seeds(9, 10, 0.9, 0, 0), (true, false));
        assert_eq!(over_seeds(0, 0, 0.9, 0, 0), (false, false));
    }
}

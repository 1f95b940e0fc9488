//! The experiments of wyffels & Schrauwen (2009), each the protocol of a
//! configuration's `[experiment]` table, returning typed results. The report
//! (`cargo xtask evaluate`) renders them; nothing here prints.

pub mod body;
pub mod claim;
pub mod conditions;
pub mod coupling;
pub mod differs;
pub mod doc;
pub mod families;
pub mod frequency;
pub mod gaits;
pub mod stability;
pub mod walking;

use rayon::prelude::*;
use serde::Serialize;

use crate::config::{Config, ExperimentSection, ExperimentTest};
use crate::error::Result;
use crate::prepare::{Prepared, SegmentCycle, prepare};
use crate::train::{penalty_at_edge, train_prepared};
use cpg_reservoir::TrainedCpg;

pub use claim::{Claim, Measure, Verdict};

/// Seeds needed for a verdict over seeds: at least `fraction` of them (rounded up).
pub fn enough(passed: usize, seeds: usize, fraction: f64) -> bool {
    claim::over_seeds(passed, seeds, fraction, 0, 0).0
}

/// A seed's judgement: whether it passed and whether a comparison that
/// decided it was closer than the report prints.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Judged {
    /// Every part of the rule held.
    pub passed: bool,
    /// Some deciding comparison was within half a printed digit of its limit.
    pub at_limit: bool,
}

/// The verdict over seeds judged `j`: at least `fraction` of them passed
/// (rounded up), at the limit when seeds decided by a hair could change it.
pub fn verdict_over(j: &[Judged], fraction: f64, rule: impl Into<String>) -> Verdict {
    let passed = j.iter().filter(|s| s.passed).count();
    let pl = j.iter().filter(|s| s.passed && s.at_limit).count();
    let fl = j.iter().filter(|s| !s.passed && s.at_limit).count();
    let (ok, fragile) = claim::over_seeds(passed, j.len(), fraction, pl, fl);
    let mut v = Verdict::new(ok, fragile, rule);
    let needed = claim::seeds_needed(j.len(), fraction);
    if ok && passed == needed && passed < j.len() {
        v.note = Some(format!("at exactly its threshold: {passed} of {} seeds, {needed} needed", j.len()));
    }
    v
}

/// Reports how far a long experiment has come (the app draws a progress bar).
pub trait Progress: Sync {
    /// A task of `total` steps begins.
    fn start(&self, label: &str, total: u64);
    /// One step is done.
    fn tick(&self);
    /// The task is done.
    fn finish(&self);
}

/// A progress report that shows nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Quiet;

impl Progress for Quiet {
    fn start(&self, _: &str, _: u64) {}
    fn tick(&self) {}
    fn finish(&self) {}
}

/// How big a run is, and on how many threads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// The quick variant: fewer seeds and shorter runs (the `quick_*` keys).
    pub quick: bool,
    /// Threads the experiment runs on (its own pool; the results do not depend on it).
    pub threads: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options { quick: false, threads: 1 }
    }
}

/// How one seed's model was trained.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeedModel {
    /// Reservoir seed.
    pub seed: u64,
    /// Chosen ridge penalty.
    pub penalty: f64,
    /// Its validation score.
    pub validation_score: f64,
    /// The penalty is the first or the last of the grid.
    pub penalty_at_edge: bool,
    /// Which edge: `upper` (the largest penalty), `lower`, or none.
    pub edge: Option<Edge>,
    /// The validation curve: (penalty, score) for every penalty of the grid.
    pub curve: Vec<(f64, f64)>,
}

impl SeedModel {
    /// The record of `m`, trained with `seed`.
    pub fn of(m: &TrainedCpg, seed: u64) -> SeedModel {
        let p = &m.provenance;
        SeedModel {
            seed,
            penalty: p.chosen_penalty,
            validation_score: p.validation_curve.iter().map(|v| v.nmse).fold(f64::INFINITY, f64::min),
            penalty_at_edge: penalty_at_edge(m),
            edge: edge_of(m),
            curve: p.validation_curve.iter().map(|v| (v.penalty, v.nmse)).collect(),
        }
    }
}

/// A penalty as the report prints it: `1.26e-2`, `1.00e1`.
pub fn pen(x: f64) -> String {
    if x == 0.0 { "0".into() } else { format!("{x:.2e}") }
}

/// An end of the penalty grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Edge {
    /// The largest penalty of the grid.
    Upper,
    /// The smallest.
    Lower,
}

fn edge_of(m: &TrainedCpg) -> Option<Edge> {
    let v = m.provenance.settings.penalties.values();
    let p = m.provenance.chosen_penalty;
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    if v.len() < 2 {
        None
    } else if p == hi {
        Some(Edge::Upper)
    } else if p == lo {
        Some(Edge::Lower)
    } else {
        None
    }
}

/// Sentences on the penalties the seeds chose: how many sit at an edge of
/// the grid and, for the paper's score, whether the best score there is a
/// constant output's (then no wider grid helps).
pub fn penalty_warnings(seeds: &[&SeedModel], h: &Header) -> Vec<String> {
    let n = seeds.len();
    let (_, hi, lo) = h.penalty_grid;
    let mut out = Vec::new();
    for (edge, name, at) in [(Edge::Upper, "upper", hi), (Edge::Lower, "lower", lo)] {
        let on: Vec<&&SeedModel> = seeds.iter().filter(|s| s.edge == Some(edge)).collect();
        if on.is_empty() {
            continue;
        }
        let scores: Vec<f64> = on.iter().map(|s| s.validation_score).collect();
        let sp = crate::stats::Spread::of(&scores);
        let flat = h.score == crate::config::ScoreKind::Nmse && edge == Edge::Upper && sp.min >= CONSTANT_OUTPUT_NMSE;
        out.push(format!(
            "The penalty sits at the grid's {name} edge (10^{at}) for {} of {n} seeds, with validation scores {:.3}–{:.3}{}",
            on.len(),
            sp.min,
            sp.max,
            if flat {
                format!(
                    ": at least {CONSTANT_OUTPUT_NMSE}, about the NMSE of a constant output (1), so the score falls as the readout shrinks toward silence and no wider grid would hold a better penalty."
                )
            } else {
                ": the best penalty may lie beyond the grid.".to_owned()
            }
        ));
    }
    out
}

/// The rows every experiment's table ends with (the penalties its seeds
/// chose, the lowest and highest, and how many sit at the grid's edge); the
/// header's warnings about them are set on the way.
pub(crate) fn penalty_rows(models: &[&SeedModel], header: &mut Header) -> [Measure; 2] {
    let pens: Vec<f64> = models.iter().map(|m| m.penalty).collect();
    let sp = crate::stats::Spread::of(&pens);
    header.warnings = penalty_warnings(models, header);
    [
        Measure::text("chosen penalty, lowest – highest", format!("{} – {}", pen(sp.min), pen(sp.max))),
        Measure::count(
            "seeds whose penalty sits at the grid's edge",
            crate::stats::Proportion::count(models.iter().map(|m| m.penalty_at_edge)),
        ),
    ]
}

/// A validation NMSE at least this large is about a constant output's (1).
pub const CONSTANT_OUTPUT_NMSE: f64 = 0.95;

/// What every experiment reports about itself.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Header {
    /// Short name (`E1`).
    pub id: String,
    /// Title.
    pub title: String,
    /// Whose protocol.
    pub protocol: crate::config::Protocol,
    /// What the configuration tries.
    pub method: String,
    /// The configuration file.
    pub config: String,
    /// What the data preparation found (periods, loops, seams).
    pub cycles: Vec<SegmentCycle>,
    /// Notes of the data preparation.
    pub notes: Vec<String>,
    /// Validation score (`nmse` or `orbit`).
    pub score: crate::config::ScoreKind,
    /// Validation state-noise variance.
    pub noise_variance: f64,
    /// Number of penalties in the grid, and its ends (log10).
    pub penalty_grid: (usize, f64, f64),
    /// Reservoir size.
    pub n_neurons: usize,
    /// What this configuration changes against the paper's protocol.
    pub differs: Vec<differs::Difference>,
    /// The conditions of its validation and of its test.
    pub conditions: conditions::Conditions,
    /// Warnings about the run (penalties at the grid's edge).
    pub warnings: Vec<String>,
}

/// The title of an experiment's view: `E5 (our protocol): walk/run switching …`.
pub(crate) fn view_title(c: &Config) -> String {
    match &c.experiment {
        Some(e) => {
            format!(
                "{} ({} protocol): {}",
                e.id,
                if e.protocol == crate::config::Protocol::Paper { "the paper's" } else { "our" },
                e.title
            )
        }
        None => c.source.display().to_string(),
    }
}

/// The [`Experiment`] accessors of a result whose fields have the common
/// names: `header`, `claims`, `table`, and `seeds` each with its `model`.
macro_rules! common_accessors {
    () => {
        fn header(&self) -> &$crate::experiment::Header {
            &self.header
        }
        fn claims(&self) -> &[$crate::experiment::Claim] {
            &self.claims
        }
        fn table(&self) -> &[$crate::experiment::Measure] {
            &self.table
        }
        fn seed_models(&self) -> Vec<&$crate::experiment::SeedModel> {
            self.seeds.iter().map(|s| &s.model).collect()
        }
    };
}
pub(crate) use common_accessors;

/// What every experiment's result is: a heading, claims (each with its
/// measured aggregates, rule and verdict), a count of the seeds that met
/// its target, and its section of the report, built from the results alone
/// (every protocol of the experiment side by side). A new kind of
/// experiment is a module with its result type implementing this, and a
/// variant of [`Outcome`]; the compiler points to every place that
/// dispatches over the kinds.
pub trait Experiment {
    /// Which figure of the paper the section reproduces (`Fig. 2`).
    fn figure(&self) -> &'static str;
    /// The header: what the configuration is and how it was validated.
    fn header(&self) -> &Header;
    /// The claims it measured, in report order.
    fn claims(&self) -> &[Claim];
    /// Its other aggregates, shown beside the claims.
    fn table(&self) -> &[Measure];
    /// How each seed's model was trained (its penalty and validation curve).
    fn seed_models(&self) -> Vec<&SeedModel>;
    /// Seeds that met the experiment's target, and seeds run.
    fn passed(&self) -> (usize, usize);
    /// What meeting the target means, for the table of what was tried.
    fn target(&self) -> &'static str;
    /// The section of the report for every protocol of this experiment.
    fn section(all: &[&Self], ctx: &doc::Context) -> Result<doc::Section>
    where
        Self: Sized;
    /// The section's heading (the summary links to it).
    fn heading(&self) -> String {
        doc::section_heading(self.header(), self.figure())
    }
}

/// The results of one experiment configuration.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Outcome {
    /// E1–E3.
    Stability(Box<stability::StabilityResult>),
    /// E4.
    Frequency(Box<frequency::FrequencyResult>),
    /// E5.
    Gaits(Box<gaits::GaitsResult>),
    /// E6.
    Coupling(Box<coupling::CouplingResult>),
    /// Walking in physics.
    Walking(Box<walking::WalkingResult>),
    /// The whole body in one generator.
    WholeBody(Box<body::BodyResult>),
}

impl Outcome {
    /// The result as an [`Experiment`].
    pub fn experiment(&self) -> &dyn Experiment {
        match self {
            Outcome::Stability(r) => r.as_ref(),
            Outcome::Frequency(r) => r.as_ref(),
            Outcome::Gaits(r) => r.as_ref(),
            Outcome::Coupling(r) => r.as_ref(),
            Outcome::Walking(r) => r.as_ref(),
            Outcome::WholeBody(r) => r.as_ref(),
        }
    }

    /// The header.
    pub fn header(&self) -> &Header {
        self.experiment().header()
    }

    /// The claims it measured, in report order.
    pub fn claims(&self) -> &[Claim] {
        self.experiment().claims()
    }

    /// Seeds that met the experiment's target, and seeds run.
    pub fn passed(&self) -> (usize, usize) {
        self.experiment().passed()
    }

    /// The report's sections of `all`: one per kind of experiment, in the
    /// order the kinds first appear, each with every configuration of that
    /// kind side by side.
    pub fn sections(all: &[&Outcome], ctx: &doc::Context) -> Result<Vec<doc::Section>> {
        fn pick<'a, T>(all: &[&'a Outcome], f: impl Fn(&'a Outcome) -> Option<&'a T>) -> Vec<&'a T> {
            all.iter().filter_map(|o| f(o)).collect()
        }
        let mut done: Vec<std::mem::Discriminant<Outcome>> = Vec::new();
        let mut out = Vec::new();
        for o in all {
            let kind = std::mem::discriminant(*o);
            if done.contains(&kind) {
                continue;
            }
            done.push(kind);
            out.push(match o {
                Outcome::Stability(_) => stability::StabilityResult::section(
                    &pick(all, |x| if let Outcome::Stability(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
                Outcome::Frequency(_) => frequency::FrequencyResult::section(
                    &pick(all, |x| if let Outcome::Frequency(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
                Outcome::Gaits(_) => gaits::GaitsResult::section(
                    &pick(all, |x| if let Outcome::Gaits(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
                Outcome::Coupling(_) => coupling::CouplingResult::section(
                    &pick(all, |x| if let Outcome::Coupling(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
                Outcome::Walking(_) => walking::WalkingResult::section(
                    &pick(all, |x| if let Outcome::Walking(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
                Outcome::WholeBody(_) => body::BodyResult::section(
                    &pick(all, |x| if let Outcome::WholeBody(r) = x { Some(r.as_ref()) } else { None }),
                    ctx,
                )?,
            });
        }
        Ok(out)
    }
}

/// The `[experiment]` section of `c`, or an error naming the file.
pub fn section(c: &Config) -> Result<&ExperimentSection> {
    c.experiment.as_ref().ok_or_else(|| c.error("experiment", "this configuration has no [experiment] section"))
}

/// The seeds an experiment runs: the configuration's seed and the following ones.
pub fn seeds(c: &Config, opts: Options) -> Result<Vec<u64>> {
    let e = section(c)?;
    let n = if opts.quick { e.quick_seeds.min(e.seeds) } else { e.seeds };
    if n == 0 || n > 1000 {
        return Err(c.error("experiment.seeds", format!("{n}; expected 1 to 1000")));
    }
    Ok((0..n).map(|k| c.reservoir.seed + k).collect())
}

/// Prepares the data once and trains one model per seed (seeds in parallel
/// on the caller's pool, each validation on `threads` threads; results in
/// seed order: the same whatever the thread count).
pub fn train_seeds(
    c: &Config,
    seeds: &[u64],
    threads: usize,
    progress: &dyn Progress,
) -> Result<(Prepared, Vec<TrainedCpg>)> {
    let p = prepare(c)?;
    progress.start("training", seeds.len() as u64);
    let models: Result<Vec<TrainedCpg>> = seeds
        .par_iter()
        .map(|&s| {
            let m = train_prepared(c, &p, s, threads);
            progress.tick();
            m
        })
        .collect();
    progress.finish();
    Ok((p, models?))
}

/// The header of an experiment on configuration `c` with prepared data `p`.
pub fn header(c: &Config, p: &Prepared, n_neurons: usize) -> Result<Header> {
    let e = section(c)?;
    let g = c.training.penalty_log10;
    Ok(Header {
        id: e.id.clone(),
        title: e.title.clone(),
        protocol: e.protocol,
        method: e.method.clone().unwrap_or_else(|| format!("the {} protocol", e.protocol)),
        config: c.source.display().to_string(),
        cycles: p.cycles.clone(),
        notes: p.notes.clone(),
        score: c.training.score,
        noise_variance: c.training.noise_variance,
        penalty_grid: (crate::train::train_settings(c)?.penalties.len(), g.start, g.stop),
        n_neurons,
        differs: match (e.protocol, &e.paper_config) {
            (crate::config::Protocol::Paper, _) => differs::paper_protocol_differences(c, &p.cycles),
            // The files as written (a quick run changes sizes in memory).
            (_, Some(p)) => {
                differs::differences(&Config::load(p)?, &Config::load(&c.source).unwrap_or_else(|_| c.clone()))?
            }
            (_, None) => Vec::new(),
        },
        conditions: conditions::conditions(c)?,
        warnings: Vec::new(),
    })
}

/// Whether E6 configurations `a` and `b` draw the same reservoir for every
/// seed they run (the same `[reservoir]` section, seeds and quick size), so
/// that [`run_together`] can advance their long free runs in one pass.
pub fn share_reservoirs(a: &Config, b: &Config) -> bool {
    match (a.experiment.as_ref(), b.experiment.as_ref()) {
        (Some(x), Some(y)) => match (x.coupling(), y.coupling()) {
            (Some(kx), Some(ky)) => {
                a.reservoir == b.reservoir
                    && x.seeds == y.seeds
                    && x.quick_seeds == y.quick_seeds
                    && kx.quick_neurons == ky.quick_neurons
            }
            _ => false,
        },
        _ => false,
    }
}

/// Runs several experiments, each with the outcome [`run`] gives it. E6
/// configurations that [`share_reservoirs`] run their seeds together (see
/// [`coupling::run_together`]); the others run one after another.
pub fn run_together(cs: &[&Config], opts: Options, progress: &dyn Progress) -> Result<Vec<Outcome>> {
    crate::in_pool(opts.threads, || run_together_here(cs, opts, progress))
}

fn run_together_here(cs: &[&Config], opts: Options, progress: &dyn Progress) -> Result<Vec<Outcome>> {
    let shared = cs.len() > 1 && cs.windows(2).all(|w| share_reservoirs(w[0], w[1]));
    if !shared {
        return cs.iter().map(|c| run_here(c, opts, progress)).collect();
    }
    let items = cs
        .iter()
        .map(|c| {
            let k = section(c)?.coupling().ok_or_else(|| c.error("experiment.test.coupling", "missing"))?;
            Ok((*c, k))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(coupling::run_together(&items, opts, progress)?.into_iter().map(|r| Outcome::Coupling(Box::new(r))).collect())
}

/// Runs the experiment of `c` on a pool of `opts.threads` threads.
pub fn run(c: &Config, opts: Options, progress: &dyn Progress) -> Result<Outcome> {
    crate::in_pool(opts.threads, || run_here(c, opts, progress))
}

fn run_here(c: &Config, opts: Options, progress: &dyn Progress) -> Result<Outcome> {
    Ok(match &section(c)?.test {
        ExperimentTest::Stability(s) => Outcome::Stability(Box::new(stability::run(c, s, opts, progress)?)),
        ExperimentTest::Frequency(f) => Outcome::Frequency(Box::new(frequency::run(c, f, opts, progress)?)),
        ExperimentTest::Gaits(g) => Outcome::Gaits(Box::new(gaits::run(c, g, opts, progress)?)),
        ExperimentTest::Coupling(k) => Outcome::Coupling(Box::new(coupling::run(c, k, opts, progress)?)),
        ExperimentTest::WholeBody(b) => Outcome::WholeBody(Box::new(body::run(c, b, opts, progress)?)),
        ExperimentTest::Walking(_) => {
            return Err(c.error(
                "experiment.test.walking",
                "runs in the Python package's simulator (MuJoCo): `cargo xtask evaluate --experiment walking` runs it",
            ));
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(score: &str) -> Header {
        Header {
            id: "E4".into(),
            title: "a test".into(),
            protocol: crate::config::Protocol::Paper,
            method: String::new(),
            config: String::new(),
            cycles: Vec::new(),
            notes: Vec::new(),
            score: score.parse().unwrap(),
            noise_variance: 1e-3,
            penalty_grid: (131, 5.0, -8.0),
            n_neurons: 300,
            differs: Vec::new(),
            conditions: conditions::Conditions { validation: Vec::new(), tuned: Vec::new(), test: Vec::new() },
            warnings: Vec::new(),
        }
    }

    fn seed(edge: Option<Edge>, score: f64) -> SeedModel {
        SeedModel {
            seed: 1,
            penalty: 1e5,
            validation_score: score,
            penalty_at_edge: edge.is_some(),
            edge,
            curve: Vec::new(),
        }
    }

    #[test]
    fn a_penalty_at_the_grid_edge_is_a_warning_that_says_why() {
        // The paper's score at a constant output's NMSE: no wider grid helps.
        let (a, b, c) = (seed(Some(Edge::Upper), 1.001), seed(Some(Edge::Upper), 1.002), seed(None, 0.9));
        let w = penalty_warnings(&[&a, &b, &c], &header("nmse"));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].contains("2 of 3 seeds") && w[0].contains("no wider grid"), "{w:?}");
        // A low score at the edge: the grid may be too narrow.
        let d = seed(Some(Edge::Lower), 0.01);
        let w = penalty_warnings(&[&d, &c], &header("orbit"));
        assert!(w[0].contains("lower edge (10^-8)") && w[0].contains("beyond the grid"), "{w:?}");
        assert!(penalty_warnings(&[&c], &header("nmse")).is_empty());
    }
}

//! `cargo xtask evaluate`: runs every experiment configuration of
//! `experiments/` through `cpg-lab` and renders the results: REPORT.md,
//! metrics.json and the figures. Nothing here computes a result.

mod families;
mod fmt;
mod reservoir;
mod summary;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use cpg_lab::Config;
use cpg_lab::experiment::families::{FamiliesConfig, FamiliesResult};
use cpg_lab::experiment::{self, Options, Outcome, Progress};
use indicatif::{ProgressBar, ProgressStyle};

use fmt::Md;

/// `cargo xtask evaluate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A smaller run for a first look: fewer seeds, shorter free runs, a
    /// 600-neuron E6 (each configuration's `quick_*` keys).
    #[arg(long)]
    quick: bool,
    /// Which part: the reservoir experiments E1–E6 of wyffels & Schrauwen
    /// (2009), the comparison of generator families of Vakulenko et al.
    /// (2017), or everything (including the variants in experiments/tried).
    #[arg(long, value_enum, default_value_t = Part::All)]
    experiment: Part,
    /// Where the report goes [default: report, or report/families for --experiment families].
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Which part of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Part {
    /// E1–E6, both protocols, and the HOAP-2 commands.
    Reservoir,
    /// Centralized networks and DMPs against the reservoir on marker positions.
    #[value(alias = "centralized")]
    Families,
    /// Everything, with the table of what was tried.
    All,
}

/// The reservoir experiments, in report order: the paper's protocol, then ours.
pub const RESERVOIR: [&str; 8] = ["e1-paper", "e1", "e4-paper", "e4", "e5-paper", "e5", "e6-paper", "e6"];

struct Bars;

impl Progress for Bars {
    fn start(&self, label: &str, total: u64) {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("    {spinner} {msg} [{bar:24}] {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message(label.to_owned());
        bar.enable_steady_tick(std::time::Duration::from_millis(250));
        *BAR.lock().unwrap_or_else(|e| e.into_inner()) = Some(bar);
    }
    fn tick(&self) {
        if let Some(b) = BAR.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            b.inc(1);
        }
    }
    fn finish(&self) {
        if let Some(b) = BAR.lock().unwrap_or_else(|e| e.into_inner()).take() {
            b.finish_and_clear();
        }
    }
}

static BAR: std::sync::Mutex<Option<ProgressBar>> = std::sync::Mutex::new(None);

/// A path relative to the workspace root, `..` resolved lexically.
fn rel(p: &Path) -> String {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    let root = crate::root();
    let root = root.canonicalize().unwrap_or(root);
    out.strip_prefix(&root).or_else(|_| out.strip_prefix(crate::root())).unwrap_or(&out).display().to_string()
}

/// [`rel`] of a path held as text.
pub fn rel_str(p: &str) -> String {
    rel(Path::new(p))
}

/// Runs one configuration, timing it.
fn run_config(path: &Path, opts: Options, times: &mut Vec<(String, f64)>) -> anyhow::Result<Outcome> {
    let t = Instant::now();
    let c = Config::load(path)?;
    eprintln!("  {}: {}", rel(path), c.experiment.as_ref().map_or("", |e| e.title.as_str()));
    let o = experiment::run(&c, opts, &Bars).with_context(|| format!("running {}", rel(path)))?;
    let (p, n) = o.passed();
    eprintln!("    {p} of {n} passed ({:.1} s)", t.elapsed().as_secs_f64());
    times.push((rel(path), t.elapsed().as_secs_f64()));
    Ok(o)
}

/// Runs two configurations that share their reservoirs together, timing both as one.
fn run_pair(
    paths: &[PathBuf],
    configs: &[Config],
    opts: Options,
    times: &mut Vec<(String, f64)>,
) -> anyhow::Result<Vec<(String, Outcome)>> {
    let t = Instant::now();
    let names: Vec<String> = paths.iter().map(|p| rel(p)).collect();
    for (n, c) in names.iter().zip(configs) {
        eprintln!("  {n}: {}", c.experiment.as_ref().map_or("", |e| e.title.as_str()));
    }
    eprintln!("    (their seeds run together: the same reservoirs)");
    let refs: Vec<&Config> = configs.iter().collect();
    let outcomes =
        experiment::run_together(&refs, opts, &Bars).with_context(|| format!("running {}", names.join(" and ")))?;
    for (n, o) in names.iter().zip(&outcomes) {
        let (p, k) = o.passed();
        eprintln!("    {n}: {p} of {k} passed");
    }
    eprintln!("    ({:.1} s)", t.elapsed().as_secs_f64());
    times.push((names.join(" + "), t.elapsed().as_secs_f64()));
    Ok(names.into_iter().zip(outcomes).collect())
}

/// Everything a report is rendered from.
struct Results {
    main: Vec<(String, Outcome)>,
    tried: Vec<(String, Outcome)>,
    families: Option<FamiliesResult>,
    times: Vec<(String, f64)>,
}

fn run_all_configs(args: &Args) -> anyhow::Result<Results> {
    let dir = crate::root().join("experiments");
    let opts = Options { quick: args.quick };
    let mut times = Vec::new();
    let mut main = Vec::new();
    if args.experiment != Part::Families {
        eprintln!("reservoir experiments (wyffels & Schrauwen 2009)");
        let paths: Vec<PathBuf> = RESERVOIR.iter().map(|name| dir.join(format!("{name}.toml"))).collect();
        let configs = paths.iter().map(|p| Config::load(p)).collect::<Result<Vec<_>, _>>()?;
        let mut i = 0;
        while i < paths.len() {
            // E6 with the paper's protocol and with ours draw the same reservoirs:
            // their seeds run together, one pass over the weights for both.
            if i + 1 < paths.len() && experiment::share_reservoirs(&configs[i], &configs[i + 1]) {
                main.extend(run_pair(&paths[i..i + 2], &configs[i..i + 2], opts, &mut times)?);
                i += 2;
            } else {
                main.push((rel(&paths[i]), run_config(&paths[i], opts, &mut times)?));
                i += 1;
            }
        }
    }
    let families = if args.experiment != Part::Reservoir {
        eprintln!("generator families (Vakulenko et al. 2017)");
        let t = Instant::now();
        let p = dir.join("families.toml");
        let fc = FamiliesConfig::load(&p)?;
        let e6 = main.iter().find_map(|(n, o)| match o {
            Outcome::Coupling(r) if n.ends_with("e6.toml") => r.trained.as_ref(),
            _ => None,
        });
        let r = experiment::families::run(&fc, e6, opts, &Bars)?;
        times.push((rel(&p), t.elapsed().as_secs_f64()));
        Some(r)
    } else {
        None
    };
    let mut tried = Vec::new();
    if args.experiment == Part::All {
        eprintln!("what we tried (experiments/tried)");
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("tried"))
            .with_context(|| format!("reading {}", dir.join("tried").display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        files.sort();
        for p in files {
            tried.push((rel(&p), run_config(&p, opts, &mut times)?));
        }
    }
    Ok(Results { main, tried, families, times })
}

fn render(args: &Args, r: &Results, dir: &Path, total_s: f64) -> anyhow::Result<String> {
    let mut md = Md::default();
    md.line("# cpg: the two papers, reproduced and measured");
    md.blank();
    md.line(format!("Generated by `cargo xtask evaluate{}{}`. Every number and verdict below was computed by that run from the configurations in `experiments/` (the same files `cpg train --config` reads); the papers' words are quoted from `shared/papers/`.", if args.quick { " --quick" } else { "" }, match args.experiment { Part::All => String::new(), p => format!(" --experiment {}", format!("{p:?}").to_lowercase()) }));
    md.blank();
    let heading = |kind: fn(&Outcome) -> bool| {
        r.main.iter().find(|(_, o)| kind(o)).map(|(_, o)| reservoir::heading(o)).unwrap_or_default()
    };
    let headings = summary::Headings {
        stability: heading(|o| matches!(o, Outcome::Stability(_))),
        frequency: heading(|o| matches!(o, Outcome::Frequency(_))),
        gaits: heading(|o| matches!(o, Outcome::Gaits(_))),
        coupling: heading(|o| matches!(o, Outcome::Coupling(_))),
        families: families::HEADING.into(),
    };
    summary::summary(&mut md, &r.main, r.families.as_ref(), &headings);
    if !r.main.is_empty() {
        md.line("## The paper's protocol and ours");
        md.blank();
        md.line("Each reservoir experiment runs twice over the same seeds: with the paper's protocol (the penalty chosen by the NMSE of a noisy free run) and with ours. Ours changes only how the penalty is chosen, plus, where one protocol fails outright, the training sequence (E5) and one input (E4). The table of what we tried shows the variants between them.");
        md.blank();
        for (_, o) in &r.main {
            md.line(format!("- {} {}", o.header().id, reservoir::protocol_line(o.header())));
        }
        md.blank();
    }
    if !r.tried.is_empty() {
        let mut all: Vec<(String, Outcome)> = r.main.clone();
        all.extend(r.tried.iter().cloned());
        summary::tried(&mut md, &all);
    }
    let st: Vec<_> = r
        .main
        .iter()
        .filter_map(|(_, o)| if let Outcome::Stability(s) = o { Some(s.as_ref()) } else { None })
        .collect();
    reservoir::stability(&mut md, &st, Some(dir))?;
    let fr: Vec<_> = r
        .main
        .iter()
        .filter_map(|(_, o)| if let Outcome::Frequency(s) = o { Some(s.as_ref()) } else { None })
        .collect();
    reservoir::frequency(&mut md, &fr, Some(dir))?;
    let ga: Vec<_> =
        r.main.iter().filter_map(|(_, o)| if let Outcome::Gaits(s) = o { Some(s.as_ref()) } else { None }).collect();
    reservoir::gaits(&mut md, &ga, Some(dir))?;
    let co: Vec<_> =
        r.main.iter().filter_map(|(_, o)| if let Outcome::Coupling(s) = o { Some(s.as_ref()) } else { None }).collect();
    reservoir::coupling(&mut md, &co, Some(dir))?;
    reservoir::hoap2(&mut md, &co, Some(dir))?;
    for c in &co {
        export_amc(c, dir)?;
    }
    if let Some(f) = &r.families {
        families::section(&mut md, f, dir)?;
    }
    md.line("## Time per configuration");
    md.blank();
    let rows: Vec<Vec<String>> = r.times.iter().map(|(n, s)| vec![format!("`{n}`"), format!("{s:.1} s")]).collect();
    md.table(&["configuration", "wall time"], "lr", &rows);
    md.line(format!("Total time of this evaluation: {total_s:.0} s on {} threads.", rayon::current_num_threads()));
    md.blank();
    md.line("The data used in this project was obtained from mocap.cs.cmu.edu. The database was created with funding from NSF EIA-0196217.");
    Ok(md.0)
}

/// The last 10 s of an E6 run as AMC, for any ASF/AMC viewer.
fn export_amc(c: &experiment::coupling::CouplingResult, dir: &Path) -> anyhow::Result<()> {
    let Some(m) = &c.trained else { return Ok(()) };
    let Some(asf) = &m.skeleton_asf else { return Ok(()) };
    let sk = cpg_mocap::parse_asf("skeleton of the model", asf.as_bytes())?;
    let channels = m.outputs.iter().filter_map(|o| cpg_mocap::Channel::parse(&o.name)).collect();
    let motion = cpg_mocap::Motion::new(channels, c.last10_units.clone(), m.provenance.sample_rate_hz)?;
    std::fs::write(
        dir.join(format!("{}_last10s.amc", reservoir::stem("e6", &c.header))),
        cpg_mocap::write_amc(&sk, &motion)?,
    )?;
    Ok(())
}

fn metrics(r: &Results) -> anyhow::Result<String> {
    let map = |v: &[(String, Outcome)]| -> serde_json::Map<String, serde_json::Value> {
        v.iter().map(|(n, o)| (n.clone(), serde_json::to_value(o).unwrap_or(serde_json::Value::Null))).collect()
    };
    let times: serde_json::Map<String, serde_json::Value> =
        r.times.iter().map(|(n, s)| (n.clone(), serde_json::json!(s))).collect();
    Ok(serde_json::to_string_pretty(&serde_json::json!({
        "experiments": map(&r.main),
        "tried": map(&r.tried),
        "families": r.families,
        "seconds": times,
    }))?)
}

/// `cargo xtask evaluate`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start = Instant::now();
    crate::fetch::run(&crate::fetch::Args::quiet_all()).context("fetching the CMU data the experiments need")?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(if args.experiment == Part::Families { "report/families" } else { "report" }));
    let out = if out.is_absolute() { out } else { crate::root().join(out) };
    let tmp = out.with_extension("partial");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let results = run_all_configs(args)?;
    let md = render(args, &results, &tmp, start.elapsed().as_secs_f64())?;
    std::fs::write(tmp.join("REPORT.md"), md)?;
    std::fs::write(tmp.join("metrics.json"), metrics(&results)?)?;
    if out.is_dir() {
        std::fs::remove_dir_all(&out).with_context(|| format!("replacing {}", out.display()))?;
    }
    std::fs::rename(&tmp, &out).with_context(|| format!("moving the report into {}", out.display()))?;
    eprintln!("report written to {} in {:.0} s", rel(&out), start.elapsed().as_secs_f64());
    Ok(())
}

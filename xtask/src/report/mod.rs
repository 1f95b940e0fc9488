//! `cargo xtask evaluate`: runs every experiment configuration of
//! `experiments/` through `cpg-lab` and renders the results: REPORT.md,
//! metrics.json and the figures. Nothing here computes a result.

mod fmt;
mod summary;
#[cfg(test)]
mod tests;
pub(crate) mod walking;

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
    /// Where the report goes [default: report, report/families for
    /// --experiment families, report/configs with --config].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Run only these experiment configurations (any `[experiment]` file,
    /// e.g. a copy of experiments/e4.toml with one setting changed) and
    /// report them alone, in the order given.
    #[arg(long = "config", value_name = "FILE")]
    configs: Vec<PathBuf>,
}

/// Which part of the evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Part {
    /// E1–E6, both protocols, and the HOAP-2 commands.
    Reservoir,
    /// Centralized networks and DMPs against the reservoir on marker positions.
    #[value(alias = "centralized")]
    Families,
    /// The HOAP-2 walking in MuJoCo on its CPG (the Python package's simulator).
    Walking,
    /// The whole body in one generator: standing, walking and running, judged on held-out trials.
    WholeBody,
    /// Everything, with the table of what was tried.
    All,
}

/// Whether the configuration at `p` is a walking experiment (run by the Python package's simulator).
fn is_walking(p: &Path) -> bool {
    Config::load(p)
        .is_ok_and(|c| c.experiment.is_some_and(|e| matches!(e.test, cpg_lab::config::ExperimentTest::Walking(_))))
}

/// Whether the configuration at `p` is the whole body's experiment.
fn is_whole_body(p: &Path) -> bool {
    Config::load(p)
        .is_ok_and(|c| c.experiment.is_some_and(|e| matches!(e.test, cpg_lab::config::ExperimentTest::WholeBody(_))))
}

/// The reservoir experiments, in report order: every configuration of
/// `experiments/` with an `[experiment]` table (`families.toml` aside), by
/// experiment (the file name before its first `-`), then the paper's
/// protocol, ours and our extensions. A new experiment is a new file there.
pub fn reservoir_experiments() -> anyhow::Result<Vec<PathBuf>> {
    let dir = crate::root().join("experiments");
    let mut found = Vec::new();
    for e in std::fs::read_dir(&dir).with_context(|| format!("reading {}", dir.display()))? {
        let p = e?.path();
        if p.extension().is_none_or(|x| x != "toml") || p.file_name().is_some_and(|f| f == "families.toml") {
            continue;
        }
        let c = Config::load(&p)?;
        let Some(x) = &c.experiment else { continue };
        let rank = x.protocol; // paper, ours, extension, tried: the declaration order
        let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let base = stem.split('-').next().unwrap_or_default().to_owned();
        found.push(((base, rank, stem), p));
    }
    found.sort();
    Ok(found.into_iter().map(|(_, p)| p).collect())
}

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
    let out = cpg_io::lexical(p);
    let root = crate::root();
    let root = root.canonicalize().unwrap_or(root);
    out.strip_prefix(&root).or_else(|_| out.strip_prefix(crate::root())).unwrap_or(&out).display().to_string()
}

/// Runs one configuration, timing it.
fn run_config(path: &Path, opts: Options, times: &mut Times) -> anyhow::Result<Outcome> {
    let t = Clock::start();
    let c = Config::load(path)?;
    eprintln!("  {}: {}", rel(path), c.experiment.as_ref().map_or("", |e| e.title.as_str()));
    let o = experiment::run(&c, opts, &Bars).with_context(|| format!("running {}", rel(path)))?;
    let (p, n) = o.passed();
    eprintln!("    {p} of {n} passed ({:.1} s)", t.elapsed_s());
    times.push(rel(path), &t);
    Ok(o)
}

/// Runs two configurations that share their reservoirs together, timing both as one.
fn run_pair(
    paths: &[PathBuf],
    configs: &[Config],
    opts: Options,
    times: &mut Times,
) -> anyhow::Result<Vec<(String, Outcome)>> {
    let t = Clock::start();
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
    eprintln!("    ({:.1} s)", t.elapsed_s());
    times.push(names.join(" + "), &t);
    Ok(names.into_iter().zip(outcomes).collect())
}

/// The machine's CPU counters at one moment (Linux `/proc`; zeros elsewhere):
/// its busy and total time over every core, and this process's with the
/// children it waited for, all in the kernel's clock ticks.
#[derive(Debug, Clone, Copy, Default)]
struct Snapshot {
    busy: f64,
    total: f64,
    ours: f64,
}

impl Snapshot {
    fn now() -> Snapshot {
        let machine = std::fs::read_to_string("/proc/stat").ok().and_then(|t| {
            let v: Vec<f64> = t.lines().next()?.split_whitespace().skip(1).filter_map(|x| x.parse().ok()).collect();
            // user nice system idle iowait irq softirq steal …
            let total: f64 = v.iter().take(8).sum();
            let idle = v.get(3).copied().unwrap_or(0.0) + v.get(4).copied().unwrap_or(0.0);
            Some((total - idle, total))
        });
        let ours = std::fs::read_to_string("/proc/self/stat").ok().and_then(|t| process_ticks(&t));
        let (busy, total) = machine.unwrap_or((0.0, 0.0));
        Snapshot { busy, total, ours: ours.unwrap_or(0.0) }
    }
}

/// A process's CPU time with the children it waited for, from its
/// `/proc/PID/stat` line: fields 14–17 (utime, stime, cutime, cstime),
/// counted after the command's name in parentheses, whose next field is the
/// state letter (field 3), in clock ticks.
fn process_ticks(stat: &str) -> Option<f64> {
    let rest = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // fields[0] is field 3, so field k is fields[k - 3].
    fields.get(11..15)?.iter().map(|x| x.parse::<f64>().ok()).sum()
}

/// A stretch of the run being timed: its wall time, and from the CPU
/// counters how much this run got and how much of the machine others took.
struct Clock {
    wall: Instant,
    at: Snapshot,
}

impl Clock {
    fn start() -> Clock {
        Clock { wall: Instant::now(), at: Snapshot::now() }
    }

    fn elapsed_s(&self) -> f64 {
        self.wall.elapsed().as_secs_f64()
    }

    /// This run's CPU seconds since the start, and the share of the
    /// machine's capacity other processes used meanwhile (0–1).
    fn load(&self) -> (f64, f64) {
        let now = Snapshot::now();
        let total = now.total - self.at.total;
        let ours = now.ours - self.at.ours;
        let others = (now.busy - self.at.busy - ours).max(0.0);
        let hz = if total > 0.0 {
            // Ticks per second: the machine's ticks over its cores and the wall time.
            total / (crate::cores() as f64 * self.elapsed_s()).max(1e-9)
        } else {
            100.0
        };
        (ours / hz, if total > 0.0 { (others / total).clamp(0.0, 1.0) } else { 0.0 })
    }
}

/// What one section of the run got.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SectionLoad {
    /// The section.
    pub section: String,
    /// Its wall time, seconds.
    pub wall_s: f64,
    /// The CPU seconds this run used meanwhile.
    pub cpu_s: f64,
    /// The share of the machine other processes took meanwhile (0–1).
    pub others_share: f64,
}

/// The sections' timings, in the order they ran.
#[derive(Debug, Clone, Default)]
struct Times {
    list: Vec<(String, f64)>,
    loads: Vec<SectionLoad>,
}

impl Times {
    fn push(&mut self, section: String, c: &Clock) {
        let wall_s = c.elapsed_s();
        let (cpu_s, others_share) = c.load();
        self.list.push((section.clone(), wall_s));
        self.loads.push(SectionLoad { section, wall_s, cpu_s, others_share });
    }
}

/// Above this share of the machine taken by other processes, the report says its timings are not clean.
pub const CLEAN_OTHERS_SHARE: f64 = 0.1;

/// Everything a report is rendered from.
struct Results {
    main: Vec<(String, Outcome)>,
    tried: Vec<(String, Outcome)>,
    families: Option<FamiliesResult>,
    times: Times,
    /// Sections that failed, with their errors: the report is written without them.
    failed: Vec<(String, String)>,
}

/// Keeps what a finished section computed: its results as JSON in
/// `<partial>/results/`, written before the next section starts, so that a
/// failure later in the run, or the run being stopped, leaves them.
fn keep_results(partial: &Path, name: &str, value: &impl serde::Serialize) {
    let dir = partial.join("results");
    let file = dir.join(format!("{}.json", name.replace(['/', ' ', '+'], "_")));
    let written = std::fs::create_dir_all(&dir)
        .map_err(anyhow::Error::from)
        .and_then(|()| Ok(std::fs::write(&file, serde_json::to_string_pretty(value)?)?));
    if let Err(e) = written {
        eprintln!("    warning: could not keep {}'s results in {}: {e:#}", name, file.display());
    }
}

/// A section's outcome, kept; or its failure, recorded, so the run goes on to the next section.
fn settle<T: serde::Serialize>(
    partial: &Path,
    name: &str,
    r: anyhow::Result<T>,
    failed: &mut Vec<(String, String)>,
) -> Option<T> {
    match r {
        Ok(v) => {
            keep_results(partial, name, &v);
            Some(v)
        }
        Err(e) => {
            eprintln!("    FAILED: {name}: {e:#}\n    (the run goes on; this section is left out of the report)");
            failed.push((name.to_owned(), format!("{e:#}")));
            None
        }
    }
}

fn run_all_configs(args: &Args, partial: &Path) -> anyhow::Result<Results> {
    let dir = crate::root().join("experiments");
    let opts = Options { quick: args.quick, threads: crate::cores() };
    let mut times = Times::default();
    let mut main = Vec::new();
    let mut failed = Vec::new();
    let wants = |part: Part| args.experiment == Part::All || args.experiment == part;
    if !args.configs.is_empty() || wants(Part::Reservoir) {
        eprintln!("reservoir experiments (wyffels & Schrauwen 2009)");
        let paths: Vec<PathBuf> = if args.configs.is_empty() {
            reservoir_experiments()?.into_iter().filter(|p| !is_walking(p) && !is_whole_body(p)).collect()
        } else {
            let cwd = std::env::current_dir().context("the current directory")?;
            args.configs.iter().map(|p| if p.is_absolute() { p.clone() } else { cwd.join(p) }).collect()
        };
        let configs = paths.iter().map(|p| Config::load(p)).collect::<Result<Vec<_>, _>>()?;
        let mut i = 0;
        while i < paths.len() {
            // E6 with the paper's protocol and with ours draw the same reservoirs:
            // their seeds run together, one pass over the weights for both.
            if i + 1 < paths.len() && experiment::share_reservoirs(&configs[i], &configs[i + 1]) {
                let names: Vec<String> = paths[i..i + 2].iter().map(|p| rel(p)).collect();
                let r = run_pair(&paths[i..i + 2], &configs[i..i + 2], opts, &mut times);
                if let Some(pair) = settle(partial, &names.join(" + "), r, &mut failed) {
                    main.extend(pair);
                }
                i += 2;
            } else {
                let name = rel(&paths[i]);
                if let Some(o) = settle(partial, &name, run_config(&paths[i], opts, &mut times), &mut failed) {
                    main.push((name, o));
                }
                i += 1;
            }
        }
    }
    if !args.configs.is_empty() {
        return Ok(Results { main, tried: Vec::new(), families: None, times, failed });
    }
    let families = if wants(Part::Families) {
        eprintln!("generator families (Vakulenko et al. 2017)");
        let t = Clock::start();
        let p = dir.join("families.toml");
        let fc = FamiliesConfig::load(&p)?;
        let e6 = main.iter().find_map(|(n, o)| match o {
            Outcome::Coupling(r) if n.ends_with("e6.toml") => r.trained.as_ref(),
            _ => None,
        });
        let r = experiment::families::run(&fc, e6, opts, &Bars).map_err(anyhow::Error::from);
        times.push(rel(&p), &t);
        settle(partial, &rel(&p), r, &mut failed)
    } else {
        None
    };
    if wants(Part::Walking) {
        for p in reservoir_experiments()?.into_iter().filter(|p| is_walking(p)) {
            eprintln!("walking in physics (the HOAP-2 in MuJoCo): {}", rel(&p));
            let t = Clock::start();
            let work = crate::root().join("target").join("walking");
            let r = (|| {
                let c = Config::load(&p)?;
                std::fs::create_dir_all(&work).with_context(|| format!("creating {}", work.display()))?;
                walking::run(&work, &c, args.quick, opts.threads).with_context(|| format!("running {}", rel(&p)))
            })();
            times.push(rel(&p), &t);
            if let Some(r) = settle(partial, &rel(&p), r, &mut failed) {
                let o = Outcome::Walking(Box::new(r));
                let (k, n) = o.passed();
                eprintln!("    {k} of {n} passed ({:.1} s)", t.elapsed_s());
                main.push((rel(&p), o));
            }
        }
    }
    if wants(Part::WholeBody) {
        for p in reservoir_experiments()?.into_iter().filter(|p| is_whole_body(p)) {
            eprintln!("the whole body in one generator");
            if let Some(o) = settle(partial, &rel(&p), run_config(&p, opts, &mut times), &mut failed) {
                main.push((rel(&p), o));
            }
        }
    }
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
            if let Some(o) = settle(partial, &rel(&p), run_config(&p, opts, &mut times), &mut failed) {
                tried.push((rel(&p), o));
            }
        }
    }
    Ok(Results { main, tried, families, times, failed })
}

/// Where the papers' texts are (`$CPG_PAPERS_DIR`, else `shared/papers` beside the checkout).
fn papers_dir() -> PathBuf {
    std::env::var_os("CPG_PAPERS_DIR").map(PathBuf::from).unwrap_or_else(|| crate::root().join("../shared/papers"))
}

/// Whitespace collapsed to single spaces.
fn squash(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Checks every quote of `claims` against the paper's text: an error names
/// the quote the paper does not hold; `Ok(None)` when the texts are not here.
fn check_quotes<'a>(claims: impl Iterator<Item = &'a cpg_lab::experiment::Claim>) -> anyhow::Result<Option<usize>> {
    let dir = papers_dir();
    if !dir.is_dir() {
        return Ok(None);
    }
    let mut texts = std::collections::HashMap::new();
    let mut seen = std::collections::HashSet::new();
    for c in claims {
        for s in &c.sources {
            let cpg_lab::experiment::claim::Source::Quote(q) = s else { continue };
            let file = dir.join(q.paper.file_name());
            let text = match texts.get(&file) {
                Some(t) => t,
                None => {
                    let t =
                        squash(&std::fs::read_to_string(&file).with_context(|| format!("reading {}", file.display()))?);
                    texts.entry(file.clone()).or_insert(t)
                }
            };
            if !text.contains(&squash(q.text)) {
                anyhow::bail!(
                    "the report quotes {} ({}) as saying \"{}\", which {} does not hold",
                    q.paper.cite(),
                    q.place,
                    q.text,
                    file.display()
                );
            }
            seen.insert(q.text);
        }
    }
    Ok(Some(seen.len()))
}

/// When, where and from what this report was made.
#[derive(Debug, Clone, serde::Serialize)]
pub struct RunInfo {
    /// The checkout's commit, with `+` when it has uncommitted changes.
    pub commit: String,
    /// When the run finished, UTC (ISO 8601).
    pub date_utc: String,
    /// The processor's model name.
    pub cpu: String,
    /// Cores available to the run.
    pub cores: usize,
    /// The widest vector instructions the kernels use here.
    pub simd: String,
    /// Threads of the run's pool.
    pub threads: usize,
    /// Seconds per configuration (or pair run together) and for the rendering.
    pub seconds: Vec<(String, f64)>,
    /// Per section: the CPU time this run got and the share of the machine other processes took.
    pub load: Vec<SectionLoad>,
    /// The share of the machine's cores that other processes took over the whole run
    /// (0: the timings are this run's alone).
    pub others_share: f64,
    /// The CPU seconds this run (and the processes it waited for) used in all.
    pub cpu_s: f64,
    /// The 1-minute load average when the run finished.
    pub load_avg_1min: Option<f64>,
    /// Seconds in all.
    pub total_s: f64,
    /// Quotes checked against the papers' texts (`None`: the texts were not found).
    pub quotes_checked: Option<usize>,
}

fn git(args: &[&str]) -> Option<String> {
    let out = std::process::Command::new("git").args(args).current_dir(crate::root()).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// Days since 1970-01-01 as a civil date (Hinnant's algorithm).
fn civil(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

fn now_utc() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (y, m, d) = civil(secs.div_euclid(86_400));
    let t = secs.rem_euclid(86_400);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", t / 3600, t % 3600 / 60, t % 60)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_owned())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_owned())
}

fn simd_level() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return "AVX-512".into();
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return "AVX2 + FMA".into();
        }
    }
    "scalar".into()
}

fn run_info(times: &Times, whole: &Clock, quotes_checked: Option<usize>) -> RunInfo {
    let total_s = whole.elapsed_s();
    let (cpu_s, others_share) = whole.load();
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    RunInfo {
        commit: if dirty { format!("{commit}+") } else { commit },
        date_utc: now_utc(),
        cpu: cpu_model(),
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        simd: simd_level(),
        threads: crate::cores(),
        seconds: times.list.clone(),
        load: times.loads.clone(),
        others_share,
        cpu_s,
        load_avg_1min: std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|t| t.split_whitespace().next().and_then(|v| v.parse().ok())),
        total_s,
        quotes_checked,
    }
}

/// What a reader needs to read the tables.
const GLOSSARY: &[(&str, &str)] = &[
    (
        "z",
        "a channel in normalised units: its mean subtracted, divided by its standard deviation over the training data (the paper's normalisation).",
    ),
    ("σ", "a standard deviation of the teacher's cycle (pushes and distances are given in it)."),
    ("teacher", "the recorded gait cycle a model is judged against, played at the rate its control setting asks for."),
    (
        "seam",
        "where a loop cut from a recording joins its own start; its excess is the jump there beyond a typical step between frames, in σ.",
    ),
    (
        "orbit score",
        "our validation score: clean free runs at each visited control setting, each scored by the NMSE against its teacher's cycle at the best phase.",
    ),
    (
        "NMSE",
        "mean squared error divided by the target's variance (1 is the error of a constant output at the target's mean).",
    ),
    (
        "twin",
        "the same model run from the same state without the push: back on the twin means back in phase, not only on the orbit.",
    ),
    (
        "back on the orbit",
        "within 0.25 σ of the teacher's cycle at the best phase over quarter-period windows, from some window until the end of the run.",
    ),
    (
        "penalty",
        "the ridge regression's regularisation; each configuration searches a grid of them and validation chooses one.",
    ),
    (
        "validation / test",
        "validation chooses the penalty; the test judges the model. A verdict is evidence only when the test uses conditions validation did not see (each section lists both).",
    ),
    ("k of n (95 % interval)", "seeds that met a rule, with the Wilson score interval of the rate at 95 %."),
    (
        "median (range; n)",
        "the median over seeds (the mean of the two middle values for an even count), the lowest and highest, and how many seeds had a value.",
    ),
    (
        "at the limit",
        "a verdict that a comparison closer than the printed digits decided: the last digit could flip it.",
    ),
];

fn render(args: &Args, r: &Results, dir: &Path, info: &RunInfo) -> anyhow::Result<String> {
    let mut md = Md::default();
    md.line("# cpg: the two papers, reproduced and measured");
    md.blank();
    md.line(format!("Generated by `cargo xtask evaluate{}{}`. Every number and verdict below was computed by that run from the configurations in `experiments/` (the same files `cpg train --config` reads); {}", if args.quick { " --quick" } else { "" }, match args.experiment { Part::All => String::new(), p => format!(" --experiment {}", format!("{p:?}").to_lowercase()) },
        match info.quotes_checked {
            Some(n) => format!("each of the {n} passages of the papers quoted below was found in `shared/papers/` by this run."),
            None => format!("the papers' texts were not found at `{}`, so the quotations were not checked by this run.", papers_dir().display()),
        }));
    md.blank();
    if !r.failed.is_empty() {
        md.line(format!(
            "**{} section(s) of this run failed and are not in this report** (the others are complete):",
            r.failed.len()
        ));
        md.blank();
        for (name, e) in &r.failed {
            md.line(format!("- `{name}`: {}", e.replace('\n', " ")));
        }
        md.blank();
    }
    summary::summary(&mut md, &r.main, r.families.as_ref());
    md.line("## How to read this report");
    md.blank();
    md.line("Each reservoir experiment runs over the same reservoir seeds with the paper's protocol (the penalty chosen by the NMSE of a noisy free run), with ours (the paper's mechanism, our validation and training choices) and, where the paper's mechanism fails, with our extension of it. Each section lists what every configuration changes against the paper, the conditions its validation and its test used, and the rules of its verdicts.");
    md.blank();
    let rows: Vec<Vec<String>> = GLOSSARY.iter().map(|(a, b)| vec![format!("**{a}**"), (*b).to_owned()]).collect();
    md.table(&["term", "meaning"], "ll", &rows);
    if !r.tried.is_empty() {
        let mut all: Vec<(String, Outcome)> = r.main.clone();
        all.extend(r.tried.iter().cloned());
        summary::tried(&mut md, &all);
    }
    let ctx = context();
    let main: Vec<&Outcome> = r.main.iter().map(|(_, o)| o).collect();
    for s in Outcome::sections(&main, &ctx)? {
        md.section(&s, Some(dir))?;
    }
    if let Some(f) = &r.families {
        md.section(&f.section(&ctx), Some(dir))?;
    }

    md.line("## This run");
    md.blank();
    md.line(format!(
        "Commit `{}`, finished {} on {} ({} cores, {} kernels, {} threads).",
        info.commit, info.date_utc, info.cpu, info.cores, info.simd, info.threads
    ));
    md.blank();
    let rows: Vec<Vec<String>> = info
        .load
        .iter()
        .map(|l| {
            vec![
                format!("`{}`", l.section),
                format!("{:.1} s", l.wall_s),
                format!("{:.1} s", l.cpu_s),
                format!("{:.0} %", 100.0 * l.others_share),
            ]
        })
        .collect();
    md.table(
        &["configuration", "wall time", "CPU time of this run", "the machine's cores taken by other processes"],
        "lrrr",
        &rows,
    );
    md.line(format!(
        "Total time of this evaluation: {:.0} s; this run used {:.0} CPU-seconds of the {} cores' {:.0}.",
        info.total_s,
        info.cpu_s,
        info.cores,
        info.total_s * info.cores as f64
    ));
    md.blank();
    md.line(load_sentence(info));
    md.blank();
    md.line("The data used in this project was obtained from mocap.cs.cmu.edu. The database was created with funding from NSF EIA-0196217.");
    Ok(md.0)
}

/// Whether the timings are the run's alone, in words built from the load it measured.
fn load_sentence(info: &RunInfo) -> String {
    let busiest = info.load.iter().max_by(|a, b| a.others_share.total_cmp(&b.others_share));
    let avg = info.load_avg_1min.map_or(String::new(), |l| format!(" (load average {l:.2} at the end)"));
    if info.others_share > CLEAN_OTHERS_SHARE || busiest.is_some_and(|b| b.others_share > CLEAN_OTHERS_SHARE) {
        let b = busiest
            .map_or(String::new(), |b| format!("; the most during `{}`, {:.0} %", b.section, 100.0 * b.others_share));
        format!(
            "**These timings are not clean**: other processes took {:.0} % of the machine's cores over the run{b}{avg}, more than the {:.0} % under which a time is this run's alone; every section that shared the cores ran slower than it would alone.",
            100.0 * info.others_share,
            100.0 * CLEAN_OTHERS_SHARE
        )
    } else {
        format!(
            "The timings are this run's: other processes took {:.0} % of the machine's cores over the run (at most {:.0} % in any section){avg}.",
            100.0 * info.others_share,
            100.0 * busiest.map_or(0.0, |b| b.others_share)
        )
    }
}

/// What the experiments' sections need to know of this checkout: paths are shown from its root.
fn context() -> cpg_lab::experiment::doc::Context {
    cpg_lab::experiment::doc::Context { root: Some(crate::root()) }
}

fn metrics(r: &Results, info: &RunInfo) -> anyhow::Result<String> {
    let map = |v: &[(String, Outcome)]| -> serde_json::Map<String, serde_json::Value> {
        v.iter().map(|(n, o)| (n.clone(), serde_json::to_value(o).unwrap_or(serde_json::Value::Null))).collect()
    };
    Ok(serde_json::to_string_pretty(&serde_json::json!({
        "run": info,
        "experiments": map(&r.main),
        "tried": map(&r.tried),
        "families": r.families,
        "failed": r.failed,
    }))?)
}

/// `cargo xtask evaluate`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let whole = Clock::start();
    crate::fetch::run(&crate::fetch::Args::quiet_all()).context("fetching the CMU data the experiments need")?;
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from(if !args.configs.is_empty() {
            "report/configs"
        } else if args.experiment == Part::Families {
            "report/families"
        } else if args.experiment == Part::Walking {
            "report/walking"
        } else if args.experiment == Part::WholeBody {
            "report/whole-body"
        } else {
            "report"
        })
    });
    let out = if out.is_absolute() { out } else { crate::root().join(out) };
    let tmp = out.with_extension("partial");
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let mut results = run_all_configs(args, &tmp)?;
    let claims = results
        .main
        .iter()
        .chain(&results.tried)
        .flat_map(|(_, o)| o.claims())
        .chain(results.families.iter().flat_map(|f| f.claims.iter()));
    let quotes = check_quotes(claims)?;
    let rendering = Clock::start();
    // The figures and pages are written while rendering; its time is measured on a first pass.
    let probe = run_info(&results.times, &whole, quotes);
    let _ = render(args, &results, &tmp, &probe)?;
    results.times.push("rendering the report and its figures".into(), &rendering);
    let info = run_info(&results.times, &whole, quotes);
    let md = render(args, &results, &tmp, &info)?;
    std::fs::write(tmp.join("REPORT.md"), md)?;
    std::fs::write(tmp.join("metrics.json"), metrics(&results, &info)?)?;
    if out.is_dir() {
        std::fs::remove_dir_all(&out).with_context(|| format!("replacing {}", out.display()))?;
    }
    std::fs::rename(&tmp, &out).with_context(|| format!("moving the report into {}", out.display()))?;
    eprintln!("report written to {} in {:.0} s", rel(&out), start.elapsed().as_secs_f64());
    if !results.failed.is_empty() {
        let names: Vec<&str> = results.failed.iter().map(|(n, _)| n.as_str()).collect();
        anyhow::bail!(
            "{} section(s) failed and are left out of the report (each named there with its error): {}",
            names.len(),
            names.join(", ")
        );
    }
    Ok(())
}

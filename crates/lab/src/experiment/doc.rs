//! An experiment's section of the report, as data: lines of text, tables,
//! figures (panels of curves), pages to watch (scenes) and files to attach.
//! Each experiment builds its own ([`super::Experiment::section`]) from its
//! results alone; the report (`cargo xtask evaluate`) writes the text as
//! markdown, draws the figures and writes the pages and files. Nothing here
//! computes a result: every number a section prints is a field of the
//! experiment's result (and so of `metrics.json`), formatted.

use cpg_view::Scene;

use super::claim::{Claim, Decision, Measure, Source, Value, Verdict};
use super::{Experiment, Header, SeedModel};

/// How a curve is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Look {
    /// The data the network learnt: dashed gray.
    Teacher,
    /// What the network generated: solid black.
    Model,
    /// A control input: dashed light gray (on a secondary scale given by the caller).
    Control,
    /// Data shown for context: solid light gray (phase portraits).
    Data,
    /// Vertical bars from 0 to each point's y, 0.8 x-units wide, dark gray.
    Bars,
    /// Points only (small black circles), e.g. values at a few settings.
    Marks,
    /// A value imposed from outside (a held output): thick dark red.
    Held,
}

/// One curve; `label` names it in the panel's legend (empty: not in it).
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// `(x, y)` points.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub look: Look,
    /// Its legend label.
    pub label: String,
}

impl Curve {
    /// A curve with its legend label.
    pub fn new(look: Look, label: impl Into<String>, points: Vec<(f64, f64)>) -> Curve {
        Curve { points, look, label: label.into() }
    }
}

/// One panel of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// One unit on the x axis is as long as one on the y axis (a path seen from above).
    pub equal_axes: bool,
    /// Title.
    pub title: String,
    /// The x axis' label.
    pub x_label: String,
    /// The y axis' label.
    pub y_label: String,
    /// The curves.
    pub curves: Vec<Curve>,
}

/// A part of a section.
#[derive(Debug, Clone)]
pub enum Block {
    /// A line of markdown text.
    Line(String),
    /// An empty line.
    Blank,
    /// A table: header cells, alignment per column (`l` or `r`), rows.
    Table {
        /// Header cells.
        head: Vec<String>,
        /// `l` or `r` per column.
        align: String,
        /// Rows of cells.
        rows: Vec<Vec<String>>,
    },
    /// A figure, drawn as `STEM.png` and `STEM.svg`.
    Figure {
        /// The file stem.
        stem: String,
        /// Its panels.
        panels: Vec<Panel>,
        /// Panels per row.
        columns: usize,
        /// Size in pixels.
        size: (u32, u32),
    },
    /// A scene to watch, written as `NAME.html` (and its first seconds as `NAME.gif`).
    Page {
        /// The file stem.
        name: String,
        /// The scene.
        scene: Box<Scene>,
        /// Seconds of the animated GIF, if one is written.
        gif_s: Option<f64>,
    },
    /// A file attached to the report (CSV, JSON, AMC).
    File {
        /// Its name.
        name: String,
        /// Its bytes.
        bytes: Vec<u8>,
    },
}

/// A section of the report, block by block.
#[derive(Debug, Clone, Default)]
pub struct Section {
    /// The blocks, in order.
    pub blocks: Vec<Block>,
}

impl Section {
    /// Appends a line of text.
    pub fn line(&mut self, s: impl Into<String>) {
        self.blocks.push(Block::Line(s.into()));
    }

    /// Appends an empty line.
    pub fn blank(&mut self) {
        self.blocks.push(Block::Blank);
    }

    /// Appends a table.
    pub fn table(&mut self, head: &[&str], align: &str, rows: &[Vec<String>]) {
        self.blocks.push(Block::Table {
            head: head.iter().map(|h| (*h).to_owned()).collect(),
            align: align.to_owned(),
            rows: rows.to_vec(),
        });
    }

    /// Appends a figure to draw.
    pub fn figure(&mut self, stem: impl Into<String>, panels: Vec<Panel>, columns: usize, size: (u32, u32)) {
        self.blocks.push(Block::Figure { stem: stem.into(), panels, columns, size });
    }

    /// Appends a page to write.
    pub fn page(&mut self, name: impl Into<String>, scene: Scene, gif_s: Option<f64>) {
        self.blocks.push(Block::Page { name: name.into(), scene: Box::new(scene), gif_s });
    }

    /// Appends a file to write.
    pub fn file(&mut self, name: impl Into<String>, bytes: Vec<u8>) {
        self.blocks.push(Block::File { name: name.into(), bytes });
    }

    /// The section's text as markdown (without its figures, pages and files).
    pub fn markdown(&self) -> String {
        let mut out = String::new();
        let mut push = |s: &str| {
            out.push_str(s);
            out.push('\n');
        };
        for b in &self.blocks {
            match b {
                Block::Line(s) => push(s),
                Block::Blank => push(""),
                Block::Table { head, align, rows } => {
                    push(&format!("| {} |", head.join(" | ")));
                    let a: Vec<&str> = align.chars().map(|c| if c == 'r' { "---:" } else { "---" }).collect();
                    push(&format!("|{}|", a.join("|")));
                    for r in rows {
                        push(&format!("| {} |", r.join(" | ")));
                    }
                    push("");
                }
                Block::Figure { .. } | Block::Page { .. } | Block::File { .. } => {}
            }
        }
        out
    }
}

/// A time in seconds, or `never`.
pub fn secs(x: Option<f64>) -> String {
    x.map_or("never".into(), |v| format!("{v:.2} s"))
}

/// A period in frames, or `decayed`.
pub fn frames(x: Option<f64>) -> String {
    x.map_or("decayed".into(), |v| format!("{v:.2}"))
}

/// `reproduced`, `not reproduced`, `not run`; `(at the limit)` when a
/// comparison that decided it was closer than the printed digits.
pub fn verdict(v: &Verdict) -> String {
    let word = match v.decision {
        Decision::Reproduced => "reproduced",
        Decision::NotReproduced => "not reproduced",
        Decision::NotRun => "not run",
        Decision::NotApplicable => "not applicable",
    };
    let word = if v.at_limit { format!("{word} (at the limit)") } else { word.to_owned() };
    match (&v.note, v.decision) {
        (Some(n), Decision::NotApplicable) => format!("{word}: {n}"),
        (Some(n), _) => format!("{word} ({n})"),
        (None, _) => word,
    }
}

/// A measured value as printed: counts with their 95 % interval, spreads
/// as median (range; n), numbers with their unit.
pub fn value(v: &Value) -> String {
    let unit = |u: &str| if u.is_empty() { String::new() } else { format!(" {u}") };
    match v {
        Value::Count(p) => {
            format!("{} of {} (95 % interval {:.0}–{:.0} %)", p.k, p.n, 100.0 * p.low, 100.0 * p.high)
        }
        Value::Spread { spread: s, unit: u, digits } => {
            if s.n == 0 {
                "—".into()
            } else if s.n == 1 {
                format!("{:.*}{} (n = 1)", digits, s.median, unit(u))
            } else {
                // Values exact at the printed digits (counts of channels) whose median, the
                // mean of the middle two, falls between them (41.5) get one more digit for
                // the median: never rounded to a count no seed had.
                let exact = |x: f64| {
                    let v = x * 10f64.powi(*digits as i32);
                    (v - v.round()).abs() <= 1e-9 * v.abs().max(1.0)
                };
                let md = if exact(s.min) && exact(s.max) && !exact(s.median) { digits + 1 } else { *digits };
                format!("{:.*}{} ({:.*}–{:.*}; n = {})", md, s.median, unit(u), digits, s.min, digits, s.max, s.n)
            }
        }
        Value::Number { value, unit: u, digits } => format!("{value:.*}{}", digits, unit(u)),
        Value::Text { text } => text.clone(),
    }
}

/// The paper's words (quoted, with where) or our reading (marked inferred).
pub fn sources(s: &[Source]) -> String {
    s.iter()
        .map(|x| match x {
            Source::Quote(q) => format!("“{}” ({})", q.text, q.place),
            Source::Inferred { text } => format!("inferred: {text}"),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `yes` / `no`.
pub fn yes(ok: bool) -> &'static str {
    if ok { "yes" } else { "no" }
}

/// A markdown anchor of a heading text (GitHub's rule, enough for our headings).
pub fn anchor(heading: &str) -> String {
    heading
        .to_lowercase()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c)
            } else if c == ' ' {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The heading of an experiment's section: `E1–E3: … (Fig. 2)`.
pub fn section_heading(h: &Header, fig: &str) -> String {
    format!("{}: {} ({fig})", h.id, h.title)
}

/// `fig2` for our protocol, `fig2-paper` for the paper's, `fig2-extension` for an extension.
pub fn stem(base: &str, h: &Header) -> String {
    if h.protocol == crate::config::Protocol::Ours { base.to_owned() } else { format!("{base}-{}", h.protocol) }
}

/// "the paper's protocol", "our protocol", "our extension", "tried".
pub fn protocol_name(h: &Header) -> String {
    use crate::config::Protocol;
    match h.protocol {
        Protocol::Ours => "our protocol".into(),
        Protocol::Paper => "the paper's protocol".into(),
        Protocol::Extension => "our extension".into(),
        Protocol::Tried => "tried".into(),
    }
}

/// `s` with its first letter in upper case.
pub fn capital(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().collect::<String>() + c.as_str()).unwrap_or_default()
}

/// Samples `y` at `rate` Hz from `t0` as `(time_s, value)` points.
pub fn pts(y: &[f64], t0: f64, rate: f64) -> Vec<(f64, f64)> {
    y.iter().enumerate().map(|(k, v)| (t0 + k as f64 / rate, *v)).collect()
}

/// What a section needs from where the report is written.
#[derive(Debug, Clone, Default)]
pub struct Context {
    /// The workspace root: paths in it are shown relative to it.
    pub root: Option<std::path::PathBuf>,
}

impl Context {
    /// A path as the report shows it: `..` resolved, relative to the root when inside it.
    pub fn path(&self, p: &str) -> String {
        let out = cpg_io::lexical(std::path::Path::new(p));
        let Some(root) = &self.root else { return out.display().to_string() };
        let canonical = root.canonicalize().unwrap_or_else(|_| root.clone());
        out.strip_prefix(&canonical).or_else(|_| out.strip_prefix(root)).unwrap_or(&out).display().to_string()
    }
}

/// One sentence on how a configuration chose its penalty.
pub fn protocol_line(h: &Header, ctx: &Context) -> String {
    let (n, a, b) = h.penalty_grid;
    let grid = format!("{n} penalties 10^{a} … 10^{b}");
    let how = match h.score {
        crate::config::ScoreKind::Nmse => format!(
            "validation by the NMSE of a free run against the teacher, step by step{}",
            if h.noise_variance > 0.0 {
                format!(", under state noise of variance {}", h.noise_variance)
            } else {
                String::new()
            }
        ),
        crate::config::ScoreKind::Orbit => "validation by the orbit score: clean free runs at settings of the controls, each scored by the phase-aligned NMSE against its cycle".into(),
    };
    format!("**{}** (`{}`): {} neurons; {grid}; {how}.", capital(&protocol_name(h)), ctx.path(&h.config), h.n_neurons)
}

/// What each configuration is, what it changes against the paper, the
/// conditions its validation and its test used, and its warnings.
pub fn protocols(s: &mut Section, hs: &[&Header], ctx: &Context) {
    for h in hs {
        s.line(protocol_line(h, ctx));
        s.blank();
        if !h.differs.is_empty() {
            s.line(format!("What differs from the paper ({}):", protocol_name(h)));
            s.blank();
            for d in &h.differs {
                s.line(format!("- {}", d.describe()));
            }
            s.blank();
        } else if h.protocol == crate::config::Protocol::Paper {
            s.line("Nothing the paper states differs.");
            s.blank();
        }
        let list = |v: &[super::conditions::Condition]| {
            if v.is_empty() { "none".to_owned() } else { v.iter().map(|c| c.describe()).collect::<Vec<_>>().join("; ") }
        };
        let shared = h.conditions.shared();
        let tuned: String = h
            .conditions
            .tuned
            .iter()
            .map(|t| format!(" `{}` was chosen outside validation ({}) on: {}.", t.key, t.how, list(&t.on)))
            .collect();
        s.line(format!(
            "Validation ran under: {}.{tuned} The test uses: {}. Shared by the test and what chose a setting: {}.",
            list(&h.conditions.validation),
            list(&h.conditions.test),
            if shared.is_empty() {
                "none".to_owned()
            } else {
                shared
                    .iter()
                    .map(|(v, t)| format!("{} / {}", v.describe(), t.describe()))
                    .collect::<Vec<_>>()
                    .join("; ")
            }
        ));
        s.blank();
        for w in &h.warnings {
            s.line(format!("Warning ({}): {w}", protocol_name(h)));
            s.blank();
        }
    }
    if let Some(first) = hs.first() {
        for n in &first.notes {
            s.line(format!("Note on the data: {n}."));
            s.blank();
        }
    }
}

/// One column of a side-by-side table: a configuration's claims and other aggregates.
pub struct Column<'a> {
    /// The configuration.
    pub header: &'a Header,
    /// Its claims.
    pub claims: &'a [Claim],
    /// Its other aggregates.
    pub table: &'a [Measure],
}

/// The claims and aggregates of every configuration of one experiment, side by side.
pub fn side_by_side(s: &mut Section, cols: &[Column<'_>]) {
    let Some(first) = cols.first() else { return };
    let mut head = vec!["claim and measure".to_owned()];
    head.extend(cols.iter().map(|c| protocol_name(c.header)));
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    let mut rows = Vec::new();
    for (i, cl) in first.claims.iter().enumerate() {
        for (j, m) in cl.measured.iter().enumerate() {
            let mut v = vec![format!("{}: {}", cl.experiment, m.label)];
            v.extend(
                cols.iter()
                    .map(|c| c.claims.get(i).and_then(|x| x.measured.get(j)).map_or("—".into(), |m| value(&m.value))),
            );
            rows.push(v);
        }
        let mut v = vec![format!("**{} verdict** ({})", cl.experiment, cl.claim)];
        v.extend(cols.iter().map(|c| c.claims.get(i).map_or("—".into(), |x| format!("**{}**", verdict(&x.verdict)))));
        rows.push(v);
    }
    for (j, m) in first.table.iter().enumerate() {
        let mut v = vec![m.label.clone()];
        v.extend(cols.iter().map(|c| c.table.get(j).map_or("—".into(), |m| value(&m.value))));
        rows.push(v);
    }
    s.table(&head, &format!("l{}", "r".repeat(cols.len())), &rows);
    for cl in first.claims {
        s.line(format!("The paper, {}: {}", cl.experiment, sources(&cl.sources)));
        s.blank();
    }
    let rules: Vec<String> = first.claims.iter().map(|c| format!("{}: {}.", c.experiment, c.verdict.rule)).collect();
    s.line(format!("Rules. {}", rules.join(" ")));
    s.blank();
}

/// The validation curves of every seed of every configuration of one experiment.
pub fn validation_figure(s: &mut Section, name: &str, cols: &[(&Header, Vec<&SeedModel>)]) {
    let panels: Vec<Panel> = cols
        .iter()
        .map(|(h, seeds)| {
            let mut curves: Vec<Curve> = seeds
                .iter()
                .enumerate()
                .map(|(k, sm)| {
                    Curve::new(
                        Look::Model,
                        if k == 0 { "a seed's scores" } else { "" },
                        sm.curve
                            .iter()
                            .filter(|(_, v)| v.is_finite() && *v > 0.0)
                            .map(|(p, v)| (p.log10(), v.log10()))
                            .collect(),
                    )
                })
                .collect();
            let (_, start, _) = h.penalty_grid;
            if start > super::differs::PAPER_PENALTY_GRID.start {
                let ys: Vec<f64> = seeds
                    .iter()
                    .flat_map(|sm| sm.curve.iter().map(|(_, v)| *v))
                    .filter(|v| v.is_finite() && *v > 0.0)
                    .map(f64::log10)
                    .collect();
                let (lo, hi) = ys.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
                let x = super::differs::PAPER_PENALTY_GRID.start;
                curves.push(Curve::new(Look::Control, "the paper's grid ends", vec![(x, lo), (x, hi)]));
            }
            curves.push(Curve::new(
                Look::Marks,
                "chosen",
                seeds
                    .iter()
                    .filter_map(|sm| {
                        sm.curve.iter().find(|(p, _)| *p == sm.penalty).map(|(p, v)| (p.log10(), v.log10()))
                    })
                    .collect(),
            ));
            Panel {
                equal_axes: false,
                title: format!("{} ({})", h.id, protocol_name(h)),
                x_label: "log10 penalty".into(),
                y_label: format!("log10 validation score ({})", h.score),
                curves,
            }
        })
        .collect();
    s.figure(name, panels, cols.len().min(3), (520 * cols.len().min(3) as u32, 420));
    s.line(format!(
        "![Validation curves: each seed's score against the penalty, the chosen penalty marked]({name}.png)"
    ));
    s.blank();
}

/// A scene to watch, written as `NAME.html` (and, with `gif_s`, its first
/// seconds as `NAME.gif`, shown in the report), and the line that links it.
pub fn view(s: &mut Section, scene: Option<&Scene>, name: &str, protocol: &str, what: &str, gif_s: Option<f64>) {
    let Some(scene) = scene else { return };
    s.page(name, scene.clone(), gif_s);
    let labels: Vec<&str> = scene.figures.iter().map(|f| f.label.as_str()).collect();
    s.line(format!(
        "Watch it, {protocol}: [`{name}.html`]({name}.html), {what} ({:.0} s), {} side by side in one self-contained page (play, pause, speed, time slider; drag to turn the view).",
        scene.n_frames() as f64 / scene.rate_hz,
        labels.join(", ")
    ));
    s.blank();
    if let Some(g) = gif_s {
        s.line(format!("![{protocol}: the first {g} s of {name}.html]({name}.gif)"));
        s.blank();
    }
}

/// The loop a teacher was cut as, against the period measured, and the stride check.
pub fn teacher_line(c: &crate::prepare::SegmentCycle, channel: &str) -> String {
    let off = 100.0 * (c.loop_len as f64 / c.period_frames - 1.0);
    let stride = match &c.stride {
        Some(s) if s.confirmed => format!(
            " Both hips confirm one stride: {} has the period {:.1} frames and {} {:.1}, {:.2} cycle apart (a half cycle is the left and right legs in turn).",
            s.left,
            s.left_period_frames,
            s.right,
            s.right_period_frames,
            s.right_lag_cycles.abs()
        ),
        Some(s) => format!(
            " The hips do not confirm one stride ({} {:.1} frames, {} {:.1}, {:.2} cycle apart).",
            s.left,
            s.left_period_frames,
            s.right,
            s.right_period_frames,
            s.right_lag_cycles.abs()
        ),
        None => String::new(),
    };
    format!(
        "Teacher: a loop of {} frames of {} (`{channel}`) from frame {}, {off:+.1} % of the period the autocorrelation finds ({:.2} frames); its seam jumps {:.3} σ beyond a typical step.{stride}",
        c.loop_len, c.label, c.loop_start, c.period_frames, c.seam_excess
    )
}

/// The opening of an experiment's section: its heading, then what each
/// configuration is and how it was validated.
pub fn opening<E: Experiment>(s: &mut Section, rs: &[&E], ctx: &Context) {
    let Some(first) = rs.first() else { return };
    s.line(format!("## {}", first.heading()));
    s.blank();
    protocols(s, &rs.iter().map(|r| r.header()).collect::<Vec<_>>(), ctx);
}

/// A line per configuration showing its drawing of the paper's figure
/// (`![Figure 2, our protocol](fig2.png)`), `base` the figure's stem.
pub fn figure_links<E: Experiment>(s: &mut Section, rs: &[&E], base: &str) {
    for r in rs {
        let number = r.figure().trim_start_matches("Fig. ");
        s.line(format!("![Figure {number}, {}]({}.png)", protocol_name(r.header()), stem(base, r.header())));
        s.blank();
    }
}

/// Every configuration's claims and aggregates side by side.
pub fn claims_side_by_side<E: Experiment>(s: &mut Section, rs: &[&E]) {
    let cols: Vec<Column<'_>> =
        rs.iter().map(|r| Column { header: r.header(), claims: r.claims(), table: r.table() }).collect();
    side_by_side(s, &cols);
}

/// Every configuration's validation curves, drawn as `name`.
pub fn validation_curves<E: Experiment>(s: &mut Section, rs: &[&E], name: &str) {
    let vc: Vec<(&Header, Vec<&SeedModel>)> = rs.iter().map(|r| (r.header(), r.seed_models())).collect();
    validation_figure(s, name, &vc);
}

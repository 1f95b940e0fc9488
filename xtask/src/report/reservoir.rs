//! Sections E1–E6 and the HOAP-2 commands: every protocol of an experiment
//! side by side. Every aggregate comes from the results (`claims`, `table`);
//! this module formats and draws.

use std::path::Path;

use cpg_lab::experiment::claim::{Claim, Measure};
use cpg_lab::experiment::coupling::CouplingResult;
use cpg_lab::experiment::frequency::FrequencyResult;
use cpg_lab::experiment::gaits::GaitsResult;
use cpg_lab::experiment::stability::StabilityResult;
use cpg_lab::experiment::{Header, SeedModel};

use super::fmt::{Md, frames, pen, secs, sources, value, verdict, yes};
use crate::figures::{Curve, Look, Panel, save};

/// `fig2` for our protocol, `fig2-paper` for the paper's, `fig2-extension` for an extension.
pub fn stem(base: &str, h: &Header) -> String {
    if h.protocol == "ours" { base.to_owned() } else { format!("{base}-{}", h.protocol) }
}

/// Writes a scene as `NAME.html` (and, with `gif_s`, its first seconds as
/// `NAME.gif`, shown in the report) and links it.
fn view(
    md: &mut Md,
    scene: Option<&cpg_view::Scene>,
    name: &str,
    protocol: &str,
    what: &str,
    gif_s: Option<f64>,
    dir: Option<&Path>,
) -> anyhow::Result<()> {
    let Some(scene) = scene else { return Ok(()) };
    if let Some(dir) = dir {
        std::fs::write(dir.join(format!("{name}.html")), scene.to_html())?;
        if let Some(s) = gif_s {
            let opts = cpg_view::GifOptions { seconds: Some(s), ..Default::default() };
            std::fs::write(dir.join(format!("{name}.gif")), scene.to_gif(&opts)?)?;
        }
    }
    let labels: Vec<&str> = scene.figures.iter().map(|f| f.label.as_str()).collect();
    md.line(format!(
        "Watch it, {protocol}: [`{name}.html`]({name}.html), {what} ({:.0} s), {} side by side in one self-contained page (play, pause, speed, time slider; drag to turn the view).",
        scene.n_frames() as f64 / scene.rate_hz,
        labels.join(", ")
    ));
    md.blank();
    if let Some(s) = gif_s {
        md.line(format!("![{protocol}: the first {s} s of {name}.html]({name}.gif)"));
        md.blank();
    }
    Ok(())
}

/// The heading of an experiment's section (the summary links to it).
pub fn heading(o: &cpg_lab::experiment::Outcome) -> String {
    use cpg_lab::experiment::Outcome;
    let fig = match o {
        Outcome::Stability(_) => "Fig. 2",
        Outcome::Frequency(_) => "Fig. 3",
        Outcome::Gaits(_) => "Fig. 4",
        Outcome::Coupling(_) => "Fig. 5",
    };
    section_heading(o.header(), fig)
}

fn section_heading(h: &Header, fig: &str) -> String {
    format!("{}: {} ({fig})", h.id, h.title)
}

/// "the paper's protocol", "our protocol", "our extension", "tried".
pub fn protocol_name(h: &Header) -> String {
    match h.protocol.as_str() {
        "ours" => "our protocol".into(),
        "paper" => "the paper's protocol".into(),
        "extension" => "our extension".into(),
        other => other.to_owned(),
    }
}

/// One sentence on how a configuration chose its penalty.
pub fn protocol_line(h: &Header) -> String {
    let (n, a, b) = h.penalty_grid;
    let grid = format!("{n} penalties 10^{a} … 10^{b}");
    let how = match h.score.as_str() {
        "nmse" => format!(
            "validation by the NMSE of a free run against the teacher, step by step{}",
            if h.noise_variance > 0.0 {
                format!(", under state noise of variance {}", h.noise_variance)
            } else {
                String::new()
            }
        ),
        _ => "validation by the orbit score: clean free runs at settings of the controls, each scored by the phase-aligned NMSE against its cycle".into(),
    };
    format!(
        "**{}** (`{}`): {} neurons; {grid}; {how}.",
        capital(&protocol_name(h)),
        super::rel_str(&h.config),
        h.n_neurons
    )
}

fn capital(s: &str) -> String {
    let mut c = s.chars();
    c.next().map(|f| f.to_uppercase().collect::<String>() + c.as_str()).unwrap_or_default()
}

fn pts(y: &[f64], t0: f64, rate: f64) -> Vec<(f64, f64)> {
    y.iter().enumerate().map(|(k, v)| (t0 + k as f64 / rate, *v)).collect()
}

/// What each configuration is, what it changes against the paper, the
/// conditions its validation and its test used, and its warnings.
fn protocols(md: &mut Md, hs: &[&Header]) {
    for h in hs {
        md.line(protocol_line(h));
        md.blank();
        if !h.differs.is_empty() {
            md.line(format!("What differs from the paper ({}):", protocol_name(h)));
            md.blank();
            for d in &h.differs {
                md.line(format!("- {}", d.describe()));
            }
            md.blank();
        } else if h.protocol == "paper" {
            md.line("Nothing the paper states differs.");
            md.blank();
        }
        let list = |v: &[cpg_lab::experiment::conditions::Condition]| {
            if v.is_empty() { "none".to_owned() } else { v.iter().map(|c| c.describe()).collect::<Vec<_>>().join("; ") }
        };
        let shared = h.conditions.shared();
        md.line(format!(
            "Validation ran under: {}. The test uses: {}. Shared by both: {}.",
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
        md.blank();
        for w in &h.warnings {
            md.line(format!("Warning ({}): {w}", protocol_name(h)));
            md.blank();
        }
    }
    if let Some(first) = hs.first() {
        for n in &first.notes {
            md.line(format!("Note on the data: {n}."));
            md.blank();
        }
    }
}

/// One column of a side-by-side table: a configuration's claims and other aggregates.
struct Column<'a> {
    header: &'a Header,
    claims: &'a [Claim],
    table: &'a [Measure],
}

/// The claims and aggregates of every configuration of one experiment, side by side.
fn side_by_side(md: &mut Md, cols: &[Column<'_>]) {
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
    md.table(&head, &format!("l{}", "r".repeat(cols.len())), &rows);
    for cl in first.claims {
        md.line(format!("The paper, {}: {}", cl.experiment, sources(&cl.sources)));
        md.blank();
    }
    let rules: Vec<String> = first.claims.iter().map(|c| format!("{}: {}.", c.experiment, c.verdict.rule)).collect();
    md.line(format!("Rules. {}", rules.join(" ")));
    md.blank();
}

/// The validation curves of every seed of every configuration of one experiment.
fn validation_figure(
    md: &mut Md,
    name: &str,
    cols: &[(&Header, Vec<&SeedModel>)],
    dir: Option<&Path>,
) -> anyhow::Result<()> {
    if let Some(dir) = dir {
        let panels: Vec<Panel> = cols
            .iter()
            .map(|(h, seeds)| {
                let mut curves: Vec<Curve> = seeds
                    .iter()
                    .enumerate()
                    .map(|(k, s)| {
                        Curve::new(
                            Look::Model,
                            if k == 0 { "a seed's scores" } else { "" },
                            s.curve
                                .iter()
                                .filter(|(_, v)| v.is_finite() && *v > 0.0)
                                .map(|(p, v)| (p.log10(), v.log10()))
                                .collect(),
                        )
                    })
                    .collect();
                let (_, start, _) = h.penalty_grid;
                if start > cpg_lab::experiment::differs::PAPER_PENALTY_GRID.start {
                    let ys: Vec<f64> = seeds
                        .iter()
                        .flat_map(|s| s.curve.iter().map(|(_, v)| *v))
                        .filter(|v| v.is_finite() && *v > 0.0)
                        .map(f64::log10)
                        .collect();
                    let (lo, hi) =
                        ys.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
                    let x = cpg_lab::experiment::differs::PAPER_PENALTY_GRID.start;
                    curves.push(Curve::new(Look::Control, "the paper's grid ends", vec![(x, lo), (x, hi)]));
                }
                curves.push(Curve::new(
                    Look::Marks,
                    "chosen",
                    seeds
                        .iter()
                        .filter_map(|s| {
                            s.curve.iter().find(|(p, _)| *p == s.penalty).map(|(p, v)| (p.log10(), v.log10()))
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
        save(&dir.join(name), &panels, cols.len().min(3), (520 * cols.len().min(3) as u32, 420))?;
    }
    md.line(format!(
        "![Validation curves: each seed's score against the penalty, the chosen penalty marked]({name}.png)"
    ));
    md.blank();
    Ok(())
}

/// E1–E3.
pub fn stability(md: &mut Md, rs: &[&StabilityResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let Some(first) = rs.first() else { return Ok(()) };
    md.line(format!("## {}", section_heading(&first.header, "Fig. 2")));
    md.blank();
    protocols(md, &rs.iter().map(|r| &r.header).collect::<Vec<_>>());
    if let Some(c) = first.header.cycles.first() {
        md.line(teacher_line(c, &first.channel));
        md.blank();
    }
    for r in rs {
        md.line(format!("![Figure 2, {}]({}.png)", protocol_name(&r.header), stem("fig2", &r.header)));
        md.blank();
    }
    let cols: Vec<Column<'_>> =
        rs.iter().map(|r| Column { header: &r.header, claims: &r.claims, table: &r.table }).collect();
    side_by_side(md, &cols);
    md.line(format!("Definitions. A seed is {}. The push holds the fed-back output at the cycle's maximum + {} σ ({:.1} in the channel's units) for {} steps ({:.3} s) from {:.2} s. Distances, windows and times are defined once in `cpg_lab::measure`: RMS over quarter-period windows in teacher standard deviations, below 0.25 from some window until the end of the run; the time is the start of that window after the release, so 0 s means at once.",
        cpg_lab::experiment::stability::RULE, first.push.above_max, first.push.held_units.first().copied().unwrap_or(f64::NAN), first.push.hold_steps, first.push.hold_s, first.push.at_s));
    md.blank();
    let vc: Vec<(&Header, Vec<&SeedModel>)> =
        rs.iter().map(|r| (&r.header, r.seeds.iter().map(|s| &s.model).collect())).collect();
    validation_figure(md, "fig_validation_e1", &vc, dir)?;
    for r in rs {
        seeds_table(md, r);
        if let Some(dir) = dir {
            figure2(r, dir)?;
        }
    }
    Ok(())
}

/// The loop a teacher was cut as, against the period measured, and the stride check.
fn teacher_line(c: &cpg_lab::prepare::SegmentCycle, channel: &str) -> String {
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

fn seeds_table(md: &mut Md, r: &StabilityResult) {
    md.line(format!("Per seed, {} (teacher period {:.0} frames):", protocol_name(&r.header), r.teacher.cycle.len()));
    md.blank();
    let rows: Vec<Vec<String>> = r
        .seeds
        .iter()
        .map(|s| {
            let st = &s.stability;
            let period = match (st.end.period_steps, st.decayed_at_s) {
                (_, Some(t)) => format!("decayed at {t:.0} s"),
                (p, None) => frames(p),
            };
            vec![
                s.model.seed.to_string(),
                pen(s.model.penalty),
                format!("{:.4}", s.model.validation_score),
                format!("{:.4}", s.first_nmse),
                period,
                format!("{:.3}", st.amplitude_ratio(0)),
                format!("{:.4}", st.end.aligned_nmse),
                yes(st.converged).into(),
                format!("{}{}", yes(st.accurate), if s.accurate.at_limit { " (at the limit)" } else { "" }),
                secs(s.recovery.orbit_s),
                secs(s.recovery.twin_s),
                format!("{:+.3}", s.recovery.phase_shift_cycles),
            ]
        })
        .collect();
    md.table(
        &[
            "seed",
            "penalty",
            "validation score",
            &format!("first-{} NMSE", r.first_samples),
            &format!("period at {:.0} s (frames)", r.long_run_s),
            "amplitude / teacher",
            "last-10-s aligned NMSE",
            "converged",
            "accurate",
            "back on the orbit",
            "back on the twin",
            "phase shift (cycles)",
        ],
        "rrrrrrrllrrr",
        &rows,
    );
}

fn figure2(r: &StabilityResult, dir: &Path) -> anyhow::Result<()> {
    let f = &r.fig2;
    let rate = 120.0;
    let units = "deg";
    let hold_t0 = r.push.at_s;
    let held = r.push.held_units.first().copied().unwrap_or(f64::NAN);
    save(
        &dir.join(stem("fig2", &r.header)),
        &[
            Panel {
                equal_axes: false,
                title: format!("E1: free run from the trained state ({})", protocol_name(&r.header)),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "teacher", pts(&f.first_teacher, 0.0, rate)),
                    Curve::new(Look::Model, "model", pts(&f.first_model, 0.0, rate)),
                ],
            },
            Panel {
                equal_axes: false,
                title: format!("E2: after {:.0} s of free run, teacher at its best phase", f.end_start_s),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "teacher", pts(&f.end_teacher, f.end_start_s, rate)),
                    Curve::new(Look::Model, "model", pts(&f.end_model, f.end_start_s, rate)),
                ],
            },
            Panel {
                equal_axes: false,
                title: format!(
                    "E3: output held at {held:.1} {units} for {:.0} ms after {:.0} s",
                    1000.0 * r.push.hold_s,
                    hold_t0
                ),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "unperturbed twin", pts(&f.free, 0.0, rate)),
                    Curve::new(Look::Model, "pushed run (the held value while held)", pts(&f.pushed, 0.0, rate)),
                    Curve::new(Look::Held, "held value", vec![(hold_t0, held), (hold_t0 + r.push.hold_s, held)]),
                ],
            },
        ],
        1,
        (1000, 900),
    )
}

/// E4.
pub fn frequency(md: &mut Md, rs: &[&FrequencyResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let Some(first) = rs.first() else { return Ok(()) };
    md.line(format!("## {}", section_heading(&first.header, "Fig. 3")));
    md.blank();
    protocols(md, &rs.iter().map(|r| &r.header).collect::<Vec<_>>());
    md.line(format!("Every configuration is trained on the femur cycle replayed at a rate u(t) that drifts smoothly in [1, 6] (the configuration's `[data.tempo]`). Test: u held at {} for {} s each with {}-s cosine ramps between; each plateau is judged over its second half against the cycle played u times as fast. The teacher's frequency at u = 1 is f0 = {:.3} Hz. A plateau's frequency counts as 0 when the output decayed or showed no rhythm.",
        first.plateaus.iter().map(|u| format!("{u}")).collect::<Vec<_>>().join(", "), first.hold_s, first.ramp_s, first.f0_hz));
    md.blank();
    for r in rs {
        md.line(format!("![Figure 3, {}]({}.png)", protocol_name(&r.header), stem("fig3", &r.header)));
        md.blank();
    }
    let cols: Vec<Column<'_>> =
        rs.iter().map(|r| Column { header: &r.header, claims: &r.claims, table: &r.table }).collect();
    side_by_side(md, &cols);
    if let Some(dir) = dir {
        frequency_against_u(rs, dir)?;
    }
    md.line("![Frequency against u: every seed at every plateau, each configuration in its panel; the line is u·f0](fig3_frequency.png)");
    md.blank();
    let vc: Vec<(&Header, Vec<&SeedModel>)> =
        rs.iter().map(|r| (&r.header, r.seeds.iter().map(|s| &s.model).collect())).collect();
    validation_figure(md, "fig_validation_e4", &vc, dir)?;
    for r in rs {
        let rows: Vec<Vec<String>> = r
            .seeds
            .iter()
            .map(|s| {
                let mut v = vec![s.model.seed.to_string(), pen(s.model.penalty)];
                v.extend(s.plateaus.iter().chain(&s.figure).map(|p| {
                    format!(
                        "{} / {:.2}{}",
                        p.measured_hz.map_or("—".into(), |h| format!("{h:.2}")),
                        p.amplitude_ratio,
                        if p.passed { "" } else { " ✗" }
                    )
                }));
                v.push(format!("{}{}", yes(s.passed), if s.at_limit { " (at the limit)" } else { "" }));
                v
            })
            .collect();
        let mut heads: Vec<String> = r.plateaus.iter().map(|u| format!("u = {u} ({:.2} Hz)", u * r.f0_hz)).collect();
        if let Some(s0) = r.seeds.first() {
            heads.extend(
                s0.figure.iter().map(|w| format!("Fig. 3, u = {} at {:.0}–{:.0} s", w.u, w.window_s[0], w.window_s[1])),
            );
        }
        let mut head = vec!["seed", "penalty"];
        head.extend(heads.iter().map(String::as_str));
        head.push("passed");
        md.line(format!(
            "Per seed, {}: measured frequency (Hz) / amplitude ratio at each plateau and held stretch (✗: outside the tolerances):",
            protocol_name(&r.header)
        ));
        md.blank();
        md.table(&head, &"r".repeat(head.len()), &rows);
        if let Some(dir) = dir {
            figure3(r, dir)?;
        }
    }
    Ok(())
}

fn frequency_against_u(rs: &[&FrequencyResult], dir: &Path) -> anyhow::Result<()> {
    let panels: Vec<Panel> = rs
        .iter()
        .map(|r| {
            let us = &r.plateaus;
            let (lo, hi) = (
                us.iter().copied().fold(f64::INFINITY, f64::min),
                us.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            );
            Panel {
                equal_axes: false,
                title: format!("E4 ({})", protocol_name(&r.header)),
                x_label: "u".into(),
                y_label: "frequency (Hz)".into(),
                curves: vec![
                    Curve::new(Look::Teacher, "u·f0", vec![(lo, lo * r.f0_hz), (hi, hi * r.f0_hz)]),
                    Curve::new(
                        Look::Marks,
                        "seeds",
                        r.seeds
                            .iter()
                            .flat_map(|s| s.plateaus.iter().map(|p| (p.u, p.measured_hz.unwrap_or(0.0))))
                            .collect(),
                    ),
                ],
            }
        })
        .collect();
    save(&dir.join("fig3_frequency"), &panels, rs.len().min(3), (460 * rs.len().min(3) as u32, 420))
}

fn figure3(r: &FrequencyResult, dir: &Path) -> anyhow::Result<()> {
    let f = &r.fig3;
    let rate = 120.0;
    save(
        &dir.join(stem("fig3", &r.header)),
        &[
            Panel {
                equal_axes: false,
                title: format!(
                    "E4 plateaus ({}): u = {}",
                    protocol_name(&r.header),
                    r.plateaus.iter().map(|u| format!("{u}")).collect::<Vec<_>>().join(", ")
                ),
                x_label: "time (s)".into(),
                y_label: "left femur (z) / u".into(),
                curves: vec![
                    Curve::new(Look::Model, "model", pts(&f.plateau_output, 0.0, rate)),
                    Curve::new(Look::Control, "control u", pts(&f.plateau_control, 0.0, rate)),
                ],
            },
            Panel {
                equal_axes: false,
                title: "The paper's test: u high → low → high".into(),
                x_label: "time (s)".into(),
                y_label: "left femur (z) / u".into(),
                curves: vec![
                    Curve::new(Look::Model, "model", pts(&f.figure_output, 0.0, rate)),
                    Curve::new(Look::Control, "control u", pts(&f.figure_control, 0.0, rate)),
                ],
            },
        ],
        1,
        (1200, 800),
    )
}

/// E5.
pub fn gaits(md: &mut Md, rs: &[&GaitsResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let Some(first) = rs.first() else { return Ok(()) };
    md.line(format!("## {}", section_heading(&first.header, "Fig. 4")));
    md.blank();
    protocols(md, &rs.iter().map(|r| &r.header).collect::<Vec<_>>());
    for c in &first.header.cycles {
        md.line(teacher_line(c, &c.period_channel));
        md.blank();
    }
    md.line(format!("Test: the first gait, a smooth switch (a {}-s cosine ramp of the controls) at {} s, back at {} s, until {} s; the same with abrupt switches.", first.ramp_s, first.switch_at_s[0], first.switch_at_s[1], first.run_s));
    md.blank();
    for r in rs {
        md.line(format!("![Figure 4, {}]({}.png)", protocol_name(&r.header), stem("fig4", &r.header)));
        md.blank();
    }
    for r in rs {
        view(
            md,
            r.view.as_ref(),
            &stem("e5_view", &r.header),
            &protocol_name(&r.header),
            "the first seed's smooth switching run",
            None,
            dir,
        )?;
    }
    let cols: Vec<Column<'_>> =
        rs.iter().map(|r| Column { header: &r.header, claims: &r.claims, table: &r.table }).collect();
    side_by_side(md, &cols);
    if let Some(dir) = dir {
        all_switches(rs, dir)?;
    }
    md.line("![Every seed's smooth switching run, each configuration in its column; the gray bands are the ramps](fig4_seeds.png)");
    md.blank();
    let vc: Vec<(&Header, Vec<&SeedModel>)> =
        rs.iter().map(|r| (&r.header, r.seeds.iter().map(|s| &s.model).collect())).collect();
    validation_figure(md, "fig_validation_e5", &vc, dir)?;
    for r in rs {
        let g = |w: &cpg_lab::experiment::gaits::GaitWindow| {
            format!(
                "{} / {:.0}, {:.2}{}",
                frames(w.period_steps),
                w.teacher_period_steps,
                w.amplitude_ratio,
                if w.passed { "" } else { " ✗" }
            )
        };
        let rows: Vec<Vec<String>> = r
            .seeds
            .iter()
            .map(|s| {
                vec![
                    s.model.seed.to_string(),
                    pen(s.model.penalty),
                    g(&s.first),
                    g(&s.second),
                    g(&s.first_again),
                    secs(s.settle_s[0]),
                    secs(s.settle_s[1]),
                    format!("{:.3}", s.max_jump_smooth),
                    format!("{:.3}", s.max_jump_abrupt),
                    format!("{}{}", yes(s.passed), if s.at_limit { " (at the limit)" } else { "" }),
                ]
            })
            .collect();
        md.line(format!(
            "Per seed, {} (period / teacher's in frames, amplitude ratio; ✗: outside the tolerances):",
            protocol_name(&r.header)
        ));
        md.blank();
        md.table(
            &[
                "seed",
                "penalty",
                "first gait",
                "second gait",
                "first gait again",
                "settled after switch 1",
                "after switch 2",
                "largest step, smooth",
                "abrupt",
                "passed",
            ],
            "rrrrrrrrrl",
            &rows,
        );
        if let Some(dir) = dir {
            figure4(r, dir)?;
        }
    }
    Ok(())
}

fn all_switches(rs: &[&GaitsResult], dir: &Path) -> anyhow::Result<()> {
    let rate = 120.0;
    let n_seeds = rs.iter().map(|r| r.smooth_runs.len()).max().unwrap_or(0);
    let mut panels = Vec::new();
    for k in 0..n_seeds {
        for r in rs {
            let Some(y) = r.smooth_runs.get(k) else { continue };
            let (lo, hi) = y.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
            let band = |t: f64| {
                Curve::new(Look::Control, "", vec![(t, lo), (t, hi), (t + r.ramp_s, hi), (t + r.ramp_s, lo), (t, lo)])
            };
            panels.push(Panel {
                equal_axes: false,
                title: format!("seed {} ({})", r.seeds.get(k).map_or(0, |s| s.model.seed), protocol_name(&r.header)),
                x_label: "time (s)".into(),
                y_label: "left femur (z)".into(),
                curves: vec![
                    band(r.switch_at_s[0]),
                    band(r.switch_at_s[1]),
                    Curve::new(Look::Model, "", pts(y, 0.0, rate)),
                ],
            });
        }
    }
    if panels.is_empty() {
        return Ok(());
    }
    let cols = rs.len().max(1);
    save(&dir.join("fig4_seeds"), &panels, cols, (520 * cols as u32, 170 * n_seeds as u32))
}

fn figure4(r: &GaitsResult, dir: &Path) -> anyhow::Result<()> {
    let f = &r.fig4;
    let rate = 120.0;
    let mut panels: Vec<Panel> = f
        .teachers
        .iter()
        .map(|(label, y)| Panel {
            equal_axes: false,
            title: format!("{label}, the training cycle"),
            x_label: "time (s)".into(),
            y_label: "left femur (z)".into(),
            curves: vec![Curve::new(Look::Teacher, "teacher", pts(y, 0.0, rate))],
        })
        .collect();
    panels.push(Panel {
        equal_axes: false,
        title: format!(
            "Smooth switches at {} s and {} s ({})",
            r.switch_at_s[0],
            r.switch_at_s[1],
            protocol_name(&r.header)
        ),
        x_label: "time (s)".into(),
        y_label: "left femur (z) / control".into(),
        curves: vec![
            Curve::new(Look::Model, "model", pts(&f.smooth, 0.0, rate)),
            Curve::new(Look::Control, "second control", pts(&f.smooth_control, 0.0, rate)),
        ],
    });
    panels.push(Panel {
        equal_axes: false,
        title: "Abrupt switches (the paper warns of spikes)".into(),
        x_label: "time (s)".into(),
        y_label: "left femur (z) / control".into(),
        curves: vec![
            Curve::new(Look::Model, "model", pts(&f.abrupt, 0.0, rate)),
            Curve::new(Look::Control, "second control", pts(&f.abrupt_control, 0.0, rate)),
        ],
    });
    save(&dir.join(stem("fig4", &r.header)), &panels, 2, (1300, 800))
}

/// E6.
pub fn coupling(md: &mut Md, rs: &[&CouplingResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let Some(first) = rs.first() else { return Ok(()) };
    md.line(format!("## {}", section_heading(&first.header, "Fig. 5")));
    md.blank();
    protocols(md, &rs.iter().map(|r| &r.header).collect::<Vec<_>>());
    if let Some(c) = first.header.cycles.first() {
        md.line(teacher_line(c, &first.reference));
        md.blank();
    }
    for r in rs {
        let gif = (r.header.protocol == "ours").then_some(5.0);
        view(
            md,
            r.view.as_ref(),
            &stem("e6_view", &r.header),
            &protocol_name(&r.header),
            "the last 10 s of the free run",
            gif,
            dir,
        )?;
    }
    md.line(format!("{} channels, one cycle of {} frames repeated; free run of {} steps ({:.0} s). A joint's **deviation** is the model's phase relation to `{}` minus the teacher's, in cycles: each channel's own teacher cycle is aligned to three cycles of the model's window to a fraction of a frame (the vertex of a parabola through the best whole shift and its neighbours), so 0 is exactly the teacher's lag and one frame is {:.4} cycle. Its **drift** is the deviation in the last 10 s minus that in the first 10 s; the verdict uses the drift. The cross-correlation **lags** are shown beside it: a joint with two similar peaks a cycle (the feet) can move its cross-correlation peak from one to the other without any change of phase, which is why the verdict does not use them. Portraits: data (the whole trial) light gray, model black (10 s from {:.0} s on).",
        first.rows.len(), first.period_frames, first.steps, first.run_s, first.reference, 1.0 / first.period_frames as f64, first.portrait_from_s));
    md.blank();
    let cols: Vec<Column<'_>> =
        rs.iter().map(|r| Column { header: &r.header, claims: &r.claims, table: &r.table }).collect();
    side_by_side(md, &cols);
    let vc: Vec<(&Header, Vec<&SeedModel>)> =
        rs.iter().map(|r| (&r.header, r.seeds.iter().map(|s| &s.model).collect())).collect();
    validation_figure(md, "fig_validation_e6", &vc, dir)?;
    if let Some(dir) = dir {
        deviation_figure(rs, dir)?;
    }
    md.line(
        "![Every joint's deviation from the teacher's phase relation over the run, first seed](fig5_deviation.png)",
    );
    md.blank();
    for r in rs {
        let rows: Vec<Vec<String>> = r
            .seeds
            .iter()
            .map(|s| {
                vec![
                    s.model.seed.to_string(),
                    pen(s.model.penalty),
                    format!("{:.3}", s.worst_drift),
                    format!("{:.4}", s.median_cycle_nmse),
                    format!("{}{}", yes(s.passed), if s.at_limit { " (at the limit)" } else { "" }),
                ]
            })
            .collect();
        md.line(format!("Seeds, {}:", protocol_name(&r.header)));
        md.blank();
        md.table(&["seed", "penalty", "largest drift (cycles)", "median cycle NMSE", "coupling kept"], "rrrrl", &rows);
    }
    md.line(format!(
        "The joint tables, the portraits, the view and the HOAP-2 commands below show the first seed ({}).",
        first.model.seed
    ));
    md.blank();
    for r in rs {
        md.line(format!("![Figure 5, {}]({}.png)", protocol_name(&r.header), stem("fig5", &r.header)));
        md.blank();
        let rows: Vec<Vec<String>> = r
            .rows
            .iter()
            .map(|j| {
                vec![
                    j.joint.clone(),
                    format!("{:+.3}", j.teacher_lag),
                    format!("{:+.3}", j.model_lag_end),
                    format!("{:+.3}", j.lag_change),
                    format!("{:+.4}", j.deviation_start),
                    format!("{:+.4}", j.deviation_end),
                    format!("{:+.4}", j.drift),
                    format!("{:.4}", j.cycle_nmse),
                ]
            })
            .collect();
        md.line(format!("Joints, {}:", protocol_name(&r.header)));
        md.blank();
        md.table(
            &[
                "joint",
                "teacher's lag (cycles)",
                "model's lag, last 10 s",
                "lag change",
                "deviation, first 10 s",
                "deviation, last 10 s",
                "drift",
                "NMSE of the last cycle",
            ],
            "lrrrrrrr",
            &rows,
        );
        let panels: Vec<Panel> = r
            .portraits
            .iter()
            .map(|p| Panel {
                equal_axes: false,
                title: format!("{} vs {}", p.channel, r.reference),
                x_label: format!("{} (z)", r.reference),
                y_label: format!("{} (z)", p.channel),
                curves: vec![
                    Curve::new(Look::Data, "data", p.data.clone()),
                    Curve::new(Look::Model, "model", p.model.clone()),
                ],
            })
            .collect();
        if let Some(dir) = dir {
            save(&dir.join(stem("fig5", &r.header)), &panels, 4, (1400, 1000))?;
        }
    }
    Ok(())
}

fn deviation_figure(rs: &[&CouplingResult], dir: &Path) -> anyhow::Result<()> {
    let panels: Vec<Panel> = rs
        .iter()
        .map(|r| {
            let d = r.rows.len();
            Panel {
                equal_axes: false,
                title: format!("E6 deviation over time ({}, seed {})", protocol_name(&r.header), r.model.seed),
                x_label: "start of the 10-s window (s)".into(),
                y_label: "deviation (cycles)".into(),
                curves: (0..d)
                    .map(|j| {
                        Curve::new(
                            Look::Model,
                            if j == 0 { "each joint" } else { "" },
                            r.deviation_over_time.iter().map(|(t, v)| (*t, v[j])).collect(),
                        )
                    })
                    .collect(),
            }
        })
        .collect();
    save(&dir.join("fig5_deviation"), &panels, rs.len().min(2), (620 * rs.len().min(2) as u32, 420))
}

/// The HOAP-2 section from E6 runs that mapped their output onto the robot.
pub fn hoap2(md: &mut Md, rs: &[&CouplingResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let mapped: Vec<&&CouplingResult> = rs.iter().filter(|r| r.hoap2.is_some()).collect();
    if mapped.is_empty() {
        return Ok(());
    }
    md.line("## HOAP-2 joint commands");
    md.blank();
    for r in &mapped {
        let Some(h) = &r.hoap2 else { continue };
        let s = stem("e6_hoap2", &r.header);
        if let Some(dir) = dir {
            std::fs::write(dir.join(format!("{s}_120hz.csv")), h.trajectory.to_csv())?;
            std::fs::write(dir.join(format!("{s}_1khz.csv")), h.trajectory_1khz.to_csv())?;
            std::fs::write(dir.join(format!("{s}_1khz.json")), h.trajectory_1khz.to_ros_json())?;
        }
        md.line(format!(
            "The end of E6's free run ({}) as a loop of {} whole cycles of the model ({} frames, cut where the run meets itself best), mapped by the configuration's channel map onto the joints of the URDF, resampled by a natural cubic spline (with {} frames of margin on each side, so that the spline's ends fall outside the loop) and kept within every joint's position range, its URDF velocity limit ({} rad/s) and an acceleration bound of {} rad/s² (ours: the HOAP-2 documents give none). The limiter starts in motion and runs the loop twice, keeping the second lap, so the commands start in the state they end in: `{s}_120hz.csv`, `{s}_1khz.csv` (time_s, then every joint's angle in rad, velocity in rad/s and acceleration in rad/s²) and `{s}_1khz.json` (a trajectory_msgs/JointTrajectory) can be played in a loop.",
            protocol_name(&r.header),
            h.loop_cycles,
            h.loop_frames,
            cpg_lab::experiment::coupling::LOOP_MARGIN,
            h.velocity_limit_rad_s,
            h.acceleration_bound_rad_s2
        ));
        md.blank();
        md.line(format!(
            "At 1 kHz the fastest commanded joint speed is {:.2} rad/s and the largest acceleration {:.1} rad/s²; {} commanded angle(s) lie outside their joint's range, so the commands are within every limit: {}. That holds because the limiter makes it so; what it changed to get there, over all joints' frames: {:.1} % had their asked angle outside the range, {:.1} % were held back by the speed limit and {:.1} % by the acceleration bound. Across the loop's seam a commanded angle jumps at most {:.3}° (the largest step within the loop is {:.3}°).",
            h.max_speed_rad_s,
            h.max_acceleration_rad_s2,
            h.n_outside_range,
            yes(h.within_limits),
            100.0 * h.share_position_clamped,
            100.0 * h.share_velocity_limited,
            100.0 * h.share_acceleration_limited,
            h.loop_seam_rad.to_degrees(),
            h.loop_max_step_rad.to_degrees()
        ));
        md.blank();
        if let Some(dir) = dir {
            knee_ankle_figure(r, h, &format!("{s}_knee_ankle"), dir)?;
        }
        md.line(format!(
            "![{}: the left knee and ankle pitch, asked and commanded]({s}_knee_ankle.png)",
            protocol_name(&r.header)
        ));
        md.blank();
        if h.robot_gait.is_some() || h.human_gait_scaled.is_some() {
            md.line(format!(
                "The gait on the robot (HOAP-2 forward kinematics of the commanded angles at the model's rate: the soles in the trunk frame) beside the human's in the recorded trial (the ankles relative to the root), its lengths scaled by the ratio of the legs ({:.3}: HOAP-2's thigh + shank over the human's femur + tibia).",
                h.leg_scale
            ));
            md.blank();
            let g = |x: Option<cpg_hoap2::Gait>, f: fn(&cpg_hoap2::Gait) -> String| {
                x.as_ref().map(f).unwrap_or_else(|| "no full cycle".into())
            };
            let rows = vec![
                vec![
                    "forward excursion of a foot (m)".to_owned(),
                    g(h.robot_gait, |x| format!("{:.3}", x.excursion_m)),
                    g(h.human_gait_scaled, |x| format!("{:.3}", x.excursion_m)),
                ],
                vec![
                    "foot lift (m)".to_owned(),
                    g(h.robot_gait, |x| format!("{:.3}", x.lift_m)),
                    g(h.human_gait_scaled, |x| format!("{:.3}", x.lift_m)),
                ],
                vec![
                    "cycle period (s)".to_owned(),
                    g(h.robot_gait, |x| format!("{:.3}", x.period_s)),
                    g(h.human_gait_scaled, |x| format!("{:.3}", x.period_s)),
                ],
                vec![
                    "right foot behind the left (cycles; 0.5 is antiphase)".to_owned(),
                    g(h.robot_gait, |x| format!("{:.2}", x.left_right_phase)),
                    g(h.human_gait_scaled, |x| format!("{:.2}", x.left_right_phase)),
                ],
            ];
            md.table(&["measure", "robot (generated)", "human (recorded, scaled)"], "lrr", &rows);
        }
        let pct = |k: usize, n: usize| format!("{:.1} %", 100.0 * k as f64 / n.max(1) as f64);
        let rows: Vec<Vec<String>> = h
            .clamps
            .joints
            .iter()
            .map(|c| {
                vec![
                    c.joint.clone(),
                    pct(c.n_clamped, c.n_frames),
                    format!("{:.2}°", c.max_excess_rad.to_degrees()),
                    format!("{:.1} … {:.1}", c.min_rad.to_degrees(), c.max_rad.to_degrees()),
                    format!("{:.2}", c.max_velocity_rad_s),
                    pct(c.n_velocity_limited, c.n_frames),
                    format!("{:.1}", c.max_acceleration_rad_s2),
                    pct(c.n_acceleration_limited, c.n_frames),
                    format!("{:.2}°", c.max_lag_rad.to_degrees()),
                ]
            })
            .collect();
        md.table(
            &[
                "joint",
                "frames clamped",
                "largest excess",
                "range asked (deg)",
                "speed asked (rad/s)",
                "frames speed-limited",
                "acceleration asked (rad/s²)",
                "frames acceleration-limited",
                "largest lag",
            ],
            "lrrrrrrrr",
            &rows,
        );
    }
    Ok(())
}

/// The left knee and ankle pitch at 1 kHz, asked and commanded, over the first two seconds of the loop.
fn knee_ankle_figure(
    r: &CouplingResult,
    h: &cpg_lab::experiment::coupling::Hoap2,
    name: &str,
    dir: &Path,
) -> anyhow::Result<()> {
    let fast = &h.trajectory_1khz;
    let asked = &h.asked_1khz;
    let span = fast.n_frames().min(2000);
    let panel = |joint: &str, what: &str| -> Option<Panel> {
        let j = fast.joints.iter().position(|x| x == joint)?;
        let d = fast.joints.len();
        let col = |v: &[f64]| -> Vec<(f64, f64)> {
            (0..span).map(|f| (f as f64 / fast.rate_hz, v[f * d + j].to_degrees())).collect()
        };
        Some(Panel {
            equal_axes: false,
            title: format!("{what} ({joint}), {}", protocol_name(&r.header)),
            x_label: "time in the loop (s)".into(),
            y_label: "angle (deg)".into(),
            curves: vec![
                Curve::new(Look::Teacher, "asked", col(&asked.values_rad)),
                Curve::new(Look::Model, "commanded", col(&fast.values_rad)),
            ],
        })
    };
    let panels: Vec<Panel> = [("lleg_joint_4", "left knee"), ("lleg_joint_5", "left ankle pitch")]
        .iter()
        .filter_map(|(j, w)| panel(j, w))
        .collect();
    if panels.is_empty() {
        return Ok(());
    }
    save(&dir.join(name), &panels, 2, (1200, 420))
}

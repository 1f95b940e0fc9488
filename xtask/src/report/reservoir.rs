//! Sections E1–E6: one renderer per result type, the paper's protocol and
//! ours side by side.

use std::path::Path;

use cpg_lab::experiment::coupling::CouplingResult;
use cpg_lab::experiment::frequency::FrequencyResult;
use cpg_lab::experiment::gaits::GaitsResult;
use cpg_lab::experiment::stability::StabilityResult;
use cpg_lab::experiment::{Header, Verdict};

use super::fmt::{Md, frames, median, pen, secs, span, verdict, yes};
use crate::figures::{Curve, Look, Panel, save};

/// `fig2` for our protocol, `fig2-paper` for the paper's.
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

/// "our protocol", "the paper's protocol".
pub fn protocol_name_pub(h: &Header) -> String {
    protocol_name(h)
}

fn protocol_name(h: &Header) -> String {
    if h.protocol == "ours" { "our protocol".into() } else { format!("the {}'s protocol", h.protocol) }
}

/// One sentence on how a protocol chose its penalty.
pub fn protocol_line(h: &Header) -> String {
    let (n, a, b) = h.penalty_grid;
    let grid = format!("{n} penalties 10^{a} … 10^{b}");
    let how = match h.score.as_str() {
        "nmse" => format!(
            "validation by the NMSE of a noisy free run (state-noise variance {}) against the teacher, step by step",
            h.noise_variance
        ),
        _ => "validation by the orbit score: clean free runs at each teacher's control setting, scored by the phase-aligned NMSE against that teacher's cycle; the largest penalty within 2× the best score".into(),
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

fn vcell(v: Verdict) -> String {
    verdict(v.passed).to_owned()
}

fn pts(y: &[f64], t0: f64, rate: f64) -> Vec<(f64, f64)> {
    y.iter().enumerate().map(|(k, v)| (t0 + k as f64 / rate, *v)).collect()
}

/// E1–E3.
pub fn stability(md: &mut Md, rs: &[&StabilityResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let Some(first) = rs.first() else { return Ok(()) };
    md.line(format!("## {}", section_heading(&first.header, "Fig. 2")));
    md.blank();
    for r in rs {
        md.line(protocol_line(&r.header));
        md.blank();
    }
    let cy = first.header.cycles.first();
    if let Some(c) = cy {
        md.line(format!(
            "Teacher: one seamless cycle of {} (`{}`): {} frames from frame {}, seam {:.3} σ beyond a typical step; the period found by autocorrelation is {:.2} frames.",
            c.label, first.channel, c.loop_len, c.loop_start, c.seam_excess, c.period_frames
        ));
        md.blank();
    }
    for r in rs {
        md.line(format!("![Figure 2, {}]({}.png)", protocol_name(&r.header), stem("fig2", &r.header)));
        md.blank();
    }
    let cols: Vec<String> = rs.iter().map(|r| protocol_name(&r.header)).collect();
    let mut head = vec!["claim and measure", "the paper"];
    head.extend(cols.iter().map(String::as_str));
    let row = |label: &str, paper: &str, f: &dyn Fn(&StabilityResult) -> String| -> Vec<String> {
        let mut v = vec![label.to_owned(), paper.to_owned()];
        v.extend(rs.iter().map(|r| f(r)));
        v
    };
    let n = first.seeds.len();
    let rows = vec![
        row(
            &format!("E1: NMSE of the first {} free-run samples, median over {n} seeds (range)", first.first_samples),
            "\"little difference\" (figure only)",
            &|r| {
                let (lo, hi) = span(r.seeds.iter().map(|s| s.first_nmse));
                format!("{:.4} ({lo:.4}–{hi:.4})", r.median_first_nmse())
            },
        ),
        row("E1 verdict", "", &|r| vcell(r.e1_verdict())),
        row(&format!("E2: seeds accurate after {:.0} s", first.long_run_s), "one run shown, \"stable\"", &|r| {
            format!("{} of {}", r.n_accurate(), r.seeds.len())
        }),
        row("E2: seeds converged (the rhythm no longer changes, accurate or not)", "—", &|r| {
            format!("{} of {}", r.n_converged(), r.seeds.len())
        }),
        row("E2 verdict", "", &|r| vcell(r.e2_verdict())),
        row("E3: seeds back on the teacher's orbit after the push; median time", "\"recovers well\"", &|r| {
            format!(
                "{} of {}; {}",
                r.n_recovered(),
                r.seeds.len(),
                secs(Some(median(r.seeds.iter().filter_map(|s| s.recovery.orbit_s).collect()))).replace("NaN s", "—")
            )
        }),
        row("E3: seeds back on the unperturbed twin (in phase); median time", "—", &|r| {
            let v: Vec<f64> = r.seeds.iter().filter_map(|s| s.recovery.twin_s).collect();
            format!(
                "{} of {}; {}",
                v.len(),
                r.seeds.len(),
                if v.is_empty() { "—".into() } else { secs(Some(median(v))) }
            )
        }),
        row("E3 verdict", "", &|r| vcell(r.e3_verdict())),
        row("chosen penalty, lowest – highest", "searched in 10^(1:−0.1:−8)", &|r| {
            let (lo, hi) = span(r.seeds.iter().map(|s| s.model.penalty));
            format!("{} – {}", pen(lo), pen(hi))
        }),
        row("warning: seeds whose penalty is at the grid's edge", "—", &|r| {
            format!("{} of {}", r.seeds.iter().filter(|s| s.model.penalty_at_edge).count(), r.seeds.len())
        }),
    ];
    md.table(&head, &"llrr".chars().take(2 + rs.len()).collect::<String>(), &rows);
    md.line(format!("Rules. E1: {}. E2: {}; a seed is {}. E3: {}; the push holds the fed-back output at the cycle's maximum + {} σ ({:.1} in the channel's units) for {} steps ({:.3} s) from {:.2} s. Distances, windows and times are defined once in `cpg_lab::measure`: RMS over quarter-period windows in teacher standard deviations, below 0.25 for a whole period of windows; the time is the start of the first such window after the release, so 0 s means at once.",
        first.e1_verdict().rule, first.e2_verdict().rule, cpg_lab::experiment::stability::RULE, first.e3_verdict().rule,
        first.push.above_max, first.push.held_units.first().copied().unwrap_or(f64::NAN), first.push.hold_steps, first.push.hold_s, first.push.at_s));
    md.blank();
    for r in rs {
        seeds_table(md, r);
        if let Some(dir) = dir {
            figure2(r, dir)?;
        }
    }
    Ok(())
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
                yes(st.accurate).into(),
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
    let c: Vec<String> = r.curve.iter().step_by(10).map(|(p, v)| format!("{}: {v:.3}", pen(*p))).collect();
    md.line(format!(
        "Validation curve of seed {} (every 10th penalty): {}.",
        r.seeds.first().map_or(0, |s| s.model.seed),
        c.join(", ")
    ));
    md.blank();
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
                title: format!("E1: free run from the trained state ({})", protocol_name(&r.header)),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "teacher", pts(&f.first_teacher, 0.0, rate)),
                    Curve::new(Look::Model, "model", pts(&f.first_model, 0.0, rate)),
                ],
            },
            Panel {
                title: format!("E2: after {:.0} s of free run, teacher at its best phase", f.end_start_s),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "teacher", pts(&f.end_teacher, f.end_start_s, rate)),
                    Curve::new(Look::Model, "model", pts(&f.end_model, f.end_start_s, rate)),
                ],
            },
            Panel {
                title: format!(
                    "E3: output held at {held:.1} {units} for {:.0} ms after {:.0} s",
                    1000.0 * r.push.hold_s,
                    hold_t0
                ),
                x_label: "time (s)".into(),
                y_label: format!("{} ({units})", r.channel),
                curves: vec![
                    Curve::new(Look::Teacher, "unperturbed twin", pts(&f.free, 0.0, rate)),
                    Curve::new(Look::Model, "pushed run", pts(&f.pushed, 0.0, rate)),
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
    for r in rs {
        md.line(protocol_line(&r.header));
        md.blank();
    }
    md.line(format!("Both are trained on the femur cycle replayed at a rate u(t) that drifts smoothly in [1, 6] (the configuration's `[data.tempo]`). Test: u held at {} for {} s each with {}-s cosine ramps between; each plateau is judged over its second half against the cycle played u times as fast. The teacher's frequency at u = 1 is f0 = {:.3} Hz.",
        first.plateaus.iter().map(|u| format!("{u}")).collect::<Vec<_>>().join(", "), first.hold_s, first.ramp_s, first.f0_hz));
    md.blank();
    for r in rs {
        md.line(format!("![Figure 3, {}]({}.png)", protocol_name(&r.header), stem("fig3", &r.header)));
        md.blank();
    }
    let mut head = vec!["claim and measure".to_owned(), "the paper".to_owned()];
    head.extend(rs.iter().map(|r| protocol_name(&r.header)));
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    let mut rows = vec![{
        let mut v = vec![
            "seeds passing every plateau".into(),
            "up to 6× (\"maximal increase of frequency by six times\")".into(),
        ];
        v.extend(rs.iter().map(|r| format!("{} of {}", r.n_passed(), r.seeds.len())));
        v
    }];
    rows.push({
        let mut v = vec!["verdict".into(), String::new()];
        v.extend(rs.iter().map(|r| vcell(r.verdict())));
        v
    });
    for (k, &u) in first.plateaus.iter().enumerate() {
        let mut v = vec![
            format!("u = {u}: frequency / (u·f0), median (range); amplitude / teacher, median"),
            if k == 0 { "a smooth change of frequency (figure)".into() } else { String::new() },
        ];
        v.extend(rs.iter().map(|r| {
            let fr: Vec<f64> = r
                .seeds
                .iter()
                .map(|s| s.plateaus[k].measured_hz.map_or(0.0, |h| h / s.plateaus[k].target_hz))
                .collect();
            let (lo, hi) = span(fr.iter().copied());
            let am = median(r.seeds.iter().map(|s| s.plateaus[k].amplitude_ratio).collect());
            format!("{:.3} ({lo:.3}–{hi:.3}); {am:.2}", median(fr))
        }));
        rows.push(v);
    }
    md.table(&head, &"llrr".chars().take(2 + rs.len()).collect::<String>(), &rows);
    md.line(format!(
        "Rule: {}. A plateau's frequency is 0 in the table when the output decayed or showed no rhythm.",
        first.verdict().rule
    ));
    md.blank();
    // The paper's own test schedule (Fig. 3), judged on its held stretches.
    let n_windows = first.seeds.first().map_or(0, |s| s.figure.len());
    if n_windows > 0 {
        md.line("The paper's Fig. 3 schedule (u from high to low and back), judged on the second half of each stretch where u is held, by the same rule:");
        md.blank();
        let mut head = vec!["held stretch".to_owned()];
        head.extend(rs.iter().map(|r| {
            format!("{}: seeds passing; frequency / (u·f0), amplitude ratio (medians)", protocol_name(&r.header))
        }));
        let head: Vec<&str> = head.iter().map(String::as_str).collect();
        let rows: Vec<Vec<String>> = (0..n_windows)
            .map(|k| {
                let w = &first.seeds[0].figure[k];
                let mut v = vec![format!("u = {} from {:.1} to {:.1} s", w.u, w.window_s[0], w.window_s[1])];
                v.extend(rs.iter().map(|r| {
                    let ok = r.seeds.iter().filter(|s| s.figure.get(k).is_some_and(|p| p.passed)).count();
                    let fr = median(
                        r.seeds
                            .iter()
                            .filter_map(|s| s.figure.get(k))
                            .map(|p| p.measured_hz.map_or(0.0, |h| h / p.target_hz))
                            .collect(),
                    );
                    let am =
                        median(r.seeds.iter().filter_map(|s| s.figure.get(k)).map(|p| p.amplitude_ratio).collect());
                    format!("{ok} of {}; {fr:.3}, {am:.2}", r.seeds.len())
                }));
                v
            })
            .collect();
        md.table(&head, &format!("l{}", "r".repeat(rs.len())), &rows);
    }
    for r in rs {
        let rows: Vec<Vec<String>> = r
            .seeds
            .iter()
            .map(|s| {
                let mut v = vec![s.model.seed.to_string(), pen(s.model.penalty)];
                v.extend(s.plateaus.iter().map(|p| {
                    format!(
                        "{} / {:.2}{}",
                        p.measured_hz.map_or("—".into(), |h| format!("{h:.2}")),
                        p.amplitude_ratio,
                        if p.passed { "" } else { " ✗" }
                    )
                }));
                v.push(yes(s.passed).into());
                v
            })
            .collect();
        let plateau_heads: Vec<String> =
            r.plateaus.iter().map(|u| format!("u = {u} ({:.2} Hz)", u * r.f0_hz)).collect();
        let mut head = vec!["seed", "penalty"];
        head.extend(plateau_heads.iter().map(String::as_str));
        head.push("passed");
        md.line(format!(
            "Per seed, {}: measured frequency (Hz) / amplitude ratio at each plateau (✗: outside the tolerances):",
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

fn figure3(r: &FrequencyResult, dir: &Path) -> anyhow::Result<()> {
    let f = &r.fig3;
    let rate = 120.0;
    save(
        &dir.join(stem("fig3", &r.header)),
        &[
            Panel {
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
    for r in rs {
        md.line(protocol_line(&r.header));
        md.blank();
    }
    let teachers: Vec<String> = first
        .header
        .cycles
        .iter()
        .map(|c| {
            format!(
                "{}: period {:.1} frames (from {}), loop of {} frames, seam {:.3} σ",
                c.label, c.period_frames, c.period_channel, c.loop_len, c.seam_excess
            )
        })
        .collect();
    md.line(format!("Teachers: {}. Test: the first gait, a smooth switch (a {}-s cosine ramp of the controls) at {} s, back at {} s, until {} s; the same with abrupt switches.", teachers.join("; "), first.ramp_s, first.switch_at_s[0], first.switch_at_s[1], first.run_s));
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
    let mut head = vec!["claim and measure".to_owned(), "the paper".to_owned()];
    head.extend(rs.iter().map(|r| protocol_name(&r.header)));
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    let med = |r: &GaitsResult, f: &dyn Fn(&cpg_lab::experiment::gaits::GaitsSeed) -> f64| {
        median(r.seeds.iter().map(f).collect())
    };
    let row = |a: &str, b: &str, f: &dyn Fn(&GaitsResult) -> String| -> Vec<String> {
        let mut v = vec![a.to_owned(), b.to_owned()];
        v.extend(rs.iter().map(|r| f(r)));
        v
    };
    let rows = vec![
        row("seeds passing", "smooth transitions both ways", &|r| format!("{} of {}", r.n_passed(), r.seeds.len())),
        row("verdict", "", &|r| vcell(r.verdict())),
        row("first gait: period / teacher's, median", "correct gait", &|r| {
            format!("{:.3}", med(r, &|s| s.first.period_steps.map_or(0.0, |p| p / s.first.teacher_period_steps)))
        }),
        row("second gait: period / teacher's, median", "\"transition from walking to running\"", &|r| {
            format!("{:.3}", med(r, &|s| s.second.period_steps.map_or(0.0, |p| p / s.second.teacher_period_steps)))
        }),
        row("first gait again: period / teacher's, median", "\"transition from running to walking\"", &|r| {
            format!(
                "{:.3}",
                med(r, &|s| s.first_again.period_steps.map_or(0.0, |p| p / s.first_again.teacher_period_steps))
            )
        }),
        row("settling after switch 1 / switch 2, median (seeds that settle)", "—", &|r| {
            let a: Vec<f64> = r.seeds.iter().filter_map(|s| s.settle_s[0]).collect();
            let b: Vec<f64> = r.seeds.iter().filter_map(|s| s.settle_s[1]).collect();
            format!(
                "{} ({}) / {} ({})",
                secs((!a.is_empty()).then(|| median(a.clone()))),
                a.len(),
                secs((!b.is_empty()).then(|| median(b.clone()))),
                b.len()
            )
        }),
        row("largest step after a smooth switch, median (data's largest)", "\"smooth\"", &|r| {
            format!("{:.3} ({:.3}) z", med(r, &|s| s.max_jump_smooth), r.data_step)
        }),
        row("largest step after an abrupt switch, median", "\"large amplitude spikes\"", &|r| {
            format!("{:.3} z", med(r, &|s| s.max_jump_abrupt))
        }),
    ];
    md.table(&head, &"llrr".chars().take(2 + rs.len()).collect::<String>(), &rows);
    md.line(format!("Rule: {}.", first.verdict().rule));
    md.blank();
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
                    yes(s.passed).into(),
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

fn figure4(r: &GaitsResult, dir: &Path) -> anyhow::Result<()> {
    let f = &r.fig4;
    let rate = 120.0;
    let mut panels: Vec<Panel> = f
        .teachers
        .iter()
        .map(|(label, y)| Panel {
            title: format!("{label}, the training cycle"),
            x_label: "time (s)".into(),
            y_label: "left femur (z)".into(),
            curves: vec![Curve::new(Look::Teacher, "teacher", pts(y, 0.0, rate))],
        })
        .collect();
    panels.push(Panel {
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
    for r in rs {
        md.line(protocol_line(&r.header));
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
    md.line(format!("{} channels, one seamless cycle of {} frames repeated; free run of {} steps ({:.0} s). A joint's **lag** is how far it trails `{}`, in cycles, from the peak of their cross-correlation (teacher: over its repeated cycle; model: over its last 10 s). Its **deviation** is the model's phase relation minus the teacher's, from aligning the joint's own teacher cycle to three cycles of the first and of the last 10 s: 0 is exactly the teacher's lag. The verdict uses the deviation: a joint with two similar peaks a cycle (the feet) can move its cross-correlation peak from one to the other without any change of phase. One frame is 1/{} of a cycle ({:.4}), the resolution of these columns. Portraits: data (the whole trial) light gray, model black (10 s from {:.0} s on).",
        first.rows.len(), first.period_frames, first.steps, first.run_s, first.reference, first.period_frames, 1.0 / first.period_frames as f64, first.portrait_from_s));
    md.blank();
    let mut head = vec!["claim and measure".to_owned(), "the paper".to_owned()];
    head.extend(rs.iter().map(|r| protocol_name(&r.header)));
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    let row = |a: &str, b: &str, f: &dyn Fn(&CouplingResult) -> String| -> Vec<String> {
        let mut v = vec![a.to_owned(), b.to_owned()];
        v.extend(rs.iter().map(|r| f(r)));
        v
    };
    let spread = |v: Vec<f64>, digits: usize| -> String {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let med = median(v.clone());
        format!("{med:.digits$} ({lo:.digits$}–{hi:.digits$})")
    };
    let rows = vec![
        row("seeds keeping every joint's drift below 0.05 cycle", "one run shown (Fig. 5)", &|r| {
            format!("{} of {}", r.n_passed(), r.seeds.len())
        }),
        row(
            "largest drift of a joint's deviation over the run (cycles): median of the seeds (range)",
            "\"tight phase coupling\", \"phase relation remains intact\"",
            &|r| spread(r.seeds.iter().map(|s| s.worst_drift).collect(), 3),
        ),
        row("verdict", "", &|r| vcell(r.verdict())),
        row(
            "median per-joint NMSE of the last cycle, best phase: median of the seeds (range)",
            "\"learn only the desired rhythmic patterns\"",
            &|r| spread(r.seeds.iter().map(|s| s.median_cycle_nmse).collect(), 4),
        ),
        row("chosen penalty, first seed", "—", &|r| pen(r.model.penalty)),
    ];
    md.table(&head, &"llrr".chars().take(2 + rs.len()).collect::<String>(), &rows);
    md.line(format!("Rule: {}.", first.verdict().rule));
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
                    if s.passed { "yes".into() } else { "no".into() },
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
                    format!("{:+.3}", j.deviation_start),
                    format!("{:+.3}", j.deviation_end),
                    format!("{:+.3}", j.drift),
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
                "deviation, first 10 s",
                "deviation, last 10 s",
                "drift",
                "NMSE of the last cycle",
            ],
            "lrrrrrr",
            &rows,
        );
        let panels: Vec<Panel> = r
            .portraits
            .iter()
            .map(|p| Panel {
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

/// The HOAP-2 section from E6 runs that mapped their output onto the robot.
pub fn hoap2(md: &mut Md, rs: &[&CouplingResult], dir: Option<&Path>) -> anyhow::Result<()> {
    let mapped: Vec<&&CouplingResult> = rs.iter().filter(|r| r.hoap2.is_some()).collect();
    if mapped.is_empty() {
        return Ok(());
    }
    md.line("## HOAP-2 joint commands");
    md.blank();
    for r in mapped {
        let Some(h) = &r.hoap2 else { continue };
        let s = stem("e6_hoap2", &r.header);
        if let Some(dir) = dir {
            std::fs::write(dir.join(format!("{s}_120hz.csv")), h.trajectory.to_csv())?;
            std::fs::write(dir.join(format!("{s}_1khz.csv")), h.trajectory_1khz.to_csv())?;
            std::fs::write(dir.join(format!("{s}_1khz.json")), h.trajectory_1khz.to_ros_json())?;
        }
        md.line(format!(
            "The last 10 s of E6 ({}) mapped by the configuration's channel map onto the joints of the URDF, resampled by a natural cubic spline and kept within every joint's position range, its URDF velocity limit ({} rad/s) and an acceleration bound of {} rad/s² (ours: the HOAP-2 documents give none): `{s}_120hz.csv`, `{s}_1khz.csv` (time_s, then every joint's angle in rad, velocity in rad/s and acceleration in rad/s²) and `{s}_1khz.json` (a trajectory_msgs/JointTrajectory).",
            protocol_name(&r.header),
            h.velocity_limit_rad_s,
            h.acceleration_bound_rad_s2
        ));
        md.blank();
        md.line(format!(
            "At 1 kHz the fastest commanded joint speed is {:.2} rad/s and the largest acceleration {:.1} rad/s²; {} commanded angle(s) lie outside their joint's range. Within every limit: {}.",
            h.max_speed_rad_s,
            h.max_acceleration_rad_s2,
            h.n_outside_range,
            if h.n_outside_range == 0
                && h.max_speed_rad_s <= h.velocity_limit_rad_s + 1e-9
                && h.max_acceleration_rad_s2 <= h.acceleration_bound_rad_s2 + 1e-6
            {
                "yes"
            } else {
                "no"
            }
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
            md.blank();
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

//! The comparison of generator families (Vakulenko et al. 2017 beside the reservoir).

use cpg_compare::fit::Spec;
use cpg_compare::measures::Errors;

use super::{FamiliesResult, NonSegmented, SegTable};
use crate::experiment::doc::*;

fn errs(e: &Errors) -> String {
    format!("{:.1} | {:.4} | {:.4} | {:.1}", e.mean_mm, e.rel_l1, e.rel_l2, e.err_abs_mm)
}

fn spec(s: Spec) -> String {
    format!("{} center{} / {} satellites", s.centers, if s.centers > 1 { "s" } else { "" }, s.satellites)
}

const HEADING: &str = FamiliesResult::HEADING;

/// The whole section.
/// The whole section.
pub fn section(s: &mut Section, r: &FamiliesResult, ctx: &Context) {
    s.line(format!("## {HEADING}"));
    s.blank();
    s.line("Only the headings, captions and Table 1 of the paper survive; the method is reconstructed in `shared/research/methods.md` §1 and every inferred choice is marked in the docs of `cpg-centralized` and `cpg-compare`. All three families run through one step interface (`cpg_compare::PatternGenerator`), are scored by the same error functions and are pushed by the same protocol as E3 (`cpg_lab::measure`). Configuration: `experiments/families.toml`.");
    s.blank();
    s.line("**Positions.** Forward kinematics of the skeleton: the root and the 30 bone end points (31 \"markers\"), 93 coordinates in mm, at 120 Hz. **Measures (our definitions; the paper's formulas are not readable).** *Mean 3-D error*: the Euclidean distance between model and data, averaged over the 31 points and all frames (mm, Figures 15–16). *Relative integral error* (Table 1's \"integral relative accuracy\"): per coordinate Σ|x − x̂| / Σ|x − x̄| with x̄ the coordinate's mean over the window, averaged over the coordinates (L1); the L2 variant uses root sums of squares. *ErrABS*: per coordinate the mean |x − x̂| in mm, averaged over the coordinates.");
    s.blank();
    let ns = &r.non_segmented;
    let ctl: Vec<String> = ns.control.iter().map(|(p, a)| format!("{p} {}", ["x", "y", "z"][*a])).collect();
    s.line(format!("**Centralized recipe.** Phase centers φ = ω·t; RBF satellites on the torus with b = √(N^(1/M)); satellite centres on a grid when N is a perfect M-th power, else at the phases of N equally spaced frames; frequencies searched on {} over {} values from 0.05 to 2.5 Hz for one or two centers ({} for three), refined by golden section, then transferred to all 93 coordinates, which share one least-squares solve. **AICc**: n = frames (per coordinate), RSS = the residual sum of squares averaged over the 93 coordinates, k = N + 1 + M. **DMP**: pydmps 0.2 semantics (`cpg-dmp` matches pydmps to 1e-9 on a fixture made by `scripts/pydmps_reference.sh`), 100 basis functions, one DMP per coordinate; the window given to the DMP is one period (methods.md §1.10).", ctl.join(", "), ns.grid_sizes.0, ns.grid_sizes.1));
    s.blank();
    non_segmented(s, r);
    segmented(s, &r.segmented, "fig_c4_segments", "Segmented: walk, run, walk, run");
    s.line("### The paper's data: CMU 86_01, Table 1");
    s.blank();
    match &r.paper {
        Some(t) => segmented(s, t, "fig_c5_table1_86_01", "Table 1 on 86_01 (ours, the paper's in brackets)"),
        None => {
            s.line(format!("`{}` is not on this machine: `cargo xtask fetch-data` did not find it in the shared data folder and could not download it, so the paper's Table 1 setup did not run and `fig_c5` was not drawn. Put the file there and rerun; the same code path (`cpg_compare::fit::table1` with the paper's boundaries) runs above on the subject-35 sequence and in a test on a stand-in. The paper's numbers, for reference:", ctx.path(&r.paper_trial)));
            s.blank();
            let rows: Vec<Vec<String>> = cpg_compare::fit::TABLE1_SPECS
                .iter()
                .zip(cpg_compare::fit::TABLE1_PAPER.iter())
                .map(|(s, p)| {
                    vec![
                        format!("{} / {}", s.centers, s.satellites),
                        p[0].to_string(),
                        p[1].to_string(),
                        p[2].to_string(),
                        p[3].to_string(),
                    ]
                })
                .collect();
            s.table(&["centers / satellites", "seg 1", "seg 2", "seg 3", "seg 4"], "lrrrr", &rows);
        }
    }
    generalisation(s, r);
    perturbation(s, r);
    strengths(s, r);
}

fn non_segmented(s: &mut Section, r: &FamiliesResult) {
    let ns = &r.non_segmented;
    s.line(format!(
        "### Non-segmented: one walking trial ({}, {} frames, {:.1} s)",
        ns.trial,
        ns.frames,
        ns.frames as f64 / 120.0
    ));
    s.blank();
    let paper_sizes = [16usize, 25, 49, 100];
    let mut rows: Vec<Vec<String>> = ns
        .rows
        .iter()
        .filter(|f| paper_sizes.contains(&f.spec.satellites))
        .map(|f| {
            let hz: Vec<String> = f.frequencies_hz.iter().map(|h| format!("{h:.3}")).collect();
            vec![
                spec(f.spec),
                errs(&f.errors),
                format!("{:.1}", f.legs.mean_mm),
                format!("{:.0}", f.aicc),
                hz.join(", "),
            ]
        })
        .collect();
    rows.push(vec![
        "DMP, 100 basis functions (the trial as one period)".into(),
        errs(&ns.dmp.0),
        format!("{:.1}", ns.dmp.1.mean_mm),
        "—".into(),
        "—".into(),
    ]);
    rows.push(vec![format!("reservoir CPG (E6 model: 22 joint angles; root and the other 40 channels from the data; phase-aligned, offset {} frames)", ns.reservoir.2), errs(&ns.reservoir.0), format!("{:.1}", ns.reservoir.1.mean_mm), "—".into(), "—".into()]);
    s.table(
        &[
            "model",
            "mean 3-D error (mm)",
            "relative integral error (L1)",
            "(L2)",
            "ErrABS (mm)",
            "mean 3-D error of the 6 leg points (mm)",
            "AICc",
            "frequencies (Hz)",
        ],
        "lrrrrrrl",
        &rows,
    );
    let sm = &r.summary;
    let per: Vec<String> = sm
        .aicc_per_centers
        .iter()
        .map(|(m, f, a)| format!("{m} → N = {} (AICc {a:.0}, {:.1} mm)", f.spec.satellites, f.mean_mm))
        .collect();
    s.line(format!(
        "AICc over N ∈ {{{}}} picks {} overall{}; per number of centers: {}.",
        sm.sizes.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", "),
        spec(ns.aicc_best),
        if sm.aicc_at_edge {
            " (the grid's largest N: AICc still falls there, so its minimum may lie beyond)"
        } else {
            ""
        },
        per.join("; ")
    ));
    s.blank();
    figures(s, ns);
    s.line("![model against data per coordinate](fig_c1_coordinates.png)");
    s.blank();
    s.line("![left ankle trajectory](fig_c2_trajectory.png)");
    s.blank();
    s.line("![AICc](fig_c3_aicc.png)");
    s.blank();
}

/// Figures c1–c3: coordinates against the data, the left ankle's path, AICc.
fn figures(s: &mut Section, ns: &NonSegmented) {
    let d = ns.names.len() * 3;
    let (x, y_dmp, y2) = &ns.traces;
    let idx = |n: &str, c: usize| ns.names.iter().position(|a| a == n).map(|p| 3 * p + c);
    let coords = [
        ("root forward (z)", "root", 2),
        ("root height (y)", "root", 1),
        ("left ankle height (ltibia y)", "ltibia", 1),
        ("right ankle height (rtibia y)", "rtibia", 1),
        ("left wrist sideways (lwrist x)", "lwrist", 0),
        ("head height (head y)", "head", 1),
    ];
    let col = |y: &[f64], c: usize| -> Vec<(f64, f64)> {
        y.chunks_exact(d).enumerate().map(|(k, f)| (k as f64 / 120.0, f[c])).collect()
    };
    let panels: Vec<Panel> = coords
        .iter()
        .filter_map(|(label, p, c)| idx(p, *c).map(|i| (label, i)))
        .map(|(label, i)| Panel {
            equal_axes: false,
            title: label.to_string(),
            x_label: "time (s)".into(),
            y_label: "position (mm)".into(),
            curves: vec![
                Curve::new(Look::Teacher, "data", col(x, i)),
                Curve::new(Look::Data, "DMP", col(y_dmp, i)),
                Curve::new(Look::Model, "2 centers / 49 satellites", col(y2, i)),
            ],
        })
        .collect();
    s.figure("fig_c1_coordinates", panels, 3, (1400, 800));
    if let Some(a) = idx("ltibia", 0) {
        let proj = |y: &[f64], u: usize, v: usize| -> Vec<(f64, f64)> {
            y.chunks_exact(d).map(|f| (f[a + u], f[a + v])).collect()
        };
        s.figure(
            "fig_c2_trajectory",
            vec![
                Panel {
                    equal_axes: true,
                    title: format!("left ankle of {} seen from above (equal scales)", ns.trial),
                    x_label: "x (mm)".into(),
                    y_label: "z, walking direction (mm)".into(),
                    curves: vec![
                        Curve::new(Look::Teacher, "data", proj(x, 0, 2)),
                        Curve::new(Look::Model, "2 centers / 49 satellites", proj(y2, 0, 2)),
                    ],
                },
                Panel {
                    equal_axes: true,
                    title: format!("left ankle of {} seen from the side (equal scales)", ns.trial),
                    x_label: "z, walking direction (mm)".into(),
                    y_label: "height y (mm)".into(),
                    curves: vec![
                        Curve::new(Look::Teacher, "data", proj(x, 2, 1)),
                        Curve::new(Look::Model, "2 centers / 49 satellites", proj(y2, 2, 1)),
                    ],
                },
            ],
            2,
            (1300, 560),
        );
    }
    let curve = |m: usize, look: Look, f: &dyn Fn(&crate::experiment::families::FitRow) -> f64| {
        Curve::new(
            look,
            format!("{m} center{}", if m > 1 { "s" } else { "" }),
            ns.rows.iter().filter(|r| r.spec.centers == m).map(|r| (r.spec.satellites as f64, f(r))).collect(),
        )
    };
    s.figure(
        "fig_c3_aicc",
        vec![
            Panel {
                equal_axes: false,
                title: "AICc".into(),
                x_label: "satellites N".into(),
                y_label: "AICc".into(),
                curves: vec![
                    curve(1, Look::Teacher, &|r| r.aicc),
                    curve(2, Look::Model, &|r| r.aicc),
                    curve(3, Look::Data, &|r| r.aicc),
                ],
            },
            Panel {
                equal_axes: false,
                title: "mean 3-D error".into(),
                x_label: "satellites N".into(),
                y_label: "error (mm)".into(),
                curves: vec![
                    curve(1, Look::Teacher, &|r| r.errors.mean_mm),
                    curve(2, Look::Model, &|r| r.errors.mean_mm),
                    curve(3, Look::Data, &|r| r.errors.mean_mm),
                ],
            },
        ],
        2,
        (1300, 520),
    );
}

fn segmented(s: &mut Section, t: &SegTable, stem: &str, title: &str) {
    let frames = t.starts.last().copied().unwrap_or(0) - t.starts.first().copied().unwrap_or(0);
    s.line(format!("### {title} ({}, {frames} frames)", t.trials.join(" + ")));
    s.blank();
    if t.paper.is_none() {
        s.line(format!("The trials are glued into one sequence whose root path is continuous (each trial turned and moved to start where the previous one ended; the posture still changes at a join), split at the joins (frames {}), fitted per segment and glued by the switching module: a clock hub and one sigmoid window per segment, steepness β = {}/s.", t.starts.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", "), t.beta_per_s));
        s.blank();
    }
    let n = t.rows.first().map_or(0, |r| r.per_segment.len());
    let mut head: Vec<String> = vec!["centers / satellites".into()];
    head.extend((1..=n).map(|k| format!("seg {k}")));
    head.extend((1..=n).map(|k| format!("seg {k}, mm")));
    head.push("whole, mm".into());
    head.push("worst step at a boundary, mm".into());
    let rows: Vec<Vec<String>> = t
        .rows
        .iter()
        .enumerate()
        .map(|(k, r)| {
            let mut v = vec![format!("{} / {}", r.spec.centers, r.spec.satellites)];
            v.extend(r.per_segment.iter().enumerate().map(|(j, e)| {
                match t.paper.as_ref().and_then(|p| p.get(k)).and_then(|p| p.get(j)) {
                    Some(pv) => format!("{:.4} ({pv})", e.rel_l1),
                    None => format!("{:.4}", e.rel_l1),
                }
            }));
            v.extend(r.per_segment.iter().map(|e| format!("{:.1}", e.mean_mm)));
            v.push(format!("{:.1}", r.whole.mean_mm));
            v.push(format!("{:.1}", r.worst_jump_mm));
            v
        })
        .collect();
    let head_ref: Vec<&str> = head.iter().map(String::as_str).collect();
    s.table(&head_ref, &format!("l{}", "r".repeat(head.len() - 1)), &rows);
    let rows_jumps: Vec<String> = t.rows.iter().map(|r| format!("{:.1}", r.worst_jump_mm)).collect();
    s.line(format!("Continuity at the boundaries: the largest frame-to-frame movement of any point within ±10 frames of a boundary is {} mm for the glued output (row by row) against {:.1} mm in the data itself.", rows_jumps.join(", "), t.rows.first().map_or(0.0, |r| r.data_jump_mm)));
    s.blank();
    let panels: Vec<Panel> = (0..n)
        .map(|j| {
            let mut curves = vec![Curve::new(
                Look::Bars,
                "ours",
                t.rows.iter().enumerate().map(|(k, r)| ((k + 1) as f64, r.per_segment[j].rel_l1)).collect(),
            )];
            if let Some(p) = &t.paper {
                curves.push(Curve::new(
                    Look::Marks,
                    "paper",
                    p.iter().enumerate().map(|(k, v)| ((k + 1) as f64, v[j])).collect(),
                ));
            }
            Panel {
                equal_axes: false,
                title: format!(
                    "segment {} ({})",
                    j + 1,
                    t.rows
                        .iter()
                        .enumerate()
                        .map(|(k, r)| format!("{}={}/{}", k + 1, r.spec.centers, r.spec.satellites))
                        .collect::<Vec<_>>()
                        .join(" ")
                ),
                x_label: "model".into(),
                y_label: "relative integral error".into(),
                curves,
            }
        })
        .chain((0..n).map(|j| Panel {
            equal_axes: false,
            title: format!("segment {}: mean 3-D error", j + 1),
            x_label: "model".into(),
            y_label: "error (mm)".into(),
            curves: vec![Curve::new(
                Look::Bars,
                "ours",
                t.rows.iter().enumerate().map(|(k, r)| ((k + 1) as f64, r.per_segment[j].mean_mm)).collect(),
            )],
        }))
        .collect();
    s.figure(stem, panels, n.max(1), (1500, 700));
    s.line(format!("![{title}]({stem}.png)"));
    s.blank();
}

fn generalisation(s: &mut Section, r: &FamiliesResult) {
    let g = &r.generalisation;
    s.line(format!(
        "### Generalisation: fitted on {}, compared with another walk, {} (not in the paper)",
        g.fitted_trial, g.other_trial
    ));
    s.blank();
    s.line(format!("Body-frame positions (the root's six channels set to zero, so the two trials share place and heading). Each model runs freely; the start offset (up to one gait cycle, {} frames) that best matches the trial is chosen, which aligns the phase. The cycle the one-cycle models learn is the gait cycle with the smallest seam in {}'s body-frame positions (frames {}–{}); E6's reservoir learnt its own loop, cut from the joint angles, so the two need not start on the same frame.", g.cycle.1, g.fitted_trial, g.cycle.0, g.cycle.0 + g.cycle.1));
    s.blank();
    let rows: Vec<Vec<String>> = g
        .rows
        .iter()
        .map(|x| {
            vec![
                x.model.clone(),
                format!("{:.1}", x.fitted.mean_mm),
                format!("{:.1}", x.other.mean_mm),
                format!("{:.3}", x.other.rel_l1),
                format!("{:.1}", x.other_legs.mean_mm),
            ]
        })
        .collect();
    s.table(
        &[
            "model",
            &format!("on {} (fitted), mean 3-D error (mm)", g.fitted_trial),
            &format!("on {}, mean 3-D error (mm)", g.other_trial),
            "relative integral error",
            "leg points (mm)",
        ],
        "lrrrr",
        &rows,
    );
}

fn perturbation(s: &mut Section, r: &FamiliesResult) {
    let p = &r.perturbation;
    s.line("### Perturbation: what each family does when its output is held away (E3's protocol)");
    s.blank();
    let gait_hz = 120.0 / p.period_frames as f64;
    s.line(format!("Every family learns the left-femur cycle of E1 ({} frames); the centralized network and the DMP from the same cycle the reservoir repeats (the search puts the center at {:.3} Hz, {:.2} × the gait frequency). From step {} the output is held at {:.1}° (the cycle's maximum + 2 σ) for {} steps. *Back on the orbit* and *back on the twin* are E3's measures (`cpg_lab::measure`): windows of a quarter period, within 0.25 σ for a whole period of windows, timed from the release to the start of the first good window. *Phase shift*: lag behind the twin long after the release, in gait cycles.", p.period_frames, p.center_hz, p.center_hz / gait_hz, p.at, p.held, p.hold));
    s.blank();
    let mut rows: Vec<Vec<String>> = p
        .rows
        .iter()
        .map(|x| {
            vec![
                x.generator.clone(),
                secs(x.recovery.orbit_s),
                secs(x.recovery.twin_s),
                format!("{:+.3}", x.recovery.phase_shift_cycles),
                x.mechanism.clone(),
            ]
        })
        .collect();
    let k = &p.kick;
    rows.push(vec![
        format!("{} (instead of the hold)", k.generator),
        secs(k.recovery.orbit_s),
        secs(k.recovery.twin_s),
        format!("{:+.3}", k.recovery.phase_shift_cycles),
        k.mechanism.clone(),
    ]);
    s.table(
        &["generator", "back on the orbit", "back on the twin", "phase shift (cycles)", "what moves the rhythm"],
        "lrrrl",
        &rows,
    );
    let trace = |v: &[f64]| -> Vec<(f64, f64)> {
        v.iter().enumerate().skip(120).take(480).map(|(k, y)| (k as f64 / 120.0, *y)).collect()
    };
    let held = p.held;
    let (t0, t1) = (p.at as f64 / 120.0, (p.at + p.hold) as f64 / 120.0);
    let panels: Vec<Panel> = p
        .rows
        .iter()
        .map(|x| Panel {
            equal_axes: false,
            title: x.generator.clone(),
            x_label: "time (s)".into(),
            y_label: format!("{} (deg)", p.channel),
            curves: vec![
                Curve::new(Look::Teacher, "unperturbed twin", trace(&x.traces.1)),
                Curve::new(Look::Model, "held run", trace(&x.traces.0)),
                Curve::new(Look::Held, "held value", vec![(t0, held), (t1, held)]),
            ],
        })
        .chain(std::iter::once(Panel {
            equal_axes: false,
            title: "Hopf center kicked".into(),
            x_label: "time (s)".into(),
            y_label: format!("{} (deg)", p.channel),
            curves: vec![
                Curve::new(Look::Teacher, "unperturbed twin", trace(&k.traces.1)),
                Curve::new(Look::Model, "kicked run", trace(&k.traces.0)),
            ],
        }))
        .collect();
    s.figure("fig_c6_perturbation", panels, 3, (1400, 700));
    s.line("![perturbations](fig_c6_perturbation.png)");
    s.blank();
}

fn strengths(s: &mut Section, r: &FamiliesResult) {
    let ns = &r.non_segmented;
    let sm = &r.summary;
    s.line("### Strengths and weaknesses, from the numbers above");
    s.blank();
    if let Some((best, smallest)) = sm.best_fit {
        s.line(format!("- **Fitting a recording.** The centralized network reproduces the trial it was fitted on to {:.1} mm ({}), against {:.1} mm with {} satellites. The DMP given the whole trial as one period reaches {:.1} mm. The reservoir, which learns one cycle of 22 joint angles and then runs freely, is at {:.1} mm once phase-aligned.",
            best.mean_mm, spec(best.spec), smallest.mean_mm, smallest.spec.satellites, ns.dmp.0.mean_mm, ns.reservoir.0.mean_mm));
    }
    let per: Vec<String> = sm.best_per_centers.iter().map(|(m, e)| format!("{e:.1} mm with {m}")).collect();
    s.line(format!("- **How many centers.** On the one walking trial the best error is {}; AICc picks {}{}. On the segmented walk/run sequence, closer to Table 1, the verdicts above compare 1 center with 2–3.", per.join(", "), spec(ns.aicc_best), if sm.aicc_at_edge { ", the grid's largest size: AICc still falls there" } else { "" }));
    if let Some(b) = sm.best_segmented {
        s.line(format!("- **Segments and switching.** Fitted segment by segment and glued, the sequence is reproduced to {:.1} mm ({}); the largest step near a boundary is {:.1} mm against {:.1} mm in the data.", b.mean_mm, spec(b.spec), sm.segmented_jumps_mm.0, sm.segmented_jumps_mm.1));
    }
    let g = &r.generalisation.rows;
    if let (Some(c), Some(last)) = (g.first(), g.last()) {
        let (lo, hi) = sm.generalisation_legs_mm;
        s.line(format!("- **Generalisation.** On another walk the centralized network fitted on a whole trial goes from {:.1} mm to {:.1} mm; the {} is at {:.1} mm there. On the leg points the models lie between {lo:.1} and {hi:.1} mm.", c.fitted.mean_mm, c.other.mean_mm, last.model, last.other.mean_mm));
    }
    let p = &r.perturbation;
    let res: Vec<String> = p
        .rows
        .iter()
        .filter(|x| x.generator.starts_with("reservoir"))
        .map(|x| {
            format!(
                "{}: back on the orbit {} with a {:+.3}-cycle phase shift",
                x.generator,
                secs(x.recovery.orbit_s),
                x.recovery.phase_shift_cycles
            )
        })
        .collect();
    let clock: Vec<String> = p
        .rows
        .iter()
        .filter(|x| !x.generator.starts_with("reservoir"))
        .map(|x| format!("{}: on its twin {}", x.generator, secs(x.recovery.twin_s)))
        .collect();
    s.line(format!("- **Perturbations.** Clock-driven families return in phase with their unperturbed twin ({}); the reservoir has its own dynamics, which the push moves ({}).", clock.join("; "), res.join("; ")));
    s.blank();
    s.line("### Verdicts and their rules");
    s.blank();
    for c in &r.claims {
        s.line(format!(
            "- **{}** ({}): {}. Rule: {}. The paper: {}",
            c.claim,
            crate::experiment::doc::verdict(&c.verdict),
            c.measured
                .iter()
                .map(|m| format!("{}: {}", m.label, crate::experiment::doc::value(&m.value)))
                .collect::<Vec<_>>()
                .join("; "),
            c.verdict.rule,
            crate::experiment::doc::sources(&c.sources)
        ));
    }
    s.blank();
}

//! The report's section of this experiment: every protocol side by side, built from the results alone.

use super::*;
use crate::experiment::doc::*;
use crate::experiment::pen;

/// E5.
pub fn gaits(s: &mut Section, rs: &[&GaitsResult], ctx: &Context) {
    let Some(first) = rs.first() else { return };
    opening(s, rs, ctx);
    for c in &first.header.cycles {
        s.line(teacher_line(c, &c.period_channel));
        s.blank();
    }
    s.line(format!("Test: the first gait, a smooth switch (a {}-s cosine ramp of the controls) at {} s, back at {} s, until {} s; the same with abrupt switches.", first.ramp_s, first.switch_at_s[0], first.switch_at_s[1], first.run_s));
    s.blank();
    figure_links(s, rs, "fig4");
    for r in rs {
        view(
            s,
            r.view.as_ref(),
            &stem("e5_view", &r.header),
            &protocol_name(&r.header),
            "the first seed's smooth switching run",
            None,
        );
    }
    claims_side_by_side(s, rs);
    all_switches(s, rs);
    s.line("![Every seed's smooth switching run, each configuration in its column; the gray bands are the ramps](fig4_seeds.png)");
    s.blank();
    validation_curves(s, rs, "fig_validation_e5");
    for r in rs {
        let g = |w: &crate::experiment::gaits::GaitWindow| {
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
        s.line(format!(
            "Per seed, {} (period / teacher's in frames, amplitude ratio; ✗: outside the tolerances):",
            protocol_name(&r.header)
        ));
        s.blank();
        s.table(
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
        figure4(s, r);
    }
}

fn all_switches(s: &mut Section, rs: &[&GaitsResult]) {
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
        return;
    }
    let cols = rs.len().max(1);
    s.figure("fig4_seeds", panels, cols, (520 * cols as u32, 170 * n_seeds as u32));
}

fn figure4(s: &mut Section, r: &GaitsResult) {
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
    s.figure(stem("fig4", &r.header), panels, 2, (1300, 800));
}

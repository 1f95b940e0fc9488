//! The report's section of this experiment: every protocol side by side, built from the results alone.

use super::*;
use crate::experiment::doc::*;
use crate::experiment::pen;

/// E1–E3.
pub fn stability(s: &mut Section, rs: &[&StabilityResult], ctx: &Context) {
    let Some(first) = rs.first() else { return };
    opening(s, rs, ctx);
    if let Some(c) = first.header.cycles.first() {
        s.line(teacher_line(c, &first.channel));
        s.blank();
    }
    figure_links(s, rs, "fig2");
    claims_side_by_side(s, rs);
    s.line(format!("Definitions. A seed is {}. The push holds the fed-back output at the cycle's maximum + {} σ ({:.1} in the channel's units) for {} steps ({:.3} s) from {:.2} s. Distances, windows and times are defined once in `cpg_lab::measure`: RMS over quarter-period windows in teacher standard deviations, below 0.25 from some window until the end of the run; the time is the start of that window after the release, so 0 s means at once.",
        crate::experiment::stability::RULE, first.push.above_max, first.push.held_units.first().copied().unwrap_or(f64::NAN), first.push.hold_steps, first.push.hold_s, first.push.at_s));
    s.blank();
    validation_curves(s, rs, "fig_validation_e1");
    for r in rs {
        seeds_table(s, r);
        figure2(s, r);
    }
}

fn seeds_table(s: &mut Section, r: &StabilityResult) {
    s.line(format!("Per seed, {} (teacher period {:.0} frames):", protocol_name(&r.header), r.teacher.cycle.len()));
    s.blank();
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
                secs(s.recovery.own_orbit_s),
                secs(s.recovery.orbit_s),
                secs(s.recovery.twin_s),
                format!("{:+.3}", s.recovery.phase_shift_cycles),
            ]
        })
        .collect();
    s.table(
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
            "back on its own orbit",
            "back on the teacher's orbit",
            "back on the twin",
            "phase shift (cycles)",
        ],
        "rrrrrrrllrrrr",
        &rows,
    );
}

fn figure2(s: &mut Section, r: &StabilityResult) {
    let f = &r.fig2;
    let rate = 120.0;
    let units = "deg";
    let hold_t0 = r.push.at_s;
    let held = r.push.held_units.first().copied().unwrap_or(f64::NAN);
    s.figure(
        stem("fig2", &r.header),
        vec![
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
    );
}

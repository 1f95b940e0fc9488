//! The report's section of this experiment: every protocol side by side, built from the results alone.

use super::*;
use crate::experiment::doc::*;
use crate::experiment::pen;

/// E4.
pub fn frequency(s: &mut Section, rs: &[&FrequencyResult], ctx: &Context) {
    let Some(first) = rs.first() else { return };
    opening(s, rs, ctx);
    s.line(format!("Every configuration is trained on the femur cycle replayed at a rate u(t) that drifts smoothly in [1, 6] (the configuration's `[data.tempo]`). Test: u held at {} for {} s each with {}-s cosine ramps between; each plateau is judged over its second half against the cycle played u times as fast. The teacher's frequency at u = 1 is f0 = {:.3} Hz. A plateau's frequency counts as 0 when the output decayed or showed no rhythm.",
        first.plateaus.iter().map(|u| format!("{u}")).collect::<Vec<_>>().join(", "), first.hold_s, first.ramp_s, first.f0_hz));
    s.blank();
    figure_links(s, rs, "fig3");
    claims_side_by_side(s, rs);
    frequency_against_u(s, rs);
    s.line("![Frequency against u: every seed at every plateau, each configuration in its panel; the line is u·f0](fig3_frequency.png)");
    s.blank();
    validation_curves(s, rs, "fig_validation_e4");
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
        s.line(format!(
            "Per seed, {}: measured frequency (Hz) / amplitude ratio at each plateau and held stretch (✗: outside the tolerances):",
            protocol_name(&r.header)
        ));
        s.blank();
        s.table(&head, &"r".repeat(head.len()), &rows);
        figure3(s, r);
    }
}

fn frequency_against_u(s: &mut Section, rs: &[&FrequencyResult]) {
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
    s.figure("fig3_frequency", panels, rs.len().min(3), (460 * rs.len().min(3) as u32, 420));
}

fn figure3(s: &mut Section, r: &FrequencyResult) {
    let f = &r.fig3;
    let rate = 120.0;
    s.figure(
        stem("fig3", &r.header),
        vec![
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
    );
}

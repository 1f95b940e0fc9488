//! The report's section of walking in physics, built from the results alone.

use super::{Row, WalkingResult};
use crate::experiment::doc::*;
use crate::stats::Spread;

/// Seconds of the flat run the report's page shows.
const VIEW_S: f64 = 30.0;

/// The gains as `name value` pairs.
fn gains(g: &serde_json::Value) -> String {
    match g.as_object() {
        Some(m) => m
            .iter()
            .map(|(k, v)| match v.as_f64() {
                Some(x) => format!("{k} {x:.3}"),
                None => format!("{k} {v}"),
            })
            .collect::<Vec<_>>()
            .join(", "),
        None => g.to_string(),
    }
}

/// `median (lo–hi)` of `v` with `digits` decimals (the value alone when all
/// are equal), or `—`.
fn spread(v: &[f64], digits: usize) -> String {
    if v.is_empty() {
        return "—".into();
    }
    let s = Spread::of(v);
    if s.n == 1 || s.min == s.max {
        format!("{:.*}", digits, s.median)
    } else {
        format!("{:.*} ({:.*}–{:.*})", digits, s.median, digits, s.min, digits, s.max)
    }
}

fn row_cells(r: &Row) -> Vec<String> {
    let abs: Vec<f64> = r.heading_deg.iter().map(|h| h.abs()).collect();
    vec![
        r.walker.clone(),
        r.condition.clone(),
        format!("{} of {}", r.upright.k, r.upright.n),
        spread(&r.upright_s, 1),
        spread(&r.forward_m, 2),
        spread(&abs, 1),
        spread(&r.speed_m_s, 3),
        spread(&r.speed_leg_lengths_s, 2),
        spread(&r.max_torque_nm, 2),
        spread(&r.cost_of_transport, 2),
        if r.pushes.n > 0 { format!("{} of {}", r.pushes.k, r.pushes.n) } else { "—".into() },
    ]
}

/// The whole section.
pub fn section(s: &mut Section, r: &WalkingResult, ctx: &Context) {
    let e = &r.eval;
    opening(s, &[r], ctx);
    s.line(format!(
        "The physical HOAP-2 (`assets/hoap2/hoap2.xml`, docs/hoap2-model.md) in MuJoCo at 1 kHz, {} s a run, from its standing pose. Walkers: the paper's protocol (a model's output copied joint by joint onto the robot) where it ran; the walk `cpg retarget` plans for the robot from subject 35 (`{}`) played open loop, without and with the balance feedback; and the CPG learnt from that walk (`{}`, one model per reservoir seed, {} seeds), stepped inside the loop from the tenth left touch-down on, without and with the feedback. Conditions: flat ground; a push of {} m/s over 0.1 s every {} s, the directions in turn; the tempo changed to ×{} half-way (the CPG's tempo input, over a {}-s cosine ramp). The feedback gains were found by `python -m cpg.sim_search` (Optuna) with a walking objective: {}.",
        e.seconds,
        ctx.path(&e.trajectory),
        ctx.path(&r.header.config),
        e.seeds.len(),
        e.push_mps,
        e.push_every_s,
        e.tempo,
        e.tempo_ramp_s,
        gains(&e.gains)
    ));
    if let Some(at) = e.seeds.iter().find_map(|x| x.cpg_feedback.stop.as_ref().and_then(|r| r.stop_at_s)) {
        s.blank();
        s.line(format!(
            "A fourth run tells each CPG to stop at {at:.0} s: its walk input u_walk falls to 0 over {} s (it was taught with 2-s blends and validated over 2-s ramps), and it should stand in its starting pose to the end.",
            e.stop_ramp_s
        ));
    }
    early_falls(s, r);
    s.blank();
    let rows: Vec<Vec<String>> = r.rows.iter().map(row_cells).collect();
    s.table(
        &[
            "walker",
            "condition",
            "upright to the end",
            "seconds upright",
            "forward (m)",
            "|heading| (°)",
            "speed (m/s)",
            "speed (leg lengths/s)",
            "largest torque (N·m)",
            "cost of transport",
            "pushes survived",
        ],
        "llrrrrrrrrr",
        &rows,
    );
    s.line("Each cell: the median over the runs (the range in brackets). Cost of transport: the servos' mechanical work over weight × distance.");
    s.blank();
    for c in &r.claims {
        s.line(format!(
            "- **{}** ({}): {}. Rule: {}.",
            c.claim,
            verdict(&c.verdict),
            c.measured.iter().map(|m| format!("{}: {}", m.label, value(&m.value))).collect::<Vec<_>>().join("; "),
            c.verdict.rule
        ));
    }
    s.blank();
    figures(s, r);
}

/// How many CPG runs fell before the CPG took over: they judge the planned start, not the CPG.
fn early_falls(s: &mut Section, r: &WalkingResult) {
    for (walker, pick) in [
        ("without feedback", (|x: &super::SeedRuns| &x.cpg) as fn(&super::SeedRuns) -> &super::Conditions),
        ("with feedback", |x: &super::SeedRuns| &x.cpg_feedback),
    ] {
        let runs: Vec<&super::SimRun> = r
            .eval
            .seeds
            .iter()
            .flat_map(|x| {
                let c = pick(x);
                [&c.flat, &c.pushes, &c.tempo].into_iter().chain(c.stop.as_ref())
            })
            .collect();
        let early: Vec<f64> = runs
            .iter()
            .filter(|x| x.fell && x.handover_s.is_some_and(|h| x.upright_s < h))
            .filter_map(|x| x.handover_s)
            .collect();
        if !early.is_empty() {
            s.blank();
            s.line(format!(
                "{} of the {} runs of the CPG {walker} fell before the CPG took over (at {} s, the tenth left touch-down of the planned start): those runs measure the start walk played open loop, not the CPG.",
                early.len(),
                runs.len(),
                spread(&early, 1)
            ));
        }
    }
}

/// The stretch of a run the gait diagram shows: 10 s of the CPG's own
/// walking, from its hand-over (a run with none: from the start), seconds.
pub fn gait_window(run: &super::SimRun) -> (f64, f64) {
    let from = run.handover_s.unwrap_or(0.0);
    (from, from + 10.0)
}

/// The first seed's recorded runs: the trunk's path from above and the soles' contacts.
fn figures(s: &mut Section, r: &WalkingResult) {
    let Some(first) = r.eval.seeds.first() else { return };
    let c = &first.cpg_feedback;
    let recorded: Vec<(&str, &super::SimRun)> = [("flat", &c.flat), ("pushes", &c.pushes), ("tempo change", &c.tempo)]
        .into_iter()
        .filter(|(_, run)| !run.trunk_path.is_empty())
        .collect();
    if recorded.is_empty() {
        return;
    }
    let paths: Vec<Curve> = recorded
        .iter()
        .enumerate()
        .map(|(k, (name, run))| {
            let look = [Look::Model, Look::Teacher, Look::Data][k % 3];
            Curve::new(look, *name, run.trunk_path.iter().map(|p| (p[1], p[2])).collect())
        })
        .collect();
    let flat = recorded[0].1;
    let (from, to) = gait_window(flat);
    let shown: Vec<&[f64; 3]> = flat.contacts_n.iter().filter(|p| (from..=to).contains(&p[0])).collect();
    let weight = shown.iter().map(|p| p[1] + p[2]).fold(0.0_f64, f64::max).max(1e-9);
    let contact = |k: usize| -> Vec<(f64, f64)> {
        shown.iter().map(|p| (p[0], p[k] / weight + if k == 1 { 1.2 } else { 0.0 })).collect()
    };
    s.figure(
        "fig_walking",
        vec![
            Panel {
                equal_axes: true,
                title: format!("the trunk's path from above, seed {} with feedback", first.seed),
                x_label: "x, forward (m)".into(),
                y_label: "y, left (m)".into(),
                curves: paths,
            },
            Panel {
                equal_axes: false,
                title: format!(
                    "gait diagram: the CPG's own strides, sole forces from {from:.1} to {to:.1} s of the flat run (left above, right below)"
                ),
                x_label: "time (s)".into(),
                y_label: "force / largest total".into(),
                curves: vec![
                    Curve::new(Look::Model, "left", contact(1)),
                    Curve::new(Look::Teacher, "right", contact(2)),
                ],
            },
        ],
        2,
        (1300, 520),
    );
    s.line(format!(
        "![The trunk's path from above and the gait diagram, seed {} with feedback](fig_walking.png)",
        first.seed
    ));
    s.blank();
    let title = format!("the HOAP-2 in MuJoCo on its CPG (seed {}, with feedback, flat ground)", first.seed);
    let scene = flat.scene(&title, Some(VIEW_S)).ok();
    view(s, scene.as_ref(), "walking_view", "the first seed with feedback", "the simulated body on flat ground", None);
}

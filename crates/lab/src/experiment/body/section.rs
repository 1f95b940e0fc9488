//! The report's section of the whole body, built from the results alone.

use super::*;
use crate::experiment::doc::*;
use crate::experiment::pen;

/// What one recurrent network was shown to hold before, as published (the
/// channels, units and motions of each; neither reports a long run's
/// stability, a standing state or trials held out of training).
const PUBLISHED: [[&str; 7]; 2] = [
    [
        "Sussillo & Abbott (2009, Neuron 63:544), FORCE learning",
        "95 joint angles (CMU)",
        "5,000",
        "walking and running, switched by constant inputs",
        "not reported",
        "not reported",
        "none",
    ],
    [
        "Jaeger (2014), conceptors",
        "61 (CMU)",
        "600 leaky units",
        "15 motions, morphed between",
        "not reported",
        "not reported",
        "none",
    ],
];

/// The whole body.
pub fn body(s: &mut Section, rs: &[&BodyResult], ctx: &Context) {
    let Some(r) = rs.first() else { return };
    opening(s, rs, ctx);
    let n = r.seeds.len();
    let t = &r.test;
    s.line(format!(
        "The generator learns {} channels ({}) and {} states ({}), selected by its control inputs. Each gait is judged against trials training never read:",
        r.channels.len(),
        r.channels.first().map_or(String::new(), |f| format!("{f} … {}", r.channels.last().unwrap_or(f))),
        r.teachers.len(),
        r.teachers.join(", ")
    ));
    s.blank();
    for g in &r.held_out {
        let periods: Vec<String> =
            g.trials.iter().map(|t| format!("{} ({:.1} frames)", t.label, t.period_frames)).collect();
        let pe = crate::stats::Spread::of(&g.pair_errors);
        s.line(format!(
            "- {}: {}; median period {:.1} frames; their spread (the RMS error of one trial's time-normalised cycle against another's, over every rotation and phase, at the best phase) {:.2}° (median of {} pairs; {:.2}–{:.2}°).",
            g.teacher,
            periods.join(", "),
            g.period_frames,
            g.spread,
            pe.n,
            pe.min,
            pe.max
        ));
    }
    s.blank();
    let sequence: Vec<&str> = t.sequence.iter().map(|&k| r.teachers.get(k).map_or("?", String::as_str)).collect();
    s.line(format!(
        "Test, for each of {n} seeds: each state's inputs held for a free run of {} s (standing judged over its last {} s, each gait over its last {WINDOW_S} s); and one free run through {} (each state held {} s, switches by {}-s cosine ramps of the inputs starting at {} s).",
        r.run_s,
        t.stand_s,
        sequence.join(" → "),
        t.stay_s,
        t.ramp_s,
        r.switch_at_s.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(", ")
    ));
    s.blank();
    s.line("What one recurrent network was shown to hold before, as published, beside this run:");
    s.blank();
    let mut rows: Vec<Vec<String>> = PUBLISHED.iter().map(|r| r.iter().map(|c| (*c).to_owned()).collect()).collect();
    for r in rs {
        let n = r.seeds.len();
        let all = |f: &dyn Fn(&BodySeed) -> bool| r.seeds.iter().filter(|s| f(s)).count();
        rows.push(vec![
            format!("this run, {} ({})", trainer(r), ctx.path(&r.header.config)),
            format!("{} of subject 35", r.channels.len()),
            r.header.n_neurons.to_string(),
            format!("{}, switched by two inputs", r.teachers.join(", ")),
            format!(
                "standing passes in {} of {n} seeds; gaits after {} s: every gait passes in {} of {n}",
                all(&|s| s.stand.passed),
                r.run_s,
                all(&|s| s.gaits.iter().all(|g| g.passed))
            ),
            format!("{} of {n} seeds pass every switch", all(&|s| s.switches.iter().all(|w| w.passed))),
            r.held_out
                .iter()
                .map(|g| format!("{}: {} trials", g.teacher, g.trials.len()))
                .collect::<Vec<_>>()
                .join("; "),
        ]);
    }
    s.table(
        &["network", "channels", "units", "motions", "long-run stability, standing", "switches", "trials held out"],
        "lllllll",
        &rows,
    );
    view(
        s,
        r.view.as_ref(),
        "whole_body_view",
        &protocol_name(&r.header),
        &format!(
            "the first seed's switching run ({}; switches at {} s)",
            sequence.join(" → "),
            r.switch_at_s.iter().map(|v| format!("{v}")).collect::<Vec<_>>().join(", ")
        ),
        None,
    );
    trainers(s, rs);
    claims_side_by_side(s, rs);
    robot(s, r);
    switch_runs(s, r);
    for r in rs {
        per_seed(s, r);
    }
    for (k, g) in r.held_out.iter().enumerate() {
        per_channel(s, r, k, g);
    }
    held_out_cycles(s, r);
    validation_curves(s, rs, "fig_validation_whole_body");
}

/// How a configuration's readout was learnt, in words.
fn trainer(r: &BodyResult) -> String {
    format!("{}, {}", protocol_name(&r.header), r.trainer)
}

/// The trainers side by side: what each holds, with what neurons, in what time.
fn trainers(s: &mut Section, rs: &[&BodyResult]) {
    if rs.len() < 2 {
        return;
    }
    // The seeds every readout ran.
    let common: Vec<u64> = rs
        .iter()
        .map(|r| r.seeds.iter().map(|s| s.model.seed).collect::<Vec<_>>())
        .reduce(|a, b| a.into_iter().filter(|x| b.contains(x)).collect())
        .unwrap_or_default();
    let rows: Vec<Vec<String>> = rs
        .iter()
        .map(|r| {
            let all = r.seeds.len();
            let seeds: Vec<&BodySeed> = r.seeds.iter().filter(|s| common.contains(&s.model.seed)).collect();
            let n = seeds.len();
            let count = |f: &dyn Fn(&BodySeed) -> bool| format!("{} of {n}", seeds.iter().filter(|s| f(s)).count());
            let mut row = vec![
                trainer(r),
                r.header.n_neurons.to_string(),
                format!(
                    "{:.1} s ({all} seeds in {:.0} s on {} threads)",
                    r.train_wall_s / all as f64 * r.threads.min(all).max(1) as f64,
                    r.train_wall_s,
                    r.threads
                ),
            ];
            row.push(count(&|s| s.stand.passed));
            for k in 0..r.held_out.len() {
                let e: Vec<f64> = seeds.iter().map(|s| s.gaits[k].error).collect();
                row.push(format!(
                    "{:.2}° ({} within the spread)",
                    crate::stats::median(&e),
                    count(&|s| s.gaits[k].error_ok)
                ));
            }
            row.push(count(&|s| s.switches.iter().all(|w| w.passed)));
            row.push(count(&|s| s.passed));
            row
        })
        .collect();
    let mut head = vec!["readout".to_owned(), "neurons".to_owned(), "training per seed".to_owned(), "stand".to_owned()];
    if let Some(r) = rs.first() {
        head.extend(r.held_out.iter().map(|g| format!("{}: cycle error (median)", g.teacher)));
    }
    head.push("every switch".into());
    head.push("everything".into());
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    s.line(format!("The two readouts on the same data, reservoirs, validation and test, on the seeds both ran ({}; FORCE's \"penalties\" above are its α: the inverse correlation starts at I / α; training time: the wall time of all its seeds over the seeds a thread trained):", seed_list(&common)));
    s.blank();
    s.table(&head, &format!("l{}", "r".repeat(head.len() - 1)), &rows);
}

fn per_seed(s: &mut Section, r: &BodyResult) {
    let mut head = vec!["seed".to_owned(), "penalty".to_owned(), "standing: distance, swing, travel".to_owned()];
    head.extend(r.held_out.iter().map(|g| {
        format!(
            "{}: period (frames; allowed {:.1}–{:.1}), channels within, error / spread",
            g.teacher, g.period_bounds.0, g.period_bounds.1
        )
    }));
    head.push("switches: settled (strides); largest step / the data's; foot slide".into());
    head.push("passed".into());
    let rows: Vec<Vec<String>> = r
        .seeds
        .iter()
        .map(|sd| {
            let mut v = vec![
                sd.model.seed.to_string(),
                pen(sd.model.penalty),
                format!(
                    "{:.2}°, {:.3}°, {:.0} mm{}",
                    sd.stand.deviation,
                    sd.stand.swing,
                    sd.stand.travel_mm,
                    if sd.stand.passed { "" } else { " ✗" }
                ),
            ];
            for (g, h) in sd.gaits.iter().zip(&r.held_out) {
                v.push(format!(
                    "{}, {} of {}, {:.2}° / {:.2}°{}",
                    g.period_steps.map_or("no rhythm".into(), |p| format!("{p:.1}")),
                    g.amplitudes_within,
                    g.amplitude.len(),
                    g.error,
                    h.spread,
                    if g.passed { "" } else { " ✗" }
                ));
            }
            v.push(format!(
                "{}; {:.2}; {}{}",
                sd.switches
                    .iter()
                    .map(|w| w.settle_s.map_or("never".into(), |x| format!("{:.2}", x / w.stride_s)))
                    .collect::<Vec<_>>()
                    .join(", "),
                sd.switches.iter().map(|w| w.step_ratio).fold(0.0, f64::max),
                slides(&sd.switches),
                if sd.switches.iter().all(|w| w.passed) { "" } else { " ✗" }
            ));
            v.push(format!("{}{}", yes(sd.passed), if sd.at_limit { " (at the limit)" } else { "" }));
            v
        })
        .collect();
    s.line(format!(
        "Per seed, {} (✗: outside its rule; the switches in order, settling counted from the ramp's end, in strides of the state reached, onto the orbit the generator keeps with those inputs held; the largest step, the largest over the channels of a channel's step over its largest in every recorded trial, training and held-out (from {:.3} to {:.3} in normalised units; in the teachers' cycles, averaged and smoother, at most {:.3}); the foot slide of each switch in order, the largest of either foot during one stance from the ramp's start to the next switch, after the feet's cleanup and, raw, before it, with the largest change the cleanup made to a leg's rotation):",
        trainer(r),
        r.data_steps.iter().copied().filter(|v| *v > 1e-9).fold(f64::INFINITY, f64::min),
        r.recorded_step,
        r.data_step
    ));
    s.blank();
    let head: Vec<&str> = head.iter().map(String::as_str).collect();
    s.table(&head, &format!("rr{}", "r".repeat(head.len() - 2)), &rows);
}

fn per_channel(s: &mut Section, r: &BodyResult, k: usize, g: &HeldOutGait) {
    let Some(first) = r.seeds.first() else { return };
    let Some(made) = first.gaits.get(k) else { return };
    let mark = |ok: bool| if ok { "" } else { " ✗" };
    let rows: Vec<Vec<String>> = r
        .channels
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let own = g.trials.iter().map(|t| t.amplitude[c]);
            let (lo, hi) = own.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
            let (blo, bhi) = g.amplitude_bounds[c];
            let teacher_ok = g.teacher_channel_ok.get(c).copied().unwrap_or(false);
            vec![
                format!("`{name}`"),
                format!("{:.2} ({lo:.2}–{hi:.2})", g.amplitude[c]),
                format!("{:.2}–{:.2}", blo.max(0.0), bhi),
                format!("{:.2}{}", g.teacher_amplitude.get(c).copied().unwrap_or(f64::NAN), mark(teacher_ok)),
                format!(
                    "{:.2}{}{}",
                    made.amplitude[c],
                    mark(made.channel_ok[c]),
                    if teacher_ok && !made.channel_ok[c] { " (the generator's)" } else { "" }
                ),
                made.channel_period_steps[c].map_or("—".into(), |p| format!("{p:.1}")),
                format!("{:.2}", made.channel_error[c]),
                format!("{:.2}", g.channel_spread[c]),
            ]
        })
        .collect();
    s.line(format!(
        "Every channel while {} (seed {}, the last {WINDOW_S} s of {} s): half ranges in degrees; the held-out trials' median and their smallest and largest; the range the rule allows (theirs widened on both sides by {:.0} % of the median, by {BARELY_MOVES_DEG}° where the median is below {BARELY_MOVES_DEG}°); the training teacher's and the generator's, ✗ outside it (a channel the teacher holds and the generator does not is the generator's fault; one the teacher misses is the teacher's, its construction's); the channel's own period in frames (the held-out median: {:.1}); its RMS error against the held-out trials (median over them) beside the held-out trials' own (median over pairs):",
        g.teacher,
        first.model.seed,
        r.run_s,
        100.0 * AMPLITUDE_TOLERANCE,
        g.period_frames
    ));
    s.blank();
    s.table(
        &[
            "channel",
            "held-out half range (smallest–largest)",
            "allowed",
            "training teacher",
            "generated",
            "period",
            "error",
            "held-out spread",
        ],
        "lrrrrrrr",
        &rows,
    );
}

/// Channels drawn per gait in the held-out cycle figure.
const CYCLE_PANELS: usize = 4;

/// Per gait, the channels that swing most in the held-out trials: each
/// trial's cycle, the training teacher's and the first seed's last cycle,
/// all time-normalised and drawn in the first trial's phase.
fn held_out_cycles(s: &mut Section, r: &BodyResult) {
    let d = r.channels.len();
    let mut panels = Vec::new();
    let mut drawn = Vec::new();
    for (k, g) in r.held_out.iter().enumerate() {
        let mut by_swing: Vec<usize> =
            (0..d).filter(|&c| r.channels[c].contains(".r") && g.amplitude[c].is_finite()).collect();
        by_swing.sort_by(|&a, &b| g.amplitude[b].total_cmp(&g.amplitude[a]));
        let generated = r.seeds.first().and_then(|s| s.gaits.get(k)).map(|x| x.cycle.as_slice()).unwrap_or(&[]);
        let column = |cycle: &[f64], c: usize| -> Vec<(f64, f64)> {
            (0..PHASES).filter_map(|p| cycle.get(p * d + c).map(|v| (p as f64 / PHASES as f64, *v))).collect()
        };
        for &c in by_swing.iter().take(CYCLE_PANELS) {
            let mut curves: Vec<Curve> = g
                .trials
                .iter()
                .enumerate()
                .map(|(i, t)| Curve::new(Look::Data, if i == 0 { "held-out trials" } else { "" }, column(&t.cycle, c)))
                .collect();
            curves.push(Curve::new(Look::Teacher, "training teacher", column(&g.teacher_cycle, c)));
            if !generated.is_empty() {
                curves.push(Curve::new(Look::Model, "generator", column(generated, c)));
            }
            panels.push(Panel {
                equal_axes: false,
                title: format!("{}: {}", g.teacher, r.channels[c]),
                x_label: "phase (cycles)".into(),
                y_label: "°".into(),
                curves,
            });
        }
        drawn.push(format!(
            "{} ({})",
            g.teacher,
            by_swing.iter().take(CYCLE_PANELS).map(|&c| format!("`{}`", r.channels[c])).collect::<Vec<_>>().join(", ")
        ));
    }
    if panels.is_empty() {
        return;
    }
    let rows = panels.len().div_ceil(CYCLE_PANELS) as u32;
    s.figure("fig_whole_body_cycles", panels, CYCLE_PANELS, (1300, 260 * rows));
    s.line(format!(
        "![Each gait's held-out trials (light gray), the training teacher (dashed) and seed {}'s last cycle after {} s of free run (black), time-normalised and drawn in the first trial's phase, for the channels that swing most in the held-out trials](fig_whole_body_cycles.png)",
        r.seeds.first().map_or(0, |s| s.model.seed),
        r.run_s
    ));
    s.blank();
    s.line(format!(
        "The figure draws, per gait, the {CYCLE_PANELS} rotations that swing most in the held-out trials: {}.",
        drawn.join("; ")
    ));
    s.blank();
}

fn switch_runs(s: &mut Section, r: &BodyResult) {
    let rate = 120.0;
    let channel =
        r.header.cycles.iter().find(|c| !c.period_channel.is_empty()).map_or("", |c| c.period_channel.as_str());
    let mut panels = Vec::new();
    for (k, y) in r.switch_runs.iter().enumerate() {
        let (lo, hi) = y.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
        let band = |t: f64| {
            Curve::new(
                Look::Control,
                "",
                vec![(t, lo), (t, hi), (t + r.test.ramp_s, hi), (t + r.test.ramp_s, lo), (t, lo)],
            )
        };
        let mut curves: Vec<Curve> = r.switch_at_s.iter().map(|&t| band(t)).collect();
        curves.push(Curve::new(Look::Model, "", pts(y, 0.0, rate)));
        panels.push(Panel {
            equal_axes: false,
            title: format!("seed {}", r.seeds.get(k).map_or(0, |s| s.model.seed)),
            x_label: "time (s)".into(),
            y_label: format!("{channel} (°)"),
            curves,
        });
    }
    if panels.is_empty() {
        return;
    }
    let rows = panels.len().div_ceil(2) as u32;
    s.figure("fig_whole_body_switches", panels, 2, (1300, 170 * rows));
    s.line("![Every seed's switching run (the period channel; gray bands: the ramps of the inputs)](fig_whole_body_switches.png)");
    s.blank();
}

fn robot(s: &mut Section, r: &BodyResult) {
    let Some(c) = &r.robot else { return };
    let seed = r.seeds.first().map_or(0, |s| s.model.seed);
    let rows: Vec<Vec<String>> = c
        .joints
        .iter()
        .map(|j| {
            let share = |n: usize| format!("{:.1} %", 100.0 * n as f64 / j.n_frames.max(1) as f64);
            vec![
                format!("`{}`", j.joint),
                format!("{:.1} … {:.1}", j.min_rad.to_degrees(), j.max_rad.to_degrees()),
                share(j.n_clamped),
                format!("{:.1}", j.max_velocity_rad_s),
                share(j.n_velocity_limited),
                share(j.n_acceleration_limited),
                format!("{:.1}°", j.max_lag_rad.to_degrees()),
            ]
        })
        .collect();
    let limited = c.joints.iter().filter(|j| j.limited_share() > 0.05).count();
    let worst = c.joints.iter().max_by(|a, b| a.max_lag_rad.total_cmp(&b.max_lag_rad));
    s.line(format!(
        "On the HOAP-2: the switching run of seed {seed} ({:.0} s) mapped by the configuration's channel map onto the robot's {} joints at {ROBOT_RATE_HZ:.0} Hz and kept within each joint's range, its URDF velocity limit and an acceleration bound of {:.0} rad/s², as `cpg hoap2` and `cpg stream --robot` keep it. A bound changed more than 5 % of the frames of {limited} of the {} joints{}:",
        r.switch_at_s.last().map_or(0.0, |t| t + r.test.ramp_s + r.test.stay_s),
        c.joints.len(),
        r.robot_acceleration_rad_s2,
        c.joints.len(),
        worst.map_or(String::new(), |j| format!("; the furthest a command lagged the angle asked for is {:.1}° (`{}`)", j.max_lag_rad.to_degrees(), j.joint))
    ));
    s.blank();
    // Which joints bind: the ones a bound changed most often, with what was asked of them.
    let mut binding: Vec<(usize, &cpg_robot::JointClamp)> =
        c.joints.iter().enumerate().filter(|(_, j)| j.limited_share() > 0.05).collect();
    binding.sort_by(|a, b| b.1.limited_share().total_cmp(&a.1.limited_share()));
    if !binding.is_empty() {
        let each: Vec<String> = binding
            .iter()
            .map(|&(k, j)| {
                let limit = r.robot_velocity_limits_rad_s.get(k).copied().unwrap_or(f64::NAN);
                let share = |n: usize| 100.0 * n as f64 / j.n_frames.max(1) as f64;
                if j.n_clamped >= j.n_velocity_limited.max(j.n_acceleration_limited) {
                    format!(
                        "`{}` by its range (the generated motion asks angles beyond it on {:.1} % of the frames)",
                        j.joint,
                        share(j.n_clamped)
                    )
                } else {
                    format!(
                        "`{}` by its speed (the generated motion asks up to {:.1} rad/s where its URDF limit is {:.1} rad/s, {:.1}×; velocity-limited on {:.1} % of the frames, acceleration-limited on {:.1} %)",
                        j.joint,
                        j.max_velocity_rad_s,
                        limit,
                        j.max_velocity_rad_s / limit,
                        share(j.n_velocity_limited),
                        share(j.n_acceleration_limited)
                    )
                }
            })
            .collect();
        s.line(format!(
            "At the person's tempo this body binds at {}. The run is shown as the limits make it, not slowed to fit.",
            each.join("; ")
        ));
        s.blank();
    }
    s.table(
        &[
            "joint",
            "asked (°)",
            "beyond the range",
            "fastest asked (rad/s)",
            "velocity-limited",
            "acceleration-limited",
            "largest lag",
        ],
        "lrrrrrr",
        &rows,
    );
}

/// Each switch's foot slide in order, then each before the feet's cleanup,
/// and the cleanup's largest change of a leg's rotation
/// (`0, 0 mm (raw: 216, 40; cleanup up to 12.5°)`); `no feet` when the
/// model has no skeleton to find them.
fn slides(switches: &[BodySwitch]) -> String {
    if switches.iter().all(|w| w.slide_mm.is_none()) {
        return "no feet".into();
    }
    let each = |f: fn(&BodySwitch) -> Option<f64>| {
        switches.iter().map(|w| f(w).map_or("—".into(), |v| format!("{v:.0}"))).collect::<Vec<String>>().join(", ")
    };
    let cleanup = switches.iter().filter_map(|w| w.cleanup_deg).fold(0.0, f64::max);
    format!("{} mm (raw: {}; cleanup up to {cleanup:.1}°)", each(|w| w.slide_mm), each(|w| w.raw_slide_mm))
}

/// Seeds in words: "seed 4", "seeds 1–3" (a run of consecutive seeds), or "seeds 1, 3, 8".
fn seed_list(seeds: &[u64]) -> String {
    match seeds {
        [] => "no seed".into(),
        [one] => format!("seed {one}"),
        [first, .., last] if seeds.windows(2).all(|w| w[1] == w[0] + 1) => format!("seeds {first}–{last}"),
        _ => format!("seeds {}", seeds.iter().map(u64::to_string).collect::<Vec<_>>().join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::{BodySwitch, seed_list, slides};

    fn switch(slide_mm: Option<f64>) -> BodySwitch {
        BodySwitch {
            from: "stand".into(),
            to: "walk".into(),
            at_s: 18.0,
            settle_s: Some(0.1),
            stride_s: 1.1,
            max_step: 0.1,
            step_ratio: 0.9,
            step_channel: "lfemur.rx".into(),
            slide_mm,
            raw_slide_mm: slide_mm.map(|v| v / 2.0),
            cleanup_deg: slide_mm.map(|v| v / 100.0),
            passed: false,
            at_limit: false,
        }
    }

    #[test]
    fn each_switch_names_its_own_slide() {
        let each = [switch(Some(540.4)), switch(Some(71.0)), switch(None), switch(Some(9.6))];
        assert_eq!(slides(&each), "540, 71, —, 10 mm (raw: 270, 36, —, 5; cleanup up to 5.4°)");
        assert_eq!(slides(&[switch(None), switch(None)]), "no feet");
    }

    #[test]
    fn seeds_read_as_a_run_or_a_list() {
        assert_eq!(seed_list(&[]), "no seed");
        assert_eq!(seed_list(&[4]), "seed 4");
        assert_eq!(seed_list(&[1, 2, 3]), "seeds 1–3");
        assert_eq!(seed_list(&[1, 3, 8]), "seeds 1, 3, 8");
    }
}

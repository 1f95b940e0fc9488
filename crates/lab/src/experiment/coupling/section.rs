//! The report's section of this experiment: every protocol side by side, built from the results alone.

use super::*;
use crate::experiment::doc::*;
use crate::experiment::pen;

/// E6.
pub fn coupling(s: &mut Section, rs: &[&CouplingResult], ctx: &Context) {
    let Some(first) = rs.first() else { return };
    opening(s, rs, ctx);
    if let Some(c) = first.header.cycles.first() {
        s.line(teacher_line(c, &first.reference));
        s.blank();
    }
    for r in rs {
        let gif = (r.header.protocol == crate::config::Protocol::Ours).then_some(5.0);
        view(
            s,
            r.view.as_ref(),
            &stem("e6_view", &r.header),
            &protocol_name(&r.header),
            "the last 10 s of the free run",
            gif,
        );
    }
    s.line(format!("{} channels, one cycle of {} frames repeated; free run of {} steps ({:.0} s). A joint's **deviation** is the model's phase relation to `{}` minus the teacher's, in cycles: each channel's own teacher cycle is aligned to three cycles of the model's window to a fraction of a frame (the vertex of a parabola through the best whole shift and its neighbours), so 0 is exactly the teacher's lag and one frame is {:.4} cycle. Its **drift** is the deviation in the last 10 s minus that in the first 10 s; the verdict uses the drift. The cross-correlation **lags** are shown beside it: a joint with two similar peaks a cycle (the feet) can move its cross-correlation peak from one to the other without any change of phase, which is why the verdict does not use them. Portraits: data (the whole trial) light gray, model black (10 s from {:.0} s on).",
        first.rows.len(), first.period_frames, first.steps, first.run_s, first.reference, 1.0 / first.period_frames as f64, first.portrait_from_s));
    s.blank();
    claims_side_by_side(s, rs);
    validation_curves(s, rs, "fig_validation_e6");
    deviation_figure(s, rs);
    s.line("![Every joint's deviation from the teacher's phase relation over the run, first seed](fig5_deviation.png)");
    s.blank();
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
        s.line(format!("Seeds, {}:", protocol_name(&r.header)));
        s.blank();
        s.table(&["seed", "penalty", "largest drift (cycles)", "median cycle NMSE", "coupling kept"], "rrrrl", &rows);
    }
    s.line(format!(
        "The joint tables, the portraits, the view and the HOAP-2 commands below show the first seed ({}).",
        first.model.seed
    ));
    s.blank();
    for r in rs {
        s.line(format!("![Figure 5, {}]({}.png)", protocol_name(&r.header), stem("fig5", &r.header)));
        s.blank();
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
        s.line(format!("Joints, {}:", protocol_name(&r.header)));
        s.blank();
        s.table(
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
        s.figure(stem("fig5", &r.header), panels, 4, (1400, 1000));
    }
}

fn deviation_figure(s: &mut Section, rs: &[&CouplingResult]) {
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
    s.figure("fig5_deviation", panels, rs.len().min(2), (620 * rs.len().min(2) as u32, 420));
}

/// The HOAP-2 section from E6 runs that mapped their output onto the robot.
pub fn hoap2(s: &mut Section, rs: &[&CouplingResult]) {
    let mapped: Vec<&&CouplingResult> = rs.iter().filter(|r| r.hoap2.is_some()).collect();
    if mapped.is_empty() {
        return;
    }
    s.line("## HOAP-2 joint commands");
    s.blank();
    for r in &mapped {
        let Some(h) = &r.hoap2 else { continue };
        let st = stem("e6_hoap2", &r.header);
        s.file(format!("{st}_120hz.csv"), h.trajectory.to_csv().into_bytes());
        s.file(format!("{st}_1khz.csv"), h.trajectory_1khz.to_csv().into_bytes());
        s.file(format!("{st}_1khz.json"), h.trajectory_1khz.to_ros_json().into_bytes());
        s.line(format!(
            "The end of E6's free run ({}) as a loop of {} whole cycles of the model ({} frames, cut where the run meets itself best), mapped by the configuration's channel map onto the joints of the URDF, resampled by a natural cubic spline (with {} frames of margin on each side, so that the spline's ends fall outside the loop) and kept within every joint's position range, its URDF velocity limit ({} rad/s) and an acceleration bound of {} rad/s² (ours: the HOAP-2 documents give none). The limiter starts in motion and runs the loop twice, keeping the second lap, so the commands start in the state they end in: `{st}_120hz.csv`, `{st}_1khz.csv` (time_s, then every joint's angle in rad, velocity in rad/s and acceleration in rad/s²) and `{st}_1khz.json` (a trajectory_msgs/JointTrajectory) can be played in a loop.",
            protocol_name(&r.header),
            h.loop_cycles,
            h.loop_frames,
            crate::experiment::coupling::LOOP_MARGIN,
            h.velocity_limit_rad_s,
            h.acceleration_bound_rad_s2
        ));
        s.blank();
        s.line(format!(
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
        s.blank();
        knee_ankle_figure(s, r, h, &format!("{st}_knee_ankle"));
        s.line(format!(
            "![{}: the left knee and ankle pitch, asked and commanded]({st}_knee_ankle.png)",
            protocol_name(&r.header)
        ));
        s.blank();
        if h.robot_gait.is_some() || h.human_gait_scaled.is_some() {
            s.line(format!(
                "The gait on the robot (HOAP-2 forward kinematics of the commanded angles at the model's rate: the soles in the trunk frame) beside the human's in the recorded trial (the ankles relative to the root), its lengths scaled by the ratio of the legs ({:.3}: HOAP-2's thigh + shank over the human's femur + tibia).",
                h.leg_scale
            ));
            s.blank();
            let g = |x: Option<cpg_robot::Gait>, f: fn(&cpg_robot::Gait) -> String| {
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
            s.table(&["measure", "robot (generated)", "human (recorded, scaled)"], "lrr", &rows);
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
        s.table(
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
}

/// The left knee and ankle pitch at 1 kHz, asked and commanded, over the first two seconds of the loop.
fn knee_ankle_figure(s: &mut Section, r: &CouplingResult, h: &Hoap2, name: &str) {
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
        return;
    }
    s.figure(name, panels, 2, (1200, 420));
}

/// The last 10 s of an E6 run as AMC, for any ASF/AMC viewer.
pub fn last_10_s(s: &mut Section, c: &CouplingResult) -> Result<()> {
    let Some(m) = &c.trained else { return Ok(()) };
    let Some(asf) = &m.skeleton_asf else { return Ok(()) };
    let sk = cpg_mocap::parse_asf("skeleton of the model", asf.as_bytes()).map_err(cpg_mocap::Error::from)?;
    let channels = m.outputs.iter().filter_map(|o| cpg_mocap::Channel::parse(&o.name)).collect();
    let motion = cpg_mocap::Motion::new(channels, c.last10_units.clone(), m.provenance.sample_rate_hz)?;
    s.file(format!("{}_last10s.amc", stem("e6", &c.header)), cpg_mocap::write_amc(&sk, &motion)?.into_bytes());
    Ok(())
}

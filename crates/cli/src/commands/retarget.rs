//! `cpg retarget`: the human's walk as a walk the HOAP-2 can balance.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use cpg_lab::retarget::{RetargetOptions, check_plan, human_walk, retarget};
use cpg_robot::Robot;
use cpg_robot::physics::MassModel;

use crate::output::{Destination, check_writable, write_output};

pub struct Retarget<'a> {
    pub motions: &'a [PathBuf],
    pub skeleton: Option<&'a Path>,
    pub profile: Option<&'a Path>,
    pub options: RetargetOptions,
    pub output: &'a Path,
    pub report: Option<&'a Path>,
    pub rate_hz: Option<f64>,
    pub bvh_unit_mm: Option<f64>,
}

pub fn run(a: Retarget<'_>) -> anyhow::Result<()> {
    let dest = check_writable(a.output)?;
    if let Some(r) = a.report {
        check_writable(r)?;
    }
    anyhow::ensure!(!a.motions.is_empty(), "give at least one walking trial (--motion)");
    let given = a.profile.map(cpg_mocap::profile::Profile::from_file).transpose()?;
    let mut trials = Vec::with_capacity(a.motions.len());
    for m in a.motions {
        let r = cpg_mocap::read_recording(
            m,
            a.skeleton,
            a.rate_hz,
            &cpg_mocap::BvhOptions { length_unit_mm: a.bvh_unit_mm },
        )?;
        let points = cpg_mocap::profile::Profile::for_skeleton(&r.skeleton, given.as_ref())
            .with_context(|| format!("{}", m.display()))?;
        trials.push((r.skeleton.forward_kinematics(&r.motion).with_context(|| format!("{}", m.display()))?, points));
    }
    let human = human_walk(&trials)?;
    let robot = Robot::hoap2()?;
    let mass = MassModel::from_urdf(&robot, cpg_robot::assets::HOAP2_URDF, Path::new("hoap2.urdf"))?;
    let (params, plan, style) = retarget(&human, &robot, &mass, &a.options)?;
    let n = plan.n_frames();
    let d = plan.joints.len();
    let checks = check_plan(&plan, &robot);
    let margin = &checks.single_support_margin_m;
    write_output(a.output, |w| {
        write!(w, "time_s")?;
        for j in &plan.joints {
            write!(w, ",{j}_rad")?;
        }
        writeln!(w, ",trunk_x_m,trunk_y_m,trunk_z_m,com_x_m,com_y_m,zmp_x_m,zmp_y_m,zmp_margin_m,support")?;
        for f in 0..n {
            write!(w, "{:.4}", f as f64 / plan.rate_hz)?;
            for v in &plan.q_rad[f * d..(f + 1) * d] {
                write!(w, ",{v:.7}")?;
            }
            let (t, c, z) = (plan.trunk_m[f], plan.com_m[f], plan.zmp_m[f]);
            let s = plan.support[f].as_str();
            writeln!(
                w,
                ",{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{s}",
                t[0], t[1], t[2], c[0], c[1], z[0], z[1], plan.margin_m[f]
            )?;
        }
        Ok(())
    })?;
    let leg = cpg_lab::retarget::robot_leg_length_m(&robot)?;
    eprintln!(
        "the human ({} strides of {} trial(s)): stride {:.3} s, {:.2} m ({:.2} leg lengths), on the ground {:.0} % of a stride, ankle lift {:.3} m",
        human.strides,
        trials.len(),
        human.stride_period_s,
        human.stride_length_m,
        human.stride_length_m / human.leg_length_m,
        100.0 * human.duty_factor,
        human.lift_m
    );
    eprintln!(
        "the robot: {} steps of {:.3} m ({:.0} % of the human's step at the robot's leg of {:.3} m), lift {:.3} m, double support {:.0} % of a step",
        params.steps,
        params.step_length_m,
        100.0 * a.options.step_scale,
        leg,
        params.lift_m,
        100.0 * params.double_support_share
    );
    eprintln!(
        "ZMP inside the support polygon in {:.1} % of {} frames; margin in single support: median {:.1} mm, lowest {:.1} mm; IK residual {:.1e} m",
        100.0 * checks.zmp_inside_share,
        n,
        1e3 * margin.median,
        1e3 * margin.min,
        plan.ik_residual_m
    );
    eprintln!(
        "fastest joint {:.2} rad/s ({}, limit {} rad/s); outside a position limit: {}",
        checks.fastest_joint.1,
        checks.fastest_joint.0,
        robot.joint(&checks.fastest_joint.0).map(|j| j.velocity_rad_s).unwrap_or(f64::NAN),
        if checks.outside_limits.is_empty() { "none".to_owned() } else { checks.outside_limits.join(", ") }
    );
    for s in &style {
        eprintln!(
            "style {:<20} {:<13} correlation {:+.2} (best {:+.2} at {:+.2} cycle), range {:.2} of the human's",
            s.human, s.joint, s.correlation, s.shifted.0, s.shifted.1, s.range_ratio
        );
    }
    if let Some(r) = a.report {
        let json = serde_json::json!({
            "human": human,
            "options": a.options,
            "robot_leg_length_m": leg,
            "params": {
                "stride_period_s": params.stride_period_s,
                "double_support_share": params.double_support_share,
                "step_length_m": params.step_length_m,
                "lift_m": params.lift_m,
                "foot_y_m": params.foot_y_m,
                "trunk_height_m": params.trunk_height_m,
                "steps": params.steps,
            },
            "frames": n,
            "rate_hz": plan.rate_hz,
            "checks": checks,
            "ik_residual_m": plan.ik_residual_m,
            "steady_stride_frames": [plan.steady_stride.0, plan.steady_stride.1],
            "style": style,
        });
        write_output(r, |w| {
            serde_json::to_writer_pretty(&mut *w, &json)?;
            writeln!(w)?;
            Ok(())
        })?;
    }
    eprintln!("wrote {} frames at {} Hz to {}", n, plan.rate_hz, Destination::describe(&dest));
    Ok(())
}

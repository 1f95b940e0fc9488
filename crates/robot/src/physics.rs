//! The HOAP-2 as a physical body: a solid box per link, the centre of mass
//! and inertia each box gives its link's mass, collision shapes, and the
//! MuJoCo model (MJCF) built from the URDF.
//!
//! The URDF's joints and masses are the reference's facts
//! (`shared/reference/hoap2-joints.md`); [`physical_urdf`] keeps them and
//! rewrites every link from its spec's shapes (`[[shapes]]` in `robot.toml`): a uniform solid box of the
//! link's mass (inertia `m/12·(b² + c²)` about its centre), which is also the
//! link's collision and visual shape. [`mjcf`] turns such a URDF into a MuJoCo
//! scene: a floor, the body tree, a position servo on every joint limited to
//! the URDF's effort, the soles' friction with a torsional term, collisions
//! between the two legs, an IMU and sole touch sensors, and a keyframe
//! `home` standing in the home pose of its spec (`home_pose_deg`). `docs/hoap2-model.md` gives the
//! derivation; `cargo xtask hoap2-model` writes the files.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use crate::{Error, Result, Robot};

/// Which parts of the body a shape collides with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Contact {
    /// The floor only (trunk, pelvis, arms, head).
    Floor,
    /// The floor and the other leg.
    FloorAndOtherLeg,
    /// The other leg only (the foot's block; the sole meets the floor).
    OtherLeg,
}

/// One solid box of a link, in the link's frame (a robot spec's `[[shapes]]`).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shape {
    /// The link's name in the URDF.
    pub link: String,
    /// The shape's name (the URDF's collision name; the MJCF geom's name); the link's when not given.
    #[serde(default)]
    pub name: String,
    /// Edge lengths along the link's x, y, z, metres.
    pub size_m: [f64; 3],
    /// Centre in the link's frame, metres.
    pub centre_m: [f64; 3],
    /// Whether this box carries the link's mass (one per link) or only collides (the soles).
    #[serde(default = "yes")]
    pub carries_mass: bool,
    /// What it collides with.
    pub contact: Contact,
    /// Where the numbers come from (`reference`, `estimate`).
    pub source: String,
}

fn yes() -> bool {
    true
}

/// The simulation settings of [`mjcf`]. None of these is in the sources:
/// each is ours, stated in `docs/hoap2-model.md`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MjcfSettings {
    /// Physics step, seconds (the control loop ticks once per step).
    pub timestep_s: f64,
    /// Position servo stiffness, N·m/rad.
    pub kp_nm_per_rad: f64,
    /// Position servo damping, N·m·s/rad.
    pub kv_nm_s_per_rad: f64,
    /// Reflected rotor inertia of each joint's motor, kg·m².
    pub armature_kg_m2: f64,
    /// Viscous friction of each joint, N·m·s/rad.
    pub damping_nm_s_per_rad: f64,
    /// Sliding friction coefficient of the soles on the floor.
    pub sliding_friction: f64,
    /// Torsional friction of the soles, metres (torque per newton of normal force).
    pub torsional_friction_m: f64,
}

impl MjcfSettings {
    /// The settings a robot's spec gives its servos and soles.
    pub fn of(spec: &crate::RobotSpec) -> MjcfSettings {
        let s = &spec.servos;
        MjcfSettings {
            timestep_s: s.timestep_s,
            kp_nm_per_rad: s.kp_nm_per_rad,
            kv_nm_s_per_rad: s.kv_nm_s_per_rad,
            armature_kg_m2: s.armature_kg_m2,
            damping_nm_s_per_rad: s.damping_nm_s_per_rad,
            sliding_friction: s.sliding_friction,
            torsional_friction_m: s.torsional_friction_m,
        }
    }
}

/// The inertia of a uniform solid box about its centre, kg·m² (`[Ixx, Iyy, Izz]`).
pub fn box_inertia(mass_kg: f64, size_m: [f64; 3]) -> [f64; 3] {
    let [a, b, c] = size_m.map(|s| s * s);
    [mass_kg / 12.0 * (b + c), mass_kg / 12.0 * (a + c), mass_kg / 12.0 * (a + b)]
}

/// A number as the generated files write it: 7 significant digits, shortest form.
fn num(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let rounded: f64 = format!("{v:.6e}").parse().unwrap_or(v);
    format!("{rounded}")
}

fn vec3(v: [f64; 3]) -> String {
    format!("{} {} {}", num(v[0]), num(v[1]), num(v[2]))
}

fn parse(text: &str, path: &Path) -> Result<urdf_rs::Robot> {
    urdf_rs::read_from_string(text).map_err(|e| Error::Urdf { path: path.to_owned(), reason: e.to_string() })
}

fn urdf_error(path: &Path, reason: String) -> Error {
    Error::Urdf { path: path.to_owned(), reason }
}

/// The shapes of one link and the one that carries its mass, or an error naming it.
fn shapes_of<'a>(shapes: &'a [Shape], link: &str, path: &Path) -> Result<(&'a Shape, Vec<&'a Shape>)> {
    let mine: Vec<&Shape> = shapes.iter().filter(|s| s.link == link).collect();
    match mine.iter().filter(|s| s.carries_mass).collect::<Vec<_>>().as_slice() {
        [solid] => Ok((solid, mine.clone())),
        _ => Err(urdf_error(path, format!("link '{link}' needs exactly one shape that carries its mass"))),
    }
}

/// Rewrites the links of URDF `text` from `shapes`: each link keeps its mass
/// and gets the centre of mass, inertia, collision and visual box of its
/// solid shape. Joints are written back unchanged. Idempotent: applied to
/// its own output it returns the same text.
pub fn physical_urdf(text: &str, path: &Path, shapes: &[Shape]) -> Result<String> {
    let r = parse(text, path)?;
    let mut out = String::new();
    out.push_str("<?xml version=\"1.0\"?>\n");
    out.push_str(
        "<!-- Fujitsu HOAP-2, 25 revolute joints. Written by `cargo xtask hoap2-model` (cpg-robot's\n     \
         physics module) from the facts in shared/reference/hoap2-joints.md: joint names, parents,\n     \
         anchors, axes, limits and link masses of the Webots model, cross-checked against the Moby\n     \
         model. Frame: x forward, y left, z up; the trunk origin stands 0.29 m above the ground in\n     \
         the zero pose. Effort 9 N·m and velocity 5 rad/s are the Webots model's simulation settings,\n     \
         not rated values. Each link is a uniform solid box of its mass (the foot and sole boxes are\n     \
         the reference's, the others our estimates); its centre of mass, inertia and collision shape\n     \
         follow from it, as docs/hoap2-model.md derives. Both feet carry the 0.02 kg sole sensor the\n     \
         reference lists for the left one: the reference's total of 7.16 kg is reached only with both. -->\n",
    );
    let _ = writeln!(out, "<robot name=\"{}\">", r.name);
    for link in &r.links {
        let mass = link.inertial.mass.value;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(urdf_error(path, format!("link '{}': mass {mass} kg is not positive", link.name)));
        }
        let (body, mine) = shapes_of(shapes, &link.name, path)?;
        let [ixx, iyy, izz] = box_inertia(mass, body.size_m);
        let _ = writeln!(out, "  <link name=\"{}\">", link.name);
        let _ = writeln!(out, "    <inertial>");
        let _ = writeln!(out, "      <origin xyz=\"{}\" rpy=\"0 0 0\"/>", vec3(body.centre_m));
        let _ = writeln!(out, "      <mass value=\"{}\"/>", num(mass));
        let _ = writeln!(
            out,
            "      <inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/>",
            num(ixx),
            num(iyy),
            num(izz)
        );
        let _ = writeln!(out, "    </inertial>");
        for s in &mine {
            for kind in ["visual", "collision"] {
                let _ = writeln!(out, "    <{kind} name=\"{}\">", s.name);
                let _ = writeln!(out, "      <origin xyz=\"{}\" rpy=\"0 0 0\"/>", vec3(s.centre_m));
                let _ = writeln!(out, "      <geometry><box size=\"{}\"/></geometry>", vec3(s.size_m));
                let _ = writeln!(out, "    </{kind}>");
            }
        }
        let _ = writeln!(out, "  </link>");
    }
    for j in &r.joints {
        let kind = match j.joint_type {
            urdf_rs::JointType::Revolute => "revolute",
            urdf_rs::JointType::Fixed => "fixed",
            _ => {
                return Err(urdf_error(
                    path,
                    format!("joint '{}': only revolute and fixed joints are written", j.name),
                ));
            }
        };
        let _ = writeln!(out, "  <joint name=\"{}\" type=\"{kind}\">", j.name);
        let _ = writeln!(out, "    <parent link=\"{}\"/>", j.parent.link);
        let _ = writeln!(out, "    <child link=\"{}\"/>", j.child.link);
        let _ = writeln!(out, "    <origin xyz=\"{}\" rpy=\"{}\"/>", vec3(*j.origin.xyz), vec3(*j.origin.rpy));
        if kind == "revolute" {
            let _ = writeln!(out, "    <axis xyz=\"{}\"/>", vec3(*j.axis.xyz));
            let l = &j.limit;
            let _ = writeln!(
                out,
                "    <limit lower=\"{}\" upper=\"{}\" effort=\"{}\" velocity=\"{}\"/>",
                num(l.lower),
                num(l.upper),
                num(l.effort),
                num(l.velocity)
            );
        }
        let _ = writeln!(out, "  </joint>");
    }
    out.push_str("</robot>\n");
    Ok(out)
}

/// The joints whose parent is `link`, in file order.
fn children_of<'a>(r: &'a urdf_rs::Robot, link: &str) -> Vec<&'a urdf_rs::Joint> {
    r.joints.iter().filter(|j| j.parent.link == link).collect()
}

/// The collision bits of a shape on link `link` of a robot whose left and
/// right legs' joints start with `lleg_` and `rleg_`: (contype, conaffinity).
/// Bit 0 is the floor, 1 the left leg, 2 the right leg, 3 the rest of the body.
fn contact_bits(contact: Contact, side: Option<bool>) -> (u32, u32) {
    const FLOOR: u32 = 1;
    const LEFT: u32 = 2;
    const RIGHT: u32 = 4;
    const REST: u32 = 8;
    let (me, other) = match side {
        Some(true) => (LEFT, RIGHT),
        Some(false) => (RIGHT, LEFT),
        None => (REST, 0),
    };
    match contact {
        Contact::Floor => (me, FLOOR),
        Contact::FloorAndOtherLeg => (me, FLOOR | other),
        Contact::OtherLeg => (me, other),
    }
}

/// The home pose of `robot`'s spec in radians for its joints, in its order.
pub fn home_pose_rad(robot: &Robot) -> Result<Vec<f64>> {
    Ok(robot.spec()?.home_pose_rad(robot))
}

/// How high the trunk origin stands when the lowest corner of any
/// floor-touching shape rests on the ground, in pose `q_rad` (the robot's joint order), metres.
pub fn standing_height_m(robot: &Robot, shapes: &[Shape], q_rad: &[f64]) -> Result<f64> {
    let names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    let poses = robot.link_poses(&names, q_rad)?;
    let mut lowest = f64::INFINITY;
    for s in shapes.iter().filter(|s| s.contact != Contact::OtherLeg) {
        let pose = match robot.joints.iter().position(|j| j.child == s.link) {
            Some(k) => poses[k],
            None => nalgebra::Isometry3::identity(),
        };
        for corner in 0..8 {
            let sign = |bit: usize| if corner >> bit & 1 == 1 { 0.5 } else { -0.5 };
            let p = Point3::new(
                s.centre_m[0] + sign(0) * s.size_m[0],
                s.centre_m[1] + sign(1) * s.size_m[1],
                s.centre_m[2] + sign(2) * s.size_m[2],
            );
            lowest = lowest.min((pose * p).z);
        }
    }
    Ok(-lowest)
}

/// Each link's mass and centre of mass in its own frame, for the robot's joints' child links and the root.
#[derive(Debug, Clone)]
pub struct MassModel {
    root: (f64, Vector3<f64>),
    links: Vec<(f64, Vector3<f64>)>,
}

impl MassModel {
    /// Reads the inertials of URDF `text` for `robot`'s links.
    pub fn from_urdf(robot: &Robot, text: &str, path: &std::path::Path) -> Result<MassModel> {
        let r = urdf_rs::read_from_string(text)
            .map_err(|e| Error::Urdf { path: path.to_owned(), reason: e.to_string() })?;
        let of = |name: &str| -> Result<(f64, Vector3<f64>)> {
            let l = r
                .links
                .iter()
                .find(|l| l.name == name)
                .ok_or_else(|| Error::Urdf { path: path.to_owned(), reason: format!("no link '{name}'") })?;
            Ok((l.inertial.mass.value, Vector3::from(*l.inertial.origin.xyz)))
        };
        let root_name = r
            .links
            .iter()
            .map(|l| l.name.as_str())
            .find(|n| !r.joints.iter().any(|j| j.child.link == *n))
            .ok_or_else(|| Error::Urdf { path: path.to_owned(), reason: "no root link".into() })?;
        Ok(MassModel { root: of(root_name)?, links: robot.joints.iter().map(|j| of(&j.child)).collect::<Result<_>>()? })
    }

    /// Each link's centre of mass and mass in the trunk frame for link `poses` (one per joint).
    pub(crate) fn points(&self, poses: &[Isometry3<f64>], out: &mut Vec<(f64, Vector3<f64>)>) {
        out.clear();
        out.push(self.root);
        for (pose, (m, c)) in poses.iter().zip(&self.links) {
            out.push((*m, (pose * Point3::from(*c)).coords));
        }
    }
}

pub(crate) fn com_of(points: &[(f64, Vector3<f64>)]) -> Vector3<f64> {
    let m: f64 = points.iter().map(|p| p.0).sum();
    points.iter().map(|(mi, c)| c * *mi).sum::<Vector3<f64>>() / m
}

/// The whole body's centre of mass in the trunk frame for pose `q_rad`, metres.
pub fn centre_of_mass_m(robot: &Robot, urdf: &str, path: &Path, q_rad: &[f64]) -> Result<[f64; 3]> {
    let names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    let mut pts = Vec::with_capacity(robot.joints.len() + 1);
    MassModel::from_urdf(robot, urdf, path)?.points(&robot.link_poses(&names, q_rad)?, &mut pts);
    let c = com_of(&pts);
    Ok([c.x, c.y, c.z])
}

/// A MuJoCo scene (MJCF) of the URDF `text` (as [`physical_urdf`] writes
/// it): a floor, the body on a free joint standing in the home pose of its spec (`home_pose_deg`) (keyframe
/// `home`, which also holds the servos' commands), a position servo per
/// revolute joint named after it (force limited to the joint's effort,
/// commands to its range), the soles' contacts with torsional friction,
/// collisions between the legs, and sensors: `imu_quat`, `imu_gyro`,
/// `imu_accel` at the trunk's centre, `lleg_touch`, `rleg_touch` under the soles.
///
/// MuJoCo has no joint speed limit: the 5 rad/s of the URDF is the
/// commander's to keep (cpg's [`crate::Limiter`] keeps every trajectory
/// within it, and `cpg.sim` rate-limits each command).
pub fn mjcf(text: &str, path: &Path, shapes: &[Shape], spec: &crate::RobotSpec) -> Result<String> {
    let r = parse(text, path)?;
    let robot = Robot::from_urdf_str(text, path)?.with_spec(spec.clone())?;
    let settings = &MjcfSettings::of(spec);
    let links: BTreeMap<&str, &urdf_rs::Link> = r.links.iter().map(|l| (l.name.as_str(), l)).collect();
    let roots: Vec<&str> =
        r.links.iter().map(|l| l.name.as_str()).filter(|n| !r.joints.iter().any(|j| j.child.link == *n)).collect();
    let [root] = roots.as_slice() else {
        return Err(urdf_error(path, format!("{} root links ({roots:?}); a robot has one", roots.len())));
    };
    let home = home_pose_rad(&robot)?;
    let height = standing_height_m(&robot, shapes, &home)? + 0.0005;
    let mut out = mjcf_header(&r.name, settings);
    let ctx = Ctx { urdf: &r, links: &links, shapes, path, trunk: root };
    for l in &r.links {
        shapes_of(shapes, &l.name, path)?;
    }
    let _ = writeln!(out, "    <body name=\"{root}\" pos=\"0 0 {}\">", num(height));
    let _ = writeln!(out, "      <freejoint name=\"root\"/>");
    body(&mut out, &ctx, root, None, 3)?;
    let _ = writeln!(out, "    </body>");
    let _ = writeln!(out, "  </worldbody>");
    mjcf_actuators_and_sensors(&mut out, &r, shapes);
    mjcf_keyframe(&mut out, &r, &robot, root, &home, height);
    out.push_str("</mujoco>\n");
    Ok(out)
}

/// The MJCF's opening: the model, the compiler, the defaults, the floor.
fn mjcf_header(name: &str, s: &MjcfSettings) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "<!-- The {} in MuJoCo, written by `cargo xtask hoap2-model` from assets/hoap2/hoap2.urdf\n     \
         (cpg-robot's physics module; docs/hoap2-model.md states every setting). Servo stiffness,\n     \
         damping, armature, joint friction and the floor's friction are ours, not the sources'.\n     \
         The 5 rad/s speed limit is the commander's to keep: MuJoCo has none. -->",
        name
    );
    let _ = writeln!(out, "<mujoco model=\"{}\">", name);
    let _ = writeln!(out, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
    let _ = writeln!(out, "  <option timestep=\"{}\" integrator=\"implicitfast\"/>", num(s.timestep_s));
    let _ = writeln!(out, "  <default>");
    let _ = writeln!(
        out,
        "    <joint armature=\"{}\" damping=\"{}\"/>",
        num(s.armature_kg_m2),
        num(s.damping_nm_s_per_rad)
    );
    let _ = writeln!(
        out,
        "    <geom friction=\"{} {} 0.0001\" rgba=\"0.75 0.77 0.8 1\"/>",
        num(s.sliding_friction),
        num(s.torsional_friction_m)
    );
    let _ = writeln!(out, "    <position kp=\"{}\" kv=\"{}\"/>", num(s.kp_nm_per_rad), num(s.kv_nm_s_per_rad));
    let _ = writeln!(out, "  </default>");
    let _ = writeln!(out, "  <worldbody>");
    let _ = writeln!(out, "    <light pos=\"0 0 3\" dir=\"0 0 -1\" directional=\"true\"/>");
    let _ = writeln!(
        out,
        "    <geom name=\"floor\" type=\"plane\" size=\"0 0 0.05\" contype=\"1\" conaffinity=\"0\" rgba=\"0.55 0.6 0.55 1\"/>"
    );

    out
}

/// What building a body needs.
struct Ctx<'a> {
    urdf: &'a urdf_rs::Robot,
    links: &'a BTreeMap<&'a str, &'a urdf_rs::Link>,
    shapes: &'a [Shape],
    path: &'a Path,
    trunk: &'a str,
}
/// One body: its inertial, shapes and sites, then its children.
fn body(out: &mut String, ctx: &Ctx, link: &str, side: Option<bool>, depth: usize) -> Result<()> {
    let pad = "  ".repeat(depth);
    let l = ctx.links.get(link).ok_or_else(|| urdf_error(ctx.path, format!("no link '{link}'")))?;
    let i = &l.inertial;
    let _ = writeln!(
        out,
        "{pad}<inertial pos=\"{}\" mass=\"{}\" fullinertia=\"{} {} {} {} {} {}\"/>",
        vec3(*i.origin.xyz),
        num(i.mass.value),
        num(i.inertia.ixx),
        num(i.inertia.iyy),
        num(i.inertia.izz),
        num(i.inertia.ixy),
        num(i.inertia.ixz),
        num(i.inertia.iyz)
    );
    for s in ctx.shapes.iter().filter(|s| s.link == link) {
        let (contype, conaffinity) = contact_bits(s.contact, side);
        let sole = !s.carries_mass;
        let size = s.size_m.map(|v| v / 2.0);
        let _ = writeln!(
            out,
            "{pad}<geom name=\"{}\" type=\"box\" size=\"{}\" pos=\"{}\" contype=\"{contype}\" conaffinity=\"{conaffinity}\"{}/>",
            s.name,
            vec3(size),
            vec3(s.centre_m),
            if sole { " condim=\"4\" rgba=\"0.2 0.2 0.25 1\"" } else { "" }
        );
        if sole {
            // The touch sensor's volume: the sole and a millimetre below it.
            let side_name = s.name.trim_end_matches("_sole");
            let _ = writeln!(
                out,
                "{pad}<site name=\"{side_name}_touch\" type=\"box\" size=\"{}\" pos=\"{}\" rgba=\"0 0 0 0\"/>",
                vec3([size[0] + 0.001, size[1] + 0.001, size[2] + 0.001]),
                vec3(s.centre_m)
            );
        }
    }
    if link == ctx.trunk {
        let centre = ctx.shapes.iter().find(|s| s.link == link && s.carries_mass).map_or([0.0; 3], |s| s.centre_m);
        let _ = writeln!(out, "{pad}<site name=\"imu\" pos=\"{}\" size=\"0.005\"/>", vec3(centre));
    }
    for j in children_of(ctx.urdf, link) {
        let side = side.or(if j.name.starts_with("lleg_") {
            Some(true)
        } else if j.name.starts_with("rleg_") {
            Some(false)
        } else {
            None
        });
        let rpy = *j.origin.rpy;
        let q = UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        let quat = if rpy == [0.0; 3] {
            String::new()
        } else {
            format!(" quat=\"{} {} {} {}\"", num(q.w), num(q.i), num(q.j), num(q.k))
        };
        let _ = writeln!(out, "{pad}<body name=\"{}\" pos=\"{}\"{quat}>", j.child.link, vec3(*j.origin.xyz));
        if j.joint_type == urdf_rs::JointType::Revolute {
            let _ = writeln!(
                out,
                "{pad}  <joint name=\"{}\" axis=\"{}\" range=\"{} {}\"/>",
                j.name,
                vec3(*j.axis.xyz),
                num(j.limit.lower),
                num(j.limit.upper)
            );
        }
        body(out, ctx, &j.child.link, side, depth + 1)?;
        let _ = writeln!(out, "{pad}</body>");
    }
    Ok(())
}

/// The position servos and the sensors (IMU, sole touch).
fn mjcf_actuators_and_sensors(out: &mut String, r: &urdf_rs::Robot, shapes: &[Shape]) {
    let _ = writeln!(out, "  <actuator>");
    for j in r.joints.iter().filter(|j| j.joint_type == urdf_rs::JointType::Revolute) {
        let _ = writeln!(
            out,
            "    <position name=\"{0}\" joint=\"{0}\" ctrlrange=\"{1} {2}\" forcerange=\"-{3} {3}\"/>",
            j.name,
            num(j.limit.lower),
            num(j.limit.upper),
            num(j.limit.effort)
        );
    }
    let _ = writeln!(out, "  </actuator>");
    let _ = writeln!(out, "  <sensor>");
    let _ = writeln!(out, "    <framequat name=\"imu_quat\" objtype=\"site\" objname=\"imu\"/>");
    let _ = writeln!(out, "    <gyro name=\"imu_gyro\" site=\"imu\"/>");
    let _ = writeln!(out, "    <accelerometer name=\"imu_accel\" site=\"imu\"/>");
    for s in shapes.iter().filter(|s| !s.carries_mass) {
        let side_name = s.name.trim_end_matches("_sole");
        let _ = writeln!(out, "    <touch name=\"{side_name}_touch\" site=\"{side_name}_touch\"/>");
    }
    let _ = writeln!(out, "  </sensor>");
}

/// The `home` keyframe: qpos in body order (depth first), ctrl in actuator order.
fn mjcf_keyframe(out: &mut String, r: &urdf_rs::Robot, robot: &Robot, root: &str, home: &[f64], height: f64) {
    let mut order = Vec::new();
    fn dfs<'a>(r: &'a urdf_rs::Robot, link: &str, order: &mut Vec<&'a str>) {
        for j in children_of(r, link) {
            if j.joint_type == urdf_rs::JointType::Revolute {
                order.push(j.name.as_str());
            }
            dfs(r, &j.child.link, order);
        }
    }
    dfs(r, root, &mut order);
    let angle = |name: &str| robot.joints.iter().position(|j| j.name == name).map_or(0.0, |k| home[k]);
    let qpos: Vec<String> = order.iter().map(|n| num(angle(n))).collect();
    let ctrl: Vec<String> =
        r.joints.iter().filter(|j| j.joint_type == urdf_rs::JointType::Revolute).map(|j| num(angle(&j.name))).collect();
    let _ = writeln!(out, "  <keyframe>");
    let _ = writeln!(
        out,
        "    <key name=\"home\" qpos=\"0 0 {} 1 0 0 0 {}\" ctrl=\"{}\"/>",
        num(height),
        qpos.join(" "),
        ctrl.join(" ")
    );
    let _ = writeln!(out, "  </keyframe>");
}

/// The derivation as a Markdown table (each link's mass, box, density, centre
/// of mass and inertia) and the whole body's figures in the home crouch, for
/// `docs/hoap2-model.md`.
pub fn derivation_markdown(text: &str, path: &Path, shapes: &[Shape], spec: &crate::RobotSpec) -> Result<String> {
    let r = parse(text, path)?;
    let robot = Robot::from_urdf_str(text, path)?.with_spec(spec.clone())?;
    let mut out = String::new();
    out.push_str("| link | mass (kg) | box x × y × z (mm) | centre of mass (mm) | density (kg/m³) | Ixx, Iyy, Izz (kg·m²) | box from |\n");
    out.push_str("|---|---:|---|---|---:|---|---|\n");
    let mm = |v: [f64; 3]| format!("{}, {}, {}", num(v[0] * 1e3), num(v[1] * 1e3), num(v[2] * 1e3));
    for link in &r.links {
        let m = link.inertial.mass.value;
        let (s, _) = shapes_of(shapes, &link.name, path)?;
        let volume = s.size_m.iter().product::<f64>();
        let i = box_inertia(m, s.size_m);
        let _ = writeln!(
            out,
            "| {} | {} | {} × {} × {} | {} | {:.0} | {:.3e}, {:.3e}, {:.3e} | {} |",
            link.name,
            num(m),
            num(s.size_m[0] * 1e3),
            num(s.size_m[1] * 1e3),
            num(s.size_m[2] * 1e3),
            mm(s.centre_m),
            m / volume,
            i[0],
            i[1],
            i[2],
            s.source
        );
    }
    for s in shapes.iter().filter(|s| !s.carries_mass) {
        let _ = writeln!(
            out,
            "| {} (collision only) | | {} × {} × {} | centre {} | | | {} |",
            s.name,
            num(s.size_m[0] * 1e3),
            num(s.size_m[1] * 1e3),
            num(s.size_m[2] * 1e3),
            mm(s.centre_m),
            s.source
        );
    }
    let home = home_pose_rad(&robot)?;
    let height = standing_height_m(&robot, shapes, &home)?;
    let com = centre_of_mass_m(&robot, text, path, &home)?;
    let names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    let poses = robot.link_poses(&names, &home)?;
    let sole = |link: &str| -> Option<[f64; 2]> {
        let s = shapes.iter().find(|s| s.link == link && !s.carries_mass)?;
        let k = robot.joints.iter().position(|j| j.child == link)?;
        let p = poses[k] * Point3::from(s.centre_m);
        Some([p.x, p.y])
    };
    let _ = writeln!(out, "\nIn the home crouch (`home_pose_deg` of `assets/hoap2/robot.toml`):\n");
    let _ = writeln!(
        out,
        "- total mass {} kg; the trunk origin {} mm above the floor;",
        num(robot.mass_kg),
        num(height * 1e3)
    );
    let _ = writeln!(
        out,
        "- the centre of mass {} mm above the floor, {} mm forward of and {} mm left of the trunk origin;",
        num(((height + com[2]) * 1e3 * 10.0).round() / 10.0),
        num((com[0] * 1e3 * 10.0).round() / 10.0),
        num((com[1] * 1e3 * 10.0).round() / 10.0)
    );
    if let (Some(l), Some(rt)) = (sole("lleg_link6"), sole("rleg_link6")) {
        let mid = [(l[0] + rt[0]) / 2.0, (l[1] + rt[1]) / 2.0];
        let _ = writeln!(
            out,
            "- its ground projection {} mm behind the soles' midpoint (the soles reach {} mm fore and aft of their centres).",
            num(((mid[0] - com[0]) * 1e3 * 10.0).round() / 10.0),
            num(shapes.iter().find(|s| !s.carries_mass).map_or(0.0, |s| s.size_m[0] / 2.0 * 1e3))
        );
    }
    Ok(out)
}

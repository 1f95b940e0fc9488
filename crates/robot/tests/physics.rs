//! The physical HOAP-2: the committed URDF and MJCF are what the physics
//! module writes, each link's inertial follows from its box, and the home
//! crouch stands over its soles.

use std::path::Path;

use cpg_robot::Robot;
use cpg_robot::assets::{HOAP2_MJCF, HOAP2_URDF};
use cpg_robot::physics::{
    Contact, Shape, box_inertia, centre_of_mass_m, home_pose_rad, mjcf, physical_urdf, standing_height_m,
};

const PATH: &str = "assets/hoap2/hoap2.urdf";

/// The HOAP-2's body, as its spec (`assets/hoap2/robot.toml`) gives it.
fn shapes() -> Vec<Shape> {
    cpg_robot::RobotSpec::hoap2().shapes
}

#[test]
fn the_committed_urdf_is_what_the_shape_table_writes() {
    let again = physical_urdf(HOAP2_URDF, Path::new(PATH), &shapes()).unwrap();
    assert!(again == HOAP2_URDF, "assets/hoap2/hoap2.urdf is stale: run `cargo xtask hoap2-model`");
}

#[test]
fn the_committed_mjcf_is_built_from_the_committed_urdf() {
    let built = mjcf(HOAP2_URDF, Path::new(PATH), &shapes(), &cpg_robot::RobotSpec::hoap2()).unwrap();
    assert!(built == HOAP2_MJCF, "assets/hoap2/hoap2.xml is stale: run `cargo xtask hoap2-model`");
}

#[test]
fn every_link_has_one_massive_box_and_keeps_its_mass() {
    let robot = Robot::hoap2().unwrap();
    // The reference's total (two sole sensors included).
    assert!((robot.mass_kg - 7.15989).abs() < 1e-5, "total mass {} kg", robot.mass_kg);
    let parsed = urdf_rs::read_from_string(HOAP2_URDF).unwrap();
    assert_eq!(parsed.links.len(), 26);
    let all = shapes();
    for link in &parsed.links {
        let solid: Vec<&Shape> = all.iter().filter(|s| s.link == link.name && s.carries_mass).collect();
        assert_eq!(solid.len(), 1, "link {}", link.name);
        let s = solid[0];
        let m = link.inertial.mass.value;
        let want = box_inertia(m, s.size_m);
        let i = &link.inertial.inertia;
        for (got, want) in [i.ixx, i.iyy, i.izz].into_iter().zip(want) {
            assert!((got - want).abs() <= 1e-6 * want, "link {}: inertia {got} against {want}", link.name);
        }
        assert_eq!([i.ixy, i.ixz, i.iyz], [0.0; 3], "link {}", link.name);
        let c = link.inertial.origin.xyz;
        for k in 0..3 {
            assert!((c[k] - s.centre_m[k]).abs() < 1e-9, "link {}: centre {c:?}", link.name);
        }
        // The triangle inequality of a physical inertia.
        assert!(want[0] + want[1] >= want[2] && want[1] + want[2] >= want[0] && want[0] + want[2] >= want[1]);
        assert!(!link.collision.is_empty(), "link {} has no collision shape", link.name);
    }
}

#[test]
fn box_inertia_is_the_textbook_one() {
    // A 1 kg cube of 1 m: m·(1 + 1)/12 about each axis.
    assert_eq!(box_inertia(1.0, [1.0; 3]), [1.0 / 6.0; 3]);
    // A thin rod along z: Izz vanishes, Ixx = Iyy = m·L²/12.
    let rod = box_inertia(3.0, [0.0, 0.0, 2.0]);
    assert_eq!(rod, [1.0, 1.0, 0.0]);
}

#[test]
fn the_soles_are_the_reference_size_and_touch_the_floor() {
    let all = shapes();
    let soles: Vec<&Shape> = all.iter().filter(|s| s.name.ends_with("sole")).collect();
    assert_eq!(soles.len(), 2);
    for s in soles {
        assert_eq!(s.size_m, [0.094, 0.062, 0.005]);
        assert!(!s.carries_mass);
        assert_eq!(s.contact, Contact::FloorAndOtherLeg);
    }
    // The soles' bottoms are the lowest points of the home crouch: the
    // keyframe's height puts them on the floor, the soles flat.
    let robot = Robot::hoap2().unwrap();
    let home = home_pose_rad(&robot).unwrap();
    let all = standing_height_m(&robot, &shapes(), &home).unwrap();
    let soles_only: Vec<Shape> = shapes().iter().filter(|s| s.name.ends_with("sole")).cloned().collect();
    let by_soles = standing_height_m(&robot, &soles_only, &home).unwrap();
    assert!((all - by_soles).abs() < 1e-12, "something hangs below the soles: {all} against {by_soles}");
    assert!((0.25..0.30).contains(&all), "trunk origin {all} m high");
    let spec = robot.spec().unwrap();
    for leg in [&spec.legs.left, &spec.legs.right] {
        let deg = |joint: &str| spec.home_pose_deg.get(joint).copied().unwrap();
        assert_eq!(
            deg(&leg.hip_pitch) + deg(&leg.knee) + deg(&leg.ankle_pitch),
            0.0,
            "the home sole of {leg:?} is not flat"
        );
    }
}

#[test]
fn the_home_centre_of_mass_is_over_the_soles() {
    let robot = Robot::hoap2().unwrap();
    let home = home_pose_rad(&robot).unwrap();
    let c = centre_of_mass_m(&robot, HOAP2_URDF, Path::new(PATH), &home).unwrap();
    // The soles' centres in the trunk frame.
    let names: Vec<String> = robot.joints.iter().map(|j| j.name.clone()).collect();
    let poses = robot.link_poses(&names, &home).unwrap();
    let all = shapes();
    let sole = all.iter().find(|s| s.name == "lleg_sole").unwrap();
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for foot in ["lleg_link6", "rleg_link6"] {
        let k = robot.joints.iter().position(|j| j.child == foot).unwrap();
        let p = poses[k] * nalgebra::Point3::from(sole.centre_m);
        xs.push(p.x);
        ys.push(p.y);
    }
    let half = [sole.size_m[0] / 2.0, sole.size_m[1] / 2.0];
    assert!((c[0] - xs[0]).abs() < half[0] - 0.02, "CoM x {} vs sole centre {}: under 2 cm of margin", c[0], xs[0]);
    assert!(c[1] > ys[1] - half[1] && c[1] < ys[0] + half[1], "CoM y {} outside the soles", c[1]);
    // The reference's left and right links differ by up to 2.4 g: the CoM
    // sits a few hundredths of a millimetre off the midline, no more.
    assert!(c[1].abs() < 1e-4, "a symmetric pose has its CoM off the midline: {} m", c[1]);
}

#[test]
fn a_link_without_a_shape_is_an_error_naming_it() {
    let headless: Vec<Shape> = shapes().iter().filter(|s| s.link != "head").cloned().collect();
    let e = physical_urdf(HOAP2_URDF, Path::new(PATH), &headless).unwrap_err().to_string();
    assert!(e.contains("head") && e.contains(PATH), "{e}");
    let e =
        mjcf("<robot", Path::new("broken.urdf"), &shapes(), &cpg_robot::RobotSpec::hoap2()).unwrap_err().to_string();
    assert!(e.contains("broken.urdf"), "{e}");
}

#[test]
fn the_mjcf_has_a_servo_per_joint_within_the_limits() {
    let robot = Robot::hoap2().unwrap();
    assert_eq!(robot.joints.len(), 25);
    for j in &robot.joints {
        let tag = format!("<position name=\"{}\" joint=\"{}\"", j.name, j.name);
        let line = HOAP2_MJCF.lines().find(|l| l.contains(&tag)).unwrap_or_else(|| panic!("no servo for {}", j.name));
        assert!(line.contains("forcerange=\"-9 9\""), "{line}");
    }
    assert!(HOAP2_MJCF.contains("<position name=\"body_joint_1\""), "the waist has no servo");
    assert!(HOAP2_MJCF.contains("condim=\"4\""), "no torsional friction on the soles");
    for sensor in ["imu_quat", "imu_gyro", "imu_accel", "lleg_touch", "rleg_touch"] {
        assert!(HOAP2_MJCF.contains(&format!("name=\"{sensor}\"")), "no sensor {sensor}");
    }
}

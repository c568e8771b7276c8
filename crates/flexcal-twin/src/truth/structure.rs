//! The twin's own elastic structure: a frame finite-element model of the
//! IR-663 written for the twin alone, not derived from the beam model that
//! flexcal identifies (`flexcal_elastic`'s built-in `ir663`, the paper's
//! Figure 8), and richer than it:
//! - its own mesh: each link is split at mid-length (column, upper arm,
//!   crank, coupler, forearm to the wrist centre W), the forearm carries a
//!   rear extension behind the elbow with the wrist motors, the wrist runs
//!   from W to the TCP;
//! - its own sections: steel boxes and tubes of the twin's choosing (the
//!   paper publishes none; all plausible for a 1980s 120-kg-class arm);
//! - joints 2 and 8 are ball screws modelled as axial springs between their
//!   slider-crank pivots, on stiff levers, so that their stiffness about
//!   the joint is `k_screw h(q)^2` with the lever arm `h` of the screw
//!   ([`screw_lever_arm`]), which changes with the configuration (the
//!   refinement the paper itself proposes in section 3.3.1 and Figure A.19);
//! - its joint bearings are finite in every direction (radial 5e9 N/m,
//!   axial 5e9 N/m, tilting 1e8 N.m/rad: large crossed-roller and tapered
//!   bearing pairs), passive joints turn freely;
//! - its own weight: the beams' steel, 75 kg of wrist motors behind the
//!   elbow, a 100 kg wrist at W and a 20 kg flange and tool at the TCP
//!   (the 120 kg wrist of the issue).
//!
//! The screws' axial stiffness was set so that an earlier twin, the
//! identified beam model with screws, deflected by the paper's measured
//! 1.6-2.5 mm under 1100 N vertical over the grid (section 3.3.1, Figure
//! 9). With this structure and the drives' compliance in series
//! ([`drive`](super::drive)) the twin deflects by 0.6 to 2.1 mm: as much as
//! the real robot far from the base axis, three times stiffer near it,
//! where a vertical load bends nothing soft in the twin (the paper's own
//! beam model is too stiff there as well, and it blames the slider
//! cranks). The figures are published as they are, not fitted.

use flexcal_elastic::description::{
    BeamDescription, ElasticDescription, JointDescription, NodeDescription, PointMassDescription,
    STEEL_DENSITY, SectionDescription, SpringDescription, SupportDescription,
};
use flexcal_kinematics::RobotDescription;
use nalgebra::Vector3;

/// Axial stiffness of the joint 2 ball screw (N/m): with its lever arm of
/// 0.22-0.35 m over the grid, `k h^2` is 2e6 to 5e6 N.m/rad, the magnitude of
/// the paper's Table 3 joint stiffness (1.72e6).
pub const SCREW_2_STIFFNESS: f64 = 4.2e7;
/// Axial stiffness of the joint 8 ball screw (N/m), chosen like
/// [`SCREW_2_STIFFNESS`] (Table 3: 1.56e6 N.m/rad).
pub const SCREW_8_STIFFNESS: f64 = 5.5e7;
/// Radial and axial stiffness of the twin's joint bearings (N/m).
pub const BEARING_STIFFNESS: f64 = 5e9;
/// Tilting stiffness of the twin's joint bearings (N.m/rad).
pub const BEARING_TILT_STIFFNESS: f64 = 1e8;
/// Mass of the wrist lumped at its centre W (kg).
pub const WRIST_MASS_KG: f64 = 100.0;
/// Mass of the flange and tool lumped at the TCP (kg).
pub const TOOL_MASS_KG: f64 = 20.0;
/// Mass of the three wrist motors behind the elbow (kg).
pub const WRIST_MOTORS_MASS_KG: f64 = 75.0;

/// The lever arm `h = l1 l3 sin(phi) / r'` of a slider-crank screw about
/// its joint, in the unit of `l1` and `l3`, from the crank geometry and the
/// joint angle (rad).
pub fn screw_lever_arm(l1: f64, l3: f64, kappa: f64, lambda: f64, joint_angle: f64) -> f64 {
    let phi = joint_angle - lambda + kappa;
    let screw = (l1 * l1 + l3 * l3 - 2.0 * l1 * l3 * phi.cos()).sqrt();
    l1 * l3 * phi.sin().abs() / screw
}

/// Slider-crank geometry of a frame of `robot` (mm, deg):
/// `(l1, l3, kappa, lambda)`, zeros when the frame has none.
pub fn crank(robot: &RobotDescription, frame: &str) -> (f64, f64, f64, f64) {
    let f = robot.frames.iter().find(|f| f.name == frame);
    match f.and_then(|f| f.slider_crank) {
        Some(c) => (c.l1_mm, c.l3_mm, c.kappa_deg, c.lambda_deg),
        None => (0.0, 0.0, 0.0, 0.0),
    }
}

fn node(name: &str, frame: &str, offset_mm: [f64; 3]) -> NodeDescription {
    NodeDescription {
        name: name.into(),
        frame: frame.into(),
        offset_mm,
    }
}

/// A steel beam whose local x-z plane contains `vecxz` given in `frame`.
fn beam(
    name: &str,
    i: &str,
    j: &str,
    section: SectionDescription,
    vecxz: [f64; 3],
    frame: &str,
) -> BeamDescription {
    BeamDescription {
        name: name.into(),
        i: i.into(),
        j: j.into(),
        section,
        vecxz,
        vecxz_frame: Some(frame.into()),
        mass_per_length_kg_m: section.area_m2 * STEEL_DENSITY,
    }
}

fn joint(name: &str, i: &str, j: &str, axis_frame: &str, kar: f64) -> JointDescription {
    JointDescription {
        name: name.into(),
        i: i.into(),
        j: j.into(),
        axis_frame: axis_frame.into(),
        ka_n_m: BEARING_STIFFNESS,
        kr_n_m: BEARING_STIFFNESS,
        kar_nm_rad: kar,
        krr_nm_rad: BEARING_TILT_STIFFNESS,
        identify: Vec::new(),
    }
}

/// The twin's elastic structure (see the module documentation), for the
/// built-in `ir663` kinematics `robot`.
pub fn twin_structure(robot: &RobotDescription) -> ElasticDescription {
    let normal = [0.0, 0.0, 1.0];
    // Half lengths of the links (mm), from the nominal geometry of Table 2.
    let column_half = 885.0 / 2.0;
    let upper_arm_half = 1047.0 / 2.0;
    let forearm_half = 1760.0 / 2.0;
    let crank_half = 473.0 / 2.0;
    let coupler_half = 1212.0 / 2.0;
    let mut nodes = vec![
        node("0", "0", [0.0; 3]),
        node("C", "0", [0.0, 0.0, column_half]),
        node("1", "1", [0.0; 3]),
        node("2", "2", [0.0; 3]),
        node("U", "2", [upper_arm_half, 0.0, 0.0]),
        node("3", "3", [0.0; 3]),
        node("3'", "3", [0.0; 3]),
        // Wrist motors 250 mm behind the elbow, on the forearm's axis (z4).
        node("M", "4", [0.0, 0.0, -1760.0 - 250.0]),
        node("F", "4", [0.0, 0.0, -forearm_half]),
        node("W", "4", [0.0; 3]),
        node("E", "E", [0.0; 3]),
        node("10", "10", [0.0; 3]),
        node("8", "8", [0.0; 3]),
        node("K", "8", [crank_half, 0.0, 0.0]),
        node("9", "9", [0.0; 3]),
        node("9'", "9", [0.0; 3]),
        node("L", "9", [coupler_half, 0.0, 0.0]),
        node("10'", "10", [0.0; 3]),
    ];
    let column = SectionDescription::steel_tube(0.55, 0.025);
    let upper_arm = SectionDescription::steel_box(0.38, 0.26, 0.018);
    let forearm_root = SectionDescription::steel_box(0.28, 0.22, 0.014);
    let forearm_tip = SectionDescription::steel_box(0.24, 0.2, 0.012);
    let crank_section = SectionDescription::steel_box(0.16, 0.11, 0.02);
    let coupler = SectionDescription::steel_tube(0.11, 0.012);
    let wrist = SectionDescription::steel_box(0.22, 0.22, 0.02);
    let mut beams = vec![
        beam("0C", "0", "C", column, [1.0, 0.0, 0.0], "1"),
        beam("C1", "C", "1", column, [1.0, 0.0, 0.0], "1"),
        beam("2U", "2", "U", upper_arm, normal, "2"),
        beam("U3", "U", "3", upper_arm, normal, "2"),
        beam("3'M", "3'", "M", forearm_root, normal, "3"),
        beam("3'F", "3'", "F", forearm_root, normal, "3"),
        beam("FW", "F", "W", forearm_tip, normal, "3"),
        beam("3'10", "3'", "10", forearm_root, normal, "3"),
        beam("WE", "W", "E", wrist, [1.0, 0.0, 0.0], "E"),
        beam("8K", "8", "K", crank_section, normal, "8"),
        beam("K9", "K", "9", crank_section, normal, "8"),
        beam("9'L", "9'", "L", coupler, normal, "9"),
        beam("L10'", "L", "10'", coupler, normal, "9"),
    ];
    let mut joints = vec![
        // Joints 2 and 8 turn freely: their screws hold them.
        joint("12", "1", "2", "2", 0.0),
        joint("18", "1", "8", "8", 0.0),
        joint("33'", "3", "3'", "3", 0.0),
        joint("99'", "9", "9'", "9", 0.0),
        joint("1010'", "10", "10'", "10", 0.0),
    ];
    let mut springs = Vec::new();
    let lever = SectionDescription::steel_box(0.4, 0.3, 0.05);
    for (joint_name, antecedent_alpha_deg, theta_const_deg, k_screw) in [
        ("2", -90.0f64, -90.0f64, SCREW_2_STIFFNESS),
        ("8", -90.0, 0.0, SCREW_8_STIFFNESS),
    ] {
        let (l1, l3, kappa, lambda) = crank(robot, joint_name);
        let (kappa, lambda) = (kappa.to_radians(), lambda.to_radians());
        // Pivot A on the driven body, in the joint's frame.
        let a = [l1 * kappa.cos(), l1 * kappa.sin(), 0.0];
        // Pivot B on frame 1, at lambda from the joint frame's x axis at
        // zero joint angle: frame 1 -> Rx(alpha) Rz(theta_const).
        let rot = nalgebra::Rotation3::from_axis_angle(
            &Vector3::x_axis(),
            antecedent_alpha_deg.to_radians(),
        ) * nalgebra::Rotation3::from_axis_angle(
            &Vector3::z_axis(),
            theta_const_deg.to_radians(),
        );
        let b = rot * Vector3::new(l3 * lambda.cos(), l3 * lambda.sin(), 0.0);
        let (node_a, node_b) = (format!("A{joint_name}"), format!("B{joint_name}"));
        nodes.push(node(&node_a, joint_name, a));
        nodes.push(node(&node_b, "1", [b.x, b.y, b.z]));
        let mut lever_a = beam(
            &format!("lever{node_a}"),
            joint_name,
            &node_a,
            lever,
            normal,
            joint_name,
        );
        let mut lever_b = beam(
            &format!("lever{node_b}"),
            "1",
            &node_b,
            lever,
            normal,
            joint_name,
        );
        // The levers are part of the castings already weighed with the links.
        lever_a.mass_per_length_kg_m = 0.0;
        lever_b.mass_per_length_kg_m = 0.0;
        beams.push(lever_a);
        beams.push(lever_b);
        springs.push(SpringDescription {
            name: format!("screw{joint_name}"),
            i: node_a,
            j: node_b,
            k_n_m: k_screw,
        });
    }
    // Keep the joint list's order stable for readers of the TOML.
    joints.sort_by(|a, b| a.name.cmp(&b.name));
    ElasticDescription {
        name: "ir663-twin".into(),
        notes: "Truth of the virtual IR-663 (flexcal-twin): its own mesh and sections, ball screws \
                as axial springs between the slider-crank pivots of joints 2 and 8, finite bearing \
                stiffness, wrist motors behind the elbow, 100 kg wrist at W and 20 kg tool at E. Not \
                the identified beam model."
            .into(),
        tcp: "E".into(),
        gravity_m_s2: [0.0, 0.0, -9.80665],
        nodes,
        beams,
        joints,
        springs,
        supports: vec![SupportDescription {
            node: "0".into(),
            fixed: [true; 6],
        }],
        point_masses: vec![
            PointMassDescription {
                node: "M".into(),
                mass_kg: WRIST_MOTORS_MASS_KG,
            },
            PointMassDescription {
                node: "W".into(),
                mass_kg: WRIST_MASS_KG,
            },
            PointMassDescription {
                node: "E".into(),
                mass_kg: TOOL_MASS_KG,
            },
        ],
    }
}

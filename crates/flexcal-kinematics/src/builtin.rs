//! Built-in robots.

use crate::KinematicsError;
use crate::description::{
    CouplingTerm, FrameDescription, JointType, LoopConstraint, LoopDescription, LoopSolver,
    RobotDescription, SliderCrankDescription, TransformDescription,
};

const NAMES: &[&str] = &["ur10", "ir663", "puma560"];

/// Names accepted by [`RobotDescription::builtin`].
pub fn builtin_robot_names() -> &'static [&'static str] {
    NAMES
}

impl RobotDescription {
    /// A built-in robot by name (see [`builtin_robot_names`]).
    pub fn builtin(name: &str) -> Result<Self, KinematicsError> {
        builtin(name)
    }
}

fn builtin(name: &str) -> Result<RobotDescription, KinematicsError> {
    match name {
        "ur10" => Ok(ur10()),
        "ir663" => Ok(ir663()),
        "puma560" => Ok(puma560()),
        _ => Err(KinematicsError::UnknownRobot {
            name: name.to_string(),
            known: NAMES.join(", "),
        }),
    }
}

fn revolute(
    name: &str,
    antecedent: &str,
    alpha_deg: f64,
    d_mm: f64,
    r_mm: f64,
) -> FrameDescription {
    let mut f = FrameDescription::new(name, antecedent, JointType::Revolute);
    f.actuated = true;
    f.alpha_deg = alpha_deg;
    f.d_mm = d_mm;
    f.r_mm = r_mm;
    f
}

fn with_limits(mut f: FrameDescription, lo: f64, hi: f64) -> FrameDescription {
    f.limits_deg = Some([lo, hi]);
    f
}

/// Universal Robots UR10, nominal standard DH rewritten in modified DH.
fn ur10() -> RobotDescription {
    // Standard DH (m): d1 = 0.1273, a2 = -0.612, a3 = -0.5723, d4 = 0.163941,
    // d5 = 0.1157, d6 = 0.0922, alpha = [pi/2, 0, 0, pi/2, -pi/2, 0]. Grouping
    // Rz(theta_i) Tz(d_i) | Tx(a_i) Rx(alpha_i) Rz(theta_{i+1}) Tz(d_{i+1}) gives
    // KK frames with alpha_i = DH alpha_{i-1}, d_i = DH a_{i-1}, r_i = DH d_i,
    // and the last Tx(a6) Rx(alpha6) = identity, so frame 6 is the DH flange.
    let mut frames = vec![
        revolute("1", "0", 0.0, 0.0, 127.3),
        revolute("2", "1", 90.0, 0.0, 0.0),
        revolute("3", "2", 0.0, -612.0, 0.0),
        revolute("4", "3", 0.0, -572.3, 163.941),
        revolute("5", "4", 90.0, 0.0, 115.7),
        revolute("6", "5", -90.0, 0.0, 92.2),
    ];
    for f in frames.iter_mut() {
        f.limits_deg = Some([-360.0, 360.0]);
    }
    // Joints 2, 3, 4 are parallel: Hayati beta instead of r (the z offsets
    // r2, r3, r4 of parallel axes are one and the same translation).
    frames[2].beta_deg = Some(0.0);
    frames[3].beta_deg = Some(0.0);
    RobotDescription {
        name: "ur10".into(),
        notes: "Universal Robots UR10, published nominal DH values rewritten in Khalil-Kleinfinger \
                (modified DH) form; base = DH base frame, end frame 6 = DH flange. Joints 2-4 parallel: \
                beta3, beta4 replace r3, r4 in xi."
            .into(),
        end_frame: None,
        parameters: None,
        actuated_order: None,
        base: TransformDescription::default(),
        tool: TransformDescription::default(),
        frames,
        loops: Vec::new(),
        links: Vec::new(),
    }
}

/// PUMA-560-like arm: Craig's modified DH table with the values distributed
/// in Corke's toolbox (a2 = 431.8 mm, d3 = 150.05 mm, a3 = 20.3 mm, d4 = 431.8 mm).
fn puma560() -> RobotDescription {
    let mut frames = vec![
        with_limits(revolute("1", "0", 0.0, 0.0, 0.0), -160.0, 160.0),
        with_limits(revolute("2", "1", -90.0, 0.0, 0.0), -225.0, 45.0),
        with_limits(revolute("3", "2", 0.0, 431.8, 150.05), -45.0, 225.0),
        with_limits(revolute("4", "3", -90.0, 20.3, 431.8), -110.0, 170.0),
        with_limits(revolute("5", "4", 90.0, 0.0, 0.0), -100.0, 100.0),
        with_limits(revolute("6", "5", -90.0, 0.0, 0.0), -266.0, 266.0),
    ];
    // Joints 2 and 3 are parallel.
    frames[2].beta_deg = Some(0.0);
    let mut tool = FrameDescription::new("E", "6", JointType::Fixed);
    tool.r_mm = 56.25;
    frames.push(tool);
    RobotDescription {
        name: "puma560".into(),
        notes:
            "PUMA-560-like arm, Craig's modified DH table (values as in Corke's Robotics Toolbox): \
                a2 = 431.8, d3 = 150.05, a3 = 20.3, d4 = 431.8 mm; flange E 56.25 mm along z6. \
                Joints 2-3 parallel: beta3 replaces r3."
                .into(),
        end_frame: None,
        parameters: None,
        actuated_order: None,
        base: TransformDescription::default(),
        tool: TransformDescription::default(),
        frames,
        loops: Vec::new(),
        links: Vec::new(),
    }
}

/// Slider-crank geometry chosen for the IR-663 (the paper gives none).
pub(crate) const IR663_CRANK_2: SliderCrankDescription = SliderCrankDescription {
    screw_offset_mm: 0.0,
    kappa_deg: 10.0,
    lambda_deg: -102.0,
    l1_mm: 350.0,
    l3_mm: 850.0,
    branch: 1,
};

pub(crate) const IR663_CRANK_8: SliderCrankDescription = SliderCrankDescription {
    screw_offset_mm: 0.0,
    kappa_deg: 5.0,
    lambda_deg: -55.0,
    l1_mm: 300.0,
    l3_mm: 800.0,
    branch: 1,
};

/// KUKA IR-663 after the reference paper: Table 1 / Table 2 with the
/// reading-notes corrections.
///
/// Reachable domain. The four-bar (joints 2 = 8, 3, 9, 10) closes only while
/// joint 10 stays at least d11 - d9 = 739 mm from the common axis of joints
/// 2 and 8: at that distance the crank (d9) and the coupler (d11) are in line
/// (joint 9 at -180 deg, the crank's dead centre). Joint 10 lies d10 = 400 mm
/// from joint 3 on the forearm, towards the wrist (Table 1: gamma10 = 90 deg
/// and row 4's r = r4 + d10), so the elbow cannot fold below 32.0 deg
/// between the upper arm (d3 = 1047 mm) and the forearm, and the wrist
/// centre (r4 + d10 = 2160 mm from joint 3) stays at least 1.388 m from the
/// shoulder. With the tool pointing down the wrist centre is rE = 244 mm
/// above the TCP, so the TCP needs z >= 1.245 m at x = 1.25 m (z >= 0.965 m
/// at x = 1.35 m, y = 0). This follows from Table 2's lengths alone: no
/// slider-crank geometry, joint limit or assembly branch changes it. Box
/// (59) (tool down) is reached with theta2 in about [-47, -1] deg and theta8
/// in about [13, 27] deg; the plane y = 0 of box (65) with theta2 in about
/// [-60, 14] deg and theta8 in about [-2, 46] deg (screws 690-1095 mm and
/// 690-930 mm, within their limits), except its three grid points at
/// x = 1.25 m, z <= 1.175 m, where the wrist centre would be 1.267-1.359 m
/// from the shoulder: there the tool must lean back towards the base (by
/// 20-45 deg to keep joint 9 about 10 deg off its dead centre) or the point
/// move out along x (to x = 1.32-1.41 m).
/// The assembly branch is the paper's: its combination
/// `dd10_id = dd10 - 0.82 dd9`, `dd11_id = dd11 - 0.39 dd9` (C.1) is a null
/// direction of this branch (about 0.02 mm of TCP motion per mm in box (59),
/// against 4 mm for d9 alone) and not of the other one.
fn ir663() -> RobotDescription {
    let mut f1 = revolute("1", "0", 0.0, 0.0, 885.0);
    f1.limits_deg = Some([-150.0, 150.0]);
    let mut f2 = revolute("2", "1", -90.0, 0.0, 0.0);
    f2.theta_deg = -90.0;
    f2.slider_crank = Some(IR663_CRANK_2);
    f2.limits_mm = Some([640.0, 1140.0]);
    let mut f3 = FrameDescription::new("3", "2", JointType::Revolute);
    f3.d_mm = 1047.0;
    f3.beta_deg = Some(0.0);
    f3.seed_deg = 35.0;
    let mut f4 = revolute("4", "3", -90.0, 0.0, 1760.0);
    f4.theta_deg = -90.0;
    f4.plus.insert("r".into(), vec!["d10".into()]);
    f4.limits_deg = Some([-350.0, 350.0]);
    let mut f5 = revolute("5", "4", 30.0, 0.0, 0.0);
    f5.limits_deg = Some([-350.0, 350.0]);
    let mut f6 = FrameDescription::new("6", "5", JointType::Revolute);
    f6.alpha_deg = -60.0;
    f6.coupled_to = vec![CouplingTerm {
        frame: "5".into(),
        ratio: -1.0,
    }];
    let mut f7 = revolute("7", "6", 30.0, 0.0, 0.0);
    f7.limits_deg = Some([-350.0, 350.0]);
    let mut f8 = revolute("8", "1", -90.0, 0.0, 0.0);
    f8.slider_crank = Some(IR663_CRANK_8);
    f8.limits_mm = Some([560.0, 1040.0]);
    for key in ["alpha", "d", "r"] {
        f8.same_as.insert(key.into(), "2".into());
    }
    let mut f9 = FrameDescription::new("9", "8", JointType::Revolute);
    f9.d_mm = 473.0;
    f9.seed_deg = -145.0;
    let mut f10 = FrameDescription::new("10", "3", JointType::Revolute);
    f10.gamma_deg = 90.0;
    f10.d_mm = 400.0;
    f10.theta_deg = -90.0;
    f10.seed_deg = -30.0;
    let mut f11 = FrameDescription::new("11", "9", JointType::Fixed);
    f11.d_mm = 1212.0;
    let mut fe = FrameDescription::new("E", "7", JointType::Fixed);
    fe.r_mm = 244.0;
    fe.beta_deg = Some(0.0);
    let parameters = [
        "alpha1", "d1", "theta1", "r1", //
        "alpha2", "d2", "r2", "r2p", "kappa2", "lambda2", "l12", "l32", //
        "beta3", "alpha3", "d3", "r3", //
        "alpha4", "d4", "theta4", "r4", //
        "alpha5", "d5", "theta5", "r5", //
        "alpha6", "d6", "r6", //
        "alpha7", "d7", "theta7", "r7", //
        "betaE", "alphaE", "dE", "rE", //
        "r8p", "kappa8", "lambda8", "l18", "l38", //
        "d9", "d10", "d11",
    ]
    .map(String::from)
    .to_vec();
    RobotDescription {
        name: "ir663".into(),
        notes: "KUKA IR-663 after Marie et al. 2013, Table 1 and Table 2 (mm), four-bar loop cut at \
                joint 10 (planar closure), theta6 = -theta5, joints 2 and 8 driven by ball-screw slider \
                cranks whose geometry is not published (values here are plausible choices)."
            .into(),
        end_frame: Some("E".into()),
        parameters: Some(parameters),
        actuated_order: Some(
            ["theta1", "r2p", "r8p", "theta4", "theta5", "theta7"]
                .map(String::from)
                .to_vec(),
        ),
        base: TransformDescription::default(),
        tool: TransformDescription::default(),
        frames: vec![f1, f2, f3, f4, f5, f6, f7, f8, f9, f10, f11, fe],
        loops: vec![LoopDescription {
            name: "four-bar".into(),
            cut: ["10".into(), "11".into()],
            constraint: LoopConstraint::Planar,
            solver: LoopSolver::FourBar,
            branch: -1,
        }],
        links: Vec::new(),
    }
}

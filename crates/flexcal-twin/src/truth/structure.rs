//! The twin's own elastic structure: a frame model of the IR-663 written
//! for the twin alone and solved by the twin's own mechanics
//! ([`mechanics`](super::mechanics): force-based Timoshenko beams, shear
//! included, its own assembly and solver), not derived from the beam model
//! that flexcal identifies (`flexcal_elastic`'s built-in `ir663`, the
//! paper's Figure 8, Euler-Bernoulli beams solved by `flexcal_fem`), and
//! richer than it:
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
//!   (the 120 kg wrist of the issue);
//! - shear deformation of every beam (Timoshenko), which the identified
//!   Euler-Bernoulli model lacks: for the stocky upper arm (L / h = 2.8)
//!   as a cantilever it adds `3 E I / (G A_s L^2)` = 22 % to the bending
//!   deflection.
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

use flexcal_kinematics::{Data, Model, RobotDescription, forward_frames};
use nalgebra::{Isometry3, Point3, Rotation3, Vector3, Vector6};
use serde::Serialize;

use super::error::TruthError;
use super::mechanics::{Element, Frame, Section};

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

/// A node of the twin's structure, fixed to a frame of the kinematic model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureNode {
    /// Name.
    pub name: String,
    /// The frame it moves with.
    pub frame: String,
    /// Its position in that frame (m).
    pub offset_m: Vector3<f64>,
}

/// A beam of the twin's structure.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureBeam {
    /// Name.
    pub name: String,
    /// First node (index).
    pub i: usize,
    /// Second node (index).
    pub j: usize,
    /// Section and material.
    pub section: Section,
    /// Whether its weight counts (levers are part of castings weighed elsewhere).
    pub weighed: bool,
    /// Direction of the section's local z axis in frame `z_frame`.
    pub z_hint: Vector3<f64>,
    /// The frame of `z_hint`.
    pub z_frame: String,
}

/// A joint bearing: six springs between two coincident nodes, z along the
/// joint axis of frame `axis_frame`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureBearing {
    /// Name.
    pub name: String,
    /// First node.
    pub i: usize,
    /// Second node.
    pub j: usize,
    /// The frame whose z axis is the joint axis.
    pub axis_frame: String,
    /// `[radial, radial, axial (N/m), tilt, tilt, about the axis (N.m/rad)]`.
    pub stiffness: [f64; 6],
}

/// A ball screw: an axial spring between its two pivots.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureScrew {
    /// Name (`screw2`, `screw8`).
    pub name: String,
    /// Pivot on the driven body.
    pub i: usize,
    /// Pivot on frame 1.
    pub j: usize,
    /// Axial stiffness (N/m).
    pub stiffness_n_m: f64,
}

/// The twin's elastic structure (see the module documentation): what
/// `elastic_truth.json` publishes as `structure`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TwinStructure {
    /// Nodes; node 0 is clamped to the floor.
    pub nodes: Vec<StructureNode>,
    /// Beams.
    pub beams: Vec<StructureBeam>,
    /// Joint bearings.
    pub bearings: Vec<StructureBearing>,
    /// Ball screws.
    pub screws: Vec<StructureScrew>,
    /// Point masses `(node, kg)`.
    pub masses: Vec<(usize, f64)>,
    /// The TCP node.
    pub tcp: usize,
    /// Gravity (m/s^2, base axes).
    pub gravity_m_s2: Vector3<f64>,
}

/// The twin's structure solved in one configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct StructureSolution {
    /// TCP displacement `[dp; dphi]` (m, rad, base axes).
    pub tcp: Vector6<f64>,
    /// Elongation of each screw (m), in [`TwinStructure::screws`] order.
    pub screw_elongations: Vec<f64>,
}

impl TwinStructure {
    /// The frame in configuration `q` with geometric parameters `xi`
    /// (positions from the forward model of `model`).
    ///
    /// # Errors
    /// The forward model's errors; a frame the model lacks.
    pub fn frame(
        &self,
        model: &Model,
        data: &mut Data,
        q: &[f64],
        xi: &[f64],
    ) -> Result<Frame, TruthError> {
        forward_frames(model, data, q, xi).map_err(|source| TruthError::Kinematics {
            step: format!("placing the structure at q = {q:?}"),
            source,
        })?;
        let pose = |name: &str| -> Result<Isometry3<f64>, TruthError> {
            // Frame 0 is the base itself.
            if name == "0" {
                return Ok(Isometry3::identity());
            }
            let index = model
                .frame_index(name)
                .ok_or_else(|| TruthError::NotTheIr663 {
                    robot: model.name().to_string(),
                    missing: format!("frame {name}"),
                })?;
            Ok(data.frame_pose(index).unwrap_or_else(Isometry3::identity))
        };
        let mut positions = Vec::with_capacity(self.nodes.len());
        for n in &self.nodes {
            positions.push((pose(&n.frame)? * Point3::from(n.offset_m)).coords);
        }
        let mut elements =
            Vec::with_capacity(self.beams.len() + self.bearings.len() + self.screws.len());
        for b in &self.beams {
            elements.push(Element::Beam {
                name: b.name.clone(),
                i: b.i,
                j: b.j,
                section: b.section,
                z_hint: pose(&b.z_frame)?.rotation * b.z_hint,
            });
        }
        for b in &self.bearings {
            elements.push(Element::Spring6 {
                name: b.name.clone(),
                i: b.i,
                j: b.j,
                axes: pose(&b.axis_frame)?.rotation.to_rotation_matrix(),
                stiffness: Vector6::from(b.stiffness),
            });
        }
        for s in &self.screws {
            elements.push(Element::Axial {
                name: s.name.clone(),
                i: s.i,
                j: s.j,
                k_n_m: s.stiffness_n_m,
            });
        }
        Ok(Frame {
            positions,
            elements,
            fixed: vec![0],
        })
    }

    /// Solves the structure placed by [`TwinStructure::frame`] under the
    /// wrench `wrench_base` at the TCP (N, N.m, base axes) and, when
    /// `own_weight`, the weight of its beams and point masses.
    ///
    /// # Errors
    /// A mechanism, bad elements.
    pub fn solve(
        &self,
        frame: &Frame,
        wrench_base: &Vector6<f64>,
        own_weight: bool,
    ) -> Result<StructureSolution, super::mechanics::MechanicsError> {
        let mut loads = vec![0.0; 6 * frame.n_nodes()];
        if own_weight {
            let mut weighed = frame.clone();
            weighed.elements.retain(|e| match e {
                Element::Beam { name, .. } => {
                    self.beams.iter().any(|b| &b.name == name && b.weighed)
                }
                _ => false,
            });
            weighed.add_own_weight(&self.gravity_m_s2, &mut loads);
            for &(node, kg) in &self.masses {
                for a in 0..3 {
                    loads[6 * node + a] += kg * self.gravity_m_s2[a];
                }
            }
        }
        for a in 0..6 {
            loads[6 * self.tcp + a] += wrench_base[a];
        }
        let u = frame.solve(&loads)?;
        let screw_elongations = self
            .screws
            .iter()
            .map(|s| {
                let axis = (frame.positions[s.j] - frame.positions[s.i]).normalize();
                let ui = Vector3::new(u[6 * s.i], u[6 * s.i + 1], u[6 * s.i + 2]);
                let uj = Vector3::new(u[6 * s.j], u[6 * s.j + 1], u[6 * s.j + 2]);
                (uj - ui).dot(&axis)
            })
            .collect();
        Ok(StructureSolution {
            tcp: super::mechanics::node_displacement(&u, self.tcp),
            screw_elongations,
        })
    }
}

/// Builds the [`TwinStructure`] from named nodes.
struct Builder {
    structure: TwinStructure,
}

impl Builder {
    fn node(&mut self, name: &str, frame: &str, offset_mm: [f64; 3]) {
        self.structure.nodes.push(StructureNode {
            name: name.into(),
            frame: frame.into(),
            offset_m: Vector3::from(offset_mm) * 1e-3,
        });
    }

    fn index(&self, name: &str) -> usize {
        self.structure
            .nodes
            .iter()
            .position(|n| n.name == name)
            .unwrap_or(usize::MAX)
    }

    /// A steel beam whose local z axis is `z_hint` in `frame`.
    fn beam(
        &mut self,
        name: &str,
        i: &str,
        j: &str,
        section: Section,
        z_hint: [f64; 3],
        frame: &str,
    ) {
        let (i, j) = (self.index(i), self.index(j));
        self.structure.beams.push(StructureBeam {
            name: name.into(),
            i,
            j,
            section,
            weighed: true,
            z_hint: Vector3::from(z_hint),
            z_frame: frame.into(),
        });
    }

    fn bearing(&mut self, name: &str, i: &str, j: &str, axis_frame: &str, about_axis: f64) {
        let (i, j) = (self.index(i), self.index(j));
        let (k, t) = (BEARING_STIFFNESS, BEARING_TILT_STIFFNESS);
        self.structure.bearings.push(StructureBearing {
            name: name.into(),
            i,
            j,
            axis_frame: axis_frame.into(),
            stiffness: [k, k, k, t, t, about_axis],
        });
    }
}

/// The twin's elastic structure (see the module documentation), for the
/// built-in `ir663` kinematics `robot`.
pub fn twin_structure(robot: &RobotDescription) -> TwinStructure {
    let normal = [0.0, 0.0, 1.0];
    // Half lengths of the links (mm), from the nominal geometry of Table 2.
    let column_half = 885.0 / 2.0;
    let upper_arm_half = 1047.0 / 2.0;
    let forearm_half = 1760.0 / 2.0;
    let crank_half = 473.0 / 2.0;
    let coupler_half = 1212.0 / 2.0;
    let mut b = Builder {
        structure: TwinStructure {
            nodes: Vec::new(),
            beams: Vec::new(),
            bearings: Vec::new(),
            screws: Vec::new(),
            masses: Vec::new(),
            tcp: 0,
            gravity_m_s2: Vector3::new(0.0, 0.0, -9.80665),
        },
    };
    for (name, frame, offset) in [
        ("0", "0", [0.0; 3]),
        ("C", "0", [0.0, 0.0, column_half]),
        ("1", "1", [0.0; 3]),
        ("2", "2", [0.0; 3]),
        ("U", "2", [upper_arm_half, 0.0, 0.0]),
        ("3", "3", [0.0; 3]),
        ("3'", "3", [0.0; 3]),
        // Wrist motors 250 mm behind the elbow, on the forearm's axis (z4).
        ("M", "4", [0.0, 0.0, -1760.0 - 250.0]),
        ("F", "4", [0.0, 0.0, -forearm_half]),
        ("W", "4", [0.0; 3]),
        ("E", "E", [0.0; 3]),
        ("10", "10", [0.0; 3]),
        ("8", "8", [0.0; 3]),
        ("K", "8", [crank_half, 0.0, 0.0]),
        ("9", "9", [0.0; 3]),
        ("9'", "9", [0.0; 3]),
        ("L", "9", [coupler_half, 0.0, 0.0]),
        ("10'", "10", [0.0; 3]),
    ] {
        b.node(name, frame, offset);
    }
    let column = Section::steel_tube(0.55, 0.025);
    let upper_arm = Section::steel_box(0.38, 0.26, 0.018);
    let forearm_root = Section::steel_box(0.28, 0.22, 0.014);
    let forearm_tip = Section::steel_box(0.24, 0.2, 0.012);
    let crank_section = Section::steel_box(0.16, 0.11, 0.02);
    let coupler = Section::steel_tube(0.11, 0.012);
    let wrist = Section::steel_box(0.22, 0.22, 0.02);
    for (name, i, j, section, hint, frame) in [
        ("0C", "0", "C", column, [1.0, 0.0, 0.0], "1"),
        ("C1", "C", "1", column, [1.0, 0.0, 0.0], "1"),
        ("2U", "2", "U", upper_arm, normal, "2"),
        ("U3", "U", "3", upper_arm, normal, "2"),
        ("3'M", "3'", "M", forearm_root, normal, "3"),
        ("3'F", "3'", "F", forearm_root, normal, "3"),
        ("FW", "F", "W", forearm_tip, normal, "3"),
        ("3'10", "3'", "10", forearm_root, normal, "3"),
        ("WE", "W", "E", wrist, [1.0, 0.0, 0.0], "E"),
        ("8K", "8", "K", crank_section, normal, "8"),
        ("K9", "K", "9", crank_section, normal, "8"),
        ("9'L", "9'", "L", coupler, normal, "9"),
        ("L10'", "L", "10'", coupler, normal, "9"),
    ] {
        b.beam(name, i, j, section, hint, frame);
    }
    // Joints 2 and 8 turn freely about their axes: their screws hold them.
    for (name, i, j, frame) in [
        ("12", "1", "2", "2"),
        ("18", "1", "8", "8"),
        ("33'", "3", "3'", "3"),
        ("99'", "9", "9'", "9"),
        ("1010'", "10", "10'", "10"),
    ] {
        b.bearing(name, i, j, frame, 0.0);
    }
    let lever = Section::steel_box(0.4, 0.3, 0.05);
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
        let rot = Rotation3::from_axis_angle(&Vector3::x_axis(), antecedent_alpha_deg.to_radians())
            * Rotation3::from_axis_angle(&Vector3::z_axis(), theta_const_deg.to_radians());
        let p = rot * Vector3::new(l3 * lambda.cos(), l3 * lambda.sin(), 0.0);
        let (node_a, node_b) = (format!("A{joint_name}"), format!("B{joint_name}"));
        b.node(&node_a, joint_name, a);
        b.node(&node_b, "1", [p.x, p.y, p.z]);
        b.beam(
            &format!("lever{node_a}"),
            joint_name,
            &node_a,
            lever,
            normal,
            joint_name,
        );
        b.beam(
            &format!("lever{node_b}"),
            "1",
            &node_b,
            lever,
            normal,
            joint_name,
        );
        // The levers are part of the castings already weighed with the links.
        let n = b.structure.beams.len();
        b.structure.beams[n - 2].weighed = false;
        b.structure.beams[n - 1].weighed = false;
        let (i, j) = (b.index(&node_a), b.index(&node_b));
        b.structure.screws.push(StructureScrew {
            name: format!("screw{joint_name}"),
            i,
            j,
            stiffness_n_m: k_screw,
        });
    }
    b.structure.masses = vec![
        (b.index("M"), WRIST_MOTORS_MASS_KG),
        (b.index("W"), WRIST_MASS_KG),
        (b.index("E"), TOOL_MASS_KG),
    ];
    b.structure.tcp = b.index("E");
    b.structure
}

//! The elastic model of a robot in a configuration: a validated
//! [`ElasticModel`], its per-thread [`ElasticData`], and the free functions
//! that place the structure in configuration q, condense it onto the TCP and
//! differentiate the TCP displacement with respect to the stiffness
//! parameters Gamma.

use flexcal_fem::{
    Beam, Factorization, Joint, LoadCase, NodeId, SolverOptions, Spring, Structure,
    assemble_and_factor, joint_stiffness_sensitivity, load_vector_into,
};
use flexcal_kinematics::{Data, Model, forward_frames};
use nalgebra::{Isometry3, Matrix3xX, Matrix6, Matrix6xX, Vector3, Vector6};

use crate::description::{ElasticDescription, JointComponent};
use crate::error::{ElasticError, Result};

/// What a stiffness parameter of Gamma acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StiffnessTarget {
    /// One component of a joint element (index into the structure's joints).
    Joint {
        /// Joint element index.
        joint: usize,
        /// Component.
        component: JointComponent,
    },
}

/// One stiffness parameter of Gamma.
#[derive(Debug, Clone, PartialEq)]
pub struct StiffnessParameter {
    /// Name (`Kar_12`, `Kr_33'`).
    pub name: String,
    /// What it acts on.
    pub target: StiffnessTarget,
    /// Value in the description (N/m or N.m/rad).
    pub nominal: f64,
    /// Unit, `N/m` or `N.m/rad`.
    pub unit: &'static str,
}

/// Where a node sits: robot frame index (`None` for the base) and offset (m).
#[derive(Debug, Clone, Copy)]
struct NodePlacement {
    frame: Option<usize>,
    offset: Vector3<f64>,
}

/// A validated robot elastic model: the robot geometry, the structure
/// template, how its nodes and element axes follow the robot frames, and the
/// stiffness parameters Gamma. Immutable; each thread owns an [`ElasticData`].
#[derive(Debug, Clone)]
pub struct ElasticModel {
    robot: Model,
    description: ElasticDescription,
    template: Structure,
    placements: Vec<NodePlacement>,
    /// Per beam: frame of its `vecxz` and the vector in that frame.
    beam_axes: Vec<(Option<usize>, Vector3<f64>)>,
    /// Per joint: frame whose z axis is the joint axis.
    joint_axes: Vec<Option<usize>>,
    parameters: Vec<StiffnessParameter>,
    tcp: NodeId,
    /// Point masses: node and weight (N) in base axes.
    weights: Vec<(NodeId, Vector3<f64>)>,
    gravity: Vector3<f64>,
}

fn check_finite(owner: &str, field: &str, values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ElasticError::invalid(
            owner,
            field,
            format!("not finite: {values:?}"),
        ))
    }
}

/// Validation of an elastic description against its robot, step by step:
/// what [`ElasticModel::new`] reads the description with.
struct Validation<'a> {
    robot: &'a Model,
    d: &'a ElasticDescription,
    /// The element names taken so far (beams, joints, springs share one
    /// name space).
    element_names: Vec<&'a str>,
}

impl<'a> Validation<'a> {
    /// The robot frame named `name` (`None` for `0` or `base`).
    fn frame_of(&self, owner: &str, field: &str, name: &str) -> Result<Option<usize>> {
        if name == "0" || name == "base" {
            return Ok(None);
        }
        self.robot
            .frame_index(name)
            .map(Some)
            .ok_or_else(|| ElasticError::UnknownFrame {
                owner: owner.to_string(),
                field: field.to_string(),
                robot: self.robot.name().to_string(),
                frame: name.to_string(),
                known: self.robot.frame_names().join(", "),
            })
    }

    /// The node named `name`.
    fn node_of(&self, owner: &str, field: &str, name: &str) -> Result<NodeId> {
        self.d
            .nodes
            .iter()
            .position(|n| n.name == name)
            .ok_or_else(|| ElasticError::UnknownNode {
                owner: owner.to_string(),
                field: field.to_string(),
                node: name.to_string(),
                known: self
                    .d
                    .nodes
                    .iter()
                    .map(|n| n.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The end nodes of a new element `name` of kind `kind`: its name must
    /// be new and its two end nodes known and distinct. Takes the name.
    fn element_ends(
        &mut self,
        owner: &str,
        kind: &str,
        (name, i, j): (&'a str, &str, &str),
    ) -> Result<(NodeId, NodeId)> {
        if self.element_names.contains(&name) {
            return Err(ElasticError::DuplicateName {
                kind: "element",
                name: name.to_string(),
            });
        }
        let (ni, nj) = (self.node_of(owner, "i", i)?, self.node_of(owner, "j", j)?);
        if ni == nj {
            return Err(ElasticError::invalid(
                owner,
                "j",
                format!("a {kind} needs two different nodes, got '{i}' twice"),
            ));
        }
        self.element_names.push(name);
        Ok((ni, nj))
    }

    /// The structure's nodes (placed at the origin until a configuration
    /// places them) and where each sits on the robot.
    fn nodes(&self) -> Result<(Structure, Vec<NodePlacement>)> {
        let mut template = Structure::new();
        let mut placements = Vec::with_capacity(self.d.nodes.len());
        for n in &self.d.nodes {
            let owner = format!("node '{}'", n.name);
            check_finite(&owner, "offset_mm", &n.offset_mm)?;
            let frame = self.frame_of(&owner, "frame", &n.frame)?;
            if template.find_node(&n.name).is_some() {
                return Err(ElasticError::DuplicateName {
                    kind: "node",
                    name: n.name.clone(),
                });
            }
            // Real positions come with the configuration; spread the template
            // nodes so no element is degenerate before then.
            template
                .add_node(n.name.clone(), Vector3::zeros())
                .map_err(|e| ElasticError::fem(owner.clone(), e))?;
            placements.push(NodePlacement {
                frame,
                offset: Vector3::from(n.offset_mm) * 1e-3,
            });
        }
        Ok((template, placements))
    }

    /// The beams, and per beam the frame of its `vecxz` and that vector.
    #[allow(clippy::type_complexity)]
    fn beams(&mut self) -> Result<(Vec<Beam>, Vec<(Option<usize>, Vector3<f64>)>)> {
        let mut beams = Vec::new();
        let mut beam_axes = Vec::new();
        let d = self.d;
        for b in &d.beams {
            let owner = format!("beam '{}'", b.name);
            let (i, j) = self.element_ends(&owner, "beam", (&b.name, &b.i, &b.j))?;
            let section = b.section.to_fem();
            section
                .validate(&owner)
                .map_err(|e| ElasticError::fem("elastic description", e))?;
            check_finite(&owner, "vecxz", &b.vecxz)?;
            if Vector3::from(b.vecxz).norm() == 0.0 {
                return Err(ElasticError::invalid(&owner, "vecxz", "must not be zero"));
            }
            if !(b.mass_per_length_kg_m.is_finite() && b.mass_per_length_kg_m >= 0.0) {
                return Err(ElasticError::invalid(
                    &owner,
                    "mass_per_length_kg_m",
                    format!("must be >= 0 and finite, got {}", b.mass_per_length_kg_m),
                ));
            }
            let frame_name = b.vecxz_frame.as_deref().unwrap_or(&d.nodes[i].frame);
            let frame = self.frame_of(&owner, "vecxz_frame", frame_name)?;
            beam_axes.push((frame, Vector3::from(b.vecxz)));
            beams.push(Beam {
                name: b.name.clone(),
                i,
                j,
                section,
                vecxz: Vector3::from(b.vecxz),
                releases: [false; 12],
                mass_per_length: b.mass_per_length_kg_m,
            });
        }
        Ok((beams, beam_axes))
    }

    /// The joint elements, per joint the frame whose z axis is its axis,
    /// and the stiffness parameters Gamma of their identified components.
    #[allow(clippy::type_complexity)]
    fn joints(&mut self) -> Result<(Vec<Joint>, Vec<Option<usize>>, Vec<StiffnessParameter>)> {
        let mut parameters = Vec::new();
        let mut joints = Vec::new();
        let mut joint_axes = Vec::new();
        for (index, jd) in self.d.joints.iter().enumerate() {
            let owner = format!("joint '{}'", jd.name);
            let (i, j) = self.element_ends(&owner, "joint", (&jd.name, &jd.i, &jd.j))?;
            for c in JointComponent::ALL {
                let v = jd.component(c);
                if !(v.is_finite() && v >= 0.0) {
                    return Err(ElasticError::invalid(
                        &owner,
                        field_name(c),
                        format!("must be >= 0 and finite, got {v}"),
                    ));
                }
            }
            identified_parameters(jd, index, &owner, &mut parameters)?;
            joint_axes.push(self.frame_of(&owner, "axis_frame", &jd.axis_frame)?);
            joints.push(Joint {
                name: jd.name.clone(),
                i,
                j,
                axis: Vector3::z(),
                local_y: None,
                stiffness: [
                    jd.ka_n_m,
                    jd.kr_n_m,
                    jd.kr_n_m,
                    jd.kar_nm_rad,
                    jd.krr_nm_rad,
                    jd.krr_nm_rad,
                ],
            });
        }
        Ok((joints, joint_axes, parameters))
    }

    /// The linear springs.
    fn springs(&mut self) -> Result<Vec<Spring>> {
        let mut springs = Vec::new();
        for sd in &self.d.springs {
            let owner = format!("spring '{}'", sd.name);
            let (i, j) = self.element_ends(&owner, "spring", (&sd.name, &sd.i, &sd.j))?;
            if !(sd.k_n_m.is_finite() && sd.k_n_m >= 0.0) {
                return Err(ElasticError::invalid(
                    &owner,
                    "k_n_m",
                    format!("must be >= 0 and finite, got {}", sd.k_n_m),
                ));
            }
            springs.push(Spring {
                name: sd.name.clone(),
                i,
                j,
                k: sd.k_n_m,
            });
        }
        Ok(springs)
    }

    /// The supports set on `template` (at least one), and the TCP node
    /// (not supported).
    fn supports_and_tcp(&self, template: &mut Structure) -> Result<NodeId> {
        let d = self.d;
        if d.supports.is_empty() {
            return Err(ElasticError::invalid(
                format!("elastic description '{}'", d.name),
                "supports",
                "at least one supported node is needed (60)",
            ));
        }
        for s in &d.supports {
            let n = self.node_of("support", "node", &s.node)?;
            template
                .set_support(n, s.fixed)
                .map_err(|e| ElasticError::fem("support", e))?;
        }
        let tcp = self.node_of(&format!("elastic description '{}'", d.name), "tcp", &d.tcp)?;
        if template.supports()[tcp].iter().any(|&f| f) {
            return Err(ElasticError::invalid(
                format!("node '{}'", d.tcp),
                "tcp",
                "the TCP node must not be supported",
            ));
        }
        Ok(tcp)
    }

    /// Gravity (m/s^2) and the point masses' weights (N) at their nodes.
    #[allow(clippy::type_complexity)]
    fn weights(&self) -> Result<(Vector3<f64>, Vec<(NodeId, Vector3<f64>)>)> {
        let d = self.d;
        check_finite("elastic description", "gravity_m_s2", &d.gravity_m_s2)?;
        let gravity = Vector3::from(d.gravity_m_s2);
        let mut weights = Vec::new();
        for m in &d.point_masses {
            let owner = format!("point mass at '{}'", m.node);
            let n = self.node_of(&owner, "node", &m.node)?;
            if !(m.mass_kg.is_finite() && m.mass_kg >= 0.0) {
                return Err(ElasticError::invalid(
                    &owner,
                    "mass_kg",
                    format!("must be >= 0 and finite, got {}", m.mass_kg),
                ));
            }
            weights.push((n, gravity * m.mass_kg));
        }
        Ok((gravity, weights))
    }
}

/// Adds to `parameters` the stiffness parameters of joint `jd` (number
/// `index`) that are identified: a positive nominal value each, names not
/// taken before.
fn identified_parameters(
    jd: &crate::description::JointDescription,
    index: usize,
    owner: &str,
    parameters: &mut Vec<StiffnessParameter>,
) -> Result<()> {
    for &c in &jd.identify {
        let v = jd.component(c);
        let name = format!("{}_{}", c.symbol(), jd.name);
        if v <= 0.0 {
            return Err(ElasticError::invalid(
                owner,
                field_name(c),
                format!("identified as '{name}': its nominal value must be > 0, got {v}"),
            ));
        }
        if parameters.iter().any(|p| p.name == name) {
            return Err(ElasticError::DuplicateName {
                kind: "stiffness parameter",
                name,
            });
        }
        parameters.push(StiffnessParameter {
            name,
            target: StiffnessTarget::Joint {
                joint: index,
                component: c,
            },
            nominal: v,
            unit: c.unit(),
        });
    }
    Ok(())
}

impl ElasticModel {
    /// Validates `description` against `robot` and builds the model: the
    /// nodes, the beams, the joints and their stiffness parameters, the
    /// springs, the supports and the TCP, the weights, in that order (the
    /// first fault found is the one reported).
    ///
    /// # Errors
    /// Unknown frames or nodes, duplicate names, non-positive section
    /// values, negative stiffness or mass, an identified stiffness that is
    /// not positive, no support, a supported TCP.
    pub fn new(robot: &Model, description: &ElasticDescription) -> Result<Self> {
        let mut v = Validation {
            robot,
            d: description,
            element_names: Vec::new(),
        };
        let (mut template, placements) = v.nodes()?;
        let (beams, beam_axes) = v.beams()?;
        let (joints, joint_axes, parameters) = v.joints()?;
        let springs = v.springs()?;
        for b in beams {
            template
                .add_beam(b)
                .map_err(|e| ElasticError::fem("elastic description", e))?;
        }
        for jt in joints {
            template
                .add_joint(jt)
                .map_err(|e| ElasticError::fem("elastic description", e))?;
        }
        for sp in springs {
            template
                .add_spring(sp)
                .map_err(|e| ElasticError::fem("elastic description", e))?;
        }
        let tcp = v.supports_and_tcp(&mut template)?;
        let (gravity, weights) = v.weights()?;
        Ok(Self {
            robot: robot.clone(),
            description: description.clone(),
            template,
            placements,
            beam_axes,
            joint_axes,
            parameters,
            tcp,
            weights,
            gravity,
        })
    }

    /// The robot geometry.
    pub fn robot(&self) -> &Model {
        &self.robot
    }

    /// The description the model was built from.
    pub fn description(&self) -> &ElasticDescription {
        &self.description
    }

    /// The structure template (node positions are placeholders until a
    /// configuration is applied with [`configure_structure`]).
    pub fn template(&self) -> &Structure {
        &self.template
    }

    /// The stiffness parameters Gamma, in order.
    pub fn parameters(&self) -> &[StiffnessParameter] {
        &self.parameters
    }

    /// Number of stiffness parameters.
    pub fn n_parameters(&self) -> usize {
        self.parameters.len()
    }

    /// Names of the stiffness parameters.
    pub fn parameter_names(&self) -> Vec<String> {
        self.parameters.iter().map(|p| p.name.clone()).collect()
    }

    /// Nominal Gamma (the values of the description), SI.
    pub fn nominal_gamma(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }

    /// Index of the TCP node.
    pub fn tcp_node(&self) -> NodeId {
        self.tcp
    }

    /// Gravity acceleration in base axes (m/s^2).
    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    /// Checks a Gamma vector (length, positive and finite values).
    ///
    /// # Errors
    /// [`ElasticError::StiffnessLength`], [`ElasticError::InvalidStiffness`].
    pub fn check_gamma(&self, gamma: &[f64]) -> Result<()> {
        if gamma.len() != self.parameters.len() {
            return Err(ElasticError::StiffnessLength {
                expected: self.parameters.len(),
                found: gamma.len(),
                names: self.parameter_names().join(", "),
            });
        }
        for (p, &v) in self.parameters.iter().zip(gamma) {
            if !(v.is_finite() && v > 0.0) {
                return Err(ElasticError::InvalidStiffness {
                    name: p.name.clone(),
                    value: v,
                });
            }
        }
        Ok(())
    }

    /// The load case of the gravity on beams and point masses.
    pub fn gravity_load_case(&self) -> LoadCase {
        let mut case = LoadCase::new("gravity");
        case.gravity = self.gravity;
        for (n, w) in &self.weights {
            case.nodal_loads
                .push((*n, Vector6::new(w.x, w.y, w.z, 0.0, 0.0, 0.0)));
        }
        case
    }
}

fn field_name(c: JointComponent) -> &'static str {
    match c {
        JointComponent::Ka => "ka_n_m",
        JointComponent::Kr => "kr_n_m",
        JointComponent::Kar => "kar_nm_rad",
        JointComponent::Krr => "krr_nm_rad",
    }
}

/// Per-thread workspace of an [`ElasticModel`]: the kinematics workspace,
/// a structure placed in the last configuration, its factorization
/// (condensing onto the TCP) and load / displacement buffers.
#[derive(Debug, Clone)]
pub struct ElasticData {
    /// Kinematics workspace.
    pub kinematics: Data,
    /// The structure in the last configuration, with the last Gamma.
    pub structure: Structure,
    factorization: Factorization,
    loads: Vec<f64>,
    displacements: Vec<f64>,
}

impl ElasticData {
    /// A workspace for `model`.
    ///
    /// # Errors
    /// [`ElasticError::Fem`] if the topology cannot be ordered (never for a
    /// validated model).
    pub fn new(model: &ElasticModel) -> Result<Self> {
        let factorization =
            Factorization::new(&model.template, &SolverOptions::condensing_onto(model.tcp))
                .map_err(|e| ElasticError::fem("elastic model", e))?;
        let n = model.template.dof_count();
        Ok(Self {
            kinematics: Data::new(&model.robot),
            structure: model.template.clone(),
            factorization,
            loads: vec![0.0; n],
            displacements: vec![0.0; n],
        })
    }

    /// Displacements (m, rad) of every node after the last solve, global
    /// layout `6 * node + dof`.
    pub fn displacements(&self) -> &[f64] {
        &self.displacements
    }
}

fn frame_pose(data: &Data, frame: Option<usize>) -> Isometry3<f64> {
    match frame {
        None => Isometry3::identity(),
        Some(f) => data.frame_pose(f).unwrap_or_else(Isometry3::identity),
    }
}

/// Places `structure` (a clone of the model's template) in configuration
/// `q` with geometric parameters `xi`: node positions from the forward model,
/// beam orientation vectors and joint axes rotated with their frames.
///
/// # Errors
/// Kinematic failures (wrong lengths, loop that cannot close).
pub fn configure_structure(
    model: &ElasticModel,
    kinematics: &mut Data,
    structure: &mut Structure,
    q: &[f64],
    xi: &[f64],
) -> Result<()> {
    forward_frames(&model.robot, kinematics, q, xi)?;
    for (node, placement) in model.placements.iter().enumerate() {
        let x_base_frame = frame_pose(kinematics, placement.frame);
        let p = x_base_frame * nalgebra::Point3::from(placement.offset);
        structure
            .set_node_position(node, p.coords)
            .map_err(|e| ElasticError::fem("configuration", e))?;
    }
    for (beam, (frame, v)) in model.beam_axes.iter().enumerate() {
        let r = frame_pose(kinematics, *frame).rotation;
        structure
            .set_beam_vecxz(beam, r * v)
            .map_err(|e| ElasticError::fem("configuration", e))?;
    }
    for (joint, frame) in model.joint_axes.iter().enumerate() {
        let axis = frame_pose(kinematics, *frame).rotation * Vector3::z();
        structure
            .set_joint_frame(joint, axis, None)
            .map_err(|e| ElasticError::fem("configuration", e))?;
    }
    Ok(())
}

/// Writes Gamma into `structure`.
///
/// # Errors
/// [`ElasticError::StiffnessLength`], [`ElasticError::InvalidStiffness`].
pub fn apply_stiffness(
    model: &ElasticModel,
    structure: &mut Structure,
    gamma: &[f64],
) -> Result<()> {
    model.check_gamma(gamma)?;
    for (p, &value) in model.parameters.iter().zip(gamma) {
        match p.target {
            StiffnessTarget::Joint { joint, component } => {
                let mut k = structure.joints()[joint].stiffness;
                for &c in component.fem_indices() {
                    k[c] = value;
                }
                structure
                    .set_joint_stiffness(joint, k)
                    .map_err(|e| ElasticError::fem(format!("parameter '{}'", p.name), e))?;
            }
        }
    }
    Ok(())
}

/// The TCP condensation of the structure in one configuration, base axes,
/// `[linear; angular]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TcpCondensation {
    /// Equivalent stiffness K_eq (27), (63) [N/m, N/rad; N.m/m, N.m/rad].
    pub k_eq: Matrix6<f64>,
    /// Equivalent compliance C_eq = K_eq^{-1} (13) [m/N, m/(N.m); rad/N, rad/(N.m)].
    pub c_eq: Matrix6<f64>,
    /// Equivalent wrench of the own weight (beams and point masses) at the TCP, F_eq of (27) [N, N.m].
    pub f_eq_gravity: Vector6<f64>,
}

fn factor(
    model: &ElasticModel,
    data: &mut ElasticData,
    q: &[f64],
    xi: &[f64],
    gamma: &[f64],
) -> Result<()> {
    configure_structure(model, &mut data.kinematics, &mut data.structure, q, xi)?;
    apply_stiffness(model, &mut data.structure, gamma)?;
    assemble_and_factor(&data.structure, &mut data.factorization)
        .map_err(|e| ElasticError::fem(format!("configuration q = {q:?}"), e))
}

/// Assembles the structure in configuration `q` and condenses it onto the
/// TCP node: K_eq, C_eq and the gravity F_eq of (27), (62)-(63).
///
/// # Errors
/// Kinematic failures, a zero-length element in this configuration, a
/// singular structure, an invalid Gamma.
pub fn tcp_condensation(
    model: &ElasticModel,
    data: &mut ElasticData,
    q: &[f64],
    xi: &[f64],
    gamma: &[f64],
) -> Result<TcpCondensation> {
    factor(model, data, q, xi, gamma)?;
    let fem = |e| ElasticError::fem(format!("condensation at q = {q:?}"), e);
    let k_eq = data.factorization.k_eq().map_err(fem)?;
    let c_eq = data.factorization.c_eq().map_err(fem)?;
    load_vector_into(&data.structure, &model.gravity_load_case(), &mut data.loads).map_err(fem)?;
    let f_eq_gravity = data.factorization.f_eq(&data.loads).map_err(fem)?;
    Ok(TcpCondensation {
        k_eq,
        c_eq,
        f_eq_gravity,
    })
}

/// The TCP compliance `C_eq = K_eq^-1` (13), (63) of the structure in
/// configuration `q` (base axes, `[linear; angular]`): what
/// [`tcp_condensation`] gives without the own-weight load vector, for callers
/// that apply many wrenches in one configuration.
///
/// # Errors
/// As [`tcp_condensation`].
pub fn tcp_compliance(
    model: &ElasticModel,
    data: &mut ElasticData,
    q: &[f64],
    xi: &[f64],
    gamma: &[f64],
) -> Result<Matrix6<f64>> {
    factor(model, data, q, xi, gamma)?;
    data.factorization
        .c_eq()
        .map_err(|e| ElasticError::fem(format!("condensation at q = {q:?}"), e))
}

/// Whether a load case includes the robot's own weight (the gravity load
/// of its links, from the elastic description's masses).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OwnWeight {
    /// The own weight is added to the applied wrench.
    Included,
    /// Only the applied wrench loads the robot.
    Excluded,
}

impl OwnWeight {
    /// [`OwnWeight::Included`] when `included`, else [`OwnWeight::Excluded`]
    /// (for a switch that says whether gravity acts).
    pub fn included_if(included: bool) -> Self {
        if included {
            Self::Included
        } else {
            Self::Excluded
        }
    }
}

/// TCP elastic displacement `dS_E = C_eq F_eq` (28), (63)-(64) in
/// configuration `q` for a wrench `wrench_tcp` applied at the TCP (base
/// axes, [N; N.m]), with the own weight added when `own_weight` says so.
/// Returns `[dP (m); dPhi (rad)]` in base axes.
///
/// # Errors
/// As [`tcp_condensation`].
pub fn tcp_deflection(
    model: &ElasticModel,
    data: &mut ElasticData,
    q: &[f64],
    xi: &[f64],
    gamma: &[f64],
    wrench_tcp: &Vector6<f64>,
    own_weight: OwnWeight,
) -> Result<Vector6<f64>> {
    factor(model, data, q, xi, gamma)?;
    fill_loads(model, data, wrench_tcp, own_weight)?;
    let fem = |e| ElasticError::fem(format!("solve at q = {q:?}"), e);
    data.factorization
        .solve_into(&data.loads, &mut data.displacements)
        .map_err(fem)?;
    Ok(tcp_block(&data.displacements, model.tcp))
}

fn fill_loads(
    model: &ElasticModel,
    data: &mut ElasticData,
    wrench_tcp: &Vector6<f64>,
    own_weight: OwnWeight,
) -> Result<()> {
    if !wrench_tcp.iter().all(|v| v.is_finite()) {
        return Err(ElasticError::invalid(
            "TCP wrench",
            "wrench",
            format!("not finite: {wrench_tcp:?}"),
        ));
    }
    if own_weight == OwnWeight::Included {
        load_vector_into(&data.structure, &model.gravity_load_case(), &mut data.loads)
            .map_err(|e| ElasticError::fem("gravity load", e))?;
    } else {
        data.loads.iter_mut().for_each(|v| *v = 0.0);
    }
    for k in 0..6 {
        data.loads[6 * model.tcp + k] += wrench_tcp[k];
    }
    Ok(())
}

fn tcp_block(u: &[f64], tcp: NodeId) -> Vector6<f64> {
    Vector6::from_column_slice(&u[6 * tcp..6 * tcp + 6])
}

/// TCP displacement for a TCP wrench (no gravity) and its derivatives with
/// respect to log Gamma: column p is `gamma_p * d dS_E / d gamma_p`, from the
/// exact sensitivity `du/dk = -K^{-1} (dK/dk) u`.
///
/// # Errors
/// As [`tcp_condensation`].
pub fn tcp_deflection_log_derivatives(
    model: &ElasticModel,
    data: &mut ElasticData,
    q: &[f64],
    xi: &[f64],
    gamma: &[f64],
    wrench_tcp: &Vector6<f64>,
) -> Result<(Vector6<f64>, Matrix6xX<f64>)> {
    let u = tcp_deflection(model, data, q, xi, gamma, wrench_tcp, OwnWeight::Excluded)?;
    let mut jac = Matrix6xX::zeros(model.parameters.len());
    let displacements = data.displacements.clone();
    for (p, param) in model.parameters.iter().enumerate() {
        let du = parameter_sensitivity(model, data, p, &displacements)
            .map_err(|e| ElasticError::fem(format!("sensitivity to '{}'", param.name), e))?;
        jac.set_column(p, &(tcp_block(&du, model.tcp) * gamma[p]));
    }
    Ok((u, jac))
}

/// `du/dgamma_p` (global layout) for the factored structure in `data` and
/// its displacements `u`.
pub(crate) fn parameter_sensitivity(
    model: &ElasticModel,
    data: &mut ElasticData,
    p: usize,
    u: &[f64],
) -> std::result::Result<Vec<f64>, flexcal_fem::FemError> {
    sensitivity_in(model, &data.structure, &mut data.factorization, p, u)
}

pub(crate) fn sensitivity_in(
    model: &ElasticModel,
    structure: &Structure,
    factorization: &mut Factorization,
    p: usize,
    u: &[f64],
) -> std::result::Result<Vec<f64>, flexcal_fem::FemError> {
    match model.parameters[p].target {
        StiffnessTarget::Joint { joint, component } => {
            let mut total: Option<Vec<f64>> = None;
            for &c in component.fem_indices() {
                let du = joint_stiffness_sensitivity(structure, factorization, joint, c, u)?;
                total = Some(match total {
                    None => du,
                    Some(mut t) => {
                        t.iter_mut().zip(&du).for_each(|(a, b)| *a += b);
                        t
                    }
                });
            }
            Ok(total.unwrap_or_default())
        }
    }
}

/// Position part (3 x n) of a 6 x n matrix.
pub fn position_rows(m: &Matrix6xX<f64>) -> Matrix3xX<f64> {
    m.fixed_rows::<3>(0).into_owned()
}

//! The numeric description of a frame structure: nodes by index, elements,
//! supports, and load cases.

use nalgebra::{Vector3, Vector6};

use crate::error::{FemError, Result, invalid};

/// Index of a node in a [`Structure`] (0-based, in insertion order).
pub type NodeId = usize;

/// Cross-section and material of a beam, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Young's modulus E (Pa); > 0.
    pub youngs_modulus: f64,
    /// Shear modulus G (Pa); > 0.
    pub shear_modulus: f64,
    /// Area A (m^2); > 0.
    pub area: f64,
    /// Second moment of area about local y, Iy (m^4); > 0. Governs bending in
    /// the local x-z plane (deflection along local z).
    pub iy: f64,
    /// Second moment of area about local z, Iz (m^4); > 0. Governs bending in
    /// the local x-y plane (deflection along local y).
    pub iz: f64,
    /// Torsion constant J (m^4); > 0.
    pub torsion_constant: f64,
    /// Shear area for shear along local y, Avy (m^2); `Some` (> 0) makes the
    /// x-y bending Timoshenko, `None` keeps it Euler-Bernoulli.
    pub shear_area_y: Option<f64>,
    /// Shear area for shear along local z, Avz (m^2); as `shear_area_y`.
    pub shear_area_z: Option<f64>,
}

/// A 3D beam between two nodes.
///
/// Local axes: x from node `i` to node `j`, y = unit(vecxz x x), z = x x y.
#[derive(Debug, Clone, PartialEq)]
pub struct Beam {
    /// Name used in messages.
    pub name: String,
    /// First node.
    pub i: NodeId,
    /// Second node.
    pub j: NodeId,
    /// Section and material.
    pub section: Section,
    /// A vector in the local x-z plane, not parallel to the beam (global axes,
    /// any length).
    pub vecxz: Vector3<f64>,
    /// End releases in local order `u1 v1 w1 rx1 ry1 rz1 u2 v2 w2 rx2 ry2 rz2`;
    /// `true` = released (the element transmits no force on that local
    /// degree of freedom; it is condensed out at element level).
    pub releases: [bool; 12],
    /// Mass per unit length (kg/m); >= 0. Only used for own-weight loads.
    pub mass_per_length: f64,
}

/// A joint element: a zero-length six-direction spring between two nodes.
///
/// Its stiffness is diag(Ka, Kr_y, Kr_z, Kar, Krr_y, Krr_z) in a frame whose
/// x is the joint axis (paper equations (17)-(18)); it acts on the relative
/// displacement and rotation of node `j` with respect to node `i`. Nodes are
/// normally coincident; otherwise the spring sits at their midpoint, joined to
/// each node by a rigid offset, so that a rigid motion of the pair never loads
/// it.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name used in messages.
    pub name: String,
    /// First node.
    pub i: NodeId,
    /// Second node.
    pub j: NodeId,
    /// Joint axis, local x (global axes, any length).
    pub axis: Vector3<f64>,
    /// Direction of local y (orthogonalised against the axis). When `None`,
    /// any perpendicular is used, which requires equal radial stiffnesses.
    pub local_y: Option<Vector3<f64>>,
    /// `[Ka, Kr, Kr, Kar, Krr, Krr]`: translational stiffnesses along local
    /// x, y, z (N/m) then rotational stiffnesses about local x, y, z
    /// (N.m/rad); each >= 0, 0 meaning free.
    pub stiffness: [f64; 6],
}

/// An axial spring of stiffness `k` (N/m) along the line from node `i` to node `j`.
#[derive(Debug, Clone, PartialEq)]
pub struct Spring {
    /// Name used in messages.
    pub name: String,
    /// First node.
    pub i: NodeId,
    /// Second node.
    pub j: NodeId,
    /// Stiffness (N/m); >= 0.
    pub k: f64,
}

/// Which element of a structure: kind and index in its list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ElementId {
    /// Index into [`Structure::beams`].
    Beam(usize),
    /// Index into [`Structure::joints`].
    Joint(usize),
    /// Index into [`Structure::springs`].
    Spring(usize),
}

/// A load case: nodal wrenches and gravity.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadCase {
    /// Name used in output.
    pub name: String,
    /// Gravity acceleration (m/s^2), global axes; acts on beams with a mass
    /// per length, as consistent equivalent nodal loads.
    pub gravity: Vector3<f64>,
    /// Nodal wrenches `[fx, fy, fz, mx, my, mz]` [N, N.m], global axes.
    pub nodal_loads: Vec<(NodeId, Vector6<f64>)>,
}

impl LoadCase {
    /// A load case without loads.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            gravity: Vector3::zeros(),
            nodal_loads: Vec::new(),
        }
    }
}

/// A frame structure: nodes (indexed, named), supports, beams, joints and
/// axial springs.
///
/// Values are validated when added; geometry (beam lengths, orientations) is
/// checked when element matrices are computed, since nodes may be moved with
/// [`Structure::set_node_position`] between solves. The topology (which
/// elements connect which nodes, supports) is what a
/// [`crate::Factorization`] is built for; positions, orientations, sections
/// and stiffness values may change freely.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Structure {
    node_names: Vec<String>,
    positions: Vec<Vector3<f64>>,
    supports: Vec<[bool; 6]>,
    beams: Vec<Beam>,
    joints: Vec<Joint>,
    springs: Vec<Spring>,
}

/// `owner` is only called on failure: these checks run in per-configuration
/// loops and must not allocate.
fn check_finite_vector(owner: &dyn Fn() -> String, field: &str, v: &Vector3<f64>) -> Result<()> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(invalid(&owner(), field, format!("not finite: {v:?}")))
    }
}

fn check_positive(owner: &str, field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            owner,
            field,
            format!("must be positive and finite, got {value}"),
        ))
    }
}

fn check_non_negative(owner: &str, field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            owner,
            field,
            format!("must be non-negative and finite, got {value}"),
        ))
    }
}

impl Section {
    /// Checks every value (`owner` names the beam in messages).
    pub fn validate(&self, owner: &str) -> Result<()> {
        check_positive(owner, "E", self.youngs_modulus)?;
        check_positive(owner, "G", self.shear_modulus)?;
        check_positive(owner, "A", self.area)?;
        check_positive(owner, "Iy", self.iy)?;
        check_positive(owner, "Iz", self.iz)?;
        check_positive(owner, "J", self.torsion_constant)?;
        if let Some(a) = self.shear_area_y {
            check_positive(owner, "Avy", a)?;
        }
        if let Some(a) = self.shear_area_z {
            check_positive(owner, "Avz", a)?;
        }
        Ok(())
    }
}

impl Structure {
    /// An empty structure.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a node at `position` (m); returns its index.
    pub fn add_node(&mut self, name: impl Into<String>, position: Vector3<f64>) -> Result<NodeId> {
        let name = name.into();
        check_finite_vector(&|| format!("node '{name}'"), "position", &position)?;
        if self.node_names.contains(&name) {
            return Err(FemError::DuplicateName { kind: "node", name });
        }
        self.node_names.push(name);
        self.positions.push(position);
        self.supports.push([false; 6]);
        Ok(self.positions.len() - 1)
    }

    /// Sets which degrees of freedom of `node` are fixed (`[ux uy uz rx ry rz]`,
    /// `true` = fixed, paper equation (60)).
    pub fn set_support(&mut self, node: NodeId, fixed: [bool; 6]) -> Result<()> {
        self.check_node("support", node)?;
        self.supports[node] = fixed;
        Ok(())
    }

    /// Moves `node` to `position` (m).
    pub fn set_node_position(&mut self, node: NodeId, position: Vector3<f64>) -> Result<()> {
        self.check_node("set_node_position", node)?;
        check_finite_vector(
            &|| format!("node '{}'", self.node_names[node]),
            "position",
            &position,
        )?;
        self.positions[node] = position;
        Ok(())
    }

    /// Adds a beam; returns its index in [`Structure::beams`].
    pub fn add_beam(&mut self, beam: Beam) -> Result<usize> {
        let owner = format!("beam '{}'", beam.name);
        self.check_pair(&owner, beam.i, beam.j)?;
        beam.section.validate(&owner)?;
        check_finite_vector(&|| owner.clone(), "vecxz", &beam.vecxz)?;
        check_non_negative(&owner, "mass_per_length", beam.mass_per_length)?;
        self.check_element_name(&beam.name)?;
        self.beams.push(beam);
        Ok(self.beams.len() - 1)
    }

    /// Adds a joint element; returns its index in [`Structure::joints`].
    pub fn add_joint(&mut self, joint: Joint) -> Result<usize> {
        let owner = format!("joint '{}'", joint.name);
        self.check_pair(&owner, joint.i, joint.j)?;
        check_joint_values(
            &|| owner.clone(),
            &joint.axis,
            joint.local_y.as_ref(),
            &joint.stiffness,
        )?;
        self.check_element_name(&joint.name)?;
        self.joints.push(joint);
        Ok(self.joints.len() - 1)
    }

    /// Adds an axial spring; returns its index in [`Structure::springs`].
    pub fn add_spring(&mut self, spring: Spring) -> Result<usize> {
        let owner = format!("spring '{}'", spring.name);
        self.check_pair(&owner, spring.i, spring.j)?;
        check_non_negative(&owner, "k", spring.k)?;
        self.check_element_name(&spring.name)?;
        self.springs.push(spring);
        Ok(self.springs.len() - 1)
    }

    /// Re-orients joint `joint`: new axis and optional local y (global axes).
    pub fn set_joint_frame(
        &mut self,
        joint: usize,
        axis: Vector3<f64>,
        local_y: Option<Vector3<f64>>,
    ) -> Result<()> {
        let current = self.joint_checked(joint)?;
        let owner = || format!("joint '{}'", current.name);
        check_joint_values(&owner, &axis, local_y.as_ref(), &current.stiffness)?;
        let j = &mut self.joints[joint];
        j.axis = axis;
        j.local_y = local_y;
        Ok(())
    }

    /// Sets the six stiffness values of joint `joint` (see [`Joint::stiffness`]).
    pub fn set_joint_stiffness(&mut self, joint: usize, stiffness: [f64; 6]) -> Result<()> {
        let current = self.joint_checked(joint)?;
        let owner = || format!("joint '{}'", current.name);
        check_joint_values(&owner, &current.axis, current.local_y.as_ref(), &stiffness)?;
        self.joints[joint].stiffness = stiffness;
        Ok(())
    }

    /// Sets the orientation vector of beam `beam` (global axes).
    pub fn set_beam_vecxz(&mut self, beam: usize, vecxz: Vector3<f64>) -> Result<()> {
        let count = self.beams.len();
        let b = self
            .beams
            .get_mut(beam)
            .ok_or_else(|| FemError::IndexOutOfRange {
                owner: "set_beam_vecxz".to_string(),
                kind: "beam",
                index: beam,
                count,
            })?;
        check_finite_vector(&|| format!("beam '{}'", b.name), "vecxz", &vecxz)?;
        b.vecxz = vecxz;
        Ok(())
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of degrees of freedom before supports (6 per node).
    pub fn dof_count(&self) -> usize {
        6 * self.positions.len()
    }

    /// Name of `node` (panics on an out-of-range index, like slice indexing).
    pub fn node_name(&self, node: NodeId) -> &str {
        &self.node_names[node]
    }

    /// Node names in index order.
    pub fn node_names(&self) -> &[String] {
        &self.node_names
    }

    /// Index of the node named `name`.
    pub fn find_node(&self, name: &str) -> Option<NodeId> {
        self.node_names.iter().position(|n| n == name)
    }

    /// Node positions (m) in index order.
    pub fn positions(&self) -> &[Vector3<f64>] {
        &self.positions
    }

    /// Supports in node order (`true` = fixed).
    pub fn supports(&self) -> &[[bool; 6]] {
        &self.supports
    }

    /// The beams.
    pub fn beams(&self) -> &[Beam] {
        &self.beams
    }

    /// The joint elements.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// The axial springs.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }

    /// Every element, beams first, then joints, then springs.
    pub fn elements(&self) -> impl Iterator<Item = ElementId> + '_ {
        (0..self.beams.len())
            .map(ElementId::Beam)
            .chain((0..self.joints.len()).map(ElementId::Joint))
            .chain((0..self.springs.len()).map(ElementId::Spring))
    }

    /// The two nodes `(i, j)` of an element (panics on an out-of-range index).
    pub fn element_nodes(&self, element: ElementId) -> (NodeId, NodeId) {
        match element {
            ElementId::Beam(b) => (self.beams[b].i, self.beams[b].j),
            ElementId::Joint(b) => (self.joints[b].i, self.joints[b].j),
            ElementId::Spring(b) => (self.springs[b].i, self.springs[b].j),
        }
    }

    /// A description of an element for messages, e.g. `beam 'b1'`.
    pub fn element_label(&self, element: ElementId) -> String {
        match element {
            ElementId::Beam(b) => format!("beam '{}'", self.beams[b].name),
            ElementId::Joint(b) => format!("joint '{}'", self.joints[b].name),
            ElementId::Spring(b) => format!("spring '{}'", self.springs[b].name),
        }
    }

    /// Beam number `beam`, or an index error.
    pub fn beam(&self, beam: usize) -> Result<&Beam> {
        self.beams.get(beam).ok_or(FemError::IndexOutOfRange {
            owner: "beam look-up".to_string(),
            kind: "beam",
            index: beam,
            count: self.beams.len(),
        })
    }

    /// Joint number `joint`, or an index error.
    pub fn joint(&self, joint: usize) -> Result<&Joint> {
        self.joints.get(joint).ok_or(FemError::IndexOutOfRange {
            owner: "joint look-up".to_string(),
            kind: "joint",
            index: joint,
            count: self.joints.len(),
        })
    }

    /// Axial spring number `spring`, or an index error.
    pub fn spring(&self, spring: usize) -> Result<&Spring> {
        self.springs.get(spring).ok_or(FemError::IndexOutOfRange {
            owner: "spring look-up".to_string(),
            kind: "spring",
            index: spring,
            count: self.springs.len(),
        })
    }

    /// Checks a load case against this structure (node indices, finite values).
    pub fn check_load_case(&self, case: &LoadCase) -> Result<()> {
        let owner = format!("load case '{}'", case.name);
        check_finite_vector(&|| owner.clone(), "gravity", &case.gravity)?;
        for (node, wrench) in &case.nodal_loads {
            self.check_node(&owner, *node)?;
            if !wrench.iter().all(|x| x.is_finite()) {
                return Err(invalid(
                    &owner,
                    "nodal_loads",
                    format!("node '{}': not finite", self.node_names[*node]),
                ));
            }
        }
        Ok(())
    }

    fn joint_checked(&self, joint: usize) -> Result<&Joint> {
        self.joints
            .get(joint)
            .ok_or_else(|| FemError::IndexOutOfRange {
                owner: "joint update".to_string(),
                kind: "joint",
                index: joint,
                count: self.joints.len(),
            })
    }

    fn check_element_name(&self, name: &str) -> Result<()> {
        let taken = self.beams.iter().any(|b| b.name == name)
            || self.joints.iter().any(|b| b.name == name)
            || self.springs.iter().any(|b| b.name == name);
        if taken {
            Err(FemError::DuplicateName {
                kind: "element",
                name: name.to_string(),
            })
        } else {
            Ok(())
        }
    }

    pub(crate) fn check_node(&self, owner: &str, node: NodeId) -> Result<()> {
        if node < self.positions.len() {
            Ok(())
        } else {
            Err(FemError::IndexOutOfRange {
                owner: owner.to_string(),
                kind: "node",
                index: node,
                count: self.positions.len(),
            })
        }
    }

    fn check_pair(&self, owner: &str, i: NodeId, j: NodeId) -> Result<()> {
        self.check_node(owner, i)?;
        self.check_node(owner, j)?;
        if i == j {
            return Err(FemError::ZeroLength {
                element: owner.to_string(),
                node_i: self.node_names[i].clone(),
                node_j: self.node_names[j].clone(),
                length: 0.0,
            });
        }
        Ok(())
    }
}

fn check_joint_values(
    owner: &dyn Fn() -> String,
    axis: &Vector3<f64>,
    local_y: Option<&Vector3<f64>>,
    stiffness: &[f64; 6],
) -> Result<()> {
    check_finite_vector(owner, "axis", axis)?;
    if let Some(y) = local_y {
        check_finite_vector(owner, "local_y", y)?;
    }
    const LABELS: [&str; 6] = ["Ka", "Kr (y)", "Kr (z)", "Kar", "Krr (y)", "Krr (z)"];
    for (value, label) in stiffness.iter().zip(LABELS) {
        if !(value.is_finite() && *value >= 0.0) {
            return Err(invalid(
                &owner(),
                &format!("stiffness {label}"),
                format!("must be non-negative and finite, got {value}"),
            ));
        }
    }
    let radial_differ = stiffness[1] != stiffness[2] || stiffness[4] != stiffness[5];
    if local_y.is_none() && radial_differ {
        return Err(invalid(
            &owner(),
            "local_y",
            "required when the y and z radial stiffnesses differ",
        ));
    }
    Ok(())
}

//! A URDF reader: the kinematic content of a `.urdf` file (links, joints,
//! their origins, axes, limits, mimic relations, and the links' masses) as
//! typed values, every error naming the file and line.
//!
//! Only what flexcal uses is read. Visual and collision geometry, meshes,
//! inertia tensors, transmissions, Gazebo and other extension tags are
//! ignored. xacro macros are refused: expand the file first
//! (`xacro robot.urdf.xacro > robot.urdf`).
//!
//! Conventions of the URDF specification (ROS wiki, "urdf/XML/joint" and
//! "urdf/XML/link"): `<origin xyz rpy>` places the joint frame in the parent
//! link's frame, with `R = Rz(yaw) Ry(pitch) Rx(roll)` (fixed axes X, Y, Z);
//! a missing `<origin>` is the identity; a missing `<axis>` is (1, 0, 0);
//! axes are normalised (as urdfdom and KDL do); the child link's frame is
//! the joint frame moved by the joint value about or along the axis;
//! `<mimic joint multiplier offset>` sets `value = multiplier * leader + offset`
//! (multiplier 1 and offset 0 by default).

use std::collections::HashMap;

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::KinematicsError;

/// XML namespaces of xacro, whose elements must be expanded before import.
const XACRO_NAMESPACES: [&str; 2] = ["http://www.ros.org/wiki/xacro", "http://wiki.ros.org/xacro"];

const EXPAND_FIRST: &str = "expand the file first (`xacro FILE.urdf.xacro > FILE.urdf`)";

/// Kind of a URDF joint (the `type` attribute).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UrdfJointKind {
    /// Rotation about the axis within limits.
    Revolute,
    /// Rotation about the axis without limits.
    Continuous,
    /// Translation along the axis.
    Prismatic,
    /// No motion.
    Fixed,
    /// Six degrees of freedom (not importable on the path to the tip).
    Floating,
    /// Motion in the plane normal to the axis (not importable on the path to the tip).
    Planar,
}

impl UrdfJointKind {
    /// True for the kinds that move with one coordinate.
    pub fn is_single_dof(self) -> bool {
        matches!(
            self,
            UrdfJointKind::Revolute | UrdfJointKind::Continuous | UrdfJointKind::Prismatic
        )
    }
}

/// `<mimic>`: the joint follows another one.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfMimic {
    /// Name of the leading joint.
    pub joint: String,
    /// Multiplier (dimensionless for joints of the same kind).
    pub multiplier: f64,
    /// Offset (rad for a revolute follower, m for a prismatic one).
    pub offset: f64,
}

/// A URDF joint.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfJoint {
    /// Joint name.
    pub name: String,
    /// 1-based line of the `<joint>` element.
    pub line: usize,
    /// Joint type.
    pub kind: UrdfJointKind,
    /// Parent link.
    pub parent: String,
    /// Child link.
    pub child: String,
    /// Joint frame in the parent link's frame (m, rad).
    pub origin: Isometry3<f64>,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    /// `<limit lower upper>` (rad or m), when given.
    pub limits: Option<(f64, f64)>,
    /// `<mimic>`, when given.
    pub mimic: Option<UrdfMimic>,
}

/// The mass of a link, from its `<inertial>`.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfInertial {
    /// Mass (kg).
    pub mass_kg: f64,
    /// Centre of mass in the link frame (m).
    pub center_m: Vector3<f64>,
}

/// A URDF link (only what kinematics and gravity need).
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfLink {
    /// Link name.
    pub name: String,
    /// 1-based line of the `<link>` element.
    pub line: usize,
    /// Mass and centre of mass, when the link has an `<inertial>`.
    pub inertial: Option<UrdfInertial>,
}

/// The kinematic tree of a URDF file, validated: names unique, every joint
/// between known links, every link the child of at most one joint, one root,
/// no cycle, mimic leaders known.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfRobot {
    /// The file (or other source) the text came from.
    pub source_name: String,
    /// `<robot name>`.
    pub name: String,
    /// Links in file order.
    pub links: Vec<UrdfLink>,
    /// Joints in file order.
    pub joints: Vec<UrdfJoint>,
}

fn urdf_error(source: &str, line: usize, message: impl Into<String>) -> KinematicsError {
    KinematicsError::Urdf {
        source_name: source.to_string(),
        line,
        message: message.into(),
    }
}

struct Reader<'a, 'input> {
    source: &'a str,
    doc: &'a roxmltree::Document<'input>,
}

impl Reader<'_, '_> {
    fn line(&self, node: roxmltree::Node) -> usize {
        self.doc.text_pos_at(node.range().start).row as usize
    }

    fn error(&self, node: roxmltree::Node, message: impl Into<String>) -> KinematicsError {
        urdf_error(self.source, self.line(node), message)
    }

    fn required<'n>(
        &self,
        node: roxmltree::Node<'n, '_>,
        attribute: &str,
    ) -> Result<&'n str, KinematicsError> {
        node.attribute(attribute).ok_or_else(|| {
            self.error(
                node,
                format!(
                    "<{}> has no `{attribute}` attribute",
                    node.tag_name().name()
                ),
            )
        })
    }

    fn number(
        &self,
        node: roxmltree::Node,
        attribute: &str,
        text: &str,
    ) -> Result<f64, KinematicsError> {
        let value: f64 = text.trim().parse().map_err(|_| {
            self.error(
                node,
                format!(
                    "<{}> {attribute}=\"{text}\" is not a number",
                    node.tag_name().name()
                ),
            )
        })?;
        if !value.is_finite() {
            return Err(self.error(
                node,
                format!(
                    "<{}> {attribute}=\"{text}\" is not finite",
                    node.tag_name().name()
                ),
            ));
        }
        Ok(value)
    }

    fn optional_number(
        &self,
        node: roxmltree::Node,
        attribute: &str,
        default: f64,
    ) -> Result<f64, KinematicsError> {
        match node.attribute(attribute) {
            Some(text) => self.number(node, attribute, text),
            None => Ok(default),
        }
    }

    fn triple(
        &self,
        node: roxmltree::Node,
        attribute: &str,
        default: [f64; 3],
    ) -> Result<Vector3<f64>, KinematicsError> {
        let Some(text) = node.attribute(attribute) else {
            return Ok(Vector3::from(default));
        };
        let parts: Vec<&str> = text.split_whitespace().collect();
        if parts.len() != 3 {
            return Err(self.error(
                node,
                format!(
                    "<{}> {attribute}=\"{text}\" needs three numbers",
                    node.tag_name().name()
                ),
            ));
        }
        let mut v = Vector3::zeros();
        for (k, part) in parts.iter().enumerate() {
            v[k] = self.number(node, attribute, part)?;
        }
        Ok(v)
    }

    /// `<origin xyz rpy>` of `parent`, identity when absent.
    fn origin(&self, parent: roxmltree::Node) -> Result<Isometry3<f64>, KinematicsError> {
        match child(parent, "origin") {
            None => Ok(Isometry3::identity()),
            Some(o) => {
                let xyz = self.triple(o, "xyz", [0.0; 3])?;
                let rpy = self.triple(o, "rpy", [0.0; 3])?;
                Ok(isometry_from_xyz_rpy(&xyz, &rpy))
            }
        }
    }
}

/// The transform of a URDF `<origin>`: translation `xyz` (m) and rotation
/// `R = Rz(rpy[2]) Ry(rpy[1]) Rx(rpy[0])` (rad).
pub fn isometry_from_xyz_rpy(xyz: &Vector3<f64>, rpy: &Vector3<f64>) -> Isometry3<f64> {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    let rz = Matrix3::new(cy, -sy, 0.0, sy, cy, 0.0, 0.0, 0.0, 1.0);
    let ry = Matrix3::new(cp, 0.0, sp, 0.0, 1.0, 0.0, -sp, 0.0, cp);
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cr, -sr, 0.0, sr, cr);
    let rotation = Rotation3::from_matrix_unchecked(rz * ry * rx);
    Isometry3::from_parts(
        Translation3::from(*xyz),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
}

fn child<'a, 'input>(
    node: roxmltree::Node<'a, 'input>,
    name: &str,
) -> Option<roxmltree::Node<'a, 'input>> {
    node.children().find(|c| {
        c.is_element() && c.tag_name().name() == name && c.tag_name().namespace().is_none()
    })
}

impl UrdfRobot {
    /// Reads URDF text; `source` names it in errors (usually the file name).
    pub fn parse(text: &str, source: &str) -> Result<Self, KinematicsError> {
        let options = roxmltree::ParsingOptions {
            allow_dtd: false,
            nodes_limit: 1_000_000,
            ..roxmltree::ParsingOptions::default()
        };
        let doc = roxmltree::Document::parse_with_options(text, options).map_err(|e| {
            // An undeclared `xacro:` prefix makes the XML itself invalid.
            match text.find("<xacro:") {
                Some(at) => urdf_error(
                    source,
                    text[..at].matches('\n').count() + 1,
                    format!("a xacro element: {EXPAND_FIRST}"),
                ),
                None => urdf_error(
                    source,
                    e.pos().row as usize,
                    format!("not well-formed XML: {e}"),
                ),
            }
        })?;
        let reader = Reader { source, doc: &doc };
        let robot = doc.root_element();
        for node in doc.descendants().filter(|n| n.is_element()) {
            let xacro_element = node
                .tag_name()
                .namespace()
                .is_some_and(|n| XACRO_NAMESPACES.contains(&n));
            let xacro_expression = node
                .attributes()
                .any(|a| a.value().contains("${") || a.value().contains("$("));
            if xacro_element || xacro_expression {
                return Err(reader.error(
                    node,
                    format!(
                        "xacro {} in <{}>: {EXPAND_FIRST}",
                        if xacro_element {
                            "element"
                        } else {
                            "expression"
                        },
                        node.tag_name().name()
                    ),
                ));
            }
        }
        if robot.tag_name().name() != "robot" {
            return Err(reader.error(
                robot,
                format!(
                    "the root element is <{}>, not <robot>",
                    robot.tag_name().name()
                ),
            ));
        }
        let name = robot.attribute("name").unwrap_or("").to_string();
        let mut links = Vec::new();
        let mut joints = Vec::new();
        for node in robot.children().filter(|n| n.is_element()) {
            if node.tag_name().namespace().is_some() {
                continue;
            }
            match node.tag_name().name() {
                "link" => links.push(read_link(&reader, node)?),
                "joint" => joints.push(read_joint(&reader, node)?),
                _ => {}
            }
        }
        let robot = UrdfRobot {
            source_name: source.to_string(),
            name,
            links,
            joints,
        };
        robot.validate()?;
        Ok(robot)
    }

    /// Reads a `.urdf` file.
    pub fn read(path: &std::path::Path) -> Result<Self, KinematicsError> {
        let text = std::fs::read_to_string(path).map_err(|e| KinematicsError::File {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    fn validate(&self) -> Result<(), KinematicsError> {
        let source = self.source_name.as_str();
        if self.links.is_empty() {
            return Err(urdf_error(source, 0, "the robot has no <link>"));
        }
        let mut link_line: HashMap<&str, usize> = HashMap::new();
        for l in &self.links {
            if link_line.insert(l.name.as_str(), l.line).is_some() {
                return Err(urdf_error(
                    source,
                    l.line,
                    format!("link `{}` is declared twice", l.name),
                ));
            }
        }
        let mut joint_index: HashMap<&str, usize> = HashMap::new();
        let mut parent_joint: HashMap<&str, &UrdfJoint> = HashMap::new();
        for (k, j) in self.joints.iter().enumerate() {
            if joint_index.insert(j.name.as_str(), k).is_some() {
                return Err(urdf_error(
                    source,
                    j.line,
                    format!("joint `{}` is declared twice", j.name),
                ));
            }
            for link in [&j.parent, &j.child] {
                if !link_line.contains_key(link.as_str()) {
                    return Err(urdf_error(
                        source,
                        j.line,
                        format!("joint `{}` names an unknown link `{link}`", j.name),
                    ));
                }
            }
            if j.parent == j.child {
                return Err(urdf_error(
                    source,
                    j.line,
                    format!("joint `{}` joins link `{}` to itself", j.name, j.parent),
                ));
            }
            if let Some(other) = parent_joint.insert(j.child.as_str(), j) {
                return Err(urdf_error(
                    source,
                    j.line,
                    format!(
                        "link `{}` is the child of joints `{}` and `{}`: a kinematic loop, which a URDF tree cannot hold (describe the loop in flexcal's TOML with a cut joint)",
                        j.child, other.name, j.name
                    ),
                ));
            }
        }
        let roots: Vec<&str> = self
            .links
            .iter()
            .map(|l| l.name.as_str())
            .filter(|l| !parent_joint.contains_key(l))
            .collect();
        match roots.len() {
            1 => {}
            0 => {
                return Err(urdf_error(
                    source,
                    0,
                    "every link is the child of a joint: the joints form a loop",
                ));
            }
            _ => {
                return Err(urdf_error(
                    source,
                    0,
                    format!(
                        "the links form {} separate trees (roots: {}); join them with joints",
                        roots.len(),
                        roots.join(", ")
                    ),
                ));
            }
        }
        // With one root and one parent per link, a link that cannot reach
        // the root lies on a cycle.
        for l in &self.links {
            let mut link = l.name.as_str();
            let mut steps = 0;
            while let Some(j) = parent_joint.get(link) {
                link = j.parent.as_str();
                steps += 1;
                if steps > self.joints.len() {
                    return Err(urdf_error(
                        source,
                        l.line,
                        format!("link `{}` lies on a cycle of joints", l.name),
                    ));
                }
            }
        }
        for j in &self.joints {
            if let Some(m) = &j.mimic {
                match joint_index.get(m.joint.as_str()) {
                    None => {
                        return Err(urdf_error(
                            source,
                            j.line,
                            format!("joint `{}` mimics an unknown joint `{}`", j.name, m.joint),
                        ));
                    }
                    Some(&k) if !self.joints[k].kind.is_single_dof() => {
                        return Err(urdf_error(
                            source,
                            j.line,
                            format!(
                                "joint `{}` mimics `{}`, which is not revolute, continuous or prismatic",
                                j.name, m.joint
                            ),
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
        Ok(())
    }

    /// The root link (the one link that is no joint's child).
    pub fn root_link(&self) -> &str {
        self.links
            .iter()
            .map(|l| l.name.as_str())
            .find(|l| !self.joints.iter().any(|j| j.child == *l))
            .unwrap_or("")
    }

    /// A joint by name.
    pub fn joint(&self, name: &str) -> Option<&UrdfJoint> {
        self.joints.iter().find(|j| j.name == name)
    }

    /// A link by name.
    pub fn link(&self, name: &str) -> Option<&UrdfLink> {
        self.links.iter().find(|l| l.name == name)
    }

    /// The joint whose child is `link` (None for the root).
    pub fn parent_joint(&self, link: &str) -> Option<&UrdfJoint> {
        self.joints.iter().find(|j| j.child == link)
    }

    /// Links without children, in file order.
    pub fn leaves(&self) -> Vec<&str> {
        self.links
            .iter()
            .map(|l| l.name.as_str())
            .filter(|l| !self.joints.iter().any(|j| j.parent == *l))
            .collect()
    }
}

fn read_link(reader: &Reader, node: roxmltree::Node) -> Result<UrdfLink, KinematicsError> {
    let name = reader.required(node, "name")?.to_string();
    let inertial = match child(node, "inertial") {
        None => None,
        Some(inertial) => {
            let origin = reader.origin(inertial)?;
            match child(inertial, "mass") {
                None => None,
                Some(mass) => {
                    let value = reader.required(mass, "value")?;
                    let mass_kg = reader.number(mass, "value", value)?;
                    if mass_kg < 0.0 {
                        return Err(
                            reader.error(mass, format!("link `{name}` has a negative mass"))
                        );
                    }
                    Some(UrdfInertial {
                        mass_kg,
                        center_m: origin.translation.vector,
                    })
                }
            }
        }
    };
    Ok(UrdfLink {
        name,
        line: reader.line(node),
        inertial,
    })
}

fn read_joint(reader: &Reader, node: roxmltree::Node) -> Result<UrdfJoint, KinematicsError> {
    let name = reader.required(node, "name")?.to_string();
    let kind_text = reader.required(node, "type")?;
    let kind = match kind_text {
        "revolute" => UrdfJointKind::Revolute,
        "continuous" => UrdfJointKind::Continuous,
        "prismatic" => UrdfJointKind::Prismatic,
        "fixed" => UrdfJointKind::Fixed,
        "floating" => UrdfJointKind::Floating,
        "planar" => UrdfJointKind::Planar,
        other => {
            return Err(reader.error(
                node,
                format!("joint `{name}` has an unknown type `{other}`"),
            ));
        }
    };
    let link_of = |tag: &str| -> Result<String, KinematicsError> {
        let element = child(node, tag)
            .ok_or_else(|| reader.error(node, format!("joint `{name}` has no <{tag}>")))?;
        Ok(reader.required(element, "link")?.to_string())
    };
    let parent = link_of("parent")?;
    let child_link = link_of("child")?;
    let origin = reader.origin(node)?;
    let axis = match child(node, "axis") {
        None => Vector3::x(),
        Some(a) => {
            let v = reader.triple(a, "xyz", [1.0, 0.0, 0.0])?;
            let norm = v.norm();
            if kind != UrdfJointKind::Fixed && norm <= 1e-12 {
                return Err(reader.error(a, format!("joint `{name}` has a zero axis")));
            }
            if norm > 0.0 { v / norm } else { Vector3::x() }
        }
    };
    let limits = match child(node, "limit") {
        None => None,
        Some(l) => {
            let lower = reader.optional_number(l, "lower", 0.0)?;
            let upper = reader.optional_number(l, "upper", 0.0)?;
            if lower > upper {
                return Err(reader.error(
                    l,
                    format!(
                        "joint `{name}`: inverted limits, lower = {lower} is above upper = {upper}"
                    ),
                ));
            }
            Some((lower, upper))
        }
    };
    let mimic = match child(node, "mimic") {
        None => None,
        Some(m) => Some(UrdfMimic {
            joint: reader.required(m, "joint")?.to_string(),
            multiplier: reader.optional_number(m, "multiplier", 1.0)?,
            offset: reader.optional_number(m, "offset", 0.0)?,
        }),
    };
    Ok(UrdfJoint {
        name,
        line: reader.line(node),
        kind,
        parent,
        child: child_link,
        origin,
        axis,
        limits,
        mimic,
    })
}

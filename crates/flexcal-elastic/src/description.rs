//! The elastic description of a robot (TOML, SI units) and the built-in
//! IR-663 description of the reference paper's Figure 8.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{ElasticError, Result};

/// An elastic description: the nodes of a frame structure attached to robot
/// frames, the beams, joint springs and axial springs between them, the
/// supports and the masses. Everything is in SI units except node offsets
/// (`offset_mm`).
///
/// ```toml
/// name = "two-link"
/// tcp = "E"
/// nodes = [ { name = "0", frame = "0" }, { name = "1", frame = "1" },
///           { name = "E", frame = "E", offset_mm = [0.0, 0.0, 0.0] } ]
/// beams = [ { name = "arm", i = "1", j = "E", vecxz = [0.0, 0.0, 1.0],
///             section = { e_pa = 2.1e11, g_pa = 8.1e10, area_m2 = 1e-2,
///                         iy_m4 = 1e-4, iz_m4 = 1e-4, j_m4 = 2e-4 } } ]
/// joints = [ { name = "01", i = "0", j = "1", axis_frame = "1", ka_n_m = 1e12,
///              kr_n_m = 1e12, kar_nm_rad = 2e6, krr_nm_rad = 1e11, identify = ["kar"] } ]
/// supports = [ { node = "0" } ]
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElasticDescription {
    /// Name of the description.
    pub name: String,
    /// Free text: where the values come from, what is assumed.
    #[serde(default)]
    pub notes: String,
    /// Name of the node at the tool centre point, onto which the structure is condensed.
    pub tcp: String,
    /// Gravity acceleration in the robot base frame (m/s^2) (default `[0, 0, -9.81]`).
    #[serde(default = "default_gravity")]
    pub gravity_m_s2: [f64; 3],
    /// Nodes, each attached to a robot frame.
    pub nodes: Vec<NodeDescription>,
    /// Beams between nodes.
    #[serde(default)]
    pub beams: Vec<BeamDescription>,
    /// Joint springs diag(Ka, Kr, Kr, Kar, Krr, Krr) about a frame's z axis (17)-(18).
    #[serde(default)]
    pub joints: Vec<JointDescription>,
    /// Axial springs along the line between two nodes (e.g. actuator screws).
    #[serde(default)]
    pub springs: Vec<SpringDescription>,
    /// Supported nodes (60).
    #[serde(default)]
    pub supports: Vec<SupportDescription>,
    /// Point masses at nodes (their weight enters the gravity load).
    #[serde(default)]
    pub point_masses: Vec<PointMassDescription>,
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// A node attached to a robot frame: its position is `x_base_frame * offset`
/// in the configuration the model is evaluated at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDescription {
    /// Node name (unique).
    pub name: String,
    /// Robot frame the node moves with (`"0"` is the base frame R0).
    pub frame: String,
    /// Offset of the node in that frame (mm) (default zero).
    #[serde(default)]
    pub offset_mm: [f64; 3],
}

/// Cross-section and material of a beam (SI).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionDescription {
    /// Young's modulus E (Pa), > 0.
    pub e_pa: f64,
    /// Shear modulus G (Pa), > 0.
    pub g_pa: f64,
    /// Area A (m^2), > 0.
    pub area_m2: f64,
    /// Second moment of area about the local y axis (m^4), > 0: deflection
    /// along local z (out of the arm plane when `vecxz` is the joint axis).
    pub iy_m4: f64,
    /// Second moment of area about the local z axis (m^4), > 0: deflection
    /// along local y (in the robot's arm plane when `vecxz` is the joint axis).
    pub iz_m4: f64,
    /// Torsion constant J (m^4), > 0.
    pub j_m4: f64,
    /// Shear area along local y (m^2); when given, Timoshenko bending.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_area_y_m2: Option<f64>,
    /// Shear area along local z (m^2); when given, Timoshenko bending.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_area_z_m2: Option<f64>,
}

impl SectionDescription {
    /// The finite-element section.
    pub fn to_fem(&self) -> flexcal_fem::Section {
        flexcal_fem::Section {
            youngs_modulus: self.e_pa,
            shear_modulus: self.g_pa,
            area: self.area_m2,
            iy: self.iy_m4,
            iz: self.iz_m4,
            torsion_constant: self.j_m4,
            shear_area_y: self.shear_area_y_m2,
            shear_area_z: self.shear_area_z_m2,
        }
    }

    /// A thin-walled rectangular steel box `depth x width` with wall `wall`
    /// (m): depth along local y (in-plane bending uses `iz`), width along local z.
    pub fn steel_box(depth: f64, width: f64, wall: f64) -> Self {
        let (h, b, t) = (depth, width, wall);
        let area = b * h - (b - 2.0 * t) * (h - 2.0 * t);
        let iz = (b * h.powi(3) - (b - 2.0 * t) * (h - 2.0 * t).powi(3)) / 12.0;
        let iy = (h * b.powi(3) - (h - 2.0 * t) * (b - 2.0 * t).powi(3)) / 12.0;
        // Bredt's formula for a closed thin-walled section.
        let (hm, bm) = (h - t, b - t);
        let j = 4.0 * (hm * bm).powi(2) * t / (2.0 * (hm + bm));
        Self::steel(area, iy, iz, j)
    }

    /// A steel tube of outer diameter `outer` and wall `wall` (m).
    pub fn steel_tube(outer: f64, wall: f64) -> Self {
        let (ro, ri) = (outer / 2.0, outer / 2.0 - wall);
        let area = std::f64::consts::PI * (ro * ro - ri * ri);
        let i = std::f64::consts::FRAC_PI_4 * (ro.powi(4) - ri.powi(4));
        Self::steel(area, i, i, 2.0 * i)
    }

    fn steel(area: f64, iy: f64, iz: f64, j: f64) -> Self {
        Self {
            e_pa: STEEL_E_PA,
            g_pa: STEEL_G_PA,
            area_m2: area,
            iy_m4: iy,
            iz_m4: iz,
            j_m4: j,
            shear_area_y_m2: None,
            shear_area_z_m2: None,
        }
    }
}

/// Young's modulus of steel used by the built-in descriptions (Pa).
pub const STEEL_E_PA: f64 = 2.1e11;
/// Shear modulus of steel used by the built-in descriptions (Pa).
pub const STEEL_G_PA: f64 = 8.1e10;
/// Density of steel used by the built-in descriptions (kg/m^3).
pub const STEEL_DENSITY: f64 = 7850.0;

/// A beam between two nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamDescription {
    /// Element name (unique among beams, joints and springs).
    pub name: String,
    /// First node.
    pub i: String,
    /// Second node.
    pub j: String,
    /// Section and material.
    pub section: SectionDescription,
    /// A vector in the beam's local x-z plane, in the frame `vecxz_frame`.
    pub vecxz: [f64; 3],
    /// Frame in which `vecxz` is given (default: the frame of node `i`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vecxz_frame: Option<String>,
    /// Mass per length (kg/m) (default 0), for the own-weight load.
    #[serde(default)]
    pub mass_per_length_kg_m: f64,
}

/// Which stiffness component of a joint a parameter stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointComponent {
    /// Ka: translation along the axis (N/m).
    Ka,
    /// Kr: translation across the axis, both radial directions (N/m).
    Kr,
    /// Kar: rotation about the axis (N.m/rad).
    Kar,
    /// Krr: rotation about the radial directions (N.m/rad).
    Krr,
}

impl JointComponent {
    /// All components in storage order.
    pub const ALL: [JointComponent; 4] = [
        JointComponent::Ka,
        JointComponent::Kr,
        JointComponent::Kar,
        JointComponent::Krr,
    ];

    /// Indices in the fem joint stiffness `[Ka, Kr, Kr, Kar, Krr, Krr]`.
    pub fn fem_indices(self) -> &'static [usize] {
        match self {
            JointComponent::Ka => &[0],
            JointComponent::Kr => &[1, 2],
            JointComponent::Kar => &[3],
            JointComponent::Krr => &[4, 5],
        }
    }

    /// Prefix of parameter names (`Kar` gives `Kar_12`).
    pub fn symbol(self) -> &'static str {
        match self {
            JointComponent::Ka => "Ka",
            JointComponent::Kr => "Kr",
            JointComponent::Kar => "Kar",
            JointComponent::Krr => "Krr",
        }
    }

    /// Unit of the component.
    pub fn unit(self) -> &'static str {
        match self {
            JointComponent::Ka | JointComponent::Kr => "N/m",
            JointComponent::Kar | JointComponent::Krr => "N.m/rad",
        }
    }
}

/// A joint spring between two (normally coincident) nodes, its axis the z
/// axis of a robot frame: stiffness diag(Ka, Kr, Kr, Kar, Krr, Krr) (17)-(18).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointDescription {
    /// Element name (unique); parameter names are `<component>_<name>`.
    pub name: String,
    /// First node.
    pub i: String,
    /// Second node.
    pub j: String,
    /// Frame whose z axis is the joint axis.
    pub axis_frame: String,
    /// Axial translational stiffness Ka (N/m), >= 0.
    pub ka_n_m: f64,
    /// Radial translational stiffness Kr (N/m), >= 0.
    pub kr_n_m: f64,
    /// Rotational stiffness about the axis Kar (N.m/rad), >= 0 (0: free joint).
    pub kar_nm_rad: f64,
    /// Rotational stiffness about the radial directions Krr (N.m/rad), >= 0.
    pub krr_nm_rad: f64,
    /// Components to identify (the vector Gamma), e.g. `["kar", "kr"]`; the
    /// values above are their nominal values. Identified components must be > 0.
    #[serde(default)]
    pub identify: Vec<JointComponent>,
}

impl JointDescription {
    /// Value of one component (N/m or N.m/rad).
    pub fn component(&self, c: JointComponent) -> f64 {
        match c {
            JointComponent::Ka => self.ka_n_m,
            JointComponent::Kr => self.kr_n_m,
            JointComponent::Kar => self.kar_nm_rad,
            JointComponent::Krr => self.krr_nm_rad,
        }
    }
}

/// An axial spring along the line between two nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringDescription {
    /// Element name (unique).
    pub name: String,
    /// First node.
    pub i: String,
    /// Second node.
    pub j: String,
    /// Stiffness (N/m), >= 0. Springs are not part of Gamma: flexcal-fem
    /// cannot change a spring's stiffness after assembly yet.
    pub k_n_m: f64,
}

/// A supported node (boundary condition (60)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupportDescription {
    /// Node name.
    pub node: String,
    /// Fixed degrees of freedom `[ux, uy, uz, rx, ry, rz]` in base axes (default all).
    #[serde(default = "all_fixed")]
    pub fixed: [bool; 6],
}

fn all_fixed() -> [bool; 6] {
    [true; 6]
}

/// A point mass at a node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointMassDescription {
    /// Node name.
    pub node: String,
    /// Mass (kg), >= 0.
    pub mass_kg: f64,
}

/// Names of the built-in elastic descriptions.
pub fn builtin_elastic_names() -> &'static [&'static str] {
    &["ir663"]
}

impl ElasticDescription {
    /// A built-in description by name (see [`builtin_elastic_names`]).
    ///
    /// # Errors
    /// [`ElasticError::UnknownBuiltin`] for another name.
    pub fn builtin(name: &str) -> Result<Self> {
        match name {
            "ir663" => Ok(ir663()),
            _ => Err(ElasticError::UnknownBuiltin {
                name: name.to_string(),
                known: builtin_elastic_names().join(", "),
            }),
        }
    }

    /// Parses TOML text; `path` only names the source in messages.
    ///
    /// # Errors
    /// [`ElasticError::Parse`] with the parser's line and column.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self> {
        toml::from_str(text).map_err(|e| ElasticError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }

    /// Reads a TOML file.
    ///
    /// # Errors
    /// I/O and parse errors naming the file.
    pub fn from_toml_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = flexcal_io::read_to_string(path)?;
        Self::from_toml_str(&text, path)
    }

    /// A built-in name or, failing that, a TOML file path.
    ///
    /// # Errors
    /// As [`ElasticDescription::from_toml_file`].
    pub fn builtin_or_file(name_or_path: &str) -> Result<Self> {
        if builtin_elastic_names().contains(&name_or_path) {
            Self::builtin(name_or_path)
        } else {
            Self::from_toml_file(name_or_path)
        }
    }

    /// TOML text of the description.
    ///
    /// # Errors
    /// [`ElasticError::Parse`] if a value cannot be written (never for finite values).
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string_pretty(self).map_err(|e| ElasticError::Parse {
            path: "<memory>".into(),
            message: e.to_string(),
        })
    }
}

/// Table 3 of the reference paper (design 1), read in N.mm/rad and N/mm as
/// the reading notes explain, converted to SI.
pub mod ir663_table3 {
    /// Kar of the actuated joint 2 (nodes 1-2) (N.m/rad).
    pub const KAR_12: f64 = 1.72e6;
    /// Kar of the actuated joint 8 (nodes 1-8) (N.m/rad).
    pub const KAR_18: f64 = 1.56e6;
    /// Kr of joint 2 (N/m).
    pub const KR_12: f64 = 5.27e13;
    /// Kr of joint 8 (N/m).
    pub const KR_18: f64 = 2.25e11;
    /// Kr of joint 3 (nodes 3-3') (N/m).
    pub const KR_33: f64 = 5.10e12;
    /// Kr of joint 9 (nodes 9-9') (N/m).
    pub const KR_99: f64 = 6.63e8;
    /// Kr of joint 10 (nodes 10-10') (N/m).
    pub const KR_1010: f64 = 6.12e7;
}

/// Stiffness given to the directions the planar campaign cannot excite:
/// joint axial translation Ka (N/m).
pub const IR663_KA: f64 = 1e12;
/// Stiffness given to the joint rotations about radial axes Krr (N.m/rad).
pub const IR663_KRR: f64 = 1e11;

/// Sections of the IR-663 links (plausible assumptions; the paper gives none).
pub mod ir663_sections {
    use super::SectionDescription;

    /// Base column 0-1: steel tube 500 mm x 30 mm.
    pub fn column() -> SectionDescription {
        SectionDescription::steel_tube(0.5, 0.03)
    }
    /// Upper arm 2-3: steel box 350 mm (in plane) x 250 mm x 20 mm.
    pub fn upper_arm() -> SectionDescription {
        SectionDescription::steel_box(0.35, 0.25, 0.02)
    }
    /// Forearm 3'-10-E: steel box 250 mm (in plane) x 200 mm x 15 mm.
    pub fn forearm() -> SectionDescription {
        SectionDescription::steel_box(0.25, 0.2, 0.015)
    }
    /// Crank 8-9: steel box 150 mm (in plane) x 100 mm x 25 mm.
    pub fn crank() -> SectionDescription {
        SectionDescription::steel_box(0.15, 0.1, 0.025)
    }
    /// Coupler 9'-10': steel tube 120 mm x 10 mm.
    pub fn coupler() -> SectionDescription {
        SectionDescription::steel_tube(0.12, 0.01)
    }
}

/// Mass of the wrist, flange and end-effector lumped at the TCP node (kg).
pub const IR663_WRIST_MASS_KG: f64 = 120.0;

pub(crate) fn node(name: &str, frame: &str) -> NodeDescription {
    NodeDescription {
        name: name.into(),
        frame: frame.into(),
        offset_mm: [0.0; 3],
    }
}

pub(crate) fn beam(name: &str, i: &str, j: &str, section: SectionDescription) -> BeamDescription {
    BeamDescription {
        name: name.into(),
        i: i.into(),
        j: j.into(),
        section,
        // The joint axis of the node's frame is normal to the arm plane, so
        // local y lies in the plane and `iz` governs in-plane bending.
        vecxz: [0.0, 0.0, 1.0],
        vecxz_frame: None,
        mass_per_length_kg_m: section.area_m2 * STEEL_DENSITY,
    }
}

pub(crate) fn joint(
    name: &str,
    i: &str,
    j: &str,
    axis_frame: &str,
    kar: f64,
    kr: f64,
    identify: &[JointComponent],
) -> JointDescription {
    JointDescription {
        name: name.into(),
        i: i.into(),
        j: j.into(),
        axis_frame: axis_frame.into(),
        ka_n_m: IR663_KA,
        kr_n_m: kr,
        kar_nm_rad: kar,
        krr_nm_rad: IR663_KRR,
        identify: identify.to_vec(),
    }
}

/// The IR-663 beam model of the paper's Figure 8.
fn ir663() -> ElasticDescription {
    use JointComponent::{Kar, Kr};
    use ir663_sections as s;
    use ir663_table3 as t;
    let nodes = [
        ("0", "0"),
        ("1", "1"),
        ("2", "2"),
        ("3", "3"),
        ("3'", "3"),
        ("10", "10"),
        ("E", "E"),
        ("8", "8"),
        ("9", "9"),
        ("9'", "9"),
        ("10'", "10"),
    ]
    .map(|(n, f)| node(n, f))
    .to_vec();
    let mut column = beam("01", "0", "1", s::column());
    // The column is vertical: any horizontal direction defines its axes.
    column.vecxz = [1.0, 0.0, 0.0];
    column.vecxz_frame = Some("1".into());
    let beams = vec![
        column,
        beam("23", "2", "3", s::upper_arm()),
        beam("3'10", "3'", "10", s::forearm()),
        beam("10E", "10", "E", s::forearm()),
        beam("89", "8", "9", s::crank()),
        beam("9'10'", "9'", "10'", s::coupler()),
    ];
    let joints = vec![
        joint("12", "1", "2", "2", t::KAR_12, t::KR_12, &[Kar, Kr]),
        joint("18", "1", "8", "8", t::KAR_18, t::KR_18, &[Kar, Kr]),
        // Passive joints turn freely (the paper's 1e-10 N.m/rad); the loop
        // keeps the structure from being a mechanism.
        joint("33'", "3", "3'", "3", 0.0, t::KR_33, &[Kr]),
        joint("99'", "9", "9'", "9", 0.0, t::KR_99, &[Kr]),
        joint("1010'", "10", "10'", "10", 0.0, t::KR_1010, &[Kr]),
    ];
    ElasticDescription {
        name: "ir663".into(),
        notes: "KUKA IR-663 beam model after Marie et al. 2013, Figure 8 and (61): nodes 0, 1, 2, 3, \
                3', 10, E, 8, 9, 9', 10' (60 x 60 reduced stiffness matrix), wrist rigid (beam 10-E \
                straight to the TCP), joint springs 1-2, 3-3', 1-8, 9-9', 10-10'. Joint stiffness \
                from Table 3 design 1 read in N.mm/rad and N/mm. Link sections (steel boxes and \
                tubes) and the 120 kg wrist mass are plausible assumptions, not KUKA data. Ka = \
                1e12 N/m and Krr = 1e11 N.m/rad stand for the directions a planar campaign cannot \
                excite; passive joints 3, 9, 10 turn freely."
            .into(),
        tcp: "E".into(),
        gravity_m_s2: default_gravity(),
        nodes,
        beams,
        joints,
        springs: Vec::new(),
        supports: vec![SupportDescription {
            node: "0".into(),
            fixed: all_fixed(),
        }],
        point_masses: vec![PointMassDescription {
            node: "E".into(),
            mass_kg: IR663_WRIST_MASS_KG,
        }],
    }
}

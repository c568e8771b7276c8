//! The structure file (TOML or JSON, chosen by extension) and the
//! file-level results: displacements of every load case, condensation.
//!
//! ```toml
//! nodes      = { N0 = [0.0, 0.0, 0.0], N1 = [1.0, 0.0, 0.0] }
//! supports   = { N0 = [true, true, true, true, true, true] }   # ux uy uz rx ry rz fixed
//! beams      = [ { name = "b1", i = "N0", j = "N1", E = 2.1e11, G = 8.1e10, A = 1e-3,
//!                  Iy = 2e-6, Iz = 1e-6, J = 3e-6, vecxz = [0.0, 0.0, 1.0] } ]
//! joints     = []
//! springs    = []
//! load_cases = [ { name = "tip", nodal_loads = { N1 = [0.0, -100.0, 0.0, 0.0, 0.0, 0.0] } } ]
//! ```
//! Optional beam fields: `Avy`, `Avz` (shear areas, m^2, Timoshenko),
//! `mass_per_length` (kg/m), `releases` (12 booleans, local order
//! `u1 v1 w1 rx1 ry1 rz1 u2 v2 w2 rx2 ry2 rz2`). Joints:
//! `{ name, i, j, axis = [..], local_y? = [..], stiffness = [Ka, Kr, Kr, Kar, Krr, Krr] }`;
//! springs `{ name, i, j, k }`; load cases may carry `gravity = [gx, gy, gz]`
//! (m/s^2). Unknown fields are rejected. Node order is kept as written.

use std::fmt;
use std::marker::PhantomData;
use std::path::Path;

use nalgebra::{Matrix6, Vector3, Vector6};
use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::{Dof, FemError, Result, invalid};
use crate::solve::{Factorization, SolverOptions, assemble_and_factor, load_vector};
use crate::structure::{Beam, Joint, LoadCase, NodeId, Section, Spring, Structure};

/// A map from names to values that keeps the order in which entries were
/// written (TOML and JSON tables), and rejects repeated names.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedMap<V>(pub Vec<(String, V)>);

impl<V> Default for NamedMap<V> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<V> NamedMap<V> {
    /// Whether the map has no entry.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl<V: Serialize> Serialize for NamedMap<V> {
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

struct NamedMapVisitor<V>(PhantomData<V>);

impl<'de, V: Deserialize<'de>> Visitor<'de> for NamedMapVisitor<V> {
    type Value = NamedMap<V>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a table of named entries")
    }

    fn visit_map<A: MapAccess<'de>>(
        self,
        mut access: A,
    ) -> std::result::Result<Self::Value, A::Error> {
        let mut entries: Vec<(String, V)> = Vec::new();
        while let Some((key, value)) = access.next_entry::<String, V>()? {
            if entries.iter().any(|(k, _)| *k == key) {
                return Err(serde::de::Error::custom(format!("duplicate name '{key}'")));
            }
            entries.push((key, value));
        }
        Ok(NamedMap(entries))
    }
}

impl<'de, V: Deserialize<'de>> Deserialize<'de> for NamedMap<V> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        deserializer.deserialize_map(NamedMapVisitor(PhantomData))
    }
}

/// A beam record of a structure file (SI units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct BeamRecord {
    /// Element name.
    pub name: String,
    /// First node's name.
    pub i: String,
    /// Second node's name.
    pub j: String,
    /// Young's modulus (Pa).
    pub E: f64,
    /// Shear modulus (Pa).
    pub G: f64,
    /// Area (m^2).
    pub A: f64,
    /// Second moment about local y (m^4).
    pub Iy: f64,
    /// Second moment about local z (m^4).
    pub Iz: f64,
    /// Torsion constant (m^4).
    pub J: f64,
    /// Vector in the local x-z plane (3 values, global axes).
    pub vecxz: Vec<f64>,
    /// Shear area along local y (m^2) (Timoshenko in the x-y plane).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub Avy: Option<f64>,
    /// Shear area along local z (m^2) (Timoshenko in the x-z plane).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub Avz: Option<f64>,
    /// Mass per length (kg/m) for own weight.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_per_length: Option<f64>,
    /// 12 end releases, local order `u1 v1 w1 rx1 ry1 rz1 u2 v2 w2 rx2 ry2 rz2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub releases: Option<Vec<bool>>,
}

/// A joint record of a structure file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointRecord {
    /// Element name.
    pub name: String,
    /// First node's name.
    pub i: String,
    /// Second node's name.
    pub j: String,
    /// Joint axis (3 values, global axes).
    pub axis: Vec<f64>,
    /// Local y direction (3 values), needed when radial stiffnesses differ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub local_y: Option<Vec<f64>>,
    /// `[Ka, Kr, Kr, Kar, Krr, Krr]` [N/m x3, N.m/rad x3]; 0 = free.
    pub stiffness: Vec<f64>,
}

/// An axial spring record of a structure file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpringRecord {
    /// Element name.
    pub name: String,
    /// First node's name.
    pub i: String,
    /// Second node's name.
    pub j: String,
    /// Stiffness along i->j (N/m).
    pub k: f64,
}

/// A load case record of a structure file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoadCaseRecord {
    /// Load case name.
    pub name: String,
    /// Gravity (m/s^2) (3 values), acting on beams with a mass per length.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Vec<f64>>,
    /// Nodal wrenches `[fx, fy, fz, mx, my, mz]` [N, N.m] by node name.
    #[serde(default)]
    pub nodal_loads: NamedMap<Vec<f64>>,
}

/// A structure file as written: see the module documentation for its shape.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StructureFile {
    /// Node positions (m) by name, in file order.
    pub nodes: NamedMap<Vec<f64>>,
    /// Fixed DOFs `[ux uy uz rx ry rz]` by node name.
    #[serde(default)]
    pub supports: NamedMap<Vec<bool>>,
    /// Beams.
    #[serde(default)]
    pub beams: Vec<BeamRecord>,
    /// Joint elements.
    #[serde(default)]
    pub joints: Vec<JointRecord>,
    /// Axial springs.
    #[serde(default)]
    pub springs: Vec<SpringRecord>,
    /// Load cases.
    #[serde(default)]
    pub load_cases: Vec<LoadCaseRecord>,
}

/// A structure file turned into a validated [`Structure`] and its load cases.
#[derive(Debug, Clone, PartialEq)]
pub struct FemModel {
    /// The structure (node names and order as in the file).
    pub structure: Structure,
    /// The load cases, in file order.
    pub load_cases: Vec<LoadCase>,
}

enum Format {
    Toml,
    Json,
}

fn format_of(path: &Path) -> Result<Format> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "toml" => Ok(Format::Toml),
        Some(e) if e == "json" => Ok(Format::Json),
        _ => Err(FemError::UnknownExtension {
            path: path.to_path_buf(),
        }),
    }
}

fn vector3(owner: &str, field: &str, values: &[f64]) -> Result<Vector3<f64>> {
    if values.len() != 3 {
        return Err(invalid(
            owner,
            field,
            format!("must have 3 values, got {}", values.len()),
        ));
    }
    if !values.iter().all(|v| v.is_finite()) {
        return Err(invalid(owner, field, format!("not finite: {values:?}")));
    }
    Ok(Vector3::new(values[0], values[1], values[2]))
}

fn array<T: Copy + Default, const N: usize>(
    owner: &str,
    field: &str,
    values: &[T],
) -> Result<[T; N]> {
    if values.len() != N {
        return Err(invalid(
            owner,
            field,
            format!("must have {N} values, got {}", values.len()),
        ));
    }
    let mut out = [T::default(); N];
    out.copy_from_slice(values);
    Ok(out)
}

impl StructureFile {
    /// Parses TOML text (`origin` names the source in messages).
    pub fn from_toml_str(text: &str, origin: &Path) -> Result<Self> {
        toml::from_str(text).map_err(|e| {
            // The parser's own text spans several lines; one line with the
            // position reads better in logs and CLI errors.
            let position = e.span().map(|span| {
                let before = &text[..span.start.min(text.len())];
                let line = before.matches('\n').count() + 1;
                let column = before.len() - before.rfind('\n').map_or(0, |p| p + 1) + 1;
                format!("line {line}, column {column}: ")
            });
            FemError::Parse {
                path: origin.to_path_buf(),
                message: format!(
                    "{}{}",
                    position.unwrap_or_default(),
                    e.message().trim_end().replace('\n', " ")
                ),
            }
        })
    }

    /// Parses JSON text (`origin` names the source in messages).
    pub fn from_json_str(text: &str, origin: &Path) -> Result<Self> {
        serde_json::from_str(text).map_err(|e| FemError::Parse {
            path: origin.to_path_buf(),
            message: e.to_string(),
        })
    }

    /// Reads a `.toml` or `.json` structure file.
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let format = format_of(path)?;
        let text = flexcal_io::read_to_string(path)?;
        match format {
            Format::Toml => Self::from_toml_str(&text, path),
            Format::Json => Self::from_json_str(&text, path),
        }
    }

    /// TOML text of this file.
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| FemError::Parse {
            path: "<toml output>".into(),
            message: e.to_string(),
        })
    }

    /// JSON text of this file (pretty-printed).
    pub fn to_json_string(&self) -> Result<String> {
        serde_json::to_string_pretty(self).map_err(|e| FemError::Parse {
            path: "<json output>".into(),
            message: e.to_string(),
        })
    }

    /// Writes the file atomically, TOML or JSON by extension.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let text = match format_of(path)? {
            Format::Toml => self.to_toml_string()?,
            Format::Json => self.to_json_string()?,
        };
        flexcal_io::write_atomic(path, text)?;
        Ok(())
    }

    /// Validates every record and builds the structure and its load cases.
    pub fn build(&self) -> Result<FemModel> {
        let mut s = Structure::new();
        for (name, position) in &self.nodes.0 {
            let owner = format!("node '{name}'");
            s.add_node(name.clone(), vector3(&owner, "position", position)?)?;
        }
        let node = |owner: &str, field: &str, name: &str| -> Result<NodeId> {
            s.find_node(name).ok_or_else(|| FemError::UnknownNode {
                owner: owner.to_string(),
                field: field.to_string(),
                node: name.to_string(),
            })
        };
        let mut supports = Vec::new();
        for (name, fixed) in &self.supports.0 {
            let n = node("supports", name, name)?;
            supports.push((n, array::<bool, 6>("supports", name, fixed)?));
        }
        let mut beams = Vec::new();
        for b in &self.beams {
            let owner = format!("beam '{}'", b.name);
            let releases = match &b.releases {
                Some(r) => array::<bool, 12>(&owner, "releases", r)?,
                None => [false; 12],
            };
            beams.push(Beam {
                name: b.name.clone(),
                i: node(&owner, "i", &b.i)?,
                j: node(&owner, "j", &b.j)?,
                section: Section {
                    youngs_modulus: b.E,
                    shear_modulus: b.G,
                    area: b.A,
                    iy: b.Iy,
                    iz: b.Iz,
                    torsion_constant: b.J,
                    shear_area_y: b.Avy,
                    shear_area_z: b.Avz,
                },
                vecxz: vector3(&owner, "vecxz", &b.vecxz)?,
                releases,
                mass_per_length: b.mass_per_length.unwrap_or(0.0),
            });
        }
        let mut joints = Vec::new();
        for j in &self.joints {
            let owner = format!("joint '{}'", j.name);
            joints.push(Joint {
                name: j.name.clone(),
                i: node(&owner, "i", &j.i)?,
                j: node(&owner, "j", &j.j)?,
                axis: vector3(&owner, "axis", &j.axis)?,
                local_y: match &j.local_y {
                    Some(y) => Some(vector3(&owner, "local_y", y)?),
                    None => None,
                },
                stiffness: array::<f64, 6>(&owner, "stiffness", &j.stiffness)?,
            });
        }
        let mut springs = Vec::new();
        for sp in &self.springs {
            let owner = format!("spring '{}'", sp.name);
            springs.push(Spring {
                name: sp.name.clone(),
                i: node(&owner, "i", &sp.i)?,
                j: node(&owner, "j", &sp.j)?,
                k: sp.k,
            });
        }
        let mut load_cases: Vec<LoadCase> = Vec::new();
        for c in &self.load_cases {
            let owner = format!("load case '{}'", c.name);
            if load_cases.iter().any(|l| l.name == c.name) {
                return Err(FemError::DuplicateName {
                    kind: "load case",
                    name: c.name.clone(),
                });
            }
            let mut case = LoadCase::new(c.name.clone());
            if let Some(g) = &c.gravity {
                case.gravity = vector3(&owner, "gravity", g)?;
            }
            for (name, wrench) in &c.nodal_loads.0 {
                let n = node(&owner, "nodal_loads", name)?;
                let w = array::<f64, 6>(&owner, &format!("nodal_loads.{name}"), wrench)?;
                if !w.iter().all(|v| v.is_finite()) {
                    return Err(invalid(
                        &owner,
                        &format!("nodal_loads.{name}"),
                        format!("not finite: {w:?}"),
                    ));
                }
                case.nodal_loads.push((n, Vector6::from_row_slice(&w)));
            }
            load_cases.push(case);
        }
        for (n, fixed) in supports {
            s.set_support(n, fixed)?;
        }
        for b in beams {
            s.add_beam(b)?;
        }
        for j in joints {
            s.add_joint(j)?;
        }
        for sp in springs {
            s.add_spring(sp)?;
        }
        Ok(FemModel {
            structure: s,
            load_cases,
        })
    }
}

/// Displacements `[ux, uy, uz, rx, ry, rz]` [m, rad] of every node (node
/// order of the structure) for one load case.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseDisplacements {
    /// Load case name.
    pub name: String,
    /// One entry per node, global axes.
    pub nodes: Vec<Vector6<f64>>,
}

/// The condensation of a structure onto one node (equations (24)-(27)).
#[derive(Debug, Clone, PartialEq)]
pub struct Condensation {
    /// The node.
    pub node: NodeId,
    /// Equivalent stiffness K_eq, global axes, `[linear; angular]`.
    pub k_eq: Matrix6<f64>,
    /// Equivalent compliance C_eq = K_eq^{-1} (by solving).
    pub c_eq: Matrix6<f64>,
    /// Equivalent wrench F_eq of each load case, with its name.
    pub f_eq: Vec<(String, Vector6<f64>)>,
}

impl FemModel {
    /// Reads and builds a structure file. Every error names the file:
    /// errors of the structure it describes come as [`FemError::InFile`].
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        StructureFile::read(path)?
            .build()
            .map_err(|source| FemError::InFile {
                path: path.to_path_buf(),
                source: Box::new(source),
            })
    }

    /// Solves every load case with one factorization.
    pub fn solve(&self) -> Result<Vec<CaseDisplacements>> {
        let s = &self.structure;
        let mut factorization = Factorization::new(s, &SolverOptions::default())?;
        assemble_and_factor(s, &mut factorization)?;
        let mut u = vec![0.0; s.dof_count()];
        self.load_cases
            .iter()
            .map(|case| {
                factorization.solve_into(&load_vector(s, case)?, &mut u)?;
                Ok(CaseDisplacements {
                    name: case.name.clone(),
                    nodes: u.chunks_exact(6).map(Vector6::from_row_slice).collect(),
                })
            })
            .collect()
    }

    /// Condenses onto the node named `node`: K_eq, C_eq and F_eq per load case.
    pub fn condense(&self, node: &str) -> Result<Condensation> {
        let s = &self.structure;
        let n = s.find_node(node).ok_or_else(|| FemError::UnknownNode {
            owner: "condensation".to_string(),
            field: "node".to_string(),
            node: node.to_string(),
        })?;
        let mut factorization = Factorization::new(s, &SolverOptions::condensing_onto(n))?;
        assemble_and_factor(s, &mut factorization)?;
        let f_eq = self
            .load_cases
            .iter()
            .map(|case| {
                Ok((
                    case.name.clone(),
                    factorization.f_eq(&load_vector(s, case)?)?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Condensation {
            node: n,
            k_eq: factorization.k_eq()?,
            c_eq: factorization.c_eq()?,
            f_eq,
        })
    }
}

fn json_number(x: f64) -> String {
    // serde_json prints the shortest text that reads back to the same f64.
    serde_json::to_string(&x).unwrap_or_else(|_| "null".to_string())
}

fn json_string(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_else(|_| "\"\"".to_string())
}

fn json_row(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|&v| json_number(v)).collect();
    format!("[{}]", items.join(", "))
}

fn json_matrix(m: &Matrix6<f64>) -> String {
    let rows: Vec<String> = (0..6)
        .map(|r| json_row(&m.row(r).iter().copied().collect::<Vec<_>>()))
        .collect();
    format!("[{}]", rows.join(", "))
}

/// `{"load_cases": {"<case>": {"<node>": [ux, uy, uz, rx, ry, rz]}}}`, in load
/// case and node file order.
pub fn displacements_json(structure: &Structure, cases: &[CaseDisplacements]) -> String {
    let case_items: Vec<String> = cases
        .iter()
        .map(|c| {
            let node_items: Vec<String> = c
                .nodes
                .iter()
                .enumerate()
                .map(|(n, u)| {
                    format!(
                        "{}: {}",
                        json_string(structure.node_name(n)),
                        json_row(u.as_slice())
                    )
                })
                .collect();
            format!("{}: {{{}}}", json_string(&c.name), node_items.join(", "))
        })
        .collect();
    format!("{{\"load_cases\": {{{}}}}}", case_items.join(", "))
}

/// The displacements as text for people: per load case a table of every
/// node's displacements (m) and rotations (rad) in global axes, in load
/// case and node file order (what `displacements_json` holds).
pub fn displacements_text(structure: &Structure, cases: &[CaseDisplacements]) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let names = structure.node_names();
    let width = names.iter().map(String::len).max().unwrap_or(4).max(4);
    for case in cases {
        let _ = writeln!(
            out,
            "load case '{}': displacements [m] and rotations [rad], global axes",
            case.name
        );
        let _ = write!(out, "{:<width$}", "node");
        for dof in Dof::ALL {
            let _ = write!(out, " {:>24}", dof.name());
        }
        out.push('\n');
        for (name, u) in names.iter().zip(&case.nodes) {
            let _ = write!(out, "{name:<width$}");
            for value in u.iter() {
                let _ = write!(out, " {value:>24e}");
            }
            out.push('\n');
        }
        out.push('\n');
    }
    out
}

/// A condensation as text for people: K_eq, C_eq and F_eq per load case at
/// `node`, global axes, order `[ux uy uz rx ry rz]`.
pub fn condensation_text(condensation: &Condensation, node: &str) -> String {
    use std::fmt::Write as _;
    let mut out =
        format!("condensation onto node '{node}', global axes, order [ux uy uz rx ry rz]\n");
    let matrices = [
        ("K_eq [N/m, N/rad; N.m/m, N.m/rad]:", &condensation.k_eq),
        (
            "C_eq = K_eq^-1 [m/N, m/(N.m); rad/N, rad/(N.m)]:",
            &condensation.c_eq,
        ),
    ];
    for (title, m) in matrices {
        let _ = writeln!(out, "{title}");
        for r in 0..6 {
            let _ = write!(out, "  {:<3}", Dof::from_index(r).name());
            for c in 0..6 {
                let _ = write!(out, " {:>24e}", m[(r, c)]);
            }
            out.push('\n');
        }
    }
    let _ = writeln!(out, "F_eq [N, N.m] per load case:");
    for (name, f) in &condensation.f_eq {
        let _ = write!(out, "  {name}:");
        for value in f.iter() {
            let _ = write!(out, " {value:e}");
        }
        out.push('\n');
    }
    out
}

/// `{"K_eq": 6x6, "C_eq": 6x6, "F_eq": {"<case>": [6 values]}}` (rows of the
/// matrices as arrays).
pub fn condensation_json(condensation: &Condensation) -> String {
    let f_items: Vec<String> = condensation
        .f_eq
        .iter()
        .map(|(name, f)| format!("{}: {}", json_string(name), json_row(f.as_slice())))
        .collect();
    format!(
        "{{\"K_eq\": {}, \"C_eq\": {}, \"F_eq\": {{{}}}}}",
        json_matrix(&condensation.k_eq),
        json_matrix(&condensation.c_eq),
        f_items.join(", ")
    )
}

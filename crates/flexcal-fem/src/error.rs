//! The error type of flexcal-fem.

use std::fmt;
use std::path::PathBuf;

/// One of the six degrees of freedom of a node, in global axes, in the order
/// used everywhere in flexcal-fem: `[ux, uy, uz, rx, ry, rz]` (`[linear; angular]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dof {
    /// Translation along x (m).
    Ux,
    /// Translation along y (m).
    Uy,
    /// Translation along z (m).
    Uz,
    /// Rotation about x (rad).
    Rx,
    /// Rotation about y (rad).
    Ry,
    /// Rotation about z (rad).
    Rz,
}

impl Dof {
    /// The six degrees of freedom in storage order.
    pub const ALL: [Dof; 6] = [Dof::Ux, Dof::Uy, Dof::Uz, Dof::Rx, Dof::Ry, Dof::Rz];

    /// Position of this degree of freedom inside a node's block of six (0..6).
    pub fn index(self) -> usize {
        self as usize
    }

    /// The degree of freedom at position `index % 6` of a node's block.
    pub fn from_index(index: usize) -> Dof {
        Dof::ALL[index % 6]
    }

    /// Short name as used in files and messages (`"ux"` .. `"rz"`).
    pub fn name(self) -> &'static str {
        ["ux", "uy", "uz", "rx", "ry", "rz"][self.index()]
    }
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything that can go wrong when building, loading or solving a structure.
///
/// Every variant names what it is about (node, element, field, file) so that
/// a message alone lets a user find the faulty line of a structure file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FemError {
    /// An error in the content of a structure file, with the file.
    #[error("{}: {source}", path.display())]
    InFile {
        /// The structure file.
        path: std::path::PathBuf,
        /// What is wrong in it.
        source: Box<FemError>,
    },
    /// A value of a node or element is out of its allowed range (negative
    /// section value, NaN, wrong number of components, ...).
    #[error("{owner}: field '{field}': {message}")]
    InvalidValue {
        /// The node, element or load case, e.g. `beam 'b1'`.
        owner: String,
        /// The field, as spelled in structure files (e.g. `Iy`, `vecxz`).
        field: String,
        /// What is wrong with it.
        message: String,
    },
    /// A name refers to a node that the structure does not have.
    #[error("{owner}: field '{field}': unknown node '{node}'")]
    UnknownNode {
        /// Where the name was used.
        owner: String,
        /// The field holding the name.
        field: String,
        /// The name that was not found.
        node: String,
    },
    /// A node, beam, joint or spring index is out of range.
    #[error("{owner}: {kind} index {index} out of range (the structure has {count})")]
    IndexOutOfRange {
        /// Where the index was used.
        owner: String,
        /// `node`, `beam`, `joint` or `spring`.
        kind: &'static str,
        /// The faulty index.
        index: usize,
        /// Number of items of that kind in the structure.
        count: usize,
    },
    /// Two nodes, elements or load cases share a name.
    #[error("duplicate {kind} name '{name}'")]
    DuplicateName {
        /// `node`, `element` or `load case`.
        kind: &'static str,
        /// The repeated name.
        name: String,
    },
    /// A beam or axial spring whose two nodes are at the same place, or an
    /// element connecting a node to itself.
    #[error("{element}: zero length (nodes '{node_i}' and '{node_j}' are {length:e} m apart)")]
    ZeroLength {
        /// The element, e.g. `beam 'b1'`.
        element: String,
        /// Name of its first node.
        node_i: String,
        /// Name of its second node.
        node_j: String,
        /// The distance found (m).
        length: f64,
    },
    /// A direction that cannot define a local frame: zero vector, or parallel
    /// to the element axis (`vecxz` of a beam, `local_y` of a joint).
    #[error("{element}: field '{field}': {message}")]
    DegenerateOrientation {
        /// The element.
        element: String,
        /// The field holding the direction.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The supported stiffness matrix is singular: the structure is a
    /// mechanism, has an unconnected node, or leaves a free direction
    /// unsupported. Found as a vanishing Cholesky pivot and mapped back to the
    /// node and degree of freedom of that equation.
    #[error(
        "singular structure: node '{node}' degree of freedom {dof} is not restrained \
         (mechanism, unconnected node or missing support; Cholesky pivot ratio {pivot_ratio:e})"
    )]
    Singular {
        /// Name of the node whose equation lost its pivot.
        node: String,
        /// The degree of freedom of that equation.
        dof: Dof,
        /// Pivot divided by the original diagonal entry (<= the tolerance).
        pivot_ratio: f64,
    },
    /// Condensation was asked onto a node that has supported degrees of
    /// freedom: its displacement is not an unknown there.
    #[error("cannot condense onto node '{node}': its degree of freedom {dof} is supported")]
    CondensedNodeSupported {
        /// The node.
        node: String,
        /// The first supported degree of freedom.
        dof: Dof,
    },
    /// A factorization was used with a structure whose topology (nodes,
    /// elements, supports) differs from the one it was built for.
    #[error("factorization built for a different structure topology: {message}")]
    TopologyChanged {
        /// What differs.
        message: String,
    },
    /// A buffer has the wrong length.
    #[error("{what}: expected length {expected}, got {found}")]
    LengthMismatch {
        /// Which buffer.
        what: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        found: usize,
    },
    /// The operation needs a factorization that has not been computed yet,
    /// or needs a condensation node that was not requested.
    #[error("{0}")]
    NotAvailable(&'static str),
    /// A structure file could not be parsed.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message (with line and column where it gives them).
        message: String,
    },
    /// A structure file name has no `.toml` or `.json` extension.
    #[error("{path}: unknown structure file extension (expected .toml or .json)")]
    UnknownExtension {
        /// The file.
        path: PathBuf,
    },
    /// Reading or writing a file failed (the message names the file and
    /// includes the system's reason).
    #[error("{0}")]
    Io(flexcal_io::IoError),
}

impl From<flexcal_io::IoError> for FemError {
    fn from(error: flexcal_io::IoError) -> Self {
        FemError::Io(error)
    }
}

/// Result type of flexcal-fem.
pub type Result<T, E = FemError> = std::result::Result<T, E>;

pub(crate) fn invalid(owner: &str, field: &str, message: impl Into<String>) -> FemError {
    FemError::InvalidValue {
        owner: owner.to_string(),
        field: field.to_string(),
        message: message.into(),
    }
}

//! The kind of each unknown of a calibration (length, angle, compliance,
//! mass, first moment, hardening): its SI unit and the unit reports show it
//! in.

/// Kind of an unknown of the extended vector `[xi; frame; target]` (and,
/// elasto-geometric, `[c; m; m c]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum UnknownKind {
    /// m.
    Length,
    /// rad.
    Angle,
    /// Joint compliance: rad/N.m (revolute) or m/N (prismatic, screw).
    Compliance,
    /// kg.
    Mass,
    /// First moment of a mass, mass times centre (kg.m).
    FirstMoment,
    /// Hardening of a joint spring (1/rad; [`crate::joint_law`]).
    Hardening,
}

impl UnknownKind {
    /// The SI unit of this kind (`m`, `rad`, `rad/N.m`, `kg`, `kg.m`,
    /// `1/rad`), in which the values are held.
    pub fn si_unit(self) -> &'static str {
        match self {
            UnknownKind::Length => "m",
            UnknownKind::Angle => "rad",
            UnknownKind::Compliance => "rad/N.m",
            UnknownKind::Mass => "kg",
            UnknownKind::FirstMoment => "kg.m",
            UnknownKind::Hardening => "1/rad",
        }
    }

    /// The unit in which files and reports show this kind, and the factor
    /// from SI to it: mm, deg, urad/N.m (um/N for linear joints), kg, kg.m.
    pub fn display_unit(self) -> (&'static str, f64) {
        match self {
            UnknownKind::Length => ("mm", 1e3),
            UnknownKind::Angle => ("deg", 180.0 / std::f64::consts::PI),
            UnknownKind::Compliance => ("urad/N.m", 1e6),
            UnknownKind::Mass => ("kg", 1.0),
            UnknownKind::FirstMoment => ("kg.m", 1.0),
            UnknownKind::Hardening => ("1/mrad", 1e-3),
        }
    }
}

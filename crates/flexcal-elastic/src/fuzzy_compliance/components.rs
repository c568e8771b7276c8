//! What a fuzzy compliance model is made of: the axes of twists and
//! wrenches, the compliance components `C_dw`, and the named inputs with
//! their units.

use serde::{Deserialize, Serialize};

/// Conclusions are fitted in mm (or mrad) per kN (or kN.m): SI values
/// times this factor, so that they are of order one.
pub(crate) const FIT_SCALE: f64 = 1e6;

/// An axis of a twist or wrench, ordered `[linear; angular]`: `X`, `Y`,
/// `Z` are translations (m) or forces (N), `Rx`, `Ry`, `Rz` rotations
/// (rad) or moments (N.m), all in the robot base frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Along x.
    X,
    /// Along y.
    Y,
    /// Along z.
    Z,
    /// About x.
    Rx,
    /// About y.
    Ry,
    /// About z.
    Rz,
}

impl Axis {
    /// The six axes in twist/wrench order.
    pub const ALL: [Axis; 6] = [Axis::X, Axis::Y, Axis::Z, Axis::Rx, Axis::Ry, Axis::Rz];

    /// Index in a twist or wrench vector (0..6).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Whether the axis is a translation / force (not a rotation / moment).
    pub fn is_linear(self) -> bool {
        self.index() < 3
    }

    /// Short name: `x`, `y`, `z`, `rx`, `ry`, `rz`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z", "rx", "ry", "rz"][self.index()]
    }

    /// Name of the wrench component along the axis: `fx` .. `mz`.
    pub fn wrench_name(self) -> &'static str {
        ["fx", "fy", "fz", "mx", "my", "mz"][self.index()]
    }
}

/// One entry `C_dw` of the TCP compliance matrix: the displacement along
/// `displacement` per unit of wrench along `wrench` (m/N, m/(N.m), rad/N or
/// rad/(N.m)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct ComplianceComponent {
    /// Displacement axis (row of the compliance matrix).
    pub displacement: Axis,
    /// Wrench axis (column of the compliance matrix).
    pub wrench: Axis,
}

impl ComplianceComponent {
    /// The component `C_dw`.
    pub fn new(displacement: Axis, wrench: Axis) -> Self {
        Self {
            displacement,
            wrench,
        }
    }

    /// The four in-plane components of equation (70), in the paper's order:
    /// `C_xx`, `C_xz`, `C_zx`, `C_zz`.
    pub fn plane_xz() -> Vec<Self> {
        vec![
            Self::new(Axis::X, Axis::X),
            Self::new(Axis::X, Axis::Z),
            Self::new(Axis::Z, Axis::X),
            Self::new(Axis::Z, Axis::Z),
        ]
    }

    /// The 3 x 3 translational block (force to translation), row by row.
    pub fn translational_block() -> Vec<Self> {
        let linear = [Axis::X, Axis::Y, Axis::Z];
        linear
            .iter()
            .flat_map(|&d| linear.iter().map(move |&w| Self::new(d, w)))
            .collect()
    }

    /// Name used for the component's fuzzy model: `c_xz` when both axes
    /// are linear, `c_x_rz` otherwise.
    pub fn name(&self) -> String {
        if self.displacement.is_linear() && self.wrench.is_linear() {
            format!("c_{}{}", self.displacement.name(), self.wrench.name())
        } else {
            format!("c_{}_{}", self.displacement.name(), self.wrench.name())
        }
    }

    /// Parses a name written by [`name`](Self::name).
    pub fn from_name(name: &str) -> Option<Self> {
        let rest = name.strip_prefix("c_")?;
        let parse = |s: &str| Axis::ALL.into_iter().find(|a| a.name() == s);
        if let Some((d, w)) = rest.split_once('_') {
            return Some(Self::new(parse(d)?, parse(w)?));
        }
        let mut chars = rest.chars();
        let (d, w) = (chars.next()?, chars.next()?);
        if chars.next().is_some() {
            return None;
        }
        Some(Self::new(parse(&d.to_string())?, parse(&w.to_string())?))
    }

    /// SI unit of the component: `m/N`, `m/(N.m)`, `rad/N` or `rad/(N.m)`.
    pub fn si_unit(&self) -> &'static str {
        match (self.displacement.is_linear(), self.wrench.is_linear()) {
            (true, true) => "m/N",
            (true, false) => "m/(N.m)",
            (false, true) => "rad/N",
            (false, false) => "rad/(N.m)",
        }
    }

    /// Unit used in printed tables (SI value times 1e6): `mm/kN`,
    /// `mm/(kN.m)`, `mrad/kN` or `mrad/(kN.m)`.
    pub fn table_unit(&self) -> &'static str {
        match (self.displacement.is_linear(), self.wrench.is_linear()) {
            (true, true) => "mm/kN",
            (true, false) => "mm/(kN.m)",
            (false, true) => "mrad/kN",
            (false, false) => "mrad/(kN.m)",
        }
    }
}

/// Unit of a model input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InputUnit {
    /// An angle (rad); printed in degrees.
    Rad,
    /// A length (m); printed in mm.
    M,
}

impl InputUnit {
    /// SI unit symbol.
    pub fn symbol(self) -> &'static str {
        match self {
            InputUnit::Rad => "rad",
            InputUnit::M => "m",
        }
    }

    /// Factor and symbol of the printed unit (degrees or mm).
    pub fn table_unit(self) -> (f64, &'static str) {
        match self {
            InputUnit::Rad => (180.0 / std::f64::consts::PI, "deg"),
            InputUnit::M => (1e3, "mm"),
        }
    }
}

/// A named model input and its unit.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputSpec {
    /// Input name (an actuated coordinate such as `theta1` or `r2p`, or the
    /// joint angle of a slider-crank joint such as `theta2`).
    pub name: String,
    /// Its unit.
    pub unit: InputUnit,
}

impl InputSpec {
    /// An angle input (rad).
    pub fn radians(name: &str) -> Self {
        Self {
            name: name.into(),
            unit: InputUnit::Rad,
        }
    }

    /// A length input (m).
    pub fn meters(name: &str) -> Self {
        Self {
            name: name.into(),
            unit: InputUnit::M,
        }
    }
}

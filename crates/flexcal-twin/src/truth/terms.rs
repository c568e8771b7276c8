//! The list of the twin's truth terms, as published with every campaign
//! (`twin.terms` of the demo's `summary.json`).

use serde::{Deserialize, Serialize};

/// One term of the twin's truth: what it is, how large, and where the
/// magnitude comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinTerm {
    /// Short name (`gravity`, `drive_nonlinearity`, ...), the same as the
    /// field of [`TruthSwitches`] that turns it on and off.
    pub name: String,
    /// Magnitude in words and numbers, with units (e.g. `"lost motion 1
    /// arcmin over +-3 % of 6 kN.m; ..."`).
    pub magnitude: String,
    /// Where the magnitude comes from (a datasheet class, a handbook, the
    /// reference paper).
    pub source: String,
    /// Whether the term is switched on in this twin.
    pub enabled: bool,
}

/// The twin's truth terms, in the order the campaigns apply them.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TwinTerms {
    /// The terms.
    pub terms: Vec<TwinTerm>,
}

impl TwinTerms {
    /// The term named `name`, if any.
    pub fn get(&self, name: &str) -> Option<&TwinTerm> {
        self.terms.iter().find(|t| t.name == name)
    }
}

/// On/off switches of every truth term (all on by default except the
/// optional temperature drift). Tests switch one term off to show what it
/// costs; a study switches none.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TruthSwitches {
    /// The true geometric errors of the paper's Appendix C.
    pub geometric_errors: bool,
    /// Own weight of links, motors, wrist and tool through the twin's FE
    /// structure, in every campaign.
    pub gravity: bool,
    /// Lost motion about zero torque and torque-hardening stiffness of the
    /// drives of joints 2 and 8.
    pub drive_nonlinearity: bool,
    /// Cyclic transmission errors (1st and 2nd harmonics of each joint angle).
    pub transmission_errors: bool,
    /// The photogrammetry frame is an unknown rigid transform away from the
    /// robot base.
    pub measurement_frame: bool,
    /// Photogrammetry noise on positions and orientations.
    pub measurement_noise: bool,
    /// Slow temperature rise of the links over a campaign (optional).
    pub temperature_drift: bool,
    /// Forming: the beam's true Young's modulus off its handbook value.
    pub beam_modulus_offset: bool,
    /// Forming: the bar's thickness off its nominal value.
    pub sheet_thickness: bool,
    /// Forming: the clamp lets the bar's root turn.
    pub clamp_compliance: bool,
    /// Forming: the tool tip is a hemisphere, not a point.
    pub tool_radius: bool,
    /// Forming: Coulomb friction between the tool and the beam.
    pub tool_friction: bool,
    /// Forming: the dead weight differs from its nominal value by the
    /// scale's accuracy.
    pub payload_error: bool,
}

impl Default for TruthSwitches {
    fn default() -> Self {
        Self {
            geometric_errors: true,
            gravity: true,
            drive_nonlinearity: true,
            transmission_errors: true,
            measurement_frame: true,
            measurement_noise: true,
            temperature_drift: false,
            beam_modulus_offset: true,
            sheet_thickness: true,
            clamp_compliance: true,
            tool_radius: true,
            tool_friction: true,
            payload_error: true,
        }
    }
}

impl TruthSwitches {
    /// Every term off: the twin is then the nominal rigid robot measured
    /// exactly in its base frame.
    pub fn none() -> Self {
        Self {
            geometric_errors: false,
            gravity: false,
            drive_nonlinearity: false,
            transmission_errors: false,
            measurement_frame: false,
            measurement_noise: false,
            temperature_drift: false,
            beam_modulus_offset: false,
            sheet_thickness: false,
            clamp_compliance: false,
            tool_radius: false,
            tool_friction: false,
            payload_error: false,
        }
    }

    /// The same switches with the term `name` set to `on`.
    ///
    /// # Errors
    /// An unknown term name, naming the known ones.
    pub fn with(mut self, name: &str, on: bool) -> Result<Self, String> {
        let field = match name {
            "geometric_errors" => &mut self.geometric_errors,
            "gravity" => &mut self.gravity,
            "drive_nonlinearity" => &mut self.drive_nonlinearity,
            "transmission_errors" => &mut self.transmission_errors,
            "measurement_frame" => &mut self.measurement_frame,
            "measurement_noise" => &mut self.measurement_noise,
            "temperature_drift" => &mut self.temperature_drift,
            "beam_modulus_offset" => &mut self.beam_modulus_offset,
            "sheet_thickness" => &mut self.sheet_thickness,
            "clamp_compliance" => &mut self.clamp_compliance,
            "tool_radius" => &mut self.tool_radius,
            "tool_friction" => &mut self.tool_friction,
            "payload_error" => &mut self.payload_error,
            other => {
                return Err(format!(
                    "unknown truth term `{other}` (known: {})",
                    TERM_NAMES.join(", ")
                ));
            }
        };
        *field = on;
        Ok(self)
    }
}

/// Names of every truth term, in [`TruthSwitches`] order.
pub const TERM_NAMES: [&str; 13] = [
    "geometric_errors",
    "gravity",
    "drive_nonlinearity",
    "transmission_errors",
    "measurement_frame",
    "measurement_noise",
    "temperature_drift",
    "beam_modulus_offset",
    "sheet_thickness",
    "clamp_compliance",
    "tool_radius",
    "tool_friction",
    "payload_error",
];

//! The forming cell as it is: the beam, the tool contact and the dead
//! weight differ from what the user's process model assumes.
//!
//! - **Young's modulus.** The user takes the handbook value of Al-5005
//!   (68.9 GPa); the twin's beam is 3 % stiffer. Measured moduli of rolled
//!   aluminium alloys scatter by a few per cent about their handbook values
//!   (temper, rolling texture, the tolerance on the 14 mm thickness, which
//!   enters cubed: +-1 % of thickness is +-3 % of stiffness).
//! - **Friction.** The tool slides on the beam with Coulomb friction
//!   `mu = 0.15`, the middle of the 0.1-0.2 that engineering friction tables
//!   give for a lubricated steel tool on aluminium; the paper names this
//!   longitudinal force as the main remaining error of its compensation
//!   (section 4). The user's model has none.
//! - **Dead weight.** The 920 N is known to the accuracy of the scale that
//!   weighed it: the twin's weight is 0.5 % heavier (an industrial hanging
//!   scale's accuracy, +-0.5 % of the reading).

use flexcal_compensate::process::CantileverBeam;
use serde::Serialize;

use super::terms::TwinTerm;

/// The forming truth terms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FormingTruth {
    /// Relative offset of the true Young's modulus from the handbook value
    /// (default +0.03).
    pub modulus_offset: f64,
    /// Coulomb friction coefficient tool-beam (default 0.15).
    pub friction_coefficient: f64,
    /// Relative error of the weighed dead weight (default +0.005).
    pub payload_relative_error: f64,
}

impl Default for FormingTruth {
    fn default() -> Self {
        Self {
            modulus_offset: 0.03,
            friction_coefficient: 0.15,
            payload_relative_error: 0.005,
        }
    }
}

impl FormingTruth {
    /// The true beam behind the user's `handbook` beam.
    pub fn true_beam(
        &self,
        handbook: &CantileverBeam,
        modulus_offset: bool,
        friction: bool,
    ) -> CantileverBeam {
        let mut beam = *handbook;
        if modulus_offset {
            beam.youngs_modulus_pa *= 1.0 + self.modulus_offset;
        }
        if friction {
            beam.friction_coefficient = self.friction_coefficient;
        }
        beam
    }

    /// The true dead weight (N) behind the weighed `nominal_n`.
    pub fn true_payload_n(&self, nominal_n: f64, payload_error: bool) -> f64 {
        if payload_error {
            nominal_n * (1.0 + self.payload_relative_error)
        } else {
            nominal_n
        }
    }

    /// The three terms as published, with their switches.
    pub fn terms(&self, modulus_offset: bool, friction: bool, payload: bool) -> [TwinTerm; 3] {
        [
            TwinTerm {
                name: "beam_modulus_offset".into(),
                magnitude: format!(
                    "true Young's modulus {:+.1} % from the handbook's 68.9 GPa",
                    100.0 * self.modulus_offset
                ),
                source: "scatter of measured moduli of rolled aluminium about handbook values (a few per cent; +-1 % of the 14 mm thickness alone is +-3 % of the bending stiffness)".into(),
                enabled: modulus_offset,
            },
            TwinTerm {
                name: "tool_friction".into(),
                magnitude: format!(
                    "Coulomb friction mu = {:.2} at the tool-beam contact",
                    self.friction_coefficient
                ),
                source: "engineering friction tables, lubricated steel on aluminium 0.1-0.2; named by the paper (section 4) as its compensation's remaining error".into(),
                enabled: friction,
            },
            TwinTerm {
                name: "payload_error".into(),
                magnitude: format!(
                    "dead weight {:+.1} % from its weighed 920 N",
                    100.0 * self.payload_relative_error
                ),
                source: "accuracy of an industrial hanging scale, +-0.5 % of the reading".into(),
                enabled: payload,
            },
        ]
    }
}

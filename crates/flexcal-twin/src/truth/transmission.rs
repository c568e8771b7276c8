//! Cyclic transmission errors of the six actuated joints: the angle a
//! joint actually takes differs from the commanded one by the first and
//! second harmonics of the joint angle,
//!
//! ```text
//! e_j(theta) = a1 sin(theta + phi1_j) + a2 sin(2 theta + phi2_j)
//! ```
//!
//! as gear eccentricities and bearing run-out make it once and twice per
//! output revolution. Reducer catalogues give an angular transmission error
//! (peak to peak over one output revolution) of about 1 arcmin for the
//! sizes used in 100-kg-class robots (Harmonic Drive CSF/CSG "transmission
//! accuracy", Nabtesco RV "angular transmission error"); the twin takes
//! `a1 = 0.35` and `a2 = 0.15` arcmin (at most 1 arcmin peak to peak) for
//! every joint, with fixed phases per joint (a property of the robot, the
//! same in every campaign and seed). The errors act on the joint angles
//! theta1, theta2, theta8, theta4, theta5, theta7 (joints 2 and 8 through
//! their slider cranks); no Khalil-Kleinfinger parameter can absorb them,
//! since they are not constant in any frame.

use serde::Serialize;

use super::terms::TwinTerm;

const ARCMIN: f64 = std::f64::consts::PI / (180.0 * 60.0);

/// Transmission errors of the six actuated joints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TransmissionErrors {
    /// First-harmonic amplitude (rad; default 0.35 arcmin).
    pub first_harmonic_rad: f64,
    /// Second-harmonic amplitude (rad; default 0.15 arcmin).
    pub second_harmonic_rad: f64,
    /// Phases `[phi1, phi2]` (rad) of joints theta1, theta2, theta8,
    /// theta4, theta5, theta7.
    pub phases_rad: [[f64; 2]; 6],
}

impl Default for TransmissionErrors {
    fn default() -> Self {
        Self {
            first_harmonic_rad: 0.35 * ARCMIN,
            second_harmonic_rad: 0.15 * ARCMIN,
            // Arbitrary fixed phases, spread so that no two joints agree.
            phases_rad: [
                [0.4, 2.1],
                [1.9, -0.7],
                [-2.6, 1.2],
                [0.9, 2.8],
                [-1.3, -2.2],
                [2.7, 0.3],
            ],
        }
    }
}

impl TransmissionErrors {
    /// Angle error (rad) of joint `j` (0-based, in the order of
    /// [`TransmissionErrors::phases_rad`]) at joint angle `theta` (rad).
    pub fn error(&self, j: usize, theta: f64) -> f64 {
        let [p1, p2] = self.phases_rad[j];
        self.first_harmonic_rad * (theta + p1).sin()
            + self.second_harmonic_rad * (2.0 * theta + p2).sin()
    }

    /// The term as published.
    pub fn term(&self, enabled: bool) -> TwinTerm {
        TwinTerm {
            name: "transmission_errors".into(),
            magnitude: format!(
                "every actuated joint: {:.2} arcmin x 1st + {:.2} arcmin x 2nd harmonic of the joint angle (at most {:.2} arcmin peak to peak)",
                self.first_harmonic_rad / ARCMIN,
                self.second_harmonic_rad / ARCMIN,
                2.0 * (self.first_harmonic_rad + self.second_harmonic_rad) / ARCMIN
            ),
            source: "reducer catalogues: Harmonic Drive CSF/CSG transmission accuracy and Nabtesco RV angular transmission error, about 1 arcmin peak to peak per output revolution".into(),
            enabled,
        }
    }
}

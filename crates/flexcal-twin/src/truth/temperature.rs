//! Optional slow temperature drift over a campaign: every length of the
//! robot's geometry grows by `alpha dT(t)`, with the temperature rising
//! linearly from 0 to `dT` between the first and the last pose.
//! `alpha = 11.7e-6 /K` is the handbook expansion coefficient of structural
//! steel; `dT = 2 K` is a workshop's drift over the few hours of a campaign
//! (without air conditioning). It is off by default: the identification
//! then reports whether it matters when a test switches it on.

use serde::Serialize;

use super::terms::TwinTerm;

/// A linear temperature ramp over a campaign.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TemperatureDrift {
    /// Linear expansion coefficient (1/K; default 11.7e-6, steel).
    pub expansion_per_kelvin: f64,
    /// Temperature rise from the first to the last pose (K; default 2).
    pub rise_kelvin: f64,
}

impl Default for TemperatureDrift {
    fn default() -> Self {
        Self {
            expansion_per_kelvin: 11.7e-6,
            rise_kelvin: 2.0,
        }
    }
}

impl TemperatureDrift {
    /// Scale of every length at campaign progress `fraction` (0 at the
    /// first pose, 1 at the last).
    pub fn length_scale(&self, fraction: f64) -> f64 {
        1.0 + self.expansion_per_kelvin * self.rise_kelvin * fraction.clamp(0.0, 1.0)
    }

    /// The term as published.
    pub fn term(&self, enabled: bool) -> TwinTerm {
        TwinTerm {
            name: "temperature_drift".into(),
            magnitude: format!(
                "lengths grow by {:.1e}/K x {:.1} K, linearly over a campaign ({:.0} um on 1.8 m)",
                self.expansion_per_kelvin,
                self.rise_kelvin,
                1.8e6 * self.expansion_per_kelvin * self.rise_kelvin
            ),
            source: "handbook expansion coefficient of structural steel (11.7e-6 /K); a workshop drift of about 2 K over a campaign of a few hours".into(),
            enabled,
        }
    }
}

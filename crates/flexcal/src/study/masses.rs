//! The mass table the elasto-geometric calibration of the IR-663 starts
//! from, estimated as a user would estimate it without weighing the arm:
//! link volumes from the robot's outline (its published lengths, Table 2 of
//! the reference paper, and envelope sections read off its outline) times
//! the density of structural steel, and the catalogue class of its wrist
//! motors and reducers. Each figure carries its source and an assumed
//! uncertainty ([`MassEntry`]); the study also runs the calibration with
//! every mass scaled by 0.75 and 1.25 ([`MASS_SCALES`]) and publishes how
//! the figures move.
//!
//! The estimate is written from these sources alone: nothing in this file
//! reads, derives from or was compared with the twin's masses
//! (`flexcal_twin::truth::structure`), which a user could not know.
//!
//! ## Limitations
//! - The envelope sections and wall thicknesses are judged from the arm's
//!   outline, not from drawings of the castings; hence the assumed
//!   uncertainties of 25-30 %.
//! - Each link is one point mass at its estimated centre; the payload (the
//!   tool) is not estimated: the calibration identifies it.

use serde::{Deserialize, Serialize};

use flexcal_calib::{GravityCompliance, PointMass};
use flexcal_kinematics::Model;

use crate::{Error, Result};

/// Density of structural and cast steel (kg/m^3), EN 1993-1-1 section 3.2.6.
pub const STEEL_DENSITY_KG_M3: f64 = 7850.0;

/// The scale factors applied to every estimated mass in the study's
/// sensitivity runs: the estimate 25 % low and 25 % high.
pub const MASS_SCALES: [f64; 2] = [0.75, 1.25];

/// One estimated mass of the table, with its source and its assumed
/// uncertainty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MassEntry {
    /// What it is.
    pub name: String,
    /// The robot frame it is fixed to.
    pub frame: String,
    /// Estimated mass (kg).
    pub mass_kg: f64,
    /// Estimated centre of mass in `frame` (mm).
    pub center_mm: [f64; 3],
    /// Assumed uncertainty of `mass_kg`, one standard deviation (%).
    pub uncertainty_percent: f64,
    /// How the figure was obtained.
    pub source: String,
}

/// Mass (kg) of a rectangular steel box of outer size `width` x `height`
/// (m), wall `wall` (m) and length `length` (m).
fn steel_box_kg(width: f64, height: f64, wall: f64, length: f64) -> f64 {
    let inner = (width - 2.0 * wall) * (height - 2.0 * wall);
    (width * height - inner) * length * STEEL_DENSITY_KG_M3
}

/// Mass (kg) of a round steel tube of outer diameter `diameter`, wall
/// `wall` and length `length` (m).
fn steel_tube_kg(diameter: f64, wall: f64, length: f64) -> f64 {
    let inner = diameter - 2.0 * wall;
    std::f64::consts::FRAC_PI_4
        * (diameter * diameter - inner * inner)
        * length
        * STEEL_DENSITY_KG_M3
}

/// The IR-663's estimated masses, in the frames of the built-in `ir663`
/// (lengths of Table 2: upper arm 1047 mm, forearm from the elbow to the
/// wrist centre W 1760 mm, crank 473 mm, coupler 1212 mm).
pub fn ir663_mass_estimate() -> Vec<MassEntry> {
    let entry = |name: &str,
                 frame: &str,
                 mass_kg: f64,
                 center_mm: [f64; 3],
                 uncertainty_percent: f64,
                 source: &str| MassEntry {
        name: name.into(),
        frame: frame.into(),
        mass_kg,
        center_mm,
        uncertainty_percent,
        source: source.into(),
    };
    // Three reducers of the wrist's class (rated output 300-600 N.m):
    // cycloidal units of that size weigh 9-17 kg in current catalogues.
    let wrist_reducers_kg = 3.0 * 13.0;
    let wrist_housing_kg = steel_tube_kg(0.25, 0.015, 0.45);
    vec![
        entry(
            "upper arm",
            "2",
            steel_box_kg(0.35, 0.30, 0.020, 1.047),
            [523.5, 0.0, 0.0],
            30.0,
            "steel box 350 x 300 mm, 20 mm walls, over the 1047 mm of Table 2 (outline), centre at mid-length",
        ),
        entry(
            "forearm",
            "4",
            steel_box_kg(0.25, 0.25, 0.012, 1.76),
            [0.0, 0.0, -880.0],
            30.0,
            "steel box 250 x 250 mm, 12 mm walls, over the 1760 mm from the elbow to W (Table 2, outline), centre at mid-length",
        ),
        entry(
            "wrist motors",
            "4",
            3.0 * 16.0,
            [0.0, 0.0, -2060.0],
            25.0,
            "three AC servo motors with brake of 4-6 N.m rated torque, 12-20 kg each in current catalogues (16 kg taken), their pack centred about 300 mm behind the elbow on the outline",
        ),
        entry(
            "wrist",
            "4",
            wrist_reducers_kg + wrist_housing_kg,
            [0.0, 0.0, 0.0],
            30.0,
            "three reducers of the 300-600 N.m class (9-17 kg each in current catalogues, 13 kg taken) and a steel housing tube of 250 mm diameter, 15 mm wall, 450 mm long, centred at W",
        ),
        entry(
            "crank",
            "8",
            steel_box_kg(0.15, 0.10, 0.020, 0.473),
            [236.5, 0.0, 0.0],
            30.0,
            "steel box 150 x 100 mm, 20 mm walls, over the 473 mm crank of Table 2 (outline), centre at mid-length",
        ),
        entry(
            "coupler",
            "9",
            steel_tube_kg(0.10, 0.010, 1.212),
            [606.0, 0.0, 0.0],
            30.0,
            "steel tube of 100 mm diameter, 10 mm wall, over the 1212 mm coupler of Table 2 (outline), centre at mid-length",
        ),
    ]
}

/// The gravity model of the elasto-geometric calibration of the built-in
/// `ir663` from [`ir663_mass_estimate`], every mass multiplied by `scale`
/// (1 for the estimate itself; [`MASS_SCALES`] for the sensitivity runs).
/// The payload starts at 10 kg and is identified.
///
/// # Errors
/// A `scale` that is not finite and positive; a robot without the `ir663`
/// frames.
pub fn ir663_mass_table(model: &Model, scale: f64) -> Result<GravityCompliance> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(Error::InvalidParameter {
            parameter: "scale".into(),
            message: format!("the mass scale must be finite and positive, found {scale}"),
        });
    }
    let estimate = ir663_mass_estimate();
    for m in &estimate {
        if model.frame_index(&m.frame).is_none() {
            return Err(Error::InvalidParameter {
                parameter: "robot".into(),
                message: format!(
                    "the IR-663 mass table needs frame `{}`; robot `{}` has none",
                    m.frame,
                    model.name()
                ),
            });
        }
    }
    Ok(GravityCompliance {
        gravity: nalgebra::Vector3::new(0.0, 0.0, -flexcal_calib::gravity::STANDARD_GRAVITY),
        masses: estimate
            .into_iter()
            .map(|m| PointMass {
                name: m.name,
                frame: m.frame,
                mass: m.mass_kg * scale,
                center: nalgebra::Vector3::from(m.center_mm) * 1e-3,
            })
            .collect(),
        payload_mass: 10.0,
        payload_center: nalgebra::Vector3::zeros(),
        payload_frame: None,
        initial_compliance: 1e-8,
        lateral: flexcal_calib::LateralCompliance::Off,
        springs: Vec::new(),
        payloads: Vec::new(),
        coupling: Vec::new(),
        deflection: flexcal_calib::Deflection::OneStep,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_and_tube_masses_match_their_volumes_computed_otherwise() {
        // A 0.2 x 0.1 box with 0.01 walls, 2 m: the walls as four strips.
        let strips = 2.0 * (0.2 * 0.01) + 2.0 * ((0.1 - 0.02) * 0.01);
        let expected = strips * 2.0 * STEEL_DENSITY_KG_M3;
        assert!((steel_box_kg(0.2, 0.1, 0.01, 2.0) - expected).abs() < 1e-9 * expected);
        // A thin tube: circumference at mid-wall times wall.
        let (d, t, l) = (0.1, 0.01, 1.5);
        let expected = std::f64::consts::PI * (d - t) * t * l * STEEL_DENSITY_KG_M3;
        assert!((steel_tube_kg(d, t, l) - expected).abs() < 1e-9 * expected);
    }

    #[test]
    fn every_estimate_has_a_source_and_an_uncertainty() {
        for m in ir663_mass_estimate() {
            assert!(m.mass_kg > 0.0 && m.mass_kg.is_finite(), "{m:?}");
            assert!((10.0..=50.0).contains(&m.uncertainty_percent), "{m:?}");
            assert!(m.source.len() > 20, "{m:?}");
        }
    }

    #[test]
    fn the_table_scales_every_mass_and_names_a_bad_scale() {
        let model = flexcal_kinematics::RobotDescription::builtin("ir663")
            .unwrap()
            .build()
            .unwrap();
        let one = ir663_mass_table(&model, 1.0).unwrap();
        let low = ir663_mass_table(&model, 0.75).unwrap();
        for (a, b) in one.masses.iter().zip(&low.masses) {
            assert!((b.mass - 0.75 * a.mass).abs() < 1e-12);
            assert_eq!(a.center, b.center);
        }
        for bad in [0.0, -1.0, f64::NAN] {
            let e = ir663_mass_table(&model, bad).unwrap_err().to_string();
            assert!(e.contains("scale"), "{e}");
        }
    }
}

//! The geometric step's loaded validation: poses of box (59) measured with a
//! known payload hung at the TCP, a load no identification pose carried,
//! predicted by each calibration as a user would predict them.
//!
//! - The geometric calibration knows nothing of loads: it predicts the
//!   unloaded pose.
//! - The elasto-geometric calibration adds the payload to its gravity model
//!   as a known weight at the TCP ([`flexcal_calib::Payload`] with
//!   `identify = false`, mass = weighed weight / g), with every identified
//!   unknown (compliances, the tool's own mass and moment) kept.
//! - The measurement frame is the one registered in the identification
//!   ([`FramePolicy::Fixed`]): the loaded poses are measured in the same
//!   session by the same camera. Re-fitting its 6 unknowns on the loaded
//!   poses, as the unloaded validations do, would absorb the payload's mean
//!   deflection: the very effect under test.

use flexcal_calib::{
    Calibration, FramePolicy, MeasurementSet, Payload, evaluate_errors, evaluate_errors_with_terms,
};
use flexcal_kinematics::Model;
use serde::{Deserialize, Serialize};

use super::ValidationFigures;
use crate::Result;

/// Where the loaded validation's payload comes from.
pub const LOADED_PAYLOAD_SOURCE: &str = "the forming head of the forming experiment (650 N as weighed, 66.3 kg), hung at the TCP; the elasto-geometric calibration is told its weighed mass, its centre at the TCP";

/// The geometric step's validation on the poses of box (59) measured with
/// the payload at the TCP.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LoadedFigures {
    /// Number of validation poses.
    pub poses: usize,
    /// The payload as weighed, the weight the elasto-geometric model is
    /// told (N).
    pub payload_weighed_n: f64,
    /// What the payload is and why that weight.
    pub payload_source: String,
    /// With the nominal robot (its own registered camera frame).
    pub before: ValidationFigures,
    /// With the geometric calibration (no load in its model).
    pub geometric: ValidationFigures,
    /// With the elasto-geometric calibration told the payload.
    pub elasto_geometric: ValidationFigures,
}

/// The payload as the user describes it to the gravity model: a known
/// weight of `weighed_n` (N) at the TCP.
pub fn tcp_payload(weighed_n: f64) -> Payload {
    Payload {
        name: "validation_payload".into(),
        frame: flexcal_calib::TCP_FRAME.into(),
        mass: weighed_n / flexcal_calib::gravity::STANDARD_GRAVITY,
        center: nalgebra::Vector3::zeros(),
        identify: false,
    }
}

/// Position and orientation errors of `calibration` on the loaded poses
/// `set`, the registered camera frame kept; an elasto-geometric calibration
/// is told the payload `payload` (a geometric one has no gravity model to
/// tell).
///
/// # Errors
/// Mismatched coordinates, a model failure at a pose, a payload frame the
/// robot lacks.
pub fn loaded_errors(
    model: &Model,
    calibration: &Calibration,
    set: &MeasurementSet,
    payload: &Payload,
) -> Result<ValidationFigures> {
    let gravity = calibration.elastic.as_ref().map(|(table, values)| {
        let mut table = table.clone();
        table.payloads.push(payload.clone());
        (table, values.as_slice())
    });
    let (errors, _) = evaluate_errors_with_terms(
        model,
        set,
        &calibration.xi,
        gravity.as_ref().map(|(table, values)| (table, *values)),
        (&calibration.joint_terms, &calibration.joint_term_values),
        &calibration.x_tcp_target(),
        FramePolicy::Fixed(calibration.x_meas_base),
        calibration.use_orientation,
    )?;
    Ok((&flexcal_calib::error_statistics(&errors)).into())
}

/// The loaded validation's figures: the nominal robot, the geometric and
/// the elasto-geometric calibration on `set`, the payload weighed at
/// `payload_weighed_n` (N).
///
/// # Errors
/// As [`loaded_errors`].
pub fn loaded_figures(
    model: &Model,
    (geometric, elasto_geometric): (&Calibration, &Calibration),
    set: &MeasurementSet,
    payload_weighed_n: f64,
) -> Result<LoadedFigures> {
    let payload = tcp_payload(payload_weighed_n);
    let (nominal, _) = evaluate_errors(
        model,
        set,
        &geometric.nominal_xi,
        None,
        &geometric.x_tcp_target_nominal_robot(),
        FramePolicy::Fixed(geometric.x_meas_base_nominal_robot),
        geometric.use_orientation,
    )?;
    Ok(LoadedFigures {
        poses: set.len(),
        payload_weighed_n,
        payload_source: LOADED_PAYLOAD_SOURCE.into(),
        before: (&flexcal_calib::error_statistics(&nominal)).into(),
        geometric: loaded_errors(model, geometric, set, &payload)?,
        elasto_geometric: loaded_errors(model, elasto_geometric, set, &payload)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_payload_is_known_at_the_tcp_with_the_weighed_mass() {
        let p = tcp_payload(650.0);
        assert!(!p.identify);
        assert_eq!(p.frame, flexcal_calib::TCP_FRAME);
        assert_eq!(p.center, nalgebra::Vector3::zeros());
        // 650 N / 9.80665 m/s^2 = 66.2815 kg (by hand).
        assert!((p.mass - 66.2815).abs() < 1e-4, "{}", p.mass);
    }
}

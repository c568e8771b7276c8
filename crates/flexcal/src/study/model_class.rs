//! How far each model class reproduces the twin: a calibration fitted to
//! noise-free twin data leaves the residual that the class cannot absorb
//! ([`model_class_residuals`]). An experiment on the twin, so it lives
//! with the study, not in the twin.

use flexcal_kinematics::Model;
use flexcal_twin::geometric::{GeometricCampaignOptions, NON_GEOMETRIC_TERMS, geometric_campaign};
use flexcal_twin::truth::TruthSwitches;

use crate::{Error, Result};

/// RMS position residuals (m) of a calibration fitted to the noise-free
/// identification poses of the geometric campaign: how far a model class
/// reproduces the twin ([`model_class_residuals`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelClassResiduals {
    /// With every term of the twin (noise off).
    pub all_terms: f64,
    /// The same calibration (every term, noise off) validated on the
    /// noise-free poses outside box (59): how far the model class
    /// extrapolates what it absorbed inside the box.
    pub all_terms_outside_box: f64,
    /// With the geometric errors and the camera frame only: the geometric
    /// model's own class.
    pub own_class: f64,
    /// With the own class and one of [`NON_GEOMETRIC_TERMS`] switched on.
    pub term_alone: Vec<(&'static str, f64)>,
}

impl ModelClassResiduals {
    /// The terms whose residual alone exceeds `threshold` (m): what the
    /// model cannot absorb.
    pub fn causes(&self, threshold: f64) -> Vec<&'static str> {
        self.term_alone
            .iter()
            .filter(|(_, rms)| *rms > threshold)
            .map(|(term, _)| *term)
            .collect()
    }
}

impl std::fmt::Display for ModelClassResiduals {
    /// The residuals in micrometres, one line per case.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "noise-free identification RMS: {:.2} um with every term ({:.2} um on the poses outside box (59)), {:.4} um with geometry and frame only",
            self.all_terms * 1e6,
            self.all_terms_outside_box * 1e6,
            self.own_class * 1e6
        )?;
        for (term, alone) in &self.term_alone {
            write!(f, "\n  {term} alone: {:.2} um", alone * 1e6)?;
        }
        Ok(())
    }
}

/// Fits a calibration (measurement frame identified, target fixed,
/// completed by `configure` for the campaign's model, e.g. with a mass
/// table) to the 27 noise-free identification poses of the geometric
/// campaign (seed 2), with every term of the twin, with its own class only,
/// and with each of [`NON_GEOMETRIC_TERMS`] alone: the residuals say which
/// terms of the twin a model class cannot reproduce.
///
/// # Errors
/// The campaign's and the calibration's errors.
pub fn model_class_residuals(
    configure: &dyn Fn(&Model, &mut flexcal_calib::CalibrationOptions),
) -> Result<ModelClassResiduals> {
    // (RMS on the identification poses, RMS on the poses outside box (59)).
    let residual = |switches: TruthSwitches| -> Result<(f64, f64)> {
        let campaign = geometric_campaign(&GeometricCampaignOptions {
            seed: 2,
            switches: TruthSwitches {
                measurement_noise: false,
                ..switches
            },
            ..GeometricCampaignOptions::default()
        })?;
        let model = &campaign.model;
        let mut options = flexcal_calib::CalibrationOptions::for_model(model);
        options.measurement_frame = flexcal_calib::FrameTreatment::Identify;
        options.target = flexcal_calib::FrameTreatment::Fixed;
        configure(model, &mut options);
        let calibration = flexcal_calib::calibrate(model, &campaign.identification, &options)?;
        let rms = |set| -> Result<f64> {
            Ok(calibration.validate(model, set, false)?.after.position_rms)
        };
        Ok((
            rms(&campaign.identification)?,
            rms(&campaign.validation_outside)?,
        ))
    };
    let own_class = TruthSwitches {
        gravity: false,
        drive_nonlinearity: false,
        transmission_errors: false,
        ..TruthSwitches::default()
    };
    let mut term_alone = Vec::with_capacity(NON_GEOMETRIC_TERMS.len());
    for term in NON_GEOMETRIC_TERMS {
        let switches = own_class
            .with(term, true)
            .map_err(|message| Error::InvalidParameter {
                parameter: "switches".into(),
                message,
            })?;
        term_alone.push((term, residual(switches)?.0));
    }
    let (all_terms, all_terms_outside_box) = residual(TruthSwitches::default())?;
    Ok(ModelClassResiduals {
        all_terms,
        all_terms_outside_box,
        own_class: residual(own_class)?.0,
        term_alone,
    })
}

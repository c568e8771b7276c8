//! Each station held out in turn: with measurements from several stations
//! (tracker placements, campaigns of other days; [`crate::MeasurementSet::pooled`],
//! or with several targets [`crate::MeasurementSet::pooled`]), the
//! calibration identified from the other stations, its model selected
//! on their poses alone, predicts the held-out station's poses with only
//! that station's measurement frame re-fitted. It is the cross-series
//! validation of a single campaign done for every station: what a robot
//! calibrated today will do on poses measured another day, from another
//! place.

use flexcal_kinematics::Model;
use serde::Serialize;

use crate::error::CalibError;
use crate::measurement::MeasurementSet;
use crate::metrics::ErrorStatistics;
use crate::options::CalibrationOptions;
use crate::selection::{SelectionOptions, calibrate_selected};

/// One station held out.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StationHoldOut {
    /// Name of the held-out station.
    pub station: String,
    /// The groups of unknowns the selection chose on the other stations
    /// (their labels, as [`crate::TermGroup::label`] gives them), or `None`
    /// without model selection.
    pub chosen: Option<Vec<String>>,
    /// Errors on the held-out poses with the nominal robot (its
    /// measurement frame and target fitted for it).
    pub before: ErrorStatistics,
    /// Errors on the held-out poses with the robot calibrated on the other
    /// stations (its measurement frame re-fitted, robot and target frozen).
    pub after: ErrorStatistics,
}

/// Every station of `set` held out in turn: identified on the others with
/// `options` and `selection` ([`crate::calibrate_selected`]), validated on it
/// with its measurement frame fitted again; with several targets per pose
/// ([`crate::MeasurementSet::pooled`]) the errors are those of every
/// observation.
///
/// # Errors
/// [`CalibError::InvalidOption`] for a set of one station; what
/// [`crate::calibrate_selected`] and [`crate::Calibration::validate`] return,
/// naming the held-out station.
pub fn hold_out_stations(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
    selection: &SelectionOptions,
) -> Result<Vec<StationHoldOut>, CalibError> {
    if set.n_stations() < 2 {
        return Err(CalibError::InvalidOption {
            name: "hold_out_stations",
            reason: format!(
                "{} holds one station: holding one out needs measurements from at least two (calibrate --data A --data B)",
                set.source
            ),
        });
    }
    (0..set.n_stations())
        .map(|s| {
            let name = set.station_names()[s].as_str();
            // The failure, named by station and step (a cancellation stays
            // one).
            let in_step = |step: &str, e: CalibError| match e {
                CalibError::Cancelled => e,
                e => CalibError::InvalidOption {
                    name: "hold_out_stations",
                    reason: format!("station `{name}` held out, {step}: {e}"),
                },
            };
            let others: Vec<usize> = (0..set.len()).filter(|&k| set.station_of(k) != s).collect();
            let held_out = set
                .station_poses(s)
                .ok_or_else(|| in_step("its poses", CalibError::NothingToIdentify))?;
            let train = set.subset(&others)?;
            let (calibration, report, _) = calibrate_selected(model, &train, options, selection)
                .map_err(|e| in_step("identification on the other stations", e))?;
            let (before, after) =
                MeasurementSet::held_out_statistics(model, &calibration, &held_out)
                    .map_err(|e| in_step("validation", e))?;
            Ok(StationHoldOut {
                station: name.to_string(),
                chosen: report.map(|r| r.chosen.iter().map(|g| g.label().to_string()).collect()),
                before,
                after,
            })
        })
        .collect()
}

//! A calibration's prediction at any pose, linearised at the identified
//! unknowns: what the predicted accuracy ([`crate::AccuracyMap`]) and the
//! split-half check in the prediction space ([`crate::SplitCheck`]) are
//! computed from, for one target and for several.

use flexcal_kinematics::Model;
use nalgebra::{DMatrix, Isometry3, Vector3};

use std::borrow::Cow;

use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::error_model::{ErrorModel, FrameStarts};
use crate::frames::TCP_FRAME;
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::targets::{Target, TargetMeasurementSet};
use crate::unknowns::{UnknownEstimate, UnknownStatus};
use flexcal_optim::{Jacobian, Residuals};

/// One observation of a [`Linearised`] prediction: a target seen at a pose.
pub(crate) struct Observed {
    /// Index of the pose in its set.
    pub pose: usize,
    /// The target's name, with several targets (`None`: the one target).
    pub target: Option<String>,
}

/// A calibration's prediction at the poses of a set, linearised at the
/// identified unknowns: three rows per observation.
pub(crate) struct Linearised {
    /// Position rows of the error model's Jacobian, every unknown of the
    /// identification (m per unit of the unknown).
    pub jacobian: faer::Mat<f64>,
    /// The calibrated model's target position of each observation, in the
    /// measurement frame (m).
    pub predicted: Vec<Vector3<f64>>,
    /// What each block of three rows observes.
    pub observed: Vec<Observed>,
}

/// An identification whose predictions carry an uncertainty: the one-target
/// [`Calibration`] and the multi-target [`crate::TargetCalibration`], on
/// their kinds of measurement set.
pub(crate) trait Predicting {
    /// The measurement set the predictions are made at.
    type Set;
    /// Actuated coordinates of pose `k` of `set` (rad or m).
    fn configuration(set: &Self::Set, k: usize) -> &[f64];
    /// Every unknown of the identification, in the covariance's order.
    fn estimates(&self) -> &[UnknownEstimate];
    /// The identification's covariance of every unknown (m, rad, ...).
    fn covariance(&self) -> Option<&DMatrix<f64>>;
    /// The prediction at the poses of `set`, linearised.
    fn linearise(&self, model: &Model, set: &Self::Set) -> Result<Linearised, CalibError>;
    /// The calibrated model's target position at each observation of `set`,
    /// in the measurement frame (m): [`Linearised::predicted`] without the
    /// Jacobian.
    fn predicted_positions(
        &self,
        model: &Model,
        set: &Self::Set,
    ) -> Result<Vec<Vector3<f64>>, CalibError>;
    /// The per-axis scatter of the training residuals, squared:
    /// `SSR / (3 N - p)` with N observations and p identified unknowns
    /// (m^2).
    fn residual_variance(&self) -> f64;
    /// The identified measurement frame.
    fn measurement_frame(&self) -> Isometry3<f64>;
    /// What the identification poses cover of each actuated coordinate.
    fn training_ranges(&self) -> &[CoordinateCoverage];
}

/// `SSR / (3 N - p)` from the RMS of the position errors of `n`
/// observations and `p` identified unknowns (m^2).
pub(crate) fn residual_variance(position_rms: f64, n: usize, p: usize) -> f64 {
    let ssr = position_rms.powi(2) * n as f64;
    ssr / ((3 * n).saturating_sub(p).max(1)) as f64
}

impl Predicting for Calibration {
    type Set = MeasurementSet;
    fn configuration(set: &MeasurementSet, k: usize) -> &[f64] {
        &set.measurements()[k].q
    }
    fn estimates(&self) -> &[UnknownEstimate] {
        &self.unknowns
    }
    fn covariance(&self) -> Option<&DMatrix<f64>> {
        self.solve.covariance.as_ref()
    }
    fn linearise(&self, model: &Model, set: &MeasurementSet) -> Result<Linearised, CalibError> {
        let (problem, x) = self.error_model_at(model, set)?;
        let (jacobian, residuals) = jacobian_and_residuals(&problem, &x)?;
        Ok(Linearised {
            jacobian,
            predicted: predicted_from(set, &residuals),
            observed: (0..set.len())
                .map(|pose| Observed { pose, target: None })
                .collect(),
        })
    }
    fn predicted_positions(
        &self,
        model: &Model,
        set: &MeasurementSet,
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        let (problem, x) = self.error_model_at(model, set)?;
        let mut residuals = vec![0.0; problem.n_residuals()];
        problem
            .residuals(&x, &mut residuals)
            .map_err(model_failure)?;
        Ok(predicted_from(set, &residuals))
    }
    fn residual_variance(&self) -> f64 {
        residual_variance(self.training_after.position_rms, self.n_poses, self.rank())
    }
    fn measurement_frame(&self) -> Isometry3<f64> {
        self.x_meas_base
    }
    fn training_ranges(&self) -> &[CoordinateCoverage] {
        &self.actuated_ranges
    }
}

impl Calibration {
    /// The error model at the identified unknowns (frames at their
    /// identified values, zero increments; positions only) and those
    /// unknowns: the identification's Jacobian at the poses of `set`
    /// (whose measured positions only enter the residuals), as the
    /// predicted accuracy and campaign planning use it.
    ///
    /// # Errors
    /// [`CalibError::InvalidOption`] when `set` gives the model another
    /// number of unknowns than the identification's; the model's errors.
    pub fn error_model_at<'a>(
        &self,
        model: &'a Model,
        set: &MeasurementSet,
    ) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
        let mut targets = TargetMeasurementSet::from_measurement_set(set, TCP_FRAME)?;
        targets = targets.with_targets(vec![Target {
            rotation: self.x_tcp_target.rotation,
            ..Target::new(TCP_FRAME, TCP_FRAME, self.x_tcp_target.translation.vector)
        }])?;
        // The later stations' frames are unknowns of the identification
        // (their covariance is part of it), with no pose of `set`.
        let mut starts = FrameStarts::nominal(&targets, self.x_meas_base, Some(false))?;
        starts.stations = std::iter::once(self.x_meas_base)
            .chain(self.station_frames.iter().copied())
            .collect();
        let gravity = self.elastic.as_ref().map(|(g, _)| g);
        let problem = ErrorModel::new(model, Cow::Owned(targets), &starts)?
            .with_elastic(gravity, &self.joint_terms)?;
        let n = problem.n_unknowns();
        if n != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {n} unknowns, the identification {}",
                    self.unknowns.len()
                ),
            });
        }
        let mut x = problem.initial_unknowns();
        let np = model.n_params();
        x[..np].copy_from_slice(&self.xi);
        if let (Some((_, values)), Some(eo)) = (&self.elastic, problem.elastic_offset()) {
            x[eo..eo + values.len()].copy_from_slice(values);
        }
        if let Some(jo) = problem.joint_terms_offset() {
            x[jo..].copy_from_slice(&self.joint_term_values);
        }
        Ok((problem, x))
    }
}

/// The identification's covariance (m, rad).
pub(crate) fn covariance_of<P: Predicting>(calibration: &P) -> Result<&DMatrix<f64>, CalibError> {
    calibration.covariance().ok_or(CalibError::InvalidOption {
        name: "accuracy",
        reason: "the identification has no covariance (no more equations than unknowns)".into(),
    })
}

/// The variance of the calibrated model's target position at each
/// observation of `set` under the identification's covariance, every
/// identified unknown with the frame's: `tr(J_k Sigma J_k^T)` (m^2,
/// measurement frame). What the split-half check compares in the
/// prediction space.
pub(crate) fn prediction_variances<P: Predicting>(
    calibration: &P,
    model: &Model,
    set: &P::Set,
) -> Result<Vec<f64>, CalibError> {
    let covariance = covariance_of(calibration)?;
    let linearised = calibration.linearise(model, set)?;
    let jac = &linearised.jacobian;
    if covariance.nrows() != jac.ncols() {
        return Err(covariance_size(covariance, jac.ncols()));
    }
    let columns: Vec<usize> = (0..jac.ncols())
        .filter(|&j| calibration.estimates()[j].status == UnknownStatus::Identified)
        .collect();
    let sigma = DMatrix::<f64>::from_fn(columns.len(), columns.len(), |a, b| {
        covariance[(columns[a], columns[b])]
    });
    Ok((0..linearised.observed.len())
        .map(|k| {
            let rows =
                DMatrix::<f64>::from_fn(3, columns.len(), |i, c| jac[(3 * k + i, columns[c])]);
            (&rows * &sigma * rows.transpose()).trace().max(0.0)
        })
        .collect())
}

/// The predicted positions of `set`'s poses from its measured ones and the
/// position residuals (predicted minus measured, three per pose; m).
fn predicted_from(set: &MeasurementSet, residuals: &[f64]) -> Vec<Vector3<f64>> {
    set.measurements()
        .iter()
        .enumerate()
        .map(|(k, m)| m.position + Vector3::from_fn(|i, _| residuals[3 * k + i]))
        .collect()
}

/// The covariance does not match the error model's unknowns.
pub(crate) fn covariance_size(covariance: &DMatrix<f64>, n: usize) -> CalibError {
    CalibError::InvalidOption {
        name: "accuracy",
        reason: format!(
            "the error model has {n} unknowns, the identification's covariance {}",
            covariance.nrows()
        ),
    }
}

/// A model failure at a pose, as the accuracy's error.
fn model_failure(e: flexcal_optim::ProblemError) -> CalibError {
    CalibError::InvalidOption {
        name: "accuracy",
        reason: e.to_string(),
    }
}

/// The error model's Jacobian and residuals at `x`.
pub(crate) fn jacobian_and_residuals<P: Jacobian>(
    problem: &P,
    x: &[f64],
) -> Result<(faer::Mat<f64>, Vec<f64>), CalibError> {
    let mut jac = faer::Mat::<f64>::zeros(problem.n_residuals(), x.len());
    problem.jacobian(x, jac.as_mut()).map_err(model_failure)?;
    let mut residuals = vec![0.0; problem.n_residuals()];
    problem
        .residuals(x, &mut residuals)
        .map_err(model_failure)?;
    Ok((jac, residuals))
}

//! A calibration's prediction at any pose, linearised at the identified
//! unknowns: what the predicted accuracy ([`crate::AccuracyMap`]) and the
//! split-half check in the prediction space ([`crate::SplitCheck`]) are
//! computed from, for one target and for several.

use flexcal_kinematics::Model;
use nalgebra::{DMatrix, Vector3};

use std::borrow::Cow;

use crate::error::CalibError;
use crate::error_model::target_unknown_names;
use crate::error_model::{ErrorModel, FrameStarts};
use crate::identify::Calibration;
use crate::measurement::MeasurementSet;
use crate::unknowns::UnknownStatus;
use flexcal_optim::Jacobian;

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

/// What a [`Calibration`] predicts at the poses of a set, with an
/// uncertainty.
impl MeasurementSet {
    /// Actuated coordinates of pose `k` (rad or m).
    pub(crate) fn configuration(&self, k: usize) -> &[f64] {
        &self.poses()[k].q
    }

    /// The prediction of `calibration` at these poses, linearised; the
    /// observations name their target, but the one of a one-target set.
    pub(crate) fn linearise(
        &self,
        calibration: &Calibration,
        model: &Model,
    ) -> Result<Linearised, CalibError> {
        let (problem, x) = calibration.error_model_at(model, self, false)?;
        let (jacobian, residuals) = jacobian_and_residuals(&problem, &x)?;
        let calibrated = problem.set();
        let named = !self.is_one_target();
        Ok(Linearised {
            jacobian,
            predicted: (0..problem.n_observations())
                .map(|r| {
                    problem.measured(r).position + Vector3::from_fn(|i, _| residuals[3 * r + i])
                })
                .collect(),
            observed: (0..problem.n_observations())
                .map(|i| {
                    let (pose, t) = problem.observation(i);
                    Observed {
                        pose,
                        target: named.then(|| calibrated.targets()[t].name.clone()),
                    }
                })
                .collect(),
        })
    }

    /// The calibrated model's target position at each observation, in the
    /// measurement frame (m): [`Linearised::predicted`] without the
    /// Jacobian.
    pub(crate) fn predicted_positions(
        &self,
        calibration: &Calibration,
        model: &Model,
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        let (problem, x) = calibration.error_model_at(model, self, false)?;
        Ok(problem
            .predict(&x)?
            .iter()
            .map(|p| p.translation.vector)
            .collect())
    }
}

/// `SSR / dof` from the RMS of the position errors of `n` observations
/// and the degrees of freedom `dof` the position rows keep (m^2).
fn residual_variance(position_rms: f64, n: usize, dof: f64) -> f64 {
    let ssr = position_rms.powi(2) * n as f64;
    ssr / dof.max(1.0)
}

impl Calibration {
    /// The per-axis scatter of the training residuals, squared:
    /// `SSR / (3 N - p)` with N observations and p identified unknowns, or
    /// `SSR / (3 N - tr(H_pp))` when orientation rows were fitted too
    /// ([`Calibration::position_residual_dof`]) (m^2).
    pub(crate) fn residual_variance(&self) -> f64 {
        let dof = self
            .position_residual_dof
            .unwrap_or_else(|| (3 * self.n_observations).saturating_sub(self.rank()).max(1) as f64);
        residual_variance(self.training_after.position_rms, self.n_observations, dof)
    }

    /// The per-axis scatter of the training residuals (m), `s = sqrt(SSR /
    /// (3 N - p))` with N observations and p identified unknowns (`3 N -
    /// tr(H_pp)` with orientation rows: [`Calibration::position_residual_dof`]): what the
    /// model leaves at the training poses, noise and every effect it lacks.
    /// An earlier campaign's value is the floor a plan of the same robot
    /// and model should state as its noise (`flexcal plan --noise-mm`),
    /// where the instrument's own noise is below what a calibration leaves.
    pub fn residual_scatter(&self) -> f64 {
        self.residual_variance().sqrt()
    }
}

impl Calibration {
    /// The error model at the identified unknowns and those unknowns: the
    /// identification's targets (their identified offsets, treated as they
    /// were), the offsets' and the measurement frames' unknowns at zero
    /// increments from the identified ones, every frame of the
    /// identification's stations (a set of fewer stations gives the others
    /// zero columns); positions only, or with the orientation rows of the
    /// targets that carry them when `use_orientation` (a campaign measuring
    /// full poses). The identification's Jacobian at the poses of `set`
    /// (whose measurements only enter the residuals), as the predicted
    /// accuracy (positions) and campaign planning use it.
    ///
    /// # Errors
    /// Targets that differ from the identification's by name;
    /// [`CalibError::InvalidOption`] when `set` gives the model another
    /// number of unknowns than the identification's; the model's errors.
    pub fn error_model_at<'a>(
        &self,
        model: &'a Model,
        set: &MeasurementSet,
        use_orientation: bool,
    ) -> Result<(ErrorModel<'a>, Vec<f64>), CalibError> {
        let calibrated = set.with_targets(self.targets.clone())?;
        let orientation = if use_orientation { None } else { Some(false) };
        let mut starts = FrameStarts::nominal(&calibrated, self.x_meas_base, orientation)?;
        starts.stations = self.measurement_frames();
        // The identification's rotation unknowns, without their rows.
        let count = calibrated.targets().len();
        starts.rotation = calibrated
            .targets()
            .iter()
            .map(|t| {
                let rx = &target_unknown_names(&t.name, count)[3];
                self.unknowns.iter().any(|u| &u.name == rx)
            })
            .collect();
        let gravity = self.elastic.as_ref().map(|(g, _)| g);
        let problem = ErrorModel::new(model, Cow::Owned(calibrated), &starts)?
            .with_elastic(gravity, &self.joint_terms)?;
        let mut x = self.xi.clone();
        x.resize(problem.frames_end(), 0.0);
        if let Some((_, values)) = &self.elastic {
            x.extend(values);
        }
        x.extend(&self.joint_term_values);
        if x.len() != self.unknowns.len() {
            return Err(CalibError::InvalidOption {
                name: "accuracy",
                reason: format!(
                    "the error model has {} unknowns, the identification {}",
                    x.len(),
                    self.unknowns.len()
                ),
            });
        }
        Ok((problem, x))
    }
}

/// The identification's covariance (m, rad).
pub(crate) fn covariance_of(calibration: &Calibration) -> Result<&DMatrix<f64>, CalibError> {
    calibration
        .solve
        .covariance
        .as_ref()
        .ok_or(CalibError::InvalidOption {
            name: "accuracy",
            reason: "the identification has no covariance (no more equations than unknowns)".into(),
        })
}

/// The variance of the calibrated model's target position at each
/// observation of `set` under the identification's covariance, every
/// identified unknown with the frame's: `tr(J_k Sigma J_k^T)` (m^2,
/// measurement frame). What the split-half check compares in the
/// prediction space.
pub(crate) fn prediction_variances(
    calibration: &Calibration,
    model: &Model,
    set: &MeasurementSet,
) -> Result<Vec<f64>, CalibError> {
    let covariance = covariance_of(calibration)?;
    let linearised = set.linearise(calibration, model)?;
    let jac = &linearised.jacobian;
    if covariance.nrows() != jac.ncols() {
        return Err(covariance_size(covariance, jac.ncols()));
    }
    let columns: Vec<usize> = (0..jac.ncols())
        .filter(|&j| calibration.unknowns[j].status == UnknownStatus::Identified)
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

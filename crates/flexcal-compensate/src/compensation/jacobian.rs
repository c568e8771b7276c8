//! The joint Jacobian at a recent configuration, factored once and reused
//! for correction steps.

use flexcal_kinematics::{Data, Model, joint_jacobian_into};
use nalgebra::{Isometry3, Matrix6xX, Vector6};

use super::error::CompensationError;

/// A step whose error shrinks by less than this factor marks the stored
/// joint Jacobian as too far from the current configuration: it is
/// recomputed there. A fresh Jacobian contracts by the ratio of the neglected
/// elastic term (about 1e-3 for the paper's robot), a Jacobian stored a few
/// millimetres of path earlier by about 1e-2, so a factorisation is reused
/// over many iterations and path points.
pub(crate) const JACOBIAN_REFRESH_RATIO: f64 = 0.1;

/// How the stored Jacobian is factored. One lives in each workspace, so
/// its size does not matter; boxing the LU would allocate at every refresh.
#[allow(clippy::large_enum_variant)]
enum JacobianFactor {
    /// No Jacobian yet.
    Empty,
    /// Six actuated coordinates: LU of the square Jacobian (on the stack,
    /// so a refresh allocates nothing).
    Square(nalgebra::LU<f64, nalgebra::U6, nalgebra::U6>),
    /// Redundant or deficient robots: least squares by SVD.
    LeastSquares(Box<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>>),
}

/// The joint Jacobian at some recent configuration, factored once and
/// reused for the correction steps: the corrections converge at the rate of
/// the Jacobian's error, so a slightly stale one costs little and saves a
/// Jacobian evaluation and a factorisation per step.
pub(crate) struct JacobianCache {
    jacobian: Matrix6xX<f64>,
    factor: JacobianFactor,
    step: Vec<f64>,
}

impl JacobianCache {
    pub(crate) fn new(n_actuated: usize) -> Self {
        Self {
            jacobian: Matrix6xX::zeros(n_actuated),
            factor: JacobianFactor::Empty,
            step: vec![0.0; n_actuated],
        }
    }

    pub(crate) fn is_empty(&self) -> bool {
        matches!(self.factor, JacobianFactor::Empty)
    }

    /// Forgets the stored Jacobian: the next correction evaluates a fresh one.
    pub(crate) fn clear(&mut self) {
        self.factor = JacobianFactor::Empty;
    }

    /// Evaluates and factors the Jacobian at `q`; returns the geometric pose.
    pub(crate) fn refresh(
        &mut self,
        model: &Model,
        data: &mut Data,
        q: &[f64],
        xi: &[f64],
    ) -> Result<Isometry3<f64>, CompensationError> {
        let pose = joint_jacobian_into(model, data, q, xi, &mut self.jacobian)?;
        self.factor = if self.jacobian.ncols() == 6 {
            let m: nalgebra::Matrix6<f64> = self.jacobian.fixed_columns::<6>(0).into_owned();
            JacobianFactor::Square(m.lu())
        } else {
            let dj = nalgebra::DMatrix::from_column_slice(
                6,
                self.jacobian.ncols(),
                self.jacobian.as_slice(),
            );
            JacobianFactor::LeastSquares(Box::new(dj.svd(true, true)))
        };
        Ok(pose)
    }

    /// `q <- clamp(q - J^-1 error)`; `limits` `None`: no clamping.
    pub(crate) fn correct(
        &mut self,
        q: &mut [f64],
        error: &Vector6<f64>,
        limits: Option<&[(f64, f64)]>,
    ) -> Result<(), CompensationError> {
        match &self.factor {
            JacobianFactor::Empty => return Err(CompensationError::Singular),
            JacobianFactor::Square(lu) => {
                let step = lu.solve(error).ok_or(CompensationError::Singular)?;
                self.step.copy_from_slice(step.as_slice());
            }
            JacobianFactor::LeastSquares(svd) => {
                let rhs = nalgebra::DVector::from_column_slice(error.as_slice());
                let step = svd
                    .solve(&rhs, 1e-12)
                    .map_err(|_| CompensationError::Singular)?;
                self.step.copy_from_slice(step.as_slice());
            }
        }
        match limits {
            Some(limits) => {
                for ((v, s), &(lo, hi)) in q.iter_mut().zip(&self.step).zip(limits) {
                    *v = (*v - s).clamp(lo, hi);
                }
            }
            None => {
                for (v, s) in q.iter_mut().zip(&self.step) {
                    *v -= s;
                }
            }
        }
        Ok(())
    }
}

//! Sensitivity indices (55)-(58) and slider-crank conversions.

use nalgebra::DMatrix;

use crate::KinematicsError;
use crate::error::check_vector;
use crate::forward::{param_jacobian_into, slider_crank_angle};
use crate::model::{ActuatedKind, JointSource, ParamKind};
use crate::{Data, Model};

/// Sensitivity of the TCP pose to each geometric parameter over a set of
/// configurations: `mu_P = |J_P,j|` (55) and `mu_Phi = |J_Phi,j|` (56), the
/// norms of the position and orientation rows of column j of the parameter
/// Jacobian; a parameter error `dxi_j` moves the TCP by `mu_P dxi_j` (57) and
/// turns it by `mu_Phi dxi_j` (58).
#[derive(Debug, Clone, PartialEq)]
pub struct SensitivityTable {
    /// Parameter names, in the order of xi.
    pub names: Vec<String>,
    /// Parameter kinds (the unit of the denominator: per m or per rad).
    pub kinds: Vec<ParamKind>,
    /// Mean of mu_P over configurations (m per unit of the parameter).
    pub mean_position: Vec<f64>,
    /// Max of mu_P over configurations (m per unit).
    pub max_position: Vec<f64>,
    /// Mean of mu_Phi over configurations (rad per unit).
    pub mean_orientation: Vec<f64>,
    /// Max of mu_Phi over configurations (rad per unit).
    pub max_orientation: Vec<f64>,
    /// Number of configurations used.
    pub n_configurations: usize,
}

/// Sensitivity indices (55)-(58) of every parameter, mean and max over
/// `configurations` (each a q vector).
pub fn sensitivity_indices(
    model: &Model,
    data: &mut Data,
    configurations: &[Vec<f64>],
    xi: &[f64],
) -> Result<SensitivityTable, KinematicsError> {
    if configurations.is_empty() {
        return Err(KinematicsError::Invalid {
            what: "sensitivity indices need at least one configuration".into(),
        });
    }
    let np = model.n_params();
    let mut table = SensitivityTable {
        names: model.params().iter().map(|p| p.name.clone()).collect(),
        kinds: model.params().iter().map(|p| p.kind).collect(),
        mean_position: vec![0.0; np],
        max_position: vec![0.0; np],
        mean_orientation: vec![0.0; np],
        max_orientation: vec![0.0; np],
        n_configurations: configurations.len(),
    };
    let mut jac = DMatrix::zeros(6, np);
    for q in configurations {
        param_jacobian_into(model, data, q, xi, &mut jac)?;
        for j in 0..np {
            let c = jac.column(j);
            let mu_p = c.rows(0, 3).norm();
            let mu_phi = c.rows(3, 3).norm();
            table.mean_position[j] += mu_p;
            table.mean_orientation[j] += mu_phi;
            table.max_position[j] = table.max_position[j].max(mu_p);
            table.max_orientation[j] = table.max_orientation[j].max(mu_phi);
        }
    }
    let n = configurations.len() as f64;
    for j in 0..np {
        table.mean_position[j] /= n;
        table.mean_orientation[j] /= n;
    }
    Ok(table)
}

/// Actuated coordinates from joint values (what a controller reports): the
/// joint angle of a slider-crank joint becomes its screw length through the
/// nominal relation V; other coordinates pass through.
///
/// `joint_values` holds one value per actuated coordinate: the joint variable
/// (rad, m) of the frame it drives, without the frame's constant offset.
pub fn actuated_from_joint_angles(
    model: &Model,
    joint_values: &[f64],
) -> Result<Vec<f64>, KinematicsError> {
    check_vector("joint_values", joint_values, model.n_actuated())?;
    let xi = model.nominal_params();
    let mut q = joint_values.to_vec();
    for (k, &f) in model.actuated_frames.iter().enumerate() {
        if model.actuated_kinds[k] != ActuatedKind::Screw {
            continue;
        }
        let JointSource::SliderCrank(c) = model.frames[f].source else {
            continue;
        };
        let crank = &model.cranks[c];
        let (kappa, lambda) = (crank.kappa.eval(xi), crank.lambda.eval(xi));
        let (l1, l3) = (crank.l1.eval(xi), crank.l3.eval(xi));
        let phi = crank.branch * (joint_values[k] - lambda + kappa);
        if !(0.0..=std::f64::consts::PI).contains(&phi) {
            return Err(KinematicsError::SliderCrankOutOfRange {
                joint: model.frames[f].name.clone(),
                screw_length: f64::NAN,
                cosine: phi.cos(),
            });
        }
        let screw = (l1 * l1 + l3 * l3 - 2.0 * l1 * l3 * phi.cos()).sqrt();
        q[k] = screw - crank.screw_offset.eval(xi);
    }
    Ok(q)
}

/// Joint values from actuated coordinates: screw lengths become joint angles
/// through the nominal relation V (Appendix A); other coordinates pass through.
pub fn joint_angles_from_actuated(model: &Model, q: &[f64]) -> Result<Vec<f64>, KinematicsError> {
    check_vector("q", q, model.n_actuated())?;
    let xi = model.nominal_params();
    let mut out = q.to_vec();
    for (k, &f) in model.actuated_frames.iter().enumerate() {
        let JointSource::SliderCrank(c) = model.frames[f].source else {
            continue;
        };
        let crank = &model.cranks[c];
        let (angle, _) = slider_crank_angle(
            &model.frames[f].name,
            q[k] + crank.screw_offset.eval(xi),
            crank.kappa.eval(xi),
            crank.lambda.eval(xi),
            crank.l1.eval(xi),
            crank.l3.eval(xi),
            crank.branch,
        )?;
        out[k] = angle;
    }
    Ok(out)
}

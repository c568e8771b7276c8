//! Pose selection for a geometric campaign (beyond the paper).

use faer::Mat;
use flexcal_kinematics::{Data, Model, param_jacobian_into};
use flexcal_optim::{
    IdentifiabilityOptions, ObservabilityIndex, PoseSelection, PoseSelectionOptions,
    analyze_identifiability, select_poses,
};
use nalgebra::DMatrix;

use crate::error::CalibError;

/// Result of [`select_calibration_poses`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationPoseSelection {
    /// The selection (indices into the candidates, sorted; indices O1-O5).
    pub selection: PoseSelection,
    /// The robot parameters the indices are computed over: the base set of
    /// the whole candidate pool (a non-identifiable parameter would make
    /// every index zero).
    pub parameters: Vec<String>,
}

/// Chooses `count` of the candidate configurations maximising an
/// observability index of the robot-parameter Jacobian (positions, plus
/// orientations when `use_orientation`), greedy then exchange.
///
/// Parameters in `fixed` are left out; the rest is first reduced to the base
/// set identifiable from the whole pool.
///
/// # Errors
/// Unknown names, candidates of the wrong length or where the model fails,
/// a count outside `1..=candidates`, solver failures.
pub fn select_calibration_poses(
    model: &Model,
    candidates: &[Vec<f64>],
    count: usize,
    index: ObservabilityIndex,
    use_orientation: bool,
    fixed: &[String],
) -> Result<CalibrationPoseSelection, CalibError> {
    let np = model.n_params();
    let mut keep = vec![true; np];
    for name in fixed {
        let j = model
            .param_index(name)
            .ok_or_else(|| CalibError::UnknownParameter {
                name: name.clone(),
                known: model
                    .params()
                    .iter()
                    .map(|p| p.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })?;
        keep[j] = false;
    }
    let columns: Vec<usize> = (0..np).filter(|&j| keep[j]).collect();
    let rows = if use_orientation { 6 } else { 3 };
    let mut data = Data::new(model);
    let mut jac = DMatrix::zeros(6, np);
    let xi = model.nominal_params();
    let mut blocks = Vec::with_capacity(candidates.len());
    for (k, q) in candidates.iter().enumerate() {
        param_jacobian_into(model, &mut data, q, xi, &mut jac).map_err(|source| {
            CalibError::Kinematics {
                pose: k,
                pose_id: format!("candidate {k}"),
                source,
            }
        })?;
        blocks.push(Mat::<f64>::from_fn(rows, columns.len(), |i, c| {
            jac[(i, columns[c])]
        }));
    }
    let stacked = Mat::<f64>::from_fn(rows * blocks.len(), columns.len(), |i, c| {
        blocks[i / rows][(i % rows, c)]
    });
    let names: Vec<String> = columns
        .iter()
        .map(|&j| model.params()[j].name.clone())
        .collect();
    let analysis =
        analyze_identifiability(stacked.as_ref(), &names, &IdentifiabilityOptions::default())
            .map_err(CalibError::optim(
                "pose selection: identifiability of the pool",
            ))?;
    let mut base = analysis.base.clone();
    base.sort_unstable();
    let reduced: Vec<Mat<f64>> = blocks
        .iter()
        .map(|b| Mat::<f64>::from_fn(rows, base.len(), |i, c| b[(i, base[c])]))
        .collect();
    let mut options = PoseSelectionOptions::new(count);
    options.index = index;
    let selection =
        select_poses(&reduced, &options).map_err(CalibError::optim("pose selection"))?;
    Ok(CalibrationPoseSelection {
        selection,
        parameters: base.iter().map(|&c| names[c].clone()).collect(),
    })
}

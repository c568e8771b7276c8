//! Choosing measurement poses from a candidate file (`flexcal poses
//! select`): the candidates' configurations (CSV `q1..qn`, rad or m), the
//! selection that maximises an observability index of the robot-parameter
//! Jacobian, and the selected configurations as a file of the same format.

use std::fmt::Write as _;
use std::path::PathBuf;

use flexcal_calib::{CalibrationPoseSelection, read_configurations, select_calibration_poses};
use flexcal_kinematics::Model;
use flexcal_optim::ObservabilityIndex;

use crate::Result;

/// What to select from which candidates.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSelectionConfig {
    /// Candidate configurations: CSV with columns `q1..qn`.
    pub candidates: PathBuf,
    /// Number of poses to select.
    pub count: usize,
    /// The index to maximise (default O1, D-optimality).
    pub index: ObservabilityIndex,
    /// Whether the measurements will carry orientations too (6 rows per
    /// pose instead of 3; default positions only).
    pub use_orientation: bool,
    /// Parameters kept at nominal (left out of the Jacobian).
    pub fixed: Vec<String>,
}

impl PoseSelectionConfig {
    /// `count` poses of `candidates` by O1 over positions, no parameter fixed.
    pub fn new(candidates: impl Into<PathBuf>, count: usize) -> Self {
        Self {
            candidates: candidates.into(),
            count,
            index: ObservabilityIndex::O1,
            use_orientation: false,
            fixed: Vec::new(),
        }
    }
}

/// A selection and the candidates it chose from.
#[derive(Debug, Clone)]
pub struct PoseSelectionRun {
    /// The candidate configurations, in file order.
    pub candidates: Vec<Vec<f64>>,
    /// The selection (rows of `candidates`) and its indices.
    pub result: CalibrationPoseSelection,
}

impl PoseSelectionRun {
    /// The selected configurations, in candidate order.
    pub fn selected(&self) -> Vec<Vec<f64>> {
        let rows = &self.result.selection.selected;
        rows.iter().map(|&i| self.candidates[i].clone()).collect()
    }

    /// Three lines: how many were selected over how many parameters, the
    /// indices O1-O5 of the selection, the selected rows (0-based).
    pub fn summary_text(&self) -> String {
        let s = &self.result.selection;
        let mut out = String::new();
        let _ = writeln!(
            out,
            "selected {} of {} candidates over {} identifiable parameters ({} exchanges, {} evaluations)",
            s.selected.len(),
            self.candidates.len(),
            self.result.parameters.len(),
            s.exchanges,
            s.evaluations
        );
        let _ = writeln!(
            out,
            "O1 {:.4e}  O2 {:.4e}  O3 {:.4e}  O4 {:.4e}  O5 {:.4e}",
            s.indices.o1, s.indices.o2, s.indices.o3, s.indices.o4, s.indices.o5
        );
        let rows: Vec<String> = s.selected.iter().map(usize::to_string).collect();
        let _ = writeln!(
            out,
            "selected candidates (0-based rows): {}",
            rows.join(" ")
        );
        out
    }
}

/// Reads the candidates and selects poses of `model` as `config` says.
///
/// # Errors
/// An unreadable candidate file (file, line, column), a count the pool
/// cannot give, unknown parameter names.
pub fn select_poses(model: &Model, config: &PoseSelectionConfig) -> Result<PoseSelectionRun> {
    let candidates = read_configurations(&config.candidates)?;
    let result = select_calibration_poses(
        model,
        &candidates,
        config.count,
        config.index,
        config.use_orientation,
        &config.fixed,
    )?;
    Ok(PoseSelectionRun { candidates, result })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_selected_rows_are_the_candidates_written_back() {
        let model = crate::load_robot("ur10").unwrap();
        let candidates: Vec<Vec<f64>> = (0..30)
            .map(|k| {
                let t = k as f64;
                vec![
                    0.2 * t,
                    -1.0 + 0.05 * t,
                    1.5 - 0.07 * t,
                    0.3 * t.sin(),
                    1.0 + 0.1 * t.cos(),
                    0.1 * t,
                ]
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("candidates.csv");
        std::fs::write(
            &path,
            crate::pose_file::configurations_to_csv(6, &candidates),
        )
        .unwrap();
        let run = select_poses(&model, &PoseSelectionConfig::new(&path, 12)).unwrap();
        assert_eq!(run.candidates, candidates);
        let selected = run.selected();
        assert_eq!(selected.len(), 12);
        for (row, q) in run.result.selection.selected.iter().zip(&selected) {
            assert_eq!(&candidates[*row], q);
        }
        let text = run.summary_text();
        assert!(text.starts_with("selected 12 of 30 candidates"), "{text}");
        assert_eq!(text.lines().count(), 3);
    }
}

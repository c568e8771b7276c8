//! The files of a plan: the pose list ready to measure (configurations
//! CSV `q1..qn` in rad or m, as `calibrate`'s and `poses select`'s files;
//! a joint trajectory CSV in deg and mm; KRL and RAPID programs through the
//! nominal TCP poses, with `compensate`'s exporters), the JSON plan and the
//! HTML page. Every text is built before any file is written, so a plan a
//! format cannot express leaves every file as it was.

use std::path::PathBuf;

use nalgebra::Isometry3;

use super::CampaignPlan;
use crate::compensate::export::{RapidOptions, joint_trajectory_csv, rapid_module};
use crate::compensate::path::{KrlOptions, krl_program};
use crate::kinematics::{Data, Model, forward_pose};
use crate::pose_file::configurations_to_csv;
use crate::{Error, Result};

/// Where to write a plan's files (each optional).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlanOutputs {
    /// The planned configurations, CSV `q1..qn` (rad or m), in measurement
    /// order: the input of `flexcal poses`, `fk`, and the `q` columns of
    /// the measurement file to fill.
    pub configurations: Option<PathBuf>,
    /// The planned configurations as a joint trajectory (deg, mm; columns
    /// named by the robot's actuated coordinates).
    pub joint_trajectory: Option<PathBuf>,
    /// A KRL program through the planned TCP poses (PTP to the first, then
    /// LIN: check the moves between poses on the cell before running it).
    pub krl: Option<PathBuf>,
    /// An ABB RAPID module through the planned TCP poses.
    pub rapid: Option<PathBuf>,
    /// The plan as JSON ([`CampaignPlan`]).
    pub report: Option<PathBuf>,
    /// The plan as an HTML page (the curve and the map).
    pub html: Option<PathBuf>,
}

impl CampaignPlan {
    /// The nominal TCP poses of the planned configurations, in the robot
    /// base frame (m).
    ///
    /// # Errors
    /// A configuration where the model fails.
    pub fn tcp_poses(&self, model: &Model) -> Result<Vec<Isometry3<f64>>> {
        let mut data = Data::new(model);
        self.configurations
            .iter()
            .map(|q| Ok(forward_pose(model, &mut data, q, model.nominal_params())?))
            .collect()
    }

    /// The plan as pretty-printed JSON (the fields of [`CampaignPlan`]).
    ///
    /// # Errors
    /// [`Error::Json`] (not expected: every field serialises).
    pub fn to_json_string(&self) -> Result<String> {
        serde_json::to_string_pretty(self).map_err(|source| Error::Json {
            context: "the plan".into(),
            source,
        })
    }

    /// Writes the files of `outputs` and returns one line per file written.
    ///
    /// # Errors
    /// A plan an export cannot express (nothing is written then); a file
    /// that cannot be written.
    pub fn write_outputs(&self, model: &Model, outputs: &PlanOutputs) -> Result<Vec<String>> {
        let poses = self.tcp_poses(model)?;
        let n = model.n_actuated();
        let mut files: Vec<(&PathBuf, String, &str)> = Vec::new();
        if let Some(path) = &outputs.configurations {
            files.push((
                path,
                configurations_to_csv(n, &self.configurations),
                "planned configurations",
            ));
        }
        if let Some(path) = &outputs.joint_trajectory {
            let text = joint_trajectory_csv(model, &self.configurations, None)?;
            files.push((path, text, "joint trajectory"));
        }
        if let Some(path) = &outputs.krl {
            let options = KrlOptions {
                program_name: "flexcal_plan".into(),
                ..KrlOptions::default()
            };
            files.push((path, krl_program(&poses, &options)?, "KRL program"));
        }
        if let Some(path) = &outputs.rapid {
            files.push((
                path,
                rapid_module(&poses, &RapidOptions::default())?,
                "RAPID module",
            ));
        }
        if let Some(path) = &outputs.report {
            files.push((path, self.to_json_string()?, "JSON plan"));
        }
        if let Some(path) = &outputs.html {
            files.push((path, self.html_report().to_html(), "HTML plan"));
        }
        let mut written = Vec::with_capacity(files.len());
        for (path, text, what) in files {
            flexcal_io::write_atomic(path, text)?;
            written.push(format!("{what} written to {}", path.display()));
        }
        Ok(written)
    }
}

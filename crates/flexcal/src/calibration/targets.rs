//! The per-target side of a calibration run with several measured targets
//! per pose (markers on the hands of a two-armed robot, reflectors on a
//! tool): reading the targets description and the measurements for
//! [`crate::calibration::run_calibration`], and the run's text, page, JSON
//! and files with per-target figures
//! ([`CalibrationRun::several_targets`]).

use serde::Serialize;

use crate::calib::{self, MeasurementSet, TargetErrors, UnknownStatus};
use crate::calibration::html::{
    calibration_page, check_sections, data_checks_section, errors_chart, statistics_row,
    statistics_table, unknowns_section,
};
use crate::calibration::text::{
    coverage_line, cross_check_text, data_check_notes, extrapolation_line, split_check_text,
    station_hold_out_text,
};
use crate::calibration::{
    CalibrationConfig, CalibrationOutputs, CalibrationRun, Exclusion, MeasurementFormat, exclude,
    extrapolation_note, station_files,
};
use crate::report::svg::Series;
use crate::report::{Report, Section};
use crate::{Error, Result};

/// The targets description of `config`, after checking that `config` sets
/// nothing a run with several targets per pose cannot take (another file
/// format, a target start, the residual model; validation options without
/// a validation set).
pub(crate) fn check_targets_config(config: &CalibrationConfig) -> Result<&std::path::Path> {
    let invalid = |parameter: &str| Error::InvalidParameter {
        parameter: parameter.to_string(),
        message: "not available with several targets per pose (--targets)".into(),
    };
    let Some(targets_path) = &config.targets else {
        return Err(Error::InvalidParameter {
            parameter: "targets".into(),
            message: "a multi-target calibration needs a targets description".into(),
        });
    };
    let unsupported = [
        ("format", config.format != MeasurementFormat::Own),
        ("target_mm", config.target_mm.is_some()),
        ("refit_target", config.refit_target),
        ("residual_inputs", !config.residual_inputs.is_empty()),
    ];
    if let Some((name, _)) = unsupported.iter().find(|(_, set)| *set) {
        return Err(invalid(name));
    }
    if config.validate.is_none() {
        let needs = [
            ("cross_check", config.cross_check),
            ("exclude_validation", !config.exclude_validation.is_empty()),
        ];
        if let Some((name, _)) = needs.iter().find(|(_, set)| *set) {
            return Err(Error::InvalidParameter {
                parameter: name.to_string(),
                message: "needs a validation set".into(),
            });
        }
    }
    Ok(targets_path)
}

/// The identification set (one station per file, pooled) and the
/// validation set of the targets described in `targets_path`, each
/// without its excluded poses and observations (recorded in `exclusions`).
pub(crate) fn read_target_sets(
    config: &CalibrationConfig,
    targets_path: &std::path::Path,
    exclusions: &mut Vec<Exclusion>,
) -> Result<(MeasurementSet, Option<MeasurementSet>)> {
    let step = |step: &'static str| move |source| Error::CalibrationStep { step, source };
    let targets = calib::read_targets(targets_path).map_err(step("targets description"))?;
    // One station per file (each with its own measurement frame).
    let sets = station_files(config)?
        .into_iter()
        .map(|path| MeasurementSet::read_targets_csv(path, &targets))
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(step("identification measurements"))?;
    let data = exclude(
        MeasurementSet::pooled(&sets).map_err(step("identification measurements"))?,
        &config.exclude,
        "--exclude",
        exclusions,
    )?;
    let validation_set = config
        .validate
        .as_deref()
        .map(|p| {
            let set = MeasurementSet::read_targets_csv(p, &targets)
                .map_err(step("validation measurements"))?;
            exclude(
                set,
                &config.exclude_validation,
                "--exclude-validation",
                exclusions,
            )
        })
        .transpose()?;
    Ok((data, validation_set))
}

impl CalibrationRun {
    /// What `flexcal calibrate --targets` prints: a line per exclusion, a
    /// line naming the robot and the identification file, then
    /// [`CalibrationRun::lines`], each ended by a newline.
    pub(crate) fn target_summary_text(&self, robot: &crate::kinematics::Model) -> String {
        let mut text: String = self.exclusions.iter().map(|e| format!("{e}\n")).collect();
        text += &format!(
            "Calibrating `{}` ({} parameters) from {}\n",
            robot.name(),
            robot.n_params(),
            self.data.source
        );
        for line in self.lines() {
            text.push_str(&line);
            text.push('\n');
        }
        text
    }

    /// Writes the files `outputs` names, each atomically: the calibrated
    /// robot description (TOML), the JSON report
    /// ([`CalibrationRun::to_json_string`]), the HTML page
    /// ([`CalibrationRun::html_report`]), the error of every
    /// observation ([`calib::observation_errors_csv`]: of the validation set
    /// when there is one, else of the identification set) and the accuracy
    /// map beside its grid (`<grid>.accuracy.csv`, one row per
    /// configuration and target); returns one line per file written saying
    /// what it holds.
    ///
    /// # Errors
    /// The file that could not be written; a calibrated description that
    /// cannot be built.
    pub(crate) fn write_target_outputs(
        &self,
        robot: &crate::kinematics::Model,
        outputs: &CalibrationOutputs,
    ) -> Result<Vec<String>> {
        let mut written = Vec::new();
        if let Some(path) = &outputs.description {
            let description = self.calibration.description(robot)?;
            flexcal_io::write_atomic(path, description.to_toml_string())?;
            written.push(format!("calibrated robot written to {}", path.display()));
        }
        if let Some(path) = &outputs.report {
            flexcal_io::write_atomic(path, self.to_json_string()?)?;
            written.push(format!("report written to {}", path.display()));
        }
        if let Some(path) = &outputs.residuals {
            let (errors, which) = match &self.validation {
                Some(v) => (&v.observation_errors, "validation"),
                None => (&self.calibration.observation_errors, "identification"),
            };
            flexcal_io::write_atomic(path, calib::observation_errors_csv(errors))?;
            written.push(format!(
                "error of every {which} observation written to {}",
                path.display()
            ));
        }
        if let Some(path) = &outputs.html {
            flexcal_io::write_atomic(path, self.html_report(robot).to_html())?;
            written.push(format!("HTML report written to {}", path.display()));
        }
        if let (Some(grid), Some(map)) = (&outputs.accuracy_grid, &self.accuracy_map) {
            let path = grid.with_extension("accuracy.csv");
            map.write_csv(&path)?;
            written.push(format!(
                "predicted accuracy of {} targets at {} configurations written to {}{}",
                self.calibration.targets.len(),
                map.poses.len() / self.calibration.targets.len().max(1),
                path.display(),
                extrapolation_note(map)
            ));
        }
        Ok(written)
    }

    /// The run as text for a terminal: the identification (rank, what the
    /// targets cannot see, identified unknowns with their standard errors),
    /// the split-half check, per-target errors before and after (mm), the
    /// data checks (repeated readings, suspect observations and the option
    /// that leaves their poses out) and the share of the validation
    /// observations within their predicted 95 % bounds.
    pub fn lines(&self) -> Vec<String> {
        let c = &self.calibration;
        let mut lines = vec![format!(
            "{} poses, {} observations of {} targets: {} of {} unknowns identified ({:?} after {} iterations)",
            c.n_poses,
            c.n_observations,
            c.targets.len(),
            c.rank(),
            c.unknowns.len(),
            c.solve.termination,
            c.solve.iterations
        )];
        if c.station_names.len() > 1 {
            lines.push(format!(
                "{} stations, each with its own measurement frame: {}",
                c.station_names.len(),
                c.station_names
                    .iter()
                    .enumerate()
                    .map(|(s, name)| format!("s{} {name}", s + 1))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if let Some(selection) = &self.selection {
            lines.extend(selection.lines());
        }
        lines.push(format!("noise: {}", c.noise));
        lines.extend(c.identifiability_notes());
        lines.extend(c.combination_lines.iter().cloned());
        lines.push(
            "identified (start -> identified, change from the start, standard error):".into(),
        );
        for u in c
            .unknowns
            .iter()
            .filter(|u| u.status == UnknownStatus::Identified)
        {
            let (unit, scale) = u.kind.display_unit();
            lines.push(format!(
                "  {:<28} {:>12.5} -> {:>12.5} {unit}, change {:>10.5} +- {:.5}",
                u.name,
                u.initial * scale,
                u.value * scale,
                (u.value - u.initial) * scale,
                u.standard_error.unwrap_or(f64::NAN) * scale
            ));
        }
        let table = |title: &str, before: &[TargetErrors], after: &[TargetErrors]| {
            let mut out = vec![format!(
                "{title}: position error per target, mean / max (mm), before -> after"
            )];
            for (b, a) in before.iter().zip(after) {
                out.push(format!(
                    "  {} on {} ({} poses): {:.4} / {:.4} -> {:.4} / {:.4}",
                    a.target,
                    a.frame,
                    a.statistics.n_poses,
                    b.statistics.position_mean * 1e3,
                    b.statistics.position_max * 1e3,
                    a.statistics.position_mean * 1e3,
                    a.statistics.position_max * 1e3
                ));
            }
            out
        };
        lines.extend(table(
            "identification",
            &c.per_target_before,
            &c.per_target_after,
        ));
        if let Some(split) = &self.split {
            lines.extend(split_check_text(split).lines().map(str::to_string));
        }
        if let Some(v) = &self.validation {
            lines.extend(table(
                "validation",
                &v.per_target_before,
                &v.per_target_after,
            ));
            lines.extend(extrapolation_line(&v.extrapolated_coordinates));
        }
        lines.extend(
            data_check_notes(
                &c.data_checks,
                self.validation.as_ref().map(|v| &v.data_checks),
            )
            .into_iter()
            .map(|note| format!("data check: {note}")),
        );
        if let Some(map) = &self.coverage {
            lines.push(coverage_line(map, "observations"));
        }
        if let Some(cross) = &self.cross {
            lines.extend(cross_check_text(cross).lines().map(str::to_string));
        }
        lines.extend(
            station_hold_out_text(&self.station_hold_out)
                .lines()
                .map(str::to_string),
        );
        lines
    }

    /// The run as a report page (write it with [`Report::to_html`]): the
    /// errors of each target before and after, the poses left out and the
    /// data checks, the model selection, every
    /// unknown, the validation observations against their predicted
    /// bounds, and the accuracy map with each target drawn where it is.
    pub(crate) fn target_html_report(&self, robot: &crate::kinematics::Model) -> Report {
        let c = &self.calibration;
        let model = if c.elastic.is_some() {
            "elasto-geometric"
        } else {
            "geometric"
        };
        let names: Vec<&str> = c.targets.iter().map(|t| t.name.as_str()).collect();
        calibration_page(
            robot,
            format!(
                "{model} model identified from {} poses of {} ({} observations of {} targets: {})",
                c.n_poses,
                self.data.source,
                c.n_observations,
                names.len(),
                names.join(", ")
            ),
            (
                self.target_errors_section(),
                data_checks_section(
                    &self.exclusions,
                    &c.data_checks,
                    self.validation.as_ref().map(|v| &v.data_checks),
                ),
            ),
            self.selection.as_ref(),
            unknowns_section(&c.unknowns, c.rank(), &c.solve),
            check_sections(
                self.split.as_ref(),
                self.cross.as_ref(),
                &self.station_hold_out,
            ),
            self.coverage.as_ref().map(|m| (m, "observations")),
            self.accuracy_map.as_ref(),
        )
    }

    /// Per-target errors before and after, and each observation's error
    /// after calibration pose by pose, one series per target.
    fn target_errors_section(&self) -> Section {
        let c = &self.calibration;
        let mut section = Section::new("Position errors");
        let mut rows = Vec::new();
        let mut push = |set: &str, before: &[TargetErrors], after: &[TargetErrors]| {
            for (b, a) in before.iter().zip(after) {
                rows.push(statistics_row(
                    &format!("{set}, {} on {}, nominal", b.target, b.frame),
                    &b.statistics,
                ));
                rows.push(statistics_row(
                    &format!("{set}, {} on {}, calibrated", a.target, a.frame),
                    &a.statistics,
                ));
            }
        };
        push("identification", &c.per_target_before, &c.per_target_after);
        if let Some(v) = &self.validation {
            push("validation", &v.per_target_before, &v.per_target_after);
        }
        statistics_table(
            &mut section,
            "Error of each target (position mm, orientation deg where measured), measurement frame fitted for the nominal robot",
            "set, target, robot",
            rows,
        );
        let (name, set, errors) = match (&self.validation, &self.validation_set) {
            (Some(v), Some(set)) => ("validation", set, &v.observation_errors),
            _ => ("identification", &self.data, &c.observation_errors),
        };
        // The pose of each observation by its label, in the set's order.
        let index: std::collections::HashMap<String, usize> = set
            .poses()
            .iter()
            .enumerate()
            .map(|(k, p)| (p.label(k), k + 1))
            .collect();
        let series: Vec<Series> = c
            .targets
            .iter()
            .map(|t| {
                let points = errors
                    .iter()
                    .filter(|e| e.target == t.name)
                    .filter_map(|e| Some((*index.get(&e.pose)? as f64, e.error.norm() * 1e3)))
                    .collect();
                Series::new(t.name.clone(), points)
            })
            .collect();
        section.figure(
            errors_chart(name, &series),
            format!(
                "Each target's position error with the calibrated robot at each {name} pose that sees it, in the order of the file."
            ),
        );
        section
    }

    /// The run as JSON: a `summary` in the units and counts of the
    /// one-target report ([`calib::TargetSummaryJson`]: mm, poses and
    /// observations apart), then the run's own types (SI units, as in the
    /// types).
    ///
    /// # Errors
    /// [`Error::Calib`] when serialisation fails.
    pub fn to_json_string(&self) -> Result<String> {
        serde_json::to_string_pretty(&self.json()).map_err(|e| {
            Error::Calib(calib::CalibError::Serialise {
                what: "multi-target calibration",
                message: e.to_string(),
            })
        })
    }

    /// What [`CalibrationRun::to_json_string`] writes, to be
    /// serialised (or flattened into a larger document).
    pub fn json(&self) -> TargetRunJson<'_> {
        let summary = calib::TargetSummaryJson::new(
            &self.calibration,
            self.validation
                .as_ref()
                .zip(self.validation_set.as_ref())
                .map(|(v, set)| (v, set.len())),
        );
        TargetRunJson { summary, run: self }
    }
}

/// The JSON document of a multi-target run: its `summary`, then the run.
#[derive(Debug, Serialize)]
pub struct TargetRunJson<'a> {
    /// Figures in the units and counts of the one-target report.
    pub summary: calib::TargetSummaryJson,
    /// The run itself (SI units).
    #[serde(flatten)]
    pub run: &'a CalibrationRun,
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use nalgebra::{Isometry3, Translation3};

    use super::*;
    use crate::calib::{CalibrationOptions, TargetObservation, TargetPose};
    use crate::kinematics::{Data, Model, RobotDescription, forward_frame_pose};

    fn calib_data(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../flexcal-calib/tests/data")
            .join(name)
    }

    /// The two-armed robot measured at its nominal geometry in its base
    /// frame, each hand's marker seen at 40 poses (and its orientation,
    /// `oriented`), written to `dir`; the run's configuration.
    fn two_arm_markers(dir: &std::path::Path, oriented: bool) -> (Model, CalibrationConfig) {
        let robot = RobotDescription::from_toml_file(&calib_data("two_arms.toml"))
            .unwrap()
            .build()
            .unwrap();
        let targets_file = calib_data("two_arms_targets.toml");
        let targets = calib::read_targets(&targets_file).unwrap();
        let mut data = Data::new(&robot);
        let xi = robot.nominal_params();
        let poses = (0..40)
            .map(|k| {
                let q: Vec<f64> = robot
                    .actuated_limits()
                    .iter()
                    .enumerate()
                    .map(|(i, &(lo, hi))| {
                        lo + ((k as f64 + 1.0) * (2.0f64 + i as f64).sqrt()).fract() * (hi - lo)
                    })
                    .collect();
                let observations = targets
                    .iter()
                    .map(|t| {
                        let point =
                            Isometry3::from_parts(Translation3::from(t.offset), Default::default());
                        let frame = robot.frame_index(&t.frame).unwrap();
                        let x =
                            forward_frame_pose(&robot, &mut data, &q, xi, frame, &point).unwrap();
                        Some(TargetObservation {
                            orientation: oriented.then(|| calib::vector_from_rotation(&x.rotation)),
                            ..TargetObservation::new(x.translation.vector)
                        })
                    })
                    .collect();
                TargetPose::new(None, q, observations)
            })
            .collect();
        let measurements = dir.join("markers.csv");
        MeasurementSet::from_poses("nominal", targets, poses)
            .unwrap()
            .write_csv(&measurements)
            .unwrap();
        let config = CalibrationConfig {
            targets: Some(targets_file),
            ..CalibrationConfig::new(&measurements, CalibrationOptions::for_model(&robot))
        };
        (robot, config)
    }

    /// Markers with orientations: their orientation errors are in the
    /// report's per-target figures (deg), in each observation's error and
    /// on the page.
    #[test]
    fn orientations_of_several_targets_appear_in_the_report_and_the_page() {
        let dir = tempfile::tempdir().unwrap();
        let (robot, config) = two_arm_markers(dir.path(), true);
        let run = crate::calibration::run_calibration(&robot, &config).unwrap();
        for target in &run.calibration.per_target_after {
            let (_, rms, _) = target.statistics.orientation_mean_rms_max.unwrap();
            assert!(rms < 1e-9, "{}: {rms:e} rad", target.target);
        }
        let outputs = CalibrationOutputs {
            residuals: Some(dir.path().join("residuals.csv")),
            accuracy_grid: None,
            description: None,
            report: Some(dir.path().join("report.json")),
            html: Some(dir.path().join("report.html")),
        };
        run.write_outputs(&robot, &outputs).unwrap();
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
                .unwrap();
        for entry in json["summary"]["identification"]["per_target"]
            .as_array()
            .unwrap()
        {
            assert!(
                entry["orientation_rms_deg"].as_f64().unwrap() < 1e-6,
                "{entry}"
            );
        }
        let csv = std::fs::read_to_string(dir.path().join("residuals.csv")).unwrap();
        assert!(
            csv.lines()
                .next()
                .unwrap()
                .ends_with(",orientation_error_deg"),
            "{csv}"
        );
        let page = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
        for expected in [
            "orientation mean (deg)",
            "target.left.rx",
            "target.right.rz",
        ] {
            assert!(page.contains(expected), "{expected} missing");
        }
    }

    /// The two-armed robot measured at its nominal geometry in its base
    /// frame: the run's text names the robot and the file, and its outputs
    /// are the description and the report (per-pose residuals refused).
    #[test]
    fn the_summary_names_the_file_and_the_outputs_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let (robot, config) = two_arm_markers(dir.path(), false);
        let measurements = config.data.clone();
        let run = crate::calibration::run_calibration(&robot, &config).unwrap();
        let text = run.summary_text(&robot);
        assert!(
            text.starts_with(&format!(
                "Calibrating `{}` ({} parameters) from {}\n40 poses, 80 observations of 2 targets",
                robot.name(),
                robot.n_params(),
                measurements.display()
            )),
            "{text}"
        );
        let outputs = CalibrationOutputs {
            residuals: None,
            accuracy_grid: None,
            description: Some(dir.path().join("calibrated.toml")),
            report: Some(dir.path().join("report.json")),
            html: None,
        };
        let written = run.write_outputs(&robot, &outputs).unwrap();
        assert_eq!(written.len(), 2, "{written:?}");
        assert!(dir.path().join("calibrated.toml").exists());
        // The report's summary counts poses and observations apart, in mm.
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
                .unwrap();
        let identification = &json["summary"]["identification"];
        assert_eq!(identification["n_poses"], 40, "{identification}");
        assert_eq!(identification["n_observations"], 80, "{identification}");
        let mean_mm = identification["position_mean_mm"].as_f64().unwrap();
        assert!(
            (mean_mm - run.calibration.training_after.position_mean * 1e3).abs() < 1e-12,
            "{identification}"
        );
        assert_eq!(identification["per_target"].as_array().unwrap().len(), 2);
        assert!(json["summary"]["noise"]["source"].is_string());
        // The error of every identification observation (no validation
        // set): a header and 80 rows.
        let residuals = CalibrationOutputs {
            residuals: Some(dir.path().join("residuals.csv")),
            ..outputs.clone()
        };
        let written = run.write_outputs(&robot, &residuals).unwrap();
        assert!(
            written[2].starts_with("error of every identification observation"),
            "{written:?}"
        );
        let csv = std::fs::read_to_string(dir.path().join("residuals.csv")).unwrap();
        assert_eq!(csv.lines().count(), 81, "{csv}");
        // The HTML page: each target's errors, every unknown, one series
        // per target in the chart.
        let html = CalibrationOutputs {
            html: Some(dir.path().join("report.html")),
            ..outputs
        };
        let written = run.write_outputs(&robot, &html).unwrap();
        assert!(
            written
                .iter()
                .any(|l| l.starts_with("HTML report written to")),
            "{written:?}"
        );
        let page = std::fs::read_to_string(dir.path().join("report.html")).unwrap();
        for expected in [
            "80 observations of 2 targets: left, right",
            "identification, left on LH, calibrated",
            "identification, right on RH, nominal",
            "Identified unknowns",
            "target.left.x",
            "<svg",
        ] {
            assert!(page.contains(expected), "{expected} missing");
        }
    }
}

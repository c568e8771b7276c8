//! The calibration run as a self-contained HTML page
//! (`flexcal calibrate --html FILE`): the errors before and after, the poses
//! left out and the data checks, the model selection, the split-half,
//! cross-series and station checks when asked for, every identified unknown, the measured errors of the
//! validation poses against their predicted 95 % bounds, and the predicted
//! accuracy over the workspace (the accuracy map) drawn where the target is.
//!
//! Everything on the page comes from the typed results of
//! [`CalibrationRun`]; nothing is computed here but the ordering of points.
//! Units: positions and errors in mm, unknowns in the display unit of their
//! kind ([`crate::calib::error_model::UnknownKind::display_unit`]).

use crate::calib::{
    AccuracyMap, CrossCheck, DataChecks, ErrorStatistics, SelectionReport, SplitCheck,
    StationHoldOut, UnknownEstimate,
};
use crate::kinematics::Model;
use crate::optim::SolveReport;
use crate::report::svg::{self, Series, YScale};
use crate::report::{Report, Section};

use super::text::{
    CROSS_CHECK_HEADER, SPLIT_CHECK_HEADER, STATION_HOLD_OUT_HEADER, cross_check_rows,
    data_check_notes, split_check_rows, station_hold_out_rows, status_word,
};
use super::{CalibrationRun, Exclusion};

impl CalibrationRun {
    /// The run as a report page (write it with [`Report::to_html`]).
    pub fn html_report(&self, robot: &Model) -> Report {
        if self.several_targets() {
            return self.target_html_report(robot);
        }
        let model = if self.options.gravity.is_some() {
            "elasto-geometric"
        } else {
            "geometric"
        };
        calibration_page(
            robot,
            format!(
                "{model} model identified from {} poses of {}",
                self.data.len(),
                self.data.source
            ),
            (
                self.errors_section(),
                data_checks_section(
                    &self.exclusions,
                    &self.calibration.data_checks,
                    self.validation.as_ref().map(|v| &v.data_checks),
                ),
            ),
            self.selection.as_ref(),
            unknowns_section(
                &self.calibration.unknowns,
                self.calibration.rank(),
                &self.calibration.solve,
            ),
            check_sections(
                self.split.as_ref(),
                self.cross.as_ref(),
                &self.station_hold_out,
            ),
            self.coverage.as_ref().map(|c| (c, "poses")),
            self.accuracy_map.as_ref(),
        )
    }

    fn errors_section(&self) -> Section {
        let mut section = Section::new("Position errors");
        let mut rows = vec![
            statistics_row("identification, nominal", &self.calibration.training_before),
            statistics_row(
                "identification, calibrated",
                &self.calibration.training_after,
            ),
        ];
        if self.calibration.station_errors.len() > 1 {
            for (s, errors) in self.calibration.station_errors.iter().enumerate() {
                rows.push(statistics_row(
                    &format!("identification, calibrated, station s{}", s + 1),
                    errors,
                ));
            }
        }
        if let Some(v) = &self.validation {
            rows.push(statistics_row("validation, nominal", &v.before));
            rows.push(statistics_row("validation, calibrated", &v.after));
        }
        statistics_table(
            &mut section,
            "Position error of the target (mm), measurement frame fitted for the nominal robot",
            "poses",
            rows,
        );
        let (name, _, errors) = self.per_pose();
        let points: Vec<(f64, f64)> = errors
            .iter()
            .enumerate()
            .map(|(k, e)| ((k + 1) as f64, e.position * 1e3))
            .collect();
        section.figure(
            errors_chart(name, &[Series::new("calibrated", points)]),
            format!(
                "Each {name} pose's position error with the calibrated robot, in the order of the file."
            ),
        );
        section
    }
}

/// The chart of the position errors after calibration of the `name` set's
/// poses (mm, against the pose's place in the file).
pub(crate) fn errors_chart(name: &str, series: &[Series]) -> String {
    svg::line_chart(
        &format!("Position error after calibration, {name} poses"),
        "pose (file order)",
        "error [mm]",
        series,
        YScale::Linear,
    )
}

/// The poses left out on request and the data checks of the identification
/// and validation sets, each finding with the option that leaves its poses
/// out; `None` when there is nothing to say.
pub(crate) fn data_checks_section(
    exclusions: &[Exclusion],
    identification: &DataChecks,
    validation: Option<&DataChecks>,
) -> Option<Section> {
    let notes = data_check_notes(identification, validation);
    if exclusions.is_empty() && notes.is_empty() {
        return None;
    }
    let mut section = Section::new("Data checks");
    for e in exclusions {
        section.paragraph(e.to_string());
    }
    for note in notes {
        section.paragraph(note);
    }
    Some(section)
}

/// The split-half check, the cross-series check and each station held
/// out, a section each, as far as the run has them: the tables and notes
/// the terminal prints.
pub(crate) fn check_sections(
    split: Option<&SplitCheck>,
    cross: Option<&CrossCheck>,
    held: &[StationHoldOut],
) -> Vec<Section> {
    let mut sections = Vec::new();
    if let Some(split) = split {
        let mut section = Section::new("Split-half check");
        section.table(
            "Each identified unknown again on odd / even and first / second halves of the poses, in its display unit; ratio: split error over standard error",
            &SPLIT_CHECK_HEADER,
            split_check_rows(split),
        );
        for note in split.notes() {
            section.paragraph(note);
        }
        sections.push(section);
    }
    if let Some(cross) = cross {
        let mut section = Section::new("Cross-series check");
        section.table(
            format!(
                "Each unknown identified again on the {} validation poses, in its display unit; z: the difference in combined standard errors (z split: each raised to its split error where larger)",
                cross.other_poses
            ),
            &CROSS_CHECK_HEADER,
            cross_check_rows(cross),
        );
        for note in cross.notes() {
            section.paragraph(note);
        }
        sections.push(section);
    }
    if !held.is_empty() {
        let mut section = Section::new("Each station held out");
        section.table(
            "Identified on the other stations (model selected on them), validated on the one held out with its measurement frame re-fitted; position errors in mm",
            &STATION_HOLD_OUT_HEADER,
            station_hold_out_rows(held),
        );
        sections.push(section);
    }
    sections
}

/// The page of a calibration run: its errors section, then the data checks,
/// the model selection, every unknown, the split-half, cross-series and
/// station checks (`checks`), the validation `entries` (`poses` or
/// `observations`) against their bounds and the accuracy map, as far as the
/// run has them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn calibration_page(
    robot: &Model,
    subtitle: String,
    (errors, data_checks): (Section, Option<Section>),
    selection: Option<&SelectionReport>,
    unknowns: Section,
    checks: Vec<Section>,
    coverage: Option<(&AccuracyMap, &str)>,
    map: Option<&AccuracyMap>,
) -> Report {
    let mut report = Report::new(format!("Calibration of {}", robot.name()), subtitle);
    report.push(errors);
    if let Some(section) = data_checks {
        report.push(section);
    }
    if let Some(selection) = selection {
        report.push(selection_section(selection));
    }
    report.push(unknowns);
    for section in checks {
        report.push(section);
    }
    if let Some((coverage, entries)) = coverage {
        report.push(coverage_section(coverage, entries));
    }
    if let Some(map) = map {
        report.push(map_section(map));
    }
    report
}

/// Every unknown: its start, identified value, standard error and status.
pub(crate) fn unknowns_section(
    unknowns: &[UnknownEstimate],
    rank: usize,
    solve: &SolveReport,
) -> Section {
    let mut section = Section::new("Identified unknowns");
    let rows = unknowns
        .iter()
        .map(|u| {
            let (unit, factor) = u.kind.display_unit();
            vec![
                u.name.clone(),
                unit.to_string(),
                format!("{:.6}", u.initial * factor),
                format!("{:.6}", u.value * factor),
                u.standard_error
                    .map_or(String::new(), |s| format!("{:.6}", s * factor)),
                status_word(u.status).to_string(),
            ]
        })
        .collect();
    section.paragraph(format!(
        "{} of {} unknowns identified; termination: {:?} after {} iterations.",
        rank,
        unknowns.len(),
        solve.termination,
        solve.iterations
    ));
    section.table(
        "Every unknown: starting and identified value, standard error",
        &[
            "unknown",
            "unit",
            "start",
            "identified",
            "std error",
            "status",
        ],
        rows,
    );
    section
}

/// A row of an errors table: count, mean, RMS and max (mm).
pub(crate) fn statistics_row(label: &str, s: &ErrorStatistics) -> Vec<String> {
    let mut row = vec![
        label.to_string(),
        s.n_poses.to_string(),
        format!("{:.4}", s.position_mean * 1e3),
        format!("{:.4}", s.position_rms * 1e3),
        format!("{:.4}", s.position_max * 1e3),
    ];
    if let Some((mean, rms, max)) = s.orientation_mean_rms_max {
        row.extend([mean, rms, max].map(|a| format!("{:.4}", a.to_degrees())));
    }
    row
}

/// A table of error statistics rows ([`statistics_row`]) under `caption`,
/// the first column headed `label`: position mean, RMS and maximum (mm),
/// and orientation ones (deg) when a row has them (`-` in the rows that
/// do not).
pub(crate) fn statistics_table(
    section: &mut Section,
    caption: &str,
    label: &str,
    mut rows: Vec<Vec<String>>,
) {
    let oriented = rows.iter().any(|r| r.len() > 5);
    let mut header = vec![label, "count", "mean", "RMS", "max"];
    if oriented {
        header.extend(["orientation mean (deg)", "RMS (deg)", "max (deg)"]);
        for row in &mut rows {
            row.resize(8, "-".to_string());
        }
    }
    section.table(caption, &header, rows);
}

/// The candidates of the model selection and the reasons of its steps.
fn selection_section(selection: &SelectionReport) -> Section {
    let mut section = Section::new("Model selection");
    let chosen = selection.chosen.clone();
    let rows = selection
        .candidates
        .iter()
        .map(|c| {
            let fmt = |v: Option<f64>, digits: usize| {
                v.map_or(String::new(), |v| format!("{v:.digits$}"))
            };
            vec![
                c.label(),
                fmt(c.cv_mean_error_mm, 4),
                fmt(c.cv_standard_error_mm, 4),
                fmt(c.extrapolation_mean_error_mm, 4),
                fmt(c.extrapolation_standard_error_mm, 4),
                fmt(c.bic, 1),
                format!("{:.0}", c.identified),
                match &c.failure {
                    Some(f) => format!("not scored: {f}"),
                    None if c.groups == chosen => "chosen".into(),
                    None => String::new(),
                },
            ]
        })
        .collect();
    section.table(
        "Candidates in the order of the search (held-out mean position error, mm)",
        &[
            "groups",
            "held-out mean",
            "std error",
            "extrapolating mean",
            "std error",
            "BIC",
            "identified",
            "",
        ],
        rows,
    );
    if !selection.chosen_on_reason.is_empty() {
        section.paragraph(format!(
            "Chosen on the {} scores: {}",
            selection.chosen_on.label(),
            selection.chosen_on_reason
        ));
    }
    for reason in &selection.reasons {
        section.paragraph(reason);
    }
    section
}

/// The measured errors of the validation `entries` (`poses`, or
/// `observations` with several targets) against their predicted bounds.
fn coverage_section(map: &AccuracyMap, entries: &str) -> Section {
    let mut section = Section::new(format!("Predicted accuracy on the validation {entries}"));
    let mut order: Vec<usize> = (0..map.poses.len()).collect();
    order.sort_by(|&a, &b| {
        map.poses[a]
            .bound_95_mm
            .total_cmp(&map.poses[b].bound_95_mm)
    });
    let bound = order
        .iter()
        .enumerate()
        .map(|(i, &k)| ((i + 1) as f64, map.poses[k].bound_95_mm))
        .collect();
    let actual = order
        .iter()
        .enumerate()
        .filter_map(|(i, &k)| map.poses[k].actual_error_mm.map(|e| ((i + 1) as f64, e)))
        .collect();
    section.figure(
        svg::line_chart(
            "Measured error against the predicted 95 % bound",
            &format!("validation {} (ordered by bound)", entries.trim_end_matches('s')),
            "position error [mm]",
            &[
                Series::new("measured", actual),
                Series::new("predicted 95 % bound", bound).dashed(),
            ],
            YScale::Linear,
        ),
        format!(
            "The measured errors lie within their bound at {:.1} % of the validation {entries} (95 % expected where the validation poses see what the training poses saw); mean bound {:.3} mm, training residual scatter {:.4} mm per axis.",
            100.0 * map.coverage.unwrap_or(f64::NAN),
            map.mean_bound_95_mm,
            map.residual_scatter_mm
        ),
    );
    section
}

/// The accuracy map drawn where each target is.
pub(crate) fn map_section(map: &AccuracyMap) -> Section {
    let mut section = Section::new("Accuracy map");
    let view = |a: usize, b: usize| -> Vec<(f64, f64, f64)> {
        map.poses
            .iter()
            .map(|p| (p.position_mm[a], p.position_mm[b], p.bound_95_mm))
            .collect()
    };
    let with_targets = map.poses.iter().any(|p| p.target.is_some());
    let entries = if with_targets {
        "configurations and targets"
    } else {
        "configurations"
    };
    section.paragraph(format!(
        "Predicted 95 % bound of the position error at {} {entries}: mean {:.3} mm, from {:.3} to {:.3} mm; training residual scatter {:.4} mm per axis{}{}.",
        map.poses.len(),
        map.mean_bound_95_mm,
        map.poses.iter().map(|p| p.bound_95_mm).fold(f64::INFINITY, f64::min),
        map.poses.iter().map(|p| p.bound_95_mm).fold(f64::NEG_INFINITY, f64::max),
        map.residual_scatter_mm,
        map.inflation_note()
            .map_or(String::new(), |note| format!("; {note}")),
        super::extrapolation_note(map)
    ));
    for (a, b, plane) in [(0, 1, "x-y"), (0, 2, "x-z")] {
        section.figure(
            svg::scatter_map(
                &format!("Predicted 95 % bound, {plane} plane of the robot base"),
                &format!("{} [mm]", ["x", "y", "z"][a]),
                &format!("{} [mm]", ["x", "y", "z"][b]),
                &view(a, b),
                "mm",
            ),
            format!(
                "Each {} drawn at the calibrated target position, projected on the {plane} plane, coloured by its predicted 95 % bound.",
                if with_targets {
                    "target at each configuration of the grid"
                } else {
                    "configuration of the grid"
                }
            ),
        );
    }
    section
}

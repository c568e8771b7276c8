//! The human-readable summary of a calibration run: the text `flexcal
//! calibrate` prints, one piece per result, so that a program embedding
//! flexcal shows its users the same tables.
//!
//! Units in the text: the unit column of each unknown (mm or deg from
//! [`crate::calib::error_model::UnknownKind::display_unit`]), position errors in mm,
//! orientation errors in deg, temperatures in deg C.

use std::fmt::Write as _;

use crate::calib::temperature::TemperatureCheck;
use crate::calib::{
    Calibration, CrossCheck, DataChecks, ErrorStatistics, MeasurementSet, PoseError, SplitCheck,
    UnknownStatus, ValidationReport,
};
use crate::kinematics::Model;

use super::CalibrationRun;

// Writing into a `String` cannot fail: the `fmt::Result`s below are `Ok`.
macro_rules! put {
    ($out:expr) => {
        let _ = writeln!($out);
    };
    ($out:expr, $($arg:tt)*) => {
        let _ = writeln!($out, $($arg)*);
    };
}

impl CalibrationRun {
    /// The summary of the run in the order of its steps (exclusions, model
    /// selection, identification, split-half check, errors before and
    /// after, predicted bounds, cross-series check, residual model,
    /// temperature): the text `flexcal calibrate` prints.
    pub fn summary_text(&self, robot: &Model) -> String {
        if self.several_targets() {
            return self.target_summary_text(robot);
        }
        let mut out = String::new();
        for e in &self.exclusions {
            put!(out, "{e}");
        }
        put!(
            out,
            "Calibrating `{}` ({} parameters{}) from {} poses of {}",
            robot.name(),
            robot.n_params(),
            if self.options.gravity.is_some() {
                ", elasto-geometric: joint compliances under gravity and the payload"
            } else {
                ""
            },
            self.data.len(),
            self.data.source
        );
        let c = &self.calibration;
        if c.station_names.len() > 1 {
            // What the `s2:` of the labels and the `frame_s2_*` unknowns mean.
            for (s, (name, errors)) in c.station_names.iter().zip(&c.station_errors).enumerate() {
                let [frame_x, ..] = crate::calib::station_frame_names(s);
                put!(
                    out,
                    "  station s{}: {name} ({} poses, measurement frame {}*)",
                    s + 1,
                    errors.n_poses,
                    frame_x.trim_end_matches('x')
                );
            }
        }
        if let Some(selection) = &self.selection {
            selection.lines().iter().for_each(|l| {
                put!(out, "{l}");
            });
        }
        out += &identification_text(&self.calibration);
        if let Some(split) = &self.split {
            out += &split_check_text(split);
        }
        out += &errors_text(&self.calibration, self.validation.as_ref());
        if let Some(map) = &self.coverage {
            put!(out, "{}", coverage_line(map, "poses"));
        }
        if let Some(cross) = &self.cross {
            out += &cross_check_text(cross);
        }
        out += &station_hold_out_text(&self.station_hold_out);
        if let Some(fit) = &self.residual {
            let r = &fit.model;
            put!(out);
            put!(
                out,
                "Fuzzy residual model over {} (fitted on the identification poses; not part of the robot model): {:?} rules for x, y, z; held-out RMS {:.4} / {:.4} / {:.4} mm",
                fit.inputs.join(", "),
                r.rule_counts(),
                r.reports[0].test.rmse * 1e3,
                r.reports[1].test.rmse * 1e3,
                r.reports[2].test.rmse * 1e3
            );
            if let Some(v) = &fit.validation {
                out += &statistics_row("validation, + residual", &v.after);
            }
        }
        let (name, set, errors) = self.per_pose();
        out += &temperature_text(name, set, &errors);
        out
    }
}

/// The word of an unknown's status in the identification table.
pub fn status_word(status: UnknownStatus) -> &'static str {
    match status {
        UnknownStatus::Identified => "identified",
        UnknownStatus::Fixed => "fixed",
        UnknownStatus::NonIdentifiable => "NON-IDENTIFIABLE",
        UnknownStatus::PoorlyIdentifiable => "poorly identifiable",
        UnknownStatus::NoInfluence => "no influence",
        UnknownStatus::AtBound => "held at bound",
    }
}

/// The identification: every unknown with its nominal and identified value,
/// standard error and status; rank and conditioning; what is not
/// identifiable and the combinations the identified values stand for; the
/// iteration history and the termination.
pub fn identification_text(c: &Calibration) -> String {
    let mut out = String::new();
    put!(out);
    put!(out, "Identifiability and identified values");
    put!(
        out,
        "{:<16} {:>9} {:>13} {:>14} {:>12} {:>12} {:>9}  status",
        "unknown",
        "unit",
        "nominal",
        "identified",
        "delta",
        "std error",
        "vs spread"
    );
    for u in &c.unknowns {
        let (unit, scale) = u.kind.display_unit();
        let se = u
            .standard_error
            .map(|s| format!("{:12.5}", s * scale))
            .unwrap_or_else(|| format!("{:>12}", "-"));
        let ratio = u
            .spread_ratio
            .map(|r| format!("{r:9.1}"))
            .unwrap_or_else(|| format!("{:>9}", "-"));
        put!(
            out,
            "{:<16} {unit:>9} {:>13.5} {:>14.5} {:>12.5} {se} {ratio}  {}",
            u.name,
            u.initial * scale,
            u.value * scale,
            (u.value - u.initial) * scale,
            status_word(u.status)
        );
    }
    put!(
        out,
        "rank {} of {} free unknowns; condition number {:.3e}",
        c.rank(),
        c.identifiability.names.len(),
        c.solve.condition_number
    );
    put!(out, "noise: {}", c.noise);
    let non = c.non_identifiable();
    if !non.is_empty() {
        put!(
            out,
            "not identifiable from these poses (kept at nominal): {}",
            non.join(", ")
        );
        put!(out, "the identified values stand for the combinations:");
        for combination in &c.combination_lines {
            put!(out, "  {combination}");
        }
    }
    let poor = c.poorly_identifiable();
    if !poor.is_empty() {
        put!(
            out,
            "poorly identifiable (standard error above the limit or, for a compliance, too large for its value; kept at its start): {}",
            poor.join(", ")
        );
    }
    for note in c.identifiability_notes() {
        put!(out, "note: {note}");
    }
    for line in c.coupling.iter().flat_map(|m| m.lines()) {
        put!(out, "{line}");
    }
    put!(out);
    put!(
        out,
        "Iteration history, every solve in order (cost 1/2 |W r|^2; RMS errors of the iterate)"
    );
    put!(
        out,
        "  {:>3}  {:>13}  {:>12}  {:>12}",
        "",
        "cost",
        "pos RMS mm",
        "rot RMS deg"
    );
    for (k, h) in c.residual_history.iter().enumerate() {
        let rotation = h
            .orientation_rms
            .map(|r| format!("{:12.5}", r.to_degrees()))
            .unwrap_or_default();
        put!(
            out,
            "  {k:3}  {:13.6e}  {:12.5}  {rotation}",
            h.cost,
            h.position_rms * 1e3
        );
    }
    put!(
        out,
        "termination: {:?} after {} iterations",
        c.solve.termination,
        c.solve.iterations
    );
    if c.solve.refused_trials > 0 {
        put!(
            out,
            "{} trial point(s) the model could not evaluate, refused as steps (last: {})",
            c.solve.refused_trials,
            c.solve.last_refusal.as_deref().unwrap_or("no reason given")
        );
    }
    out
}

/// One row of the errors table: `label`, poses, position mean / RMS / max
/// (mm), orientation mean / RMS / max (deg) when measured.
pub fn statistics_row(label: &str, s: &ErrorStatistics) -> String {
    let o = s
        .orientation_mean_rms_max
        .map(|(m, r, x)| {
            format!(
                "{:10.4} {:10.4} {:10.4}",
                m.to_degrees(),
                r.to_degrees(),
                x.to_degrees()
            )
        })
        .unwrap_or_default();
    format!(
        "{label:<24} {:5} {:10.4} {:10.4} {:10.4} {o}\n",
        s.n_poses,
        s.position_mean * 1e3,
        s.position_rms * 1e3,
        s.position_max * 1e3
    )
}

/// Whether temperature explains the remaining error of the `name` set: its
/// range and the correlation and slope of the position error against it
/// (empty when fewer than 3 poses carry a temperature).
pub fn temperature_text(name: &str, set: &MeasurementSet, errors: &[PoseError]) -> String {
    let Some(check) = TemperatureCheck::of(set, errors) else {
        return String::new();
    };
    let (lo, hi) = (check.min_c, check.max_c);
    match (check.correlation, check.slope_mm_per_k) {
        (Some(r), Some(slope)) => format!(
            "temperature on the {name} set: {lo:.2} to {hi:.2} C; correlation of the position error with it r = {r:.3} (r^2 = {:.3}), slope {slope:.4} mm/K\n",
            r * r
        ),
        _ => format!("temperature on the {name} set: constant {lo:.2} C; no analysis\n"),
    }
}

/// `v` with `digits` decimals, or `-` when there is none.
fn dash_or(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
}

/// Each station held out in turn: its errors before and with the robot
/// calibrated on the others (mm), and the groups chosen there; empty
/// without stations held out.
pub fn station_hold_out_text(held: &[crate::calib::StationHoldOut]) -> String {
    let mut out = String::new();
    if held.is_empty() {
        return out;
    }
    put!(out);
    put!(
        out,
        "Each station held out (identified on the others, model selected on them; validated on it with its measurement frame re-fitted):"
    );
    let h = STATION_HOLD_OUT_HEADER;
    put!(
        out,
        "{:<24} {:>5} {:>10} {:>10} {:>10} {:>10}  {}",
        h[0],
        h[1],
        h[2],
        h[3],
        h[4],
        h[5],
        h[6]
    );
    for r in station_hold_out_rows(held) {
        put!(
            out,
            "{:<24} {:>5} {:>10} {:>10} {:>10} {:>10}  {}",
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            r[5],
            r[6]
        );
    }
    out
}

/// The columns of [`station_hold_out_rows`].
pub(crate) const STATION_HOLD_OUT_HEADER: [&str; 7] = [
    "held out",
    "poses",
    "before mm",
    "mean mm",
    "rms mm",
    "max mm",
    "chosen",
];

/// One row per station held out: its name, poses, mean error with the
/// nominal robot and mean, RMS and maximum with the robot calibrated on
/// the others (mm, 4 decimals), and the groups chosen there.
pub(crate) fn station_hold_out_rows(held: &[crate::calib::StationHoldOut]) -> Vec<Vec<String>> {
    held.iter()
        .enumerate()
        .map(|(s, h)| {
            vec![
                format!("station s{}", s + 1),
                h.after.n_poses.to_string(),
                format!("{:.4}", h.before.position_mean * 1e3),
                format!("{:.4}", h.after.position_mean * 1e3),
                format!("{:.4}", h.after.position_rms * 1e3),
                format!("{:.4}", h.after.position_max * 1e3),
                h.chosen.as_ref().map_or("(no selection)".to_string(), |c| {
                    if c.is_empty() {
                        "base model".to_string()
                    } else {
                        c.join(" + ")
                    }
                }),
            ]
        })
        .collect()
}

/// `predicted 95 % bounds (mean ... mm) cover ... % of the validation
/// <entries>`: the share of a validation set's measured errors within their
/// predicted bounds (`entries`: `poses`, or `observations` with several
/// targets).
pub fn coverage_line(map: &crate::calib::AccuracyMap, entries: &str) -> String {
    format!(
        "predicted 95 % bounds (mean {:.3} mm{}{}) cover {:.1} % of the validation {entries}",
        map.mean_bound_95_mm,
        map.inflation_note()
            .map_or(String::new(), |note| format!(", {note}")),
        if map.extrapolation.is_some() {
            ", the model's growth outside the training ranges included"
        } else {
            ""
        },
        100.0 * map.coverage.unwrap_or(f64::NAN)
    )
}

/// The split-half check: each unknown identified again on odd / even and
/// first / second halves of the poses, against its standard error.
pub fn split_check_text(split: &SplitCheck) -> String {
    let mut out = String::new();
    put!(out);
    put!(
        out,
        "Split-half check (identified again on odd / even and first / second halves)"
    );
    let rows = std::iter::once(SPLIT_CHECK_HEADER.map(str::to_string).to_vec())
        .chain(split_check_rows(split));
    for r in rows {
        put!(
            out,
            "{:<16} {:>9} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12} {:>7}",
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            r[5],
            r[6],
            r[7],
            r[8]
        );
    }
    for note in split.notes() {
        put!(out, "note: {note}");
    }
    out
}

/// The columns of [`split_check_rows`].
pub(crate) const SPLIT_CHECK_HEADER: [&str; 9] = [
    "unknown",
    "unit",
    "std error",
    "odd",
    "even",
    "first",
    "second",
    "split err",
    "ratio",
];

/// One row per unknown of the split-half check: name, display unit,
/// standard error, the four half values, the split error (5 decimals) and
/// its ratio to the standard error (1 decimal), `-` where there is none.
pub(crate) fn split_check_rows(split: &SplitCheck) -> Vec<Vec<String>> {
    split
        .unknowns
        .iter()
        .map(|u| {
            let mut row = vec![
                u.name.clone(),
                u.unit.to_string(),
                format!("{:.5}", u.standard_error),
            ];
            row.extend(u.half_values.iter().map(|v| dash_or(*v, 5)));
            row.push(dash_or(u.split_error, 5));
            row.push(dash_or(u.ratio, 1));
            row
        })
        .collect()
}

/// The columns of [`cross_check_rows`].
pub(crate) const CROSS_CHECK_HEADER: [&str; 8] = [
    "unknown",
    "unit",
    "identified",
    "std error",
    "validation set",
    "std error",
    "z",
    "z split",
];

/// One row per unknown of the cross-series check: name, display unit,
/// value and standard error on each set (5 decimals), z and z with the
/// split errors (1 decimal), `-` where there is none.
pub(crate) fn cross_check_rows(cross: &CrossCheck) -> Vec<Vec<String>> {
    cross
        .unknowns
        .iter()
        .map(|u| {
            vec![
                u.name.clone(),
                u.unit.to_string(),
                format!("{:.5}", u.value),
                format!("{:.5}", u.standard_error),
                dash_or(u.other_value, 5),
                dash_or(u.other_standard_error, 5),
                dash_or(u.z, 1),
                dash_or(u.z_split, 1),
            ]
        })
        .collect()
}

/// The cross-series check: each unknown identified again on the validation
/// set, compared in combined standard errors (z).
pub fn cross_check_text(cross: &CrossCheck) -> String {
    let mut out = String::new();
    put!(out);
    put!(
        out,
        "Cross-series check (identified again on the {} validation poses{})",
        cross.other_poses,
        if cross.unknowns.iter().any(|u| u.z_split.is_some()) {
            "; z split: each standard error raised to its split error where larger"
        } else {
            ""
        }
    );
    let rows = std::iter::once(CROSS_CHECK_HEADER.map(str::to_string).to_vec())
        .chain(cross_check_rows(cross));
    for r in rows {
        put!(
            out,
            "{:<18} {:>9} {:>14} {:>12} {:>14} {:>12} {:>7} {:>8}",
            r[0],
            r[1],
            r[2],
            r[3],
            r[4],
            r[5],
            r[6],
            r[7]
        );
    }
    for note in cross.notes() {
        put!(out, "note: {note}");
    }
    out
}

/// The sentence naming the coordinates at which validation poses leave the
/// identification poses' range, with the share of the poses that do
/// (`None` when none does).
pub(crate) fn extrapolation_line(extrapolated: &[(String, f64)]) -> Option<String> {
    if extrapolated.is_empty() {
        return None;
    }
    let list: Vec<String> = extrapolated
        .iter()
        .map(|(name, f)| {
            // A share that rounds to 0 % is still some poses.
            if *f < 0.005 {
                format!("{name} (under 1 % of the poses)")
            } else {
                format!("{name} ({:.0} % of the poses)", f * 100.0)
            }
        })
        .collect();
    Some(format!(
        "validation poses outside the identification poses' range of: {}",
        list.join(", ")
    ))
}

/// The data checks of the identification set and, with a validation, of
/// the validation set: for each, its findings in sentences and the option
/// that leaves its suspect poses out.
pub(crate) fn data_check_notes(
    identification: &DataChecks,
    validation: Option<&DataChecks>,
) -> Vec<String> {
    std::iter::once(("identification", "--exclude", identification))
        .chain(validation.map(|checks| ("validation", "--exclude-validation", checks)))
        .flat_map(|(what, option, checks)| {
            let hint = checks.exclude_hint(option);
            checks.notes(what).into_iter().chain(hint)
        })
        .collect()
}

/// The errors before and after calibration on the identification set and,
/// with a validation, on the validation set; the validation's frame note
/// and extrapolated coordinates; the data checks and the option that
/// leaves the suspect poses out.
pub fn errors_text(c: &Calibration, validation: Option<&ValidationReport>) -> String {
    let mut out = String::new();
    put!(out);
    put!(
        out,
        "{:<24} {:>5} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "errors",
        "poses",
        "mean mm",
        "rms mm",
        "max mm",
        "mean deg",
        "rms deg",
        "max deg"
    );
    out += &statistics_row("identification before", &c.training_before);
    out += &statistics_row("identification after", &c.training_after);
    if c.station_errors.len() > 1 {
        for (s, errors) in c.station_errors.iter().enumerate() {
            out += &statistics_row(&format!("  station s{}", s + 1), errors);
        }
    }
    if let Some(v) = validation {
        out += &statistics_row("validation before", &v.before);
        out += &statistics_row("validation after", &v.after);
        put!(out, "validation: {}", v.frame_note);
        if let Some(line) = extrapolation_line(&v.extrapolated_coordinates) {
            put!(out, "{line}");
        }
    }
    for note in data_check_notes(&c.data_checks, validation.map(|v| &v.data_checks)) {
        put!(out, "data check: {note}");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_status_has_its_own_word() {
        let words = [
            UnknownStatus::Identified,
            UnknownStatus::Fixed,
            UnknownStatus::NonIdentifiable,
            UnknownStatus::PoorlyIdentifiable,
            UnknownStatus::NoInfluence,
            UnknownStatus::AtBound,
        ]
        .map(status_word);
        let distinct: std::collections::BTreeSet<_> = words.iter().collect();
        assert_eq!(distinct.len(), words.len());
    }

    #[test]
    fn missing_values_print_as_a_dash() {
        assert_eq!(dash_or(None, 5), "-");
        assert_eq!(dash_or(Some(1.234_567), 2), "1.23");
    }

    #[test]
    fn a_statistics_row_is_one_line_in_mm() {
        let s = ErrorStatistics {
            n_poses: 3,
            position_mean: 1e-3,
            position_rms: 2e-3,
            position_max: 3e-3,
            orientation_mean_rms_max: None,
        };
        let row = statistics_row("identification after", &s);
        assert_eq!(row.lines().count(), 1);
        assert!(row.ends_with('\n'));
        let fields: Vec<&str> = row.split_whitespace().collect();
        assert_eq!(&fields[2..], ["3", "1.0000", "2.0000", "3.0000"]);
    }
}

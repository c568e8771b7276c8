//! Cross-series table on the IPA UR10 data (the dataset README's baseline
//! protocol): calibrate on one series, validate on another, re-fitting only
//! the tracker -> base transform on the validation series; geometric and
//! elasto-geometric (joint compliances under gravity) models side by side.
//!
//! Printed again without each series' suspect poses (its own fit's data
//! checks), with the probe's measured orientations in the fits, and with
//! both.
//!
//! Last, the acceptance table of model selection (positions only, all
//! poses: the dataset's protocol): the elasto-geometric model whose groups
//! of unknowns cross-validation chose on the training series alone, against
//! the full geometric model and the dataset README's `dh` and `dh+g`; the
//! share of validation poses within the predicted 95 % bounds, inside and
//! outside the training ranges of joints 2 and 3; the validation error by
//! the side of the shoulder's gravity torque (on stderr); and the joint
//! compliances each series identifies with the non-linear joint law.
//! `ipa_table selected` prints that part only; `ipa_table selected lateral`
//! prints it with the lateral joint compliances allowed in the richest model
//! (`GravityCompliance::lateral`, one more group for the selection).
//!
//! The compliance table ends with the three series pooled as three
//! stations.
//!
//! Then two series pooled as two stations (one measurement frame each,
//! `MeasurementSet::pooled`) and validated on the third, by the same
//! protocol and selection; `ipa_table pooled` prints that part only.
//!
//! `cargo run --release -p flexcal-calib --example ipa_table`

use std::path::PathBuf;
use std::time::Instant;

use flexcal_calib::{
    Calibration, CalibrationOptions, CoordinateCoverage, ErrorStatistics, GravityCompliance,
    JointLaw, MeasurementSet, SelectOn, SelectionOptions, SplitCheck, UnknownStatus, Weighting,
    calibrate, calibrate_selected,
};
use flexcal_kinematics::Model;
use flexcal_kinematics::RobotDescription;

fn cell(s: &ErrorStatistics) -> String {
    format!(
        "{:.3} / {:.3} / {:.2}",
        s.position_mean * 1e3,
        s.position_rms * 1e3,
        s.position_max * 1e3
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets/ipa-ur10");
    if !root.exists() {
        println!("IPA UR10 data absent ({}): nothing to do", root.display());
        return Ok(());
    }
    let files = [
        ("B", "Series_B/measurements_joint_configurations.csv"),
        ("C", "Series_C/measurements_random_poses.csv"),
        ("D", "Series_D/measurements_iso_cubes.csv"),
    ];
    let model = RobotDescription::builtin("ur10")?.build()?;
    let sets: Vec<(&str, MeasurementSet)> = files
        .iter()
        .map(|(name, file)| Ok((*name, MeasurementSet::read_ipa(&root.join(file))?)))
        .collect::<Result<_, flexcal_calib::CalibError>>()?;
    let mut geometric = CalibrationOptions::for_model(&model);
    geometric.use_orientation = Some(false);
    geometric.weighting = Weighting::Uniform;
    let mut elastic = geometric.clone();
    elastic.gravity = Some(GravityCompliance::ur10_urdf(&model)?);
    if std::env::args().skip(2).any(|a| a == "equilibrium") {
        equilibrium_on(&model, &sets, &mut elastic)?;
    }
    let part = std::env::args().nth(1);
    if part.as_deref() == Some("pooled") {
        return pooled_table(&Study::new(&model, &sets, &geometric, &elastic));
    }
    let selected_only = part.as_deref() == Some("selected");
    if std::env::args().nth(2).as_deref() == Some("lateral") {
        if let Some(gravity) = elastic.gravity.as_mut() {
            gravity.lateral = flexcal_calib::LateralCompliance::AboutX;
        }
        println!("(lateral joint compliances allowed in the richest model)");
    }
    if !selected_only {
        earlier_tables(&model, &sets, geometric.clone(), elastic.clone())?;
    }
    let study = Study::new(&model, &sets, &geometric, &elastic);
    selected_table(&study)?;
    if !selected_only {
        pooled_table(&study)?;
    }
    Ok(())
}

/// `ipa_table <part> equilibrium`: the tables with the deflection as the
/// static equilibrium instead of the one step, after what the equilibrium
/// changes on each series' elasto-geometric fit (its deflection report).
fn equilibrium_on(
    model: &Model,
    sets: &[(&str, MeasurementSet)],
    elastic: &mut CalibrationOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    if let Some(gravity) = elastic.gravity.as_mut() {
        gravity.deflection = flexcal_calib::Deflection::equilibrium();
    }
    println!("(the deflection as the static equilibrium)");
    for (name, set) in sets {
        let fitted = calibrate(model, set, elastic)?;
        if let Some(r) = &fitted.deflection {
            println!(
                "series {name}: largest one-step torque change {:.3} N.m on {} ({:.2} % of its span); one step against equilibrium {:.4} mm RMS, {:.4} mm max",
                r.largest_torque_change_nm,
                r.largest_torque_change_joint,
                100.0 * r.largest_torque_change_share,
                r.position_difference_rms_mm,
                r.position_difference_max_mm
            );
        }
    }
    Ok(())
}

/// What the selected and pooled tables share: the robot, the series and
/// the options of the models compared.
struct Study<'a> {
    model: &'a Model,
    sets: &'a [(&'a str, MeasurementSet)],
    geometric: &'a CalibrationOptions,
    elastic: &'a CalibrationOptions,
    /// The richest model the selection starts from: the compliances of
    /// `elastic` and the non-linear joint law (the selection adds the
    /// cyclic errors as a group of their own).
    richest: CalibrationOptions,
}

impl<'a> Study<'a> {
    fn new(
        model: &'a Model,
        sets: &'a [(&'a str, MeasurementSet)],
        geometric: &'a CalibrationOptions,
        elastic: &'a CalibrationOptions,
    ) -> Self {
        let mut richest = elastic.clone();
        richest.joint_terms.law = Some(JointLaw::default());
        Self {
            model,
            sets,
            geometric,
            elastic,
            richest,
        }
    }

    /// The series named `name` (B, C or D).
    fn set(&self, name: &str) -> &'a MeasurementSet {
        &self
            .sets
            .iter()
            .find(|(n, _)| *n == name)
            .expect("series")
            .1
    }
}

/// Two series pooled as two stations, validated on the third (positions
/// only, all poses, the model selected by cross-validation on the pooled
/// poses): what a campaign measured from two tracker placements gives.
fn pooled_table(study: &Study) -> Result<(), Box<dyn std::error::Error>> {
    let Study {
        model,
        geometric,
        richest,
        ..
    } = study;
    let set = |name: &str| study.set(name);
    println!(
        "\nTwo series pooled as two stations (one measurement frame each), validated on the third (positions only, all poses):"
    );
    println!(
        "| stations -> validate | geometric | elasto-geometric, selected | within 95 % bound | chosen | compliance_theta2 (urad/N.m) |\n|---|---|---|---|---|---|"
    );
    for (a, b, v) in [("B", "C", "D"), ("B", "D", "C"), ("C", "D", "B")] {
        let pooled = MeasurementSet::pooled(&[set(a).clone(), set(b).clone()])?;
        let validate = set(v);
        let start = Instant::now();
        let (selected, report, chosen) =
            calibrate_selected(model, &pooled, richest, &SelectionOptions::default())?;
        eprintln!(
            "{a} + {b}: selection and identification {:.2} s",
            start.elapsed().as_secs_f64()
        );
        let g = calibrate(model, &pooled, geometric)?;
        let split = SplitCheck::new(model, &pooled, &chosen, &selected)?;
        let g_report = g.validate(model, validate, false)?;
        let s_report = selected.validate(model, validate, false)?;
        let map = selected.accuracy_coverage_of(model, validate, &s_report, Some(&split))?;
        let label = chosen_label(report.as_ref());
        let compliance = estimate_cell(&selected, &split, "compliance_theta2", 1e6);
        println!(
            "| {a} + {b} -> {v} | {} | {} | {} | {label} | {compliance} |",
            mean_max(&g_report.after),
            mean_max(&s_report.after),
            bound_cell(&map),
        );
    }
    Ok(())
}

/// The dataset README's baselines (`baseline.py`), validation mean / max
/// (mm): `dh` and `dh+g`, for B -> C, B -> D, C -> B, C -> D.
const BASELINES: [(&str, &str, [f64; 4]); 4] = [
    ("B", "C", [0.570, 1.91, 0.512, 1.59]),
    ("B", "D", [0.499, 1.22, 0.711, 1.83]),
    ("C", "B", [0.842, 2.09, 0.478, 2.13]),
    ("C", "D", [0.704, 2.21, 0.605, 1.65]),
];

/// Model selection on the training series, positions only, all poses.
fn selected_table(study: &Study) -> Result<(), Box<dyn std::error::Error>> {
    let Study {
        model,
        geometric,
        elastic,
        richest,
        ..
    } = study;
    let set = |name: &str| study.set(name);
    let selection = SelectionOptions::default();
    println!(
        "\nModel selection by cross-validation on the training series (positions only, all poses):"
    );
    println!(
        "| pair | geometric | elasto-geometric, selected | dh | dh+g | within 95 % bound, extrapolation included | without it | chosen |\n|---|---|---|---|---|---|---|---|"
    );
    // Rows of the second table: the model chosen on the extrapolating folds
    // beside the one chosen on the ordinary folds.
    let mut extrapolation_rows = Vec::new();
    for train_name in ["B", "C"] {
        let train = set(train_name);
        let mut every_term = richest.clone();
        every_term.joint_terms.cyclic = true;
        let start = Instant::now();
        let every = calibrate(model, train, &every_term)?;
        eprintln!(
            "{train_name}: identification with the law and cyclic errors {:.3} s ({} iterations in all, {:?})",
            start.elapsed().as_secs_f64(),
            every.cost_history.len(),
            every.solve.termination
        );
        if std::env::var_os("FLEXCAL_TIMING_ONLY").is_some() {
            continue;
        }
        let start = Instant::now();
        let (selected, report, chosen) = calibrate_selected(model, train, richest, &selection)?;
        eprintln!(
            "{train_name}: selection and identification {:.2} s",
            start.elapsed().as_secs_f64()
        );
        if let Some(report) = &report {
            for line in report.lines() {
                eprintln!("{line}");
            }
        }
        print_lateral(train_name, &selected);
        let on_extrapolation = SelectionOptions {
            select_on: SelectOn::Extrapolation,
            ..selection.clone()
        };
        let start = Instant::now();
        let (extrapolated, x_report, _) =
            calibrate_selected(model, train, richest, &on_extrapolation)?;
        eprintln!(
            "{train_name}: selection on the extrapolating folds and identification {:.2} s",
            start.elapsed().as_secs_f64()
        );
        if let Some(report) = &x_report {
            for line in report.lines() {
                eprintln!("{line}");
            }
        }
        let x_label = chosen_label(x_report.as_ref());
        let g = calibrate(model, train, geometric)?;
        let split = SplitCheck::new(model, train, &chosen, &selected)?;
        let start = Instant::now();
        let extrapolation = selected.extrapolation(model, train, &chosen)?;
        eprintln!(
            "{train_name}: held-out-range folds {:.2} s",
            start.elapsed().as_secs_f64()
        );
        for fold in &extrapolation.folds {
            eprintln!("{train_name}: fold {fold:?}");
        }
        for note in extrapolation.notes() {
            eprintln!("{train_name}: {note}");
        }
        let label = chosen_label(report.as_ref());
        for (t, v, [dh, dh_max, dhg, dhg_max]) in BASELINES {
            if t != train_name {
                continue;
            }
            let validate = set(v);
            let g_report = g.validate(model, validate, false)?;
            let s_report = selected.validate(model, validate, false)?;
            let map = selected.accuracy_coverage_of(model, validate, &s_report, Some(&split))?;
            let plain = selected.accuracy_coverage_of(model, validate, &s_report, None)?;
            let beyond = map.clone().with_extrapolation(&extrapolation);
            let x_errors = extrapolated.validate(model, validate, false)?;
            // `calibrate --validate` (select-on auto) chooses on the
            // extrapolating folds when the validation poses leave the
            // training range: the validation report's own check.
            let auto = if s_report.extrapolated_coordinates.is_empty() {
                "interpolation"
            } else {
                "extrapolation"
            };
            extrapolation_rows.push(format!(
                "| {t} -> {v} | {} | {} | {auto} | {label} | {x_label} |",
                mean_max(&s_report.after),
                mean_max(&x_errors.after)
            ));
            println!(
                "| {t} -> {v} | {} | {} | {dh:.3} / {dh_max:.2} | {dhg:.3} / {dhg_max:.2} | {}; {} | {}; {:.1} % / {:.2} mm without | {label} |",
                mean_max(&g_report.after),
                mean_max(&s_report.after),
                bound_cell(&beyond),
                extrapolation_share(&beyond),
                bound_cell(&map),
                100.0 * plain.coverage.unwrap_or(f64::NAN),
                plain.mean_bound_95_mm
            );
            // Coverage inside and outside the training poses' ranges of the
            // shoulder and elbow (the joints that carry the arm's weight).
            let ranges = CoordinateCoverage::of_actuated(model, train);
            let mut counts = [[0usize; 2]; 2];
            for p in &beyond.poses {
                let outside = p.q[1..3]
                    .iter()
                    .zip(&ranges[1..3])
                    .any(|(q, range)| !range.contains(*q, 0.0));
                let within = p.actual_error_mm.is_some_and(|e| e <= p.bound_95_mm);
                counts[usize::from(outside)][usize::from(within)] += 1;
            }
            let share = |c: [usize; 2]| 100.0 * c[1] as f64 / (c[0] + c[1]).max(1) as f64;
            eprintln!(
                "{t} -> {v}: within the bound (extrapolation included) {:.1} % of the {} poses inside the training ranges of joints 2 and 3, {:.1} % of the {} outside",
                share(counts[0]),
                counts[0][0] + counts[0][1],
                share(counts[1]),
                counts[1][0] + counts[1][1]
            );
            // Validation error by the side of the shoulder's (joint 2's)
            // gravity torque: a joint behaving differently under the two
            // signs (lost motion, stiffness by direction) would show here.
            if let Some(gravity) = &elastic.gravity {
                let shoulder = |s: &MeasurementSet| -> Result<Vec<f64>, flexcal_calib::CalibError> {
                    Ok(gravity
                        .joint_torques(model, s)?
                        .iter()
                        .map(|t| t[1])
                        .collect())
                };
                let trained = shoulder(train)?;
                let span = CoordinateCoverage::of(trained.iter().copied(), None);
                let (lo, hi) = (span.lo, span.hi);
                let positive = trained.iter().filter(|t| **t >= 0.0).count();
                let mut sides = [(0usize, 0.0f64); 2];
                for (tau, e) in shoulder(validate)?.iter().zip(&s_report.after_per_pose) {
                    let side = &mut sides[usize::from(*tau >= 0.0)];
                    side.0 += 1;
                    side.1 += e.position;
                }
                let mean = |(n, sum): (usize, f64)| 1e3 * sum / n.max(1) as f64;
                eprintln!(
                    "{t} -> {v}: joint-2 gravity torque {lo:.1} to {hi:.1} N.m in {t}, >= 0 at {:.1} % of its poses; validation mean {:.3} mm over the {} poses of {v} with torque < 0, {:.3} mm over the {} with torque >= 0",
                    100.0 * positive as f64 / trained.len() as f64,
                    mean(sides[0]),
                    sides[0].0,
                    mean(sides[1]),
                    sides[1].0
                );
            }
        }
    }
    println!(
        "\nChosen on the ordinary (interpolating) folds and on the extrapolating folds (validation mean / max, mm; `auto`: what `calibrate --validate` chooses on):"
    );
    println!(
        "| pair | chosen on interpolation | chosen on extrapolation | auto | chosen (interpolation) | chosen (extrapolation) |\n|---|---|---|---|---|---|"
    );
    for row in &extrapolation_rows {
        println!("{row}");
    }
    println!(
        "\nJoint compliances (urad/N.m) +/- standard error / split error, per series; linear springs, then the non-linear law:"
    );
    println!(
        "| series | model | compliance_theta2 | compliance_theta3 | hardening_theta2 (1/mrad) | lost_motion_theta2 (mrad) |\n|---|---|---|---|---|---|"
    );
    // Each series, then the three together as three stations: the shoulder
    // loaded from both sides over the whole span of its torque.
    let all = MeasurementSet::pooled(&[set("B").clone(), set("C").clone(), set("D").clone()])?;
    for (name, data) in [
        ("B", set("B")),
        ("C", set("C")),
        ("D", set("D")),
        ("B + C + D", &all),
    ] {
        for (label, options) in [("linear", *elastic), ("law", richest)] {
            let mut options = options.clone();
            options.joint_terms.cyclic = false;
            let c = calibrate(model, data, &options)?;
            print_lateral(&format!("{name} ({label})"), &c);
            let split = SplitCheck::new(model, data, &options, &c)?;
            let cell = |unknown: &str, scale: f64| estimate_cell(&c, &split, unknown, scale);
            println!(
                "| {name} | {label} | {} | {} | {} | {} |",
                cell("compliance_theta2", 1e6),
                cell("compliance_theta3", 1e6),
                cell("hardening_theta2", 1e-3),
                cell("lost_motion_theta2", 1e3)
            );
        }
    }
    Ok(())
}

/// Mean / max position error (mm).
fn mean_max(s: &ErrorStatistics) -> String {
    format!("{:.3} / {:.2}", s.position_mean * 1e3, s.position_max * 1e3)
}

/// The share of poses within their predicted 95 % bound, the mean bound
/// and the split-half inflation.
fn bound_cell(map: &flexcal_calib::AccuracyMap) -> String {
    format!(
        "{:.1} % (mean bound {:.2} mm, x{:.2})",
        100.0 * map.coverage.unwrap_or(f64::NAN),
        map.mean_bound_95_mm,
        map.inflation
    )
}

/// The share of the poses whose bound is dominated by its extrapolation
/// part, and the largest such part.
fn extrapolation_share(map: &flexcal_calib::AccuracyMap) -> String {
    let dominated = map
        .poses
        .iter()
        .filter(|p| p.parts.dominant() == "extrapolation")
        .count();
    let largest = map
        .poses
        .iter()
        .map(|p| p.parts.extrapolation_mm)
        .fold(0.0, f64::max);
    format!(
        "extrapolation dominates {:.1} % of the bounds (largest part {largest:.2} mm)",
        100.0 * dominated as f64 / map.poses.len().max(1) as f64
    )
}

/// The groups of unknowns a selection chose, as the report names them.
fn chosen_label(report: Option<&flexcal_calib::SelectionReport>) -> String {
    report.map_or(String::new(), |r| {
        r.chosen
            .iter()
            .map(|g| g.label())
            .collect::<Vec<_>>()
            .join(" + ")
    })
}

/// `value +/- standard error / split error` of `unknown` in `calibration`
/// (SI times `scale`), or its value and status when it is not identified.
fn estimate_cell(
    calibration: &Calibration,
    split: &SplitCheck,
    unknown: &str,
    scale: f64,
) -> String {
    let Some(u) = calibration.unknowns.iter().find(|u| u.name == unknown) else {
        return "-".to_string();
    };
    if u.status != UnknownStatus::Identified {
        return format!("{:.2} ({:?})", u.value * scale, u.status);
    }
    let split_error = split
        .unknowns
        .iter()
        .find(|s| s.name == unknown)
        .and_then(|s| s.split_error)
        .map_or("-".into(), |e| format!("{e:.2}"));
    format!(
        "{:.2} +/- {:.2} / {split_error}",
        u.value * scale,
        u.standard_error.unwrap_or(f64::NAN) * scale
    )
}

/// Prints the lateral compliances of `calibration` (urad/N.m) to stderr,
/// each line starting with `label`.
fn print_lateral(label: &str, calibration: &Calibration) {
    for u in calibration
        .unknowns
        .iter()
        .filter(|u| u.name.starts_with("lateral_compliance_"))
    {
        eprintln!(
            "{label}: {} = {:.2} urad/N.m +/- {} ({:?})",
            u.name,
            u.value * 1e6,
            u.standard_error
                .map_or("-".into(), |e| format!("{:.2}", e * 1e6)),
            u.status
        );
    }
}

/// The tables of the geometric and linear elasto-geometric models.
fn earlier_tables(
    model: &Model,
    sets: &[(&str, MeasurementSet)],
    geometric: CalibrationOptions,
    elastic: CalibrationOptions,
) -> Result<(), Box<dyn std::error::Error>> {
    let sets = sets.to_vec();
    // One table row: nominal, geometric and elasto-geometric on `validate`.
    let row = |train_name: &str,
               validate_name: &str,
               g: &Calibration,
               e: &Calibration,
               validate: &MeasurementSet|
     -> Result<(), flexcal_calib::CalibError> {
        let g_report = g.validate(model, validate, false)?;
        let e_report = e.validate(model, validate, false)?;
        println!(
            "| {train_name} -> {validate_name} | {} | {} | {} |",
            cell(&g_report.before),
            cell(&g_report.after),
            cell(&e_report.after)
        );
        Ok(())
    };
    println!("| train -> validate | nominal | geometric | elasto-geometric |\n|---|---|---|---|");
    let mut faults = Vec::new();
    for (train_name, train) in &sets {
        let start = Instant::now();
        let g = calibrate(model, train, &geometric)?;
        let middle = Instant::now();
        let e = calibrate(model, train, &elastic)?;
        let end = Instant::now();
        for (validate_name, validate) in &sets {
            if validate_name == train_name {
                continue;
            }
            row(train_name, validate_name, &g, &e, validate)?;
        }
        eprintln!(
            "trained on {train_name}: geometric {:.3} mm mean on the training set ({:.1} ms), elasto-geometric {:.3} mm ({:.1} ms)",
            g.training_after.position_mean * 1e3,
            (middle - start).as_secs_f64() * 1e3,
            e.training_after.position_mean * 1e3,
            (end - middle).as_secs_f64() * 1e3
        );
        for note in e
            .identifiability_notes()
            .into_iter()
            .chain(e.data_checks.notes("training"))
        {
            eprintln!("  {note}");
        }
        // The series' own suspect poses, from its own elasto-geometric fit.
        let suspects: Vec<String> = e
            .data_checks
            .suspect_poses
            .iter()
            .map(|s| s.pose.clone())
            .collect();
        faults.push(suspects);
    }

    // The pairs again with each series' suspect poses left out, where it has any.
    let clean: Vec<(&str, MeasurementSet)> = sets
        .iter()
        .zip(&faults)
        .map(|((name, set), f)| {
            Ok((
                *name,
                if f.is_empty() {
                    set.clone()
                } else {
                    set.excluding(f)?
                },
            ))
        })
        .collect::<Result<_, flexcal_calib::CalibError>>()?;
    println!("\nWithout each series' suspect poses ({}):", {
        let named: Vec<String> = sets
            .iter()
            .zip(&faults)
            .filter(|(_, f)| !f.is_empty())
            .map(|((name, _), f)| format!("{name}: {}", f.join(", ")))
            .collect();
        named.join("; ")
    });
    println!("| train -> validate | nominal | geometric | elasto-geometric |\n|---|---|---|---|");
    for (t, (train_name, train)) in clean.iter().enumerate() {
        let g = calibrate(model, train, &geometric)?;
        let e = calibrate(model, train, &elastic)?;
        for (v, (validate_name, validate)) in clean.iter().enumerate() {
            if t == v || (faults[t].is_empty() && faults[v].is_empty()) {
                continue;
            }
            row(train_name, validate_name, &g, &e, validate)?;
        }
    }

    // All pairs again with the T-Mac's measured orientations in the fits
    // (calibrate --with-orientation), then also without each series'
    // suspect poses; the figures stay position errors.
    let (mut geometric, mut elastic) = (geometric, elastic);
    geometric.use_orientation = Some(true);
    elastic.use_orientation = Some(true);
    let degrees = |s: &ErrorStatistics| {
        s.orientation_mean_rms_max
            .map_or(f64::NAN, |o| o.0.to_degrees())
    };
    for (title, series) in [
        ("With the probe's orientations", &sets),
        (
            "With the probe's orientations, without the suspect poses",
            &clean,
        ),
    ] {
        println!("\n{title} (position errors; mean orientation error in deg):");
        println!(
            "| train -> validate | geometric | elasto-geometric | deg, geometric / elasto-geometric |\n|---|---|---|---|"
        );
        for (train_name, train) in series {
            let g = calibrate(model, train, &geometric)?;
            let e = calibrate(model, train, &elastic)?;
            for (validate_name, validate) in series {
                if validate_name == train_name {
                    continue;
                }
                let g_report = g.validate(model, validate, false)?;
                let e_report = e.validate(model, validate, false)?;
                println!(
                    "| {train_name} -> {validate_name} | {} | {} | {:.3} / {:.3} |",
                    cell(&g_report.after),
                    cell(&e_report.after),
                    degrees(&g_report.after),
                    degrees(&e_report.after)
                );
            }
        }
    }
    Ok(())
}

//! Cross-series table on the IPA UR10 data (the dataset README's baseline
//! protocol): calibrate on one series, validate on another, re-fitting only
//! the tracker -> base transform on the validation series; geometric and
//! elasto-geometric (joint compliances under gravity) models side by side.
//!
//! Printed again without each series' suspect poses (its own fit's data
//! checks), with the probe's measured orientations in the fits, and with
//! both.
//!
//! `cargo run --release -p flexcal-calib --example ipa_table`

use std::path::PathBuf;
use std::time::Instant;

use flexcal_calib::{
    Calibration, CalibrationOptions, ErrorStatistics, GravityCompliance, MeasurementSet, Weighting,
    calibrate,
};
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
    // One table row: nominal, geometric and elasto-geometric on `validate`.
    let row = |train_name: &str,
               validate_name: &str,
               g: &Calibration,
               e: &Calibration,
               validate: &MeasurementSet|
     -> Result<(), flexcal_calib::CalibError> {
        let g_report = g.validate(&model, validate, false)?;
        let e_report = e.validate(&model, validate, false)?;
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
        let g = calibrate(&model, train, &geometric)?;
        let middle = Instant::now();
        let e = calibrate(&model, train, &elastic)?;
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
        let g = calibrate(&model, train, &geometric)?;
        let e = calibrate(&model, train, &elastic)?;
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
            let g = calibrate(&model, train, &geometric)?;
            let e = calibrate(&model, train, &elastic)?;
            for (validate_name, validate) in series {
                if validate_name == train_name {
                    continue;
                }
                let g_report = g.validate(&model, validate, false)?;
                let e_report = e.validate(&model, validate, false)?;
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

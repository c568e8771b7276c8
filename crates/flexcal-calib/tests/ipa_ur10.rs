//! The IPA UR10 laser-tracker data: calibrate on series B, validate on C
//! (the dataset README's `dh` baseline: 0.570 mm mean; `dh+g`: 0.512 mean,
//! 1.59 max), geometric and elasto-geometric. Skips without data.

use std::io::Write;
use std::path::PathBuf;

use flexcal_calib::{
    CalibrationOptions, GravityCompliance, MeasurementSet, UnknownStatus, Weighting, calibrate,
};
use flexcal_kinematics::{Model, RobotDescription};

fn series(name: &str, file: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10")
        .join(name)
        .join(file);
    if path.exists() {
        Some(path)
    } else {
        // Written directly: the harness captures println! of passing tests.
        let _ = writeln!(
            std::io::stderr(),
            "SKIPPED: IPA UR10 data absent ({})",
            path.display()
        );
        None
    }
}

/// The UR10, the options of the dataset's protocol (positions, uniform
/// weights) and the two series, or `None` (with a message) without data.
fn setup(files: [(&str, &str); 2]) -> Option<(Model, CalibrationOptions, [MeasurementSet; 2])> {
    let [a, b] = files.map(|(name, file)| series(name, file));
    let (a, b) = (a?, b?);
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut options = CalibrationOptions::for_model(&model);
    options.use_orientation = Some(false);
    options.weighting = Weighting::Uniform;
    let sets = [a, b].map(|path| MeasurementSet::read_ipa(&path).unwrap());
    Some((model, options, sets))
}

#[test]
fn series_b_to_c_matches_the_dh_baseline() {
    let Some((model, mut options, [train, validate])) = setup([
        ("Series_B", "measurements_joint_configurations.csv"),
        ("Series_C", "measurements_random_poses.csv"),
    ]) else {
        return;
    };
    let calibration = calibrate(&model, &train, &options).unwrap();
    let report = calibration.validate(&model, &validate, false).unwrap();
    println!(
        "B -> C: train {:.3} mm mean; validation before {:.3} / {:.3}, after {:.3} / {:.3} mm (mean / max); rank {}, non-identifiable {:?}",
        calibration.training_after.position_mean * 1e3,
        report.before.position_mean * 1e3,
        report.before.position_max * 1e3,
        report.after.position_mean * 1e3,
        report.after.position_max * 1e3,
        calibration.rank(),
        calibration.non_identifiable()
    );
    assert!(calibration.solve.termination.is_converged());
    // Within 2 % of the README's dh column (0.570 mm mean), or better.
    assert!(report.after.position_mean * 1e3 <= 0.570 * 1.02);
    assert!(report.after.position_mean < report.before.position_mean);

    // Without the axis tilts beta3, beta4 (which plain DH cannot represent)
    // the model is the baseline's: the same validation mean to 0.5 %.
    let mut no_tilt = options.clone();
    no_tilt.fixed = vec!["beta3".into(), "beta4".into()];
    let plain = calibrate(&model, &train, &no_tilt).unwrap();
    let plain_report = plain.validate(&model, &validate, false).unwrap();
    println!(
        "B -> C without beta3, beta4: {:.3} / {:.3} mm",
        plain_report.after.position_mean * 1e3,
        plain_report.after.position_max * 1e3
    );
    assert!((plain_report.after.position_mean * 1e3 - 0.570).abs() < 0.570 * 0.005);

    // Elasto-geometric: joint compliances under gravity, identified jointly.
    options.gravity = Some(GravityCompliance::ur10_urdf(&model).unwrap());
    let elastic = calibrate(&model, &train, &options).unwrap();
    let elastic_report = elastic.validate(&model, &validate, false).unwrap();
    let identified: Vec<&str> = elastic
        .unknowns
        .iter()
        .filter(|u| u.name.starts_with("compliance_") && u.status == UnknownStatus::Identified)
        .map(|u| u.name.as_str())
        .collect();
    println!(
        "B -> C elasto-geometric: validation after {:.3} / {:.3} mm (mean / max); compliances identified: {identified:?}",
        elastic_report.after.position_mean * 1e3,
        elastic_report.after.position_max * 1e3,
    );
    assert!(elastic.solve.termination.is_converged());
    // Gravity never loads joint 1 (vertical axis): its compliance moves
    // nothing; joint 2 carries the arm.
    let theta1 = elastic
        .unknowns
        .iter()
        .find(|u| u.name == "compliance_theta1");
    assert_eq!(theta1.map(|u| u.status), Some(UnknownStatus::NoInfluence));
    assert!(identified.contains(&"compliance_theta2"));
    // Better than geometry alone and than the README's dh+g (0.512 / 1.59 mm).
    assert!(elastic_report.after.position_mean < report.after.position_mean);
    assert!(elastic_report.after.position_max < report.after.position_max);
    assert!(elastic_report.after.position_mean * 1e3 < 0.512);
    assert!(elastic_report.after.position_max * 1e3 < 1.59);
}

/// Series D (ISO cubes): the identifiability analysis names what D cannot
/// identify, the probe offset along the tool axis, and finds its geometry
/// well spread (joint 1 turns through more than a revolution). Given the
/// probe offset from series B, D's geometry validates on B as well as a
/// B -> C or C -> B fit: the offset is all that D lacks.
#[test]
fn series_d_lacks_only_the_probe_offset() {
    let Some((model, options, [set_b, set_d])) = setup([
        ("Series_B", "measurements_joint_configurations.csv"),
        ("Series_D", "measurements_iso_cubes.csv"),
    ]) else {
        return;
    };
    let from_d = calibrate(&model, &set_d, &options).unwrap();
    let status = |name: &str| {
        from_d
            .unknowns
            .iter()
            .find(|u| u.name == name)
            .map(|u| u.status)
            .unwrap()
    };
    assert_eq!(status("target_z"), UnknownStatus::PoorlyIdentifiable);
    let notes = from_d.identifiability_notes().join("\n");
    assert!(notes.contains("not identified along target_z"), "{notes}");
    let worst_ratio = from_d
        .unknowns
        .iter()
        .filter_map(|u| u.spread_ratio)
        .fold(0.0, f64::max);
    assert!(worst_ratio < 10.0, "worst spread ratio {worst_ratio}");
    let alone = from_d.validate(&model, &set_b, false).unwrap();

    let from_b = calibrate(&model, &set_b, &options).unwrap();
    let mut with_offset = options.clone();
    with_offset.target_value = Some(from_b.x_tcp_target());
    let from_d_with_offset = calibrate(&model, &set_d, &with_offset).unwrap();
    let helped = from_d_with_offset.validate(&model, &set_b, false).unwrap();
    println!(
        "D -> B: {:.3} mm mean alone, {:.3} mm with the probe offset of a B fit; worst spread ratio on D {worst_ratio:.1}",
        alone.after.position_mean * 1e3,
        helped.after.position_mean * 1e3
    );
    assert!(alone.after.position_mean > 2e-3);
    assert!(helped.after.position_mean < 0.6e-3);
}

/// Series B holds recording faults: two pairs of poses share one tracker
/// reading to the last digit, and three poses stay near 2 mm off when B is
/// fitted on itself (four times the RMS error; the next is below three).
/// The data checks name them; left out of the validation, the C -> B
/// maximum is no longer set by them and the elasto-geometric model is
/// ahead of the geometric one in maximum too.
#[test]
fn series_b_recording_faults_are_named() {
    let Some((model, mut options, [set_b, set_c])) = setup([
        ("Series_B", "measurements_joint_configurations.csv"),
        ("Series_C", "measurements_random_poses.csv"),
    ]) else {
        return;
    };
    options.gravity = Some(GravityCompliance::ur10_urdf(&model).unwrap());
    let from_b = calibrate(&model, &set_b, &options).unwrap();
    let checks = &from_b.data_checks;
    let pairs: Vec<[&str; 2]> = checks
        .repeated_readings
        .iter()
        .map(|r| [r.poses[0].as_str(), r.poses[1].as_str()])
        .collect();
    assert_eq!(
        pairs,
        [["line 533", "line 534"], ["line 1064", "line 1065"]]
    );
    let suspects: Vec<&str> = checks
        .suspect_poses
        .iter()
        .map(|s| s.pose.as_str())
        .collect();
    assert_eq!(suspects, ["line 534", "line 856", "line 857"]);
    let notes = checks.notes("identification").join("\n");
    assert!(
        notes.contains("stale reading (line 534, by its error"),
        "{notes}"
    );

    let from_c = calibrate(&model, &set_c, &options).unwrap();
    let faults: Vec<String> = suspects.iter().map(|s| s.to_string()).collect();
    let clean_b = set_b.excluding(&faults).unwrap();
    assert_eq!(clean_b.len(), set_b.len() - 3);
    let all = from_c.validate(&model, &set_b, false).unwrap();
    let clean = from_c.validate(&model, &clean_b, false).unwrap();
    options.gravity = None;
    let geometric = calibrate(&model, &set_c, &options)
        .unwrap()
        .validate(&model, &clean_b, false)
        .unwrap();
    println!(
        "C -> B elasto-geometric max {:.3} mm with all poses, {:.3} without B's faults (geometric {:.3})",
        all.after.position_max * 1e3,
        clean.after.position_max * 1e3,
        geometric.after.position_max * 1e3
    );
    // The worst validation pose with all of B is one of the faults.
    let worst = all
        .after_per_pose
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.position.total_cmp(&b.1.position))
        .map(|(k, _)| set_b.measurements()[k].label(k))
        .unwrap();
    assert!(suspects.contains(&worst.as_str()), "{worst}");
    assert!(clean.after.position_max < 0.8 * all.after.position_max);
    assert!(clean.after.position_max < geometric.after.position_max);
    assert!(clean.after.position_mean < geometric.after.position_mean);
}

/// #8's acceptance pairs with the T-Mac probe's measured orientations in
/// the fits (which the baseline protocol leaves out) and without the three
/// recording faults of series B that its data checks name (see
/// `series_b_recording_faults_are_named`): for B -> C, B -> D, C -> B and
/// C -> D the elasto-geometric model beats the geometric one fitted to the
/// same data and the README's `dh+g` column, in mean and in maximum
/// position error, and predicts the probe's orientation better.
#[test]
fn with_orientations_gravity_beats_geometry_on_every_pair() {
    let Some((model, mut options, [set_b, set_c])) = setup([
        ("Series_B", "measurements_joint_configurations.csv"),
        ("Series_C", "measurements_random_poses.csv"),
    ]) else {
        return;
    };
    let Some(path_d) = series("Series_D", "measurements_iso_cubes.csv") else {
        return;
    };
    let set_d = MeasurementSet::read_ipa(&path_d).unwrap();
    let faults = ["534", "856", "857"].map(String::from);
    let set_b = set_b.excluding(&faults).unwrap();
    options.use_orientation = Some(true);
    let mut elastic_options = options.clone();
    elastic_options.gravity = Some(GravityCompliance::ur10_urdf(&model).unwrap());
    // (train, validate, dh+g mean and max from the dataset README, mm).
    let pairs = [
        (&set_b, &set_c, "B -> C", 0.512, 1.59),
        (&set_b, &set_d, "B -> D", 0.711, 1.83),
        (&set_c, &set_b, "C -> B", 0.478, 2.13),
        (&set_c, &set_d, "C -> D", 0.605, 1.65),
    ];
    let figures = |r: &flexcal_calib::ValidationReport| {
        (
            r.after.position_mean * 1e3,
            r.after.position_max * 1e3,
            r.after.orientation_mean_rms_max.unwrap().0.to_degrees(),
        )
    };
    let mut fits = Vec::new();
    for set in [&set_b, &set_c] {
        fits.push((
            calibrate(&model, set, &options).unwrap(),
            calibrate(&model, set, &elastic_options).unwrap(),
        ));
    }
    for (k, (_, validate, name, dhg_mean, dhg_max)) in pairs.into_iter().enumerate() {
        let (geometric, elastic) = &fits[k / 2];
        let g = figures(&geometric.validate(&model, validate, false).unwrap());
        let e = figures(&elastic.validate(&model, validate, false).unwrap());
        println!(
            "{name} with orientations: geometric {g:.3?}, elasto-geometric {e:.3?} (mean mm, max mm, mean deg)"
        );
        assert!(e.0 < g.0 && e.1 < g.1, "{name}: {e:?} vs {g:?}");
        assert!(e.0 < dhg_mean && e.1 < dhg_max, "{name}: {e:?}");
        assert!(e.2 < g.2, "{name}: {e:?} vs {g:?}");
    }
}

/// B -> D: the geometric model validates 9 % behind the `dh` baseline,
/// which has no tilt of the parallel axes. Identified again on D, the tilt
/// beta3 and the joint-2 offset come out beyond the plain standard errors,
/// and the cross-series check names them; with each standard error raised
/// to its split error (both series' standard errors are understated), B
/// and D agree on every unknown: B's beta3 is not significant, and the 9 %
/// is the price of identifying it.
#[test]
fn series_b_and_d_agree_within_their_split_errors() {
    let Some((model, options, [train, other])) = setup([
        ("Series_B", "measurements_joint_configurations.csv"),
        ("Series_D", "measurements_iso_cubes.csv"),
    ]) else {
        return;
    };
    let calibration = calibrate(&model, &train, &options).unwrap();
    let plain =
        flexcal_calib::CrossCheck::new(&model, &other, &options, &calibration, None).unwrap();
    let split = flexcal_calib::SplitCheck::new(&model, &train, &options, &calibration).unwrap();
    let widened =
        flexcal_calib::CrossCheck::new(&model, &other, &options, &calibration, Some(&split))
            .unwrap();
    for note in plain.notes().into_iter().chain(widened.notes()) {
        println!("{note}");
    }
    let disagreeing = |c: &flexcal_calib::CrossCheck| -> Vec<String> {
        c.disagreeing().map(|u| u.name.clone()).collect()
    };
    let named = disagreeing(&plain);
    assert!(
        named.contains(&"beta3".to_string()) && named.contains(&"theta2".to_string()),
        "{named:?}"
    );
    assert!(disagreeing(&widened).is_empty(), "{:?}", widened.notes());
    let beta = |name: &str| widened.unknowns.iter().find(|u| u.name == name).unwrap();
    // The split errors only widen: |z_split| <= |z|.
    let beta3 = beta("beta3");
    assert!(beta3.z_split.unwrap().abs() < beta3.z.unwrap().abs());
    assert!(beta3.split_error.is_some() && beta3.other_split_error.is_some());
    assert!(beta("beta4").z.unwrap().abs() < 1.0);
    // D cannot identify the probe offset along its axis: not compared.
    let target_z = beta("target_z");
    assert!(target_z.other_value.is_none() && target_z.z.is_none() && target_z.z_split.is_none());
}

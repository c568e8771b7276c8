//! The multi-target measurement files: CSV with per-target columns and the
//! targets description (TOML), written and read back, and their errors.

use flexcal_calib::{
    FrameTreatment, Measurement, MeasurementSet, TCP_FRAME, Target, TargetObservation, TargetPose,
    read_targets, targets_from_toml_str, targets_to_toml_string, write_targets,
};
use nalgebra::Vector3;

fn targets() -> Vec<Target> {
    let mut fixed = Target::new("right", "RH", Vector3::new(0.03, -0.001, 0.04));
    fixed.treatment = FrameTreatment::Fixed;
    vec![
        Target::new("left", "LH", Vector3::new(0.0301, 0.0, 0.0405)),
        fixed,
    ]
}

/// Five poses: the left target with orientation and standard deviations,
/// the right one position only, and each missing on one pose.
fn sample() -> MeasurementSet {
    let poses = (0..5)
        .map(|k| {
            let t = k as f64;
            let left = TargetObservation {
                position: Vector3::new(1.2 + 0.01 * t, -0.3, 0.123_456_789),
                orientation: Some(Vector3::new(0.1, -0.2 * t, 0.3)),
                position_std: Some(Vector3::new(1e-5, 2e-5, 3e-5)),
                orientation_std: Some(Vector3::new(1e-4, 1e-4, 2e-4)),
            };
            let right = TargetObservation::new(Vector3::new(0.9, 0.1 * t, -0.05));
            TargetPose::new(
                Some(format!("p{k}")),
                vec![0.1 * t, -0.2, 0.3, 1.0 / 3.0, 0.5, -0.6, 0.7, 0.8, -0.9],
                vec![(k != 2).then_some(left), (k != 4).then_some(right)],
            )
        })
        .collect();
    MeasurementSet::from_poses("sample", targets(), poses).unwrap()
}

#[test]
fn measurements_and_targets_round_trip_through_their_files() {
    let set = sample();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("markers.csv");
    let toml = dir.path().join("targets.toml");
    set.write_csv(&csv).unwrap();
    write_targets(&toml, set.targets()).unwrap();
    let targets = read_targets(&toml).unwrap();
    assert_eq!(targets.len(), 2);
    for (a, b) in targets.iter().zip(set.targets()) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.frame, b.frame);
        assert_eq!(a.treatment, b.treatment);
        assert!((a.offset - b.offset).norm() < 1e-15);
    }
    let back = MeasurementSet::read_targets_csv(&csv, &targets).unwrap();
    assert_eq!(back.len(), set.len());
    assert_eq!(back.n_observations(), 8);
    for (a, b) in back.poses().iter().zip(set.poses()) {
        assert_eq!(a.pose_id, b.pose_id);
        assert_eq!(a.q, b.q);
        for (oa, ob) in a.observations.iter().zip(&b.observations) {
            match (oa, ob) {
                (None, None) => {}
                (Some(oa), Some(ob)) => {
                    assert!((oa.position - ob.position).norm() < 1e-15);
                    let close = |x: Option<Vector3<f64>>, y: Option<Vector3<f64>>| match (x, y) {
                        (None, None) => true,
                        (Some(x), Some(y)) => (x - y).norm() < 1e-15,
                        _ => false,
                    };
                    assert!(close(oa.orientation, ob.orientation));
                    assert!(close(oa.position_std, ob.position_std));
                    assert!(close(oa.orientation_std, ob.orientation_std));
                }
                _ => panic!("an observation appeared or vanished"),
            }
        }
    }
    let header = set.to_csv_string().lines().next().unwrap().to_string();
    assert!(header.contains("left_x_mm") && header.contains("left_srz_deg"));
    assert!(header.contains("right_z_mm") && !header.contains("right_rx_deg"));
}

#[test]
fn targets_description_parses_defaults_and_names_its_errors() {
    let text = "[[target]]\nname = \"probe\"\nframe = \"tcp\"\noffset_mm = [0, 0, 120]\n";
    let targets = targets_from_toml_str(text, "t.toml").unwrap();
    assert_eq!(targets[0].treatment, FrameTreatment::Identify);
    assert_eq!(targets[0].frame, TCP_FRAME);
    assert!((targets[0].offset.z - 0.12).abs() < 1e-15);
    let again = targets_from_toml_str(&targets_to_toml_string(&targets).unwrap(), "again").unwrap();
    assert_eq!(again, targets);

    let bad = "[[target]]\nname = \"probe\"\nframe = \"tcp\"\noffset_mm = [0, 0]\n";
    let err = targets_from_toml_str(bad, "t.toml")
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("t.toml:4:"), "{err}");
    let twice = format!("{text}{text}");
    let err = targets_from_toml_str(&twice, "t.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("`probe` is declared twice"), "{err}");
    let spaced = text.replace("probe", "my probe");
    let err = targets_from_toml_str(&spaced, "t.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("my probe"), "{err}");
}

#[test]
fn malformed_measurement_files_are_named_errors() {
    let targets = targets();
    let header = "q1,q2,left_x_mm,left_y_mm,left_z_mm,right_x_mm,right_y_mm,right_z_mm\n";
    // A row with some of a target's cells empty.
    let text = format!("{header}0.1,0.2,1,2,3,4,5,6\n0.1,0.2,1,,3,4,5,6\n");
    let err = MeasurementSet::from_targets_csv_str(&text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("m.csv:3:") && err.contains("`left`"),
        "{err}"
    );
    // A row where no target was seen.
    let text = format!("{header}0.1,0.2,1,2,3,4,5,6\n0.1,0.2,,,,,,\n");
    let err = MeasurementSet::from_targets_csv_str(&text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("m.csv:3:") && err.contains("no target"),
        "{err}"
    );
    // Columns of a target the description does not know (a typo).
    let text = format!(
        "{}0.1,0.2,1,2,3,4,5,6,7,8,9\n",
        header.replace('\n', ",lfet_x_mm,lfet_y_mm,lfet_z_mm\n")
    );
    let err = MeasurementSet::from_targets_csv_str(&text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`lfet_x_mm`") && err.contains("left, right"),
        "{err}"
    );
    // A target of the description without its columns.
    let text = "q1,left_x_mm,left_y_mm,left_z_mm\n0.1,1,2,3\n";
    let err = MeasurementSet::from_targets_csv_str(text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(err.contains("right_x_mm"), "{err}");
    // A target never seen.
    let text = format!("{header}0.1,0.2,1,2,3,,,\n");
    let err = MeasurementSet::from_targets_csv_str(&text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(err.contains("`right` is observed on no pose"), "{err}");
    // A number that is not one.
    let text = format!("{header}0.1,0.2,1,2,3,4,5,x\n");
    let err = MeasurementSet::from_targets_csv_str(&text, "m.csv", &targets)
        .unwrap_err()
        .to_string();
    assert!(err.contains("m.csv") && err.contains("right_z_mm"), "{err}");
}

#[test]
fn a_one_target_set_is_a_set_of_one_target_on_the_tcp() {
    let mut m = Measurement::new(vec![0.1, 0.2], Vector3::new(1.0, 2.0, 3.0));
    m.pose_id = Some("a".into());
    let mut set = MeasurementSet::new("one", vec![m.clone(), m]).unwrap();
    set.set_nominal_target(nalgebra::Isometry3::translation(0.0, 0.0, 0.1));
    assert!(set.is_one_target());
    assert_eq!(set.targets().len(), 1);
    assert_eq!(set.targets()[0].name, flexcal_calib::TCP_TARGET);
    assert_eq!(set.targets()[0].frame, TCP_FRAME);
    assert!((set.targets()[0].offset.z - 0.1).abs() < 1e-15);
    assert_eq!(set.n_observations(), 2);
    // A one-target set writes the one-target CSV, its rows as given.
    assert!(
        set.to_csv_string()
            .starts_with("pose_id,q1,q2,x_mm,y_mm,z_mm\n"),
        "{}",
        set.to_csv_string()
    );
    assert_eq!(set.measurements()[1].position, Vector3::new(1.0, 2.0, 3.0));
    // The target named otherwise, the per-target columns.
    let probe = Target {
        name: "probe".into(),
        ..set.targets()[0].clone()
    };
    let multi = MeasurementSet::from_poses("one", vec![probe], set.poses().to_vec()).unwrap();
    assert!(!multi.is_one_target());
    let text = multi.to_csv_string();
    assert!(
        text.starts_with("pose_id,q1,q2,probe_x_mm,probe_y_mm,probe_z_mm\n"),
        "{text}"
    );
}

//! Seeded fuzzing of the calibration readers: flexcal's measurement CSV, the
//! IPA laser-tracker CSV and the mass table, 10 000 mutants of a real file each (flexcal_io::fuzz):
//! every mutant gives a valid result or a named error, never a panic.

use flexcal_calib::{GravityCompliance, IPA_JOINT_COLUMNS, MeasurementSet};
use flexcal_io::fuzz::TextMutator;
use flexcal_kinematics::RobotDescription;

const CASES: usize = 10_000;

/// Pose `k` of the source files: UR10 joint values (rad), then a measured
/// position (mm) and orientation (deg).
fn pose_values(k: usize) -> [f64; 12] {
    let t = k as f64 * 0.1;
    [
        0.1 + t,
        -1.2 + t,
        1.0 - t,
        -0.5,
        1.3,
        0.2 * t,
        800.0 + 10.0 * t,
        -150.0 + t,
        420.5,
        179.0,
        -2.0 * t,
        45.0,
    ]
}

/// A measurement file as flexcal writes it: UR10 configurations with
/// positions, orientations, standard deviations and temperatures, measured
/// from two stations.
fn measurement_csv() -> String {
    let mut text = String::from(
        "pose_id,station,q1,q2,q3,q4,q5,q6,x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,sx_mm,sy_mm,sz_mm,temperature_c\n",
    );
    for k in 0..12 {
        let values: Vec<String> = pose_values(k).iter().map(f64::to_string).collect();
        text.push_str(&format!(
            "p{k},{},{},0.01,0.01,0.02,{}\n",
            ["north", "south"][k % 2],
            values.join(","),
            21.5 + k as f64 * 0.1
        ));
    }
    text
}

#[test]
fn measurement_csv_reader_survives_mutated_files() {
    let source = measurement_csv();
    MeasurementSet::from_csv_str(&source, "source.csv").expect("the source file is valid");
    let mut mutator = TextMutator::new(19);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&source);
        match MeasurementSet::from_csv_str(&text, "fuzz.csv") {
            Ok(set) => {
                valid += 1;
                assert!(!set.measurements().is_empty());
                // Every station named has a pose, every pose a station.
                for s in 0..set.n_stations() {
                    assert!(set.station_poses(s).is_some(), "station {s}");
                }
                assert!((0..set.len()).all(|k| set.station_of(k) < set.n_stations()));
            }
            Err(e) => assert!(e.to_string().contains("fuzz.csv"), "{e}"),
        }
    }
    println!("measurement CSV: {valid} valid of {CASES}");
}

#[test]
fn mass_table_reader_survives_mutated_files() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let source = GravityCompliance::ur10_urdf(&model)
        .unwrap()
        .to_toml_string()
        .unwrap();
    let mut mutator = TextMutator::new(20);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&source);
        match GravityCompliance::from_toml_str(&text, "fuzz.toml") {
            Ok(_) => valid += 1,
            Err(e) => assert!(e.to_string().contains("fuzz.toml"), "{e}"),
        }
    }
    println!("mass table: {valid} valid of {CASES}");
}

/// An IPA laser-tracker export as the dataset writes it: semicolons,
/// decimal commas, the joint and measurement columns
/// ([`MeasurementSet::read_ipa`]).
fn ipa_csv() -> String {
    let measured = ["x", "y", "z", "rx", "ry", "rz"];
    let mut header: Vec<String> = IPA_JOINT_COLUMNS.iter().map(|j| j.to_string()).collect();
    header.extend(measured.iter().map(|a| format!("measurement_{a}")));
    header.extend(measured.iter().map(|a| format!("measurement_std_{a}")));
    header.push("measurement_temperature".into());
    let mut text = header.join(";") + "\r\n";
    for k in 0..12 {
        let mut values = pose_values(k).to_vec();
        values.extend([0.01, 0.01, 0.02, 0.001, 0.001, 0.001, 21.5 + k as f64 * 0.1]);
        let row: Vec<String> = values
            .iter()
            .map(|v| format!("{v}").replace('.', ","))
            .collect();
        text += &(row.join(";") + "\r\n");
    }
    text
}

#[test]
fn ipa_reader_survives_mutated_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.csv");
    let source = ipa_csv();
    std::fs::write(&path, &source).unwrap();
    MeasurementSet::read_ipa(&path).expect("the source file is valid");
    let mut mutator = TextMutator::new(21);
    let mut valid = 0;
    for _ in 0..CASES {
        std::fs::write(&path, mutator.mutate(&source)).unwrap();
        match MeasurementSet::read_ipa(&path) {
            Ok(set) => {
                valid += 1;
                assert!(!set.measurements().is_empty());
            }
            Err(e) => assert!(e.to_string().contains("fuzz.csv"), "{e}"),
        }
    }
    println!("IPA CSV: {valid} valid of {CASES}");
}

/// A multi-target measurement file as flexcal writes it: two markers, the
/// left one with orientation and standard deviations, each missing on a
/// pose, and the targets description beside it.
fn multi_target_files() -> (String, String) {
    use flexcal_calib::{MeasurementSet, Target, TargetObservation, TargetPose};
    use nalgebra::Vector3;
    let targets = vec![
        Target::new("left", "LH", Vector3::new(0.03, 0.0, 0.04)),
        Target::new("right", "RH", Vector3::new(0.03, 0.0, 0.04)),
    ];
    let poses = (0..10)
        .map(|k| {
            let t = k as f64 * 0.1;
            let left = TargetObservation {
                position: Vector3::new(1.2 + t, -0.3, 0.4),
                orientation: Some(Vector3::new(0.1, -t, 0.3)),
                position_std: Some(Vector3::new(2e-5, 2e-5, 3e-5)),
                orientation_std: Some(Vector3::new(1e-4, 1e-4, 1e-4)),
            };
            TargetPose {
                pose_id: Some(format!("p{k}")),
                q: vec![0.1 + t, -1.2 + t, 1.0 - t, -0.5, 1.3],
                observations: vec![
                    (k != 3).then_some(left),
                    (k != 6).then(|| TargetObservation::new(Vector3::new(0.8, t, -0.2))),
                ],
                wrench: None,
                temperature_c: None,
            }
        })
        .collect();
    let set = MeasurementSet::from_poses("source", targets.clone(), poses).unwrap();
    (
        set.to_csv_string(),
        flexcal_calib::targets_to_toml_string(&targets).unwrap(),
    )
}

#[test]
fn multi_target_readers_survive_mutated_files() {
    use flexcal_calib::{MeasurementSet, targets_from_toml_str};
    let (csv, toml) = multi_target_files();
    let targets = targets_from_toml_str(&toml, "source.toml").expect("the source file is valid");
    MeasurementSet::from_targets_csv_str(&csv, "source.csv", &targets)
        .expect("the source file is valid");
    let mut mutator = TextMutator::new(23);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&csv);
        match MeasurementSet::from_targets_csv_str(&text, "fuzz.csv", &targets) {
            Ok(set) => {
                valid += 1;
                assert!(set.n_observations() > 0);
            }
            Err(e) => assert!(e.to_string().contains("fuzz.csv"), "{e}"),
        }
    }
    println!("multi-target CSV: {valid} valid of {CASES}");
    let mut mutator = TextMutator::new(24);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&toml);
        match targets_from_toml_str(&text, "fuzz.toml") {
            Ok(targets) => {
                valid += 1;
                assert!(!targets.is_empty());
            }
            Err(e) => assert!(e.to_string().contains("fuzz.toml"), "{e}"),
        }
    }
    println!("targets description: {valid} valid of {CASES}");
}

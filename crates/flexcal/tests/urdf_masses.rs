//! A URDF robot's `<inertial>` masses are the default mass table of its
//! elasto-geometric model ([`RobotSpec::mass_table`]); a mass table file
//! overrides them. Checked on the public UR10 URDF of
//! `../shared/robots/urdf/` (read in place; the test says so and returns
//! when the file is absent): its link masses, and the gravity torques they
//! give against the built-in `ur10` with its hand-written table of the same
//! URDF's masses.

use std::path::PathBuf;

use flexcal::RobotSpec;
use flexcal::calib::GravityCompliance;
use flexcal::kinematics::{Data, ImportOptions, PointLoad, actuated_forces_into};

fn ur10_urdf() -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/robots/urdf/ur10_robot.urdf");
    if path.exists() {
        Some(path)
    } else {
        eprintln!("UR10 URDF absent ({}): test skipped", path.display());
        None
    }
}

/// Gravity torques (N.m) of a mass table's links at `q`.
fn gravity_torques(
    model: &flexcal::kinematics::Model,
    table: &GravityCompliance,
    q: &[f64],
) -> Vec<f64> {
    let loads: Vec<PointLoad> = table
        .masses
        .iter()
        .map(|m| PointLoad {
            frame: model.frame_index(&m.frame).unwrap(),
            point: m.center,
            force: table.gravity * m.mass,
        })
        .collect();
    let mut data = Data::new(model);
    let mut tau = vec![0.0; model.n_actuated()];
    actuated_forces_into(
        model,
        &mut data,
        q,
        model.nominal_params(),
        &loads,
        &mut tau,
    )
    .unwrap();
    tau
}

#[test]
fn a_urdf_robots_inertials_are_its_default_mass_table() {
    let Some(path) = ur10_urdf() else {
        return;
    };
    let spec = RobotSpec::File(path);
    let options = ImportOptions::default();
    let model = spec.model_with(&options).unwrap();
    let table = spec.mass_table(&options, &model, None).unwrap();
    let masses: Vec<(&str, f64)> = table
        .masses
        .iter()
        .map(|m| (m.name.as_str(), m.mass))
        .collect();
    println!("UR10 URDF mass table: {masses:?}");
    // The moving links' <inertial> masses (kg); base_link (4 kg) loads no joint.
    for (link, kg) in [
        ("shoulder_link", 7.778),
        ("upper_arm_link", 12.93),
        ("forearm_link", 3.87),
        ("wrist_1_link", 1.96),
        ("wrist_2_link", 1.96),
        ("wrist_3_link", 0.202),
    ] {
        assert!(masses.contains(&(link, kg)), "{link} {kg} kg missing");
    }
    assert!(!masses.iter().any(|(link, _)| *link == "base_link"));

    // Gravity torques on the shoulder and elbow against the built-in ur10
    // with its hand-written table of the same masses (centres moved along
    // the joint axes, which changes no torque about joints 1-3).
    let builtin = RobotSpec::parse("ur10").unwrap();
    let builtin_model = builtin.model().unwrap();
    let builtin_table = builtin.mass_table(&options, &builtin_model, None).unwrap();
    assert_eq!(
        builtin_table,
        GravityCompliance::ur10_urdf(&builtin_model).unwrap()
    );
    let mut worst = 0.0f64;
    for k in 0..20 {
        // Spread over the joint ranges without a random generator.
        let q: Vec<f64> = (0..6)
            .map(|j| 3.0 * (1.7 * f64::from(k) + 0.9 * f64::from(j)).sin())
            .collect();
        let from_urdf = gravity_torques(&model, &table, &q);
        let from_builtin = gravity_torques(&builtin_model, &builtin_table, &q);
        for i in 0..3 {
            worst = worst.max((from_urdf[i] - from_builtin[i]).abs());
        }
    }
    println!(
        "shoulder and elbow gravity torques, URDF masses vs built-in table: worst {worst:.2e} N.m"
    );
    assert!(worst < 1e-9, "{worst:.3e} N.m");
}

#[test]
fn a_mass_table_file_overrides_the_urdf_inertials() {
    let Some(path) = ur10_urdf() else {
        return;
    };
    let spec = RobotSpec::File(path);
    let options = ImportOptions::default();
    let model = spec.model_with(&options).unwrap();
    let mut table = spec.mass_table(&options, &model, None).unwrap();
    table.masses.truncate(2);
    table.payload_mass = 2.5;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("masses.toml");
    std::fs::write(&file, table.to_toml_string().unwrap()).unwrap();
    let chosen = spec.mass_table(&options, &model, Some(&file)).unwrap();
    assert_eq!(chosen.masses.len(), 2);
    assert_eq!(chosen.payload_mass, 2.5);
}

#[test]
fn a_robot_without_masses_asks_for_a_mass_table_file() {
    let spec = RobotSpec::parse("ir663").unwrap();
    let model = spec.model().unwrap();
    let err = spec
        .mass_table(&ImportOptions::default(), &model, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("ir663") && err.contains("mass table"), "{err}");
}

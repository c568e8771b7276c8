//! Seeded fuzzing of the robot file readers (description TOML, URDF, SYMORO
//! `.par`): real files mutated (`flexcal_io::fuzz`) by byte flips, byte insertions and deletions,
//! truncations, duplicated and removed lines, and swapped numbers. Every
//! mutant must give a valid robot or a named error: no panic, no hang (each
//! case is bounded by the reader's own limits; the whole run takes about a
//! second). 10 000 cases per reader per run, on stable Rust.

use std::path::PathBuf;

use flexcal_io::fuzz::TextMutator;
use flexcal_kinematics::{
    ImportOptions, ImportedRobot, RobotDescription, forward_pose, urdf::UrdfRobot,
};

const CASES: usize = 10_000;

fn data(file: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(file);
    std::fs::read_to_string(path).unwrap()
}

/// A valid result must also be usable: build it and run the forward model once.
fn exercise(description: &RobotDescription) {
    if let Ok(model) = description.build() {
        let mut data = flexcal_kinematics::Data::new(&model);
        let q: Vec<f64> = model
            .actuated_limits()
            .iter()
            .map(|(lo, hi)| 0.5 * (lo + hi))
            .collect();
        let _ = forward_pose(&model, &mut data, &q, model.nominal_params());
    }
}

/// The mutants read by one reader: valid robots (each built and evaluated,
/// [`exercise`]) and errors, each of which must say what was wrong (and
/// start with `error_prefix`, the file's name, where the reader names it).
#[derive(Default)]
struct Outcomes {
    valid: usize,
    errors: usize,
}

impl Outcomes {
    fn count(
        &mut self,
        result: Result<&RobotDescription, impl std::fmt::Display>,
        error_prefix: &str,
    ) {
        match result {
            Ok(description) => {
                self.valid += 1;
                exercise(description);
            }
            Err(e) => {
                self.errors += 1;
                let message = e.to_string();
                assert!(
                    !message.is_empty() && message.starts_with(error_prefix),
                    "{message}"
                );
            }
        }
    }
}

#[test]
fn urdf_reader_survives_mutated_files() {
    let sources = [data("urdf/edge_cases.urdf"), data("urdf/irb6640_like.urdf")];
    let mut mutator = TextMutator::new(16);
    let mut outcomes = Outcomes::default();
    for case in 0..CASES {
        let text = mutator.mutate(&sources[case % sources.len()]);
        match UrdfRobot::parse(&text, "fuzz.urdf") {
            Ok(robot) => {
                let options = ImportOptions {
                    tip: Some("tip".into()).filter(|_| case % 3 != 0),
                    ..ImportOptions::default()
                };
                let imported = ImportedRobot::from_urdf(&robot, &options);
                outcomes.count(imported.as_ref().map(|i| &i.description), "");
            }
            Err(e) => outcomes.count(Err(e), "fuzz.urdf:"),
        }
    }
    let Outcomes { valid, errors } = outcomes;
    println!("URDF: {valid} valid, {errors} named errors of {CASES}");
    assert_eq!(valid + errors, CASES);
}

#[test]
fn toml_reader_survives_mutated_files() {
    let sources = [
        RobotDescription::builtin("ir663").unwrap().to_toml_string(),
        RobotDescription::builtin("ur10").unwrap().to_toml_string(),
    ];
    let mut mutator = TextMutator::new(17);
    let mut outcomes = Outcomes::default();
    for case in 0..CASES {
        let text = mutator.mutate(&sources[case % sources.len()]);
        let description = RobotDescription::from_toml_str(&text, "fuzz.toml");
        outcomes.count(description.as_ref(), "fuzz.toml:");
    }
    let Outcomes { valid, errors } = outcomes;
    println!("TOML: {valid} valid, {errors} named errors of {CASES}");
}

#[test]
fn par_reader_survives_mutated_files() {
    let dir = tempfile::tempdir().unwrap();
    let values = dir.path().join("values.toml");
    std::fs::write(
        &values,
        data("symoro/stanford_values.toml")
            + &data("symoro/rx90_values.toml")
            + &data("symoro/fourbar_values.toml"),
    )
    .unwrap();
    let sources = [
        data("symoro/rx90.par"),
        data("symoro/stanford.par"),
        data("symoro/fourbar.par"),
    ];
    let mut mutator = TextMutator::new(18);
    let mut outcomes = Outcomes::default();
    for case in 0..CASES {
        let text = mutator.mutate(&sources[case % sources.len()]);
        let options = ImportOptions {
            values: Some(values.clone()),
            tip: Some("2".into()).filter(|_| case % 3 == 2),
            ..ImportOptions::default()
        };
        let imported = ImportedRobot::from_par_str(&text, "fuzz.par", &options);
        outcomes.count(imported.as_ref().map(|i| &i.description), "");
    }
    let Outcomes { valid, errors } = outcomes;
    println!(".par: {valid} valid, {errors} named errors of {CASES}");
}

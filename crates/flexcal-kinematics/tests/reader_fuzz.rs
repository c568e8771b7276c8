//! Seeded fuzzing of the robot file readers (description TOML, URDF, SYMORO
//! `.par`): real files mutated by byte flips, byte insertions and deletions,
//! truncations, duplicated and removed lines, and swapped numbers. Every
//! mutant must give a valid robot or a named error: no panic, no hang (each
//! case is bounded by the reader's own limits; the whole run takes about a
//! second). 10 000 cases per reader per run, on stable Rust.

use std::path::PathBuf;

use flexcal_kinematics::{
    ImportOptions, ImportedRobot, RobotDescription, forward_pose, urdf::UrdfRobot,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const CASES: usize = 10_000;

fn data(file: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(file);
    std::fs::read_to_string(path).unwrap()
}

/// One random mutation of `text` (possibly several stacked).
fn mutate(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut bytes = text.as_bytes().to_vec();
    let rounds = rng.random_range(1..4);
    for _ in 0..rounds {
        if bytes.is_empty() {
            break;
        }
        let at = rng.random_range(0..bytes.len());
        match rng.random_range(0..8) {
            0 => bytes[at] ^= 1 << rng.random_range(0..8),
            1 => bytes.truncate(at),
            2 => {
                let b = *b"0123456789-.e<>/=\"{},( )*\n#[]";
                bytes.insert(at, b[rng.random_range(0..b.len())]);
            }
            3 => {
                bytes.remove(at);
            }
            4 | 5 => {
                // Duplicate or remove a line.
                let text = String::from_utf8_lossy(&bytes).into_owned();
                let mut lines: Vec<&str> = text.lines().collect();
                if lines.is_empty() {
                    continue;
                }
                let k = rng.random_range(0..lines.len());
                if rng.random_bool(0.5) {
                    lines.insert(k, lines[k]);
                } else {
                    lines.remove(k);
                }
                bytes = lines.join("\n").into_bytes();
            }
            6 => {
                // Replace a digit run by an extreme number.
                let choices: [&[u8]; 6] =
                    [b"1e308", b"-0", b"nan", b"inf", b"1e-320", b"99999999999"];
                let c = choices[rng.random_range(0..choices.len())];
                let end = (at + 1).min(bytes.len());
                bytes.splice(at..end, c.iter().copied());
            }
            _ => {
                // Swap two bytes far apart.
                let other = rng.random_range(0..bytes.len());
                bytes.swap(at, other);
            }
        }
    }
    String::from_utf8_lossy(&bytes).into_owned()
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

#[test]
fn urdf_reader_survives_mutated_files() {
    let sources = [data("urdf/edge_cases.urdf"), data("urdf/irb6640_like.urdf")];
    let mut rng = ChaCha8Rng::seed_from_u64(16);
    let (mut valid, mut errors) = (0, 0);
    for case in 0..CASES {
        let text = mutate(&sources[case % sources.len()], &mut rng);
        match UrdfRobot::parse(&text, "fuzz.urdf") {
            Ok(robot) => {
                let options = ImportOptions {
                    tip: Some("tip".into()).filter(|_| case % 3 != 0),
                    ..ImportOptions::default()
                };
                match ImportedRobot::from_urdf(&robot, &options) {
                    Ok(imported) => {
                        valid += 1;
                        exercise(&imported.description);
                    }
                    Err(e) => {
                        errors += 1;
                        assert!(!e.to_string().is_empty());
                    }
                }
            }
            Err(e) => {
                errors += 1;
                assert!(e.to_string().starts_with("fuzz.urdf:"), "{e}");
            }
        }
    }
    println!("URDF: {valid} valid, {errors} named errors of {CASES}");
    assert_eq!(valid + errors, CASES);
}

#[test]
fn toml_reader_survives_mutated_files() {
    let sources = [
        RobotDescription::builtin("ir663").unwrap().to_toml_string(),
        RobotDescription::builtin("ur10").unwrap().to_toml_string(),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let (mut valid, mut errors) = (0, 0);
    for case in 0..CASES {
        let text = mutate(&sources[case % sources.len()], &mut rng);
        match RobotDescription::from_toml_str(&text, "fuzz.toml") {
            Ok(description) => {
                valid += 1;
                exercise(&description);
            }
            Err(e) => {
                errors += 1;
                assert!(e.to_string().starts_with("fuzz.toml:"), "{e}");
            }
        }
    }
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
    let mut rng = ChaCha8Rng::seed_from_u64(18);
    let (mut valid, mut errors) = (0, 0);
    for case in 0..CASES {
        let text = mutate(&sources[case % sources.len()], &mut rng);
        let options = ImportOptions {
            values: Some(values.clone()),
            tip: Some("2".into()).filter(|_| case % 3 == 2),
            ..ImportOptions::default()
        };
        match ImportedRobot::from_par_str(&text, "fuzz.par", &options) {
            Ok(imported) => {
                valid += 1;
                exercise(&imported.description);
            }
            Err(e) => {
                errors += 1;
                assert!(!e.to_string().is_empty());
            }
        }
    }
    println!(".par: {valid} valid, {errors} named errors of {CASES}");
}

//! Seeded fuzzing of the target-path CSV reader: 10 000 mutants of a path
//! file (flexcal_io::fuzz) each give a path or a named error, never a panic.

use flexcal_compensate::path::{PathPoint, target_path_from_table, target_path_to_csv};
use flexcal_io::fuzz::TextMutator;
use flexcal_io::{CsvOptions, CsvTable};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

#[test]
fn path_reader_survives_mutated_files() {
    let points: Vec<PathPoint> = (0..20)
        .map(|k| PathPoint {
            line: 0,
            x_part_tcp: Isometry3::from_parts(
                Translation3::new(0.1 * k as f64, -0.02, 0.3),
                UnitQuaternion::from_euler_angles(3.1, 0.01 * k as f64, 0.2),
            ),
        })
        .collect();
    let source = target_path_to_csv(&points);
    let down = UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0);
    let mut mutator = TextMutator::new(22);
    let mut valid = 0;
    for _ in 0..10_000 {
        let text = mutator.mutate(&source);
        let result = CsvTable::from_str(&text, "fuzz.csv", &CsvOptions::default())
            .map_err(|e| e.to_string())
            .and_then(|t| target_path_from_table(&t, down).map_err(|e| e.to_string()));
        match result {
            Ok(path) => {
                valid += 1;
                let finite = |p: &PathPoint| {
                    p.x_part_tcp
                        .translation
                        .vector
                        .iter()
                        .all(|v| v.is_finite())
                };
                assert!(path.iter().all(finite));
            }
            Err(e) => assert!(e.contains("fuzz.csv"), "{e}"),
        }
    }
    println!("path CSV: {valid} valid of 10000");
}

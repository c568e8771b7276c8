//! Seeded fuzzing of the fuzzy-model readers (flexcal's TOML and the `.fis`
//! format): 10 000 mutants of a real model file each
//! (`flexcal_io::fuzz::TextMutator`); every mutant gives a model or a named
//! error, never a panic.

use flexcal_fuzzy::{Dataset, FuzzyModel, FuzzyParams};
use flexcal_io::fuzz::TextMutator;

const CASES: usize = 10_000;

/// A fitted two-input model, as `flexcal fuzzy fit` would write it.
fn fitted_model() -> FuzzyModel {
    let sample = |count: usize, shift: f64| {
        let a: Vec<f64> = (0..count)
            .map(|k| -2.0 + 5.0 * (k as f64 + shift) / count as f64)
            .collect();
        let b: Vec<f64> = (0..count)
            .map(|k| ((k as f64 + shift) * 0.37).sin() * 3.0)
            .collect();
        let y: Vec<f64> = a
            .iter()
            .zip(&b)
            .map(|(a, b)| 1.0 + 2.0 * a - b + 0.5 * a * b)
            .collect();
        Dataset::new(vec!["a".into(), "b".into()], "y".into(), &[a, b], y).unwrap()
    };
    FuzzyParams::default()
        .fit(&sample(60, 0.0), &sample(30, 0.5), &mut |_| {})
        .unwrap()
        .model
}

#[test]
fn toml_model_reader_survives_mutated_files() {
    let source = fitted_model().to_toml_string();
    FuzzyModel::from_toml_str(&source, "source.toml").expect("the source file is valid");
    let mut mutator = TextMutator::new(41);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&source);
        match FuzzyModel::from_toml_str(&text, "fuzz.toml") {
            Ok(model) => {
                valid += 1;
                // A model that reads back evaluates without panicking.
                let _ = model.evaluate(&[0.5, -0.5]);
            }
            Err(e) => assert!(e.to_string().contains("fuzz.toml"), "{e}"),
        }
    }
    println!("fuzzy model TOML: {valid} valid of {CASES}");
}

#[test]
fn fis_reader_survives_mutated_files() {
    let source = fitted_model().to_fis_string("fuzz");
    FuzzyModel::from_fis_str(&source).expect("the source file is valid");
    let mut mutator = TextMutator::new(42);
    let mut valid = 0;
    for _ in 0..CASES {
        let text = mutator.mutate(&source);
        match FuzzyModel::from_fis_str(&text) {
            Ok(model) => {
                valid += 1;
                let _ = model.evaluate(&[0.5, -0.5]);
            }
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
    println!("fuzzy model .fis: {valid} valid of {CASES}");
}

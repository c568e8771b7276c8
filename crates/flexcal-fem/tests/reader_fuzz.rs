//! Seeded fuzzing of the structure file reader: 10 000 mutants of the
//! example structures (flexcal_io::fuzz) each give a structure or a named
//! error, never a panic.

use std::path::{Path, PathBuf};

use flexcal_fem::StructureFile;
use flexcal_io::fuzz::TextMutator;

#[test]
fn structure_reader_survives_mutated_files() {
    let examples = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let sources = ["cantilever.toml", "joint_chain.toml"]
        .map(|f| std::fs::read_to_string(examples.join(f)).unwrap());
    let mut mutator = TextMutator::new(21);
    let mut valid = 0;
    for case in 0..10_000 {
        let text = mutator.mutate(&sources[case % 2]);
        match StructureFile::from_toml_str(&text, Path::new("fuzz.toml")) {
            Ok(_) => valid += 1,
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
    println!("structure file: {valid} valid of 10000");
}

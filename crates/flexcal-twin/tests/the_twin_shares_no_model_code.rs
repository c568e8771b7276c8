//! The import rule: the twin's truth shares no model code with what it
//! tests. Every path the twin's sources name in `flexcal_elastic`,
//! `flexcal_compensate` and `flexcal_calib` (the crates whose models the
//! twin's campaigns are used to test) must be one of the measurement and
//! path file formats; the nominal geometry comes from `flexcal_kinematics`,
//! which no identified model owns. A new import of a model, an estimator,
//! a process model or a constant of those crates fails this test by name.

use std::path::Path;

/// The crates whose models the twin tests.
const MODEL_CRATES: [&str; 3] = ["flexcal_elastic", "flexcal_compensate", "flexcal_calib"];

/// What the twin may use of them: the file formats and their errors.
const ALLOWED: [&str; 7] = [
    // The geometric campaign's measurement files.
    "flexcal_calib::Measurement",
    "flexcal_calib::MeasurementSet",
    "flexcal_calib::CalibError",
    // The elastic campaign's measurement files.
    "flexcal_elastic::campaign::PositionRow",
    "flexcal_elastic::campaign::write_position_rows",
    "flexcal_elastic::ElasticError",
    // The forming path's points.
    "flexcal_compensate::path::PathPoint",
];

/// `a::{b, c::{d, e}}` -> `a::b`, `a::c::d`, `a::c::e`.
fn expand(path: &str) -> Vec<String> {
    let path: String = path.chars().filter(|c| !c.is_whitespace()).collect();
    let Some(open) = path.find('{') else {
        return vec![path.trim_end_matches("::").to_string()];
    };
    let prefix = &path[..open];
    let inner = &path[open + 1..path.rfind('}').unwrap_or(path.len())];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (k, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.is_empty())
        .flat_map(|p| expand(&format!("{prefix}{p}")))
        .map(|p| p.trim_end_matches("::self").to_string())
        .collect()
}

/// Every path into a model crate named by `source` (comments left out),
/// with its line.
fn model_paths(source: &str) -> Vec<(usize, String)> {
    let code: Vec<&str> = source
        .lines()
        .map(|l| match l.find("//") {
            Some(k) => &l[..k],
            None => l,
        })
        .collect();
    let text = code.join("\n");
    let mut found = Vec::new();
    for krate in MODEL_CRATES {
        let pattern = format!("{krate}::");
        let mut from = 0;
        while let Some(k) = text[from..].find(&pattern) {
            let start = from + k;
            let before = text[..start].chars().last();
            from = start + pattern.len();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            // The path, braces included when it is a use tree.
            let mut depth = 0i32;
            let mut end = start;
            for (k, c) in text[start..].char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth > 0 => depth -= 1,
                    c if c.is_alphanumeric() || c == '_' || c == ':' => {}
                    ',' | ' ' | '\n' if depth > 0 => {}
                    _ => {
                        end = start + k;
                        break;
                    }
                }
                end = start + k + c.len_utf8();
            }
            let line = text[..start].matches('\n').count() + 1;
            found.extend(expand(&text[start..end]).into_iter().map(|p| (line, p)));
        }
    }
    found
}

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn the_twin_shares_no_model_code() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    files.sort();
    assert!(files.len() > 10, "{files:?}");
    let mut used = std::collections::BTreeSet::new();
    let mut forbidden = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (line, path) in model_paths(&text) {
            // A path may name an item's member (`Error::Variant`): the item decides.
            let allowed = ALLOWED
                .iter()
                .any(|a| path == *a || path.starts_with(&format!("{a}::")));
            if allowed {
                used.insert(path.clone());
            } else {
                forbidden.push(format!(
                    "{}:{line}: {path}",
                    file.strip_prefix(root).unwrap().display()
                ));
            }
        }
    }
    println!("the twin's imports from the model crates: {used:?}");
    assert!(
        forbidden.is_empty(),
        "the twin uses model code of the crates it tests:\n{}",
        forbidden.join("\n")
    );
    // The rule is checked on something: the formats are used.
    assert!(used.contains("flexcal_calib::MeasurementSet"), "{used:?}");
    assert!(
        used.contains("flexcal_compensate::path::PathPoint"),
        "{used:?}"
    );
}

#[test]
fn the_twin_depends_on_no_other_model_crate() {
    let manifest =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml")).unwrap();
    let dependencies = manifest
        .split("[dependencies]")
        .nth(1)
        .and_then(|s| s.split("\n[").next())
        .unwrap();
    let flexcal: Vec<&str> = dependencies
        .lines()
        .filter_map(|l| l.trim().split('.').next())
        .filter(|n| n.starts_with("flexcal-"))
        .collect();
    assert_eq!(
        flexcal,
        [
            "flexcal-io",
            "flexcal-kinematics",
            "flexcal-calib",
            "flexcal-elastic",
            "flexcal-compensate"
        ],
        "the twin depends on the nominal geometry, io and the file formats only"
    );
}

#[test]
fn the_listing_finds_use_trees_inline_paths_and_skips_comments() {
    let source = "use flexcal_elastic::{campaign::{PositionRow, write_position_rows}, model::ElasticModel};\n\
                  // flexcal_calib::calibrate is only named in a comment\n\
                  fn f() -> Result<(), flexcal_calib::CalibError> { flexcal_compensate::process::CantileverBeam::reference(x) }\n\
                  use my_flexcal_calib::Other;\n";
    let paths: Vec<String> = model_paths(source).into_iter().map(|(_, p)| p).collect();
    assert_eq!(
        paths,
        [
            "flexcal_elastic::campaign::PositionRow",
            "flexcal_elastic::campaign::write_position_rows",
            "flexcal_elastic::model::ElasticModel",
            "flexcal_compensate::process::CantileverBeam::reference",
            "flexcal_calib::CalibError",
        ]
    );
}

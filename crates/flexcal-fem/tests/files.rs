//! Structure files: parsing, round trips, error messages, and the example files.

use std::path::{Path, PathBuf};

use flexcal_fem::{
    Dof, FemError, FemModel, StructureFile, condensation_json, condensation_text,
    displacements_json, displacements_text,
};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

fn parse_toml(text: &str) -> Result<FemModel, FemError> {
    StructureFile::from_toml_str(text, Path::new("test.toml"))?.build()
}

const CANTILEVER: &str = r#"
nodes = { root = [0.0, 0.0, 0.0], tip = [2.0, 0.0, 0.0] }
supports = { root = [true, true, true, true, true, true] }
beams = [ { name = "b1", i = "root", j = "tip", E = 2.0e11, G = 8.0e10, A = 1e-3,
            Iy = 2e-6, Iz = 1e-6, J = 3e-6, vecxz = [0, 0, 1] } ]
load_cases = [ { name = "down", nodal_loads = { tip = [0.0, -100.0, 0.0, 0.0, 0.0, 0.0] } } ]
"#;

#[test]
fn every_example_file_solves_and_condenses() {
    for (file, node) in [
        ("cantilever.toml", "tip"),
        ("l_frame.json", "end"),
        ("joint_chain.toml", "tcp"),
    ] {
        let model = FemModel::read(example(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let cases = model.solve().unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(cases.len(), model.load_cases.len());
        let condensed = model
            .condense(node)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        // Condensed model (13) reproduces the full solve at the node.
        let n = model.structure.find_node(node).unwrap();
        for (case, (_, f_eq)) in cases.iter().zip(&condensed.f_eq) {
            let from_condensed = condensed.c_eq * f_eq;
            let full = case.nodes[n];
            assert!(
                (from_condensed - full).amax() <= 1e-9 * full.amax().max(1e-12),
                "{file}"
            );
        }
    }
}

#[test]
fn toml_and_json_round_trip_every_example() {
    let dir = tempfile::tempdir().unwrap();
    for file in ["cantilever.toml", "l_frame.json", "joint_chain.toml"] {
        let original = StructureFile::read(example(file)).unwrap();
        for ext in ["toml", "json"] {
            let path = dir.path().join(format!("copy.{ext}"));
            original.write(&path).unwrap();
            let back = StructureFile::read(&path).unwrap();
            assert_eq!(back, original, "{file} through {ext}");
        }
    }
}

#[test]
fn node_order_of_the_file_is_kept_in_output() {
    let text = r#"
nodes = { zeta = [0.0, 0.0, 0.0], alpha = [1.0, 0.0, 0.0], mid = [2.0, 0.0, 0.0] }
supports = { zeta = [true, true, true, true, true, true] }
beams = [
  { name = "b1", i = "zeta", j = "alpha", E = 2.0e11, G = 8.0e10, A = 1e-3, Iy = 2e-6, Iz = 1e-6, J = 3e-6, vecxz = [0, 0, 1] },
  { name = "b2", i = "alpha", j = "mid", E = 2.0e11, G = 8.0e10, A = 1e-3, Iy = 2e-6, Iz = 1e-6, J = 3e-6, vecxz = [0, 0, 1] },
]
load_cases = [ { name = "z", nodal_loads = { mid = [0, 0, 1, 0, 0, 0] } }, { name = "a", nodal_loads = { alpha = [1, 0, 0, 0, 0, 0] } } ]
"#;
    let model = parse_toml(text).unwrap();
    assert_eq!(model.structure.node_names(), ["zeta", "alpha", "mid"]);
    let json = displacements_json(&model.structure, &model.solve().unwrap());
    let zeta = json.find("\"zeta\"").unwrap();
    let alpha = json.find("\"alpha\"").unwrap();
    let mid = json.find("\"mid\"").unwrap();
    assert!(zeta < alpha && alpha < mid, "{json}");
    assert!(json.find("\"z\":").unwrap() < json.find("\"a\":").unwrap());
    // The output is valid JSON of exactly the specified shape.
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    let tip = &value["load_cases"]["z"]["mid"];
    assert_eq!(tip.as_array().unwrap().len(), 6);
    assert_eq!(value.as_object().unwrap().len(), 1);
}

#[test]
fn text_output_holds_the_same_values_as_json() {
    let model = parse_toml(CANTILEVER).unwrap();
    let cases = model.solve().unwrap();
    let text = displacements_text(&model.structure, &cases);
    let tip: Vec<f64> = text
        .lines()
        .find(|l| l.starts_with("tip "))
        .unwrap()
        .split_whitespace()
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(tip.as_slice(), cases[0].nodes[1].as_slice());
    let condensed = model.condense("tip").unwrap();
    let text = condensation_text(&condensed, "tip");
    let lines: Vec<&str> = text.lines().collect();
    // Title, K_eq title and 6 rows, C_eq title and 6 rows, F_eq title, one case.
    assert_eq!(lines.len(), 1 + 7 + 7 + 1 + 1, "{text}");
    let c_uy: Vec<f64> = lines[10]
        .split_whitespace()
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(c_uy[1], condensed.c_eq[(1, 1)]);
    assert_eq!(lines[16].split_whitespace().nth(2), Some("-1e2"));
}

#[test]
fn json_output_holds_full_precision_values() {
    let model = parse_toml(CANTILEVER).unwrap();
    let cases = model.solve().unwrap();
    let json = displacements_json(&model.structure, &cases);
    // serde_json's default float parser is best-effort (it may miss the
    // last bit); read the printed text back with Rust's exact parser.
    let down = &json[json.find("\"down\": {").unwrap()..];
    let tip = &down[down.find("\"tip\": [").unwrap() + 8..];
    let printed: Vec<f64> = tip[..tip.find(']').unwrap()]
        .split(", ")
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(printed.as_slice(), cases[0].nodes[1].as_slice());
    let uy = printed[1];
    assert!((uy - -100.0 * 8.0 / (3.0 * 2.0e11 * 1e-6)).abs() < 1e-15);

    let condensed = model.condense("tip").unwrap();
    let value: serde_json::Value = serde_json::from_str(&condensation_json(&condensed)).unwrap();
    assert_eq!(value["K_eq"].as_array().unwrap().len(), 6);
    assert_eq!(value["C_eq"][1].as_array().unwrap().len(), 6);
    let c_yy = value["C_eq"][1][1].as_f64().unwrap();
    assert!((c_yy - condensed.c_eq[(1, 1)]).abs() <= 1e-15 * c_yy.abs());
    assert_eq!(value["F_eq"]["down"][1].as_f64().unwrap(), -100.0);
}

fn error_of(text: &str) -> String {
    match parse_toml(text).and_then(|m| m.solve().map(|_| ())) {
        Ok(()) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_input_gives_errors_naming_element_and_field() {
    let unknown = CANTILEVER.replace("j = \"tip\"", "j = \"tipp\"");
    let msg = error_of(&unknown);
    assert!(msg.contains("beam 'b1'") && msg.contains("tipp"), "{msg}");

    let negative = CANTILEVER.replace("Iy = 2e-6", "Iy = -2e-6");
    let msg = error_of(&negative);
    assert!(msg.contains("beam 'b1'") && msg.contains("'Iy'"), "{msg}");

    let not_a_number = CANTILEVER.replace("E = 2.0e11", "E = nan");
    let msg = error_of(&not_a_number);
    assert!(msg.contains("'E'"), "{msg}");

    let short = CANTILEVER.replace("vecxz = [0, 0, 1]", "vecxz = [0, 1]");
    let msg = error_of(&short);
    assert!(msg.contains("'vecxz'") && msg.contains("3 values"), "{msg}");

    let parallel = CANTILEVER.replace("vecxz = [0, 0, 1]", "vecxz = [3, 0, 0]");
    let msg = error_of(&parallel);
    assert!(msg.contains("beam 'b1'") && msg.contains("vecxz"), "{msg}");

    let zero_length = CANTILEVER.replace("tip = [2.0, 0.0, 0.0]", "tip = [0.0, 0.0, 0.0]");
    let msg = error_of(&zero_length);
    assert!(
        msg.contains("beam 'b1'") && msg.contains("zero length"),
        "{msg}"
    );

    let wrong_load = CANTILEVER.replace("[0.0, -100.0, 0.0, 0.0, 0.0, 0.0]", "[0.0, -100.0]");
    let msg = error_of(&wrong_load);
    assert!(
        msg.contains("load case 'down'") && msg.contains("6 values"),
        "{msg}"
    );

    let typo = CANTILEVER.replace("vecxz", "vec_xz");
    let msg = error_of(&typo);
    assert!(msg.contains("vec_xz"), "{msg}");

    let bad_support = CANTILEVER.replace("[true, true, true, true, true, true]", "[true]");
    let msg = error_of(&bad_support);
    assert!(msg.contains("supports") && msg.contains("root"), "{msg}");
}

#[test]
fn a_structure_error_read_from_a_file_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("unknown_node.toml");
    std::fs::write(&path, CANTILEVER.replace("j = \"tip\"", "j = \"tipp\"")).unwrap();
    let err = FemModel::read(&path).unwrap_err();
    assert!(matches!(err, FemError::InFile { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    assert!(msg.contains("beam 'b1'") && msg.contains("tipp"), "{msg}");
}

#[test]
fn singular_structures_name_the_node_and_dof() {
    // An unconnected node.
    let lonely = CANTILEVER.replace(
        "tip = [2.0, 0.0, 0.0] }",
        "tip = [2.0, 0.0, 0.0], lonely = [5.0, 5.0, 5.0] }",
    );
    match parse_toml(&lonely).unwrap().solve() {
        Err(FemError::Singular { node, dof, .. }) => {
            assert_eq!(node, "lonely");
            assert_eq!(dof, Dof::Ux);
        }
        other => panic!("{other:?}"),
    }
    // Torsion released at both ends: the tip spins freely about x.
    let spinning = CANTILEVER.replace(
        "vecxz = [0, 0, 1] }",
        "vecxz = [0, 0, 1], releases = [false, false, false, true, false, false, false, false, false, true, false, false] }",
    );
    let err = parse_toml(&spinning).unwrap().solve().unwrap_err();
    match &err {
        FemError::Singular { node, dof, .. } => {
            assert_eq!(node, "tip");
            assert_eq!(*dof, Dof::Rx);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("node 'tip'") && err.to_string().contains("rx"));
    // No support at all: rigid-body motion.
    let floating = CANTILEVER.replace(
        "supports = { root = [true, true, true, true, true, true] }",
        "",
    );
    assert!(matches!(
        parse_toml(&floating).unwrap().solve(),
        Err(FemError::Singular { .. })
    ));
}

#[test]
fn condensing_onto_a_supported_or_unknown_node_is_an_error() {
    let model = parse_toml(CANTILEVER).unwrap();
    assert!(matches!(
        model.condense("root"),
        Err(FemError::CondensedNodeSupported { .. })
    ));
    assert!(matches!(
        model.condense("nowhere"),
        Err(FemError::UnknownNode { .. })
    ));
}

#[test]
fn json_duplicate_names_and_unknown_extension_are_rejected() {
    let json = r#"{"nodes": {"a": [0, 0, 0], "a": [1, 0, 0]}}"#;
    let err = StructureFile::from_json_str(json, Path::new("x.json")).unwrap_err();
    assert!(err.to_string().contains("duplicate name 'a'"), "{err}");
    let err = StructureFile::read("structure.yaml").unwrap_err();
    assert!(matches!(err, FemError::UnknownExtension { .. }));
}

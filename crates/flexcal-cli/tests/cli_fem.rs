//! `flexcal fem solve` and `flexcal fem condense` run end to end on temporary files.

use std::path::Path;

mod common;
use common::flexcal;

const E: f64 = 2.0e11;
const IZ: f64 = 1e-6;
const IY: f64 = 2e-6;

const CANTILEVER: &str = r#"
nodes = { root = [0.0, 0.0, 0.0], tip = [2.0, 0.0, 0.0] }
supports = { root = [true, true, true, true, true, true] }
beams = [ { name = "b1", i = "root", j = "tip", E = 2.0e11, G = 8.0e10, A = 1e-3,
            Iy = 2e-6, Iz = 1e-6, J = 3e-6, vecxz = [0, 0, 1] } ]
load_cases = [
  { name = "down", nodal_loads = { tip = [0.0, -100.0, 0.0, 0.0, 0.0, 0.0] } },
  { name = "side", nodal_loads = { tip = [0.0, 0.0, 50.0, 0.0, 0.0, 0.0] } },
]
"#;

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn solve_json_gives_closed_form_cantilever_deflections() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "cantilever.toml", CANTILEVER);
    let out = flexcal(&["fem", "solve", &file, "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let value: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let down = value["load_cases"]["down"]["tip"].as_array().unwrap();
    let uy = down[1].as_f64().unwrap();
    assert!((uy - -100.0 * 8.0 / (3.0 * E * IZ)).abs() < 1e-15);
    let side = value["load_cases"]["side"]["tip"].as_array().unwrap();
    let uz = side[2].as_f64().unwrap();
    assert!((uz - 50.0 * 8.0 / (3.0 * E * IY)).abs() < 1e-15);
    let root = value["load_cases"]["down"]["root"].as_array().unwrap();
    assert!(root.iter().all(|v| v.as_f64() == Some(0.0)));
}

#[test]
fn solve_json_and_toml_inputs_agree_and_the_table_lists_every_node() {
    let dir = tempfile::tempdir().unwrap();
    let toml_file = write(dir.path(), "c.toml", CANTILEVER);
    let structure: toml::Value = toml::from_str(CANTILEVER).unwrap();
    let json_file = write(
        dir.path(),
        "c.json",
        &serde_json::to_string(&structure).unwrap(),
    );
    let a = flexcal(&["fem", "solve", &toml_file, "--json"]);
    let b = flexcal(&["fem", "solve", &json_file, "--json"]);
    assert!(a.status.success() && b.status.success());
    let va: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let vb: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    assert_eq!(va, vb);

    let table = flexcal(&["fem", "solve", &toml_file]);
    assert!(table.status.success());
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(text.contains("load case 'down'") && text.contains("load case 'side'"));
    assert!(text.contains("root") && text.contains("tip") && text.contains("rz"));
}

#[test]
fn condense_json_gives_k_eq_c_eq_and_f_eq() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "cantilever.toml", CANTILEVER);
    let out = flexcal(&["fem", "condense", &file, "--node", "tip", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let value: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c_yy = value["C_eq"][1][1].as_f64().unwrap();
    assert!((c_yy - 8.0 / (3.0 * E * IZ)).abs() < 1e-15);
    let k_yy = value["K_eq"][1][1].as_f64().unwrap();
    assert!((k_yy - 12.0 * E * IZ / 8.0).abs() < 1e-6 * k_yy);
    assert_eq!(value["F_eq"]["down"][1].as_f64(), Some(-100.0));
    assert_eq!(value["F_eq"]["side"].as_array().unwrap().len(), 6);

    let text = flexcal(&["fem", "condense", &file, "--node", "tip"]);
    assert!(text.status.success());
    assert!(String::from_utf8_lossy(&text.stdout).contains("K_eq"));
}

#[test]
fn bad_input_exits_non_zero_with_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let unknown = write(
        dir.path(),
        "bad.toml",
        &CANTILEVER.replace("j = \"tip\"", "j = \"tipp\""),
    );
    let out = flexcal(&["fem", "solve", &unknown]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("tipp") && err.contains("beam 'b1'"), "{err}");

    let singular = write(
        dir.path(),
        "floating.toml",
        &CANTILEVER.replace(
            "supports = { root = [true, true, true, true, true, true] }",
            "",
        ),
    );
    let out = flexcal(&["fem", "solve", &singular, "--json"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("singular structure"));

    let out = flexcal(&[
        "fem",
        "condense",
        &unknown.replace("bad", "missing"),
        "--node",
        "tip",
    ]);
    assert!(!out.status.success());

    let broken = write(dir.path(), "broken.toml", "nodes = { a = [0, 0, 0] ");
    let out = flexcal(&["fem", "solve", &broken]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
}

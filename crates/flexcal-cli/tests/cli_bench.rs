//! `flexcal bench` end to end: every core operation is timed and reported.

mod common;
use common::{flexcal, stderr};

#[test]
fn bench_times_every_core_operation() {
    let out = flexcal(&["bench", "--json", "--budget-ms", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let operations = json["operations"].as_array().unwrap();
    let names: Vec<&str> = operations
        .iter()
        .map(|o| o["name"].as_str().unwrap())
        .collect();
    for expected in ["ur10", "ir663", "fuzzy", "condensation", "10000-point path"] {
        assert!(
            names.iter().any(|n| n.contains(expected)),
            "no operation named like `{expected}` in {names:?}"
        );
    }
    for o in operations {
        let ns = o["ns_per_op"].as_f64().unwrap();
        assert!(ns.is_finite() && ns > 0.0, "{o}");
        assert!(o["iterations"].as_u64().unwrap() >= 1, "{o}");
    }
}

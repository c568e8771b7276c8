//! The plan's bounds on the IPA UR10 data: planned from series C's (or
//! B's) configurations alone, calibrated on its measurements, validated on
//! the other series. Skips with a message when the data is absent. The
//! figures are in docs/planning.md.

use std::io::Write as _;
use std::path::PathBuf;

use flexcal::plan::ipa_check::ipa_plan_check;

fn series(name: &str, file: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/datasets/ipa-ur10")
        .join(name)
        .join(file);
    if path.exists() {
        return Some(path);
    }
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED: IPA UR10 data absent ({})",
        path.display()
    );
    None
}

#[test]
fn planned_bounds_on_the_ipa_pairs() {
    let (Some(b), Some(c)) = (
        series("Series_B", "measurements_joint_configurations.csv"),
        series("Series_C", "measurements_random_poses.csv"),
    ) else {
        return;
    };
    let model = flexcal::load_robot("ur10").unwrap();
    for (pair, train, validate) in [("C -> B", &c, &b), ("B -> C", &b, &c)] {
        let check = ipa_plan_check(&model, pair, train, validate, 0.02).unwrap();
        let _ = writeln!(
            std::io::stderr(),
            "{}",
            serde_json::to_string(&check).unwrap()
        );
        // Every miss is inside the training ranges or outside at least one.
        let misses = check.poses - (check.coverage * check.poses as f64).round() as usize;
        let outside: usize = check.misses_outside.iter().map(|(_, n)| n).sum();
        assert!(check.misses_inside <= misses, "{check:?}");
        assert!(check.misses_inside + outside >= misses, "{check:?}");
        assert!(check.predicted_mean_bound_95_mm > 0.0 && check.achieved_mean_error_mm > 0.0);
    }
}

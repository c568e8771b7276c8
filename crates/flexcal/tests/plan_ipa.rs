//! The plan's bounds on the IPA UR10 data: planned from series C's (or
//! B's) configurations alone, calibrated on its measurements, validated on
//! the other series; the plan's noise either the tracker's stated noise or
//! the residual scatter of an earlier campaign (series D). Skips with a
//! message when the data is absent. The figures are in docs/planning.md.

use std::io::Write as _;
use std::path::PathBuf;

use flexcal::plan::ipa_check::{IpaPlanCheck, ipa_plan_check, prior_residual_scatter_mm};

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

/// The misses' accounting, recomputed from the coverage: explained and
/// unexplained misses add up, no coordinate counts more misses than poses.
fn check_accounting(check: &IpaPlanCheck) {
    let misses = check.poses - (check.coverage * check.poses as f64).round() as usize;
    let m = &check.misses;
    assert_eq!(m.all.entries, check.poses, "{check:?}");
    assert_eq!(m.all.misses, misses, "{check:?}");
    assert_eq!(m.explained() + m.inside.misses, misses, "{check:?}");
    for c in &m.coordinates {
        assert!(c.outside.misses <= c.outside.entries.min(m.explained()));
    }
    assert!(check.predicted_mean_bound_95_mm > 0.0 && check.achieved_mean_error_mm > 0.0);
}

#[test]
fn planned_bounds_on_the_ipa_pairs() {
    let (Some(b), Some(c), Some(d)) = (
        series("Series_B", "measurements_joint_configurations.csv"),
        series("Series_C", "measurements_random_poses.csv"),
        series("Series_D", "measurements_iso_cubes.csv"),
    ) else {
        return;
    };
    let model = flexcal::load_robot("ur10").unwrap();
    let floor_mm = prior_residual_scatter_mm(&model, &d).unwrap();
    // What a calibration of the UR10 leaves is well above the tracker's
    // stated noise (the reason the stated noise's bounds miss).
    assert!(floor_mm > 0.02, "series D's residual scatter {floor_mm} mm");
    for (pair, train, validate) in [("C -> B", &c, &b), ("B -> C", &b, &c)] {
        let stated = ipa_plan_check(&model, pair, train, validate, 0.02, "tracker").unwrap();
        let floor = ipa_plan_check(
            &model,
            pair,
            train,
            validate,
            floor_mm,
            "series D's residual scatter",
        )
        .unwrap();
        // For reference, the training series' own scatter: known only after
        // measuring it, what `calibrate`'s own bound starts from.
        let own_mm = prior_residual_scatter_mm(&model, train).unwrap();
        let own = ipa_plan_check(
            &model,
            pair,
            train,
            validate,
            own_mm,
            "own residual scatter",
        )
        .unwrap();
        for check in [&stated, &floor, &own] {
            let _ = writeln!(
                std::io::stderr(),
                "{} ({} {:.4} mm): coverage {:.1} %, mean bound {:.4} mm, mean error {:.4} mm; {}",
                check.pair,
                check.noise_source,
                check.noise_mm,
                100.0 * check.coverage,
                check.predicted_mean_bound_95_mm,
                check.achieved_mean_error_mm,
                check.misses.summary()
            );
            check_accounting(check);
        }
        // The same poses and calibration: a larger stated noise gives larger
        // bounds and so covers at least as many poses.
        assert_eq!(stated.achieved_mean_error_mm, floor.achieved_mean_error_mm);
        assert!(floor.predicted_mean_bound_95_mm > stated.predicted_mean_bound_95_mm);
        assert!(floor.coverage >= stated.coverage);
    }
}

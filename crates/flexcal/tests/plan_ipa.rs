//! The plan's bounds on the IPA UR10 data: planned from series C's (or
//! B's) configurations alone, calibrated on its measurements, validated on
//! the other series; the plan's noise either the tracker's stated noise or
//! the residual scatter of an earlier campaign (series D), and the plan
//! with series D's calibration as its prior (`plan --prior`: its model,
//! floor, split-half inflation and extrapolation growth). Skips with a
//! message when the data is absent. The figures are in docs/planning.md.

use std::io::Write as _;
use std::path::PathBuf;

use flexcal::plan::ipa_check::{
    IpaPlanCheck, TRACKER_NOISE_MM, ipa_plan_check, ipa_prior, ipa_prior_check,
    prior_residual_scatter_mm,
};

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
    // The bound's parts add up in squares, point by point, so their means
    // cannot exceed the mean bound.
    let p = &check.misses;
    assert!(p.all.entries > 0);
    let parts = check.mean_parts_mm;
    for part in [
        parts.scatter_mm,
        parts.parameters_mm,
        parts.extrapolation_mm,
    ] {
        assert!(part <= check.predicted_mean_bound_95_mm + 1e-9, "{check:?}");
    }
}

fn print(check: &IpaPlanCheck) {
    let p = check.mean_parts_mm;
    let _ = writeln!(
        std::io::stderr(),
        "{} [{}] ({} {:.4} mm, inflation {:.2}): coverage {:.1} %, mean bound {:.4} mm (parts: scatter {:.4}, parameters {:.4}, extrapolation {:.4}), mean error {:.4} mm; {}",
        check.pair,
        check.model,
        check.noise_source,
        check.noise_mm,
        check.inflation,
        100.0 * check.coverage,
        check.predicted_mean_bound_95_mm,
        p.scatter_mm,
        p.parameters_mm,
        p.extrapolation_mm,
        check.achieved_mean_error_mm,
        check.misses.summary()
    );
}

/// Series B, C and D's files, or `None` (each absent one said) when the
/// data is not there.
fn series_b_c_d() -> Option<(PathBuf, PathBuf, PathBuf)> {
    let b = series("Series_B", "measurements_joint_configurations.csv");
    let c = series("Series_C", "measurements_random_poses.csv");
    let d = series("Series_D", "measurements_iso_cubes.csv");
    Some((b?, c?, d?))
}

#[test]
fn planned_bounds_on_the_ipa_pairs() {
    let Some((b, c, d)) = series_b_c_d() else {
        return;
    };
    let model = flexcal::load_robot("ur10").unwrap();
    let floor_mm = prior_residual_scatter_mm(&model, &d).unwrap();
    // What a calibration of the UR10 leaves is well above the tracker's
    // stated noise (the reason the stated noise's bounds miss).
    assert!(floor_mm > 0.02, "series D's residual scatter {floor_mm} mm");
    for (pair, train, validate) in [("C -> B", &c, &b), ("B -> C", &b, &c)] {
        let files = (train.as_path(), validate.as_path());
        let stated = ipa_plan_check(&model, pair, files, TRACKER_NOISE_MM, "tracker").unwrap();
        let floor =
            ipa_plan_check(&model, pair, files, floor_mm, "series D's residual scatter").unwrap();
        // For reference, the training series' own scatter: known only after
        // measuring it, what `calibrate`'s own bound starts from.
        let own_mm = prior_residual_scatter_mm(&model, train).unwrap();
        let own = ipa_plan_check(&model, pair, files, own_mm, "own residual scatter").unwrap();
        for check in [&stated, &floor, &own] {
            print(check);
            check_accounting(check);
        }
        // The same poses and calibration: a larger stated noise gives larger
        // bounds and so covers at least as many poses.
        assert_eq!(stated.achieved_mean_error_mm, floor.achieved_mean_error_mm);
        assert!(floor.predicted_mean_bound_95_mm > stated.predicted_mean_bound_95_mm);
        assert!(floor.coverage >= stated.coverage);
    }
}

#[test]
fn planned_bounds_with_series_d_as_prior() {
    let Some((b, c, d)) = series_b_c_d() else {
        return;
    };
    let model = flexcal::load_robot("ur10").unwrap();
    let prior = ipa_prior(&model, &d).unwrap();
    let growth = prior.extrapolation.as_ref().expect("the prior's growth");
    let _ = writeln!(
        std::io::stderr(),
        "prior (series D): {} model, groups {:?}, residual scatter {:.4} mm, split-half prediction ratio {:.3}, growth {}",
        prior.model,
        prior.chosen_groups,
        prior.residual_scatter_mm,
        prior.prediction_ratio,
        growth
            .growth
            .iter()
            .map(|g| format!(
                "{} {:.4} mm/deg (measured to {:.1} deg out)",
                g.coordinate,
                g.growth * 1e3 * 1f64.to_radians(),
                g.max_distance.to_degrees()
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    assert!(prior.residual_scatter_mm > TRACKER_NOISE_MM);
    // The parts of the prior one by one, to say which carries over.
    let floor_only = flexcal::plan::Prior {
        prediction_ratio: 1.0,
        extrapolation: None,
        ..prior.clone()
    };
    let inflated = flexcal::plan::Prior {
        extrapolation: None,
        ..prior.clone()
    };
    for (pair, train, validate) in [("C -> B", &c, &b), ("B -> C", &b, &c)] {
        let files = (train.as_path(), validate.as_path());
        let rows: Vec<IpaPlanCheck> = [
            (&floor_only, "prior D: its model and floor"),
            (&inflated, "prior D: + its inflation"),
            (&prior, "prior D: + its growth (plan --prior)"),
        ]
        .into_iter()
        .map(|(p, name)| ipa_prior_check(&model, pair, files, p, name).unwrap())
        .collect();
        for check in &rows {
            print(check);
            check_accounting(check);
            assert!((check.noise_mm - prior.residual_scatter_mm).abs() < 1e-9);
        }
        // One calibration for every row; each part of the prior can only
        // widen the bounds, so covers at least as many poses.
        for pair in rows.windows(2) {
            assert_eq!(
                pair[0].achieved_mean_error_mm,
                pair[1].achieved_mean_error_mm
            );
            assert!(pair[1].predicted_mean_bound_95_mm >= pair[0].predicted_mean_bound_95_mm);
            assert!(pair[1].coverage >= pair[0].coverage);
        }
        assert!((rows[1].inflation - prior.prediction_ratio.max(1.0)).abs() < 1e-12);
        assert_eq!(rows[0].mean_parts_mm.extrapolation_mm, 0.0);
    }
}

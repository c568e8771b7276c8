//! A plan with an earlier calibration as its prior: the report read back,
//! bad reports refused by name, and each part of the prior checked
//! against the plan without it.

use rand::{Rng, SeedableRng};

use super::tests::{ur10, ur10_box};
use super::*;

fn options(model: &Model) -> CalibrationOptions {
    let mut options = CalibrationOptions::for_model(model);
    options.target = calib::FrameTreatment::Fixed;
    options
}

/// The JSON report (`calibrate --report --split-check`) of a calibration
/// of 60 poses of the nominal UR10 measured with seeded noise of 0.1 mm
/// standard deviation per axis, and that calibration's residual scatter (mm) and split-half
/// ratio.
fn earlier_report(model: &Model) -> (String, f64, f64) {
    let q: Vec<Vec<f64>> = ur10_box()
        .sample(model, 60, 11, "earlier")
        .unwrap()
        .into_iter()
        .map(|c| c.value)
        .collect();
    let options = options(model);
    let targets = planned_targets(&options, None);
    let x = nominal_target_poses(model, &targets, &q).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    // Uniform noise of 0.1 mm standard deviation per axis.
    let half_width = 0.1e-3 * 3f64.sqrt();
    let poses = q
        .iter()
        .zip(&x)
        .map(|(q, x)| {
            let e = Vector3::from_fn(|_, _| rng.random_range(-half_width..half_width));
            TargetPose::new(
                None,
                q.clone(),
                vec![Some(TargetObservation::new(x[0].translation.vector + e))],
            )
        })
        .collect();
    let set = MeasurementSet::from_poses("earlier", targets, poses).unwrap();
    let calibration = calib::calibrate(model, &set, &options).unwrap();
    let split = calib::SplitCheck::new(model, &set, &options, &calibration).unwrap();
    let ratio = split.prediction_ratio.unwrap();
    let mut report = calib::CalibrationReportJson::new(model.name(), &calibration, None);
    report.split_check = Some(split);
    (
        serde_json::to_string(&report).unwrap(),
        calibration.residual_scatter() * 1e3,
        ratio,
    )
}

#[test]
fn a_calibration_report_is_read_as_a_prior_and_bad_ones_are_refused() {
    let model = ur10();
    let (text, scatter_mm, ratio) = earlier_report(&model);
    let prior = Prior::from_report_str(&text, "earlier.json").unwrap();
    assert_eq!(prior.robot, "ur10");
    assert_eq!(prior.model, "geometric");
    assert_eq!(prior.chosen_groups, None);
    assert_eq!(prior.extrapolation, None);
    assert!((prior.residual_scatter_mm - scatter_mm).abs() < 1e-12 * scatter_mm);
    assert!((prior.residual_scatter_mm - 0.1).abs() < 0.03, "{prior:?}");
    // serde_json's parsing is within an ulp or two of the written value.
    assert!((prior.prediction_ratio - ratio).abs() < 1e-12 * ratio);
    assert_eq!(prior.inflation(), prior.prediction_ratio.max(1.0));
    prior.check(&model).unwrap();
    // Another robot's prior.
    let other = crate::load_robot("ir663").unwrap();
    let err = prior.check(&other).unwrap_err().to_string();
    assert!(err.contains("a calibration of 'ur10', not of"), "{err}");
    // Reports without the statistics, and what is not a report.
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let without = |pointer: &str, key: &str| {
        let mut v = value.clone();
        v.pointer_mut(pointer)
            .unwrap()
            .as_object_mut()
            .unwrap()
            .remove(key);
        v.to_string()
    };
    let mut zero = value.clone();
    zero["identification"]["residual_scatter_mm"] = 0.0.into();
    for (text, expected) in [
        (
            without("", "split_check"),
            "calibrate the prior with --split-check",
        ),
        (
            without("/identification", "residual_scatter_mm"),
            "no identification.residual_scatter_mm",
        ),
        (
            zero.to_string(),
            "residual_scatter_mm must be finite and > 0",
        ),
        ("q1,q2\n0,1".to_string(), "not a calibration report"),
    ] {
        let err = Prior::from_report_str(&text, "old.json")
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("old.json: "), "{err}");
        assert!(err.contains(expected), "{err}");
    }
}

/// A prior of `scatter_mm`, `ratio` and a growth of `growth` (m/rad) per
/// joint whose own ranges are those of one configuration (the plan must
/// use the planned poses' ranges instead).
fn prior(model: &Model, scatter_mm: f64, ratio: f64, growth: Option<f64>) -> Prior {
    let q0 = [0.0; 6];
    let extrapolation = growth.map(|g| calib::ExtrapolationModel {
        ranges: calib::CoordinateCoverage::of_configurations(model, &[&q0[..]]),
        growth: model
            .actuated_names()
            .iter()
            .map(|name| calib::CoordinateGrowth {
                coordinate: name.clone(),
                growth: g,
                max_distance: 0.5,
            })
            .collect(),
        folds: Vec::new(),
        n_observations: 0,
    });
    Prior {
        source: "test prior".into(),
        robot: model.name().into(),
        model: "geometric".into(),
        chosen_groups: None,
        residual_scatter_mm: scatter_mm,
        prediction_ratio: ratio,
        extrapolation,
    }
}

fn plan_with(model: &Model, prior: Option<Prior>) -> CampaignPlan {
    let mut config = PlanConfig::new(
        options(model),
        [0.02, 0.02, 0.03],
        PoseSource::Box {
            joint_box: ur10_box(),
            count: 50,
            seed: 1,
        },
        PoseSource::Box {
            joint_box: ur10_box(),
            count: 30,
            seed: 2,
        },
    );
    config.count = Some(25);
    config.max_poses = Some(30);
    config.prior = prior;
    plan_campaign(model, &config).unwrap()
}

/// With a prior whose scatter lies below the instrument's noise the
/// poses are those of the plan without it; every identification part is
/// the ratio times larger, the scatter part unchanged, the growth added
/// at the distance outside the planned poses' ranges (zero inside), and
/// the bound the root sum of squares of the parts.
#[test]
fn the_prior_inflates_the_identification_and_adds_its_growth_outside_the_planned_ranges() {
    let model = ur10();
    let without = plan_with(&model, None);
    let g = 2e-3;
    let with = plan_with(&model, Some(prior(&model, 0.01, 2.0, Some(g))));
    assert_eq!(with.selected, without.selected);
    let used = with.prior.as_ref().unwrap();
    assert_eq!(used.floor_mm, [0.02, 0.02, 0.03]);
    assert_eq!(used.inflation, 2.0);
    let planned: Vec<&[f64]> = with.configurations.iter().map(|q| &q[..]).collect();
    let ranges = calib::CoordinateCoverage::of_configurations(&model, &planned);
    let mut outside = 0;
    for (a, b) in without
        .prediction
        .map
        .poses
        .iter()
        .zip(&with.prediction.map.poses)
    {
        assert!((b.parts.parameters_mm - 2.0 * a.parts.parameters_mm).abs() < 1e-9);
        assert!((b.parts.scatter_mm - a.parts.scatter_mm).abs() < 1e-12);
        let variance: f64 = ranges
            .iter()
            .zip(&b.q)
            .map(|(r, q)| (g * r.distance_outside(*q)).powi(2))
            .sum();
        let expected = (calib::CHI2_3_95 * variance).sqrt() * 1e3;
        assert!((b.parts.extrapolation_mm - expected).abs() < 1e-9, "{b:?}");
        assert_eq!(
            b.parts.extrapolation_mm > 0.0,
            !b.outside_training_range.is_empty()
        );
        outside += usize::from(!b.outside_training_range.is_empty());
        assert!((b.bound_95_mm - b.parts.bound_mm()).abs() < 1e-12);
    }
    assert!(outside > 0, "no region point outside the planned ranges");
    // The curve has the inflation: its largest bound is the largest
    // bound without it, inflated (a monotone map of the same point's).
    let s2 = config_scatter_variance();
    for (a, b) in without.curve.iter().zip(&with.curve) {
        let v = (a.accuracy.max_bound_95_mm * 1e-3).powi(2) / calib::CHI2_3_95 - s2;
        let inflated = (calib::CHI2_3_95 * (4.0 * v + s2)).sqrt() * 1e3;
        assert!((b.accuracy.max_bound_95_mm - inflated).abs() < 1e-9 * inflated);
    }
}

/// The per-axis variance of the plans' noise 0.02/0.02/0.03 mm (m^2).
fn config_scatter_variance() -> f64 {
    Instrument::positions([0.02, 0.02, 0.03]).scatter_variance()
}

/// A prior whose scatter exceeds the instrument's noise is the floor: the
/// scatter part is its 95 % radius, and the plan says so.
#[test]
fn the_priors_scatter_is_the_floor_where_larger() {
    let model = ur10();
    let plan = plan_with(&model, Some(prior(&model, 0.05, 0.5, None)));
    let used = plan.prior.as_ref().unwrap();
    assert_eq!(used.floor_mm, [0.05; 3]);
    assert!(
        used.floor_source
            .starts_with("the prior's residual scatter")
    );
    // A ratio below 1 does not shrink the bounds.
    assert_eq!(used.inflation, 1.0);
    for p in &plan.prediction.map.poses {
        assert!((p.parts.scatter_mm - calib::CHI2_3_95.sqrt() * 0.05).abs() < 1e-12);
        assert_eq!(p.parts.extrapolation_mm, 0.0);
    }
    assert!(
        plan.summary_text()
            .contains("floor 0.0500/0.0500/0.0500 mm")
    );
}

//! Bounds beyond the training poses: a robot whose true error has a term
//! the geometric model lacks, growing with the shoulder angle, calibrated
//! on a band of shoulder angles and validated on both sides of it.

mod common;

use flexcal_calib::{
    CHI2_3_95, CalibrationOptions, FrameTreatment, Measurement, MeasurementSet, Weighting,
    calibrate,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const NOISE: f64 = 20e-6;

/// Positions of the TCP in the base frame at `n` poses whose shoulder
/// angle is drawn from `shoulder` (rad): the nominal geometry plus a cubic
/// sag in the shoulder angle about -1.6 rad (no geometric parameter holds
/// it), plus noise.
fn simulate(model: &Model, n: usize, shoulder: (f64, f64), seed: u64) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, NOISE).unwrap();
    let mut data = Data::new(model);
    let xi = model.nominal_params().to_vec();
    let poses = (0..n)
        .map(|_| {
            let mut q = common::ur10_configuration(&mut rng);
            q[1] = rng.random_range(shoulder.0..shoulder.1);
            let x = forward_pose(model, &mut data, &q, &xi).unwrap();
            let sag = 1e-3 * (q[1] + 1.6).powi(2) * Vector3::new(0.3, -0.2, 1.0);
            let noise = Vector3::from_fn(|_, _| normal.sample(&mut rng));
            Measurement::new(q, x.translation.vector + sag + noise)
        })
        .collect();
    MeasurementSet::new("simulated", poses).unwrap()
}

#[test]
fn the_bound_grows_where_the_shoulder_leaves_its_training_band() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let train = simulate(&model, 200, (-2.2, -1.0), 1);
    let validation = simulate(&model, 400, (-2.6, -0.6), 2);
    let mut options = CalibrationOptions::for_model(&model);
    options.measurement_frame = FrameTreatment::Fixed;
    options.target = FrameTreatment::Fixed;
    options.weighting = Weighting::Uniform;
    options.default_position_std = NOISE;
    let calibration = calibrate(&model, &train, &options).unwrap();
    let extrapolation = calibration.extrapolation(&model, &train, &options).unwrap();
    let growth: Vec<f64> = extrapolation.growth.iter().map(|g| g.growth).collect();
    eprintln!("growth (m/rad) {growth:?}");
    for fold in &extrapolation.folds {
        eprintln!("{fold:?}");
    }
    // The shoulder's growth is measured; the others are small beside it.
    assert!(growth[1] > 0.0, "{growth:?}");
    for (i, g) in growth.iter().enumerate() {
        assert!(i == 1 || *g < 0.3 * growth[1], "{growth:?}");
    }
    assert_eq!(extrapolation.folds.len(), 12);
    assert!(extrapolation.folds.iter().all(|f| f.skipped.is_none()));

    let plain = calibration
        .accuracy_coverage(&model, &validation, None)
        .unwrap();
    let beyond = plain.clone().with_extrapolation(&extrapolation);
    let ranges = &extrapolation.ranges;
    let (mut outside, mut within_plain, mut within_beyond) = (0usize, 0usize, 0usize);
    for (a, b) in plain.poses.iter().zip(&beyond.poses) {
        // The bound is the root of the sum of its parts' squares, and the
        // extrapolation part is the growth times the distance out.
        assert!((b.parts.bound_mm() - b.bound_95_mm).abs() < 1e-12);
        let variance: f64 = ranges
            .iter()
            .zip(&growth)
            .zip(&b.q)
            .map(|((r, g), q)| (g * r.distance_outside(*q)).powi(2))
            .sum();
        let expected = (CHI2_3_95 * variance).sqrt() * 1e3;
        assert!((b.parts.extrapolation_mm - expected).abs() < 1e-12 * (1.0 + expected));
        assert_eq!(a.parts.scatter_mm, b.parts.scatter_mm);
        assert_eq!(a.parts.parameters_mm, b.parts.parameters_mm);
        if b.outside_training_range.is_empty() {
            // Inside every range a bound is unchanged.
            assert_eq!(b.parts.extrapolation_mm, 0.0);
            assert!((a.bound_95_mm - b.bound_95_mm).abs() < 1e-12 * a.bound_95_mm);
        }
        if ranges[1].distance_outside(b.q[1]) > 0.2 {
            outside += 1;
            let error = b.actual_error_mm.unwrap();
            within_plain += usize::from(error <= a.bound_95_mm);
            within_beyond += usize::from(error <= b.bound_95_mm);
        }
    }
    let share = |k: usize| k as f64 / outside as f64;
    eprintln!(
        "{outside} poses more than 0.2 rad outside: {:.3} within the plain bound, {:.3} with the extrapolation part; coverage {:.3} -> {:.3}",
        share(within_plain),
        share(within_beyond),
        plain.coverage.unwrap(),
        beyond.coverage.unwrap()
    );
    assert!(outside > 50, "{outside}");
    assert!(share(within_plain) < 0.5, "{}", share(within_plain));
    assert!(share(within_beyond) > 0.85, "{}", share(within_beyond));
    assert!(beyond.extrapolation.is_some() && plain.extrapolation.is_none());
    // The map's CSV carries the parts.
    let csv = beyond.to_csv_string();
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .contains(",actual_error_mm,scatter_95_mm,parameters_95_mm,extrapolation_95_mm,")
    );
    // A training set that is not the calibration's is named.
    let other = simulate(&model, 20, (-2.2, -1.0), 3);
    let err = calibration
        .extrapolation(&model, &other, &options)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("extrapolation") && err.contains("20 poses"),
        "{err}"
    );
}

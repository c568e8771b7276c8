//! The fuzzy residual model: on a UR10 whose errors include a smooth
//! function of the elbow configuration that no geometric parameter can
//! represent, the model fitted on the identification poses removes most of
//! the remaining error on other poses measured from another tracker
//! position (the frame re-fitted with the corrected predictions).

use flexcal_calib::{
    CalibError, CalibrationOptions, FrameTreatment, Measurement, MeasurementSet, ResidualModel,
    calibrate,
};
use flexcal_fuzzy::FuzzyParams;
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

mod common;

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// The unmodelled error (m, base frame): harmonics of the shoulder and
/// elbow angles that the geometric parameters (first harmonics) miss.
fn unmodelled(q: &[f64]) -> Vector3<f64> {
    5e-4 * Vector3::new(
        (2.0 * q[1]).sin(),
        (3.0 * q[2]).cos(),
        (2.0 * q[1] + q[2]).sin(),
    )
}

/// Positions measured in `frame` (tracker -> base) with 10 um noise.
fn measure(model: &Model, frame: &Isometry3<f64>, n: usize, seed: u64) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 10e-6).unwrap();
    let mut data = Data::new(model);
    let measurements = (0..n)
        .map(|_| {
            let q = common::ur10_configuration(&mut rng);
            let tcp = forward_pose(model, &mut data, &q, model.nominal_params()).unwrap();
            let p = tcp.translation.vector + unmodelled(&q);
            let measured =
                frame * nalgebra::Point3::from(p) + Vector3::from_fn(|_, _| noise.sample(&mut rng));
            Measurement::new(q, measured.coords)
        })
        .collect();
    MeasurementSet::new("simulated", measurements).unwrap()
}

#[test]
fn residual_model_removes_what_geometry_cannot_represent() {
    let model = ur10();
    let tracker_1 = Isometry3::from_parts(
        Translation3::new(3.1, -0.4, 0.2),
        UnitQuaternion::from_euler_angles(0.01, -0.02, 2.3),
    );
    let tracker_2 = Isometry3::from_parts(
        Translation3::new(-0.5, 2.9, -0.1),
        UnitQuaternion::from_euler_angles(-0.015, 0.01, -1.1),
    );
    let train = measure(&model, &tracker_1, 500, 11);
    let validate = measure(&model, &tracker_2, 300, 12);
    let mut options = CalibrationOptions::for_model(&model);
    options.target = FrameTreatment::Fixed;
    let calibration = calibrate(&model, &train, &options).unwrap();
    let residual = ResidualModel::fit(
        &model,
        &calibration,
        &train,
        &["theta2", "theta3"],
        &FuzzyParams::default(),
        1,
    )
    .unwrap();
    let plain = calibration.validate(&model, &validate, false).unwrap();
    let corrected = calibration
        .validate_with_residual_model(&model, &validate, &residual, false)
        .unwrap();
    println!(
        "validation mean {:.4} mm, with the residual model {:.4} mm; rules {:?}",
        plain.after.position_mean * 1e3,
        corrected.after.position_mean * 1e3,
        residual.rule_counts()
    );
    // The harmonics leave a few tenths of a millimetre to the geometry ...
    assert!(plain.after.position_mean > 0.2e-3);
    // ... which the residual model more than halves, on other poses, from
    // another tracker position.
    assert!(corrected.after.position_mean < 0.45 * plain.after.position_mean);
    // On the held-out identification poses each axis model explains most of
    // what the calibration left on that axis.
    let left = calibration.training_errors(&model, &train).unwrap();
    let to_base = calibration.x_meas_base.rotation.inverse();
    for axis in 0..3 {
        let rms = (left
            .iter()
            .map(|e| (to_base * e.position_vector)[axis].powi(2))
            .sum::<f64>()
            / left.len() as f64)
            .sqrt();
        let held_out = residual.reports[axis].test.rmse;
        println!(
            "axis {axis}: left {:.4} mm, held out {:.4} mm",
            rms * 1e3,
            held_out * 1e3
        );
        assert!(held_out < 0.4 * rms, "axis {axis}: {held_out} of {rms}");
    }
}

#[test]
fn bad_inputs_are_named() {
    let model = ur10();
    let frame = Isometry3::identity();
    let train = measure(&model, &frame, 60, 13);
    let calibration = calibrate(&model, &train, &CalibrationOptions::for_model(&model)).unwrap();
    let err = ResidualModel::fit(
        &model,
        &calibration,
        &train,
        &["theta9"],
        &FuzzyParams::default(),
        1,
    )
    .unwrap_err();
    assert!(
        matches!(&err, CalibError::InvalidOption { .. })
            && err
                .to_string()
                .contains("`theta9` is not an actuated coordinate"),
        "{err}"
    );
    let err = ResidualModel::fit(
        &model,
        &calibration,
        &train,
        &[],
        &FuzzyParams::default(),
        1,
    )
    .unwrap_err();
    assert!(err.to_string().contains("at least one"), "{err}");
}

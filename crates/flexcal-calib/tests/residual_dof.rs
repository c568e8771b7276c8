//! The residual scatter of a fit that uses orientation rows too: the
//! position residuals keep `3 N - tr(H_pp)` degrees of freedom (the hat
//! matrix's trace over the position rows), not `3 N - p`, because the
//! orientation rows carry part of the fit. Checked against a known noise:
//! a simulated UR10 measured in full pose with Gaussian noise whose
//! position and orientation parts match the identification's default
//! weighting, so the weighted fit is the maximum-likelihood one and
//! `E[SSR_pos] = sigma^2 (3 N - tr(H_pp))` holds exactly (to first order).

use flexcal_calib::{
    CalibrationOptions, Measurement, MeasurementSet, calibrate, vector_from_rotation,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

mod common;

/// Position noise per axis (m): a laser tracker's.
const POSITION_NOISE: f64 = 20e-6;
/// The default weighting counts 0.01 deg like 50 um: an orientation noise
/// in that ratio (0.004 deg) gives every weighted row the same variance.
fn orientation_noise() -> f64 {
    0.01f64.to_radians() * POSITION_NOISE / 50e-6
}

/// The defaults with the target's nominal pose known, as a user gives
/// the tool's drawing.
fn options(target: Isometry3<f64>) -> CalibrationOptions {
    CalibrationOptions {
        target_value: Some(target),
        ..CalibrationOptions::default()
    }
}

/// `poses` configurations of a UR10 whose geometry is off by up to 0.5 mm
/// and 1 mrad (drawn from `seed`), measured with the tracker's noise in
/// position, and in orientation too when `full_poses`; the target's
/// nominal pose.
fn measured(
    model: &Model,
    seed: u64,
    poses: usize,
    full_poses: bool,
) -> (MeasurementSet, Isometry3<f64>) {
    let (frame, target) = common::generic_frame_and_target();
    let position = Normal::new(0.0, POSITION_NOISE).unwrap();
    let orientation = Normal::new(0.0, orientation_noise()).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let truth = common::perturbed_geometry(model, &mut rng, 5e-4, 1e-3);
    let mut data = Data::new(model);
    let measurements: Vec<Measurement> = (0..poses)
        .map(|_| {
            let q: Vec<f64> = (0..model.n_actuated())
                .map(|_| rng.random_range(-2.0..2.0))
                .collect();
            let x = frame * forward_pose(model, &mut data, &q, &truth).unwrap() * target;
            let noise = Vector3::from_fn(|_, _| position.sample(&mut rng));
            let mut m = Measurement::new(q, x.translation.vector + noise);
            if full_poses {
                let turn = Vector3::from_fn(|_, _| orientation.sample(&mut rng));
                m.orientation = Some(vector_from_rotation(
                    &(UnitQuaternion::from_scaled_axis(turn) * x.rotation),
                ));
            }
            m
        })
        .collect();
    let name = if full_poses {
        "full poses"
    } else {
        "positions"
    };
    (MeasurementSet::new(name, measurements).unwrap(), target)
}

#[test]
fn the_scatter_of_a_full_pose_fit_estimates_the_position_noise() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let (mut new_ratio, mut old_ratio) = (0.0, 0.0);
    let seeds = 40;
    for seed in 0..seeds {
        let (set, target) = measured(&model, 1000 + seed, 20, true);
        let calibration = calibrate(&model, &set, &options(target)).unwrap();
        let dof = calibration
            .position_residual_dof
            .expect("orientation rows fitted");
        let n = calibration.n_observations as f64;
        let p = calibration.rank() as f64;
        // The orientation rows take part of the fit: more than 3 N - p
        // degrees of freedom are left to the positions, fewer than 3 N.
        assert!(
            dof > 3.0 * n - p && dof < 3.0 * n,
            "dof {dof}, N {n}, p {p}"
        );
        let s2 = calibration.residual_scatter().powi(2);
        new_ratio += s2 / POSITION_NOISE.powi(2);
        old_ratio += s2 * dof / (3.0 * n - p) / POSITION_NOISE.powi(2);
    }
    let (new_ratio, old_ratio) = (new_ratio / seeds as f64, old_ratio / seeds as f64);
    println!(
        "scatter^2 / noise^2, mean over {seeds} fits of 20 full poses: {new_ratio:.3} with 3N - tr(H_pp), {old_ratio:.3} with 3N - p"
    );
    // About 35 degrees of freedom per fit: one ratio spreads by about
    // 0.24, the mean of 40 by 0.04.
    assert!((new_ratio - 1.0).abs() < 0.15, "{new_ratio}");
    assert!(old_ratio > 1.2, "{old_ratio}");
}

#[test]
fn positions_alone_keep_three_n_minus_p() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let (set, target) = measured(&model, 7, 30, false);
    let calibration = calibrate(&model, &set, &options(target)).unwrap();
    assert!(calibration.rank() > 20, "rank {}", calibration.rank());
    assert_eq!(calibration.position_residual_dof, None);
    let n = calibration.n_observations as f64;
    let ssr = calibration.training_after.position_rms.powi(2) * n;
    let expected = ssr / (3.0 * n - calibration.rank() as f64);
    let s2 = calibration.residual_scatter().powi(2);
    assert!(
        (s2 - expected).abs() <= 1e-12 * expected,
        "{s2} against {expected}"
    );
}

//! Cancellation of an identification through `CalibrationOptions::cancel`:
//! a cancelled token ends `calibrate`, `calibrate_selected` and `calibrate` with the
//! named error instead of a result. (That the solver stops within the
//! iteration under way is tested where the check lives, in flexcal-optim's
//! `a_cancelled_token_ends_the_solve_within_the_iteration_under_way`.)

use flexcal_calib::{
    CalibError, CalibrationOptions, CancelToken, Measurement, MeasurementSet, SelectionMethod,
    SelectionOptions, calibrate, calibrate_selected,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A UR10 whose lengths differ from nominal by up to 1 mm, measured without
/// noise at `n` configurations: an identification with work to do.
fn campaign(n: usize) -> (Model, MeasurementSet) {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let truth: Vec<f64> = model
        .nominal_params()
        .iter()
        .map(|v| v + rng.random_range(-1e-3..1e-3))
        .collect();
    let mut data = Data::new(&model);
    let measurements = (0..n)
        .map(|_| {
            let q: Vec<f64> = (0..6).map(|_| rng.random_range(-2.5..2.5)).collect();
            let p = forward_pose(&model, &mut data, &q, &truth).unwrap();
            Measurement::new(q, p.translation.vector)
        })
        .collect();
    (
        model,
        MeasurementSet::new("simulated", measurements).unwrap(),
    )
}

#[test]
fn a_cancelled_identification_returns_the_named_error() {
    let (model, set) = campaign(60);
    let token = CancelToken::new();
    let mut options = CalibrationOptions::for_model(&model);
    options.cancel = Some(token.clone());
    // Not cancelled: the token changes nothing.
    let finished = calibrate(&model, &set, &options).expect("identification");
    assert!(finished.solve.termination.is_converged());
    token.cancel();
    let e = calibrate(&model, &set, &options).unwrap_err();
    assert!(matches!(e, CalibError::Cancelled), "{e}");
    assert_eq!(e.to_string(), "identification cancelled on request");
}

#[test]
fn model_selection_passes_the_token_to_its_fits() {
    let (model, set) = campaign(60);
    let token = CancelToken::new();
    token.cancel();
    let mut options = CalibrationOptions::for_model(&model);
    options.cancel = Some(token);
    for method in [SelectionMethod::CrossValidation, SelectionMethod::Bic] {
        let selection = SelectionOptions {
            method,
            ..SelectionOptions::default()
        };
        let e = calibrate_selected(&model, &set, &options, &selection).unwrap_err();
        assert!(matches!(e, CalibError::Cancelled), "{method:?}: {e}");
    }
}

#[test]
fn a_cancelled_multi_target_identification_returns_the_named_error() {
    // The same campaign as one target on the TCP.
    let (model, set) = campaign(60);
    let probe = flexcal_calib::Target {
        name: "probe".into(),
        ..set.targets()[0].clone()
    };
    let targets =
        flexcal_calib::MeasurementSet::from_poses(&set.source, vec![probe], set.poses().to_vec())
            .unwrap();
    let token = CancelToken::new();
    let mut options = CalibrationOptions::for_model(&model);
    options.cancel = Some(token.clone());
    let finished = flexcal_calib::calibrate(&model, &targets, &options).unwrap();
    assert!(finished.solve.termination.is_converged());
    token.cancel();
    let e = flexcal_calib::calibrate(&model, &targets, &options).unwrap_err();
    assert!(matches!(e, CalibError::Cancelled), "{e}");
}

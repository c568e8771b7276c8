//! The spread ratio of the identified unknowns: the standard error that the
//! poses give over the one of as many poses spread over the joint ranges.
//! A spread design scores about 1; poses clustered around one configuration
//! score far more and are named in the identifiability notes.

use flexcal_calib::{
    CalibrationOptions, Measurement, MeasurementSet, UnknownStatus, WEAK_SPREAD_RATIO, calibrate,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// Positions of the nominal UR10 (base frame = measurement frame) at the
/// configurations `draw` gives, with 20 um of noise per axis.
fn measure(
    model: &Model,
    n: usize,
    seed: u64,
    draw: impl Fn(&mut ChaCha8Rng) -> Vec<f64>,
) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 20e-6).unwrap();
    let mut data = Data::new(model);
    let measurements = (0..n)
        .map(|_| {
            let q = draw(&mut rng);
            let pose = forward_pose(model, &mut data, &q, model.nominal_params()).unwrap();
            let p = pose.translation.vector + Vector3::from_fn(|_, _| noise.sample(&mut rng));
            Measurement::new(q, p)
        })
        .collect();
    MeasurementSet::new("simulated", measurements).unwrap()
}

fn ratios(set: &MeasurementSet, model: &Model) -> (Vec<(String, f64)>, Vec<String>) {
    let calibration = calibrate(model, set, &CalibrationOptions::for_model(model)).unwrap();
    let ratios = calibration
        .unknowns
        .iter()
        .filter(|u| u.status == UnknownStatus::Identified)
        .map(|u| {
            (
                u.name.clone(),
                u.spread_ratio.expect("identified unknowns have a ratio"),
            )
        })
        .collect();
    (ratios, calibration.identifiability_notes())
}

#[test]
fn a_spread_design_scores_about_one() {
    let model = ur10();
    // Drawn like the reference (uniformly over the joint limits) but with
    // another seed and more poses than the reference holds.
    let limits = model.actuated_limits().to_vec();
    let set = measure(&model, 600, 3, |rng| {
        limits
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..hi))
            .collect()
    });
    let (ratios, notes) = ratios(&set, &model);
    assert!(ratios.len() > 20, "{ratios:?}");
    for (name, r) in &ratios {
        assert!((0.8..1.25).contains(r), "{name}: ratio {r}");
    }
    assert!(
        !notes.iter().any(|n| n.contains("less precisely")),
        "{notes:?}"
    );
}

#[test]
fn clustered_poses_are_named_as_weak() {
    let model = ur10();
    // Every joint within +-8 deg of one configuration.
    let center = [0.4, -1.2, 1.1, -1.3, -1.5, 0.3];
    let half = 8f64.to_radians();
    let set = measure(&model, 300, 4, |rng| {
        center
            .iter()
            .map(|c| c + rng.random_range(-half..half))
            .collect()
    });
    let (ratios, notes) = ratios(&set, &model);
    let robot: Vec<&(String, f64)> = ratios
        .iter()
        .filter(|(n, _)| !n.starts_with("frame_") && !n.starts_with("target_"))
        .collect();
    let weak = robot.iter().filter(|(_, r)| *r > WEAK_SPREAD_RATIO).count();
    assert!(
        2 * weak > robot.len(),
        "most identified robot parameters should be weak: {ratios:?}"
    );
    let note = notes
        .iter()
        .find(|n| n.contains("less precisely"))
        .expect("a note names the weak unknowns");
    for (name, r) in robot.iter().filter(|(_, r)| *r > WEAK_SPREAD_RATIO) {
        assert!(
            note.contains(&format!("{name} x{r:.0}")),
            "{name} missing from {note}"
        );
    }
}

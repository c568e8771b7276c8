//! The split-half check of the standard errors: with independent noise the
//! halves agree as the standard errors predict. With an error the model
//! lacks and a campaign that sweeps the workspace in order (halves in file
//! order then see different regions, like the IPA series), they do not, and
//! the check says which standard errors understate the uncertainty.

mod common;

use flexcal_calib::{
    CalibrationOptions, Measurement, MeasurementSet, SPLIT_RATIO_WARNING, SplitCheck, calibrate,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// 400 UR10 poses of a robot 0.3 mm longer in d3 than nominal, in the base
/// frame, with 30 um of noise per axis; the true robot stands at
/// `q + deflection(q)`. With `sweep`, the poses come in the order of joint 2
/// (a campaign that lowers the arm step by step).
fn campaign(model: &Model, sweep: bool, deflection: impl Fn(&[f64]) -> Vec<f64>) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let noise = Normal::new(0.0, 30e-6).unwrap();
    let mut truth = model.nominal_params().to_vec();
    truth[model.param_index("d3").unwrap()] += 0.3e-3;
    let mut data = Data::new(model);
    let mut configurations: Vec<Vec<f64>> = (0..400)
        .map(|_| common::ur10_configuration(&mut rng))
        .collect();
    if sweep {
        configurations.sort_by(|a, b| a[1].total_cmp(&b[1]));
    }
    let measurements = configurations
        .into_iter()
        .map(|q| {
            let deflected: Vec<f64> = q.iter().zip(deflection(&q)).map(|(a, b)| a + b).collect();
            let p = forward_pose(model, &mut data, &deflected, &truth)
                .unwrap()
                .translation
                .vector;
            Measurement::new(q, p + Vector3::from_fn(|_, _| noise.sample(&mut rng)))
        })
        .collect();
    MeasurementSet::new("campaign", measurements).unwrap()
}

fn check(model: &Model, set: &MeasurementSet) -> SplitCheck {
    let options = CalibrationOptions::for_model(model);
    let calibration = calibrate(model, set, &options).unwrap();
    SplitCheck::new(model, set, &options, &calibration).unwrap()
}

fn median_ratio(check: &SplitCheck) -> f64 {
    let mut ratios: Vec<f64> = check.unknowns.iter().filter_map(|u| u.ratio).collect();
    assert!(ratios.len() > 15, "{check:?}");
    ratios.sort_by(f64::total_cmp);
    ratios[ratios.len() / 2]
}

#[test]
fn independent_noise_passes_and_an_unmodelled_sag_is_caught() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let clean = check(&model, &campaign(&model, true, |_| vec![0.0; 6]));
    let median = median_ratio(&clean);
    println!("independent noise: median ratio {median:.2}");
    assert!((0.6..1.5).contains(&median), "median ratio {median}");
    // In the prediction space too: the halves' predicted positions differ
    // as the covariance says.
    let clean_prediction = clean.prediction_ratio.unwrap();
    println!("independent noise: prediction ratio {clean_prediction:.2}");
    assert!((0.6..1.5).contains(&clean_prediction), "{clean_prediction}");
    let flagged = clean
        .unknowns
        .iter()
        .filter(|u| u.ratio.is_some_and(|r| r > SPLIT_RATIO_WARNING))
        .count();
    assert!(flagged <= 1, "{:?}", clean.notes());
    // Every compared unknown carries its four half values and d3 is among them.
    assert!(clean.unknowns.iter().any(|u| u.name == "d3"));
    for u in &clean.unknowns {
        if u.split_error.is_some() {
            assert!(u.half_values.iter().all(Option::is_some), "{u:?}");
        }
    }

    // The shoulder sags under the arm's weight by 0.03 deg times the cosine
    // of its angle (the gravity torque's shape), which the geometric model
    // lacks, on the same swept campaign.
    let sagging = check(
        &model,
        &campaign(&model, true, |q| {
            let mut dq = vec![0.0; 6];
            dq[1] = 0.03f64.to_radians() * q[1].cos();
            dq
        }),
    );
    let ratio = |name: &str| {
        sagging
            .unknowns
            .iter()
            .find(|u| u.name == name)
            .and_then(|u| u.ratio)
            .unwrap()
    };
    println!(
        "unmodelled sag: theta2 x{:.1}, d2 x{:.1}; {:?}",
        ratio("theta2"),
        ratio("d2"),
        sagging.notes()
    );
    let sag_prediction = sagging.prediction_ratio.unwrap();
    println!("unmodelled sag: prediction ratio {sag_prediction:.2}");
    assert!(sag_prediction > 3.0, "{sag_prediction}");
    // The parameters that take up the sag differ between the halves far
    // beyond their standard errors, and the notes name them.
    assert!(ratio("theta2") > 5.0 && ratio("d2") > 5.0);
    let notes = sagging.notes().join("\n");
    assert!(
        notes.contains("standard errors understated") && notes.contains("theta2 x"),
        "{notes}"
    );
}

//! The cross-series check: two campaigns of the same robot with independent
//! noise agree within their standard errors. When the robot sags in a way
//! the geometric model lacks and the two campaigns visit different parts of
//! the shoulder's range, the parameters that take up the sag come out
//! different, and the check names them.

mod common;

use flexcal_calib::{
    CROSS_Z_WARNING, CalibrationOptions, CrossCheck, Measurement, MeasurementSet, SplitCheck,
    calibrate,
};
use flexcal_kinematics::{Data, Model, RobotDescription, forward_pose};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// 300 UR10 poses (seeded) whose shoulder angle lies in `shoulder` (rad), of
/// a robot 0.3 mm longer in d3 than nominal and standing at
/// `q + deflection(q)`, in the base frame, with 30 um of noise per axis.
fn campaign(
    model: &Model,
    seed: u64,
    shoulder: std::ops::Range<f64>,
    deflection: impl Fn(&[f64]) -> Vec<f64>,
) -> MeasurementSet {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 30e-6).unwrap();
    let mut truth = model.nominal_params().to_vec();
    truth[model.param_index("d3").unwrap()] += 0.3e-3;
    let mut data = Data::new(model);
    let mut measurements = Vec::new();
    while measurements.len() < 300 {
        let q = common::ur10_configuration(&mut rng);
        if !shoulder.contains(&q[1]) {
            continue;
        }
        let deflected: Vec<f64> = q.iter().zip(deflection(&q)).map(|(a, b)| a + b).collect();
        let p = forward_pose(model, &mut data, &deflected, &truth)
            .unwrap()
            .translation
            .vector;
        measurements.push(Measurement::new(
            q,
            p + Vector3::from_fn(|_, _| noise.sample(&mut rng)),
        ));
    }
    MeasurementSet::new(&format!("campaign {seed}"), measurements).unwrap()
}

fn check(model: &Model, first: &MeasurementSet, other: &MeasurementSet) -> CrossCheck {
    let options = CalibrationOptions::for_model(model);
    let calibration = calibrate(model, first, &options).unwrap();
    CrossCheck::new(model, other, &options, &calibration, None).unwrap()
}

fn z(check: &CrossCheck, name: &str) -> f64 {
    check
        .unknowns
        .iter()
        .find(|u| u.name == name)
        .and_then(|u| u.z)
        .unwrap_or_else(|| panic!("{name} not compared: {check:?}"))
}

#[test]
fn same_robot_agrees_and_an_unmodelled_sag_does_not_transfer() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let no_sag = |_: &[f64]| vec![0.0; 6];
    let clean = check(
        &model,
        &campaign(&model, 5, -2.6..-0.5, no_sag),
        &campaign(&model, 6, -2.6..-0.5, no_sag),
    );
    let mut magnitudes: Vec<f64> = clean.unknowns.iter().filter_map(|u| u.z).collect();
    assert!(magnitudes.len() > 15, "{clean:?}");
    magnitudes.iter_mut().for_each(|z| *z = z.abs());
    magnitudes.sort_by(f64::total_cmp);
    let median = magnitudes[magnitudes.len() / 2];
    println!("same robot: median |z| {median:.2}; {:?}", clean.notes());
    // A standard normal's median |z| is 0.67; with about 20 unknowns the
    // sample median stays within this range.
    assert!((0.3..1.2).contains(&median), "median |z| {median}");
    assert!(clean.disagreeing().count() <= 1, "{:?}", clean.notes());
    // Every compared unknown carries both values, and the one the truth moved
    // agrees within its standard errors.
    for u in &clean.unknowns {
        assert!(
            u.other_value.is_some() && u.other_standard_error.is_some(),
            "{u:?}"
        );
    }
    assert!(z(&clean, "d3").abs() < CROSS_Z_WARNING);
    assert_eq!(clean.other_poses, 300);
    assert_eq!(clean.other_set, "campaign 6");

    // The shoulder sags by 0.03 deg times the cosine of its angle. One
    // campaign keeps the arm low (shoulder below -1.55 rad), the other high.
    let sag = |q: &[f64]| {
        let mut dq = vec![0.0; 6];
        dq[1] = 0.03f64.to_radians() * q[1].cos();
        dq
    };
    let (low, high) = (
        campaign(&model, 5, -2.6..-1.55, sag),
        campaign(&model, 6, -1.55..-0.5, sag),
    );
    let sagging = check(&model, &low, &high);
    println!(
        "unmodelled sag: z theta2 {:+.1}, d2 {:+.1}; {:?}",
        z(&sagging, "theta2"),
        z(&sagging, "d2"),
        sagging.notes()
    );
    // The sag's linear part about each campaign's shoulder angles is taken up
    // by the joint offset: different in the two halves of the range.
    assert!(z(&sagging, "theta2").abs() > 2.0 * CROSS_Z_WARNING);
    let notes = sagging.notes().join("\n");
    assert!(
        notes.contains("disagree beyond") && notes.contains("theta2 ("),
        "{notes}"
    );
    // z is signed as other minus identified.
    let theta2 = sagging
        .unknowns
        .iter()
        .find(|u| u.name == "theta2")
        .unwrap();
    assert_eq!(
        theta2.z.unwrap().signum(),
        (theta2.other_value.unwrap() - theta2.value).signum()
    );

    // With the split checks: within each campaign the sag's residue is
    // spread over the poses in random order, so the halves agree, the split
    // errors stay near the standard errors and the disagreement stands.
    let options = CalibrationOptions::for_model(&model);
    let calibration = calibrate(&model, &low, &options).unwrap();
    let split = SplitCheck::new(&model, &low, &options, &calibration).unwrap();
    let widened = CrossCheck::new(&model, &high, &options, &calibration, Some(&split)).unwrap();
    for u in &widened.unknowns {
        if let (Some(z), Some(z_split)) = (u.z, u.z_split) {
            assert!(z_split.abs() <= z.abs() + 1e-12, "{u:?}");
        }
    }
    let theta2 = widened
        .unknowns
        .iter()
        .find(|u| u.name == "theta2")
        .unwrap();
    assert!(
        theta2.z_split.unwrap().abs() > 2.0 * CROSS_Z_WARNING,
        "{theta2:?}"
    );
    assert!(widened.disagreeing().any(|u| u.name == "theta2"));
    assert!(widened.notes()[0].contains("raised to its split error"));
}

#[test]
fn sets_too_small_to_identify_or_to_halve() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let first = campaign(&model, 5, -2.6..-0.5, |_| vec![0.0; 6]);
    let options = CalibrationOptions::for_model(&model);
    let calibration = calibrate(&model, &first, &options).unwrap();
    let tiny = first.subset(&[0, 1, 2]).unwrap();
    let error = CrossCheck::new(&model, &tiny, &options, &calibration, None).unwrap_err();
    let text = error.to_string();
    println!("{text}");
    assert!(text.contains("poses"), "{text}");

    // Twelve poses identify the robot but cannot be halved: with the split
    // checks asked for, the check stands on the plain standard errors and
    // says why.
    let split = SplitCheck::new(&model, &first, &options, &calibration).unwrap();
    let small = first.subset(&(0..12).collect::<Vec<_>>()).unwrap();
    let cross = CrossCheck::new(&model, &small, &options, &calibration, Some(&split)).unwrap();
    let why = cross.other_split_failure.as_deref().unwrap();
    assert!(why.contains("too few measurements"), "{why}");
    assert!(cross.unknowns.iter().all(|u| u.z_split.is_none()));
    assert!(cross.unknowns.iter().any(|u| u.z.is_some()));
    let notes = cross.notes().join("\n");
    assert!(
        notes.contains("no split-half check on the other set"),
        "{notes}"
    );
}

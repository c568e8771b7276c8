//! Measurements from several stations (one measurement frame each, the
//! robot and the target shared): the error model's frame columns against
//! central differences, exact recovery of both frames without noise,
//! compliances within their standard errors with noise, and what a single
//! frame for two stations would cost.

use flexcal_calib::{
    CalibrationOptions, ErrorModel, FrameTreatment, GravityCompliance, JointLaw, JointTerms,
    Measurement, MeasurementSet, UnknownStatus, Weighting, calibrate, rotation_from_vector,
};
use flexcal_kinematics::{Model, RobotDescription};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

mod common;

fn ur10() -> Model {
    RobotDescription::builtin("ur10").unwrap().build().unwrap()
}

/// The tracker of the first station, 3 m from the robot.
fn first_station() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(0.4, -3.2, 0.1),
        rotation_from_vector(&Vector3::new(0.0, 0.05, 1.5)),
    )
}

/// The tracker moved to the other side of the robot and lower: a second
/// station.
fn second_station() -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(-2.6, 1.9, -0.3),
        rotation_from_vector(&Vector3::new(0.04, -0.03, -2.4)),
    )
}

/// A UR10 with geometry `xi` and linear joint compliances `compliance`
/// (rad/N.m) under gravity, measured with Gaussian noise `noise` (m) per
/// axis.
struct Ur10<'a> {
    model: &'a Model,
    gravity: &'a GravityCompliance,
    xi: &'a [f64],
    compliance: &'a [f64],
    noise: f64,
}

impl<'a> Ur10<'a> {
    /// The robot measured without noise.
    fn exact(
        model: &'a Model,
        gravity: &'a GravityCompliance,
        xi: &'a [f64],
        compliance: &'a [f64],
    ) -> Self {
        Self {
            model,
            gravity,
            xi,
            compliance,
            noise: 0.0,
        }
    }

    /// `n` poses drawn from `seed`, seen from a tracker at `frame`.
    fn station(&self, frame: Isometry3<f64>, n: usize, seed: u64) -> MeasurementSet {
        common::GravitySimulation {
            model: self.model,
            gravity: self.gravity,
            xi: self.xi,
            payload: (1.4, Vector3::new(0.01, -0.02, 0.12)),
            frame,
            noise: self.noise,
        }
        .measure(
            n,
            seed,
            "simulated station",
            common::ur10_configuration,
            |q, tau| {
                q.iter()
                    .zip(tau)
                    .zip(self.compliance)
                    .map(|((q, t), c)| q + c * t)
                    .collect()
            },
        )
    }
}

/// True joint compliances (rad/N.m), as in the single-station tests.
const COMPLIANCES: [f64; 6] = [0.0, 14e-6, 9e-6, 20e-6, 15e-6, 10e-6];

#[test]
fn station_frame_columns_match_central_differences() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let (frame, target) = common::generic_frame_and_target();
    let robot = Ur10::exact(&model, &gravity, model.nominal_params(), &COMPLIANCES);
    let sets: Vec<MeasurementSet> = [frame, second_station(), first_station()]
        .iter()
        .enumerate()
        .map(|(s, f)| common::with_orientation(&robot.station(*f, 3, s as u64)))
        .collect();
    let pooled = MeasurementSet::pooled(&sets).unwrap();
    assert_eq!(pooled.n_stations(), 3);
    let terms = JointTerms {
        law: Some(JointLaw::default()),
        cyclic: true,
    };
    let problem = ErrorModel::one_target(&model, &pooled, true, frame, target)
        .unwrap()
        .with_station_frames(&[second_station(), first_station()])
        .unwrap()
        .with_elastic(Some(&gravity), &terms)
        .unwrap();
    assert_eq!(problem.kinds().len(), problem.n_unknowns());
    let (_, jac) = common::assert_elastic_jacobian_matches(
        "ur10 seen from three stations",
        &model,
        &problem,
        9,
    );
    // A station's frame moves its own poses' rows only.
    for s in 0..3 {
        let o = problem.station_frame_offset(s);
        assert!(problem.names()[o].starts_with("frame_"), "{s}");
        for k in 0..pooled.len() {
            let moved = (0..6).any(|i| (0..6).any(|c| jac[(6 * k + i, o + c)] != 0.0));
            assert_eq!(moved, pooled.station_of(k) == s, "station {s}, pose {k}");
        }
    }
    // Later stations' frames are named by their number; elastic unknowns
    // follow them.
    let names = problem.names();
    let o = problem.station_frame_offset(2);
    assert_eq!(names[o], "frame_s3_x");
    assert_eq!(names[problem.frames_end()], "compliance_theta1");
}

#[test]
fn pooled_stations_recover_both_frames_exactly_where_one_frame_cannot() {
    let model = ur10();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let truth = common::perturbed_geometry(&model, &mut rng, 1e-3, 2e-3);
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let robot = Ur10::exact(&model, &gravity, &truth, &[0.0; 6]);
    let first = robot.station(first_station(), 50, 1);
    let second = robot.station(second_station(), 50, 2);
    let pooled = MeasurementSet::pooled(&[first.clone(), second.clone()]).unwrap();
    // Two sets of the same name: the second station's is made unique, so
    // that a `station` column can tell them apart.
    assert_eq!(
        pooled.station_names(),
        ["simulated station", "simulated station (s2)"]
    );
    let back = MeasurementSet::from_csv_str(&pooled.to_csv_string(), "back").unwrap();
    assert_eq!(back.n_stations(), 2);
    assert_eq!(pooled.measurements()[50].label(50), "s2:#0");
    let mut options = CalibrationOptions::for_model(&model);
    options.target = FrameTreatment::Fixed;
    let calibration = calibrate(&model, &pooled, &options).unwrap();
    assert!(
        calibration.training_after.position_max < 1e-9,
        "{:?}",
        calibration.training_after
    );
    assert_eq!(calibration.station_frames.len(), 1);
    let counts: Vec<usize> = calibration
        .station_errors
        .iter()
        .map(|e| e.n_poses)
        .collect();
    assert_eq!(counts, [50, 50]);
    // The base parameters the frames absorb are the same for both stations:
    // the motion from one tracker placement to the other is exact.
    let identified = calibration.station_frames[0] * calibration.x_meas_base.inverse();
    let true_motion = second_station() * first_station().inverse();
    let motion_error = identified.inverse() * true_motion;
    assert!(
        motion_error.translation.vector.norm() < 1e-9 && motion_error.rotation.angle() < 1e-9,
        "{motion_error:?}"
    );
    // Each station validates on its own: the identified frames are exact.
    let errors = calibration.training_errors(&model, &pooled).unwrap();
    assert!(errors.iter().all(|e| e.position < 1e-9));
    // A subset without the first station's poses: that frame has no
    // influence and the rest fits as well.
    let second_only = pooled.subset(&(50..100).collect::<Vec<_>>()).unwrap();
    let subset_fit = calibrate(&model, &second_only, &options).unwrap();
    assert!(subset_fit.training_after.position_max < 1e-9);
    for u in &subset_fit.unknowns {
        if u.name.starts_with("frame_") {
            let first_frame = !u.name.starts_with("frame_s2_");
            assert_eq!(
                u.status,
                if first_frame {
                    UnknownStatus::NoInfluence
                } else {
                    UnknownStatus::Identified
                },
                "{}",
                u.name
            );
        }
    }
    // The two stations as one (one measurement frame for both) cannot fit:
    // the frames are metres apart.
    let mut joined = first.measurements().to_vec();
    joined.extend(second.measurements().iter().cloned());
    let one_frame = MeasurementSet::new("one frame", joined).unwrap();
    let wrong = calibrate(&model, &one_frame, &options).unwrap();
    assert!(
        wrong.training_after.position_rms > 0.1,
        "{:?}",
        wrong.training_after
    );
}

#[test]
fn pooled_stations_identify_compliances_within_their_standard_errors() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let truth = common::perturbed_geometry(&model, &mut rng, 5e-4, 1e-3);
    let noise = 20e-6;
    let c = COMPLIANCES;
    let robot = Ur10 {
        noise,
        ..Ur10::exact(&model, &gravity, &truth, &c)
    };
    let sets = [
        robot.station(first_station(), 300, 11),
        robot.station(second_station(), 300, 12),
    ];
    let pooled = MeasurementSet::pooled(&sets).unwrap();
    let mut options = CalibrationOptions::for_model(&model);
    options.weighting = Weighting::Uniform;
    options.default_position_std = noise;
    options.target = FrameTreatment::Fixed;
    options.gravity = Some(gravity.clone());
    let calibration = calibrate(&model, &pooled, &options).unwrap();
    assert!(calibration.solve.termination.is_converged());
    for (name, true_value) in [("compliance_theta2", c[1]), ("compliance_theta3", c[2])] {
        common::assert_recovered(&calibration, name, true_value);
    }
    for name in ["frame_s2_x", "frame_s2_rz"] {
        let u = calibration.unknowns.iter().find(|u| u.name == name);
        assert_eq!(u.unwrap().status, UnknownStatus::Identified, "{name}");
    }
    // New poses of either station (the frame re-fitted) are predicted to
    // the noise.
    let noise_mean = noise * (8.0 / std::f64::consts::PI).sqrt();
    for (s, frame) in [first_station(), second_station()].into_iter().enumerate() {
        let fresh = robot.station(frame, 200, 20 + s as u64);
        let report = calibration.validate(&model, &fresh, false).unwrap();
        assert!(
            report.after.position_mean < 1.3 * noise_mean,
            "station {}: {:?}",
            s + 1,
            report.after
        );
    }
    // A validation set of two stations re-fits a frame for each.
    let fresh = MeasurementSet::pooled(&[
        robot.station(first_station(), 100, 30),
        robot.station(second_station(), 100, 31),
    ])
    .unwrap();
    let report = calibration.validate(&model, &fresh, false).unwrap();
    assert!(
        report.after.position_mean < 1.3 * noise_mean,
        "{:?}",
        report.after
    );
    // Its poses of the second station alone (a subset keeps both stations'
    // names): the empty station's frame is left alone, the other re-fitted.
    let second_only = fresh.subset(&(100..200).collect::<Vec<_>>()).unwrap();
    let report = calibration.validate(&model, &second_only, false).unwrap();
    assert!(
        report.after.position_mean < 1.3 * noise_mean,
        "{:?}",
        report.after
    );
    let moved = report.measurement_frame.inverse() * second_station();
    assert!(moved.translation.vector.norm() < 1e-3, "{moved:?}");
    // The predicted accuracy carries the covariance of the pooled fit.
    let map = calibration
        .accuracy_coverage(&model, &sets[1], None)
        .unwrap();
    assert_eq!(map.poses.len(), sets[1].len());
    // Each station held out: identified on the other, validated on it.
    let selection = flexcal_calib::SelectionOptions {
        method: flexcal_calib::SelectionMethod::None,
        ..Default::default()
    };
    let held = flexcal_calib::hold_out_stations(&model, &pooled, &options, &selection).unwrap();
    assert_eq!(held.len(), 2);
    for (h, set) in held.iter().zip(&sets) {
        assert_eq!(h.after.n_poses, set.len());
        assert!(h.chosen.is_none());
        assert!(
            h.after.position_mean < 1.3 * noise_mean && h.before.position_mean > 10.0 * noise_mean,
            "{h:?}"
        );
    }
    let e = flexcal_calib::hold_out_stations(&model, &sets[0], &options, &selection).unwrap_err();
    assert!(e.to_string().contains("at least two"), "{e}");
    // The split-half check halves each station's poses (every half places
    // both frames): with independent noise its halves agree as the
    // covariance predicts, in the unknowns and in the predicted positions.
    let split = flexcal_calib::SplitCheck::new(&model, &pooled, &options, &calibration).unwrap();
    assert!(!split.unknowns.iter().any(|u| u.name.starts_with("frame_")));
    let ratio = split.prediction_ratio.unwrap();
    assert!(ratio > 0.3 && ratio < 2.5, "prediction ratio {ratio}");
}

#[test]
fn pooling_names_the_set_that_does_not_fit() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let robot = Ur10::exact(&model, &gravity, model.nominal_params(), &[0.0; 6]);
    let a = robot.station(first_station(), 5, 1);
    let mut b = robot.station(second_station(), 5, 2);
    b.source = "other.csv".into();
    // Another robot: five joints.
    let short: Vec<Measurement> = b
        .measurements()
        .iter()
        .map(|m| Measurement::new(m.q[..5].to_vec(), m.position))
        .collect();
    let short = MeasurementSet::new("five.csv", short).unwrap();
    let e = MeasurementSet::pooled(&[a.clone(), short]).unwrap_err();
    assert!(
        e.to_string().contains("five.csv") && e.to_string().contains("5 actuated"),
        "{e}"
    );
    // Orientations in one set only.
    let e = MeasurementSet::pooled(&[a.clone(), common::with_orientation(&b)]).unwrap_err();
    assert!(e.to_string().contains("orientations"), "{e}");
    // Another target.
    let mut moved = b.clone();
    moved.set_nominal_target(Isometry3::translation(0.0, 0.0, 0.1));
    let e = MeasurementSet::pooled(&[a.clone(), moved]).unwrap_err();
    assert!(
        e.to_string().contains("other.csv") && e.to_string().contains("target"),
        "{e}"
    );
    assert!(MeasurementSet::pooled(&[]).is_err());
    // One set pools to itself.
    assert_eq!(MeasurementSet::pooled(std::slice::from_ref(&a)).unwrap(), a);
}

#[test]
fn the_station_column_round_trips() {
    let model = ur10();
    let gravity = GravityCompliance::ur10_urdf(&model).unwrap();
    let robot = Ur10::exact(&model, &gravity, model.nominal_params(), &[0.0; 6]);
    let renamed = |set: MeasurementSet, name: &str| {
        MeasurementSet::new(name, set.measurements().to_vec()).unwrap()
    };
    let a = renamed(robot.station(first_station(), 4, 1), "north");
    let b = renamed(robot.station(second_station(), 3, 2), "south");
    let pooled = MeasurementSet::pooled(&[a, b]).unwrap();
    let text = pooled.to_csv_string();
    assert!(text.starts_with("pose_id,station,q1"), "{text}");
    let back = MeasurementSet::from_csv_str(&text, "pooled.csv").unwrap();
    assert_eq!(back.station_names(), ["north", "south"]);
    for (k, (m, original)) in back
        .measurements()
        .iter()
        .zip(pooled.measurements())
        .enumerate()
    {
        // Positions pass through millimetres: equal to the last bits.
        assert!((m.position - original.position).norm() < 1e-15, "{k}");
        assert_eq!((&m.pose_id, &m.q), (&original.pose_id, &original.q));
        assert_eq!(back.station_of(k), pooled.station_of(k));
    }
    // A subset keeps every station, even one it has no pose of.
    let subset = pooled.subset(&[0, 1]).unwrap();
    assert_eq!(subset.n_stations(), 2);
    assert!(subset.station_poses(1).is_none());
    // An empty station cell is named by its line.
    let broken = text.replacen(",south,", ",,", 1);
    let e = MeasurementSet::from_csv_str(&broken, "broken.csv").unwrap_err();
    assert!(
        e.to_string().contains("broken.csv") && e.to_string().contains("station"),
        "{e}"
    );
}

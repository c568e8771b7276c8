//! The simulated measurement sets of the several-target benchmarks
//! (`benches/calib.rs`), shared with `examples/threads_speed.rs`.

use std::path::PathBuf;

use flexcal_calib::{
    GravityCompliance, MeasurementSet, TargetObservation, TargetPose, read_targets,
    rotation_from_vector,
};
use flexcal_kinematics::{
    Data, PointLoad, RobotDescription, actuated_forces_into, forward_frame_pose,
};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

/// A measurement set of the robot of `tests/data/<robot>.toml` with its
/// targets (`<robot>_targets.toml`): `n` poses over the joint limits,
/// geometric errors of +-0.3 mm / rad x 1e-3, every joint deflected by
/// `compliance` (rad/N.m) times its gravity torque under the mass table
/// (one linear step: a workload for the identification, not a truth), an
/// unknown tracker frame and `noise` (m) per axis.
pub fn target_set(
    robot: &str,
    gravity: &GravityCompliance,
    n: usize,
    compliance: f64,
    noise: f64,
) -> (flexcal_kinematics::Model, MeasurementSet) {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let model = RobotDescription::from_toml_file(&data.join(format!("{robot}.toml")))
        .and_then(|d| d.build())
        .expect("the robot");
    let targets = read_targets(&data.join(format!("{robot}_targets.toml"))).expect("targets");
    let loads: Vec<PointLoad> = gravity
        .masses
        .iter()
        .map(|m| PointLoad {
            frame: model.frame_index(&m.frame).expect("a frame of the robot"),
            point: m.center,
            force: gravity.gravity * m.mass,
        })
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, noise).expect("a normal law");
    let xi: Vec<f64> = model
        .nominal_params()
        .iter()
        .map(|v| v + rng.random_range(-3e-4..3e-4))
        .collect();
    let tracker = Isometry3::from_parts(
        Translation3::new(2.5, -0.4, -0.9),
        rotation_from_vector(&Vector3::new(0.1, -0.2, 2.4)),
    );
    let mut kinematics = Data::new(&model);
    let mut tau = vec![0.0; model.n_actuated()];
    let poses = (0..n)
        .map(|k| {
            let q: Vec<f64> = model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect();
            actuated_forces_into(&model, &mut kinematics, &q, &xi, &loads, &mut tau)
                .expect("gravity torques");
            let deflected: Vec<f64> = q
                .iter()
                .zip(&tau)
                .map(|(q, t)| q + compliance * t)
                .collect();
            let observations = targets
                .iter()
                .map(|t| {
                    let frame = model.frame_index(&t.frame).expect("a frame of the robot");
                    let point =
                        Isometry3::from_parts(Translation3::from(t.offset), Default::default());
                    let x =
                        forward_frame_pose(&model, &mut kinematics, &deflected, &xi, frame, &point)
                            .expect("forward model");
                    let p = (tracker * x).translation.vector
                        + Vector3::from_fn(|_, _| noise.sample(&mut rng));
                    Some(TargetObservation::new(p))
                })
                .collect();
            TargetPose::new(Some(format!("p{k}")), q, observations)
        })
        .collect();
    let set = MeasurementSet::from_poses("bench", targets, poses).expect("a valid set");
    (model, set)
}

//! Shared helpers of the integration tests.

use flexcal_kinematics::{Data, Model, actuated_from_joint_angles, forward_pose};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A configuration drawn uniformly in the test domain of a built-in robot:
/// within the limits, away from wrist singularities, and for `ir663` within
/// the assembled domain of the four-bar (joint 2 in [-55, 10] deg, joint 8 in
/// [5, 45] deg); draws that do not assemble are redrawn.
#[allow(dead_code)]
pub fn random_configuration(model: &Model, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let xi = model.nominal_params();
    let mut data = Data::new(model);
    for _ in 0..100 {
        let q: Vec<f64> = if model.name() == "ir663" {
            let joints = [
                rng.random_range(-1.0..1.0),
                rng.random_range(-55f64..10.0).to_radians(),
                rng.random_range(5f64..45.0).to_radians(),
                rng.random_range(-1.0..1.0),
                rng.random_range(0.5..2.5),
                rng.random_range(-1.0..1.0),
            ];
            match actuated_from_joint_angles(model, &joints) {
                Ok(q) => q,
                Err(_) => continue,
            }
        } else {
            model
                .actuated_limits()
                .iter()
                .enumerate()
                .map(|(k, &(lo, hi))| {
                    let (lo, hi) = (lo.max(-2.5), hi.min(2.5));
                    let v = rng.random_range(lo..hi);
                    // Keep the wrist bent (joint 5) to stay off its singularity.
                    if k == 4 && v.abs() < 0.3 { v + 0.6 } else { v }
                })
                .collect()
        };
        if forward_pose(model, &mut data, &q, xi).is_ok() {
            return q;
        }
    }
    panic!("no assembled configuration found for {}", model.name());
}

//! The pose and parameter Jacobian of a point on any frame (not only the
//! TCP), against central finite differences: on a tree (a torso carrying two
//! arms, whose hands lie on different branches) and on a closed loop (the
//! IR-663's parallelogram, frames before and after the loop's passive
//! joints).

use flexcal_kinematics::{
    Data, Model, RobotDescription, forward_frame_pose, forward_pose,
    frame_param_and_joint_jacobians_into, frame_param_jacobian, frame_points_jacobians_into,
    param_jacobian,
};
use nalgebra::{DMatrix, Isometry3, Matrix6xX, Translation3, UnitQuaternion, Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod common;

/// A torso joint carrying two four-joint arms, each ending in a hand frame.
const TWO_ARMS: &str = r#"
name = "two-arms"
end_frame = "LH"
[[frame]]
name = "1"
joint = "revolute"
actuated = true
r_mm = 400
[[frame]]
name = "L1"
antecedent = "1"
joint = "revolute"
actuated = true
alpha_deg = 90
d_mm = 200
[[frame]]
name = "L2"
antecedent = "L1"
joint = "revolute"
actuated = true
alpha_deg = -90
[[frame]]
name = "L3"
antecedent = "L2"
joint = "revolute"
actuated = true
alpha_deg = 90
r_mm = 300
[[frame]]
name = "L4"
antecedent = "L3"
joint = "revolute"
actuated = true
alpha_deg = 90
d_mm = 80
[[frame]]
name = "LH"
antecedent = "L4"
joint = "fixed"
alpha_deg = -90
d_mm = -80
r_mm = 250
[[frame]]
name = "R1"
antecedent = "1"
joint = "revolute"
actuated = true
gamma_deg = 180
b_mm = 50
alpha_deg = 90
d_mm = 200
[[frame]]
name = "R2"
antecedent = "R1"
joint = "revolute"
actuated = true
alpha_deg = -90
[[frame]]
name = "R3"
antecedent = "R2"
joint = "revolute"
actuated = true
alpha_deg = 90
r_mm = 300
[[frame]]
name = "R4"
antecedent = "R3"
joint = "revolute"
actuated = true
alpha_deg = 90
d_mm = 80
[[frame]]
name = "RH"
antecedent = "R4"
joint = "fixed"
alpha_deg = -90
d_mm = -80
r_mm = 250
"#;

fn point(offset_mm: [f64; 3], rotation: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(Vector3::from(offset_mm) * 1e-3),
        UnitQuaternion::from_scaled_axis(Vector3::from(rotation)),
    )
}

fn pose_difference(plus: &Isometry3<f64>, minus: &Isometry3<f64>, h: f64) -> Vector6<f64> {
    let dp = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
    let dphi = (plus.rotation * minus.rotation.inverse()).scaled_axis() / (2.0 * h);
    Vector6::new(dp.x, dp.y, dp.z, dphi.x, dphi.y, dphi.z)
}

/// Checks the frame Jacobian of `frame` against central differences at
/// seeded configurations and perturbed parameters; returns the columns that
/// are exactly zero at every configuration.
fn check_frame(
    model: &Model,
    frame: &str,
    x_frame_point: &Isometry3<f64>,
    configurations: &[Vec<f64>],
    rng: &mut ChaCha8Rng,
) -> Vec<String> {
    let f = model.frame_index(frame).unwrap();
    let mut data = Data::new(model);
    let mut never_moves = vec![true; model.n_params()];
    for q in configurations {
        let xi: Vec<f64> = model
            .nominal_params()
            .iter()
            .map(|v| v + 1e-3 * rng.random_range(-1.0..1.0))
            .collect();
        let (pose, jac) = frame_param_jacobian(model, &mut data, q, &xi, f, x_frame_point).unwrap();
        let direct = forward_frame_pose(model, &mut data, q, &xi, f, x_frame_point).unwrap();
        assert!((pose.translation.vector - direct.translation.vector).norm() < 1e-14);
        assert!(pose.rotation.angle_to(&direct.rotation) < 1e-12);
        let h = 1e-6;
        let mut numeric = DMatrix::zeros(6, model.n_params());
        for j in 0..model.n_params() {
            let mut x = xi.clone();
            x[j] += h;
            let plus = forward_frame_pose(model, &mut data, q, &x, f, x_frame_point).unwrap();
            x[j] -= 2.0 * h;
            let minus = forward_frame_pose(model, &mut data, q, &x, f, x_frame_point).unwrap();
            numeric.set_column(j, &pose_difference(&plus, &minus, h));
        }
        let scale = jac.amax().max(1.0);
        let err = (&jac - &numeric).amax() / scale;
        assert!(
            err < 1e-6,
            "{}, frame {frame}: Jacobian error {err:e} at q = {q:?}",
            model.name()
        );
        assert!(
            jac.amax() > 0.1,
            "frame {frame}: the Jacobian is (nearly) zero"
        );
        // The joint Jacobian of the same point from the same pass.
        let na = model.n_actuated();
        let (mut params, mut joints) = (DMatrix::zeros(6, model.n_params()), Matrix6xX::zeros(na));
        let both = frame_param_and_joint_jacobians_into(
            model,
            &mut data,
            q,
            &xi,
            f,
            x_frame_point,
            &mut params,
            &mut joints,
        )
        .unwrap();
        assert!((both.translation.vector - pose.translation.vector).norm() < 1e-12);
        assert!((&params - &jac).amax() < 1e-12);
        let mut numeric_q = Matrix6xX::zeros(na);
        for c in 0..na {
            let mut qc = q.clone();
            qc[c] += h;
            let plus = forward_frame_pose(model, &mut data, &qc, &xi, f, x_frame_point).unwrap();
            qc[c] -= 2.0 * h;
            let minus = forward_frame_pose(model, &mut data, &qc, &xi, f, x_frame_point).unwrap();
            numeric_q.set_column(c, &pose_difference(&plus, &minus, h));
        }
        let err_q = (&joints - &numeric_q).amax() / joints.amax().max(1.0);
        assert!(
            err_q < 1e-6,
            "{}, frame {frame}: joint Jacobian error {err_q:e} at q = {q:?}",
            model.name()
        );
        for (j, moves) in never_moves.iter_mut().enumerate() {
            if jac.column(j).amax() != 0.0 {
                *moves = false;
            }
        }
    }
    model
        .params()
        .iter()
        .zip(&never_moves)
        .filter(|(_, n)| **n)
        .map(|(p, _)| p.name.clone())
        .collect()
}

#[test]
fn hands_of_a_two_armed_tree_match_finite_differences_and_see_only_their_branch() {
    let model = RobotDescription::from_toml_str(TWO_ARMS, "two-arms.toml")
        .unwrap()
        .build()
        .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x7472_6565);
    let configurations: Vec<Vec<f64>> = (0..6)
        .map(|_| {
            (0..model.n_actuated())
                .map(|_| rng.random_range(-2.0..2.0))
                .collect()
        })
        .collect();
    let marker = point([30.0, -20.0, 40.0], [0.3, -0.2, 0.5]);
    let left_blind = check_frame(&model, "LH", &marker, &configurations, &mut rng);
    let right_blind = check_frame(&model, "RH", &marker, &configurations, &mut rng);
    // Each hand is moved by the torso and its own arm, never by the other
    // arm: exactly the other arm's parameters have zero columns.
    let of_arm = |arm: char| -> Vec<String> {
        model
            .params()
            .iter()
            .filter(|p| p.frame.starts_with(arm))
            .map(|p| p.name.clone())
            .collect()
    };
    assert_eq!(left_blind, of_arm('R'));
    assert_eq!(right_blind, of_arm('L'));
    assert!(left_blind.contains(&"dR3".to_string()));
    // Nor do the other arm's joints move a hand: their joint columns are
    // zero, the torso's and the own arm's are not.
    let mut data = Data::new(&model);
    let na = model.n_actuated();
    let (mut params, mut joints) = (DMatrix::zeros(6, model.n_params()), Matrix6xX::zeros(na));
    let left_hand = model.frame_index("LH").unwrap();
    frame_param_and_joint_jacobians_into(
        &model,
        &mut data,
        &configurations[1],
        model.nominal_params(),
        left_hand,
        &marker,
        &mut params,
        &mut joints,
    )
    .unwrap();
    for (c, name) in model.actuated_names().iter().enumerate() {
        let moves = joints.column(c).amax() > 0.0;
        assert_eq!(moves, !name.contains('R'), "joint {name} on the left hand");
    }
    // Several points from one pass equal the calls point by point.
    let points: Vec<(usize, Isometry3<f64>)> = ["LH", "RH", "L3"]
        .iter()
        .map(|f| (model.frame_index(f).unwrap(), marker))
        .collect();
    let mut params_all = vec![DMatrix::zeros(6, model.n_params()); 3];
    let mut joints_all = vec![Matrix6xX::zeros(na); 3];
    let mut poses = vec![Isometry3::identity(); 3];
    let q = &configurations[2];
    frame_points_jacobians_into(
        &model,
        &mut data,
        q,
        model.nominal_params(),
        &points,
        &mut params_all,
        &mut joints_all,
        &mut poses,
    )
    .unwrap();
    for (i, (frame, point)) in points.iter().enumerate() {
        let pose = frame_param_and_joint_jacobians_into(
            &model,
            &mut data,
            q,
            model.nominal_params(),
            *frame,
            point,
            &mut params,
            &mut joints,
        )
        .unwrap();
        assert!((pose.translation.vector - poses[i].translation.vector).norm() < 1e-14);
        assert!((&params - &params_all[i]).amax() < 1e-14);
        assert!((&joints - &joints_all[i]).amax() < 1e-14);
    }
    // Too few outputs is a named error.
    let err = frame_points_jacobians_into(
        &model,
        &mut data,
        q,
        model.nominal_params(),
        &points,
        &mut params_all[..2],
        &mut joints_all,
        &mut poses,
    )
    .unwrap_err();
    assert!(err.to_string().contains("one per point"), "{err}");
    // An intermediate frame of an arm (the elbow) too.
    check_frame(
        &model,
        "L3",
        &Isometry3::identity(),
        &configurations,
        &mut rng,
    );
    // The end frame with the tool transform is the TCP of the classic call.
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let q = &configurations[0];
    let (tcp, jac_tcp) = param_jacobian(&model, &mut data, q, &xi).unwrap();
    let (point_pose, jac_point) =
        frame_param_jacobian(&model, &mut data, q, &xi, model.end_frame(), &model.tool()).unwrap();
    assert!((tcp.translation.vector - point_pose.translation.vector).norm() < 1e-14);
    assert!((jac_tcp - jac_point).amax() < 1e-14);
}

#[test]
fn frames_of_a_closed_loop_robot_match_finite_differences() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0x6c6f_6f70);
    let configurations: Vec<Vec<f64>> = (0..5)
        .map(|_| common::random_configuration(&model, &mut rng))
        .collect();
    let marker = point([120.0, 15.0, -60.0], [0.1, 0.4, -0.2]);
    // Every frame of the robot: on the loop, beyond it, and the end frame.
    for frame in model.frame_names().to_vec() {
        check_frame(&model, &frame, &marker, &configurations, &mut rng);
    }
    let mut data = Data::new(&model);
    let xi = model.nominal_params().to_vec();
    let q = &configurations[0];
    let (tcp, jac_tcp) = param_jacobian(&model, &mut data, q, &xi).unwrap();
    let (point_pose, jac_point) =
        frame_param_jacobian(&model, &mut data, q, &xi, model.end_frame(), &model.tool()).unwrap();
    assert!((tcp.translation.vector - point_pose.translation.vector).norm() < 1e-14);
    assert!((jac_tcp - jac_point).amax() < 1e-12);
    assert!(forward_pose(&model, &mut data, q, &xi).is_ok());
}

#[test]
fn a_frame_index_out_of_range_is_a_named_error() {
    let model = RobotDescription::builtin("ur10").unwrap().build().unwrap();
    let mut data = Data::new(&model);
    let q = [0.0; 6];
    let xi = model.nominal_params().to_vec();
    let err =
        frame_param_jacobian(&model, &mut data, &q, &xi, 99, &Isometry3::identity()).unwrap_err();
    assert!(err.to_string().contains("frame index"), "{err}");
    assert!(forward_frame_pose(&model, &mut data, &q, &xi, 99, &Isometry3::identity()).is_err());
}

/// The parameter and joint Jacobians from one forward pass equal those of
/// two separate calls (to rounding), on a serial robot and on a closed loop.
#[test]
fn param_and_joint_jacobians_from_one_pass_equal_the_separate_calls() {
    use flexcal_kinematics::{joint_jacobian_into, param_and_joint_jacobians_into};
    use nalgebra::Matrix6xX;
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    for name in ["ur10", "ir663"] {
        let model = RobotDescription::builtin(name).unwrap().build().unwrap();
        let mut data = Data::new(&model);
        let xi = model.nominal_params().to_vec();
        for _ in 0..5 {
            let q: Vec<f64> = model
                .actuated_limits()
                .iter()
                .map(|&(lo, hi)| lo + 0.1 * (hi - lo) + 0.8 * (hi - lo) * rng.random::<f64>())
                .collect();
            let (pose, params) = param_jacobian(&model, &mut data, &q, &xi).unwrap();
            let mut joints = Matrix6xX::zeros(model.n_actuated());
            joint_jacobian_into(&model, &mut data, &q, &xi, &mut joints).unwrap();
            let mut params_once = DMatrix::zeros(6, model.n_params());
            let mut joints_once = Matrix6xX::zeros(model.n_actuated());
            let pose_once = param_and_joint_jacobians_into(
                &model,
                &mut data,
                &q,
                &xi,
                &mut params_once,
                &mut joints_once,
            )
            .unwrap();
            // A closed loop's passive joints are solved from the previous
            // solution: two passes agree to rounding, not bit for bit.
            let close = |a: &[f64], b: &[f64]| {
                a.iter()
                    .zip(b)
                    .all(|(x, y)| (x - y).abs() <= 1e-12 * (1.0 + x.abs()))
            };
            assert!(
                close(
                    pose.to_homogeneous().as_slice(),
                    pose_once.to_homogeneous().as_slice()
                ),
                "{name}"
            );
            assert!(close(params.as_slice(), params_once.as_slice()), "{name}");
            assert!(close(joints.as_slice(), joints_once.as_slice()), "{name}");
        }
    }
}

//! The IR-663: four-bar closure, slider cranks, coupling; closed form against
//! the general Newton solver.

use flexcal_kinematics::{
    Data, KinematicsError, LoopSolver, RobotDescription, actuated_from_joint_angles,
    forward_frames, forward_pose, joint_angles_from_actuated,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

mod common;

#[test]
fn ir663_has_the_papers_43_parameters_and_6_actuated_coordinates() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    assert_eq!(model.n_params(), 43);
    assert_eq!(
        model.actuated_names(),
        ["theta1", "r2p", "r8p", "theta4", "theta5", "theta7"]
    );
    assert_eq!(model.params()[0].name, "alpha1");
    assert_eq!(model.params()[42].name, "d11");
    assert_eq!(model.passive_names(), ["3", "10", "9"]);
    let xi = model.nominal_params();
    let r1 = model.param_index("r1").unwrap();
    assert!((xi[r1] - 0.885).abs() < 1e-15);
}

#[test]
fn ir663_loop_closes_over_the_domain_and_the_coupling_holds() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let mut rng = ChaCha8Rng::seed_from_u64(663);
    let (f10, f11) = (
        model.frame_index("10").unwrap(),
        model.frame_index("11").unwrap(),
    );
    let (f5, f6) = (
        model.frame_index("5").unwrap(),
        model.frame_index("6").unwrap(),
    );
    for _ in 0..50 {
        let q = common::random_configuration(&model, &mut rng);
        forward_frames(&model, &mut data, &q, &xi).unwrap();
        let a = data.frame_pose(f10).unwrap();
        let b = data.frame_pose(f11).unwrap();
        // With nominal (planar) parameters the cut frames coincide entirely.
        assert!((a.translation.vector - b.translation.vector).norm() < 1e-9);
        assert!(a.rotation.angle_to(&b.rotation) < 1e-9);
        // Distance joint 10 - joint 9 is d11 (the closure the paper's U solves).
        let o9 = data.frame_origin(model.frame_index("9").unwrap()).unwrap();
        assert!(((a.translation.vector - o9).norm() - 1.212).abs() < 1e-9);
        let joints = data.joint_values();
        assert!((joints[f6] + joints[f5]).abs() < 1e-15, "theta6 = -theta5");
    }
}

#[test]
fn four_bar_closed_form_and_newton_agree() {
    let closed = RobotDescription::builtin("ir663").unwrap();
    let mut newton = closed.clone();
    newton.loops[0].solver = LoopSolver::Newton;
    let closed = closed.build().unwrap();
    let newton = newton.build().unwrap();
    let xi = closed.nominal_params().to_vec();
    let mut data_closed = Data::new(&closed);
    let mut data_newton = Data::new(&newton);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    // A path through the domain: Newton follows its previous solution.
    let mut q = common::random_configuration(&closed, &mut rng);
    for _ in 0..40 {
        let x_closed = forward_pose(&closed, &mut data_closed, &q, &xi).unwrap();
        let x_newton = forward_pose(&newton, &mut data_newton, &q, &xi).unwrap();
        assert!((x_closed.translation.vector - x_newton.translation.vector).norm() < 1e-10);
        for (a, b) in data_closed
            .passive_values()
            .iter()
            .zip(data_newton.passive_values())
        {
            assert!((a - b).abs() < 1e-10, "passive {a} vs {b}");
        }
        let next = common::random_configuration(&closed, &mut rng);
        for (v, n) in q.iter_mut().zip(&next) {
            *v += 0.1 * (n - *v);
        }
    }
}

#[test]
fn slider_crank_conversion_round_trips() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..100 {
        let q = common::random_configuration(&model, &mut rng);
        let joints = joint_angles_from_actuated(&model, &q).unwrap();
        let back = actuated_from_joint_angles(&model, &joints).unwrap();
        for (a, b) in q.iter().zip(&back) {
            assert!((a - b).abs() < 1e-12);
        }
        // Law of cosines with r'^2: screw length from the joint-2 angle.
        let crank_angle = joints[1] - (-102f64).to_radians() + 10f64.to_radians();
        let (l1, l3) = (0.35, 0.85);
        let screw = (l1 * l1 + l3 * l3 - 2.0 * l1 * l3 * crank_angle.cos()).sqrt();
        assert!((screw - q[1]).abs() < 1e-12);
    }
}

#[test]
fn out_of_range_screw_and_open_loop_are_named_errors() {
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    // Screw longer than l1 + l3.
    let q = [0.0, 1.3, 0.8, 0.0, 1.0, 0.0];
    match forward_pose(&model, &mut data, &q, &xi) {
        Err(KinematicsError::SliderCrankOutOfRange { joint, .. }) => assert_eq!(joint, "2"),
        other => panic!("expected SliderCrankOutOfRange, got {other:?}"),
    }
    // Upper arm and crank 40 deg apart: joints 3 and 9 come closer than
    // d11 - d10, the coupler cannot reach.
    let joints = [0.0, 25f64.to_radians(), -25f64.to_radians(), 0.0, 1.0, 0.0];
    let far = actuated_from_joint_angles(&model, &joints).unwrap();
    match forward_pose(&model, &mut data, &far, &xi) {
        Err(KinematicsError::LoopCannotClose { loop_name, q, .. }) => {
            assert_eq!(loop_name, "four-bar");
            assert_eq!(q, far);
        }
        other => panic!("expected LoopCannotClose, got {other:?}"),
    }
}

/// Serpentine grid so that each inverse solution seeds the next.
fn serpentine(xs: &[f64], ys: &[f64], zs: &[f64]) -> Vec<nalgebra::Vector3<f64>> {
    let mut out = Vec::new();
    for (i, &x) in xs.iter().enumerate() {
        for (j, &y) in ys.iter().enumerate() {
            let y_row: Vec<f64> = zs.to_vec();
            let forward = (i + j) % 2 == 0;
            for k in 0..y_row.len() {
                let z = if forward {
                    y_row[k]
                } else {
                    y_row[y_row.len() - 1 - k]
                };
                out.push(nalgebra::Vector3::new(x, y, z));
            }
        }
    }
    out
}

fn steps(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..=n)
        .map(|i| lo + (hi - lo) * i as f64 / n as f64)
        .collect()
}

/// Smallest distance (m) from the shoulder (joint 2's axis) to the wrist
/// centre that the IR-663's four-bar allows, from its nominal lengths: the
/// triangle of joint 8, joint 9 and joint 10 keeps joints 2 (= 8) and 10 at
/// least d11 - d9 apart, which bounds the elbow angle between the upper arm
/// (d3) and the forearm, on which joint 10 lies d10 from joint 3 and the
/// wrist centre r4 + d10.
fn ir663_smallest_wrist_distance(model: &flexcal_kinematics::Model) -> f64 {
    let xi = model.nominal_params();
    let p = |name: &str| xi[model.param_index(name).unwrap()];
    let (d3, d9, d10, d11) = (p("d3"), p("d9"), p("d10"), p("d11"));
    let forearm = p("r4") + d10;
    let closest = d11 - d9;
    let cos_elbow = (d3 * d3 + d10 * d10 - closest * closest) / (2.0 * d3 * d10);
    (d3 * d3 + forearm * forearm - 2.0 * d3 * forearm * cos_elbow).sqrt()
}

/// Distance (m) from the shoulder to the wrist centre for a TCP at `p` with
/// the tool pointing straight down.
fn ir663_wrist_distance_tool_down(
    model: &flexcal_kinematics::Model,
    p: &nalgebra::Vector3<f64>,
) -> f64 {
    let xi = model.nominal_params();
    let v = |name: &str| xi[model.param_index(name).unwrap()];
    p.x.hypot(p.y).hypot(p.z + v("rE") - v("r1"))
}

#[test]
fn ir663_reaches_box_59_and_box_65_with_the_tool_down_except_the_four_bar_dead_centre() {
    use flexcal_kinematics::{InverseOptions, InverseTarget, inverse_pose};
    use nalgebra::{Isometry3, UnitQuaternion, Vector3};
    let mut unlimited = RobotDescription::builtin("ir663").unwrap();
    for f in unlimited.frames.iter_mut() {
        f.limits_deg = None;
        f.limits_mm = None;
    }
    let unlimited = unlimited.build().unwrap();
    let model = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let xi = model.nominal_params().to_vec();
    let mut data = Data::new(&model);
    let (f10, f11) = (
        model.frame_index("10").unwrap(),
        model.frame_index("11").unwrap(),
    );
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let options = InverseOptions {
        target: InverseTarget::PositionAndToolAxis,
        ..InverseOptions::default()
    };
    let start = actuated_from_joint_angles(&model, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0]).unwrap();
    // 1.388 m with Table 2: elbow folded to 32.0 deg, crank and coupler in line.
    let smallest = ir663_smallest_wrist_distance(&model);
    assert!((smallest - 1.3883).abs() < 1e-4, "{smallest}");
    let box59 = serpentine(
        &steps(1.4, 2.1, 4),
        &steps(-0.3, 0.3, 4),
        &steps(1.4, 1.7, 3),
    );
    // The paper's 7 x 9 grid of (65), then a finer one.
    let grid65 = serpentine(&steps(1.25, 2.25, 6), &[0.0], &steps(0.85, 2.15, 8));
    let fine65 = serpentine(&steps(1.25, 2.25, 10), &[0.0], &steps(0.85, 2.15, 13));
    let mut grid65_out_of_reach = Vec::new();
    for (name, points) in [("(59)", box59), ("(65)", grid65), ("(65) fine", fine65)] {
        let mut seed = start.clone();
        for p in points {
            let target = Isometry3::from_parts(p.into(), down);
            let reach = ir663_wrist_distance_tool_down(&model, &p);
            if reach < smallest - 1e-3 {
                // No configuration exists, limits or not.
                if name == "(65)" {
                    grid65_out_of_reach.push(p);
                }
                for robot in [&model, &unlimited] {
                    let mut d = Data::new(robot);
                    assert!(
                        inverse_pose(robot, &mut d, &target, &seed, &xi, &options).is_err(),
                        "box {name}: {p:?} reached although the wrist centre would be \
                         {reach} m < {smallest} m from the shoulder"
                    );
                }
                continue;
            }
            if reach < smallest + 0.02 {
                // Within 20 mm of the dead centre: no claim either way.
                continue;
            }
            let s = inverse_pose(&model, &mut data, &target, &seed, &xi, &options)
                .unwrap_or_else(|e| panic!("box {name}: {p:?}: {e}"));
            for (q, (lo, hi)) in s.q.iter().zip(model.actuated_limits()) {
                assert!(
                    (*lo..=*hi).contains(q),
                    "box {name}: {p:?}: {q} out of limits"
                );
            }
            forward_frames(&model, &mut data, &s.q, &xi).unwrap();
            let residual =
                (data.frame_origin(f10).unwrap() - data.frame_origin(f11).unwrap()).norm();
            assert!(
                residual < 1e-9,
                "box {name}: {p:?}: loop residual {residual} m"
            );
            let joints = joint_angles_from_actuated(&model, &s.q).unwrap();
            assert!((-61f64..15.0).contains(&joints[1].to_degrees()));
            seed = s.q;
        }
    }
    // Exactly the three lowest points at x = 1.25 m (z 0.85, 1.0125, 1.175).
    assert_eq!(grid65_out_of_reach.len(), 3, "{grid65_out_of_reach:?}");
    for p in &grid65_out_of_reach {
        assert!((p.x - 1.25).abs() < 1e-12 && p.z < 1.2);
    }
}

#[test]
fn full_six_component_closure_agrees_with_the_planar_one_and_differentiates() {
    use flexcal_kinematics::{LoopConstraint, param_jacobian};
    let planar = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let mut full = RobotDescription::builtin("ir663").unwrap();
    full.loops[0].constraint = LoopConstraint::Full;
    full.loops[0].solver = LoopSolver::Newton;
    let full = full.build().unwrap();
    let xi = planar.nominal_params().to_vec();
    let (mut data_planar, mut data_full) = (Data::new(&planar), Data::new(&full));
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    // Start where the passive seeds of the description hold, then walk: the
    // Newton closure follows its previous solution, branch by branch.
    let mut q = actuated_from_joint_angles(
        &planar,
        &[
            0.0,
            (-33.8f64).to_radians(),
            24.4f64.to_radians(),
            0.5,
            1.5,
            0.0,
        ],
    )
    .unwrap();
    for step in 0..30 {
        if step % 6 == 5 {
            let next = common::random_configuration(&planar, &mut rng);
            for (v, n) in q.iter_mut().zip(&next) {
                *v += 0.15 * (n - *v);
            }
        }
        let (x_planar, j_planar) = param_jacobian(&planar, &mut data_planar, &q, &xi).unwrap();
        let (x_full, j_full) = param_jacobian(&full, &mut data_full, &q, &xi).unwrap();
        assert!((x_planar.translation.vector - x_full.translation.vector).norm() < 1e-10);
        // Parameters that keep the loop planar leave both closures consistent:
        // their columns agree; the others (beta3, alpha3, r3 tilt or shift the
        // loop out of its plane) only the planar closure can follow.
        for (j, p) in planar.params().iter().enumerate() {
            if ["beta3", "alpha3", "r3"].contains(&p.name.as_str()) {
                continue;
            }
            let diff = (j_planar.column(j) - j_full.column(j)).amax();
            assert!(diff < 1e-8, "{}: {diff:e}", p.name);
        }
        // Central differences through the full (Gauss-Newton) closure.
        let h = 1e-6;
        for name in ["d9", "d10", "d11", "l38", "kappa2"] {
            let j = full.param_index(name).unwrap();
            let mut x = xi.clone();
            x[j] += h;
            let plus = forward_pose(&full, &mut data_full, &q, &x).unwrap();
            x[j] -= 2.0 * h;
            let minus = forward_pose(&full, &mut data_full, &q, &x).unwrap();
            let fd = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
            let analytic = j_full.fixed_view::<3, 1>(0, j).into_owned();
            assert!(
                (fd - analytic).amax() < 1e-6 * analytic.amax().max(1.0),
                "{name}"
            );
        }
    }
}

#[test]
fn passive_seeds_select_the_assembly_branch_newton_follows() {
    let mut other = RobotDescription::builtin("ir663").unwrap();
    other.loops[0].branch = 1;
    let other = other.build().unwrap();
    let mut newton = RobotDescription::builtin("ir663").unwrap();
    newton.loops[0].solver = LoopSolver::Newton;
    let newton = newton.build().unwrap();
    let xi = other.nominal_params().to_vec();
    let q = actuated_from_joint_angles(
        &other,
        &[
            0.0,
            (-20f64).to_radians(),
            25f64.to_radians(),
            0.5,
            1.5,
            0.0,
        ],
    )
    .unwrap();
    let mut data_other = Data::new(&other);
    let x_other = forward_pose(&other, &mut data_other, &q, &xi).unwrap();
    let mut data = Data::new(&newton);
    let x_default = forward_pose(&newton, &mut data, &q, &xi).unwrap();
    // The two assemblies put the TCP far apart.
    assert!((x_default.translation.vector - x_other.translation.vector).norm() > 0.1);
    let seeds: Vec<f64> = data_other
        .passive_values()
        .iter()
        .map(|v| v + 0.05)
        .collect();
    data.set_passive_values(&newton, &seeds).unwrap();
    let x = forward_pose(&newton, &mut data, &q, &xi).unwrap();
    assert!((x.translation.vector - x_other.translation.vector).norm() < 1e-10);
    assert!(matches!(
        data.set_passive_values(&newton, &[0.0]),
        Err(KinematicsError::WrongLength { .. })
    ));
}

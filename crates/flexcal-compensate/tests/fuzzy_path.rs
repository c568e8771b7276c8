//! Path compensation of the IR-663 with the fuzzy compliance model.

use flexcal_compensate::compensation::{Cell, ElastoGeometricModel};
use flexcal_compensate::path::PathPoint;
use flexcal_compensate::process::{BeamTheory, CantileverBeam, ProcessModel};
use flexcal_elastic::fuzzy_compliance::{
    ComplianceComponent, FuzzyCompliance, InputSpec, RobotFuzzyCompliance,
};
use flexcal_fuzzy::{FuzzyModel, FuzzyStructure, Partition};
use flexcal_kinematics::{Data, Model, RobotDescription, actuated_from_joint_angles, inverse_pose};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};

/// A 4 x 3-rule plane compliance of the IR-663's size (m/N).
fn ir663_fuzzy(robot: &Model) -> RobotFuzzyCompliance {
    let structure = FuzzyStructure::new(
        vec!["theta2".into(), "theta8".into()],
        vec![
            Partition::new(vec![-1.2, -0.6, -0.1, 0.5]).unwrap(),
            Partition::new(vec![-0.5, 0.4, 1.3]).unwrap(),
        ],
    )
    .unwrap();
    let components = ComplianceComponent::plane_xz().to_vec();
    let models = components
        .iter()
        .zip([1.0e-6, 0.3e-6, 0.25e-6, 1.5e-6])
        .map(|(c, scale)| {
            let conclusions = (0..12)
                .map(|rule| scale * (1.0 + 0.04 * rule as f64))
                .collect();
            FuzzyModel::new(structure.clone(), c.name(), conclusions).unwrap()
        })
        .collect();
    let inputs = vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")];
    let compliance = FuzzyCompliance::new(inputs, components, models).unwrap();
    RobotFuzzyCompliance::new(compliance, robot.clone()).unwrap()
}

/// The fuzzy model drives path compensation of the IR-663 (closed loops,
/// ball screws) in the forming cell: the tracked path must equal the
/// points compensated one by one from scratch, with and without the beam.
#[test]
fn tracked_ir663_path_equals_points_compensated_from_scratch() {
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let fuzzy = ir663_fuzzy(&robot);
    let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
    let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
    let points = 150;
    let path: Vec<PathPoint> = (0..points)
        .map(|k| PathPoint {
            line: k + 2,
            x_part_tcp: Isometry3::from_parts(
                Translation3::new(0.58 - 0.2 * k as f64 / (points - 1) as f64, 0.0, -0.025),
                down,
            ),
        })
        .collect();
    let cell = Cell {
        x_base_part: Isometry3::translation(1.2, 0.0, 1.45),
        payload_base: Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0),
    };
    let mut data = Data::new(&robot);
    let xi = robot.nominal_params().to_vec();
    let start = actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0]).unwrap();
    let first = cell.x_base_part * path[0].x_part_tcp;
    let seed = inverse_pose(&robot, &mut data, &first, &start, &xi, &Default::default())
        .unwrap()
        .q;
    for process in [None, Some(&beam as &dyn ProcessModel)] {
        let egm =
            ElastoGeometricModel::with_nominal_geometry(&robot, &fuzzy, process, cell.clone());
        let mut workspace = egm.data().unwrap();
        let tracked = egm.compensate_path(&mut workspace, &path, &seed, &Default::default());
        let mut cold_seed = seed.clone();
        for (k, outcome) in tracked.iter().enumerate() {
            let t = outcome.result.as_ref().unwrap();
            let target = cell.x_base_part * path[k].x_part_tcp;
            let next = cell.x_base_part * path[(k + 1).min(points - 1)].x_part_tcp;
            let previous = cell.x_base_part * path[k.saturating_sub(1)].x_part_tcp;
            let motion = if k + 1 < points {
                next.translation.vector - target.translation.vector
            } else {
                target.translation.vector - previous.translation.vector
            };
            let c = egm
                .compensate_pose(
                    &mut workspace,
                    &target,
                    &cold_seed,
                    &motion,
                    &Default::default(),
                )
                .unwrap();
            cold_seed.clone_from(&c.q_commanded);
            assert!(t.residual.fixed_rows::<3>(0).norm() <= 1e-9);
            assert!(t.residual.fixed_rows::<3>(3).norm() <= 1e-9);
            for (a, b) in t.q_commanded.iter().zip(&c.q_commanded) {
                assert!((a - b).abs() < 1e-7, "point {k}: {a} vs {b}");
            }
            assert!((t.uncompensated_error - c.uncompensated_error).norm() < 1e-9);
        }
    }
}

//! Unit tests of compensation.

use super::*;
use flexcal_kinematics::{InverseTarget, KinematicsError, Model};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3, Vector6};

use super::point::converged;
use crate::path::PathPoint;
use crate::process::{BeamTheory, CantileverBeam, ConstantWrench};
use crate::process::{ProcessModel, ToolState};
use flexcal_kinematics::RobotDescription;
use nalgebra::Matrix6;

fn compliance() -> ConstantCompliance {
    // ~1.5e-3 mm/N in translation, like the paper's robot, slightly coupled.
    let mut c = Matrix6::from_diagonal(&Vector6::new(1.5e-6, 1.2e-6, 1.5e-6, 2e-7, 2e-7, 2e-7));
    c[(0, 2)] = 3e-7;
    c[(2, 0)] = 3e-7;
    ConstantCompliance { compliance: c }
}

/// The UR10 of these tests and the compliance above.
struct Ur10 {
    model: Model,
    elastic: ConstantCompliance,
}

impl Ur10 {
    fn new() -> Self {
        Self {
            model: RobotDescription::builtin("ur10").unwrap().build().unwrap(),
            elastic: compliance(),
        }
    }

    /// Its elasto-geometric model: nominal geometry, `process`, `cell`.
    fn egm<'a>(
        &'a self,
        process: Option<&'a dyn ProcessModel>,
        cell: Cell,
    ) -> ElastoGeometricModel<'a, ConstantCompliance> {
        ElastoGeometricModel::with_nominal_geometry(&self.model, &self.elastic, process, cell)
    }
}

fn tool_down_at(p: Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(p),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    )
}

/// The part frame of the path tests, with a payload (N, N.m in R0).
fn part_cell(payload_base: Vector6<f64>) -> Cell {
    Cell {
        x_base_part: Isometry3::translation(0.3, 0.25, 0.2),
        payload_base,
    }
}

/// A configuration near the targets of these tests (elbow up, tool down).
const SEED: [f64; 6] = [0.3, -1.2, 1.5, -1.9, -1.57, 0.0];

fn compensate_at_rest(
    egm: &ElastoGeometricModel<'_, ConstantCompliance>,
    data: &mut CompensationData<()>,
    target: &Isometry3<f64>,
) -> CompensatedPoint {
    egm.compensate_pose(data, target, &SEED, &Vector3::zeros(), &Default::default())
        .unwrap()
}

#[test]
fn zero_load_compensation_is_the_inverse_model() {
    let ur10 = Ur10::new();
    let egm = ur10.egm(None, Cell::payload_only(Vector6::zeros()));
    let mut data = egm.data().unwrap();
    let target = tool_down_at(Vector3::new(0.6, 0.3, 0.4));
    let c = compensate_at_rest(&egm, &mut data, &target);
    assert_eq!(c.iterations, 0);
    assert_eq!(c.q_commanded, c.q_uncompensated);
    assert!(position_norm(&c.uncompensated_error) < 1e-9);
}

#[test]
fn payload_is_compensated_to_solver_tolerance() {
    let ur10 = Ur10::new();
    let egm = ur10.egm(
        None,
        Cell::payload_only(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let mut data = egm.data().unwrap();
    let target = tool_down_at(Vector3::new(0.6, 0.3, 0.4));
    let c = compensate_at_rest(&egm, &mut data, &target);
    // Uncompensated: 920 N x 1.5e-3 mm/N ~ 1.4 mm down.
    assert!((c.uncompensated_error[2] + 920.0 * 1.5e-6).abs() < 1e-9);
    assert!(position_norm(&c.residual) <= 1e-9);
    // The fake pose sits above the target by the deflection.
    let lift = c.commanded_base.translation.vector.z - target.translation.vector.z;
    assert!((lift - 920.0 * 1.5e-6).abs() < 1e-6, "{lift}");
}

#[test]
fn forming_beam_and_robot_are_solved_together() {
    let ur10 = Ur10::new();
    let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
    // Beam along base x, clamp at x = 0.3, top surface at z = 0.2.
    let x_base_part = Isometry3::translation(0.3, 0.25, 0.2);
    let egm = ur10.egm(
        Some(&beam),
        Cell {
            x_base_part,
            payload_base: Vector6::zeros(),
        },
    );
    let mut data = egm.data().unwrap();
    let path = crate::path::tool_down_line(0.58, 5);
    let outcomes = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
    let mut previous_error = 0.0;
    for o in &outcomes {
        let c = o.result.as_ref().unwrap();
        // The beam pushes the tool up: the uncompensated tool sits above
        // the target, by more as the tool nears the clamp (stiffer beam).
        assert!(c.uncompensated_error[2] > 0.0);
        assert!(c.uncompensated_error[2] > previous_error);
        previous_error = c.uncompensated_error[2];
        assert!(position_norm(&c.residual) <= 1e-9);
        // At equilibrium the wrench equals the beam's reaction at the reached point.
        let reached = displace(
            &c.commanded_base,
            &ur10
                .elastic
                .tcp_displacement(&mut (), &c.q_commanded, &c.wrench_base)
                .unwrap(),
        );
        let in_part = x_base_part.inverse() * reached;
        let w = beam
            .wrench_on_tool(&ToolState::at(in_part.translation.vector))
            .unwrap();
        assert!((w[2] - c.wrench_base[2]).abs() < 1e-3 * w[2].abs());
    }
}

#[test]
fn unreachable_points_are_reported_per_point() {
    let ur10 = Ur10::new();
    let constant = ConstantWrench {
        wrench: Vector6::new(0.0, 0.0, 100.0, 0.0, 0.0, 0.0),
    };
    let egm = ur10.egm(Some(&constant), Cell::payload_only(Vector6::zeros()));
    let mut data = egm.data().unwrap();
    let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
    let path = vec![
        PathPoint {
            line: 2,
            x_part_tcp: Isometry3::from_parts(Translation3::new(0.6, 0.3, 0.4), down),
        },
        PathPoint {
            line: 3,
            x_part_tcp: Isometry3::from_parts(Translation3::new(4.0, 0.0, 0.0), down),
        },
    ];
    let outcomes = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
    assert!(outcomes[0].result.is_ok());
    let err = outcomes[1].result.as_ref().unwrap_err();
    assert_eq!(outcomes[1].line, 3);
    assert!(
        matches!(
            err,
            CompensationError::Kinematics(KinematicsError::Unreachable { .. })
        ),
        "{err}"
    );
}

/// An elastic model that counts its evaluations.
struct Counting<'a> {
    inner: &'a ConstantCompliance,
    calls: std::sync::atomic::AtomicUsize,
}

impl TcpDeflection for Counting<'_> {
    type Workspace = ();

    fn describe(&self) -> String {
        self.inner.describe()
    }

    fn workspace(&self) -> Result<(), DeflectionError> {
        Ok(())
    }

    fn tcp_displacement(
        &self,
        workspace: &mut (),
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DeflectionError> {
        self.calls
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.inner.tcp_displacement(workspace, q, wrench_base)
    }
}

/// A finely sampled straight travel along base -x, tool down, in the
/// part frame of `forming_beam_and_robot_are_solved_together`.
fn fine_travel(points: usize) -> Vec<PathPoint> {
    let down = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
    (0..points)
        .map(|i| PathPoint {
            line: i + 2,
            x_part_tcp: Isometry3::from_parts(
                Translation3::new(0.58 - 0.2 * i as f64 / (points - 1) as f64, 0.0, -0.025),
                down,
            ),
        })
        .collect()
}

/// Compensates every point on its own, seeded by the previous point's
/// command: the reference the path tracker must reproduce.
fn cold_path(
    egm: &ElastoGeometricModel<'_, Counting<'_>>,
    data: &mut CompensationData<()>,
    path: &[PathPoint],
) -> Vec<CompensatedPoint> {
    let mut seed = SEED.to_vec();
    let targets: Vec<Isometry3<f64>> = path
        .iter()
        .map(|p| egm.cell.x_base_part * p.x_part_tcp)
        .collect();
    let mut out = Vec::new();
    for (i, target) in targets.iter().enumerate() {
        let motion = if i + 1 < targets.len() {
            targets[i + 1].translation.vector - target.translation.vector
        } else {
            target.translation.vector - targets[i - 1].translation.vector
        };
        let c = egm
            .compensate_pose(data, target, &seed, &motion, &Default::default())
            .unwrap();
        seed.clone_from(&c.q_commanded);
        out.push(c);
    }
    out
}

fn assert_tracked_equals_cold(with_beam: bool) {
    let ur10 = Ur10::new();
    let elastic = Counting {
        inner: &ur10.elastic,
        calls: 0.into(),
    };
    let beam = CantileverBeam::reference(BeamTheory::SmallDeflection);
    // The counting wrapper, not the plain compliance.
    let egm = ElastoGeometricModel::with_nominal_geometry(
        &ur10.model,
        &elastic,
        with_beam.then_some(&beam as &dyn ProcessModel),
        part_cell(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let mut data = egm.data().unwrap();
    let points = 1000;
    let path = fine_travel(points);
    let cold = cold_path(&egm, &mut data, &path);
    let cold_calls = elastic.calls.swap(0, std::sync::atomic::Ordering::Relaxed);
    let tracked = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
    let tracked_calls = elastic.calls.load(std::sync::atomic::Ordering::Relaxed);
    let options = CompensationOptions::default();
    for (t, c) in tracked.iter().zip(&cold) {
        let t = t.result.as_ref().unwrap();
        // Both meet the tolerances on the same branch...
        assert!(converged(&t.residual, &options), "{:?}", t.residual);
        // ...so commands agree to the tolerance over the Jacobian's
        // smallest gain, and predicted errors to the tolerance.
        for (a, b) in t.q_commanded.iter().zip(&c.q_commanded) {
            assert!((a - b).abs() < 1e-7, "{a} vs {b}");
        }
        for (a, b) in t.q_uncompensated.iter().zip(&c.q_uncompensated) {
            assert!((a - b).abs() < 1e-8, "{a} vs {b}");
        }
        assert!((t.uncompensated_error - c.uncompensated_error).norm() < 1e-9);
        assert!((t.wrench_base - c.wrench_base).norm() < 1e-3);
    }
    // The tracker is what makes paths cheap: it must cut the elastic
    // evaluations (two per point once it runs, one for the uncompensated
    // and one for the compensated command, plus the coupling's extra
    // evaluations with the beam; a point solved from scratch needs at
    // least three, with the beam over twenty).
    let per_point = if with_beam { 3 } else { 2 };
    assert!(
        tracked_calls <= per_point * points + 20,
        "tracked {tracked_calls}, cold {cold_calls}"
    );
    assert!(
        tracked_calls < cold_calls,
        "tracked {tracked_calls}, cold {cold_calls}"
    );
}

#[test]
fn tracked_path_equals_points_solved_from_scratch_under_payload() {
    assert_tracked_equals_cold(false);
}

#[test]
fn tracked_path_equals_points_solved_from_scratch_with_the_beam() {
    assert_tracked_equals_cold(true);
}

#[test]
fn tracked_path_without_load_is_the_inverse_model() {
    let ur10 = Ur10::new();
    let egm = ur10.egm(None, part_cell(Vector6::zeros()));
    let mut data = egm.data().unwrap();
    let outcomes = egm.compensate_path(&mut data, &fine_travel(50), &SEED, &Default::default());
    for o in &outcomes {
        let c = o.result.as_ref().unwrap();
        assert_eq!(c.iterations, 0);
        assert_eq!(c.q_commanded, c.q_uncompensated);
        assert!(c.uncompensated_error.norm() < 1e-9);
    }
}

#[test]
fn tracked_path_with_a_free_tool_rotation_meets_the_tolerances() {
    let ur10 = Ur10::new();
    let egm = ur10.egm(
        None,
        part_cell(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let mut data = egm.data().unwrap();
    let mut options = CompensationOptions::default();
    options.inverse.target = InverseTarget::PositionAndToolAxis;
    let path = fine_travel(100);
    let outcomes = egm.compensate_path(&mut data, &path, &SEED, &options);
    for (o, p) in outcomes.iter().zip(&path) {
        let c = o.result.as_ref().unwrap();
        assert!(converged(&c.residual, &options), "{:?}", c.residual);
        // The uncompensated command reaches the target's position.
        let reached = flexcal_kinematics::forward_pose(
            &ur10.model,
            &mut data.kinematics,
            &c.q_uncompensated,
            &egm.xi,
        )
        .unwrap();
        let target = egm.cell.x_base_part * p.x_part_tcp;
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-9);
    }
}

#[test]
fn parallel_path_equals_the_path_tracked_in_one_thread() {
    let ur10 = Ur10::new();
    let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
    let egm = ur10.egm(
        Some(&beam),
        part_cell(Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0)),
    );
    let path = fine_travel(1200);
    let mut data = egm.data().unwrap();
    let serial = egm.compensate_path(&mut data, &path, &SEED, &Default::default());
    // Four threads: four stretches of 300 points, whatever the machine.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let parallel = pool
        .install(|| egm.compensate_path_parallel(&path, &SEED, &Default::default()))
        .unwrap();
    assert_eq!(parallel.len(), serial.len());
    let options = CompensationOptions::default();
    for (p, s) in parallel.iter().zip(&serial) {
        assert_eq!(p.line, s.line);
        let (p, s) = (p.result.as_ref().unwrap(), s.result.as_ref().unwrap());
        assert!(converged(&p.residual, &options), "{:?}", p.residual);
        for (a, b) in p.q_commanded.iter().zip(&s.q_commanded) {
            assert!((a - b).abs() < 1e-7, "{a} vs {b}");
        }
        assert!((p.uncompensated_error - s.uncompensated_error).norm() < 1e-9);
    }
}

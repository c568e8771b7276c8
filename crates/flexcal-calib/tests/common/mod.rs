//! Shared checks and draws of the integration tests (each test file uses
//! part of them).
#![allow(dead_code)]

use faer::Mat;
use flexcal_calib::{
    ErrorModel, GravityCompliance, Measurement, MeasurementSet, UnknownKind, rotation_from_vector,
};
use flexcal_kinematics::{Data, Model, ParamKind, PointLoad, actuated_forces_into, forward_pose};
use flexcal_optim::{Jacobian, Residuals};
use nalgebra::{Isometry3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A file of `tests/data`.
pub fn data_file(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The light two-armed robot of `tests/data/compliant_torso.toml`.
pub fn compliant_torso() -> Model {
    flexcal_kinematics::RobotDescription::from_toml_file(&data_file("compliant_torso.toml"))
        .unwrap()
        .build()
        .unwrap()
}

/// Asserts that the analytic Jacobian of `problem` at `x` matches central
/// differences with step `step(j)` per unknown: entry by entry within
/// `tolerance(analytic column, central difference)`. Returns the Jacobian.
pub fn assert_jacobian_matches(
    label: &str,
    problem: &ErrorModel<'_>,
    x: &[f64],
    step: &dyn Fn(usize) -> f64,
    tolerance: &dyn Fn(&[f64], f64) -> f64,
) -> Mat<f64> {
    let (m, n) = (problem.n_residuals(), problem.n_unknowns());
    let mut jac = Mat::<f64>::zeros(m, n);
    problem.jacobian(x, jac.as_mut()).unwrap();
    let (mut plus, mut minus) = (vec![0.0; m], vec![0.0; m]);
    for j in 0..n {
        let h = step(j);
        let mut xp = x.to_vec();
        xp[j] += h;
        let mut xm = x.to_vec();
        xm[j] -= h;
        problem.residuals(&xp, &mut plus).unwrap();
        problem.residuals(&xm, &mut minus).unwrap();
        let column: Vec<f64> = (0..m).map(|i| jac[(i, j)]).collect();
        for i in 0..m {
            let fd = (plus[i] - minus[i]) / (2.0 * h);
            assert!(
                (fd - jac[(i, j)]).abs() < tolerance(&column, fd),
                "{label}: row {i}, unknown {}: analytic {} vs central difference {fd}",
                problem.names()[j],
                jac[(i, j)]
            );
        }
    }
    jac
}

/// Asserts that `name` is identified in `calibration` within 3 standard
/// errors of `true_value`, with a standard error below a fifth of it.
pub fn assert_recovered(calibration: &flexcal_calib::Calibration, name: &str, true_value: f64) {
    let u = calibration
        .unknowns
        .iter()
        .find(|u| u.name == name)
        .unwrap_or_else(|| panic!("no unknown {name}"));
    assert_eq!(u.status, flexcal_calib::UnknownStatus::Identified, "{name}");
    let se = u.standard_error.unwrap();
    assert!(
        (u.value - true_value).abs() < 3.0 * se && se < 0.2 * true_value,
        "{name}: identified {} +/- {se}, true {true_value}",
        u.value
    );
}

/// A UR10 configuration (rad) drawn over a working range: shoulder from
/// -2.6 to -0.5 rad (arm above the base), elbow within +-2.2 rad, the other
/// joints within +-2.5 rad.
pub fn ur10_configuration(rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..6)
        .map(|k| match k {
            1 => rng.random_range(-2.6..-0.5),
            2 => rng.random_range(-2.2..2.2),
            _ => rng.random_range(-2.5..2.5),
        })
        .collect()
}

/// A measurement frame (tracker 3 m away, turned) and a target offset
/// (turned, off the TCP) generic enough that no Jacobian entry vanishes by
/// symmetry.
pub fn generic_frame_and_target() -> (Isometry3<f64>, Isometry3<f64>) {
    (
        Isometry3::from_parts(
            Translation3::new(0.3, -3.1, 0.2),
            rotation_from_vector(&Vector3::new(0.1, -0.2, 2.0)),
        ),
        Isometry3::from_parts(
            Translation3::new(0.01, 0.02, 0.11),
            rotation_from_vector(&Vector3::new(0.3, 0.1, -1.2)),
        ),
    )
}

/// A true geometry: the nominal parameters of `model` moved by up to
/// +-`length` (m) and +-`angle` (rad), drawn from `rng`.
pub fn perturbed_geometry(
    model: &Model,
    rng: &mut ChaCha8Rng,
    length: f64,
    angle: f64,
) -> Vec<f64> {
    model
        .nominal_params()
        .iter()
        .zip(model.params())
        .map(|(v, p)| {
            v + match p.kind {
                ParamKind::Length => rng.random_range(-length..length),
                ParamKind::Angle => rng.random_range(-angle..angle),
            }
        })
        .collect()
}

/// A robot whose joints deflect under gravity, measured by a tracker in
/// `frame`, simulated independently of the calibration code: generalised
/// forces of the link weights of `gravity` and of a payload (a point load
/// on the flange) by virtual work, then the forward model of the true
/// geometry `xi` at the deflected joints.
pub struct GravitySimulation<'a> {
    pub model: &'a Model,
    pub gravity: &'a GravityCompliance,
    /// True geometric parameters.
    pub xi: &'a [f64],
    /// True payload mass (kg) and centre in the flange frame (m).
    pub payload: (f64, Vector3<f64>),
    /// Pose of the robot base in the tracker frame.
    pub frame: Isometry3<f64>,
    /// Gaussian noise per axis (m).
    pub noise: f64,
}

impl GravitySimulation<'_> {
    /// `n` measured positions from `seed`: configurations from `draw`, each
    /// deflected to `deflect(q, tau)` under the generalised gravity forces
    /// `tau` (N.m).
    pub fn measure(
        &self,
        n: usize,
        seed: u64,
        label: &str,
        draw: impl Fn(&mut ChaCha8Rng) -> Vec<f64>,
        deflect: impl Fn(&[f64], &[f64]) -> Vec<f64>,
    ) -> MeasurementSet {
        let model = self.model;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let normal = Normal::new(0.0, self.noise.max(1e-300)).unwrap();
        let mut data = Data::new(model);
        let mut loads = link_loads(model, self.gravity);
        loads.push(PointLoad {
            frame: model.end_frame(),
            point: self.payload.1,
            force: self.gravity.gravity * self.payload.0,
        });
        let measurements = (0..n)
            .map(|_| {
                let q = draw(&mut rng);
                let mut tau = vec![0.0; model.n_actuated()];
                actuated_forces_into(
                    model,
                    &mut data,
                    &q,
                    model.nominal_params(),
                    &loads,
                    &mut tau,
                )
                .unwrap();
                let deflected = deflect(&q, &tau);
                let x = self.frame * forward_pose(model, &mut data, &deflected, self.xi).unwrap();
                let p = x.translation.vector
                    + Vector3::from_fn(|_, _| {
                        if self.noise > 0.0 {
                            normal.sample(&mut rng)
                        } else {
                            0.0
                        }
                    });
                Measurement::new(q, p)
            })
            .collect();
        MeasurementSet::new(label, measurements).unwrap()
    }
}

/// `set` with a measured orientation (a rotation vector, rad) near the
/// predicted ones on every pose, so that orientation rows are checked too.
pub fn with_orientation(set: &MeasurementSet) -> MeasurementSet {
    let measurements: Vec<Measurement> = set
        .measurements()
        .iter()
        .map(|m| {
            let mut m = m.clone();
            m.orientation = Some(Vector3::new(0.2, -1.0, 0.4));
            m
        })
        .collect();
    MeasurementSet::new("with orientation", measurements).unwrap()
}

/// Checks the Jacobian of an elasto-geometric `problem` of `model` (with
/// gravity and joint terms) against central differences away from the
/// start: frame and target increments, compliances (5-20 urad/N.m),
/// hardening, angles and the payload drawn from `seed`, each unknown
/// stepped by a size fit for its kind. Returns the point and the Jacobian.
pub fn assert_elastic_jacobian_matches(
    label: &str,
    model: &Model,
    problem: &ErrorModel<'_>,
    seed: u64,
) -> (Vec<f64>, Mat<f64>) {
    let kinds = problem.kinds();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = problem.initial_unknowns();
    let eo = problem.elastic_offset().expect("an elastic model");
    let jo = problem.joint_terms_offset().expect("joint terms");
    for v in x[model.n_params()..eo].iter_mut() {
        *v = rng.random_range(-0.05..0.05);
    }
    for (j, (v, kind)) in x[eo..].iter_mut().zip(&kinds[eo..]).enumerate() {
        *v += match kind {
            UnknownKind::Compliance => rng.random_range(5e-6..2e-5),
            UnknownKind::Hardening => rng.random_range(0.0..800.0),
            UnknownKind::Angle => rng.random_range(-2e-4..2e-4),
            _ if eo + j < jo => rng.random_range(-0.1..0.1),
            _ => 0.0,
        };
    }
    let step = |j: usize| match kinds[j] {
        UnknownKind::Compliance => 1e-10,
        UnknownKind::Hardening => 1e-1,
        UnknownKind::Mass | UnknownKind::FirstMoment => 1e-5,
        _ => 1e-6,
    };
    let jac = assert_jacobian_matches(label, problem, &x, &step, &|column, _| {
        1e-5 * column.iter().fold(1e-12, |a: f64, v| a.max(v.abs())) + 1e-9
    });
    (x, jac)
}

/// Elastic deflection of a spring `(e / c)(1 + eta |e|) = tau` (rad, N.m,
/// rad/N.m, 1/rad) by Newton's method from the linear solution: the truth
/// of the simulated non-linear joints, written apart from the library's
/// joint law.
pub fn spring_deflection(tau: f64, c: f64, eta: f64) -> f64 {
    if c == 0.0 {
        return 0.0;
    }
    let mut e = c * tau;
    for _ in 0..60 {
        let g = (e / c) * (1.0 + eta * e.abs()) - tau;
        e -= g / ((1.0 + 2.0 * eta * e.abs()) / c);
    }
    e
}

/// The weights of the links of `gravity` as point loads on `model`'s
/// frames (N).
pub fn link_loads(model: &Model, gravity: &GravityCompliance) -> Vec<PointLoad> {
    gravity
        .masses
        .iter()
        .map(|m| PointLoad {
            frame: model.frame_index(&m.frame).unwrap(),
            point: m.center,
            force: gravity.gravity * m.mass,
        })
        .collect()
}

/// The lateral rotation of the structure outboard of frame `f`: a turn
/// about the frame's x axis by `compliance` (rad/N.m) times the moment about
/// that axis of every load that moves with the frame, all on the geometry
/// the last forward pass left in `data`. Inserting `Rx` after the frame
/// moves every point after it by `x' = T_f Rx T_f^-1 x`; this returns
/// `T_f Rx T_f^-1`. The truth of the simulated lateral compliances, written
/// apart from the library.
pub fn lateral_turn(
    model: &Model,
    data: &Data,
    loads: &[PointLoad],
    f: usize,
    compliance: f64,
) -> Isometry3<f64> {
    let t_f = data.frame_pose(f).unwrap();
    let axis = t_f.rotation * Vector3::x();
    let origin = t_f.translation.vector;
    let moment: f64 = loads
        .iter()
        .filter(|l| model.moves_with(l.frame, f))
        .map(|load| {
            let at = data.frame_pose(load.frame).unwrap();
            let p = (at * nalgebra::Point3::from(load.point)).coords;
            axis.dot(&(p - origin).cross(&load.force))
        })
        .sum();
    let turn = Isometry3::from_parts(
        Translation3::identity(),
        nalgebra::UnitQuaternion::from_axis_angle(&Vector3::x_axis(), compliance * moment),
    );
    t_f * turn * t_f.inverse()
}

/// The index of the actuated coordinate named `name` of `model`.
pub fn actuated_index(model: &Model, name: &str) -> usize {
    model
        .actuated_names()
        .iter()
        .position(|a| a == name)
        .unwrap_or_else(|| panic!("no actuated coordinate `{name}`"))
}

/// The largest distance (m) of each of two predictions of `problem` (one
/// pose per observation, as [`ErrorModel::predict`] gives them) from the
/// exact marker position `exact(pose, target)` of each observation.
pub fn largest_errors(
    problem: &ErrorModel<'_>,
    predictions: [&[Isometry3<f64>]; 2],
    mut exact: impl FnMut(usize, usize) -> Vector3<f64>,
) -> [f64; 2] {
    let mut largest = [0.0_f64; 2];
    for i in 0..problem.n_observations() {
        let (k, t) = problem.observation(i);
        let exact = exact(k, t);
        for (l, predicted) in largest.iter_mut().zip(predictions) {
            *l = l.max((predicted[i].translation.vector - exact).norm());
        }
    }
    largest
}

/// Prints the largest marker errors (m) of the one step and the
/// equilibrium against an exact equilibrium (`what`), and checks that the
/// one step errs visibly (over 0.3 mm) and the equilibrium by under 5 % of it.
pub fn equilibrium_beats_one_step(what: &str, one_step_error: f64, equilibrium_error: f64) {
    eprintln!(
        "{what}, largest marker error: one step {:.4} mm, equilibrium {:.4} mm",
        one_step_error * 1e3,
        equilibrium_error * 1e3
    );
    assert!(one_step_error > 0.3e-3, "one step {one_step_error}");
    assert!(
        equilibrium_error < 0.05 * one_step_error,
        "equilibrium {equilibrium_error} against one step {one_step_error}"
    );
}

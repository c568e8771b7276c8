//! Tests of the fuzzy compliance model on synthetic plane campaigns with a
//! known configuration-dependent compliance (seeded noise), on the built-in
//! IR-663's inputs, and on bad input.

use flexcal_elastic::campaign::DeflectionMeasurement;
use flexcal_elastic::fuzzy_compliance::{
    Axis, ComplianceComponent, ComplianceFitParams, ComplianceSample, FuzzyCompliance,
    FuzzyComplianceError, InputSource, InputSpec, RobotFuzzyCompliance, RobotInputs,
    compliance_samples, identify_compliance, noise_floor_rms,
};
use flexcal_elastic::metrics::per_load_metrics;
use flexcal_elastic::tcp::TcpDeflection;
use flexcal_fuzzy::{FuzzyModel, FuzzyStructure, Partition};
use flexcal_kinematics::{
    RobotDescription, actuated_from_joint_angles, joint_angles_from_actuated,
};
use nalgebra::{Vector3, Vector6};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type Plane = fn(f64, f64) -> [f64; 4];

/// Bilinear in (a, b): exactly representable by a 2 x 2 rule grid.
fn bilinear(a: f64, b: f64) -> [f64; 4] {
    [
        1.0e-6 * (1.0 + 0.5 * a + 0.3 * b + 0.4 * a * b),
        0.2e-6 * (1.0 - 0.2 * a * b),
        0.3e-6 * (1.0 + 0.1 * a),
        1.5e-6 * (1.0 + 0.2 * b - 0.3 * a * b),
    ]
}

/// Smooth but not multilinear, about 1 mm/kN like the IR-663.
fn smooth(a: f64, b: f64) -> [f64; 4] {
    [
        1.0e-6 * (0.9 + 0.4 * (1.3 * a).sin() + 0.3 * b * b),
        0.3e-6 * (1.0 + a * b),
        0.25e-6 * (1.0 + 0.5 * a),
        1.4e-6 * (1.0 + 0.3 * (a - 0.5 * b).cos()),
    ]
}

fn gaussian(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
    sigma * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// The paper's campaign shape: a 7 x 9 grid of configurations, each loaded
/// along +x and along -z with `load` N, deflections with Gaussian noise of
/// `sigma` m per component.
fn plane_campaign(truth: Plane, load: f64, sigma: f64, seed: u64) -> Vec<ComplianceSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut samples = Vec::new();
    for i in 0..7 {
        for j in 0..9 {
            let (a, b) = (-1.0 + 0.2 * i as f64, 0.55 + 0.06 * j as f64);
            let c = truth(a, b);
            for (fx, fz) in [(load, 0.0), (0.0, -load)] {
                let dx = c[0] * fx + c[1] * fz + gaussian(&mut rng, sigma);
                let dy = gaussian(&mut rng, sigma);
                let dz = c[2] * fx + c[3] * fz + gaussian(&mut rng, sigma);
                samples.push(ComplianceSample {
                    pose_id: (9 * i + j) as u64,
                    inputs: vec![a, b],
                    wrench: Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0),
                    deflection: Vector3::new(dx, dy, dz),
                    sigma: Vector3::repeat(sigma),
                });
            }
        }
    }
    samples
}

/// The training range of both inputs (the outermost modal values).
fn domain(model: &FuzzyCompliance) -> [(f64, f64); 2] {
    let p = model.models()[0].structure().partitions();
    [(p[0].lower(), p[0].upper()), (p[1].lower(), p[1].upper())]
}

fn plane_inputs() -> Vec<InputSpec> {
    vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")]
}

fn fit(samples: &[ComplianceSample]) -> flexcal_elastic::fuzzy_compliance::FittedCompliance {
    identify_compliance(
        &plane_inputs(),
        &ComplianceComponent::plane_xz(),
        samples,
        &ComplianceFitParams::default(),
        &mut |_| {},
    )
    .unwrap()
}

#[test]
fn bilinear_compliance_is_reproduced_exactly() {
    let samples = plane_campaign(bilinear, 900.0, 0.0, 1);
    // No pull towards the constant prior: plain least squares.
    let mut params = ComplianceFitParams::default();
    params.fuzzy.ridge = 0.0;
    let fitted = identify_compliance(
        &plane_inputs(),
        &ComplianceComponent::plane_xz(),
        &samples,
        &params,
        &mut |_| {},
    )
    .unwrap();
    let r = &fitted.report;
    assert_eq!((r.training_configurations, r.test_configurations), (45, 18));
    assert_eq!(
        r.training_samples.len() + r.test_samples.len(),
        samples.len()
    );
    assert!(r.test_mm.rmse < 1e-9, "test RMSE {} mm", r.test_mm.rmse);
    // Anywhere inside the training range, not only at the grid points.
    let [(a0, a1), (b0, b1)] = domain(&fitted.compliance);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for _ in 0..200 {
        let (a, b) = (rng.random_range(a0..a1), rng.random_range(b0..b1));
        let c = fitted.compliance.compliance_matrix(&[a, b]).unwrap();
        let t = bilinear(a, b);
        for (value, truth) in [c[(0, 0)], c[(0, 2)], c[(2, 0)], c[(2, 2)]].iter().zip(t) {
            assert!((value - truth).abs() < 1e-15, "{value} vs {truth}");
        }
        assert_eq!(c[(1, 1)], 0.0);
    }
}

#[test]
fn smooth_compliance_reaches_the_noise_floor_on_other_loads() {
    let sigma = 30e-6;
    let train = plane_campaign(smooth, 900.0, sigma, 11);
    let fitted = fit(&train);
    let model = &fitted.compliance;
    // The paper's 4 x 3 budget: a grid of at most 12 rules, shared.
    for m in model.models() {
        assert!(
            m.conclusions().len() <= 12,
            "{} rules",
            m.conclusions().len()
        );
        assert_eq!(m.structure(), model.models()[0].structure());
    }
    let axes = [Axis::X, Axis::Z];
    for (load, seed) in [(300.0, 12), (600.0, 13), (1100.0, 14)] {
        let validation = plane_campaign(smooth, load, sigma, seed);
        let floor = noise_floor_rms(&validation, &axes);
        assert!((floor - sigma * 2f64.sqrt()).abs() < 1e-15);
        let residuals = model.residual_samples(&validation).unwrap();
        assert!(residuals.iter().all(|r| r.residual.y == 0.0));
        let table = per_load_metrics(&residuals);
        let rms_m = table.overall_rms_mm * 1e-3;
        // Model error small against the noise: within 20 % of the floor.
        assert!(
            rms_m < 1.2 * floor,
            "{load} N: RMS {rms_m} m, floor {floor} m"
        );
    }
    // The identified compliance itself, against the truth (noise-free).
    let mut worst: f64 = 0.0;
    let [(a0, a1), (b0, b1)] = domain(model);
    for i in 0..=20 {
        for j in 0..=20 {
            let (a, b) = (
                a0 + (a1 - a0) * i as f64 / 20.0,
                b0 + (b1 - b0) * j as f64 / 20.0,
            );
            let c = model.compliance_matrix(&[a, b]).unwrap();
            let t = smooth(a, b);
            for (value, truth) in [c[(0, 0)], c[(0, 2)], c[(2, 0)], c[(2, 2)]].iter().zip(t) {
                worst = worst.max((value - truth).abs());
            }
        }
    }
    // 0.1 mm/kN against components of 0.25 to 2 mm/kN.
    assert!(worst < 0.1e-6, "largest compliance error {worst} m/N");
}

#[test]
fn compliance_file_round_trips() {
    let fitted = fit(&plane_campaign(smooth, 900.0, 30e-6, 3));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("compliance.toml");
    fitted.compliance.write(&path).unwrap();
    let back = FuzzyCompliance::read(&path).unwrap();
    assert_eq!(back, fitted.compliance);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.contains("unit = \"m/N\"") && text.contains("unit = \"rad\""),
        "{text}"
    );
    let wrong = text.replacen("unit = \"m/N\"", "unit = \"mm/kN\"", 1);
    let err = FuzzyCompliance::from_toml_str(&wrong, "edited.toml").unwrap_err();
    assert!(
        err.to_string().contains("edited.toml") && err.to_string().contains("mm/kN"),
        "{err}"
    );
    let err = FuzzyCompliance::from_toml_str("format = 3", "x.toml").unwrap_err();
    assert!(matches!(err, FuzzyComplianceError::File { .. }), "{err}");
}

#[test]
fn rule_base_prints_like_table_4() {
    let structure = FuzzyStructure::new(
        vec!["theta2".into(), "theta8".into()],
        vec![
            Partition::new(vec![-0.5, -0.1, 0.2, 0.6]).unwrap(),
            Partition::new(vec![0.6, 0.8, 1.1]).unwrap(),
        ],
    )
    .unwrap();
    let conclusions: Vec<f64> = (0..12).map(|i| -1e-6 * (0.6 + 0.05 * i as f64)).collect();
    let components = vec![ComplianceComponent::new(Axis::X, Axis::X)];
    let model = FuzzyModel::new(structure, "c_xx".into(), conclusions).unwrap();
    let compliance = FuzzyCompliance::new(plane_inputs(), components.clone(), vec![model]).unwrap();
    let table = compliance.rule_base_table(components[0]).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert_eq!(lines.len(), 13, "{table}");
    assert!(
        lines[0].contains("(deg)") && lines[0].contains("mm/kN"),
        "{table}"
    );
    // Rule 2: first modal value of theta2, second of theta8, b = -0.65 mm/kN.
    let cells: Vec<f64> = lines[2]
        .split_whitespace()
        .map(|c| c.parse().unwrap())
        .collect();
    assert_eq!(cells[0], 2.0);
    assert!((cells[1] - (-0.5f64).to_degrees()).abs() < 0.006);
    assert!((cells[2] - 0.8f64.to_degrees()).abs() < 0.006);
    assert!((cells[3] + 0.65).abs() < 1e-3);
    assert!(
        compliance
            .rule_base_table(ComplianceComponent::new(Axis::Z, Axis::Z))
            .is_none()
    );
}

fn two_by_two_compliance(values: [[f64; 4]; 4]) -> FuzzyCompliance {
    let components = ComplianceComponent::plane_xz();
    let models = components
        .iter()
        .zip(values)
        .map(|(c, b)| {
            let s = FuzzyStructure::new(
                vec!["theta2".into(), "theta8".into()],
                vec![
                    Partition::new(vec![-1.0, 1.0]).unwrap(),
                    Partition::new(vec![0.0, 2.0]).unwrap(),
                ],
            )
            .unwrap();
            FuzzyModel::new(s, c.name(), b.to_vec()).unwrap()
        })
        .collect();
    FuzzyCompliance::new(plane_inputs(), components, models).unwrap()
}

proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 64,
        // Seeded: every run draws the same cases.
        rng_seed: proptest::test_runner::RngSeed::Fixed(20130002),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]

    /// Equation (38): the displacement is linear in the wrench and equals
    /// the compliance matrix applied to it; a zero load gives zero.
    #[test]
    fn displacement_is_the_compliance_matrix_applied_linearly(
        values in prop::array::uniform4(prop::array::uniform4(-2e-6..2e-6f64)),
        a in -1.5..1.5f64, b in -0.5..2.5f64,
        w1 in prop::array::uniform6(-1e3..1e3f64),
        w2 in prop::array::uniform6(-1e3..1e3f64),
        s in -3.0..3.0f64,
    ) {
        let model = two_by_two_compliance(values);
        let (w1, w2) = (Vector6::from(w1), Vector6::from(w2));
        let x = [a, b];
        let d1 = model.displacement(&x, &w1).unwrap();
        let d2 = model.displacement(&x, &w2).unwrap();
        let combined = model.displacement(&x, &(w1 * s + w2)).unwrap();
        prop_assert!((combined - (d1 * s + d2)).norm() <= 1e-12 * (1.0 + combined.norm()));
        let c = model.compliance_matrix(&x).unwrap();
        prop_assert!((c * w1 - d1).norm() <= 1e-15);
        prop_assert_eq!(model.displacement(&x, &Vector6::zeros()).unwrap(), Vector6::zeros());
        // Rows and columns of y and of the rotations are not modelled.
        prop_assert_eq!(d1[1], 0.0);
        prop_assert!(d1.fixed_rows::<3>(3).iter().all(|v| *v == 0.0));
    }
}

#[test]
fn ir663_inputs_are_joint_angles_and_the_elastic_interface_applies_the_compliance() {
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let inputs = RobotInputs::resolve(&robot, &["theta2", "theta8"]).unwrap();
    assert!(matches!(inputs.sources()[0], InputSource::JointAngle(_)));
    let q = actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0]).unwrap();
    let joints = joint_angles_from_actuated(&robot, &q).unwrap();
    let x = inputs.values(&robot, &q).unwrap();
    assert!(
        (x[0] + 0.5).abs() < 1e-9 && (x[1] - 0.4).abs() < 1e-9,
        "{x:?} from {joints:?}"
    );
    // An actuated coordinate is taken as it is, with its unit.
    let raw = RobotInputs::resolve(&robot, &["theta1", "r2p"]).unwrap();
    assert_eq!(raw.specs()[1].unit, InputSpec::meters("r2p").unit);
    assert_eq!(raw.values(&robot, &q).unwrap(), vec![q[0], q[1]]);

    let compliance = two_by_two_compliance([[1e-6, 2e-6, 3e-6, 4e-6]; 4]);
    let wrench = Vector6::new(300.0, 50.0, -900.0, 1.0, 2.0, 3.0);
    let expected = compliance.displacement(&x, &wrench).unwrap();
    let bound = RobotFuzzyCompliance::new(compliance, robot.clone()).unwrap();
    let mut workspace = bound.workspace().unwrap();
    let got = bound.tcp_displacement(&mut workspace, &q, &wrench).unwrap();
    assert_eq!(got, expected);
    assert!(bound.describe().contains("c_xz") && bound.describe().contains("theta8"));
    let err = bound
        .tcp_displacement(&mut workspace, &q[..3], &wrench)
        .unwrap_err();
    assert!(err.to_string().contains("actuated"), "{err}");

    // Deflection measurements become samples of the inputs.
    let measurement = DeflectionMeasurement {
        pose_id: 7,
        q: q.clone(),
        wrench,
        deflection: Vector3::new(1e-4, 0.0, -2e-4),
        sigma: Vector3::repeat(3e-5),
    };
    let samples = compliance_samples(&robot, &inputs, &[measurement]).unwrap();
    assert_eq!(samples[0].inputs, x);
    assert_eq!(samples[0].pose_id, 7);
}

#[test]
fn unknown_input_names_list_the_valid_ones() {
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let err = RobotInputs::resolve(&robot, &["theta2", "theta9"]).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("'theta9'") && text.contains("theta8") && text.contains("r2p"),
        "{text}"
    );
    let err = RobotInputs::resolve(&robot, &["theta2", "theta2"]).unwrap_err();
    assert!(
        matches!(err, FuzzyComplianceError::Duplicate { .. }),
        "{err}"
    );
    assert!(matches!(
        RobotInputs::resolve(&robot, &[]),
        Err(FuzzyComplianceError::NoInputs)
    ));
}

fn identify_error(samples: &[ComplianceSample], components: &[ComplianceComponent]) -> String {
    identify_compliance(
        &plane_inputs(),
        components,
        samples,
        &ComplianceFitParams::default(),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string()
}

#[test]
fn bad_input_gives_errors_naming_it() {
    let plane = ComplianceComponent::plane_xz();
    let good = plane_campaign(bilinear, 900.0, 0.0, 5);

    // Fewer configurations than rules: 3 configurations x 2 loads, test
    // fraction leaves 2 for training, the simplest model has 4 rules.
    let few: Vec<ComplianceSample> = good.iter().take(6).cloned().collect();
    let err = identify_error(&few, &plane);
    assert!(err.contains("fewer than the 4 rules"), "{err}");

    // A constant input column.
    let mut constant = good.clone();
    constant.iter_mut().for_each(|s| s.inputs[1] = 0.7);
    let err = identify_error(&constant, &plane);
    assert!(
        err.contains("'theta8'") && err.contains("constant"),
        "{err}"
    );

    // NaN in an input and in a deflection.
    let mut nan = good.clone();
    nan[17].inputs[0] = f64::NAN;
    let err = identify_error(&nan, &plane);
    assert!(
        err.contains("sample 17") && err.contains("'theta2'") && err.contains("NaN"),
        "{err}"
    );
    let mut nan = good.clone();
    nan[4].deflection.z = f64::NAN;
    let err = identify_error(&nan, &plane);
    assert!(err.contains("sample 4") && err.contains("dz"), "{err}");

    // Only horizontal loads: C_xz and C_zz are not determined.
    let horizontal: Vec<ComplianceSample> =
        good.iter().filter(|s| s.wrench.x != 0.0).cloned().collect();
    let err = identify_error(&horizontal, &plane);
    assert!(err.contains("'c_xz'") && err.contains("fz"), "{err}");

    // Rotations are not measured; inputs of the wrong length.
    let err = identify_error(&good, &[ComplianceComponent::new(Axis::Rx, Axis::X)]);
    assert!(
        err.contains("'c_rx_x'") && err.contains("rotations"),
        "{err}"
    );
    let mut short = good.clone();
    short[2].inputs.pop();
    let err = identify_error(&short, &plane);
    assert!(
        err.contains("sample 2") && err.contains("1 input value"),
        "{err}"
    );

    // Settings.
    let params = ComplianceFitParams {
        test_fraction: 1.0,
        ..ComplianceFitParams::default()
    };
    let err =
        identify_compliance(&plane_inputs(), &plane, &good, &params, &mut |_| {}).unwrap_err();
    assert!(err.to_string().contains("test_fraction"), "{err}");
}

#[test]
fn component_names_round_trip() {
    for d in Axis::ALL {
        for w in Axis::ALL {
            let c = ComplianceComponent::new(d, w);
            assert_eq!(
                ComplianceComponent::from_name(&c.name()),
                Some(c),
                "{}",
                c.name()
            );
        }
    }
    assert_eq!(ComplianceComponent::translational_block().len(), 9);
    assert_eq!(ComplianceComponent::from_name("c_xq"), None);
}

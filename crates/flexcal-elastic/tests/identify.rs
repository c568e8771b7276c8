//! Stiffness identification on deflections simulated with the model itself:
//! the equivalent stiffnesses are recovered and the serial springs of
//! (68)-(69) are reported by name.

use flexcal_elastic::campaign::DeflectionMeasurement;
use flexcal_elastic::description::ElasticDescription;
use flexcal_elastic::identify::{
    GroupKind, StiffnessIdentificationOptions, identify_stiffness, residual_samples,
};
use flexcal_elastic::metrics::per_load_metrics;
use flexcal_elastic::model::{ElasticData, ElasticModel, OwnWeight, tcp_deflection};
use flexcal_kinematics::{RobotDescription, actuated_from_joint_angles};
use nalgebra::{Vector3, Vector6};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

#[test]
fn recovers_equivalent_stiffness_and_reports_serial_springs() {
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let model = ElasticModel::new(&robot, &ElasticDescription::builtin("ir663").unwrap()).unwrap();
    let mut data = ElasticData::new(&model).unwrap();
    let xi = robot.nominal_params();
    // Truth: Table 3 magnitudes with softer radial joints, so that both
    // equivalent radial stiffnesses matter.
    let truth = [2.0e6, 3.0e9, 1.5e6, 2.0e9, 5.0e9, 4.0e8, 8.0e7];
    let k_req_12 = 1.0 / (1.0 / truth[1] + 1.0 / truth[4]);
    let k_req_18 = 1.0 / (1.0 / truth[3] + 1.0 / truth[5] + 1.0 / truth[6]);
    let noise = Normal::new(0.0, 2e-6).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut measurements = Vec::new();
    let mut id = 0;
    for t2 in [-0.8, -0.5, -0.2, 0.1] {
        for t8 in [0.2, 0.45, 0.7] {
            let q = actuated_from_joint_angles(&robot, &[0.0, t2, t8, 0.0, 1.6, 0.0]).unwrap();
            for (fx, fz) in [(900.0, 0.0), (0.0, -900.0)] {
                let w = Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0);
                let u = tcp_deflection(&model, &mut data, &q, xi, &truth, &w, OwnWeight::Excluded)
                    .unwrap();
                let d = u.fixed_rows::<3>(0) + Vector3::from_fn(|_, _| noise.sample(&mut rng));
                measurements.push(DeflectionMeasurement {
                    pose_id: id,
                    q: q.clone(),
                    wrench: w,
                    deflection: d,
                    sigma: Vector3::repeat(2e-6),
                });
                id += 1;
            }
        }
    }
    let options = StiffnessIdentificationOptions {
        global_search_evaluations: 800,
        seed: 3,
        ..StiffnessIdentificationOptions::default()
    };
    let fit = identify_stiffness(&model, &measurements, xi, &options).unwrap();
    let ident = &fit.identifiability;
    let lines = ident.describe().join("\n");
    // Two serial groups, named.
    let series: Vec<&Vec<String>> = ident
        .groups
        .iter()
        .filter(|g| g.kind == GroupKind::Series)
        .map(|g| &g.members)
        .collect();
    assert!(
        series.contains(&&vec!["Kr_12".to_string(), "Kr_33'".to_string()]),
        "{lines}"
    );
    assert!(
        series.contains(&&vec![
            "Kr_18".to_string(),
            "Kr_99'".to_string(),
            "Kr_1010'".to_string()
        ]),
        "{lines}"
    );
    assert_eq!(ident.structural_rank, 4, "{lines}");
    // The identifiable quantities are recovered.
    let eq = |members: &[&str]| {
        ident
            .groups
            .iter()
            .find(|g| {
                g.members
                    .iter()
                    .map(String::as_str)
                    .eq(members.iter().copied())
            })
            .and_then(|g| g.equivalent)
            .unwrap()
    };
    let k18 = eq(&["Kr_18", "Kr_99'", "Kr_1010'"]);
    assert!(
        (k18 / k_req_18 - 1.0).abs() < 0.02,
        "K_req18 {k18:e} vs {k_req_18:e}\n{lines}"
    );
    // K_req12 moves the TCP by about 1 um against 2 um of noise per
    // coordinate: the data determine it only coarsely.
    let k12 = eq(&["Kr_12", "Kr_33'"]);
    assert!(
        (k12 / k_req_12 - 1.0).abs() < 0.3,
        "K_req12 {k12:e} vs {k_req_12:e}\n{lines}"
    );
    assert!(
        (fit.gamma[0] / truth[0] - 1.0).abs() < 0.01,
        "Kar_12 {:e}",
        fit.gamma[0]
    );
    assert!(
        (fit.gamma[2] / truth[2] - 1.0).abs() < 0.01,
        "Kar_18 {:e}",
        fit.gamma[2]
    );
    assert!(
        fit.solve.termination.is_converged(),
        "{:?}",
        fit.solve.termination
    );
    // Residuals at the noise level.
    let samples = residual_samples(&model, &measurements, xi, &fit.gamma).unwrap();
    let table = per_load_metrics(&samples);
    assert!(table.overall_rms_mm < 0.006, "{table}");
}

#[test]
fn identification_without_data_is_an_error() {
    let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
    let model = ElasticModel::new(&robot, &ElasticDescription::builtin("ir663").unwrap()).unwrap();
    let err = identify_stiffness(
        &model,
        &[],
        robot.nominal_params(),
        &StiffnessIdentificationOptions::default(),
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("no deflection measurement"),
        "{err}"
    );
}

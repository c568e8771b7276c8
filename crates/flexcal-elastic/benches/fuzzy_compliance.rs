//! Speed of the fuzzy compliance model: identifying the four in-plane
//! components (C_xx, C_xz, C_zx, C_zz) jointly from the paper's 900 N
//! protocol (63 configurations x horizontal and vertical loads, 18 held out
//! for the structure choice), and evaluating the fitted 2 x 2 compliance.
//!
//! Goal: the four models identified in <= 2 s. Run with
//! `cargo bench -p flexcal-elastic --bench fuzzy_compliance`.

use criterion::{Criterion, criterion_group, criterion_main};
use flexcal_elastic::fuzzy_compliance::{
    ComplianceComponent, ComplianceFitParams, ComplianceSample, InputSpec, identify_compliance,
};
use nalgebra::{Vector3, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

/// A smooth configuration-dependent plane compliance (m/N) of two joint
/// angles (rad), the size of the IR-663's (about 1 mm/kN).
fn compliance(a: f64, b: f64) -> [f64; 4] {
    let xx = 1.0e-6 * (0.9 + 0.4 * (1.3 * a).sin() + 0.3 * b * b);
    let xz = 0.3e-6 * (1.0 + a * b);
    let zx = 0.25e-6 * (1.0 + 0.5 * a);
    let zz = 1.4e-6 * (1.0 + 0.3 * (a - 0.5 * b).cos());
    [xx, xz, zx, zz]
}

/// The 7 x 9 grid measured under 900 N along +x and along -z, with 30 um
/// noise on each deflection component.
fn campaign() -> Vec<ComplianceSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(663);
    // Box-Muller: a Gaussian draw of standard deviation 30 um.
    let noise = |rng: &mut ChaCha8Rng| {
        let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
        30e-6 * (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let mut samples = Vec::new();
    for i in 0..7 {
        for j in 0..9 {
            let (a, b) = (-1.0 + 0.2 * i as f64, 0.55 + 0.06 * j as f64);
            let c = compliance(a, b);
            for (fx, fz) in [(900.0, 0.0), (0.0, -900.0)] {
                let dx = c[0] * fx + c[1] * fz + noise(&mut rng);
                let dz = c[2] * fx + c[3] * fz + noise(&mut rng);
                samples.push(ComplianceSample {
                    pose_id: (9 * i + j) as u64,
                    inputs: vec![a, b],
                    wrench: Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0),
                    deflection: Vector3::new(dx, 0.0, dz),
                    sigma: Vector3::repeat(30e-6),
                });
            }
        }
    }
    samples
}

fn identification(c: &mut Criterion) {
    let samples = campaign();
    let inputs = vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")];
    let components = ComplianceComponent::plane_xz();
    let params = ComplianceFitParams::default();
    let mut group = c.benchmark_group("fuzzy_compliance");
    group.sample_size(10);
    group.bench_function("identify_four_components_126_samples", |b| {
        b.iter(|| {
            let fit = identify_compliance(
                black_box(&inputs),
                &components,
                black_box(&samples),
                &params,
                &mut |_| {},
            )
            .unwrap();
            black_box(fit.compliance)
        })
    });
    let fit = identify_compliance(&inputs, &components, &samples, &params, &mut |_| {}).unwrap();
    let wrench = Vector6::new(600.0, 0.0, -300.0, 0.0, 0.0, 0.0);
    group.sample_size(50);
    group.bench_function("displacement_one_configuration", |b| {
        b.iter(|| {
            fit.compliance
                .displacement(black_box(&[0.1, 0.7]), black_box(&wrench))
                .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, identification);
criterion_main!(benches);

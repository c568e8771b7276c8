//! Evaluation speed of a 2-input, 12-rule (4 x 3) model, the size of the
//! paper's compliance models (Table 4): batch evaluation, per sample.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flexcal_fuzzy::{FuzzyModel, FuzzyStructure, Partition};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn table_4_model() -> FuzzyModel {
    let s = FuzzyStructure::new(
        vec!["theta2".into(), "theta8".into()],
        vec![
            Partition::new(vec![-24.15, 1.37, 12.54, 36.83]).unwrap(),
            Partition::new(vec![33.04, 48.63, 62.90]).unwrap(),
        ],
    )
    .unwrap();
    let b = vec![
        -0.639, -0.718, -0.910, -0.730, -0.953, -1.040, -0.711, -1.010, -1.218, -0.769, -1.057,
        -1.156,
    ];
    FuzzyModel::new(s, "c_xx".into(), b).unwrap()
}

fn evaluation(c: &mut Criterion) {
    let model = table_4_model();
    let samples = 4096;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let inputs: Vec<f64> = (0..samples)
        .flat_map(|_| [rng.random_range(-30.0..40.0), rng.random_range(30.0..65.0)])
        .collect();
    let mut outputs = vec![0.0; samples];
    let mut group = c.benchmark_group("fuzzy_4x3");
    group.throughput(Throughput::Elements(samples as u64));
    group.bench_function("evaluate_batch_4096", |b| {
        b.iter(|| {
            model
                .evaluate_batch(black_box(&inputs), &mut outputs)
                .unwrap();
            black_box(&outputs);
        })
    });
    group.bench_function("evaluate_single_4096", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for x in black_box(&inputs).chunks_exact(2) {
                sum += model.evaluate(x).unwrap();
            }
            black_box(sum)
        })
    });
    group.finish();
}

criterion_group!(benches, evaluation);
criterion_main!(benches);

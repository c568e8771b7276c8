//! Speed of tool-path compensation on the IR-663 (issue #6): one path point
//! solved from scratch, and a whole 10 000-point path (the forming travel in
//! the twin's cell, 920 N dead weight), with the fuzzy compliance model and
//! with the FE beam model, without and with the cantilever beam pushing on
//! the tool.
//!
//! Goals: the 10 000-point path in <= 50 ms with the fuzzy model and <= 1 s
//! with the FE model. Run with
//! `cargo bench -p flexcal --bench compensation`; `flexcal bench`
//! times the same fixtures (`flexcal::bench_fixtures`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};

use flexcal::bench_fixtures::{CompensationFixture, Elastic, Load, PATH_POINTS};

fn bench(c: &mut Criterion) {
    let fixture = CompensationFixture::new(PATH_POINTS).expect("built-in fixture");
    let mut group = c.benchmark_group("ir663 compensation");
    for elastic in [Elastic::Fuzzy, Elastic::Fe] {
        let egm = fixture.model(elastic, Load::DeadWeight);
        let mut data = egm.data().expect("workspace");
        group.sample_size(50);
        group.measurement_time(Duration::from_secs(3));
        group.bench_function(
            format!("one path point from scratch, {}, 920 N", elastic.label()),
            |b| {
                b.iter(|| {
                    fixture
                        .compensate_middle_point(&egm, &mut data)
                        .expect("reachable point")
                })
            },
        );
        for load in Load::ALL {
            let egm = fixture.model(elastic, load);
            let load = load.label();
            let mut data = egm.data().expect("workspace");
            // What is timed must be a successful compensation of every point.
            let check =
                egm.compensate_path(&mut data, &fixture.path, &fixture.seed, &fixture.options);
            if let Some((k, e)) = check
                .iter()
                .enumerate()
                .find_map(|(k, o)| o.result.as_ref().err().map(|e| (k, e)))
            {
                panic!(
                    "{} with {load}: path point {k} failed: {e}",
                    elastic.label()
                );
            }
            group.sample_size(10);
            group.measurement_time(Duration::from_secs(if elastic == Elastic::Fe {
                8
            } else {
                3
            }));
            group.bench_function(
                format!("{PATH_POINTS}-point path, {}, {load}", elastic.label()),
                |b| {
                    b.iter(|| {
                        egm.compensate_path(
                            &mut data,
                            black_box(&fixture.path),
                            &fixture.seed,
                            &fixture.options,
                        )
                    })
                },
            );
            group.bench_function(
                format!(
                    "{PATH_POINTS}-point path in parallel threads, {}, {load}",
                    elastic.label()
                ),
                |b| {
                    b.iter(|| {
                        egm.compensate_path_parallel(
                            black_box(&fixture.path),
                            &fixture.seed,
                            &fixture.options,
                        )
                        .expect("workspaces")
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! Identifiability analysis, observability indices and pose selection.

mod common;

use approx::assert_relative_eq;
use common::*;
use faer::Mat;
use flexcal_optim::*;
use proptest::prelude::*;
use rand::{Rng, SeedableRng, seq::index::sample};
use rand_chacha::ChaCha8Rng;

fn names(n: usize) -> Vec<String> {
    (0..n).map(|j| format!("p{j}")).collect()
}

/// Columns: a, b, c (independent, of very different magnitudes),
/// d = 1e-3 (2 a - 0.5 b) (a parameter in a unit 1000 times larger), and a zero column.
fn collinear_jacobian(seed: u64) -> Mat<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let m = 12;
    let mut j = Mat::<f64>::zeros(m, 5);
    for i in 0..m {
        j[(i, 0)] = rng.random_range(-1.0..1.0);
        j[(i, 1)] = 50.0 * rng.random_range(-1.0..1.0);
        j[(i, 2)] = 0.01 * rng.random_range(-1.0..1.0);
        j[(i, 3)] = 1e-3 * (2.0 * j[(i, 0)] - 0.5 * j[(i, 1)]);
    }
    j
}

#[test]
fn exact_combination_is_recovered_in_physical_units() {
    let jac = collinear_jacobian(1);
    let options = IdentifiabilityOptions {
        priorities: vec![1, 1, 1, 0, 0],
        ..Default::default()
    };
    let report = analyze_identifiability(jac.as_ref(), &names(5), &options).unwrap();
    assert_eq!(report.rank, 3);
    let mut base = report.base.clone();
    base.sort_unstable();
    assert_eq!(base, [0, 1, 2]);
    assert_eq!(report.non_identifiable, [3, 4]);
    assert_eq!(report.non_identifiable_names(), ["p3", "p4"]);
    // J xi = a (xi0 + 2e-3 xi3) + b (xi1 - 0.5e-3 xi3) + c xi2.
    let row = |b: usize| report.base.iter().position(|&x| x == b).unwrap();
    assert_relative_eq!(
        report.combination_matrix[(row(0), 0)],
        2e-3,
        max_relative = 1e-10
    );
    assert_relative_eq!(
        report.combination_matrix[(row(1), 0)],
        -0.5e-3,
        max_relative = 1e-10
    );
    assert!(report.combination_matrix[(row(2), 0)].abs() < 1e-14);
    assert_eq!(report.combination_matrix[(row(0), 1)], 0.0);
    assert_eq!(report.diagnoses[4], Diagnosis::NoInfluence);
    assert_eq!(report.diagnoses[0], Diagnosis::Identifiable);
    match &report.diagnoses[3] {
        Diagnosis::Collinear { with } => {
            let mut partners: Vec<usize> = with.iter().map(|w| w.0).collect();
            partners.sort_unstable();
            assert_eq!(partners, [0, 1]);
            for &(b, k) in with {
                assert_relative_eq!(k, if b == 0 { 2e-3 } else { -0.5e-3 }, max_relative = 1e-10);
            }
        }
        other => panic!("{other:?}"),
    }
    let mut lines = report.format_combinations(1e-6);
    lines.sort();
    assert_eq!(lines, ["p0_id = p0 + 0.002 p3", "p1_id = p1 - 0.0005 p3"]);
    assert!(matches!(
        report.ensure_full_rank(),
        Err(OptimError::RankDeficient { rank: 3, parameters, .. }) if parameters == ["p3", "p4"]
    ));
}

#[test]
fn without_singular_values_the_base_set_and_combinations_are_the_same() {
    for seed in 1..6 {
        let jac = collinear_jacobian(seed);
        let full = IdentifiabilityOptions {
            priorities: vec![1, 0, 1, 0, 0],
            ..Default::default()
        };
        let lean = IdentifiabilityOptions {
            singular_values: false,
            ..full.clone()
        };
        let with = analyze_identifiability(jac.as_ref(), &names(5), &full).unwrap();
        let without = analyze_identifiability(jac.as_ref(), &names(5), &lean).unwrap();
        assert_eq!(with.singular_values.len(), 5);
        assert!(with.base_condition_number.is_finite());
        assert!(without.singular_values.is_empty());
        assert!(without.base_condition_number.is_nan());
        assert_eq!(without.rank, with.rank);
        assert_eq!(without.base, with.base);
        assert_eq!(without.non_identifiable, with.non_identifiable);
        assert_eq!(without.combination_matrix, with.combination_matrix);
        assert_eq!(without.diagnoses, with.diagnoses);
        assert_eq!(without.column_scales, with.column_scales);
    }
}

#[test]
fn priorities_choose_which_of_two_collinear_parameters_is_kept() {
    let arm = PlanarArm {
        joints: arm_configurations(12, 2),
        measured: vec![],
        redundant_offset: true,
    };
    let mut x = ARM_NOMINAL.to_vec();
    x.push(0.0);
    let mut jac = Mat::<f64>::zeros(24, 9);
    for (k, q) in arm.joints.iter().enumerate() {
        jac.as_mut()
            .subrows_mut(2 * k, 2)
            .copy_from(&PlanarArm::block(&x, q, true));
    }
    let arm_names: Vec<String> = ARM_NAMES.iter().map(|s| s.to_string()).collect();
    for preferred in [5usize, 8] {
        let mut priorities = vec![0; 9];
        priorities[preferred] = 1;
        let options = IdentifiabilityOptions {
            priorities,
            ..Default::default()
        };
        let report = analyze_identifiability(jac.as_ref(), &arm_names, &options).unwrap();
        assert_eq!(report.rank, 8);
        assert_eq!(report.base[0], preferred);
        let other = if preferred == 5 { 8 } else { 5 };
        assert_eq!(report.non_identifiable, [other]);
        let expected = format!(
            "{}_id = {} + {}",
            ARM_NAMES[preferred], ARM_NAMES[preferred], ARM_NAMES[other]
        );
        assert_eq!(report.format_combinations(1e-6), [expected]);
        assert!(report.base_condition_number.is_finite());
        assert!(report.singular_values[8] < 1e-12 * report.singular_values[0]);
    }
}

#[test]
fn rejects_bad_input() {
    let jac = collinear_jacobian(1);
    assert!(matches!(
        analyze_identifiability(jac.as_ref(), &names(4), &Default::default()),
        Err(OptimError::DimensionMismatch {
            argument: "names",
            ..
        })
    ));
    let mut bad = jac.clone();
    bad[(2, 1)] = f64::NAN;
    assert!(matches!(
        analyze_identifiability(bad.as_ref(), &names(5), &Default::default()),
        Err(OptimError::NonFiniteInput {
            argument: "jacobian",
            index: 11
        })
    ));
}

proptest! {
    #![proptest_config(proptest::test_runner::Config {
        cases: 32,
        // Seeded: every run draws the same cases.
        rng_seed: proptest::test_runner::RngSeed::Fixed(20130011),
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    })]
    /// J = [B, B K]: the base is B and the combination matrix is K.
    #[test]
    fn combination_matrix_is_recovered(seed in 0u64..10_000) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (m, nb, nn) = (15, 4, 3);
        let b = Mat::<f64>::from_fn(m, nb, |_, j| rng.random_range(-1.0..1.0) * 10f64.powi(j as i32 - 2));
        let k = Mat::<f64>::from_fn(nb, nn, |_, _| rng.random_range(-3.0..3.0));
        let bk = &b * &k;
        let jac = Mat::<f64>::from_fn(m, nb + nn, |i, j| if j < nb { b[(i, j)] } else { bk[(i, j - nb)] });
        let mut priorities = vec![0; nb + nn];
        priorities[..nb].fill(1);
        let report = analyze_identifiability(jac.as_ref(), &names(nb + nn), &IdentifiabilityOptions { priorities, ..Default::default() }).unwrap();
        prop_assert_eq!(report.rank, nb);
        for (row, &bi) in report.base.iter().enumerate() {
            for col in 0..nn {
                let expected = k[(bi, col)];
                prop_assert!((report.combination_matrix[(row, col)] - expected).abs() < 1e-8 * (1.0 + expected.abs()));
            }
        }
    }
}

#[test]
fn observability_indices_of_a_diagonal_matrix() {
    // Singular values 3, 2, 1 with 4 rows.
    let mut j = Mat::<f64>::zeros(4, 3);
    j[(0, 0)] = 3.0;
    j[(1, 1)] = -2.0;
    j[(3, 2)] = 1.0;
    let o = observability_indices(j.as_ref(), &ColumnScaling::Identity).unwrap();
    assert_relative_eq!(o.o1, 6f64.powf(1.0 / 3.0) / 2.0, max_relative = 1e-12);
    assert_relative_eq!(o.o2, 1.0 / 3.0, max_relative = 1e-12);
    assert_relative_eq!(o.o3, 1.0, max_relative = 1e-12);
    assert_relative_eq!(o.o4, 1.0 / 3.0, max_relative = 1e-12);
    assert_relative_eq!(o.o5, 6.0 / 11.0, max_relative = 1e-12);
    // A rotated copy (orthogonal rows mix) has the same indices.
    let c = 0.6;
    let s = 0.8;
    let mut rotated = j.clone();
    for col in 0..3 {
        let (a, b) = (j[(0, col)], j[(3, col)]);
        rotated[(0, col)] = c * a - s * b;
        rotated[(3, col)] = s * a + c * b;
    }
    let r = observability_indices(rotated.as_ref(), &ColumnScaling::Identity).unwrap();
    assert_relative_eq!(r.o1, o.o1, max_relative = 1e-12);
    assert_relative_eq!(r.o5, o.o5, max_relative = 1e-12);
    // Column scaling to unit norms makes this matrix orthonormal: every sigma is 1.
    let scaled = observability_indices(j.as_ref(), &ColumnScaling::ColumnNorm).unwrap();
    assert_relative_eq!(scaled.o2, 1.0, max_relative = 1e-12);
    assert_relative_eq!(scaled.o5, 1.0 / 3.0, max_relative = 1e-12);
    let rank_deficient = ObservabilityIndices::from_singular_values(&[2.0, 0.0], 5);
    assert_eq!(rank_deficient.o1, 0.0);
    assert_eq!(rank_deficient.o5, 0.0);
}

#[test]
fn selected_poses_beat_random_selections() {
    let pool_q = arm_configurations(60, 9);
    let pool: Vec<Mat<f64>> = pool_q
        .iter()
        .map(|q| PlanarArm::block(&ARM_NOMINAL, q, false))
        .collect();
    let count = 6;
    for index in [ObservabilityIndex::O1, ObservabilityIndex::O3] {
        let options = PoseSelectionOptions {
            index,
            ..PoseSelectionOptions::new(count)
        };
        let selection = select_poses(&pool, &options).unwrap();
        assert_eq!(selection.selected.len(), count);
        let chosen = selection.indices.get(index);
        assert!(chosen >= selection.greedy_value);
        // Judge random subsets with the same scaling: the pool's column norms.
        let mut stacked = Mat::<f64>::zeros(120, 8);
        for (k, b) in pool.iter().enumerate() {
            stacked.as_mut().subrows_mut(2 * k, 2).copy_from(b);
        }
        let norms: Vec<f64> = (0..8).map(|j| stacked.col(j).norm_l2()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut best_random: f64 = 0.0;
        for _ in 0..200 {
            let subset = sample(&mut rng, pool.len(), count).into_vec();
            let mut a = Mat::<f64>::zeros(2 * count, 8);
            for (r, &k) in subset.iter().enumerate() {
                a.as_mut().subrows_mut(2 * r, 2).copy_from(&pool[k]);
            }
            let value = observability_indices(a.as_ref(), &ColumnScaling::Fixed(norms.clone()))
                .unwrap()
                .get(index);
            best_random = best_random.max(value);
        }
        assert!(
            chosen > best_random,
            "{index:?}: selected {chosen} vs best of 200 random {best_random}"
        );
    }
}

#[test]
fn pose_selection_rejects_bad_requests() {
    let pool = vec![Mat::<f64>::zeros(2, 3), Mat::<f64>::zeros(2, 4)];
    assert!(matches!(
        select_poses(&pool, &PoseSelectionOptions::new(1)),
        Err(OptimError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        select_poses(&pool[..1], &PoseSelectionOptions::new(2)),
        Err(OptimError::InvalidOption { name: "count", .. })
    ));
}

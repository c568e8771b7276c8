//! Every claim docs/demo.md makes about the study over seeds 1-5, checked
//! against a threshold stated from the measurement noise or from the claim
//! itself, never from the measured figure plus a margin. The study runs
//! once per test binary (seeds 1-5, as `cargo run --release -p flexcal
//! --example multi_seed`); each test reads the figures it needs.
//!
//! The noise thresholds: the twin's camera draws a Gaussian position noise
//! of `sigma` per axis (the figure the files state, `summary.json`
//! `geometric.noise_position_std_per_axis_um`). The norm of such an error
//! has a standard deviation of `sigma sqrt(3 - 8 / pi)`, so the mean error
//! of `n` poses is uncertain by a standard error of that over `sqrt(n)`; two
//! standard errors are what 16 validation poses can resolve. An RMS over
//! `n` poses of `k` noisy axes has a relative standard error of
//! `1 / sqrt(2 n k)`.

use std::sync::OnceLock;

use flexcal::study::{MultiSeedSummary, Summary, ValidationFigures, multi_seed_study};
use flexcal::twin::elastic::HELD_OUT_POSES;

/// The seeds of docs/demo.md's tables.
const SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

/// The paper's bar for the forming compensation: at least 80 % better...
const PAPER_IMPROVEMENT_PERCENT: f64 = 80.0;
/// ... and every point within +-0.15 mm.
const PAPER_TOLERANCE_MM: f64 = 0.15;

fn study() -> &'static MultiSeedSummary {
    static STUDY: OnceLock<MultiSeedSummary> = OnceLock::new();
    STUDY.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        multi_seed_study(&SEEDS, dir.path(), &mut ()).unwrap()
    })
}

fn summaries() -> &'static [Summary] {
    &study().summaries
}

/// Position noise per axis (mm), as the campaign files state it.
fn sigma_mm() -> f64 {
    summaries()[0].geometric.noise_position_std_per_axis_um * 1e-3
}

/// Standard deviation of one measurement's position error norm (mm).
fn norm_std_mm() -> f64 {
    sigma_mm() * (3.0 - 8.0 / std::f64::consts::PI).sqrt()
}

/// Two standard errors of a mean error over `n` poses (mm): the smallest
/// difference of two means that the noise lets `n` poses resolve.
fn resolvable_mean_mm(n: usize) -> f64 {
    2.0 * norm_std_mm() / (n as f64).sqrt()
}

/// The smallest difference of two max errors the noise lets one tell apart
/// (mm): two standard deviations of one error norm.
fn resolvable_max_mm() -> f64 {
    2.0 * norm_std_mm()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn medians(pick: impl Fn(&Summary) -> f64) -> f64 {
    median(summaries().iter().map(pick).collect())
}

/// The (geometric, elasto-geometric) validation figures of one set.
type Pair<'a> = (&'a ValidationFigures, &'a ValidationFigures);

fn inside(s: &Summary) -> Pair<'_> {
    (&s.geometric.validation_after, &s.geometric.elasto_geometric)
}

fn outside(s: &Summary) -> Pair<'_> {
    let o = &s.geometric.outside_box;
    (&o.geometric, &o.elasto_geometric)
}

fn loaded(s: &Summary) -> Pair<'_> {
    let l = &s.geometric.loaded;
    (&l.geometric, &l.elasto_geometric)
}

#[test]
fn calibration_brings_box_59_down_towards_the_noise_on_every_seed() {
    for s in summaries() {
        let g = &s.geometric;
        let floor = g.noise_floor_position_mean_mm;
        let se2 = resolvable_mean_mm(16);
        let (geometric, elasto) = inside(s);
        for (name, after) in [("geometric", geometric), ("elasto-geometric", elasto)] {
            // The paper's reduction, 0.96 -> 0.24 mm, is 75 %: the twin's
            // calibrations do at least as well...
            assert!(
                after.position_mean_mm <= 0.25 * g.validation_before.position_mean_mm,
                "seed {}: {name} {} against nominal {}",
                s.seed,
                after.position_mean_mm,
                g.validation_before.position_mean_mm
            );
            // ... and no model gets below what the noise allows.
            assert!(
                after.position_mean_mm > floor - se2,
                "seed {}: {name} {} below the noise floor {floor}",
                s.seed,
                after.position_mean_mm
            );
        }
    }
}

#[test]
fn inside_box_59_the_two_calibrations_cannot_be_told_apart() {
    let mean =
        medians(|s| inside(s).0.position_mean_mm) - medians(|s| inside(s).1.position_mean_mm);
    let max = medians(|s| inside(s).0.position_max_mm) - medians(|s| inside(s).1.position_max_mm);
    println!("geometric - elasto-geometric medians: mean {mean:.4} mm, max {max:.4} mm");
    assert!(mean.abs() < resolvable_mean_mm(16), "{mean}");
    assert!(max.abs() < resolvable_max_mm(), "{max}");
}

#[test]
fn outside_box_59_the_errors_exceed_the_noise_and_neither_calibration_wins_on_both() {
    let floor = summaries()[0].geometric.noise_floor_position_mean_mm;
    for s in summaries() {
        let (geometric, elasto) = outside(s);
        for (name, f) in [("geometric", geometric), ("elasto-geometric", elasto)] {
            assert!(
                f.position_mean_mm > floor + resolvable_mean_mm(16),
                "seed {}: {name} {} within the noise of {floor}",
                s.seed,
                f.position_mean_mm
            );
        }
    }
    // docs/demo.md: the elasto-geometric calibration does not beat the
    // geometric one outside the box (lower median mean, higher median
    // max). Beating it would be lower on both by more than the noise
    // resolves; then the page must say so.
    let mean =
        medians(|s| outside(s).0.position_mean_mm) - medians(|s| outside(s).1.position_mean_mm);
    let max = medians(|s| outside(s).0.position_max_mm) - medians(|s| outside(s).1.position_max_mm);
    println!("outside, geometric - elasto-geometric medians: mean {mean:.4} mm, max {max:.4} mm");
    assert!(
        !(mean > resolvable_mean_mm(16) && max > resolvable_max_mm()),
        "the elasto-geometric calibration now beats the geometric one outside box (59): mean by {mean}, max by {max}"
    );
}

#[test]
fn with_the_payload_the_elasto_geometric_calibration_beats_the_geometric_one_on_every_seed() {
    let floor = summaries()[0].geometric.noise_floor_position_mean_mm;
    for s in summaries() {
        let l = &s.geometric.loaded;
        let (geometric, elasto) = loaded(s);
        let n = l.poses;
        // The payload's deflection exceeds the noise: the test can fail.
        assert!(
            geometric.position_mean_mm > floor + resolvable_mean_mm(n),
            "seed {}: {}",
            s.seed,
            geometric.position_mean_mm
        );
        // Told the payload, the elasto-geometric model predicts part of
        // it: lower mean and max by more than the noise resolves...
        assert!(
            geometric.position_mean_mm - elasto.position_mean_mm > resolvable_mean_mm(n),
            "seed {}: mean {} against {}",
            s.seed,
            elasto.position_mean_mm,
            geometric.position_mean_mm
        );
        assert!(
            geometric.position_max_mm - elasto.position_max_mm > resolvable_max_mm(),
            "seed {}: max {} against {}",
            s.seed,
            elasto.position_max_mm,
            geometric.position_max_mm
        );
        // ... but not all of it: its error stays above the noise
        // (docs/demo.md: the joint compliances under gravity do not carry
        // the twin's deflection under a load at the TCP).
        assert!(
            elasto.position_mean_mm > floor + resolvable_mean_mm(n),
            "seed {}: {}",
            s.seed,
            elasto.position_mean_mm
        );
    }
}

#[test]
fn masses_25_percent_off_move_the_figures_by_less_than_the_page_says() {
    let se2 = resolvable_mean_mm(16);
    let mut outside_moves = Vec::new();
    for s in summaries() {
        let g = &s.geometric;
        assert!(!g.mass_scaled.is_empty());
        for m in &g.mass_scaled {
            let moved = |a: &ValidationFigures, b: &ValidationFigures| {
                (
                    (a.position_mean_mm - b.position_mean_mm).abs(),
                    (a.position_max_mm - b.position_max_mm).abs(),
                )
            };
            // Inside box (59): less than 1 um, mean and max, every seed.
            let (mean, max) = moved(&m.inside, &g.elasto_geometric);
            assert!(
                mean < 1e-3 && max < 1e-3,
                "seed {} x {}: inside moved by {mean} / {max} mm",
                s.seed,
                m.scale
            );
            // With the payload: the mean moves by less than the noise
            // resolves on its poses, every seed.
            let (mean, _) = moved(&m.loaded, &g.loaded.elasto_geometric);
            assert!(
                mean < resolvable_mean_mm(g.loaded.poses),
                "seed {} x {}: loaded mean moved by {mean} mm",
                s.seed,
                m.scale
            );
            outside_moves.push(
                (m.outside.position_mean_mm - g.outside_box.elasto_geometric.position_mean_mm)
                    .abs(),
            );
        }
    }
    // Outside the box the median move of the mean is under the noise's
    // resolution too (single seeds move further: docs/demo.md).
    let outside = median(outside_moves);
    assert!(outside < se2, "outside median move {outside} mm");
}

#[test]
fn on_the_training_grid_the_fuzzy_model_beats_the_parametric_one_on_every_load_and_seed() {
    for s in summaries() {
        for (metric, table) in [
            ("x-z", &s.elastic.same_metric.plane_xz),
            ("3-D", &s.elastic.same_metric.three_d),
        ] {
            assert!(table.parametric.loads.len() >= 4, "{metric}");
            for (load, p) in &table.parametric.loads {
                let f = &table.fuzzy.loads[load];
                assert!(
                    f.rms_mm < p.rms_mm,
                    "seed {} {metric} {load} N: fuzzy {} against parametric {}",
                    s.seed,
                    f.rms_mm,
                    p.rms_mm
                );
            }
            assert!(table.fuzzy.all.rms_mm < table.parametric.all.rms_mm);
        }
    }
}

#[test]
fn held_out_the_fuzzy_models_advantage_is_gone_and_both_stay_near_the_noise() {
    for (metric, axes, pick) in [
        (
            "x-z",
            2.0,
            (|s: &Summary| &s.elastic.held_out.plane_xz)
                as fn(&Summary) -> &flexcal::study::SameMetric,
        ),
        ("3-D", 3.0, |s: &Summary| &s.elastic.held_out.three_d),
    ] {
        let floor = medians(|s| pick(s).noise_floor_mm);
        let parametric = medians(|s| pick(s).parametric.all.rms_mm);
        let fuzzy = medians(|s| pick(s).fuzzy.all.rms_mm);
        // Two standard errors of an RMS over the held-out poses' axes.
        let resolvable = 2.0 * floor / (2.0 * HELD_OUT_POSES as f64 * axes).sqrt();
        println!(
            "held out {metric}: parametric {parametric:.4}, fuzzy {fuzzy:.4} mm, floor {floor:.4}, resolvable {resolvable:.4}"
        );
        assert!(
            (parametric - fuzzy).abs() < resolvable,
            "{metric}: the medians differ by {} mm",
            parametric - fuzzy
        );
        // docs/demo.md: both within 25 um of the noise floor.
        for (name, rms) in [("parametric", parametric), ("fuzzy", fuzzy)] {
            assert!(
                rms - floor < 0.025,
                "{metric} {name}: {rms} against {floor}"
            );
            assert!(
                rms > floor - resolvable,
                "{metric} {name}: {rms} below {floor}"
            );
        }
    }
}

#[test]
fn both_compensations_meet_the_papers_bar_over_the_contact_points_on_every_seed() {
    for s in summaries() {
        let f = &s.forming;
        // Every point but the first, which touches the surface, presses.
        assert_eq!(f.contact_points + 1, f.path_points, "seed {}", s.seed);
        // The bar is not met without compensation (else it proves nothing).
        assert!(
            f.uncompensated_contact_mm > PAPER_TOLERANCE_MM,
            "seed {}",
            s.seed
        );
        assert_eq!(f.compensations.len(), 2, "fuzzy and FE beam model");
        for c in &f.compensations {
            assert!(
                c.improvement_contact_percent >= PAPER_IMPROVEMENT_PERCENT,
                "seed {} {}: {} %",
                s.seed,
                c.model,
                c.improvement_contact_percent
            );
            assert!(
                c.max_deviation_contact_mm <= PAPER_TOLERANCE_MM && c.within_tolerance_contact,
                "seed {} {}: {} mm",
                s.seed,
                c.model,
                c.max_deviation_contact_mm
            );
        }
    }
}

#[test]
fn neither_compensation_is_better_on_every_seed() {
    let deviation = |s: &Summary, model: &str| {
        s.forming
            .compensations
            .iter()
            .find(|c| c.model == model)
            .unwrap()
            .max_deviation_contact_mm
    };
    let fe_better = summaries()
        .iter()
        .filter(|s| deviation(s, "FE beam model") < deviation(s, "fuzzy model"))
        .count();
    println!(
        "FE beam model better on {fe_better} of {} seeds",
        SEEDS.len()
    );
    assert!(fe_better > 0 && fe_better < SEEDS.len(), "{fe_better}");
}

#[test]
fn the_dead_weight_is_unlike_every_training_load() {
    for s in summaries() {
        let w = s.forming.dead_weight_n;
        for load in s.elastic.parametric.loads.keys() {
            let load: f64 = load.parse().unwrap();
            // Further from each load than the paper's 920 N from its 900 N
            // (2.2 %), by more than twice that.
            assert!((w - load).abs() > 0.05 * load, "{w} N against {load} N");
        }
    }
}

//! Plans with several targets per pose: a two-armed robot (a torso joint
//! carrying two arms, `flexcal-calib`'s test robot) with one marker on
//! each hand.

use std::path::PathBuf;

use super::*;
use crate::kinematics::{RobotDescription, forward_frame_pose};

fn calib_data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../flexcal-calib/tests/data")
        .join(name)
}

fn two_arms() -> Model {
    RobotDescription::from_toml_file(&calib_data("two_arms.toml"))
        .unwrap()
        .build()
        .unwrap()
}

fn hands() -> Vec<calib::Target> {
    calib::read_targets(&calib_data("two_arms_targets.toml")).unwrap()
}

/// A plan of `count` poses among 60 candidates of the joint limits, for a
/// region of 20 points, measuring `targets`.
fn config(model: &Model, targets: Option<Vec<calib::Target>>, count: usize) -> PlanConfig {
    let drawn = |count, seed| PoseSource::Box {
        joint_box: JointBox::of_limits(model),
        count,
        seed,
    };
    let mut config = PlanConfig::new(
        CalibrationOptions::for_model(model),
        [0.02; 3],
        drawn(60, 5),
        drawn(20, 6),
    );
    config.targets = targets;
    config.count = Some(count);
    config.max_poses = Some(25);
    config
}

/// The target's pose in the base frame, written here from the kinematics:
/// its frame's pose times its offset.
fn target_pose(model: &Model, q: &[f64], target: &calib::Target) -> Isometry3<f64> {
    let frame = model.frame_index(&target.frame).unwrap();
    let mut data = Data::new(model);
    forward_frame_pose(
        model,
        &mut data,
        q,
        model.nominal_params(),
        frame,
        &target.pose(),
    )
    .unwrap()
}

/// Each target is predicted at every region point, its statistics are
/// those of its own bounds, and the design's variances (the greedy's
/// rows, stacked over the targets) agree with `calibrate`'s accuracy map
/// of the planned poses, target by target.
#[test]
fn each_target_is_predicted_and_the_design_agrees_with_calibrate() {
    let model = two_arms();
    let config = config(&model, Some(hands()), 20);
    let plan = plan_campaign(&model, &config).unwrap();
    let names: Vec<&str> = plan.targets.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["left", "right"]);
    let map = &plan.prediction.map.poses;
    assert_eq!(map.len(), 2 * plan.region_points);
    for (t, own) in plan.prediction.per_target.iter().enumerate() {
        assert_eq!(own.target, names[t]);
        let bounds: Vec<f64> = map
            .iter()
            .filter(|p| p.target.as_deref() == Some(names[t]))
            .map(|p| p.bound_95_mm)
            .collect();
        assert_eq!(bounds.len(), plan.region_points);
        let mean = bounds.iter().sum::<f64>() / bounds.len() as f64;
        assert!((own.accuracy.mean_bound_95_mm - mean).abs() < 1e-12);
        let max = bounds.iter().copied().fold(0.0, f64::max);
        assert_eq!(own.accuracy.max_bound_95_mm, max);
    }
    let curve_point = plan.curve.last().unwrap();
    assert_eq!(curve_point.per_target.len(), 2);
    super::tests::design_agrees_with_the_map(&model, &config, &plan);
}

/// Poses chosen for both hands predict the right hand better than poses
/// chosen for the left hand alone, both campaigns measuring both markers
/// (the criterion summed over the targets is what aims at the right arm).
#[test]
fn both_targets_beat_one_target_on_the_other_hands_error() {
    let model = two_arms();
    let both = plan_campaign(&model, &config(&model, Some(hands()), 20)).unwrap();
    let left_only: Vec<calib::Target> = hands().into_iter().take(1).collect();
    let left = plan_campaign(&model, &config(&model, Some(left_only), 20)).unwrap();
    assert_eq!(left.prediction.per_target.len(), 1);
    let c = config(&model, Some(hands()), 20);
    let region: Vec<Vec<f64>> = both
        .prediction
        .map
        .poses
        .iter()
        .step_by(2)
        .map(|p| p.q.clone())
        .collect();
    let left_poses_both_measured = predict_campaign(
        &model,
        &c.options,
        &c.instrument,
        Some(&hands()),
        (&left.configurations, &region),
        None,
    )
    .unwrap();
    let right = |p: &CampaignPrediction| p.per_target[1].accuracy.mean_bound_95_mm;
    assert!(
        right(&both.prediction) < right(&left_poses_both_measured),
        "right hand: planned for both {} mm, planned for the left {} mm",
        right(&both.prediction),
        right(&left_poses_both_measured)
    );
}

/// A candidate keeps the targets the instrument sees; a candidate where it
/// sees none is left out; a target on a frame the robot lacks is named.
#[test]
fn the_sight_is_tested_per_target_and_unknown_frames_are_named() {
    let model = two_arms();
    let targets = hands();
    let mut c = config(&model, Some(targets.clone()), 12);
    let offered = c.candidates.configurations(&model, "c").unwrap();
    // A box cutting each hand's positions at its median height.
    let z: Vec<Vec<f64>> = offered
        .iter()
        .map(|row| {
            targets
                .iter()
                .map(|t| target_pose(&model, &row.value, t).translation.z * 1e3)
                .collect()
        })
        .collect();
    let mut all: Vec<f64> = z.iter().flatten().copied().collect();
    all.sort_by(f64::total_cmp);
    let z_lo = all[all.len() / 2];
    c.instrument.sight.reach_box_mm = Some([[-1e4, 1e4], [-1e4, 1e4], [z_lo, 1e4]]);
    let seen: Vec<Vec<bool>> = z
        .iter()
        .map(|row| row.iter().map(|v| *v >= z_lo).collect())
        .collect();
    let hidden = seen.iter().flatten().filter(|s| !**s).count();
    let none_seen = seen.iter().filter(|row| !row.contains(&true)).count();
    assert!(
        none_seen > 0 && none_seen < 30,
        "the test's box must cut: {none_seen}"
    );
    let plan = plan_campaign(&model, &c).unwrap();
    assert_eq!(plan.outside_reach_box, hidden);
    assert_eq!(plan.left_out, none_seen);
    assert_eq!(plan.candidates, offered.len() - none_seen);
    for k in &plan.selected {
        assert!(seen[*k].contains(&true), "candidate {k} planned unseen");
    }
    let set = synthetic_set(&model, &plan.configurations, &c.instrument, &targets).unwrap();
    for (pose, k) in set.poses().iter().zip(&plan.selected) {
        let observed: Vec<bool> = pose.observations.iter().map(Option::is_some).collect();
        assert_eq!(observed, seen[*k]);
    }
    assert!(plan.summary_text().contains("where it sees no target"));
    // A target on a frame the robot does not have.
    let mut wrong = targets;
    wrong[1].frame = "RX".into();
    let m = plan_campaign(&model, &config(&model, Some(wrong), 12))
        .unwrap_err()
        .to_string();
    assert!(
        m.contains("target `right`") && m.contains("no frame `RX`"),
        "{m}"
    );
}

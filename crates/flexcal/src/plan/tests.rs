use super::*;

pub(super) fn ur10() -> Model {
    crate::load_robot("ur10").unwrap()
}

/// A box of the UR10's workspace away from its singular configurations.
pub(super) fn ur10_box() -> JointBox {
    JointBox {
        ranges: vec![
            (-1.5, 1.5),
            (-2.2, -0.6),
            (0.5, 2.2),
            (-2.5, 0.5),
            (0.5, 2.6),
            (-3.0, 3.0),
        ],
    }
}

fn config(count: Option<usize>, candidates: usize, region: usize) -> PlanConfig {
    let mut options = CalibrationOptions::for_model(&ur10());
    options.target = calib::FrameTreatment::Fixed;
    let mut config = PlanConfig::new(
        options,
        [0.02, 0.02, 0.03],
        PoseSource::Box {
            joint_box: ur10_box(),
            count: candidates,
            seed: 1,
        },
        PoseSource::Box {
            joint_box: ur10_box(),
            count: region,
            seed: 2,
        },
    );
    config.count = count;
    config.max_poses = Some(candidates.min(40));
    config
}

/// More poses never raise a predicted variance: along the greedy order the
/// mean, percentile and largest bound do not increase.
#[test]
fn the_curve_never_rises_and_the_knee_is_on_it() {
    let model = ur10();
    let plan = plan_campaign(&model, &config(Some(25), 60, 30)).unwrap();
    assert!(!plan.curve.is_empty());
    for w in plan.curve.windows(2) {
        let (a, b) = (w[0].accuracy, w[1].accuracy);
        assert_eq!(w[1].poses, w[0].poses + 1);
        assert!(
            b.mean_bound_95_mm <= a.mean_bound_95_mm * (1.0 + 1e-9),
            "{w:?}"
        );
        assert!(
            b.max_bound_95_mm <= a.max_bound_95_mm * (1.0 + 1e-9),
            "{w:?}"
        );
    }
    let knee = plan.knee.unwrap();
    let last = plan.curve.last().unwrap().accuracy.mean_bound_95_mm;
    let at = |n: usize| plan.curve.iter().find(|p| p.poses == n).unwrap().accuracy;
    assert!(at(knee).mean_bound_95_mm <= 1.05 * last);
    if knee > plan.curve[0].poses {
        assert!(at(knee - 1).mean_bound_95_mm > 1.05 * last);
    }
    // The floor: with the model known exactly the bound is the noise's.
    let floor = calib::bound_95(0.0, plan.instrument.scatter_variance()) * 1e3;
    assert!(last > floor);
    assert_eq!(plan.count, 25);
    assert_eq!(plan.configurations.len(), 25);
    let mut rows = plan.selected.clone();
    rows.sort_unstable();
    rows.dedup();
    assert_eq!(rows.len(), 25, "a pose planned twice");
    assert_eq!(plan.prediction.map.poses.len(), 30);
    let text = plan.summary_text();
    assert!(text.contains("<- knee"), "{text}");
}

/// The plan's prediction (a calibration of the planned poses and its
/// accuracy map) agrees with the design's variances of the same poses,
/// two evaluations that share only the error model's Jacobian.
#[test]
fn the_prediction_matches_the_designs_variances() {
    for orientation in [None, Some([0.01, 0.01, 0.02])] {
        prediction_matches_the_designs_variances(orientation);
    }
}

/// [`the_prediction_matches_the_designs_variances`] for an instrument
/// measuring positions, or full poses with `orientation_noise_deg`.
fn prediction_matches_the_designs_variances(orientation_noise_deg: Option<[f64; 3]>) {
    let model = ur10();
    let mut config = config(Some(20), 50, 15);
    config.instrument.orientation_noise_deg = orientation_noise_deg;
    let plan = plan_campaign(&model, &config).unwrap();
    // The same unknowns: the design's and the six of the measurement frame.
    assert_eq!(plan.prediction.rank, plan.design_unknowns.len() + 6);
    design_agrees_with_the_map(&model, &config, &plan);
}

/// The design's variances at the planned poses (the greedy's rows,
/// stacked over the targets a pose shows, the region's point-major over
/// the targets) against `calibrate`'s accuracy map of the planned poses in
/// `plan`, point by point and target by target.
pub(super) fn design_agrees_with_the_map(model: &Model, config: &PlanConfig, plan: &CampaignPlan) {
    let options = plan_options(&config.options, &config.instrument);
    let pool: Vec<Vec<f64>> = config
        .candidates
        .configurations(model, "c")
        .unwrap()
        .into_iter()
        .map(|c| c.value)
        .collect();
    let map = &plan.prediction.map.poses;
    let n_targets = plan.targets.len();
    let region: Vec<Vec<f64>> = map.iter().step_by(n_targets).map(|p| p.q.clone()).collect();
    let (design, _) = pool_design(
        model,
        &options,
        &config.instrument,
        &plan.targets,
        &pool,
        &region,
    )
    .unwrap();
    let variances = design.region_variances(&plan.selected).unwrap();
    let s2 = config.instrument.scatter_variance();
    for (i, v) in variances.iter().enumerate() {
        let (r, t) = (i / n_targets, &plan.targets[i % n_targets].name);
        let p = map
            .iter()
            .find(|p| p.q == region[r] && p.target.as_ref().is_none_or(|name| name == t))
            .unwrap();
        let bound = calib::bound_95(*v, s2) * 1e3;
        assert!(
            (bound - p.bound_95_mm).abs() < 1e-6 * bound,
            "point {r} target {t}: {bound} vs {}",
            p.bound_95_mm
        );
    }
}

/// The position rows of the design are the derivatives of the nominal
/// robot's TCP position, and with full poses its orientation rows those of
/// the TCP's rotation vector in the base frame: finite differences of
/// forward_pose in a robot parameter.
#[test]
fn the_design_rows_are_derivatives_of_the_pose() {
    let model = ur10();
    let mut config = config(None, 20, 3);
    config.instrument.orientation_noise_deg = Some([0.01; 3]);
    let options = plan_options(&config.options, &config.instrument);
    let pool: Vec<Vec<f64>> = config
        .candidates
        .configurations(&model, "c")
        .unwrap()
        .into_iter()
        .map(|c| c.value)
        .collect();
    let set = synthetic_set(
        &model,
        &pool,
        &config.instrument,
        &planned_targets(&options, None),
    )
    .unwrap();
    let calibration = calib::calibrate(&model, &set, &options).unwrap();
    let j = model.param_index("d3").unwrap();
    let rows = jacobian_rows(&model, &calibration, &set, &[j], &[1.0; 6]).unwrap();
    let mut data = Data::new(&model);
    let h = 1e-6;
    for (q, row) in pool.iter().zip(&rows).take(5) {
        assert_eq!(row.nrows(), 6);
        let mut xi = calibration.xi.clone();
        xi[j] += h;
        let plus = forward_pose(&model, &mut data, q, &xi).unwrap();
        xi[j] -= 2.0 * h;
        let minus = forward_pose(&model, &mut data, q, &xi).unwrap();
        let fd_position = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
        // R(xi + h) R(xi - h)^T = exp(2 h omega) in the base frame.
        let fd_rotation = (plus.rotation * minus.rotation.inverse()).scaled_axis() / (2.0 * h);
        for i in 0..3 {
            for (analytic, fd) in [
                (row[(i, 0)], fd_position[i]),
                (row[(i + 3, 0)], fd_rotation[i]),
            ] {
                assert!((analytic - fd).abs() < 1e-6, "{analytic} vs {fd}");
            }
        }
    }
}

#[test]
fn bad_input_gets_named_errors() {
    let model = ur10();
    let message = |c: &PlanConfig| plan_campaign(&model, c).unwrap_err().to_string();
    let mut c = config(Some(10), 30, 5);
    c.instrument.noise_mm = [0.02, 0.0, 0.02];
    assert!(
        message(&c).contains("noise along y must be finite and > 0"),
        "{}",
        message(&c)
    );
    c.instrument.noise_mm = [f64::NAN, 0.02, 0.02];
    assert!(message(&c).contains("noise along x"), "{}", message(&c));
    let mut c = config(Some(10), 30, 5);
    c.instrument.orientation_noise_deg = Some([0.01, 0.01, 0.0]);
    let m = message(&c);
    assert!(
        m.contains("orientation_noise_deg")
            && m.contains("noise along z must be finite and > 0 deg"),
        "{m}"
    );
    let mut c = config(Some(10), 30, 5);
    if let PoseSource::Box { joint_box, .. } = &mut c.region {
        joint_box.ranges[0] = (-1.0, 7.0);
    }
    let m = message(&c);
    assert!(
        m.contains("region") && m.contains("leaves the joint limits") && m.contains("cannot reach"),
        "{m}"
    );
    let mut c = config(Some(10), 30, 5);
    c.region = PoseSource::Configurations(Vec::new());
    assert!(
        message(&c).contains("region: no configurations"),
        "{}",
        message(&c)
    );
    let mut c = config(Some(10), 30, 5);
    if let PoseSource::Box { joint_box, .. } = &mut c.candidates {
        joint_box.ranges[1] = (-1.0, -1.0);
    }
    assert!(
        message(&c).contains("candidates: the range of"),
        "{}",
        message(&c)
    );
    assert!(message(&c).contains("is empty"), "{}", message(&c));
    let mut c = config(Some(10), 30, 5);
    c.region = PoseSource::Configurations(vec![Located {
        value: vec![0.0, -1.0, 1.0, 0.0, 1.0, 9.0],
        origin: "path.csv:3".into(),
    }]);
    let m = message(&c);
    assert!(
        m.starts_with("path.csv:3: ") && m.contains("cannot reach"),
        "{m}"
    );
    let c = config(Some(31), 30, 5);
    assert!(
        message(&c).contains("31 poses asked for, but only 30 candidates"),
        "{}",
        message(&c)
    );
}

/// A sight leaves out exactly the candidates whose TCP lies outside its
/// box or faces away from the instrument (each tested here on the pose
/// itself), plans among the rest, and names the rows as given.
#[test]
fn the_plan_chooses_only_among_the_poses_the_instrument_sees() {
    let model = ur10();
    let mut c = config(Some(12), 120, 20);
    c.max_poses = Some(20);
    let offered = c.candidates.configurations(&model, "candidates").unwrap();
    let mut data = Data::new(&model);
    let poses: Vec<Isometry3<f64>> = offered
        .iter()
        .map(|row| forward_pose(&model, &mut data, &row.value, model.nominal_params()).unwrap())
        .collect();
    // A box that cuts off the fifth of the TCPs farthest along x.
    let mut x_mm: Vec<f64> = poses.iter().map(|x| x.translation.x * 1e3).collect();
    x_mm.sort_by(f64::total_cmp);
    let x_hi = x_mm[x_mm.len() * 4 / 5];
    let instrument_mm = [2500.0, 0.0, 500.0];
    let (box_mm, half_angle) = (
        [[-2000.0, x_hi], [-2000.0, 2000.0], [-2000.0, 2000.0]],
        110.0,
    );
    c.instrument.sight = Sight {
        reach_box_mm: Some(box_mm),
        line_of_sight: Some(LineOfSight {
            position_mm: instrument_mm,
            max_incidence_deg: half_angle,
        }),
    };
    let seen: Vec<bool> = poses
        .iter()
        .map(|x| {
            let p = x.translation.vector * 1e3;
            let inside = (0..3).all(|i| p[i] >= box_mm[i][0] && p[i] <= box_mm[i][1]);
            let facing = x.rotation * Vector3::z();
            let cos = facing.dot(&(Vector3::from(instrument_mm) - p).normalize());
            inside && cos >= half_angle.to_radians().cos()
        })
        .collect();
    let n_seen = seen.iter().filter(|s| **s).count();
    assert!(
        n_seen > 20 && n_seen < offered.len(),
        "the test's sight must cut: {n_seen}"
    );
    let plan = plan_campaign(&model, &c).unwrap();
    assert_eq!(plan.candidates, n_seen);
    assert_eq!(
        plan.candidates + plan.outside_reach_box + plan.facing_away,
        offered.len()
    );
    assert_eq!(plan.left_out, plan.outside_reach_box + plan.facing_away);
    assert!(
        plan.outside_reach_box > 0 && plan.facing_away > 0,
        "{plan:?}"
    );
    for (k, q) in plan.selected.iter().zip(&plan.configurations) {
        assert!(seen[*k], "pose {k} planned out of sight");
        assert_eq!(&offered[*k].value, q);
    }
    assert!(plan.summary_text().contains("facing away from it"));
    // A box the robot's TCP never enters: refused by name.
    c.instrument.sight.reach_box_mm = Some([[5000.0, 6000.0], [0.0, 1.0], [0.0, 1.0]]);
    let m = plan_campaign(&model, &c).unwrap_err().to_string();
    assert!(
        m.contains("the instrument sees none of the 120 candidates: 120 outside the reach box"),
        "{m}"
    );
    // More poses than the sight leaves.
    c.instrument.sight.reach_box_mm = Some(box_mm);
    c.count = Some(n_seen + 1);
    let m = plan_campaign(&model, &c).unwrap_err().to_string();
    assert!(
        m.contains(&format!(
            "but only {n_seen} candidates in the instrument's sight"
        )),
        "{m}"
    );
}

#[test]
fn region_statistics_use_the_nearest_rank() {
    let bounds: Vec<f64> = (1..=20).map(f64::from).collect();
    let a = RegionAccuracy::of(&bounds);
    assert_eq!(a.p95_bound_95_mm, 19.0);
    assert_eq!(a.max_bound_95_mm, 20.0);
    assert!((a.mean_bound_95_mm - 10.5).abs() < 1e-12);
    assert_eq!(RegionAccuracy::of(&[3.0]).p95_bound_95_mm, 3.0);
}

/// The plan's files: configurations that read back, a KRL program and a
/// RAPID module with one target per pose, a JSON plan that parses back.
#[test]
fn the_files_of_a_plan_round_trip() {
    let model = ur10();
    let plan = plan_campaign(&model, &config(Some(12), 30, 6)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let outputs = output::PlanOutputs {
        configurations: Some(dir.path().join("poses.csv")),
        joint_trajectory: Some(dir.path().join("joints.csv")),
        krl: Some(dir.path().join("plan.src")),
        rapid: Some(dir.path().join("plan.mod")),
        report: Some(dir.path().join("plan.json")),
        html: Some(dir.path().join("plan.html")),
    };
    let written = plan.write_outputs(&model, &outputs).unwrap();
    assert_eq!(written.len(), 6);
    let back =
        crate::pose_file::read_configurations(&dir.path().join("poses.csv"), &model).unwrap();
    let back: Vec<Vec<f64>> = back.into_iter().map(|l| l.value).collect();
    assert_eq!(back, plan.configurations);
    let json = std::fs::read_to_string(dir.path().join("plan.json")).unwrap();
    let parsed: CampaignPlan = serde_json::from_str(&json).unwrap();
    assert_eq!(parsed.selected, plan.selected);
    let rapid = std::fs::read_to_string(dir.path().join("plan.mod")).unwrap();
    assert!(rapid.matches("robtarget").count() >= 12, "{rapid}");
    let html = std::fs::read_to_string(dir.path().join("plan.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("Planned poses"));
    assert!(
        html.contains("noise 0.0200/0.0200/0.0300 mm (positions)"),
        "the instrument"
    );
}

/// With the frame kept as identified the prediction's identification part
/// is the variance of the planned poses' whole weighted least squares,
/// frame included, computed here from their Jacobian (the information
/// matrix over every identified unknown, inverted): region point by point,
/// for positions and for full poses. The frame registered again (the
/// robot's unknowns conditioned on the frame's) never gives more.
#[test]
fn the_frame_as_identified_counts_the_whole_least_squares_variance() {
    for orientation_noise_deg in [None, Some([0.01, 0.01, 0.02])] {
        let model = ur10();
        let mut config = config(Some(20), 50, 15);
        config.instrument.orientation_noise_deg = orientation_noise_deg;
        let plan = plan_campaign(&model, &config).unwrap();
        let pool = config.candidates.configurations(&model, "c").unwrap();
        let planned: Vec<Vec<f64>> = plan
            .selected
            .iter()
            .map(|&k| pool[k].value.clone())
            .collect();
        let region: Vec<Vec<f64>> = plan
            .prediction
            .map
            .poses
            .iter()
            .map(|p| p.q.clone())
            .collect();
        let mut instrument = config.instrument.clone();
        let registered = plan.prediction.map.clone();
        instrument.frame = calib::FrameUncertainty::AsIdentified;
        let options = plan_options(&config.options, &instrument);
        let as_identified = predict_campaign(
            &model,
            &config.options,
            &instrument,
            None,
            (&planned, &region),
            None,
        )
        .unwrap()
        .map;
        let (set, calibration) =
            synthetic_calibration(&model, &options, &instrument, &plan.targets, &planned).unwrap();
        let columns: Vec<usize> = (0..calibration.unknowns.len())
            .filter(|&j| calibration.unknowns[j].status == calib::UnknownStatus::Identified)
            .collect();
        let blocks = jacobian_rows(
            &model,
            &calibration,
            &set,
            &columns,
            &instrument.row_weights(),
        )
        .unwrap();
        let mut information = DMatrix::<f64>::zeros(columns.len(), columns.len());
        for b in &blocks {
            information += b.transpose() * b;
        }
        let covariance = information.try_inverse().unwrap();
        let region_set = synthetic_set(
            &model,
            &region,
            &Instrument::positions(instrument.noise_mm),
            &plan.targets,
        )
        .unwrap();
        let rows = jacobian_rows(&model, &calibration, &region_set, &columns, &[1.0; 3]).unwrap();
        for ((r, p), c) in rows.iter().zip(&as_identified.poses).zip(&registered.poses) {
            let expected = (r * &covariance * r.transpose()).trace().sqrt() * 1e3;
            assert!(
                (expected - p.model_uncertainty_mm).abs() < 1e-6 * expected,
                "{}: {expected} mm computed, {} mm predicted",
                p.pose,
                p.model_uncertainty_mm
            );
            assert!(c.model_uncertainty_mm <= p.model_uncertainty_mm * (1.0 + 1e-9));
        }
    }
}

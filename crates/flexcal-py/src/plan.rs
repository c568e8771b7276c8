//! `flexcal.plan(...)`: a campaign plan before measuring
//! ([`flexcal::plan::plan_campaign`]), returned as the plan's JSON parsed
//! into Python dicts and lists (the fields of `CampaignPlan`, docs/planning.md).

use crate::arrays::{AllowTypeChange, PyArrayLikeDyn};
use flexcal::calib::{CalibrationOptions, FrameTreatment};
use flexcal::plan::{JointBox, LineOfSight, PlanConfig, PoseSource, Sight, plan_campaign};
use flexcal::pose_file::Located;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

use crate::arrays::exact;
use crate::calibration::gravity_option;
use crate::errors::InputError;
use crate::interrupt::run_interruptible;
use crate::robot::Robot;

/// Configurations of an `(n, dof)` array (rad or m) named `what`.
fn configurations(
    what: &str,
    array: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    dof: usize,
) -> PyResult<PoseSource> {
    let (values, shape) = exact(what, array, &[None, Some(dof)])?;
    Ok(PoseSource::Configurations(
        values
            .chunks(dof)
            .take(shape[0])
            .enumerate()
            .map(|(k, q)| Located {
                value: q.to_vec(),
                origin: format!("{what} row {k}"),
            })
            .collect(),
    ))
}

/// The instrument's sight from the keywords (checked by the plan).
fn sight(
    reach_box_mm: Option<[[f64; 2]; 3]>,
    sight_from_mm: Option<[f64; 3]>,
    max_incidence_deg: Option<f64>,
) -> PyResult<Sight> {
    let line_of_sight = match (sight_from_mm, max_incidence_deg) {
        (Some(position_mm), Some(max_incidence_deg)) => Some(LineOfSight {
            position_mm,
            max_incidence_deg,
        }),
        (None, None) => None,
        _ => {
            return Err(InputError::new_err(
                "sight_from_mm and max_incidence_deg: give both (the instrument's position, mm, and the largest incidence, deg) or neither",
            ));
        }
    };
    Ok(Sight {
        reach_box_mm,
        line_of_sight,
    })
}

/// Plans a measurement campaign before measuring: which poses, how many,
/// and the predicted 95 % bound they buy over the region.
///
/// `noise_mm` the instrument's standard deviation per position axis (mm;
/// one value or three); `candidates` (n, dof) configurations the cell
/// allows (rad or m), else `candidate_count` drawn in `joint_box` (dof, 2)
/// (rad or m; default the joint limits) with `seed`; `region` (m, dof)
/// configurations where accuracy matters, else `region_count` drawn in the
/// box with `seed + 1`; `poses` the number to plan (default: the knee);
/// `max_poses` the curve's end; `model`, `masses`, `fix`, `fixed_frame`,
/// `fixed_target` as for `calibrate`; `orientation_noise_deg` (one value
/// or three, deg) when the instrument measures full poses, the standard
/// deviation of the measured orientation about each axis (checked finite
/// and > 0 by the plan, as `--orientation-noise-deg`); `reach_box_mm`
/// ((3, 2): x, y, z ranges in the base frame, mm), `sight_from_mm` (the
/// instrument's position in the base frame, mm) with `max_incidence_deg`
/// (the largest angle between the target's z axis and the line to the
/// instrument, deg): candidates the instrument cannot see are left out
/// (`outside_reach_box`, `facing_away` count them). `targets`: several
/// targets per pose, the TOML description `calibrate` reads
/// (`MeasurementSet.read_csv`'s `targets`, docs/file-formats.md):
/// the sight is tested per target, a pose where none is seen is left out,
/// and the curve and prediction carry `per_target` (each target's
/// `accuracy`). `frame_uncertainty`: `"registered"` (default: the
/// measurement frame registered again where the region is measured or
/// used) or `"as-identified"` (the region measured from the campaign's
/// instrument placement: the frame's uncertainty counted), as
/// `--frame-uncertainty`. `prior`: an earlier calibration of the same
/// robot, the JSON report of `calibrate --report` made with
/// `--split-check` (and `--extrapolation` for its growth), as `plan
/// --prior`: its model (the default of `model`) and chosen groups, its
/// residual scatter as the noise floor, its split-half inflation, its
/// growth outside the planned poses' ranges (`prior` in the result says
/// what was used; each map point's `parts` split its bound).
///
/// Returns the plan as a dict: `configurations` (the planned poses),
/// `selected` (candidate rows), `curve` (per count: `poses` and
/// `accuracy` with `mean_bound_95_mm`, `p95_bound_95_mm`,
/// `max_bound_95_mm`), `knee`, `prediction` (`accuracy`, `map`,
/// `identifiability_notes`, ...). Runs without the GIL.
#[pyfunction]
#[pyo3(signature = (robot, noise_mm, candidates = None, region = None, joint_box = None, candidate_count = 200, region_count = 200, seed = 1, poses = None, max_poses = None, model = None, masses = None, fix = Vec::new(), fixed_frame = false, fixed_target = false, knee_tolerance = 0.05, orientation_noise_deg = None, reach_box_mm = None, sight_from_mm = None, max_incidence_deg = None, targets = None, frame_uncertainty = "registered", prior = None))]
#[allow(clippy::too_many_arguments)]
pub fn plan<'py>(
    py: Python<'py>,
    robot: &Robot,
    noise_mm: Vec<f64>,
    candidates: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    region: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    joint_box: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    candidate_count: usize,
    region_count: usize,
    seed: u64,
    poses: Option<usize>,
    max_poses: Option<usize>,
    model: Option<&str>,
    masses: Option<PathBuf>,
    fix: Vec<String>,
    fixed_frame: bool,
    fixed_target: bool,
    knee_tolerance: f64,
    orientation_noise_deg: Option<Vec<f64>>,
    reach_box_mm: Option<[[f64; 2]; 3]>,
    sight_from_mm: Option<[f64; 3]>,
    max_incidence_deg: Option<f64>,
    targets: Option<PathBuf>,
    frame_uncertainty: &str,
    prior: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let robot_model = Arc::clone(&robot.model);
    let dof = robot_model.n_actuated();
    let noise_mm = match noise_mm[..] {
        [s] => [s; 3],
        [x, y, z] => [x, y, z],
        _ => {
            return Err(InputError::new_err(format!(
                "noise_mm: one value or three (x, y, z), got {}",
                noise_mm.len()
            )));
        }
    };
    let joint_box = match joint_box {
        Some(b) => {
            let (v, _) = exact("joint_box", &b, &[Some(dof), Some(2)])?;
            JointBox {
                ranges: v.chunks(2).map(|r| (r[0], r[1])).collect(),
            }
        }
        None => JointBox::of_limits(&robot_model),
    };
    let drawn = |count, seed| PoseSource::Box {
        joint_box: joint_box.clone(),
        count,
        seed,
    };
    let candidates = match candidates {
        Some(c) => configurations("candidates", &c, dof)?,
        None => drawn(candidate_count, seed),
    };
    let region = match region {
        Some(r) => configurations("region", &r, dof)?,
        None => drawn(region_count, seed.wrapping_add(1)),
    };
    let prior = prior
        .map(|path| flexcal::plan::Prior::read(&path).map_err(|e| crate::errors::facade_error(&e)))
        .transpose()?;
    let model = model.unwrap_or(match &prior {
        Some(p) if p.model == "elasto-geometric" => "elasto-geometric",
        _ => "geometric",
    });
    let mut options = CalibrationOptions::for_model(&robot_model);
    options.gravity = gravity_option(model, masses, &robot_model)?;
    options.fixed = fix;
    if fixed_frame {
        options.measurement_frame = FrameTreatment::Fixed;
    }
    if fixed_target {
        options.target = FrameTreatment::Fixed;
    }
    let orientation_noise_deg = orientation_noise_deg
        .map(|v| match v[..] {
            [s] => Ok([s; 3]),
            [x, y, z] => Ok([x, y, z]),
            _ => Err(InputError::new_err(format!(
                "orientation_noise_deg: one value or three (about x, y, z), got {}",
                v.len()
            ))),
        })
        .transpose()?;
    let mut config = PlanConfig::new(options, noise_mm, candidates, region);
    config.instrument.orientation_noise_deg = orientation_noise_deg;
    config.instrument.frame = frame_uncertainty
        .parse()
        .map_err(|e: String| InputError::new_err(format!("frame_uncertainty: {e}")))?;
    config.instrument.sight = sight(reach_box_mm, sight_from_mm, max_incidence_deg)?;
    if let Some(path) = targets {
        if fixed_target {
            return Err(InputError::new_err(
                "fixed_target is for one target: with targets each target's `identify` decides",
            ));
        }
        config.targets =
            Some(flexcal::calib::read_targets(&path).map_err(|e| crate::errors::calib_error(&e))?);
    }
    config.prior = prior;
    config.count = poses;
    config.max_poses = max_poses;
    config.knee_tolerance = knee_tolerance;
    let text = run_interruptible(py, move || {
        let plan = plan_campaign(&robot_model, &config)?;
        Ok(plan.to_json_string()?)
    })?;
    py.import("json")?.call_method1("loads", (text,))
}

//! Step 2 of the identification: where the
//! frames start. Each station's measurement frame starts from a closed-form
//! registration (Kabsch/Horn by SVD, [`crate::geometry::register_points`])
//! of the nominal robot's target positions onto that station's measured
//! ones; the orientation of each target whose orientations are fitted
//! starts from the data, the mean over its observations of the rotation
//! each implies ([`crate::geometry::mean_rotation`]). The unknowns are
//! increments on these starts, so the robot's linearisation point is the
//! nominal robot in the right place.

use flexcal_kinematics::{Data, Model, forward_frames};
use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use crate::error::CalibError;
use crate::error_model::FrameStarts;
use crate::frames::resolve_frame;
use crate::geometry::{mean_rotation, register_points, rotation_from_vector};
use crate::measurement::MeasurementSet;
use crate::options::CalibrationOptions;
use crate::options::FrameTreatment;

/// The pose `x_base_f` of each target's frame (after the tool for a target
/// on the TCP) at every pose of `set`, the robot rigid at `xi`: one entry
/// per pose, one per target.
///
/// # Errors
/// [`CalibError::Kinematics`] naming the pose; a target on an unknown
/// frame.
pub(crate) fn target_frames(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
) -> Result<Vec<Vec<Isometry3<f64>>>, CalibError> {
    let frames = set
        .targets()
        .iter()
        .map(|t| {
            resolve_frame(
                model,
                &set.source,
                &format!("target `{}`", t.name),
                &t.frame,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut data = Data::new(model);
    set.poses()
        .iter()
        .enumerate()
        .map(|(k, pose)| {
            forward_frames(model, &mut data, &pose.q, xi).map_err(|source| {
                CalibError::Kinematics {
                    pose: k,
                    pose_id: pose.label(k),
                    source,
                }
            })?;
            Ok(frames
                .iter()
                .map(|&(f, on_tcp)| {
                    let frame = data.frame_pose(f).expect("a checked frame");
                    if on_tcp { frame * model.tool() } else { frame }
                })
                .collect())
        })
        .collect()
}

/// The pose `x_base_target` of every target of `set` (its frame's pose
/// times its nominal offset and orientation) at every pose of `set`, the
/// robot rigid at `xi`: one entry per pose, one per target, whether or not
/// the target was seen there. What an instrument would see of a nominal
/// robot: a plan's synthetic measurements and its line-of-sight tests.
///
/// # Errors
/// [`CalibError::BadMeasurement`] naming a target on a frame the robot
/// does not have (and the robot's frames); [`CalibError::Kinematics`]
/// naming the pose where the model fails.
pub fn target_poses(
    model: &Model,
    set: &MeasurementSet,
    xi: &[f64],
) -> Result<Vec<Vec<Isometry3<f64>>>, CalibError> {
    let frames = target_frames(model, set, xi)?;
    Ok(frames
        .into_iter()
        .map(|row| {
            row.into_iter()
                .zip(set.targets())
                .map(|(x_base_f, target)| x_base_f * target.pose())
                .collect()
        })
        .collect())
}

/// The starting frames of an identification of `set` (see the module
/// docs): the measurement frame of each station (the first's given or
/// fixed by `options`, a fixed one the identity), each target's start (its
/// nominal pose, or `options.target_value` for a set's only target, its
/// rotation registered where its orientations are fitted), and which
/// targets' orientations are fitted. A station without poses (a subset's)
/// starts where the first does.
///
/// # Errors
/// [`CalibError::BadMeasurement`] for orientations asked of a target
/// without them; a degenerate registration; a model failure at a pose.
pub(crate) fn frame_starts(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
) -> Result<FrameStarts, CalibError> {
    let mut starts = FrameStarts::nominal(set, Isometry3::identity(), options.use_orientation)?;
    if let Some(target) = options.target_value {
        starts.targets[0] = target;
    }
    let frame_fixed = options.measurement_frame == FrameTreatment::Fixed;
    let frames = target_frames(model, set, model.nominal_params())?;
    let registered = if frame_fixed {
        vec![None; set.n_stations()]
    } else {
        register_stations(set, &frames, &starts.targets)?
    };
    let first = match (frame_fixed, options.measurement_frame_value) {
        (_, Some(x)) => x,
        (true, None) => Isometry3::identity(),
        (false, None) => registered[0].unwrap_or_else(Isometry3::identity),
    };
    starts.stations = std::iter::once(first)
        .chain(registered[1..].iter().map(|r| r.unwrap_or(first)))
        .collect();
    let registers_rotation =
        options.target != FrameTreatment::Fixed && options.target_value.is_none();
    for t in 0..set.targets().len() {
        if starts.orientation[t]
            && registers_rotation
            && set.targets()[t].treatment != FrameTreatment::Fixed
        {
            let rotation = register_target_rotation(set, &frames, &starts.stations, t)?;
            starts.targets[t] = Isometry3::from_parts(starts.targets[t].translation, rotation);
        }
    }
    Ok(starts)
}

/// The registration of each station's predicted target positions onto its
/// measured ones (`None` for a station without observations): `frames`
/// from [`target_frames`], the targets at `targets` in their frames.
///
/// # Errors
/// [`CalibError::DegenerateRegistration`].
pub(crate) fn register_stations(
    set: &MeasurementSet,
    frames: &[Vec<Isometry3<f64>>],
    targets: &[Isometry3<f64>],
) -> Result<Vec<Option<Isometry3<f64>>>, CalibError> {
    (0..set.n_stations())
        .map(|s| {
            let (measured, predicted): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) =
                observations_at(set, s)
                    .map(|(k, t)| {
                        let o = set.poses()[k].observations[t].as_ref().expect("seen");
                        let p = frames[k][t] * targets[t] * Point3::origin();
                        (o.position, p.coords)
                    })
                    .unzip();
            if measured.is_empty() {
                return Ok(None);
            }
            register_points(&measured, &predicted).map(Some)
        })
        .collect()
}

/// `(pose, target)` of every observation of station `s`.
fn observations_at(set: &MeasurementSet, s: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
    set.poses()
        .iter()
        .enumerate()
        .filter(move |(k, _)| set.station_of(*k) == s)
        .flat_map(|(k, pose)| {
            pose.observations
                .iter()
                .enumerate()
                .filter(|(_, o)| o.is_some())
                .map(move |(t, _)| (k, t))
        })
}

/// The start of target `t`'s orientation in its frame: from the first
/// station that sees it, in that station's starting frame, each
/// observation gives `R_f_target = (R_meas_base R_base_f)^T R_meas_target`;
/// their mean rotation. A probe whose frame is turned against the one its
/// nominal pose assumes (a quarter turn about the tool axis, say) then
/// starts where the data put it.
fn register_target_rotation(
    set: &MeasurementSet,
    frames: &[Vec<Isometry3<f64>>],
    stations: &[Isometry3<f64>],
    t: usize,
) -> Result<UnitQuaternion<f64>, CalibError> {
    let seen = |k: usize| set.poses()[k].observations[t].as_ref();
    let Some(s) = (0..set.len())
        .find(|&k| seen(k).is_some())
        .map(|k| set.station_of(k))
    else {
        return Ok(set.targets()[t].rotation);
    };
    let rotations: Vec<UnitQuaternion<f64>> = (0..set.len())
        .filter(|&k| set.station_of(k) == s)
        .filter_map(|k| seen(k).map(|o| (k, o)))
        .map(|(k, o)| {
            let orientation = o.orientation.ok_or_else(|| CalibError::BadMeasurement {
                source_name: set.source.clone(),
                line: 0,
                what: format!(
                    "pose {}: no orientation of target `{}` to register its rotation",
                    set.poses()[k].label(k),
                    set.targets()[t].name
                ),
            })?;
            Ok((stations[s].rotation * frames[k][t].rotation).inverse()
                * rotation_from_vector(&orientation))
        })
        .collect::<Result<_, CalibError>>()?;
    mean_rotation(&rotations)
}

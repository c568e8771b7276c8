//! Campaign planning before measuring (`flexcal plan`): which poses, how
//! many, and the accuracy they will buy over the region that matters.
//!
//! Given a robot, the model to identify (the same
//! [`calib::CalibrationOptions`] as `calibrate`: geometric or
//! elasto-geometric, frames identified or fixed, parameters fixed or
//! deferred), the instrument (positions, or full poses) and its noise per
//! axis, a pool of candidate
//! configurations (a file, or a joint box sampled with a seed) and the
//! region where accuracy matters (a path or configuration file, or a joint
//! box sampled with a seed), [`plan_campaign`]:
//! 0. tests which targets (one at the TCP or a given offset, or several
//!    of a targets description: [`PlanConfig::targets`]) the instrument
//!    sees at each candidate (a reach box, a line of sight: [`sight`]) and
//!    leaves out the candidates where it sees none;
//! 1. identifies the pool: `calibrate` on the positions (and orientations,
//!    when the instrument measures them) the nominal robot would give at
//!    every candidate, weighted by the instrument's noise
//!    ([`synthetic_set`]), decides which unknowns any campaign from this
//!    pool can identify (the columns of the design);
//! 2. chooses poses greedily on the I-optimal criterion, the mean over the
//!    region of the predicted position variance `tr(J_r Sigma J_r^T)` of
//!    the identification with the stated noise (`docs/planning.md` gives the
//!    equations), up to the largest count asked.
//!    With several targets a candidate's rows are those of the targets
//!    seen at it and the region's those of every target at every point:
//!    the criterion is summed over the targets.
//! 3. predicts the accuracy over the region for every prefix of the greedy
//!    order: mean, 95th percentile and maximum of the 95 % bound
//!    `sqrt(chi2_3(0.95) (tr Sigma_pred / 3 + s^2))` of
//!    [`calib::accuracy`], with `s` the instrument's noise
//!    ([`CurvePoint`], over all targets and per target), and finds the
//!    knee where more poses stop paying ([`PlanConfig::knee_tolerance`]);
//! 4. refines the campaign of the chosen count by exchange passes and
//!    predicts its accuracy with `calibrate`'s own machinery: a
//!    calibration of the planned poses on the same noise-free positions,
//!    its identifiability notes (what the campaign cannot determine, in
//!    `calibrate`'s words), its combinations and its accuracy map over
//!    the region ([`predict_campaign`]), with a prior's floor, inflation
//!    and growth outside the planned poses' ranges ([`prior`]).
//!
//! ## Limitations
//! - The region's accuracy is that of the targets' positions, also when
//!   the instrument measures full poses.
//! - The sight is tested on the nominal robot, the target alone: the
//!   robot's own links hiding the target are not modelled.
//! - Without a prior the prediction is that of a model that holds: what
//!   the identified model lacks (non-geometric errors, temperature,
//!   unmodelled elasticity) is not in the bound unless the stated noise
//!   includes it, and region points outside the planned poses' joint
//!   ranges are flagged ([`calib::PoseAccuracy::outside_training_range`]),
//!   not widened. An earlier calibration of the robot as
//!   [`PlanConfig::prior`] ([`prior`]) brings its residual scatter as the
//!   floor, its split-half inflation and its growth outside the training
//!   ranges, all measured on its own poses.
//! - The linearisation is at the nominal robot; errors of millimetres
//!   change the Jacobian to second order only.
//! - The greedy criterion is the mean predicted variance; the curve
//!   reports the bound, which is not linear in it.

use std::fmt::Write as _;

use nalgebra::{DMatrix, Isometry3, Vector3};
use serde::{Deserialize, Serialize};

use crate::calib::{
    self, AccuracyMap, Calibration, CalibrationOptions, MeasurementSet, TargetObservation,
    TargetPose,
};
use crate::kinematics::{Data, Model, forward_pose};
use crate::pose_file::Located;
use crate::{Error, Result};

pub(crate) mod design;
mod html;
pub mod ipa_check;
pub mod noise_check;
pub mod output;
pub mod prior;
pub mod sight;
pub mod twin_check;

use design::Design;
pub use prior::{Prior, PriorUse};
pub use sight::{LineOfSight, OutOfSight, Sight, SightFilter};

/// The instrument of the campaign: what it measures (positions, or full
/// poses) and its noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Instrument {
    /// Standard deviation of each measured position axis x, y, z (mm;
    /// finite and > 0).
    pub noise_mm: [f64; 3],
    /// Standard deviation of the measured orientation about each axis x,
    /// y, z of the measurement frame (deg; finite and > 0), when the
    /// instrument measures full poses (a photogrammetry camera tracking a
    /// target of several LEDs, a 6D tracker probe); `None`: positions only
    /// (a laser tracker's reflector). The orientation rows then enter the
    /// identification weighted by it, as a campaign's file would carry it
    /// (`srx_deg`, `sry_deg`, `srz_deg`).
    #[serde(default)]
    pub orientation_noise_deg: Option<[f64; 3]>,
    /// Where it can measure the target (a reach box, a line of sight);
    /// candidates it cannot see are left out of the plan. Default:
    /// everywhere.
    #[serde(default)]
    pub sight: Sight,
    /// How the measurement frame's uncertainty enters the predicted bounds:
    /// registered again where the region is measured or used (default:
    /// the robot's uncertainty conditioned on the frame), or kept as the
    /// campaign identifies it (the region measured from the same
    /// placement: the frame's uncertainty counted).
    #[serde(default)]
    pub frame: calib::FrameUncertainty,
}

impl Instrument {
    /// An instrument measuring positions only with `noise_mm` per axis.
    pub fn positions(noise_mm: [f64; 3]) -> Self {
        Self {
            noise_mm,
            orientation_noise_deg: None,
            sight: Sight::default(),
            frame: calib::FrameUncertainty::default(),
        }
    }

    /// The per-axis variance of the isotropic scatter the bound assumes:
    /// the mean of the axes' variances (m^2).
    pub fn scatter_variance(&self) -> f64 {
        self.noise_mm
            .iter()
            .map(|s| (s * 1e-3).powi(2))
            .sum::<f64>()
            / 3.0
    }

    /// `noise x/y/z mm (positions)` or `noise x/y/z mm and x/y/z deg (full
    /// poses)`, with `; frame as identified` when the measurement frame's
    /// uncertainty is counted, for reports.
    pub fn describe(&self) -> String {
        let n = self.noise_mm;
        let measured = self
            .orientation_noise_deg
            .map_or(" (positions)".to_string(), |o| {
                format!(" and {:.4}/{:.4}/{:.4} deg (full poses)", o[0], o[1], o[2])
            });
        let frame = match self.frame {
            calib::FrameUncertainty::Registered => "",
            calib::FrameUncertainty::AsIdentified => {
                "; frame as identified (its uncertainty counted)"
            }
        };
        format!(
            "noise {:.4}/{:.4}/{:.4} mm{measured}{frame}",
            n[0], n[1], n[2]
        )
    }

    /// Whether the instrument measures orientations too.
    pub fn measures_orientation(&self) -> bool {
        self.orientation_noise_deg.is_some()
    }

    /// The weights of one pose's residual rows: `1 / sigma` per position
    /// axis (1/m), then per orientation axis (1/rad) when measured.
    fn row_weights(&self) -> Vec<f64> {
        let mut weights: Vec<f64> = self.noise_mm.iter().map(|s| 1.0 / (s * 1e-3)).collect();
        if let Some(deg) = self.orientation_noise_deg {
            weights.extend(deg.iter().map(|s| 1.0 / s.to_radians()));
        }
        weights
    }

    fn check(&self) -> Result<()> {
        let axes = ["x", "y", "z"];
        let invalid = |parameter: &str, axis: &str, unit: &str, s: f64| Error::InvalidParameter {
            parameter: parameter.into(),
            message: format!(
                "the instrument's noise along {axis} must be finite and > 0 {unit}, found {s}"
            ),
        };
        for (axis, s) in axes.iter().zip(self.noise_mm) {
            if !(s.is_finite() && s > 0.0) {
                return Err(invalid("noise_mm", axis, "mm", s));
            }
        }
        for (axis, s) in axes
            .iter()
            .zip(self.orientation_noise_deg.into_iter().flatten())
        {
            if !(s.is_finite() && s > 0.0) {
                return Err(invalid("orientation_noise_deg", axis, "deg", s));
            }
        }
        Ok(())
    }
}

/// A box of actuated coordinates (rad or m), one `(lo, hi)` per
/// coordinate, in the order of [`Model::actuated_names`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointBox {
    /// Lower and upper bound of each actuated coordinate (rad or m).
    pub ranges: Vec<(f64, f64)>,
}

impl JointBox {
    /// The robot's joint limits.
    pub fn of_limits(model: &Model) -> Self {
        Self {
            ranges: model.actuated_limits().to_vec(),
        }
    }

    /// The box of `text`, `lo:hi` per actuated coordinate separated by
    /// commas, in deg for revolute joints and mm for prismatic joints and
    /// screws (the file and command-line units); `what` names the argument
    /// in errors. The box is checked ([`JointBox::check`]).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `what`: a range that is not two
    /// numbers `lo:hi`, and [`JointBox::check`]'s errors.
    pub fn from_text(model: &Model, text: &str, what: &str) -> Result<Self> {
        let invalid = |message: String| Error::InvalidParameter {
            parameter: what.to_string(),
            message,
        };
        let ranges = text
            .split(',')
            .zip(model.actuated_kinds().iter().chain(std::iter::repeat(
                &crate::kinematics::ActuatedKind::Revolute,
            )))
            .map(|(range, kind)| {
                let unit = match kind {
                    crate::kinematics::ActuatedKind::Revolute => 1f64.to_radians(),
                    _ => 1e-3,
                };
                let numbers: Vec<f64> = range
                    .split(':')
                    .map(|v| v.trim().parse::<f64>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| invalid(format!("'{range}' is not a range lo:hi")))?;
                match numbers[..] {
                    [lo, hi] => Ok((lo * unit, hi * unit)),
                    _ => Err(invalid(format!("'{range}' is not a range lo:hi"))),
                }
            })
            .collect::<Result<Vec<_>>>()?;
        let joint_box = Self { ranges };
        joint_box.check(model, what)?;
        Ok(joint_box)
    }

    /// Checks the box against `model`: one range per actuated coordinate,
    /// finite, not empty (`lo < hi`), inside the joint limits.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming `what` and the coordinate.
    pub fn check(&self, model: &Model, what: &str) -> Result<()> {
        let invalid = |message: String| Error::InvalidParameter {
            parameter: what.to_string(),
            message,
        };
        if self.ranges.len() != model.n_actuated() {
            return Err(invalid(format!(
                "{} ranges for the {} actuated coordinates of '{}'",
                self.ranges.len(),
                model.n_actuated(),
                model.name()
            )));
        }
        let names = model.actuated_names();
        for ((&(lo, hi), &(min, max)), name) in
            self.ranges.iter().zip(model.actuated_limits()).zip(names)
        {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(invalid(format!(
                    "the range of {name} is empty: [{lo}, {hi}]"
                )));
            }
            if lo < min - LIMIT_TOLERANCE || hi > max + LIMIT_TOLERANCE {
                return Err(invalid(format!(
                    "the range of {name} [{lo}, {hi}] leaves the joint limits [{min}, {max}]: the robot cannot reach it"
                )));
            }
        }
        Ok(())
    }

    /// `count` configurations drawn uniformly in the box with `seed`
    /// (ChaCha8), a closed loop's drawn again where it cannot close,
    /// labelled `what sample k`.
    ///
    /// # Errors
    /// As [`JointBox::check`]; [`Error::InvalidParameter`] when a closed
    /// loop rarely closes in the box.
    pub fn sample(
        &self,
        model: &Model,
        count: usize,
        seed: u64,
        what: &str,
    ) -> Result<Vec<Located<Vec<f64>>>> {
        use rand::{Rng, SeedableRng};
        self.check(model, what)?;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut data = Data::new(model);
        let xi = model.nominal_params();
        let mut drawn = Vec::with_capacity(count);
        let mut tries = 0usize;
        while drawn.len() < count && tries < 50 * count.max(1) {
            tries += 1;
            let q: Vec<f64> = self
                .ranges
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..hi))
                .collect();
            if model.is_serial() || forward_pose(model, &mut data, &q, xi).is_ok() {
                drawn.push(Located {
                    value: q,
                    origin: format!("{what} sample {}", drawn.len() + 1),
                });
            }
        }
        if drawn.len() < count {
            return Err(Error::InvalidParameter {
                parameter: what.to_string(),
                message: format!(
                    "only {} of {count} configurations of the box close the robot's loops",
                    drawn.len()
                ),
            });
        }
        Ok(drawn)
    }
}

/// Tolerance on the joint limits (rad or m): rounding in a file.
const LIMIT_TOLERANCE: f64 = 1e-9;

/// Where configurations come from: given ones (a file), or a joint box
/// sampled with a seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum PoseSource {
    /// Configurations read from a file (or given), each with its origin.
    Configurations(Vec<Located<Vec<f64>>>),
    /// `count` configurations drawn uniformly in a box with `seed`.
    Box {
        /// The box.
        joint_box: JointBox,
        /// Number of configurations (>= 1).
        count: usize,
        /// Seed of the draw.
        seed: u64,
    },
}

impl PoseSource {
    /// The configurations, checked to be reachable: the robot's number of
    /// actuated coordinates, finite, inside the joint limits, a closed
    /// loop closing; `what` names the source in errors.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for an empty source or box;
    /// [`Error::InvalidData`] naming the row the robot cannot reach.
    pub fn configurations(&self, model: &Model, what: &str) -> Result<Vec<Located<Vec<f64>>>> {
        let rows = match self {
            Self::Configurations(rows) => rows.clone(),
            Self::Box {
                joint_box,
                count,
                seed,
            } => joint_box.sample(model, *count, *seed, what)?,
        };
        if rows.is_empty() {
            return Err(Error::InvalidParameter {
                parameter: what.to_string(),
                message: "no configurations".into(),
            });
        }
        let mut data = Data::new(model);
        for row in &rows {
            reachable(model, &mut data, row)?;
        }
        Ok(rows)
    }
}

/// Checks that the robot reaches the configuration `row`.
fn reachable(model: &Model, data: &mut Data, row: &Located<Vec<f64>>) -> Result<()> {
    let unreachable = |message: String| Error::InvalidData {
        origin: row.origin.clone(),
        message,
    };
    let q = &row.value;
    if q.len() != model.n_actuated() {
        return Err(unreachable(format!(
            "{} coordinates for the {} actuated coordinates of '{}'",
            q.len(),
            model.n_actuated(),
            model.name()
        )));
    }
    for ((v, &(lo, hi)), name) in q
        .iter()
        .zip(model.actuated_limits())
        .zip(model.actuated_names())
    {
        if !(v.is_finite() && *v >= lo - LIMIT_TOLERANCE && *v <= hi + LIMIT_TOLERANCE) {
            return Err(unreachable(format!(
                "{name} = {v} outside the joint limits [{lo}, {hi}]: the robot cannot reach it"
            )));
        }
    }
    forward_pose(model, data, q, model.nominal_params())
        .map(|_| ())
        .map_err(|source| Error::KinematicsAt {
            origin: row.origin.clone(),
            source,
        })
}

/// Everything a plan needs besides the robot.
#[derive(Debug, Clone)]
pub struct PlanConfig {
    /// The model to identify, as for `calibrate` (the plan measures what
    /// the instrument measures and weights it by the instrument's noise:
    /// its `use_orientation` and `weighting` are overridden).
    pub options: CalibrationOptions,
    /// The instrument (positions or full poses, its noise).
    pub instrument: Instrument,
    /// The candidate poses the cell allows.
    pub candidates: PoseSource,
    /// The region where accuracy matters.
    pub region: PoseSource,
    /// Several targets per pose (reflectors on a tool, markers on the
    /// hands of a two-armed robot), as a targets description gives them
    /// ([`calib::read_targets`]); `None`: one target, at the TCP or at
    /// [`CalibrationOptions::target_value`]. Each target's offset is
    /// identified or kept as its description says.
    pub targets: Option<Vec<calib::Target>>,
    /// An earlier calibration of the same robot ([`prior`]): its chosen
    /// groups of unknowns are identified, its residual scatter is the
    /// noise floor where larger than the instrument's, its split-half
    /// inflation raises the identification part of every bound, and its
    /// extrapolation growth (when it has one) widens the bounds of region
    /// points outside the planned poses' ranges. `None`: the instrument's
    /// noise alone, the model as `options` says.
    pub prior: Option<Prior>,
    /// Number of poses to plan (`None`: the knee of the curve).
    pub count: Option<usize>,
    /// Largest number of poses on the curve (`None`: the larger of the
    /// count asked and [`DEFAULT_CURVE_POSES`], at most the candidates).
    pub max_poses: Option<usize>,
    /// The knee is the smallest count whose mean bound is within this
    /// fraction of the mean bound of the largest count on the curve
    /// (default 0.05; range (0, 1)).
    pub knee_tolerance: f64,
}

/// Default largest number of poses on the curve.
pub const DEFAULT_CURVE_POSES: usize = 100;

impl PlanConfig {
    /// A plan of `candidates` for `region` with `options` and an
    /// instrument measuring positions with `noise_mm` per axis (set
    /// [`Instrument::orientation_noise_deg`] for full poses); the count at
    /// the knee.
    pub fn new(
        options: CalibrationOptions,
        noise_mm: [f64; 3],
        candidates: PoseSource,
        region: PoseSource,
    ) -> Self {
        Self {
            options,
            instrument: Instrument::positions(noise_mm),
            candidates,
            region,
            targets: None,
            prior: None,
            count: None,
            max_poses: None,
            knee_tolerance: 0.05,
        }
    }

    /// The largest count on the curve for `n_candidates` candidates (those
    /// `sight` kept).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`]: a count of zero or above the candidates.
    fn curve_end(&self, n_candidates: usize, sight: &SightFilter) -> Result<usize> {
        let seen = if sight.left_out() > 0 {
            format!(" in the instrument's sight ({})", sight.describe())
        } else {
            String::new()
        };
        let too_many = |name: &str, n: usize| Error::InvalidParameter {
            parameter: name.to_string(),
            message: format!("{n} poses asked for, but only {n_candidates} candidates{seen}"),
        };
        for (name, n) in [("count", self.count), ("max_poses", self.max_poses)] {
            match n {
                Some(0) => {
                    return Err(Error::InvalidParameter {
                        parameter: name.into(),
                        message: "must be >= 1".into(),
                    });
                }
                Some(n) if n > n_candidates => return Err(too_many(name, n)),
                _ => {}
            }
        }
        if !(self.knee_tolerance > 0.0 && self.knee_tolerance < 1.0) {
            return Err(Error::InvalidParameter {
                parameter: "knee_tolerance".into(),
                message: format!("must be in (0, 1), found {}", self.knee_tolerance),
            });
        }
        let end = self
            .max_poses
            .unwrap_or_else(|| self.count.unwrap_or(0).max(DEFAULT_CURVE_POSES))
            .min(n_candidates);
        Ok(end.max(self.count.unwrap_or(0)))
    }
}

/// Predicted accuracy over the region: statistics of the 95 % bound.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RegionAccuracy {
    /// Mean of the 95 % bounds over the region points (mm).
    pub mean_bound_95_mm: f64,
    /// 95th percentile (nearest rank) of the bounds (mm).
    pub p95_bound_95_mm: f64,
    /// Largest bound (mm).
    pub max_bound_95_mm: f64,
    /// The mean error norm over the region the bounds imply, each error
    /// taken as isotropic Gaussian: `sqrt(8 / pi) sigma` per point with
    /// `sigma = bound / sqrt(chi2_3(0.95))` (mm); what the achieved mean
    /// error of a validation over the region is compared with.
    pub predicted_mean_error_mm: f64,
}

impl RegionAccuracy {
    /// The statistics of `bounds_mm` (mm; empty gives zeros).
    pub fn of(bounds_mm: &[f64]) -> Self {
        let mut sorted = bounds_mm.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let rank = ((0.95 * n as f64).ceil() as usize).clamp(1, n.max(1)) - 1;
        let mean = sorted.iter().sum::<f64>() / n.max(1) as f64;
        Self {
            mean_bound_95_mm: mean,
            predicted_mean_error_mm: mean * (8.0 / std::f64::consts::PI).sqrt()
                / calib::CHI2_3_95.sqrt(),
            p95_bound_95_mm: sorted.get(rank).copied().unwrap_or(0.0),
            max_bound_95_mm: sorted.last().copied().unwrap_or(0.0),
        }
    }
}

/// The predicted accuracy over the region of one target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetAccuracy {
    /// The target's name (`tcp` for the one target of a plan without a
    /// targets description).
    pub target: String,
    /// Its predicted accuracy over the region points.
    pub accuracy: RegionAccuracy,
}

/// The accuracy over the region of every target and over all, from the
/// bounds (mm) of the region points, each with the index of its target in
/// `targets`.
fn accuracy_per_target(
    targets: &[calib::Target],
    bounds_mm: &[(usize, f64)],
) -> (RegionAccuracy, Vec<TargetAccuracy>) {
    let per_target = targets
        .iter()
        .enumerate()
        .map(|(t, target)| {
            let own: Vec<f64> = bounds_mm
                .iter()
                .filter(|(i, _)| *i == t)
                .map(|(_, b)| *b)
                .collect();
            TargetAccuracy {
                target: target.name.clone(),
                accuracy: RegionAccuracy::of(&own),
            }
        })
        .collect();
    let all: Vec<f64> = bounds_mm.iter().map(|(_, b)| *b).collect();
    (RegionAccuracy::of(&all), per_target)
}

/// One point of the accuracy-versus-poses curve: the greedy campaign of
/// `poses` poses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Number of poses.
    pub poses: usize,
    /// Predicted accuracy over the region, every target's bounds together.
    pub accuracy: RegionAccuracy,
    /// Predicted accuracy over the region of each target.
    #[serde(default)]
    pub per_target: Vec<TargetAccuracy>,
}

/// What a campaign of given poses is predicted to give, by `calibrate`'s
/// own machinery ([`predict_campaign`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignPrediction {
    /// Predicted accuracy over the region, every target's bounds together.
    pub accuracy: RegionAccuracy,
    /// Predicted accuracy over the region of each target.
    #[serde(default)]
    pub per_target: Vec<TargetAccuracy>,
    /// The 95 % bound at every region point and target
    /// ([`calib::AccuracyMap`], point-major, its scatter the instrument's
    /// noise; region points outside the planned poses' joint ranges are
    /// flagged).
    pub map: AccuracyMap,
    /// What the campaign cannot determine, in `calibrate`'s words
    /// ([`Calibration::identifiability_notes`]).
    pub identifiability_notes: Vec<String>,
    /// Unknowns exactly dependent on others with these poses.
    pub non_identifiable: Vec<String>,
    /// Unknowns the poses see too weakly for the noise.
    pub poorly_identifiable: Vec<String>,
    /// What the identified unknowns stand for (`calibrate`'s lines).
    pub combinations: Vec<String>,
    /// Number of unknowns the campaign identifies.
    pub rank: usize,
}

/// A campaign plan: the poses, the curve, the knee and the prediction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CampaignPlan {
    /// The robot's name.
    pub robot: String,
    /// `geometric` or `elasto-geometric`.
    pub model: String,
    /// The selection criterion, in words.
    pub criterion: String,
    /// The instrument.
    pub instrument: Instrument,
    /// The targets measured at every pose (one, `tcp`, without a targets
    /// description).
    #[serde(default)]
    pub targets: Vec<calib::Target>,
    /// Number of candidate configurations the instrument sees (a target
    /// at least; those the plan chooses among).
    pub candidates: usize,
    /// Observations of a target at a candidate out of sight because the
    /// target lies outside the instrument's reach box
    /// ([`Sight::reach_box_mm`]; with one target, candidates left out).
    #[serde(default)]
    pub outside_reach_box: usize,
    /// Observations of a target at a candidate out of sight because the
    /// target faces away from the instrument ([`Sight::line_of_sight`]).
    #[serde(default)]
    pub facing_away: usize,
    /// Candidates left out because the instrument sees none of their
    /// targets.
    #[serde(default)]
    pub left_out: usize,
    /// Number of region points.
    pub region_points: usize,
    /// The unknowns the whole pool identifies (the design's columns, the
    /// measurement frame apart).
    pub design_unknowns: Vec<String>,
    /// Predicted accuracy of the greedy campaign of each count, from the
    /// first count whose poses determine every design unknown.
    pub curve: Vec<CurvePoint>,
    /// The knee of the curve: the smallest count within
    /// [`PlanConfig::knee_tolerance`] of the curve's last mean bound.
    pub knee: Option<usize>,
    /// Number of planned poses.
    pub count: usize,
    /// The planned poses (rows of the candidates as given, 0-based, those
    /// out of sight counted), in greedy order as refined by the exchange
    /// passes.
    pub selected: Vec<usize>,
    /// Where each planned pose came from (file and line, or sample).
    pub origins: Vec<String>,
    /// The planned configurations (rad or m).
    pub configurations: Vec<Vec<f64>>,
    /// Number of exchanges the passes made.
    pub exchanges: usize,
    /// The prediction for the planned poses.
    pub prediction: CampaignPrediction,
    /// How the plan used an earlier calibration of the robot
    /// ([`PlanConfig::prior`]; absent without one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorUse>,
}

/// Plans a campaign (module docs).
///
/// # Errors
/// Named errors before any work: the instrument's noise (zero, negative,
/// NaN) or sight (an empty reach box, an angle outside (0, 180] deg), an
/// empty box or one outside the joint limits, a candidate or region
/// configuration the robot cannot reach (by its row), no candidate in the
/// instrument's sight, more poses than candidates it sees; then the identification's errors, and a pool that
/// cannot determine the unknowns with all its poses.
pub fn plan_campaign(model: &Model, config: &PlanConfig) -> Result<CampaignPlan> {
    config.instrument.check()?;
    let prior = config.prior.as_ref();
    if let Some(prior) = prior {
        prior.check(model)?;
    }
    let instrument = with_floor(&config.instrument, prior);
    let offered = config.candidates.configurations(model, "candidates")?;
    let region = config.region.configurations(model, "region")?;
    let base = prior.map_or_else(
        || config.options.clone(),
        |p| p.options(model, &config.options),
    );
    let options = plan_options(&base, &instrument);
    let targets = planned_targets(&options, config.targets.as_deref());
    let offered_q: Vec<Vec<f64>> = offered.iter().map(|c| c.value.clone()).collect();
    let sight = config
        .instrument
        .sight
        .filter(&nominal_target_poses(model, &targets, &offered_q)?)?;
    let candidates: Vec<&Located<Vec<f64>>> = sight.kept.iter().map(|&k| &offered[k]).collect();
    let end = config.curve_end(candidates.len(), &sight)?;
    let pool_q: Vec<Vec<f64>> = candidates.iter().map(|c| c.value.clone()).collect();
    let region_q: Vec<Vec<f64>> = region.iter().map(|c| c.value.clone()).collect();
    let (design, design_unknowns) =
        pool_design(model, &options, &instrument, &targets, &pool_q, &region_q)?;
    let order = design.greedy(end).ok_or_else(|| Error::InvalidParameter {
        parameter: "candidates".into(),
        message: "the greedy selection's information is not positive definite".into(),
    })?;
    let inflation = prior.map_or(1.0, Prior::inflation);
    let curve = curve_of(
        &design,
        &order,
        (instrument.scatter_variance(), inflation),
        &targets,
    );
    let knee = knee_of(&curve, config.knee_tolerance);
    let count = config.count.or(knee).ok_or_else(|| Error::InvalidParameter {
        parameter: "candidates".into(),
        message: format!(
            "{end} poses of the {} candidates do not determine the {} unknowns the pool identifies: no curve, no knee (ask for more poses, or fix parameters)",
            candidates.len(),
            design_unknowns.len()
        ),
    })?;
    let mut selected = order[..count].to_vec();
    let exchanges = design.exchange(&mut selected);
    let configurations: Vec<Vec<f64>> = selected.iter().map(|&k| pool_q[k].clone()).collect();
    let prediction = predict_campaign(
        model,
        &options,
        &config.instrument,
        config.targets.as_deref(),
        (&configurations, &region_q),
        prior,
    )?;
    Ok(CampaignPlan {
        robot: model.name().to_string(),
        model: model_name(&options).into(),
        criterion: "I-optimal: greedy then exchange on the mean predicted position variance over the region, summed over the targets".into(),
        instrument: config.instrument.clone(),
        targets,
        candidates: candidates.len(),
        outside_reach_box: sight.outside_box,
        facing_away: sight.facing_away,
        left_out: sight.left_out(),
        region_points: region.len(),
        design_unknowns,
        curve,
        knee,
        count,
        origins: selected.iter().map(|&k| candidates[k].origin.clone()).collect(),
        selected: selected.iter().map(|&k| sight.kept[k]).collect(),
        configurations,
        exchanges,
        prediction,
        prior: prior.map(|p| prior_use(p, &config.instrument, &instrument)),
    })
}

/// `instrument` with its noise raised, axis by axis, to `prior`'s residual
/// scatter where that is larger ([`Prior::floor`]).
fn with_floor(instrument: &Instrument, prior: Option<&Prior>) -> Instrument {
    let mut floored = instrument.clone();
    if let Some(prior) = prior {
        floored.noise_mm = prior.floor(instrument.noise_mm).0;
    }
    floored
}

/// How the plan used `prior`: the floor of `floored` against the stated
/// `instrument`'s noise, the inflation, the extrapolation.
fn prior_use(prior: &Prior, instrument: &Instrument, floored: &Instrument) -> PriorUse {
    let floor_source = if floored.noise_mm == instrument.noise_mm {
        "the instrument's noise (at least the prior's residual scatter)"
    } else {
        "the prior's residual scatter (above the instrument's noise)"
    };
    PriorUse {
        prior: prior.clone(),
        floor_mm: floored.noise_mm,
        floor_source: floor_source.into(),
        inflation: prior.inflation(),
        extrapolation: prior.extrapolation.is_some(),
    }
}

/// The predicted accuracy over the region of every prefix of the greedy
/// `order` whose information is non-singular, `s2` the scatter's variance
/// per axis (m^2), every identification variance raised by `inflation`
/// squared (1: none); the design's region rows point-major over `targets`.
fn curve_of(
    design: &Design,
    order: &[usize],
    (s2, inflation): (f64, f64),
    targets: &[calib::Target],
) -> Vec<CurvePoint> {
    (1..=order.len())
        .filter_map(|n| {
            let variances = design.region_variances(&order[..n])?;
            let bounds: Vec<(usize, f64)> = variances
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    let v = v * inflation * inflation;
                    (i % targets.len(), calib::bound_95(v, s2) * 1e3)
                })
                .collect();
            let (accuracy, per_target) = accuracy_per_target(targets, &bounds);
            Some(CurvePoint {
                poses: n,
                accuracy,
                per_target,
            })
        })
        .collect()
}

/// `geometric` or `elasto-geometric`.
fn model_name(options: &CalibrationOptions) -> &'static str {
    if options.gravity.is_some() {
        "elasto-geometric"
    } else {
        "geometric"
    }
}

/// The calibration options of a plan: `options` measuring what the
/// instrument measures (positions, or full poses), weighted by its noise
/// (absolute weights), without cancellation.
fn plan_options(options: &CalibrationOptions, instrument: &Instrument) -> CalibrationOptions {
    CalibrationOptions {
        use_orientation: Some(instrument.measures_orientation()),
        weighting: calib::Weighting::FromFile,
        cancel: None,
        ..options.clone()
    }
}

/// The smallest count of `curve` whose mean bound is within `tolerance` of
/// the last one's.
fn knee_of(curve: &[CurvePoint], tolerance: f64) -> Option<usize> {
    let last = curve.last()?.accuracy.mean_bound_95_mm;
    curve
        .iter()
        .find(|p| p.accuracy.mean_bound_95_mm <= (1.0 + tolerance) * last)
        .map(|p| p.poses)
}

/// The targets of a plan: those of a targets description, else one
/// target at the options' starting or fixed target
/// ([`CalibrationOptions::target_value`], e.g. a probe offset), else at the
/// TCP.
fn planned_targets(
    options: &CalibrationOptions,
    targets: Option<&[calib::Target]>,
) -> Vec<calib::Target> {
    if let Some(targets) = targets {
        return targets.to_vec();
    }
    let x_tcp_target = options.target_value.unwrap_or_else(Isometry3::identity);
    let mut target = calib::Target::new(
        calib::TCP_TARGET,
        calib::TCP_FRAME,
        x_tcp_target.translation.vector,
    );
    target.rotation = x_tcp_target.rotation;
    vec![target]
}

/// The pose `x_base_target` of every target at every configuration, the
/// nominal robot rigid: one entry per configuration, one per target.
///
/// # Errors
/// A target on a frame the robot does not have (named, with the robot's
/// frames); a configuration where the model fails.
fn nominal_target_poses(
    model: &Model,
    targets: &[calib::Target],
    configurations: &[Vec<f64>],
) -> Result<Vec<Vec<Isometry3<f64>>>> {
    let poses = configurations
        .iter()
        .map(|q| {
            TargetPose::new(
                None,
                q.clone(),
                vec![Some(TargetObservation::new(Vector3::zeros())); targets.len()],
            )
        })
        .collect();
    let set = MeasurementSet::from_poses("targets", targets.to_vec(), poses)?;
    Ok(calib::start::target_poses(
        model,
        &set,
        model.nominal_params(),
    )?)
}

/// The measurements the nominal robot would give at `configurations`: the
/// position of every target the instrument sees ([`Sight::sees`]) in the
/// robot's base frame, and its orientation when the instrument measures
/// them, with the instrument's noise as their standard deviations (no
/// noise added), labelled `plan-k`; the targets' nominal offsets are the
/// set's.
///
/// # Errors
/// A target on a frame the robot does not have; a configuration where
/// the model fails; a configuration where the instrument sees no target,
/// a target it sees at none (the set's checks).
pub fn synthetic_set(
    model: &Model,
    configurations: &[Vec<f64>],
    instrument: &Instrument,
    targets: &[calib::Target],
) -> Result<MeasurementSet> {
    let std = Vector3::from(instrument.noise_mm) * 1e-3;
    let orientation_std = instrument
        .orientation_noise_deg
        .map(|deg| Vector3::from(deg).map(f64::to_radians));
    let x_base_targets = nominal_target_poses(model, targets, configurations)?;
    let poses = configurations
        .iter()
        .zip(x_base_targets)
        .enumerate()
        .map(|(k, (q, xs))| TargetPose {
            pose_id: Some(format!("plan-{}", k + 1)),
            q: q.clone(),
            observations: xs
                .iter()
                .map(|x| {
                    instrument
                        .sight
                        .sees(x)
                        .is_none()
                        .then(|| TargetObservation {
                            position: x.translation.vector,
                            orientation: orientation_std.map(|_| x.rotation.scaled_axis()),
                            position_std: Some(std),
                            orientation_std,
                        })
                })
                .collect(),
            wrench: None,
            temperature_c: None,
        })
        .collect();
    Ok(MeasurementSet::from_poses(
        "planned poses",
        targets.to_vec(),
        poses,
    )?)
}

/// The calibration of `configurations` on their [`synthetic_set`].
fn synthetic_calibration(
    model: &Model,
    options: &CalibrationOptions,
    instrument: &Instrument,
    targets: &[calib::Target],
    configurations: &[Vec<f64>],
) -> Result<(MeasurementSet, Calibration)> {
    let set = synthetic_set(model, configurations, instrument, targets)?;
    let calibration =
        calib::calibrate(model, &set, options).map_err(|source| Error::CalibrationStep {
            step: "planning: identification of the planned poses",
            source,
        })?;
    Ok((set, calibration))
}

/// The design of the pool: the unknowns a calibration of every candidate
/// identifies (the measurement frame's apart) and the candidates' weighted
/// rows (every target the instrument sees at a candidate, stacked) and the
/// region's position rows (one block per point and target, point-major)
/// over them.
fn pool_design(
    model: &Model,
    options: &CalibrationOptions,
    instrument: &Instrument,
    targets: &[calib::Target],
    pool: &[Vec<f64>],
    region: &[Vec<f64>],
) -> Result<(Design, Vec<String>)> {
    let pool_options = CalibrationOptions {
        spread_reference: false,
        ..options.clone()
    };
    let (pool_set, calibration) =
        synthetic_calibration(model, &pool_options, instrument, targets, pool)?;
    let columns: Vec<usize> = calibration
        .unknowns
        .iter()
        .enumerate()
        .filter(|(_, u)| {
            u.status == calib::UnknownStatus::Identified && !u.name.starts_with("frame_")
        })
        .map(|(j, _)| j)
        .collect();
    let blocks = jacobian_rows(
        model,
        &calibration,
        &pool_set,
        &columns,
        &instrument.row_weights(),
    )?;
    let candidates = stacked_by_pose(&pool_set, blocks);
    let positions = Instrument::positions(instrument.noise_mm);
    let region_set = synthetic_set(model, region, &positions, targets)?;
    let region_rows = jacobian_rows(model, &calibration, &region_set, &columns, &[1.0; 3])?;
    let names = columns
        .iter()
        .map(|&j| calibration.unknowns[j].name.clone())
        .collect();
    Ok((Design::new(candidates, region_rows), names))
}

/// The observation blocks of `set` (in its order: pose-major, the targets
/// seen at each pose) stacked into one block per pose.
fn stacked_by_pose(set: &MeasurementSet, blocks: Vec<DMatrix<f64>>) -> Vec<DMatrix<f64>> {
    let mut blocks = blocks.into_iter();
    set.poses()
        .iter()
        .map(|pose| {
            let own: Vec<DMatrix<f64>> = blocks
                .by_ref()
                .take(pose.observations.iter().flatten().count())
                .collect();
            let rows = own.iter().map(DMatrix::nrows).sum();
            let cols = own.first().map_or(0, DMatrix::ncols);
            let mut stacked = DMatrix::<f64>::zeros(rows, cols);
            let mut r = 0;
            for block in own {
                stacked.rows_mut(r, block.nrows()).copy_from(&block);
                r += block.nrows();
            }
            stacked
        })
        .collect()
}

/// The rows of the identification's Jacobian at the observations of `set`
/// over the unknowns `columns`, one block per observation (pose-major),
/// row i times `weights[i]`: 3 position rows, and 3 orientation rows when
/// `weights` has 6 (the set then carries orientations).
fn jacobian_rows(
    model: &Model,
    calibration: &Calibration,
    set: &MeasurementSet,
    columns: &[usize],
    weights: &[f64],
) -> Result<Vec<DMatrix<f64>>> {
    use crate::optim::{Jacobian as _, Residuals as _};
    let (problem, x) = calibration.error_model_at(model, set, weights.len() == 6)?;
    let mut jac = faer::Mat::<f64>::zeros(problem.n_residuals(), x.len());
    problem
        .jacobian(&x, jac.as_mut())
        .map_err(|e| Error::InvalidData {
            origin: set.source.clone(),
            message: e.to_string(),
        })?;
    Ok((0..set.n_observations())
        .map(|b| {
            let rows = problem.block_rows(b);
            DMatrix::from_fn(rows.len(), columns.len(), |i, c| {
                jac[(rows.start + i, columns[c])] * weights[i]
            })
        })
        .collect())
}

/// What a campaign measuring `targets` (`None`: one target, as
/// [`PlanConfig::targets`]) at `configurations` with `instrument` is
/// predicted to give over `region` (rad or m) when `options`' model is
/// identified: `calibrate` on the measurements the nominal robot would
/// give ([`synthetic_set`]: the targets the instrument sees), its
/// identifiability notes and combinations, and its accuracy map over the
/// region, every target at every point, with the instrument's noise as
/// the scatter (the map's bounds recomputed with it; the synthetic
/// residuals are zero). With a `prior` ([`PlanConfig::prior`]; its groups
/// of unknowns already in `options`) the noise is floored at its residual
/// scatter, the identification part raised by its split-half inflation,
/// and its growth outside the training ranges added at the region points
/// outside the planned poses' ranges; the map's
/// [`calib::PoseAccuracy::parts`] say which part of each bound comes
/// from where.
///
/// # Errors
/// The identification's errors (too few poses for the unknowns, a model
/// failure at a pose); a target on a frame the robot does not have; a
/// configuration where the instrument sees no target.
pub fn predict_campaign(
    model: &Model,
    options: &CalibrationOptions,
    instrument: &Instrument,
    targets: Option<&[calib::Target]>,
    (configurations, region): (&[Vec<f64>], &[Vec<f64>]),
    prior: Option<&Prior>,
) -> Result<CampaignPrediction> {
    let instrument = &with_floor(instrument, prior);
    let options = plan_options(options, instrument);
    let targets = planned_targets(&options, targets);
    let (_, calibration) =
        synthetic_calibration(model, &options, instrument, &targets, configurations)?;
    let mut map = calibration
        .predicted_accuracy_with_frame(model, region, None, instrument.frame)
        .map_err(|source| Error::CalibrationStep {
            step: "planning: predicted accuracy over the region",
            source,
        })?;
    let s2 = instrument.scatter_variance();
    let inflation = prior.map_or(1.0, Prior::inflation);
    for p in &mut map.poses {
        p.model_uncertainty_mm *= inflation;
        let trace = (p.model_uncertainty_mm * 1e-3).powi(2);
        p.parts = calib::BoundParts {
            scatter_mm: calib::bound_95(0.0, s2) * 1e3,
            parameters_mm: calib::bound_95(trace, 0.0) * 1e3,
            extrapolation_mm: 0.0,
        };
        p.bound_95_mm = calib::bound_95(trace, s2) * 1e3;
    }
    map.residual_scatter_mm = s2.sqrt() * 1e3;
    map.inflation = inflation;
    if let Some(growth) = prior.and_then(|p| p.extrapolation.as_ref()) {
        // The prior's growth per unit of distance, outside the planned
        // poses' ranges (not the prior's own).
        let planned = calib::ExtrapolationModel {
            ranges: calibration.actuated_ranges.clone(),
            ..growth.clone()
        };
        map = map.with_extrapolation(&planned);
    }
    let bounds: Vec<(usize, f64)> = map
        .poses
        .iter()
        .map(|p| {
            let t = p
                .target
                .as_ref()
                .and_then(|name| targets.iter().position(|t| &t.name == name))
                .unwrap_or(0);
            (t, p.bound_95_mm)
        })
        .collect();
    let (accuracy, per_target) = accuracy_per_target(&targets, &bounds);
    map.mean_bound_95_mm = accuracy.mean_bound_95_mm;
    let strings = |v: Vec<&str>| v.into_iter().map(String::from).collect();
    Ok(CampaignPrediction {
        accuracy,
        per_target,
        identifiability_notes: calibration.identifiability_notes(),
        non_identifiable: strings(calibration.non_identifiable()),
        poorly_identifiable: strings(calibration.poorly_identifiable()),
        combinations: calibration.combination_lines.clone(),
        rank: calibration.rank(),
        map,
    })
}

impl CampaignPlan {
    /// The human-readable summary (what `flexcal plan` prints): the
    /// campaign, the curve (every count up to 10, then every 5th and the
    /// knee and chosen counts), the knee, the prediction and what the
    /// campaign cannot determine; lines ended by newlines.
    pub fn summary_text(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "plan for {} ({} model): {} poses of {} candidates, region of {} points, {}, {} design unknowns",
            self.robot,
            self.model,
            self.count,
            self.candidates,
            self.region_points,
            self.instrument.describe(),
            self.design_unknowns.len()
        );
        if self.targets.len() > 1 {
            let names: Vec<&str> = self.targets.iter().map(|t| t.name.as_str()).collect();
            let _ = writeln!(out, "targets: {}", names.join(", "));
        }
        let out_of_sight = self.outside_reach_box + self.facing_away;
        if self.targets.len() == 1 && out_of_sight > 0 {
            let _ = writeln!(
                out,
                "left out {out_of_sight} candidates the instrument cannot see: {} outside the reach box, {} facing away from it",
                self.outside_reach_box, self.facing_away
            );
        } else if out_of_sight > 0 {
            let _ = writeln!(
                out,
                "the instrument cannot see {out_of_sight} targets at candidates: {} outside the reach box, {} facing away from it; left out {} candidates where it sees no target",
                self.outside_reach_box, self.facing_away, self.left_out
            );
        }
        let _ = writeln!(
            out,
            "criterion: {} ({} exchanges)",
            self.criterion, self.exchanges
        );
        let _ = writeln!(
            out,
            "predicted 95 % bound over the region (mm), greedy campaign of each size:"
        );
        let _ = writeln!(
            out,
            "{:>6} {:>10} {:>10} {:>10}",
            "poses", "mean", "p95", "max"
        );
        for p in &self.curve {
            let shown = p.poses <= 10
                || p.poses % 5 == 0
                || Some(p.poses) == self.knee
                || p.poses == self.count
                || Some(p) == self.curve.last();
            if shown {
                let a = p.accuracy;
                let mark = if Some(p.poses) == self.knee {
                    "  <- knee"
                } else {
                    ""
                };
                let _ = writeln!(
                    out,
                    "{:>6} {:>10.4} {:>10.4} {:>10.4}{mark}",
                    p.poses, a.mean_bound_95_mm, a.p95_bound_95_mm, a.max_bound_95_mm
                );
            }
        }
        match self.knee {
            Some(k) => {
                let _ = writeln!(
                    out,
                    "knee: {k} poses (more poses improve the mean bound by less than the tolerance up to the curve's end)"
                );
            }
            None => {
                let _ = writeln!(out, "knee: none (the curve is empty)");
            }
        }
        let a = self.prediction.accuracy;
        let _ = writeln!(
            out,
            "planned {} poses: rank {}, predicted 95 % bound mean {:.4} mm, p95 {:.4} mm, max {:.4} mm; {} region points outside the planned poses' joint ranges",
            self.count,
            self.prediction.rank,
            a.mean_bound_95_mm,
            a.p95_bound_95_mm,
            a.max_bound_95_mm,
            self.prediction.map.extrapolated_poses
        );
        if self.targets.len() > 1 {
            for t in &self.prediction.per_target {
                let a = t.accuracy;
                let _ = writeln!(
                    out,
                    "target {}: predicted 95 % bound mean {:.4} mm, p95 {:.4} mm, max {:.4} mm",
                    t.target, a.mean_bound_95_mm, a.p95_bound_95_mm, a.max_bound_95_mm
                );
            }
        }
        if let Some(prior) = &self.prior {
            let _ = writeln!(out, "{}", prior.describe());
            let _ = writeln!(out, "{}", parts_line(&self.prediction.map));
        }
        for note in &self.prediction.identifiability_notes {
            let _ = writeln!(out, "note: {note}");
        }
        out
    }
}

/// `bound parts over the region (mean of each, mm): ...`: the mean of
/// every part of the region's bounds ([`calib::BoundParts`]) and the
/// number of points each part dominates.
fn parts_line(map: &AccuracyMap) -> String {
    let n = map.poses.len().max(1) as f64;
    let mean =
        |f: fn(&calib::BoundParts) -> f64| map.poses.iter().map(|p| f(&p.parts)).sum::<f64>() / n;
    let dominated = |part: &str| {
        map.poses
            .iter()
            .filter(|p| p.parts.dominant() == part)
            .count()
    };
    format!(
        "bound parts over the region (mean, mm): scatter {:.4}, parameters {:.4}, extrapolation {:.4}; dominant at {} / {} / {} points",
        mean(|p| p.scatter_mm),
        mean(|p| p.parameters_mm),
        mean(|p| p.extrapolation_mm),
        dominated("scatter"),
        dominated("parameters"),
        dominated("extrapolation")
    )
}

#[cfg(test)]
mod prior_tests;
#[cfg(test)]
mod target_tests;
#[cfg(test)]
mod tests;

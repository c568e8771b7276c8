//! Model selection from the training data alone: which groups of unknowns
//! (joint offsets, axis tilts, joint compliances, the payload, the
//! non-linear joint law, cyclic joint errors, lateral joint compliances) are
//! worth identifying.
//!
//! The paper removes "the columns of J of parameters with little influence"
//! (section 2.1.5, before (11)) by hand; the identifiability analysis of
//! [`crate::calibrate`] removes those the poses cannot determine. Neither
//! asks whether a determinable unknown helps predict poses the fit has not
//! seen: a term fitted to what the model leaves on these poses (thermal
//! drift, an unmodelled effect) can make predictions elsewhere worse. Two
//! scores answer it:
//!
//! - **k-fold cross-validation** ([`SelectionMethod::CrossValidation`]):
//!   each fold of poses is predicted by the model identified on the other
//!   folds (the measurement frame as identified with them: same tracker),
//!   and the score is the mean position error over all held-out poses.
//!   Errors of a real robot are correlated between neighbouring poses, so
//!   random folds would leave a neighbour of every held-out pose in the
//!   training part and reward models that interpolate what they should not
//!   generalise. The folds are therefore **clusters in joint space**
//!   ([`FoldScheme::JointClusters`], default): k-means on the actuated
//!   coordinates scaled by their ranges, seeded, so that each fold is a
//!   region of the workspace the others did not visit — what a validation
//!   campaign on other poses asks of the model. Contiguous blocks in
//!   acquisition order ([`FoldScheme::AcquisitionBlocks`]) keep together
//!   poses measured close in time (drift) and, for scanned grids, close in
//!   space; they are the alternative when the file order is meaningful.
//! - **BIC** ([`SelectionMethod::Bic`]): `n ln(2 cost / n) + p ln n` on the
//!   full fit (n residual rows, p identified unknowns, weighted cost): one
//!   fit per candidate instead of k, but it assumes independent errors,
//!   which real campaigns violate (it then favours rich models).
//!
//! The search is backward elimination over the groups: from the model
//! with every group allowed, the group whose removal leaves the best score
//! is removed as long as the score does not get worse by more than its
//! uncertainty (cross-validation: the standard error over the folds of the
//! paired difference, the "one standard error" rule, which prefers the
//! simpler of two models the data cannot tell apart; BIC: by 2, "positive
//! evidence" on Kass and Raftery's scale). Removing the compliances removes
//! the payload, the non-linear law and the lateral compliances with them.
//! Backward, not forward: groups overlap (a
//! cyclic error of the shoulder imitates part of its compliance), and a
//! forward search adds first whatever imitates the largest missing effect,
//! then cannot take it out (a test on a simulated robot shows it). The [`SelectionReport`] lists every
//! candidate scored, with its score, and why the chosen model won.
//!
//! **Interpolation and extrapolation.** The ordinary folds hold out regions
//! inside the training poses' ranges, where every reasonable candidate
//! predicts alike and the simplest wins. A calibrated robot is used beyond
//! them: in joint angles, and in the gravity load, which a campaign may
//! apply from one side only. Candidates are therefore also scored on
//! **extrapolating folds** ([`crate::folds`]): one per joint, holding out
//! the ends of its angle range and of its gravity-torque range. The report
//! gives both scores side by side, and [`SelectOn`] says which the search
//! chooses on: by default ([`SelectOn::Auto`]) the extrapolating ones when
//! the region the robot is to be used in ([`SelectionOptions::region`]: the
//! validation poses, the accuracy map's grid) leaves the training poses'
//! range by the report's extrapolation check, else the ordinary ones.
//! When the extrapolating scores choose, every candidate gets them; when
//! the ordinary ones choose, only the models the search moved through (the
//! model with every group, each model a step took, the chosen one) get
//! them, after the search: they then inform and do not choose, and on a
//! robot with many joints the extrapolating folds (one per joint) would
//! otherwise cost several times the ordinary ones
//! ([`SelectionOptions::every_extrapolation_score`] asks for every
//! candidate's).
//!
//! Measurements of several targets per pose are selected the same way
//! ([`select_model`], [`calibrate_selected`] with either kind of set): the folds
//! are clusters of poses, every target of a pose in the same fold, and a
//! fold's score is the mean position error of its observations.

use flexcal_kinematics::{Model, Quantity};
use serde::{Deserialize, Serialize};

use crate::coverage::CoordinateCoverage;
use crate::error::CalibError;
use crate::folds::{
    EXTRAPOLATION_END_SHARE, ExtrapolationFold, FoldPoses, FoldScheme, extrapolating_folds,
    fold_assignment,
};
use crate::identify::{Calibration, calibrate};
use crate::joint_law::JointLaw;
use crate::measurement::MeasurementSet;
use crate::metrics::ErrorStatistics;
use crate::options::CalibrationOptions;
use crate::unknowns::{UnknownEstimate, UnknownStatus};
use crate::validate::FramePolicy;
use crate::validate::target_position_errors;

/// What model selection needs of a set of measurements: fits, scored on
/// held-out poses.
impl MeasurementSet {
    /// Identifies the candidate `options` on these poses.
    pub(crate) fn fit(
        &self,
        model: &Model,
        options: &CalibrationOptions,
    ) -> Result<Calibration, CalibError> {
        calibrate(model, self, options)
    }

    /// Position errors (m) of each observation of `held_out` predicted by
    /// `fitted`, its measurement frame as identified (same instrument).
    pub(crate) fn held_out_errors(
        model: &Model,
        fitted: &Calibration,
        held_out: &MeasurementSet,
    ) -> Result<Vec<f64>, CalibError> {
        if !held_out.is_one_target() {
            return target_position_errors(model, fitted, held_out);
        }
        let (errors, _) =
            fitted.errors_after(model, held_out, FramePolicy::Fixed(fitted.x_meas_base))?;
        Ok(errors.iter().map(|e| e.position).collect())
    }

    /// Errors of `held_out` (poses of another station) with the nominal
    /// robot and with `fitted`'s, each with the measurement frame fitted
    /// again on `held_out`: (before, after).
    pub(crate) fn held_out_statistics(
        model: &Model,
        fitted: &Calibration,
        held_out: &MeasurementSet,
    ) -> Result<(ErrorStatistics, ErrorStatistics), CalibError> {
        let validation = fitted.validate(model, held_out, false)?;
        Ok((validation.before, validation.after))
    }

    /// The BIC of a fit: three rows per observation, six where the
    /// observation's orientation was fitted (one target or several).
    pub(crate) fn bic(fitted: &Calibration) -> f64 {
        let rows = fitted
            .observation_errors
            .iter()
            .map(|e| if e.orientation_error.is_some() { 6 } else { 3 })
            .sum();
        bic(rows, fitted.solve.cost, &fitted.unknowns)
    }
}

/// Fewest poses for which [`SelectionMethod::CrossValidation`] is the
/// default of [`default_method`]: with the default 5 folds each held-out
/// fold has at least 20 poses (its mean error known to about 20 %), and
/// each training part 80 poses, 240 position equations for the 40-90
/// unknowns of a rich 6-axis model. Below it no selection by default:
/// held-out folds too small to score, and BIC's independence assumption
/// is what a small campaign cannot check (BIC stays available).
pub const MIN_POSES_FOR_CROSS_VALIDATION: usize = 100;

/// A difference of cross-validated scores (m) below which two candidates
/// tie: round-off of noise-free data, far below any instrument's noise.
const ROUND_OFF_SCORE: f64 = 1e-9;

/// How the candidate models are scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SelectionMethod {
    /// k-fold cross-validation over the training poses.
    CrossValidation,
    /// Bayesian information criterion of the full fit.
    Bic,
    /// No selection: every group allowed is identified.
    None,
}

impl std::str::FromStr for SelectionMethod {
    type Err = String;
    /// `cv`, `bic` or `none`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "cv" => Ok(Self::CrossValidation),
            "bic" => Ok(Self::Bic),
            "none" => Ok(Self::None),
            other => Err(format!("`{other}`: expected cv, bic or none")),
        }
    }
}

/// Which cross-validated score the search chooses on (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SelectOn {
    /// The ordinary folds (clusters or blocks inside the training ranges).
    Interpolation,
    /// The extrapolating folds (the ends of each joint's angle and
    /// gravity-torque ranges held out).
    Extrapolation,
    /// The extrapolating folds when [`SelectionOptions::region`] leaves the
    /// training poses' range in some actuated coordinate, else the ordinary
    /// ones (default).
    #[default]
    Auto,
}

impl SelectOn {
    /// Name on the command line and in reports.
    pub fn label(self) -> &'static str {
        match self {
            SelectOn::Interpolation => "interpolation",
            SelectOn::Extrapolation => "extrapolation",
            SelectOn::Auto => "auto",
        }
    }
}

impl std::str::FromStr for SelectOn {
    type Err = String;
    /// `interpolation`, `extrapolation` or `auto`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "interpolation" => Ok(Self::Interpolation),
            "extrapolation" => Ok(Self::Extrapolation),
            "auto" => Ok(Self::Auto),
            other => Err(format!(
                "`{other}`: expected interpolation, extrapolation or auto"
            )),
        }
    }
}

/// A group of unknowns that selection may switch on or off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TermGroup {
    /// Joint offsets (the `theta` parameters).
    JointOffsets,
    /// Hayati tilts of parallel axes (the `beta` parameters).
    AxisTilts,
    /// Joint compliances under gravity (needs a mass table).
    Compliances,
    /// The payload's mass and first moment (`payload_*`), identified with
    /// the compliances; off, the mass table's payload is taken as known.
    /// Removed with the compliances.
    Payload,
    /// The non-linear joint stiffness law ([`crate::joint_law`]).
    JointLaw,
    /// Cyclic joint errors ([`crate::joint_law`]).
    CyclicErrors,
    /// Lateral joint compliances under the gravity moment
    /// ([`crate::gravity`], `lateral_compliance_*`).
    LateralCompliances,
}

impl TermGroup {
    /// Name in reports.
    pub fn label(self) -> &'static str {
        match self {
            TermGroup::JointOffsets => "offsets",
            TermGroup::AxisTilts => "tilts",
            TermGroup::Compliances => "compliances",
            TermGroup::Payload => "payload",
            TermGroup::JointLaw => "joint law",
            TermGroup::CyclicErrors => "cyclic",
            TermGroup::LateralCompliances => "lateral",
        }
    }
}

/// Settings of [`select_model`].
#[derive(Debug, Clone, PartialEq)]
pub struct SelectionOptions {
    /// Scoring method (see [`default_method`]).
    pub method: SelectionMethod,
    /// Number of folds (default 5; `>= 2`).
    pub folds: usize,
    /// Fold construction (default [`FoldScheme::JointClusters`]).
    pub scheme: FoldScheme,
    /// Seed of the k-means start (default 1).
    pub seed: u64,
    /// Groups the search may add (default: every group the options allow:
    /// the law and the compliances only with a mass table, the lateral
    /// compliances only when its [`crate::GravityCompliance::lateral`] is on).
    pub groups: Option<Vec<TermGroup>>,
    /// Which score the search chooses on (default [`SelectOn::Auto`]).
    pub select_on: SelectOn,
    /// Actuated configurations (rad or m, one per pose of use) of the
    /// region the calibrated robot is to be used in: the validation poses,
    /// the accuracy map's grid. Empty when unknown; [`SelectOn::Auto`] then
    /// chooses on the ordinary folds.
    pub region: Vec<Vec<f64>>,
    /// Whether every candidate is scored on the extrapolating folds when
    /// the ordinary scores choose (default `false`: only the models the
    /// search moved through, which costs a fit per extrapolating fold for
    /// a few models instead of every candidate; module docs). When the
    /// extrapolating scores choose, every candidate has them anyway.
    pub every_extrapolation_score: bool,
}

impl Default for SelectionOptions {
    fn default() -> Self {
        Self {
            method: SelectionMethod::CrossValidation,
            folds: 5,
            scheme: FoldScheme::JointClusters,
            seed: 1,
            groups: None,
            select_on: SelectOn::Auto,
            region: Vec::new(),
            every_extrapolation_score: false,
        }
    }
}

/// Cross-validation when the set has at least
/// [`MIN_POSES_FOR_CROSS_VALIDATION`] poses, else none (every group the
/// options allow is identified; the identifiability analysis alone
/// decides, as without selection).
pub fn default_method(set: &MeasurementSet) -> SelectionMethod {
    default_method_for(set.len())
}

/// [`default_method`] for a set of `poses` poses (of one or several
/// targets).
pub fn default_method_for(poses: usize) -> SelectionMethod {
    if poses >= MIN_POSES_FOR_CROSS_VALIDATION {
        SelectionMethod::CrossValidation
    } else {
        SelectionMethod::None
    }
}

/// One candidate model and its scores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateScore {
    /// The optional groups identified.
    pub groups: Vec<TermGroup>,
    /// Cross-validated mean position error over the held-out poses (mm).
    pub cv_mean_error_mm: Option<f64>,
    /// Its standard error, from the spread of the per-fold means (mm).
    pub cv_standard_error_mm: Option<f64>,
    /// Mean held-out position error of each fold (mm).
    pub cv_fold_errors_mm: Vec<f64>,
    /// Mean position error over the poses held out by the extrapolating
    /// folds (mm; cross-validation).
    #[serde(default)]
    pub extrapolation_mean_error_mm: Option<f64>,
    /// Its standard error, from the spread of the per-fold means (mm).
    #[serde(default)]
    pub extrapolation_standard_error_mm: Option<f64>,
    /// Mean held-out position error of each extrapolating fold (mm), in the
    /// order of [`SelectionReport::extrapolation_folds`].
    #[serde(default)]
    pub extrapolation_fold_errors_mm: Vec<f64>,
    /// Why the extrapolating folds could not score it, if they could not.
    #[serde(default)]
    pub extrapolation_failure: Option<String>,
    /// BIC of the full fit (dimensionless), when scored by BIC.
    pub bic: Option<f64>,
    /// Identified unknowns of the full fit (BIC) or the mean over folds (CV).
    pub identified: f64,
    /// Why it could not be scored, if it could not.
    pub failure: Option<String>,
}

impl CandidateScore {
    /// A candidate of `groups` not scored yet.
    fn unscored(groups: Vec<TermGroup>) -> Self {
        Self {
            groups,
            cv_mean_error_mm: None,
            cv_standard_error_mm: None,
            cv_fold_errors_mm: Vec::new(),
            extrapolation_mean_error_mm: None,
            extrapolation_standard_error_mm: None,
            extrapolation_fold_errors_mm: Vec::new(),
            extrapolation_failure: None,
            bic: None,
            identified: 0.0,
            failure: None,
        }
    }

    /// `offsets + tilts + ...`, or `base` for none.
    pub fn label(&self) -> String {
        if self.groups.is_empty() {
            "base".into()
        } else {
            self.groups
                .iter()
                .map(|g| g.label())
                .collect::<Vec<_>>()
                .join(" + ")
        }
    }
}

/// What model selection scored and chose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelectionReport {
    /// The scoring method.
    pub method: SelectionMethod,
    /// Fold construction (cross-validation).
    pub scheme: FoldScheme,
    /// Number of folds (cross-validation).
    pub folds: usize,
    /// Number of poses in each fold (cross-validation).
    pub fold_sizes: Vec<usize>,
    /// Every candidate scored, in the order of the search.
    pub candidates: Vec<CandidateScore>,
    /// The groups of the chosen model.
    pub chosen: Vec<TermGroup>,
    /// Why the chosen model won, one sentence per search step.
    pub reasons: Vec<String>,
    /// What the options asked to choose on.
    #[serde(default)]
    pub select_on: SelectOn,
    /// The score the search chose on: [`SelectOn::Interpolation`] or
    /// [`SelectOn::Extrapolation`].
    #[serde(default = "interpolation")]
    pub chosen_on: SelectOn,
    /// Why that score, in one sentence.
    #[serde(default)]
    pub chosen_on_reason: String,
    /// Share of each range held out at each end by the extrapolating folds
    /// ([`EXTRAPOLATION_END_SHARE`]).
    #[serde(default)]
    pub extrapolation_end_share: f64,
    /// The extrapolating folds, in the order of
    /// [`CandidateScore::extrapolation_fold_errors_mm`].
    #[serde(default)]
    pub extrapolation_folds: Vec<ExtrapolationFold>,
}

/// Serde default of [`SelectionReport::chosen_on`] in reports written
/// before the extrapolating folds.
fn interpolation() -> SelectOn {
    SelectOn::Interpolation
}

impl SelectionReport {
    /// The report as text: one line per candidate, then the reasons.
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![match self.method {
            SelectionMethod::CrossValidation => format!(
                "Model selection by {}-fold cross-validation ({}, folds of {:?} poses), backward over groups of unknowns:",
                self.folds,
                match self.scheme {
                    FoldScheme::JointClusters => "clusters in joint space",
                    FoldScheme::AcquisitionBlocks => "blocks in acquisition order",
                },
                self.fold_sizes
            ),
            SelectionMethod::Bic => {
                "Model selection by BIC, backward over groups of unknowns:".into()
            }
            SelectionMethod::None => "No model selection.".into(),
        }];
        if !self.extrapolation_folds.is_empty() {
            lines.push(format!(
                "Extrapolating folds (the outer {:.0} % of each end of a joint's angle or gravity-torque range held out): {}",
                100.0 * self.extrapolation_end_share,
                self.extrapolation_folds
                    .iter()
                    .map(ExtrapolationFold::label)
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            let every = self.candidates.iter().all(|c| {
                c.failure.is_some()
                    || c.extrapolation_mean_error_mm.is_some()
                    || c.extrapolation_failure.is_some()
            });
            if !every {
                lines.push(
                    "  (the ordinary scores choose: the extrapolating ones are given for the models the search moved through)"
                        .into(),
                );
            }
        }
        for c in &self.candidates {
            let mut score = match (&c.failure, c.cv_mean_error_mm, c.bic) {
                (Some(f), _, _) => format!("not scored: {f}"),
                (None, Some(e), _) => format!(
                    "held-out mean {e:.4} mm +/- {:.4}",
                    c.cv_standard_error_mm.unwrap_or(f64::NAN)
                ),
                (None, None, Some(b)) => format!("BIC {b:.1}"),
                _ => String::new(),
            };
            match (&c.extrapolation_failure, c.extrapolation_mean_error_mm) {
                (Some(f), _) => score.push_str(&format!("; extrapolating: not scored: {f}")),
                (None, Some(e)) => score.push_str(&format!(
                    "; extrapolating {e:.4} mm +/- {:.4}",
                    c.extrapolation_standard_error_mm.unwrap_or(f64::NAN)
                )),
                _ => {}
            }
            lines.push(format!(
                "  {:<48} {score} ({:.0} identified)",
                c.label(),
                c.identified
            ));
        }
        if !self.chosen_on_reason.is_empty() {
            lines.push(format!(
                "  chosen on the {} scores: {}",
                match self.chosen_on {
                    SelectOn::Extrapolation => "extrapolating",
                    _ => "ordinary (interpolating)",
                },
                self.chosen_on_reason
            ));
        }
        lines.extend(self.reasons.iter().map(|r| format!("  {r}")));
        let chosen = CandidateScore::unscored(self.chosen.clone());
        lines.push(format!("  chosen: {}", chosen.label()));
        lines
    }
}

/// A candidate's score, its per-fold means (cross-validation; empty for
/// BIC) and its number of identified unknowns (the mean over the folds).
type Score = (f64, Vec<f64>, f64);

/// The options of the candidate with `groups` on, from `base` (whose
/// `gravity` and `joint_terms` say what is available): the model a
/// selection that chose `groups` identifies ([`SelectionReport::chosen`]),
/// as a later plan of the same robot reads it from the report.
pub fn candidate_options(
    model: &Model,
    base: &CalibrationOptions,
    groups: &[TermGroup],
) -> CalibrationOptions {
    let mut options = base.clone();
    let on = |g: TermGroup| groups.contains(&g);
    for p in model.params() {
        let off = match p.quantity {
            Quantity::Theta => !on(TermGroup::JointOffsets),
            Quantity::Beta => !on(TermGroup::AxisTilts),
            _ => false,
        };
        if off && !options.fixed.contains(&p.name) {
            options.fixed.push(p.name.clone());
        }
    }
    if !on(TermGroup::Compliances) {
        options.gravity = None;
    } else if !on(TermGroup::Payload) {
        // Every identified payload's unknowns, the further payloads' too.
        let names = options
            .gravity
            .as_ref()
            .map(|g| g.payload_unknown_names())
            .unwrap_or_default();
        for name in names {
            if !options.fixed.contains(&name) {
                options.fixed.push(name);
            }
        }
    }
    if let (false, Some(gravity)) = (on(TermGroup::LateralCompliances), &mut options.gravity) {
        gravity.lateral = crate::gravity::LateralCompliance::Off;
    }
    options.joint_terms.law = if on(TermGroup::JointLaw) && options.gravity.is_some() {
        Some(base.joint_terms.law.unwrap_or_default())
    } else {
        None
    };
    options.joint_terms.cyclic = on(TermGroup::CyclicErrors);
    // Fixed names of groups switched off must exist in the candidate.
    let allowed: Vec<String> = {
        let mut names = crate::gravity::GravityCompliance::unknown_names(model);
        names.extend(crate::gravity::lateral_compliance_names(model));
        names.extend(
            crate::joint_law::JointTerms {
                law: Some(JointLaw::default()),
                cyclic: true,
            }
            .unknown_names(model),
        );
        names
    };
    let mut present = options.joint_terms.unknown_names(model);
    if let Some(gravity) = &options.gravity {
        present.extend(gravity.elastic_unknown_names(model));
    }
    options
        .fixed
        .retain(|name| !allowed.contains(name) || present.contains(name));
    options
}

/// The groups a search over `base` may add.
fn available_groups(model: &Model, base: &CalibrationOptions) -> Vec<TermGroup> {
    let has = |q: Quantity| model.params().iter().any(|p| p.quantity == q);
    let mut groups = Vec::new();
    if has(Quantity::Theta) {
        groups.push(TermGroup::JointOffsets);
    }
    if has(Quantity::Beta) {
        groups.push(TermGroup::AxisTilts);
    }
    if let Some(gravity) = &base.gravity {
        groups.push(TermGroup::Compliances);
        // The payload, unless every one of its unknowns is fixed already.
        if crate::gravity::PAYLOAD_PARAMETER_NAMES
            .iter()
            .any(|name| !base.fixed.iter().any(|f| f == name))
        {
            groups.push(TermGroup::Payload);
        }
        groups.push(TermGroup::JointLaw);
        if gravity.lateral != crate::gravity::LateralCompliance::Off {
            groups.push(TermGroup::LateralCompliances);
        }
    }
    if !crate::joint_law::cyclic_joints(model).is_empty() {
        groups.push(TermGroup::CyclicErrors);
    }
    groups
}

/// Whether the unknown `name` belongs to `group`. The compliances take
/// with them the groups that cannot stand without them (the payload, the
/// law, the lateral compliances).
fn in_group(model: &Model, group: TermGroup, name: &str) -> bool {
    let quantity = |q: Quantity| {
        model
            .params()
            .iter()
            .any(|p| p.quantity == q && p.name == name)
    };
    match group {
        TermGroup::JointOffsets => quantity(Quantity::Theta),
        TermGroup::AxisTilts => quantity(Quantity::Beta),
        TermGroup::Compliances => {
            name.starts_with("compliance_")
                || [
                    TermGroup::Payload,
                    TermGroup::JointLaw,
                    TermGroup::LateralCompliances,
                ]
                .into_iter()
                .any(|g| in_group(model, g, name))
        }
        TermGroup::Payload => name.starts_with("payload_"),
        TermGroup::JointLaw => name.starts_with("hardening_") || name.starts_with("lost_motion_"),
        TermGroup::CyclicErrors => name.starts_with("cyclic_"),
        TermGroup::LateralCompliances => name.starts_with("lateral_compliance_"),
    }
}

/// Drops from `groups` every group none of whose unknowns the model with
/// every group identifies on the whole set (the identifiability analysis
/// leaves them at their starting values): a fit on fewer poses does not
/// identify them either, so removing such a group changes no fit, and
/// scoring its removal would cost a fit per fold at every step for nothing.
/// One fit on the whole set; when it fails the search goes on with every
/// group and reports the failure as it would.
fn remove_unidentified_groups(
    model: &Model,
    set: &MeasurementSet,
    base: &CalibrationOptions,
    groups: &mut Vec<TermGroup>,
    reasons: &mut Vec<String>,
) {
    let mut options = candidate_options(model, base, groups);
    options.spread_reference = false;
    let Ok(full) = set.fit(model, &options) else {
        return;
    };
    let unknowns = full.unknowns;
    let identified: Vec<&str> = unknowns
        .iter()
        .filter(|u| u.status == UnknownStatus::Identified)
        .map(|u| u.name.as_str())
        .collect();
    let present: Vec<&str> = unknowns.iter().map(|u| u.name.as_str()).collect();
    groups.retain(|&g| {
        let has = |names: &[&str]| names.iter().any(|n| in_group(model, g, n));
        // A group without unknowns in this model (none present) is left to
        // the search, which reports it as it is.
        if !has(&present) || has(&identified) {
            return true;
        }
        reasons.push(format!(
            "{}: none of its unknowns is identified on the whole set with every group (left at their starting values): not a candidate",
            g.label()
        ));
        false
    });
}

/// The subset of `set` whose poses have `keep(k)`.
fn subset(
    set: &MeasurementSet,
    keep: impl Fn(usize) -> bool,
) -> Result<MeasurementSet, CalibError> {
    let indices: Vec<usize> = (0..set.len()).filter(|&k| keep(k)).collect();
    set.subset(&indices)
}

/// What one fit of a candidate gives its score: per held-out pose position
/// errors (cross-validation; empty for BIC), the number of identified
/// unknowns, and the BIC of the fit (BIC only).
type FitOutcome = (Vec<f64>, usize, f64);

/// Runs the fits of several candidates at once: every fold of every
/// candidate (cross-validation) or every candidate on the whole set (BIC),
/// as one queue shared by a few threads. A backward step's candidates are
/// independent, and one queue keeps every core busy until the last fit,
/// where scoring candidate by candidate waited at each candidate for its
/// slowest fold. Each fit owns its workspaces (each [`calibrate`] builds
/// its own). Results come back in the order of `candidates`, then folds.
fn run_fits(
    model: &Model,
    set: &MeasurementSet,
    folds: &[(MeasurementSet, MeasurementSet)],
    candidates: &[CalibrationOptions],
) -> Vec<Vec<Result<FitOutcome, CalibError>>> {
    let per_candidate = folds.len().max(1);
    let jobs = candidates.len() * per_candidate;
    let rank = |fitted: &Calibration| {
        fitted
            .unknowns
            .iter()
            .filter(|u| u.status == UnknownStatus::Identified)
            .count()
    };
    let fit = |job: usize| -> Result<FitOutcome, CalibError> {
        let options = &candidates[job / per_candidate];
        if folds.is_empty() {
            let fitted = set.fit(model, options)?;
            return Ok((Vec::new(), rank(&fitted), MeasurementSet::bic(&fitted)));
        }
        let (train, held_out) = &folds[job % per_candidate];
        let fitted = train.fit(model, options)?;
        let errors = MeasurementSet::held_out_errors(model, &fitted, held_out)?;
        Ok((errors, rank(&fitted), f64::NAN))
    };
    // At least one thread per fold, as when the folds of a candidate were
    // fitted each on its thread: on a machine shared with other jobs the
    // scheduler shares the cores per thread, and fewer threads than before
    // would get the selection less of them.
    let threads = std::thread::available_parallelism()
        .map_or(1, usize::from)
        .max(folds.len())
        .clamp(1, jobs.max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut results: Vec<Option<Result<FitOutcome, CalibError>>> =
        std::iter::repeat_with(|| None).take(jobs).collect();
    std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let job = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if job >= jobs {
                            break done;
                        }
                        done.push((job, fit(job)));
                    }
                })
            })
            .collect();
        for worker in workers {
            for (job, result) in worker.join().expect("an identification does not panic") {
                results[job] = Some(result);
            }
        }
    });
    let mut results = results.into_iter().map(|r| r.expect("every job ran"));
    (0..candidates.len())
        .map(|_| results.by_ref().take(per_candidate).collect())
        .collect()
}

/// Combines the per-fold outcomes of one candidate into
/// `(per-pose errors, per-fold means, mean rank)`.
fn cross_validation_score(
    fits: Vec<Result<FitOutcome, CalibError>>,
) -> Result<(Vec<f64>, Vec<f64>, f64), CalibError> {
    let k = fits.len();
    let mut per_pose = Vec::new();
    let mut fold_means = Vec::new();
    let mut rank = 0.0;
    for fit in fits {
        let (errors, r, _) = fit?;
        fold_means.push(errors.iter().sum::<f64>() / errors.len().max(1) as f64);
        per_pose.push(errors);
        rank += r as f64;
    }
    rank /= k as f64;
    Ok((per_pose.concat(), fold_means, rank))
}

/// BIC of a fit with `rows` residual rows, weighted cost `cost` and
/// `unknowns`: `n ln(2 cost / n) + p ln n`.
fn bic(rows: usize, cost: f64, unknowns: &[UnknownEstimate]) -> f64 {
    let n = rows as f64;
    let p = unknowns
        .iter()
        .filter(|u| u.status == UnknownStatus::Identified)
        .count() as f64;
    n * (2.0 * cost / n).max(f64::MIN_POSITIVE).ln() + p * n.ln()
}

/// The training and held-out parts of every fold of cross-validation:
/// the ordinary folds ([`SelectionOptions::scheme`]) first, then the
/// extrapolating ones ([`crate::folds`]); with the number of ordinary
/// ones. Records the folds in `report`.
///
/// # Errors
/// [`CalibError::InvalidOption`] for fewer than 2 folds or more folds than
/// poses; what the gravity torques of the extrapolating folds return.
fn build_folds(
    model: &Model,
    set: &MeasurementSet,
    base: &CalibrationOptions,
    selection: &SelectionOptions,
    report: &mut SelectionReport,
) -> Result<(Vec<(MeasurementSet, MeasurementSet)>, usize), CalibError> {
    if selection.folds < 2 || selection.folds > set.len() {
        return Err(CalibError::InvalidOption {
            name: "folds",
            reason: format!(
                "must be between 2 and the number of poses ({}), found {}",
                set.len(),
                selection.folds
            ),
        });
    }
    let poses = fold_poses(set);
    let assignment = fold_assignment(
        model,
        &poses,
        selection.folds,
        selection.scheme,
        selection.seed,
    );
    let mut folds = Vec::new();
    for f in 0..selection.folds {
        let train = subset(set, |k| assignment[k] != f)?;
        let held_out = subset(set, |k| assignment[k] == f)?;
        report.fold_sizes.push(held_out.len());
        folds.push((train, held_out));
    }
    report.extrapolation_end_share = EXTRAPOLATION_END_SHARE;
    for (fold, held_out) in
        extrapolating_folds(model, &poses, base.gravity.as_ref(), base.min_torque_share)?
    {
        folds.push((
            subset(set, |k| !held_out[k])?,
            subset(set, |k| held_out[k])?,
        ));
        report.extrapolation_folds.push(fold);
    }
    Ok((folds, selection.folds))
}

/// The configurations and stations of `set`'s poses.
fn fold_poses(set: &MeasurementSet) -> FoldPoses<'_> {
    FoldPoses {
        q: (0..set.len()).map(|k| set.configuration(k)).collect(),
        station: (0..set.len()).map(|k| set.station_of(k)).collect(),
        n_stations: set.n_stations(),
    }
}

/// The score the search chooses on, and why: what
/// [`SelectionOptions::select_on`] asks, [`SelectOn::Auto`] decided by
/// whether [`SelectionOptions::region`] leaves the training poses' range
/// (the check of the validation report,
/// [`crate::ValidationReport::extrapolated_coordinates`]).
fn score_to_choose_on(
    model: &Model,
    set: &MeasurementSet,
    selection: &SelectionOptions,
    has_extrapolating: bool,
) -> (SelectOn, String) {
    if !has_extrapolating {
        let why = "no joint's range or torque range has ends of enough poses to hold out";
        return (SelectOn::Interpolation, why.into());
    }
    match selection.select_on {
        SelectOn::Interpolation => (SelectOn::Interpolation, "asked for".into()),
        SelectOn::Extrapolation => (SelectOn::Extrapolation, "asked for".into()),
        SelectOn::Auto if selection.region.is_empty() => (
            SelectOn::Interpolation,
            "no region of use given (validation poses, accuracy map), so none known to leave the training range".into(),
        ),
        SelectOn::Auto => {
            let q: Vec<&[f64]> = (0..set.len()).map(|k| set.configuration(k)).collect();
            let ranges = CoordinateCoverage::of_configurations(model, &q);
            let outside = crate::coverage::extrapolated_coordinates(
                model.actuated_names(),
                &ranges,
                selection.region.iter().map(Vec::as_slice),
            );
            let n = selection.region.len();
            if outside.is_empty() {
                (
                    SelectOn::Interpolation,
                    format!("the {n} poses of the region of use lie within the training poses' ranges"),
                )
            } else {
                let which: Vec<String> = outside
                    .iter()
                    .map(|(name, share)| format!("{name} ({:.1} %)", 100.0 * share))
                    .collect();
                (
                    SelectOn::Extrapolation,
                    format!(
                        "the {n} poses of the region of use leave the training poses' range in {} (share of the poses)",
                        which.join(", ")
                    ),
                )
            }
        }
    }
}

/// Mean over the held-out poses, the per-fold means, the mean rank and the
/// standard error of the mean (from the spread of the fold means), of one
/// candidate's fits on some folds.
fn fold_summary(
    fits: Vec<Result<FitOutcome, CalibError>>,
) -> Result<(f64, Vec<f64>, f64, f64), CalibError> {
    let (per_pose, fold_means, rank) = cross_validation_score(fits)?;
    let k = fold_means.len() as f64;
    let mean = per_pose.iter().sum::<f64>() / per_pose.len().max(1) as f64;
    let fm = fold_means.iter().sum::<f64>() / k;
    let sd = (fold_means.iter().map(|v| (v - fm).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    Ok((mean, fold_means, rank, sd / k.sqrt()))
}

/// Fills `candidate` from its fits (cross-validation: the first `ordinary`
/// fits are the ordinary folds, the rest the extrapolating ones; BIC, `None`:
/// one fit) and returns the score the search chooses on (`on`), `None`
/// when that score failed (the reason in the candidate).
fn score_candidate(
    candidate: &mut CandidateScore,
    mut fits: Vec<Result<FitOutcome, CalibError>>,
    ordinary: Option<usize>,
    on: SelectOn,
) -> Option<Score> {
    let Some(ordinary) = ordinary else {
        let fit = fits.into_iter().next().expect("one fit per candidate");
        return match fit {
            Ok((_, rank, b)) => {
                candidate.bic = Some(b);
                candidate.identified = rank as f64;
                Some((b, Vec::new(), rank as f64))
            }
            Err(e) => {
                candidate.failure = Some(e.to_string());
                None
            }
        };
    };
    let extrapolating = fits.split_off(ordinary);
    let interpolation = match fold_summary(fits) {
        Ok((mean, fold_means, rank, se)) => {
            candidate.cv_mean_error_mm = Some(mean * 1e3);
            candidate.cv_standard_error_mm = Some(se * 1e3);
            candidate.cv_fold_errors_mm = fold_means.iter().map(|v| v * 1e3).collect();
            candidate.identified = rank;
            Some((mean, fold_means, rank))
        }
        Err(e) => {
            candidate.failure = Some(e.to_string());
            None
        }
    };
    let extrapolation = extrapolation_score(candidate, extrapolating);
    match on {
        SelectOn::Extrapolation => extrapolation,
        _ => interpolation,
    }
}

/// Fills the extrapolating scores of `candidate` from its fits on the
/// extrapolating folds and returns them (`None` without fits or when they
/// failed, the reason in the candidate).
fn extrapolation_score(
    candidate: &mut CandidateScore,
    extrapolating: Vec<Result<FitOutcome, CalibError>>,
) -> Option<Score> {
    if extrapolating.is_empty() {
        return None;
    }
    match fold_summary(extrapolating) {
        Ok((mean, fold_means, rank, se)) => {
            candidate.extrapolation_mean_error_mm = Some(mean * 1e3);
            candidate.extrapolation_standard_error_mm = Some(se * 1e3);
            candidate.extrapolation_fold_errors_mm = fold_means.iter().map(|v| v * 1e3).collect();
            Some((mean, fold_means, rank))
        }
        Err(e) => {
            candidate.extrapolation_failure = Some(e.to_string());
            None
        }
    }
}

/// The report of a search with `selection`'s settings, before any
/// candidate is scored.
fn empty_report(selection: &SelectionOptions) -> SelectionReport {
    SelectionReport {
        method: selection.method,
        scheme: selection.scheme,
        folds: selection.folds,
        fold_sizes: Vec::new(),
        candidates: Vec::new(),
        chosen: Vec::new(),
        reasons: Vec::new(),
        select_on: selection.select_on,
        chosen_on: SelectOn::Interpolation,
        chosen_on_reason: String::new(),
        extrapolation_end_share: 0.0,
        extrapolation_folds: Vec::new(),
    }
}

/// Scores candidates of one search: each set of groups once (backward
/// steps reach some twice), the candidates of one step fitted together
/// ([`run_fits`]).
struct Scorer<'s> {
    model: &'s Model,
    set: &'s MeasurementSet,
    base: &'s CalibrationOptions,
    /// The folds of cross-validation (empty for BIC).
    folds: Vec<(MeasurementSet, MeasurementSet)>,
    /// The number of ordinary folds (cross-validation), `None` for BIC.
    ordinary: Option<usize>,
    /// The score the search chooses on.
    on: SelectOn,
    /// [`SelectionOptions::every_extrapolation_score`].
    every_extrapolation_score: bool,
    /// Every set of groups scored so far (sorted), with its score.
    scored: Vec<(Vec<TermGroup>, Option<Score>)>,
}

impl Scorer<'_> {
    /// The scores of `trials` (`None` where a score failed), fitting the
    /// sets of groups not scored yet and recording them in `report`.
    fn score(
        &mut self,
        trials: &[Vec<TermGroup>],
        report: &mut SelectionReport,
    ) -> Vec<Option<Score>> {
        let keys: Vec<Vec<TermGroup>> = trials
            .iter()
            .map(|t| {
                let mut sorted = t.clone();
                sorted.sort();
                sorted
            })
            .collect();
        let mut new: Vec<Vec<TermGroup>> = Vec::new();
        for key in &keys {
            if !self.scored.iter().any(|(g, _)| g == key) && !new.contains(key) {
                new.push(key.clone());
            }
        }
        let options: Vec<CalibrationOptions> =
            new.iter().map(|key| self.fold_options(key)).collect();
        let fits = run_fits(self.model, self.set, self.choosing_folds(), &options);
        for (key, fits) in new.into_iter().zip(fits) {
            let mut candidate = CandidateScore::unscored(key.clone());
            let out = score_candidate(&mut candidate, fits, self.ordinary, self.on);
            report.candidates.push(candidate);
            self.scored.push((key, out));
        }
        keys.iter()
            .map(|key| {
                self.scored
                    .iter()
                    .find(|(g, _)| g == key)
                    .and_then(|(_, s)| s.clone())
            })
            .collect()
    }
}

impl Scorer<'_> {
    /// The folds every candidate is fitted on: every fold when the
    /// extrapolating scores choose or every candidate is to have them,
    /// the ordinary ones otherwise (BIC: none).
    fn choosing_folds(&self) -> &[(MeasurementSet, MeasurementSet)] {
        match (self.ordinary, self.on) {
            (Some(ordinary), SelectOn::Interpolation | SelectOn::Auto)
                if !self.every_extrapolation_score =>
            {
                &self.folds[..ordinary]
            }
            _ => &self.folds,
        }
    }

    /// The extrapolating scores of the models in `path`, when the search
    /// chose on the ordinary ones and left them out: filled into their
    /// candidates in `report` (module docs).
    fn score_extrapolation(&self, path: &[Vec<TermGroup>], report: &mut SelectionReport) {
        let Some(ordinary) = self.ordinary else {
            return;
        };
        if self.choosing_folds().len() == self.folds.len() {
            return;
        }
        let mut keys: Vec<Vec<TermGroup>> = Vec::new();
        for groups in path {
            let mut key = groups.clone();
            key.sort();
            let scored = report
                .candidates
                .iter()
                .any(|c| c.groups == key && c.failure.is_none());
            if scored && !keys.contains(&key) {
                keys.push(key);
            }
        }
        let options: Vec<CalibrationOptions> =
            keys.iter().map(|key| self.fold_options(key)).collect();
        let fits = run_fits(self.model, self.set, &self.folds[ordinary..], &options);
        for (key, fits) in keys.iter().zip(fits) {
            if let Some(candidate) = report.candidates.iter_mut().find(|c| &c.groups == key) {
                extrapolation_score(candidate, fits);
            }
        }
    }

    /// The options of the candidate `key` for its fold fits.
    fn fold_options(&self, key: &[TermGroup]) -> CalibrationOptions {
        let mut options = candidate_options(self.model, self.base, key);
        // Scores need no spread ratios; fold fits serve their
        // predictions only (BIC's fits keep their solves: BIC
        // scores the cost itself).
        options.spread_reference = false;
        options.prediction_only = self.ordinary.is_some();
        // The fits of a step run side by side ([`run_fits`]): one thread each.
        options.threads = Some(1);
        options
    }
}

/// The candidates of one backward step from `chosen`: each group removed
/// in turn (the compliances take the payload, the law and the lateral
/// compliances with them), with the group removed.
fn removal_trials(chosen: &[TermGroup]) -> Vec<(TermGroup, Vec<TermGroup>)> {
    chosen
        .iter()
        .map(|&g| {
            let trial = chosen
                .iter()
                .copied()
                .filter(|&c| {
                    c != g
                        && !(g == TermGroup::Compliances
                            && matches!(
                                c,
                                TermGroup::Payload
                                    | TermGroup::JointLaw
                                    | TermGroup::LateralCompliances
                            ))
                })
                .collect();
            (g, trial)
        })
        .collect()
}

/// Whether removing `g` (score `s`) from the current model (score
/// `current`) is taken, and the reason in words. `cv`: the scores are
/// cross-validation means (m), else BIC.
fn judge_removal(g: TermGroup, s: &Score, current: &Score, cv: bool) -> (bool, String) {
    let unit = if cv { "mm" } else { "" };
    let show = |v: f64| if cv { v * 1e3 } else { v };
    // The uncertainty of the difference: paired over the folds (CV), or
    // 2 (BIC: positive evidence for the richer model).
    let margin = if cv {
        let d: Vec<f64> = s.1.iter().zip(&current.1).map(|(a, b)| a - b).collect();
        let k = d.len() as f64;
        let m = d.iter().sum::<f64>() / k;
        // A difference below 1 nm in a mean position error is
        // round-off (noise-free data), not a loss.
        ((d.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (k - 1.0)).sqrt() / k.sqrt())
            .max(ROUND_OFF_SCORE)
    } else {
        2.0
    };
    let loss = s.0 - current.0;
    // A group none of whose unknowns was identified (all left at their
    // starting values by the identifiability analysis) leaves the same
    // number of identified unknowns and nearly the same fits: the
    // paired uncertainty then collapses to almost nothing and would
    // keep a group that does nothing. Such a removal goes when it
    // costs less than 0.1 % of the score (cross-validation; BIC's
    // margin of 2 already lets it go).
    let empty_group = cv && s.2 >= current.2 && loss <= 1e-3 * current.0.abs();
    if loss > margin && empty_group {
        let why = format!(
            "without {} the score is {:.4} {unit} against {:.4} with as many unknowns identified ({:.0}): none of the group's was, removed",
            g.label(),
            show(s.0),
            show(current.0),
            s.2
        );
        (true, why)
    } else if loss <= margin {
        let why = format!(
            "without {} the score is {:.4} {unit} against {:.4}, not worse by more than its uncertainty {:.4}: removed (the simpler model)",
            g.label(),
            show(s.0),
            show(current.0),
            show(margin)
        );
        (true, why)
    } else {
        let why = format!(
            "every removal worsens the score by more than its uncertainty (the least, {}, from {:.4} to {:.4} {unit}, uncertainty {:.4}): the search stops",
            g.label(),
            show(current.0),
            show(s.0),
            show(margin)
        );
        (false, why)
    }
}

/// The backward search from `chosen` (score `current`): at each step the
/// removal that leaves the best score, taken while [`judge_removal`]
/// allows. Returns the models it moved through, from `chosen` to the
/// groups kept (the last).
fn backward_search(
    scorer: &mut Scorer<'_>,
    mut chosen: Vec<TermGroup>,
    mut current: Score,
    report: &mut SelectionReport,
) -> Vec<Vec<TermGroup>> {
    let cv = scorer.ordinary.is_some();
    let mut path = vec![chosen.clone()];
    loop {
        let (removed, trials): (Vec<TermGroup>, Vec<Vec<TermGroup>>) =
            removal_trials(&chosen).into_iter().unzip();
        let scores = scorer.score(&trials, report);
        let mut best: Option<(TermGroup, Vec<TermGroup>, Score)> = None;
        for ((g, trial), s) in removed.into_iter().zip(trials).zip(scores) {
            if let Some(s) = s {
                if best.as_ref().is_none_or(|(_, _, b)| s.0 < b.0) {
                    best = Some((g, trial, s));
                }
            }
        }
        let Some((g, trial, s)) = best else {
            report.reasons.push("no group left to remove".into());
            return path;
        };
        let (take, why) = judge_removal(g, &s, &current, cv);
        report.reasons.push(why);
        if !take {
            return path;
        }
        chosen = trial;
        path.push(chosen.clone());
        current = s;
    }
}

/// Chooses from `set` alone which groups of unknowns to identify (module
/// docs), starting from `base` (the richest model the user allows: its
/// mass table makes compliances and the law available). Returns the
/// report and the chosen options.
///
/// # Errors
/// [`CalibError::InvalidOption`] for fewer than 2 folds or more folds than
/// poses; what [`calibrate`] returns when even the base model fails.
///
/// With several targets per pose the folds are clusters of poses (every
/// target of a pose in the same fold) and the score the mean position
/// error over the held-out observations; a fold that leaves a target
/// unobserved in its training or held-out part fails its candidate, named
/// in the report.
pub fn select_model(
    model: &Model,
    set: &MeasurementSet,
    base: &CalibrationOptions,
    selection: &SelectionOptions,
) -> Result<(SelectionReport, CalibrationOptions), CalibError> {
    let mut groups = available_groups(model, base);
    if let Some(allowed) = &selection.groups {
        groups.retain(|g| allowed.contains(g));
    }
    let mut report = empty_report(selection);
    if selection.method == SelectionMethod::None {
        report.chosen = groups.clone();
        report
            .reasons
            .push("no selection: every group identified".into());
        return Ok((report, candidate_options(model, base, &groups)));
    }
    remove_unidentified_groups(model, set, base, &mut groups, &mut report.reasons);
    let cv = selection.method == SelectionMethod::CrossValidation;
    // Ordinary folds first, then the extrapolating ones: one queue of fits.
    let (folds, ordinary) = if cv {
        build_folds(model, set, base, selection, &mut report)?
    } else {
        (Vec::new(), 0)
    };
    let (chosen_on, why) = score_to_choose_on(model, set, selection, folds.len() > ordinary);
    report.chosen_on = chosen_on;
    report.chosen_on_reason = if cv { why } else { String::new() };
    let mut scorer = Scorer {
        model,
        set,
        base,
        folds,
        ordinary: cv.then_some(ordinary),
        on: chosen_on,
        every_extrapolation_score: selection.every_extrapolation_score,
        scored: Vec::new(),
    };
    let Some(current) = scorer
        .score(std::slice::from_ref(&groups), &mut report)
        .pop()
        .flatten()
    else {
        let first = &report.candidates[0];
        let failure = first
            .failure
            .clone()
            .or_else(|| first.extrapolation_failure.clone())
            .unwrap_or_default();
        return Err(CalibError::InvalidOption {
            name: "select",
            reason: format!("the model with every group could not be scored: {failure}"),
        });
    };
    let path = backward_search(&mut scorer, groups, current, &mut report);
    scorer.score_extrapolation(&path, &mut report);
    let mut chosen = path.last().cloned().unwrap_or_default();
    chosen.sort();
    report.chosen = chosen.clone();
    Ok((report, candidate_options(model, base, &chosen)))
}

/// Selects the model ([`select_model`]) and identifies it on the whole
/// set: the one call behind `calibrate --select`. With
/// [`SelectionMethod::None`] the model of `options` is identified as it is
/// and no report is returned.
///
/// # Errors
/// As [`select_model`] and [`calibrate`].
pub fn calibrate_selected(
    model: &Model,
    set: &MeasurementSet,
    options: &CalibrationOptions,
    selection: &SelectionOptions,
) -> Result<(Calibration, Option<SelectionReport>, CalibrationOptions), CalibError> {
    if selection.method == SelectionMethod::None {
        return Ok((set.fit(model, options)?, None, options.clone()));
    }
    let (report, chosen) = select_model(model, set, options, selection).map_err(|e| {
        // A fit cancelled during the search fails its candidate: say why.
        match &options.cancel {
            Some(token) if token.is_cancelled() => CalibError::Cancelled,
            _ => e,
        }
    })?;
    Ok((set.fit(model, &chosen)?, Some(report), chosen))
}

//! Compliances judged on their own scale, and the noise every judgement
//! uses.
//!
//! A joint of a light robot may be forty times softer than a joint of an
//! industrial arm: a fixed standard-error limit in rad/N.m tuned on one
//! rejects every compliance of the other. So the identification keeps a
//! compliance (about a joint's axis or lateral) when the data determine it
//! relative to its own scale, the larger of its fitted value and its
//! starting value: after the fit, that scale must be at least
//! [`crate::CalibrationOptions::min_compliance_z`] standard errors (default
//! 2). A compliance the data put at zero with a small standard error is
//! determined (the joint is stiff) and kept there. A compliance left out
//! stays at its start, like every unknown the data do not determine: the
//! mass table's starting compliance is then the user's prior, and on a
//! robot much stiffer or softer than it, it carries into the predictions. The judgement runs on the richest identifiable fit (every compliance
//! the exact rank allows is in the first fit, so the noise estimated from
//! its residual is not inflated by the sag of the ones left out), and
//! leaves out one weak compliance at a time (all those below one standard
//! error at once), fitting again after each step: two compliances that
//! trade off against each other are not both dropped when one of them
//! alone is determined.
//!
//! A joint whose gravity torque spans less than
//! [`crate::CalibrationOptions::min_torque_share`] (default
//! [`MIN_TORQUE_SHARE`], 5 %) of
//! the most loaded joint's span is barely loaded: over a few N.m its
//! compliance cannot be told from the geometry's and the model's small
//! errors, which it would absorb with a value that says nothing of the
//! joint (on IPA series B, a UR10 wrist joint loaded by +-3 N.m came out
//! at 500 +/- 100 urad/N.m, forty times its neighbours). Its compliance
//! stays at its start before any fit.
//!
//! Compliances are non-negative: a spring yields in the direction of the
//! load. A determined compliance the fit puts below zero by more than its
//! standard error is held at zero ([`ScaleOutcome::AtBound`]) and the rest
//! fitted again; the report names it, since a bound that binds says that
//! another term of the model is missing or that the mass table is off.
//! A coupling group's off-diagonal entries (`coupling_compliance_*`) have
//! no sign: they are judged on their own scale like the others, and their
//! group's matrix is held positive semi-definite instead (the coupling
//! module).
//!
//! A fit that serves its predictions only (model selection's fold fits,
//! [`crate::CalibrationOptions::prediction_only`]) is not solved again after
//! each step: the step's effect is the linearised update of the fit
//! (`linearised_update`: the Gauss-Newton step of the fit's quadratic
//! model with the settled compliances held, the covariance and the
//! variance factor updated with it), exact for residuals linear in the
//! unknowns. Once no compliance is left to settle, the fit is solved
//! again only if a judgement made on an update lay within
//! `CLOSE_SHARE` (10 %) of its threshold, and the judgement then goes on
//! from that solve.
//!
//! The noise: the instrument's stated figure when the user gives one
//! ([`InstrumentNoise`], `--noise-mm`), the file's standard deviations when
//! every observation has them, else estimated from the weighted residual of
//! the fit ([`NoiseSource`]).
//!
//! Limitations: the bound is handled as an active set without Lagrange
//! multipliers (a compliance held at zero is not released again when
//! others change); the standard errors are the linearised ones of the fit.

use serde::Serialize;

use nalgebra::{DMatrix, DVector};

use crate::error::CalibError;
use flexcal_optim::SolveReport;

/// The measurement instrument's stated noise, one standard deviation per
/// axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InstrumentNoise {
    /// Position noise per axis (m, `> 0`).
    pub position_std: f64,
    /// Orientation noise per axis (rad, `> 0`); needed when orientations
    /// are fitted.
    pub orientation_std: Option<f64>,
}

impl InstrumentNoise {
    pub(crate) fn check(&self) -> Result<(), CalibError> {
        let positive = crate::error::require_positive;
        positive("instrument_noise.position_std", self.position_std)?;
        if let Some(s) = self.orientation_std {
            positive("instrument_noise.orientation_std", s)?;
        }
        Ok(())
    }

    /// The orientation noise, or an error naming it when orientations are
    /// fitted without one.
    pub(crate) fn orientation(&self) -> Result<f64, CalibError> {
        self.orientation_std.ok_or(CalibError::InvalidOption {
            name: "instrument_noise.orientation_std",
            reason: "orientations are fitted: state the instrument's orientation noise too (--noise-deg), or leave orientations out".into(),
        })
    }
}

/// Where the noise level of an identification came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum NoiseSource {
    /// The instrument's figure stated by the user.
    Instrument(InstrumentNoise),
    /// The standard deviations of the measurement file, per observation.
    File,
    /// Estimated from the weighted residual of the final fit: the noise
    /// per position axis it stands for (m), model error included.
    Estimated {
        /// One standard deviation per position axis (m).
        position_std: f64,
    },
}

impl std::fmt::Display for NoiseSource {
    /// One phrase for reports: where the noise came from and its size
    /// (mm, deg).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NoiseSource::Instrument(noise) => {
                write!(
                    f,
                    "the instrument's stated {:.4} mm per position axis",
                    noise.position_std * 1e3
                )?;
                if let Some(s) = noise.orientation_std {
                    write!(f, " and {:.4} deg per orientation axis", s.to_degrees())?;
                }
                Ok(())
            }
            NoiseSource::File => write!(f, "the measurement file's standard deviations"),
            NoiseSource::Estimated { position_std } => write!(
                f,
                "estimated from the fit's residual, {:.4} mm per position axis (what the model leaves included; a stated instrument noise replaces it)",
                position_std * 1e3
            ),
        }
    }
}

/// The default share of the most loaded joint's gravity-torque span below
/// which a joint's compliance is not identified (module docs;
/// [`crate::CalibrationOptions::min_torque_share`]).
pub const MIN_TORQUE_SHARE: f64 = 0.05;

/// The largest magnitude of a torque span (N.m).
pub(crate) fn torque_magnitude(span: &crate::coverage::CoordinateCoverage) -> f64 {
    span.lo.abs().max(span.hi.abs())
}

/// `mask` (unknowns left at their start before any fit) with the
/// compliances `compliance_<joint>` of the unknowns `names` whose joints
/// gravity barely loads added: their torque (`torque_ranges`, in the
/// order of `actuated_names`) below `share` of the largest
/// ([`crate::CalibrationOptions::min_torque_share`]).
pub(crate) fn barely_loaded(
    mask: Vec<bool>,
    (names, actuated_names): (&[String], &[String]),
    torque_ranges: &[crate::coverage::CoordinateCoverage],
    share: f64,
) -> Vec<bool> {
    let largest = torque_ranges
        .iter()
        .map(torque_magnitude)
        .fold(0.0, f64::max);
    names
        .iter()
        .zip(mask)
        .map(|(name, left)| {
            left || name
                .strip_prefix("compliance_")
                .and_then(|joint| actuated_names.iter().position(|a| a == joint))
                .and_then(|i| torque_ranges.get(i))
                .is_some_and(|span| torque_magnitude(span) < share * largest)
        })
        .collect()
}

/// What the judgement on its own scale made of a compliance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ScaleOutcome {
    /// Determined: its scale (the larger of its value and its start) is
    /// at least `min_compliance_z` standard errors.
    Kept,
    /// Not determined: left at its starting value.
    LeftOut,
    /// Determined, and below zero by more than its standard error: held
    /// at zero.
    AtBound,
}

/// The fit that judged a compliance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScaleJudgement {
    /// Its value in that fit (rad/N.m or m/N).
    pub value: f64,
    /// Its standard error in that fit (same unit; infinite when the fit
    /// gave none).
    pub standard_error: f64,
    /// What became of it.
    pub outcome: ScaleOutcome,
}

impl ScaleJudgement {
    /// Unknown `j` of the fit `report` held at a bound: its fitted value
    /// and standard error (infinite when the fit gave none).
    pub(crate) fn at_bound(report: &SolveReport, j: usize) -> Self {
        Self {
            value: report.x[j],
            standard_error: report.standard_errors[j]
                .filter(|s| s.is_finite())
                .unwrap_or(f64::INFINITY),
            outcome: ScaleOutcome::AtBound,
        }
    }
}

/// One solve from `x0` with the unknowns `frozen` held.
pub(crate) type Solve<'a> = dyn FnMut(&[f64], &[bool]) -> Result<SolveReport, CalibError> + 'a;

/// A fit after judging: its report, the frozen unknowns, and each
/// compliance's judgement.
pub(crate) type Judged = (SolveReport, Vec<bool>, Vec<Option<ScaleJudgement>>);

/// What [`judge_compliances`] needs besides the fit.
pub(crate) struct Judging<'a> {
    /// Which unknowns are compliances.
    pub compliance: &'a [bool],
    /// Which compliances are bounded below by zero (all but a coupling
    /// group's off-diagonal entries).
    pub nonnegative: &'a [bool],
    /// Absolute standard-error limits (unit of each unknown).
    pub limits: &'a [f64],
    /// [`crate::CalibrationOptions::min_compliance_z`].
    pub z_min: f64,
    /// Starting values (where a compliance left out goes back to; its
    /// scale is at least its start).
    pub x_start: &'a [f64],
    /// How the fit is updated after each step.
    pub update: JudgeUpdate,
    /// Whether the row weights are absolute (the variance factor is then
    /// 1; else it is estimated from the cost).
    pub absolute: bool,
}

/// How [`judge_compliances`] updates the fit after it leaves compliances
/// out or holds them at zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum JudgeUpdate {
    /// Solved again after each step.
    Solve,
    /// The linearised update ([`linearised_update`]) after each step;
    /// solved again only when some judgement made on a linearised update
    /// lies within [`CLOSE_SHARE`] of its threshold, or when the update
    /// cannot be made (an unknown without a standard error).
    Linearised,
}

/// Share of a threshold (the z-score, the standard-error limit, the bound)
/// within which a judgement made on a linearised update is made again on
/// a solved fit ([`JudgeUpdate::Linearised`]).
pub(crate) const CLOSE_SHARE: f64 = 0.1;

/// The fit `report` (a minimum of the weighted cost, its covariance from
/// the Jacobian there) with the unknowns of `held` put at the given values
/// and the others moved by the Gauss-Newton step of that quadratic model:
/// `dx = C[:, S] C[S, S]^-1 (v - x_S)`, the covariance of the rest the
/// Schur complement `C - C[:, S] C[S, S]^-1 C[S, :]`, the cost raised by
/// `sigma2 / 2 (v - x_S)^T C[S, S]^-1 (v - x_S)` and, with relative weights
/// (`absolute` false), the variance factor re-estimated with `|S|` more
/// degrees of freedom. Exact when the residuals are linear in the
/// unknowns. `None` when the fit has no covariance or `C[S, S]` is not
/// positive definite (an unknown of `held` without a standard error).
pub(crate) fn linearised_update(
    report: &SolveReport,
    held: &[(usize, f64)],
    absolute: bool,
) -> Option<SolveReport> {
    let covariance = report.covariance.as_ref()?;
    let sigma2 = report.sigma2;
    if held.is_empty() || !(sigma2.is_finite() && sigma2 > 0.0) {
        return None;
    }
    let n = report.x.len();
    let s = held.len();
    let index: Vec<usize> = held.iter().map(|&(j, _)| j).collect();
    let c_ss = DMatrix::from_fn(s, s, |a, b| covariance[(index[a], index[b])]);
    let cholesky = c_ss.cholesky()?;
    let c_xs = DMatrix::from_fn(n, s, |i, a| covariance[(i, index[a])]);
    let d = DVector::from_iterator(s, held.iter().map(|&(j, v)| v - report.x[j]));
    let w = cholesky.solve(&d);
    let step = &c_xs * &w;
    let mut x: Vec<f64> = report
        .x
        .iter()
        .zip(step.iter())
        .map(|(x, dx)| x + dx)
        .collect();
    for &(j, v) in held {
        x[j] = v;
    }
    let cost = report.cost + 0.5 * sigma2 * d.dot(&w);
    let new_sigma2 = if absolute {
        1.0
    } else {
        // m - rank = 2 cost / sigma2 before; |S| unknowns fewer after.
        2.0 * cost / (2.0 * report.cost / sigma2 + s as f64)
    };
    let mut c = covariance - &c_xs * cholesky.solve(&c_xs.transpose());
    c *= new_sigma2 / sigma2;
    for &j in &index {
        c.row_mut(j).fill(0.0);
        c.column_mut(j).fill(0.0);
    }
    let standard_errors = (0..n)
        .map(|j| {
            report.standard_errors[j]
                .filter(|_| !index.contains(&j))
                .map(|_| c[(j, j)].max(0.0).sqrt())
        })
        .collect();
    Some(SolveReport {
        x,
        cost,
        sigma2: new_sigma2,
        covariance: Some(c),
        standard_errors,
        n_free: report.n_free.saturating_sub(s),
        rank: report.rank.saturating_sub(s),
        iterations: 0,
        cost_history: Vec::new(),
        start_weighted_residuals: Vec::new(),
        ..report.clone()
    })
}

/// Whether `value` lies within [`CLOSE_SHARE`] of `threshold`.
fn near(value: f64, threshold: f64) -> bool {
    (value - threshold).abs() <= CLOSE_SHARE * threshold.abs()
}

/// One step of [`judge_compliances`] on the fit `report`: records each
/// free compliance's judgement in `judgements` and returns those to settle
/// now (the hopeless ones together, otherwise the weakest alone, with the
/// ones beyond their limit or below zero), and whether some judgement lies
/// within [`CLOSE_SHARE`] of its threshold.
fn judge_step(
    judging: &Judging<'_>,
    report: &SolveReport,
    frozen: &[bool],
    judgements: &mut [Option<ScaleJudgement>],
) -> (Vec<(usize, ScaleOutcome)>, bool) {
    let mut weak: Vec<(usize, f64)> = Vec::new();
    let mut settled: Vec<(usize, ScaleOutcome)> = Vec::new();
    let mut close = false;
    for j in (0..frozen.len()).filter(|&j| judging.compliance[j] && !frozen[j]) {
        let value = report.x[j];
        let se = report.standard_errors[j]
            .filter(|s| s.is_finite())
            .unwrap_or(f64::INFINITY);
        // Its own scale: the larger of its fitted value and its start
        // (a compliance the data put at zero with a small error is
        // determined: the joint is stiff).
        let z = value.abs().max(judging.x_start[j].abs()) / se;
        judgements[j] = Some(ScaleJudgement {
            value,
            standard_error: se,
            outcome: ScaleOutcome::Kept,
        });
        close |= near(se, judging.limits[j]) || near(z, judging.z_min);
        if se > judging.limits[j] {
            settled.push((j, ScaleOutcome::LeftOut));
        } else if z < judging.z_min {
            weak.push((j, z));
        } else if judging.nonnegative[j] {
            close |= near(value, -se);
            if value < -se {
                settled.push((j, ScaleOutcome::AtBound));
            }
        }
    }
    // Hopeless ones together, otherwise the weakest alone.
    weak.sort_by(|a, b| a.1.total_cmp(&b.1));
    let hopeless = weak.iter().take_while(|(_, z)| *z < 1.0).count();
    let take = if hopeless > 0 {
        hopeless
    } else {
        weak.len().min(1)
    };
    settled.extend(
        weak[..take]
            .iter()
            .map(|&(j, _)| (j, ScaleOutcome::LeftOut)),
    );
    (settled, close)
}

/// Judges every identified compliance of the fit `report` on its own
/// scale (module docs), updating the fit after each step as
/// [`Judging::update`] says (with `solve`, or linearised); returns the
/// final fit, the frozen unknowns and each compliance's judgement.
pub(crate) fn judge_compliances(
    judging: &Judging<'_>,
    (mut report, mut frozen): (SolveReport, Vec<bool>),
    solve: &mut Solve<'_>,
) -> Result<Judged, CalibError> {
    let n = frozen.len();
    let mut judgements: Vec<Option<ScaleJudgement>> = vec![None; n];
    let candidates = (0..n).filter(|&j| judging.compliance[j]).count();
    // Whether `report` is a linearised update, and whether a judgement
    // made on one was close to its threshold.
    let (mut linear, mut close) = (false, false);
    // Each step settles a compliance at least; a solve after linearised
    // steps may start a second run of steps.
    for _ in 0..=2 * candidates + 1 {
        let (settled, near_threshold) = judge_step(judging, &report, &frozen, &mut judgements);
        close |= linear && near_threshold;
        if settled.is_empty() {
            if linear && close {
                report = solve(&report.x, &frozen)?;
                (linear, close) = (false, false);
                continue;
            }
            break;
        }
        let mut held = Vec::with_capacity(settled.len());
        for &(j, outcome) in &settled {
            frozen[j] = true;
            held.push((
                j,
                match outcome {
                    ScaleOutcome::AtBound => 0.0,
                    _ => judging.x_start[j],
                },
            ));
            if let Some(judgement) = &mut judgements[j] {
                judgement.outcome = outcome;
            }
        }
        if frozen.iter().all(|f| *f) {
            return Err(CalibError::NothingToIdentify);
        }
        let update = match judging.update {
            JudgeUpdate::Linearised => linearised_update(&report, &held, judging.absolute),
            JudgeUpdate::Solve => None,
        };
        linear = update.is_some();
        report = match update {
            Some(update) => update,
            None => {
                let mut x0 = report.x.clone();
                for &(j, v) in &held {
                    x0[j] = v;
                }
                solve(&x0, &frozen)?
            }
        };
    }
    // The kept ones carry their final values.
    for j in (0..n).filter(|&j| judging.compliance[j] && !frozen[j]) {
        if let Some(judgement) = &mut judgements[j] {
            judgement.value = report.x[j];
            judgement.standard_error = report.standard_errors[j]
                .filter(|s| s.is_finite())
                .unwrap_or(f64::INFINITY);
        }
    }
    Ok((report, frozen, judgements))
}

/// For each unknown: when it is a joint law's hardening, the index of its
/// joint's compliance unknown and the joint's largest gravity torque
/// magnitude over the poses (N.m), from the names `names` and the torque
/// spans `torque_ranges` (in the order of `actuated_names`).
pub(crate) fn hardening_floors(
    names: &[String],
    actuated_names: &[String],
    torque_ranges: &[crate::coverage::CoordinateCoverage],
) -> Vec<Option<(usize, f64)>> {
    names
        .iter()
        .map(|name| {
            let joint = name.strip_prefix("hardening_")?;
            let i = actuated_names.iter().position(|a| a == joint)?;
            let compliance = format!("compliance_{joint}");
            let c = names.iter().position(|n| *n == compliance)?;
            Some((c, torque_magnitude(torque_ranges.get(i)?)))
        })
        .collect()
}

/// Holds each identified hardening that the fit puts below its monotone
/// floor ([`crate::joint_law::monotone_hardening_floor`] of its joint's
/// fitted compliance and largest torque, `floors` from
/// [`hardening_floors`]) at that floor, status at-bound, and fits the rest
/// again (at most three passes: a bound is computed from the compliance
/// of the fit in which it binds).
pub(crate) fn hold_monotone_laws(
    floors: &[Option<(usize, f64)>],
    judged: Judged,
    solve: &mut Solve<'_>,
) -> Result<Judged, CalibError> {
    hold_at_bounds(judged, solve, &|report, frozen| {
        floors
            .iter()
            .enumerate()
            .filter_map(|(j, floor)| {
                let (c, largest) = (*floor)?;
                crate::joint_law::monotone_hardening_floor(report.x[c], largest)
                    .filter(|b| !frozen[j] && report.x[j] < *b)
                    .map(|b| (j, b))
            })
            .collect()
    })
}

/// The bounds that bind in a fit: each unknown to hold and the value it is
/// held at, from the fit and the unknowns already frozen.
pub(crate) type Binding<'a> = dyn Fn(&SolveReport, &[bool]) -> Vec<(usize, f64)> + 'a;

/// Holds the unknowns `binding` names at their bounds (status at-bound,
/// frozen) and fits the rest again, at most three passes: a bound may
/// depend on unknowns that move in the refit.
pub(crate) fn hold_at_bounds(
    (mut report, mut frozen, mut judgements): Judged,
    solve: &mut Solve<'_>,
    binding: &Binding<'_>,
) -> Result<Judged, CalibError> {
    for _ in 0..3 {
        let held = binding(&report, &frozen);
        if held.is_empty() {
            break;
        }
        let mut x0 = report.x.clone();
        for &(j, bound) in &held {
            judgements[j] = Some(ScaleJudgement::at_bound(&report, j));
            frozen[j] = true;
            x0[j] = bound;
        }
        report = solve(&x0, &frozen)?;
    }
    Ok((report, frozen, judgements))
}

/// A converged fit at `x` with unit standard errors, for the tests of the
/// bounds.
#[cfg(test)]
pub(crate) fn report(x: Vec<f64>) -> SolveReport {
    let n = x.len();
    SolveReport {
        standard_errors: vec![Some(1.0); n],
        parameter_names: Vec::new(),
        cost: 0.0,
        cost_history: Vec::new(),
        start_weighted_residuals: Vec::new(),
        iterations: 1,
        residual_evaluations: 1,
        jacobian_evaluations: 1,
        refused_trials: 0,
        last_refusal: None,
        termination: flexcal_optim::Termination::SmallStep,
        n_free: n,
        rank: n,
        not_identified: Vec::new(),
        singular_values: Vec::new(),
        condition_number: 1.0,
        column_scales: Vec::new(),
        sigma2: 1.0,
        covariance: None,
        x,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coverage::CoordinateCoverage;
    use rand::{Rng, SeedableRng};

    /// The linearised update of a linear least-squares fit is the fit of
    /// the reduced problem: values, cost, variance factor and covariance
    /// against the normal equations of the unknowns left free, solved
    /// here apart; seeded random problems, relative and absolute weights.
    #[test]
    fn the_linearised_update_of_a_linear_fit_is_the_reduced_fit() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for (m, n, absolute) in [(40, 6, false), (25, 5, true), (60, 9, false)] {
            let a = DMatrix::<f64>::from_fn(m, n, |_, _| rng.random_range(-1.0..1.0));
            let b = DVector::<f64>::from_fn(m, |_, _| rng.random_range(-1.0..1.0));
            // The full fit, by the normal equations.
            let fit = |cols: &[usize], rhs: &DVector<f64>| {
                let sub = a.select_columns(cols);
                let normal = (sub.transpose() * &sub).try_inverse().unwrap();
                let x = &normal * sub.transpose() * rhs;
                let r = &sub * &x - rhs;
                (x, normal, 0.5 * r.norm_squared())
            };
            let all: Vec<usize> = (0..n).collect();
            let (x_hat, normal, cost) = fit(&all, &b);
            let sigma2 = if absolute {
                1.0
            } else {
                2.0 * cost / (m - n) as f64
            };
            let mut fitted = report(x_hat.iter().copied().collect());
            fitted.cost = cost;
            fitted.sigma2 = sigma2;
            fitted.covariance = Some(&normal * sigma2);
            fitted.standard_errors = (0..n)
                .map(|j| Some((sigma2 * normal[(j, j)]).sqrt()))
                .collect();
            let held = [(1, 0.3), (n - 2, -0.2)];
            let update = linearised_update(&fitted, &held, absolute).unwrap();
            // The reduced problem, fitted apart.
            let free: Vec<usize> = all
                .iter()
                .copied()
                .filter(|j| *j != 1 && *j != n - 2)
                .collect();
            let rhs = &b - a.column(1) * 0.3 - a.column(n - 2) * -0.2;
            let (x_free, normal_free, cost_free) = fit(&free, &rhs);
            let sigma2_free = if absolute {
                1.0
            } else {
                2.0 * cost_free / (m - free.len()) as f64
            };
            let close = |u: f64, v: f64| (u - v).abs() <= 1e-10 * (1.0 + v.abs());
            assert!(close(update.cost, cost_free), "{} {cost_free}", update.cost);
            assert!(close(update.sigma2, sigma2_free));
            assert_eq!((update.x[1], update.x[n - 2]), (0.3, -0.2));
            let c = update.covariance.as_ref().unwrap();
            for (a_, &i) in free.iter().enumerate() {
                assert!(close(update.x[i], x_free[a_]), "x[{i}]");
                let se = update.standard_errors[i].unwrap();
                assert!(close(se * se, sigma2_free * normal_free[(a_, a_)]));
                for (b_, &k) in free.iter().enumerate() {
                    assert!(close(c[(i, k)], sigma2_free * normal_free[(a_, b_)]));
                }
            }
            for j in [1, n - 2] {
                assert!(update.standard_errors[j].is_none());
                assert!((0..n).all(|k| c[(j, k)] == 0.0 && c[(k, j)] == 0.0));
            }
        }
        // Without a covariance there is no update (the judgement solves).
        let mut bare = report(vec![1.0, 2.0]);
        bare.covariance = None;
        assert!(linearised_update(&bare, &[(0, 0.0)], false).is_none());
    }

    /// A softening the fit pushes past the yield is held at the floor of
    /// the compliance it is fitted with, the rest solved again; one within
    /// the bound and one of a joint without torque are left alone.
    #[test]
    fn a_hardening_below_the_monotone_floor_is_held_there() {
        let names: Vec<String> = [
            "compliance_a",
            "compliance_b",
            "hardening_a",
            "hardening_b",
            "theta_a",
        ]
        .map(String::from)
        .to_vec();
        let actuated = ["a", "b"].map(String::from).to_vec();
        let span = |t: f64| CoordinateCoverage {
            lo: -0.5 * t,
            hi: t,
            period: None,
        };
        let floors = hardening_floors(&names, &actuated, &[span(40.0), span(0.0)]);
        assert_eq!(
            floors,
            vec![None, None, Some((0, 40.0)), Some((1, 0.0)), None]
        );
        let c = 300e-6;
        let floor = crate::joint_law::monotone_hardening_floor(c, 40.0).unwrap();
        // The fit: joint a softens beyond the yield, joint b too but it
        // carries no torque.
        let first = report(vec![c, c, 3.0 * floor, 5.0 * floor, 0.01]);
        let mut calls = Vec::new();
        let mut solve = |x0: &[f64], frozen: &[bool]| {
            calls.push((x0.to_vec(), frozen.to_vec()));
            // The refit moves the free unknowns a little.
            let mut x = x0.to_vec();
            for (v, f) in x.iter_mut().zip(frozen) {
                if !f {
                    *v *= 1.01;
                }
            }
            Ok(report(x))
        };
        let (last, frozen, judgements) =
            hold_monotone_laws(&floors, (first, vec![false; 5], vec![None; 5]), &mut solve)
                .unwrap();
        assert_eq!(calls.len(), 1);
        assert_eq!(frozen, vec![false, false, true, false, false]);
        assert!((last.x[2] - floor).abs() < 1e-12 * floor.abs());
        let judged = judgements[2].unwrap();
        assert_eq!(judged.outcome, ScaleOutcome::AtBound);
        assert!((judged.value - 3.0 * floor).abs() < 1e-12 * floor.abs());
        assert!(judgements[3].is_none());
        // Within the bound: nothing held, no refit.
        let within = report(vec![c, c, 0.5 * floor, 0.0, 0.0]);
        let mut never = |_: &[f64], _: &[bool]| -> Result<SolveReport, CalibError> {
            panic!("nothing to hold")
        };
        let (_, frozen, _) =
            hold_monotone_laws(&floors, (within, vec![false; 5], vec![None; 5]), &mut never)
                .unwrap();
        assert!(frozen.iter().all(|f| !f));
    }
}

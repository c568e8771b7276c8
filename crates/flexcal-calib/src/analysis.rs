//! Step 6 of the identification: the
//! rank-revealing analysis and the solver rounds. Pivoted QR of the
//! weighted stacked Jacobian (streamed, `AnalysisContext::reduced`)
//! decides which unknowns are exactly dependent on others (the paper's
//! base parameters (11)) and which the noise leaves undetermined; the
//! rounds solve the base set, estimate the noise again, check the joint
//! terms' limits and judge the compliances on their own scale
//! ([`crate::significance`]); `unknown_estimates` gives every unknown
//! its status.

use faer::Mat;
use faer::prelude::SolveLstsq;
use flexcal_optim::{
    ColumnScaling, IdentifiabilityOptions, IdentifiabilityReport, Residuals, SolveReport,
    analyze_identifiability,
};

use crate::error::CalibError;
use crate::error_model::{ErrorModel, UnknownKind};
use crate::significance::{
    Judging, ScaleJudgement, ScaleOutcome, Solve, hold_monotone_laws, judge_compliances,
};
use crate::unknowns::{Combination, UnknownEstimate, UnknownStatus};

/// Maps an index of an analysis over a subset of unknowns back to the full vector.
pub(crate) fn analysis_index(
    analysis: &IdentifiabilityReport,
    j: usize,
    names: &[String],
) -> usize {
    let name = &analysis.names[j];
    names.iter().position(|n| n == name).unwrap_or(0)
}

/// The error model's own error back from the solver's problem error.
pub(crate) fn problem_error(e: flexcal_optim::ProblemError) -> CalibError {
    match e.downcast::<CalibError>() {
        Ok(calib) => *calib,
        Err(other) => CalibError::BadMeasurement {
            source_name: String::new(),
            line: 0,
            what: other.to_string(),
        },
    }
}

/// What the identifiability analyses share.
pub(crate) struct AnalysisContext<'a> {
    pub problem: &'a ErrorModel<'a>,
    pub weights: &'a [f64],
    pub names: &'a [String],
    pub priorities: &'a [i32],
    pub limits: &'a [f64],
    pub rank_tolerance: f64,
    /// Whether the numerical analysis (no noise level) computes its
    /// singular values (the reported ones;
    /// [`crate::CalibrationOptions::prediction_only`] skips them).
    pub singular_values: bool,
}

impl AnalysisContext<'_> {
    /// The triangular factor `R` of the weighted Jacobian `W J = Q R` at `x`
    /// (min(m, n) x n). Column-pivoted QR, ranks, base sets and least-squares
    /// combinations of any subset of columns are the same on `R` as on `W J`
    /// (they differ by the orthogonal `Q`), at a fraction of the cost for
    /// thousands of poses.
    pub(crate) fn reduced(&self, x: &[f64]) -> Result<Mat<f64>, CalibError> {
        let n = self.problem.n_unknowns();
        let blocks = self.problem.n_observations();
        // Streamed by groups of observations of at most 320 rows: R of
        // [R_so_far; W J_group], so the whole stacked Jacobian is never held.
        let mut groups = Vec::new();
        let mut start = 0;
        while start < blocks {
            let first_row = self.problem.block_rows(start).start;
            let mut end = start + 1;
            while end < blocks && self.problem.block_rows(end).end - first_row <= 320 {
                end += 1;
            }
            groups.push(start..end);
            start = end;
        }
        // The Jacobian of several groups at once (one evaluation shared
        // between the model's threads), up to 2 560 rows; each group's QR
        // in turn, as if it had been evaluated alone.
        let mut r = Mat::<f64>::zeros(0, n);
        let mut g = 0;
        while g < groups.len() {
            let first_row = self.problem.block_rows(groups[g].start).start;
            let mut last = g + 1;
            while last < groups.len()
                && self.problem.block_rows(groups[last].end - 1).end - first_row <= 2560
            {
                last += 1;
            }
            let batch_rows = self.problem.block_rows(groups[last - 1].end - 1).end - first_row;
            let mut batch = Mat::<f64>::zeros(batch_rows, n);
            self.problem
                .jacobian_blocks(x, groups[g].start..groups[last - 1].end, batch.as_mut())
                .map_err(problem_error)?;
            for group in &groups[g..last] {
                let group_row = self.problem.block_rows(group.start).start;
                let m_block = self.problem.block_rows(group.end - 1).end - group_row;
                let top = r.nrows();
                let mut stacked = Mat::<f64>::zeros(top + m_block, n);
                for j in 0..n {
                    for i in 0..top {
                        stacked[(i, j)] = r[(i, j)];
                    }
                    for i in 0..m_block {
                        stacked[(top + i, j)] =
                            batch[(group_row - first_row + i, j)] * self.weights[group_row + i];
                    }
                }
                let qr = stacked.qr();
                let thin = qr.thin_R();
                r = Mat::<f64>::from_fn(
                    thin.nrows(),
                    n,
                    |i, j| if i <= j { thin[(i, j)] } else { 0.0 },
                );
            }
            g = last;
        }
        Ok(r)
    }

    /// `K` with `J_N = J_B K` (weighted least squares at `x`), so that
    /// `J (xi_B, xi_N) = J_B (xi_B + K xi_N)`.
    pub(crate) fn combinations(
        &self,
        reduced: &Mat<f64>,
        base: &[usize],
        absorbed: &[usize],
    ) -> Result<Vec<Combination>, CalibError> {
        let m = reduced.nrows();
        if absorbed.is_empty() || base.is_empty() {
            return Ok(base
                .iter()
                .map(|&b| Combination {
                    name: self.names[b].clone(),
                    terms: Vec::new(),
                })
                .collect());
        }
        let j_b = Mat::<f64>::from_fn(m, base.len(), |i, c| reduced[(i, base[c])]);
        let j_n = Mat::<f64>::from_fn(m, absorbed.len(), |i, c| reduced[(i, absorbed[c])]);
        // The base columns are independent by construction: plain QR least squares.
        let k = j_b.qr().solve_lstsq(&j_n);
        Ok(base
            .iter()
            .enumerate()
            .map(|(row, &b)| {
                let mut terms: Vec<(String, f64)> = absorbed
                    .iter()
                    .enumerate()
                    .map(|(col, &a)| (self.names[a].clone(), k[(row, col)]))
                    .filter(|(_, v)| v.is_finite() && *v != 0.0)
                    .collect();
                terms.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
                Combination {
                    name: self.names[b].clone(),
                    terms,
                }
            })
            .collect())
    }

    /// Identifiability of the unknowns not excluded, at `x`, on the weighted
    /// Jacobian (so a pose measured poorly counts less).
    ///
    /// Without `noise`, columns are scaled by their norms and the rank is the
    /// numerical one at `rank_tolerance`. With the noise level `sigma`
    /// (weighted units), column j is scaled by its standard-error limit
    /// `l_j` and a column enters the base set only if its part orthogonal to
    /// the columns already chosen, `|R_kk| l_j`, exceeds `sigma`: the
    /// identified value would otherwise carry a standard error above `l_j`
    /// (`se_k >= sigma / |R_kk|`).
    pub(crate) fn analyse(
        &self,
        reduced: &Mat<f64>,
        noise: Option<f64>,
        excluded: &dyn Fn(usize) -> bool,
    ) -> Result<IdentifiabilityReport, CalibError> {
        let n = reduced.ncols();
        let kept: Vec<usize> = (0..n).filter(|&j| !excluded(j)).collect();
        let sub = Mat::<f64>::from_fn(reduced.nrows(), kept.len(), |i, c| reduced[(i, kept[c])]);
        let sub_names: Vec<String> = kept.iter().map(|&j| self.names[j].clone()).collect();
        let mut options = IdentifiabilityOptions {
            rank_tolerance: self.rank_tolerance,
            priorities: kept.iter().map(|&j| self.priorities[j]).collect(),
            // The analyses at a noise level give the base set alone; only
            // the numerical one is reported (two SVDs saved per round).
            singular_values: noise.is_none() && self.singular_values,
            ..IdentifiabilityOptions::default()
        };
        if let Some(sigma) = noise {
            let limits: Vec<f64> = kept.iter().map(|&j| self.limits[j]).collect();
            let reference = (0..kept.len())
                .map(|c| sub.col(c).norm_l2() * limits[c])
                .fold(0.0, f64::max);
            if reference > 0.0 && sigma.is_finite() {
                options.rank_tolerance = (sigma / reference).clamp(1e-12, 0.999);
            }
            options.column_scaling = ColumnScaling::Fixed(limits.iter().map(|l| 1.0 / l).collect());
        }
        analyze_identifiability(sub.as_ref(), &sub_names, &options)
            .map_err(CalibError::optim("identifiability analysis"))
    }
}

/// Noise level in weighted units at `x` with `free` unknowns identified: 1
/// with absolute weights, else estimated from the weighted residual
/// `sqrt(sum (w r)^2 / (m - free))` (first at the start, then at each fit).
pub(crate) fn noise_level(
    problem: &impl Residuals,
    weights: &[f64],
    absolute: bool,
    x: &[f64],
    free: usize,
) -> Result<f64, CalibError> {
    if absolute {
        return Ok(1.0);
    }
    let rows = weights.len();
    let mut r = vec![0.0; rows];
    problem.residuals(x, &mut r).map_err(problem_error)?;
    let ssr: f64 = r.iter().zip(weights).map(|(r, w)| (r * w).powi(2)).sum();
    Ok((ssr / (rows.saturating_sub(free).max(1)) as f64).sqrt())
}

/// What an identification found of each unknown, by index.
pub(crate) struct UnknownFlags<'a> {
    /// Kept at its value by the options.
    pub fixed: &'a [bool],
    /// Its column is zero (a frame that no observation sees).
    pub no_influence: &'a [bool],
    /// Left at its starting value by the rank or noise-aware rank.
    pub frozen: &'a [bool],
    /// A combination of others whatever the noise.
    pub exactly_dependent: &'a [bool],
    /// Each compliance's judgement on its own scale.
    pub judgements: &'a [Option<ScaleJudgement>],
}

/// Every unknown `(names, kinds)` with its start and identified value
/// (`(x_initial, report)`, the report giving the values and standard
/// errors), its status from `flags` and its spread ratio: the one place
/// that decides [`UnknownStatus`] for one target and for several.
pub(crate) fn unknown_estimates(
    (names, kinds): (&[String], &[UnknownKind]),
    (x_initial, report): (&[f64], &SolveReport),
    flags: &UnknownFlags<'_>,
    spread_ratios: &[Option<f64>],
) -> Vec<UnknownEstimate> {
    (0..names.len())
        .map(|j| {
            let at_bound = flags.judgements[j]
                .is_some_and(|judgement| judgement.outcome == ScaleOutcome::AtBound);
            let status = if flags.fixed[j] {
                UnknownStatus::Fixed
            } else if at_bound {
                UnknownStatus::AtBound
            } else if flags.no_influence[j] {
                UnknownStatus::NoInfluence
            } else if flags.frozen[j] && flags.exactly_dependent[j] {
                UnknownStatus::NonIdentifiable
            } else if flags.frozen[j] {
                UnknownStatus::PoorlyIdentifiable
            } else {
                UnknownStatus::Identified
            };
            UnknownEstimate {
                name: names[j].clone(),
                kind: kinds[j],
                initial: x_initial[j],
                value: report.x[j],
                standard_error: if status == UnknownStatus::Identified {
                    report.standard_errors[j]
                } else {
                    None
                },
                spread_ratio: spread_ratios[j],
                status,
                judgement: flags.judgements[j],
            }
        })
        .collect()
}

/// The noise level (weighted units) at unknowns `x` with `free` unknowns
/// identified.
pub(crate) type NoiseAt<'a> = dyn Fn(&[f64], usize) -> Result<f64, CalibError> + 'a;

/// What the rounds of a noise-aware identification
/// ([`AnalysisContext::identify_in_rounds`]) start from.
pub(crate) struct Rounds<'a> {
    /// [`AnalysisContext::reduced`] at the start point.
    pub reduced_start: &'a Mat<f64>,
    /// The start point: nominal robot, frames fitted.
    pub x_start: &'a [f64],
    /// Fixed unknowns and those without influence.
    pub excluded: &'a dyn Fn(usize) -> bool,
    /// Left at their start before any fit: cyclic errors over less than
    /// their period, compliances of barely loaded joints.
    pub partial_period: &'a [bool],
    /// Whether the row weights are absolute (the noise level is then 1).
    pub absolute: bool,
    /// [`crate::CalibrationOptions::require_full_rank`].
    pub require_full_rank: bool,
    /// Number of unknowns not excluded.
    pub free_count: usize,
    /// Index of the first joint-term unknown (the number of unknowns
    /// without joint terms).
    pub joint_start: usize,
    /// The kind of every unknown (the compliances are judged on their own
    /// scale, [`crate::significance`]).
    pub kinds: &'a [UnknownKind],
    /// [`crate::CalibrationOptions::min_compliance_z`].
    pub min_compliance_z: f64,
    /// Per unknown, for a joint law's hardening: its compliance's index
    /// and its joint's largest torque (the monotone bound,
    /// [`crate::significance::hardening_floors`]).
    pub hardening_floors: &'a [Option<(usize, f64)>],
    /// The coupling groups' matrices among the unknowns (held positive
    /// semi-definite, [`crate::coupling`]).
    pub coupling_matrices: &'a [crate::coupling::MatrixIndices],
    /// How the judgement of the compliances updates the fit
    /// ([`crate::CalibrationOptions::prediction_only`]).
    pub judge_update: crate::significance::JudgeUpdate,
}

/// What the rounds of [`AnalysisContext::identify_in_rounds`] found: the
/// final fit, the unknowns left at their start (or bound), those exactly
/// dependent on others, the numerical analysis (no noise) that found
/// them, and each compliance's judgement on its own scale.
pub(crate) struct RoundsOutcome {
    pub report: SolveReport,
    pub frozen: Vec<bool>,
    pub exactly_dependent: Vec<bool>,
    pub numerical: IdentifiabilityReport,
    pub judgements: Vec<Option<ScaleJudgement>>,
}

impl AnalysisContext<'_> {
    /// The identification's rounds: unknowns beyond the numerical rank are
    /// left out whatever the noise; then the base set at the noise level
    /// (estimated from the residual unless the weights are absolute) is
    /// solved, the noise estimated again from the fit, and the base set
    /// solved again only if it changes (at most 4 rounds). The joint terms
    /// are non-linear in their unknowns: their standard-error limits are
    /// checked again at the solution, and a term beyond them is put back
    /// to its starting value and the rest solved again. Last, the
    /// compliances are judged on their own scale
    /// ([`crate::significance`]) and the joint laws held monotone.
    ///
    /// # Errors
    /// [`CalibError::NothingToIdentify`], [`CalibError::RankDeficient`]
    /// (with `require_full_rank`), and what `noise_at` and `solve` return.
    pub(crate) fn identify_in_rounds(
        &self,
        r: &Rounds<'_>,
        noise_at: &NoiseAt<'_>,
        solve: &mut Solve<'_>,
    ) -> Result<RoundsOutcome, CalibError> {
        let n = self.names.len();
        let excluded = r.excluded;
        // Unknowns beyond the numerical rank whatever the noise (exact
        // dependencies).
        let numerical = self.analyse(r.reduced_start, None, excluded)?;
        let mut exactly_dependent = vec![false; n];
        for &j in &numerical.non_identifiable {
            exactly_dependent[analysis_index(&numerical, j, self.names)] = true;
        }
        let mut sigma = noise_at(r.x_start, r.free_count)?;
        // Solve, re-estimate the noise from the fit, and solve again only if
        // the base set then changes (relative weights: the first estimate
        // includes the model error of the nominal robot).
        let mut previous: Option<(Vec<usize>, SolveReport, Vec<bool>)> = None;
        let mut round = 0;
        let (report, frozen) = loop {
            round += 1;
            let analysis = self.analyse(r.reduced_start, Some(sigma), &|j| {
                excluded(j) || exactly_dependent[j] || r.partial_period[j]
            })?;
            let mut base = analysis.base.clone();
            base.sort_unstable();
            // A later round starts from the previous fit, its newly frozen
            // unknowns put back at their starting values: the base set
            // changes by a few unknowns, so most of the way is already done.
            let mut warm: Option<(Vec<f64>, Vec<bool>)> = None;
            if let Some((previous_base, report, frozen)) = previous.take() {
                if previous_base == base || round > 4 {
                    break (report, frozen);
                }
                warm = Some((report.x, frozen));
            }
            let mut frozen = vec![true; n];
            for &b in &analysis.base {
                frozen[analysis_index(&analysis, b, self.names)] = false;
            }
            if frozen.iter().all(|f| *f) {
                return Err(CalibError::NothingToIdentify);
            }
            if r.require_full_rank && frozen.iter().enumerate().any(|(j, f)| *f && !excluded(j)) {
                return Err(CalibError::RankDeficient {
                    rank: analysis.rank,
                    unknowns: r.free_count,
                    non_identifiable: (0..n)
                        .filter(|&j| frozen[j] && !excluded(j))
                        .map(|j| self.names[j].clone())
                        .collect(),
                });
            }
            let mut x0 = r.x_start.to_vec();
            if let Some((x_previous, frozen_previous)) = &warm {
                for j in 0..n {
                    if !frozen[j] && !frozen_previous[j] {
                        x0[j] = x_previous[j];
                    }
                }
            }
            let report = solve(&x0, &frozen)?;
            if r.absolute {
                break (report, frozen);
            }
            sigma = noise_at(&report.x, analysis.rank)?;
            previous = Some((base, report, frozen));
        };
        let (report, frozen) = self.hold_joint_terms_within_limits(r, (report, frozen), solve)?;
        let compliance: Vec<bool> = r
            .kinds
            .iter()
            .map(|k| *k == UnknownKind::Compliance)
            .collect();
        // A coupling's off-diagonal entry has no sign: its group's matrix
        // is bounded instead.
        let nonnegative: Vec<bool> = self
            .names
            .iter()
            .map(|n| !crate::gravity::is_coupling_compliance(n))
            .collect();
        let (report, frozen, judgements) = judge_compliances(
            &Judging {
                compliance: &compliance,
                nonnegative: &nonnegative,
                limits: self.limits,
                z_min: r.min_compliance_z,
                x_start: r.x_start,
                update: r.judge_update,
                absolute: r.absolute,
            },
            (report, frozen),
            solve,
        )?;
        let (report, frozen, judgements) =
            hold_monotone_laws(r.hardening_floors, (report, frozen, judgements), solve)?;
        let (report, frozen, judgements) = crate::coupling::hold_positive_semidefinite(
            r.coupling_matrices,
            (report, frozen, judgements),
            solve,
        )?;
        Ok(RoundsOutcome {
            report,
            frozen,
            exactly_dependent,
            numerical,
            judgements,
        })
    }

    /// The joint terms (from `r.joint_start` on) whose standard error
    /// exceeds their limit, or is unknown, frozen at their start and the
    /// fit solved again; up to three times.
    ///
    /// # Errors
    /// What `solve` returns.
    fn hold_joint_terms_within_limits(
        &self,
        r: &Rounds<'_>,
        (mut report, mut frozen): (SolveReport, Vec<bool>),
        solve: &mut Solve<'_>,
    ) -> Result<(SolveReport, Vec<bool>), CalibError> {
        for _ in 0..3 {
            let beyond: Vec<usize> = (r.joint_start..self.names.len())
                .filter(|&j| {
                    !frozen[j]
                        && report.standard_errors[j]
                            .is_none_or(|se| se.is_nan() || se > self.limits[j])
                })
                .collect();
            if beyond.is_empty() {
                break;
            }
            let mut x0 = report.x.clone();
            for &j in &beyond {
                frozen[j] = true;
                x0[j] = r.x_start[j];
            }
            report = solve(&x0, &frozen)?;
        }
        Ok((report, frozen))
    }
}

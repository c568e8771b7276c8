//! The outcomes of the identification workflows as text for people (what
//! `flexcal identify stiffness` and `flexcal identify compliance` print):
//! deflections and residuals in mm, loads in N.

use std::fmt::Write as _;

use super::{ComplianceOutcome, ComplianceStructure, ComplianceWorkflowOptions, StiffnessOutcome};
use crate::fuzzy_compliance::ComplianceComponent;

impl StiffnessOutcome {
    /// The training sets, the global search and the Levenberg-Marquardt
    /// solve, criterion (67), the identified Gamma with its sensitivities,
    /// the identifiability, the per-load residuals (Table 5) and the noise
    /// floor.
    pub fn summary_text(&self) -> String {
        let fitted = &self.fitted;
        let s = &fitted.solve;
        let mut out = String::new();
        let _ = writeln!(out, "training sets: {}", self.train_sets.join(", "));
        let _ = writeln!(
            out,
            "global search: {} evaluations, best mean squared weighted residual {:.4e}",
            fitted.global_search_evaluations, fitted.global_search_value
        );
        let _ = writeln!(
            out,
            "Levenberg-Marquardt: {:?} after {} iterations ({} residual evaluations), rank {} of {} free, cond {:.3e}",
            s.termination,
            s.iterations,
            s.residual_evaluations,
            s.rank,
            s.n_free,
            s.condition_number
        );
        let _ = writeln!(
            out,
            "criterion (67) C(Gamma) = {:.5} mm^2 on the training sets",
            fitted.criterion_mm2
        );
        let _ = writeln!(out, "identified Gamma:");
        for (j, name) in fitted.names.iter().enumerate() {
            let sens = fitted.identifiability.sensitivity[j];
            let _ = writeln!(
                out,
                "  {name:<10} {:>12.4e} {:<8} (sensitivity {:.3e} sigma per ln unit)",
                fitted.gamma[j], fitted.units[j], sens
            );
        }
        let _ = writeln!(out, "identifiability:");
        for line in fitted.identifiability.describe() {
            let _ = writeln!(out, "  {line}");
        }
        let _ = writeln!(
            out,
            "residuals of the identified model, per load (both directions pooled; train load {} N):",
            self.report.train_load_n
        );
        let _ = writeln!(out, "{}", self.table);
        let _ = writeln!(
            out,
            "noise floor (RMS norm of the deflection noise, from the files' standard deviations): {:.4} mm",
            self.noise_floor_mm
        );
        out
    }
}

impl ComplianceOutcome {
    /// The inputs and training sets, the structure found and its search,
    /// the RMSE on training and test configurations, the rule base of C_xx
    /// (Table 4), the per-load residuals in the x-z plane (Table 5) and the
    /// noise floor; `options` are the ones the outcome was identified with.
    pub fn summary_text(&self, options: &ComplianceWorkflowOptions) -> String {
        let mut out = String::new();
        let names: Vec<&str> = options.inputs.iter().map(|s| s.trim()).collect();
        let _ = writeln!(
            out,
            "fuzzy compliance (C_xx, C_xz, C_zx, C_zz) of ({}) identified on {} deflections ({}), split seed {}",
            names.join(", "),
            self.training_samples,
            self.train_sets.join(", "),
            options.seed
        );
        let model = &self.fitted.compliance;
        let r = &self.fitted.report;
        let grid: Vec<String> = model.models()[0]
            .structure()
            .membership_counts()
            .iter()
            .map(usize::to_string)
            .collect();
        let _ = writeln!(
            out,
            "{} training + {} test configurations; structure {} ({} rules per component{}), growth stopped: {:?}",
            r.training_configurations,
            r.test_configurations,
            grid.join(" x "),
            model.models()[0].conclusions().len(),
            if options.structure == ComplianceStructure::Shared {
                ", shared"
            } else {
                " for C_xx"
            },
            r.search.termination
        );
        let _ = writeln!(
            out,
            "{} fits, {} Solis-Wets placements, {:.3} s; RMSE per displacement component: training {:.4} mm, test {:.4} mm; cond >= {:.2e}",
            r.search.evaluations,
            r.search.placement_runs,
            r.elapsed_s,
            r.training_mm.rmse,
            r.test_mm.rmse,
            r.conclusions.condition_lower_bound.unwrap_or(f64::NAN)
        );
        let _ = writeln!(out, "rule base of C_xx (Table 4):");
        if let Some(table) = model.rule_base_table(ComplianceComponent::plane_xz()[0]) {
            out += &table;
        }
        let _ = writeln!(
            out,
            "fuzzy model residuals in the x-z plane, per load (both directions pooled; train load {} N) (Table 5):",
            options.train_load_n
        );
        let _ = writeln!(out, "{}", self.table);
        let _ = writeln!(
            out,
            "measurement-noise floor (RMS norm of the stated deflection noise in the x-z plane): {:.4} mm; overall RMS / floor = {:.2}",
            self.noise_floor_mm,
            self.table.overall_rms_mm / self.noise_floor_mm
        );
        out
    }
}

//! The fitted fuzzy compliance model: one Takagi-Sugeno model per
//! compliance component, evaluated into the compliance matrix (38) and the
//! displacement under a wrench (70).

use std::fmt::Write as _;

use flexcal_fuzzy::FuzzyModel;
use nalgebra::{Matrix6, Vector3, Vector6};

use super::components::{Axis, ComplianceComponent, FIT_SCALE, InputSpec};
use super::error::{FuzzyComplianceError, Result};
use super::samples::ComplianceSample;
use crate::metrics::ResidualSample;

/// A fitted fuzzy compliance model: one single-output fuzzy model per
/// compliance component, all of the same named inputs (SI). Immutable;
/// evaluation needs no workspace.
#[derive(Debug, Clone, PartialEq)]
pub struct FuzzyCompliance {
    inputs: Vec<InputSpec>,
    components: Vec<ComplianceComponent>,
    models: Vec<FuzzyModel>,
}

impl FuzzyCompliance {
    /// A model from its inputs, components and one fuzzy model per component
    /// (inputs in SI, conclusions in the component's SI unit). Each model's
    /// inputs must be `inputs`' names in order and its output named after
    /// its component ([`ComplianceComponent::name`]).
    ///
    /// # Errors
    /// Empty or repeated inputs or components, mismatched lengths or names.
    pub fn new(
        inputs: Vec<InputSpec>,
        components: Vec<ComplianceComponent>,
        models: Vec<FuzzyModel>,
    ) -> Result<Self> {
        check_inputs_and_components(&inputs, &components)?;
        if models.len() != components.len() {
            return Err(FuzzyComplianceError::Inconsistent {
                message: format!(
                    "{} fuzzy model(s) for {} component(s)",
                    models.len(),
                    components.len()
                ),
            });
        }
        let names: Vec<String> = inputs.iter().map(|i| i.name.clone()).collect();
        for (model, component) in models.iter().zip(&components) {
            if model.input_names() != names.as_slice() {
                return Err(FuzzyComplianceError::Inconsistent {
                    message: format!(
                        "model of '{}' has inputs {:?}, expected {:?}",
                        component.name(),
                        model.input_names(),
                        names
                    ),
                });
            }
            if model.output_name() != component.name() {
                return Err(FuzzyComplianceError::Inconsistent {
                    message: format!(
                        "model output '{}' should be named '{}'",
                        model.output_name(),
                        component.name()
                    ),
                });
            }
        }
        Ok(Self {
            inputs,
            components,
            models,
        })
    }

    /// Inputs (names and units).
    pub fn inputs(&self) -> &[InputSpec] {
        &self.inputs
    }

    /// Input names, in order.
    pub fn input_names(&self) -> Vec<&str> {
        self.inputs.iter().map(|i| i.name.as_str()).collect()
    }

    /// Modelled components.
    pub fn components(&self) -> &[ComplianceComponent] {
        &self.components
    }

    /// One fuzzy model per component (SI), in the order of
    /// [`components`](Self::components).
    pub fn models(&self) -> &[FuzzyModel] {
        &self.models
    }

    /// The model of `component`, if modelled.
    pub fn model(&self, component: ComplianceComponent) -> Option<&FuzzyModel> {
        self.components
            .iter()
            .position(|&c| c == component)
            .map(|k| &self.models[k])
    }

    /// Displacement axes the model predicts (rows holding a component),
    /// sorted.
    pub fn displacement_axes(&self) -> Vec<Axis> {
        let mut axes: Vec<Axis> = self.components.iter().map(|c| c.displacement).collect();
        axes.sort();
        axes.dedup();
        axes
    }

    /// The compliance matrix `C` of equation (38) (SI, base axes, twist and
    /// wrench ordered `[linear; angular]`) at input values `x`; entries
    /// that are not modelled are zero.
    ///
    /// # Errors
    /// A wrong number of inputs or a non-finite input.
    pub fn compliance_matrix(&self, x: &[f64]) -> Result<Matrix6<f64>> {
        let mut c = Matrix6::zeros();
        for (component, model) in self.components.iter().zip(&self.models) {
            c[(component.displacement.index(), component.wrench.index())] = model.evaluate(x)?;
        }
        Ok(c)
    }

    /// Elastic displacement `dS = C(x) W` (m, rad) under the TCP wrench
    /// `wrench` `[N; N.m]` (equations (38), (70)).
    ///
    /// # Errors
    /// As [`compliance_matrix`](Self::compliance_matrix).
    pub fn displacement(&self, x: &[f64], wrench: &Vector6<f64>) -> Result<Vector6<f64>> {
        let mut d = Vector6::zeros();
        for (component, model) in self.components.iter().zip(&self.models) {
            d[component.displacement.index()] +=
                model.evaluate(x)? * wrench[component.wrench.index()];
        }
        Ok(d)
    }

    /// The rule base of one component like the paper's Table 4: the modal
    /// values of each input's membership functions (deg or mm) and the
    /// conclusion `b^i` (mm/kN...), one line per rule, last input varying
    /// fastest. `None` when the component is not modelled.
    pub fn rule_base_table(&self, component: ComplianceComponent) -> Option<String> {
        let model = self.model(component)?;
        let structure = model.structure();
        let mut text = String::new();
        let _ = write!(text, "{:>5}", "rule");
        for spec in &self.inputs {
            let (_, unit) = spec.unit.table_unit();
            let _ = write!(text, " {:>16}", format!("c_{} ({unit})", spec.name));
        }
        let _ = writeln!(text, " {:>14}", format!("b ({})", component.table_unit()));
        for (rule, &b) in model.conclusions().iter().enumerate() {
            let memberships = structure.rule_memberships(rule)?;
            let _ = write!(text, "{:>5}", rule + 1);
            for ((spec, partition), &k) in self
                .inputs
                .iter()
                .zip(structure.partitions())
                .zip(&memberships)
            {
                let (factor, _) = spec.unit.table_unit();
                let _ = write!(text, " {:>16.2}", partition.modal_values()[k] * factor);
            }
            let _ = writeln!(text, " {:>14.3}", b * FIT_SCALE);
        }
        Some(text)
    }

    /// Residuals `predicted - measured` (m) of `samples`, restricted to the
    /// displacement axes the model predicts (the others are zero: an
    /// in-plane model is judged in its plane), with their load magnitudes,
    /// for [`crate::metrics::per_load_metrics`].
    ///
    /// # Errors
    /// A sample with the wrong number of inputs or a non-finite value.
    pub fn residual_samples(&self, samples: &[ComplianceSample]) -> Result<Vec<ResidualSample>> {
        let axes = self.displacement_axes();
        samples
            .iter()
            .enumerate()
            .map(|(k, s)| {
                if s.inputs.len() != self.inputs.len() {
                    return Err(FuzzyComplianceError::InputCount {
                        sample: k,
                        pose_id: s.pose_id,
                        expected: self.inputs.len(),
                        found: s.inputs.len(),
                    });
                }
                let predicted = self.displacement(&s.inputs, &s.wrench)?;
                let mut residual = Vector3::zeros();
                for a in axes.iter().filter(|a| a.is_linear()) {
                    residual[a.index()] = predicted[a.index()] - s.deflection[a.index()];
                }
                Ok(ResidualSample {
                    load_n: s.load_n(),
                    residual,
                })
            })
            .collect()
    }
}

/// At least one input and one component, each named once.
pub(crate) fn check_inputs_and_components(
    inputs: &[InputSpec],
    components: &[ComplianceComponent],
) -> Result<()> {
    if inputs.is_empty() {
        return Err(FuzzyComplianceError::NoInputs);
    }
    if components.is_empty() {
        return Err(FuzzyComplianceError::NoComponents);
    }
    check_unique(inputs.iter().map(|i| i.name.clone()))?;
    check_unique(components.iter().map(|c| c.name()))
}

pub(crate) fn check_unique(names: impl Iterator<Item = String>) -> Result<()> {
    let mut seen = Vec::new();
    for name in names {
        if seen.contains(&name) {
            return Err(FuzzyComplianceError::Duplicate { name });
        }
        seen.push(name);
    }
    Ok(())
}

//! Fuzzy compliance files (TOML): format, inputs with units, and one table
//! per component with its unit, modal values and conclusions (SI).

use std::path::Path;

use flexcal_fuzzy::{FuzzyModel, FuzzyStructure, Partition};
use serde::{Deserialize, Serialize};

use super::components::{Axis, ComplianceComponent, InputSpec};
use super::error::{FuzzyComplianceError, Result};
use super::model::FuzzyCompliance;

/// Identifier written in the `format` key of fuzzy compliance files.
pub const COMPLIANCE_FORMAT: &str = "flexcal-fuzzy-compliance-0";

impl FuzzyCompliance {
    /// The model as TOML text: format, inputs with units, and one table per
    /// component with its unit, modal values and conclusions (SI). Numbers
    /// round-trip exactly.
    pub fn to_toml_string(&self) -> String {
        let file = ComplianceFile {
            format: COMPLIANCE_FORMAT.into(),
            version: 1,
            inputs: self.inputs().to_vec(),
            components: self
                .components()
                .iter()
                .zip(self.models())
                .map(|(c, m)| ComponentFile {
                    name: c.name(),
                    displacement: c.displacement,
                    wrench: c.wrench,
                    unit: c.si_unit().into(),
                    modal_values: m
                        .structure()
                        .partitions()
                        .iter()
                        .map(|p| p.modal_values().to_vec())
                        .collect(),
                    conclusions: m.conclusions().to_vec(),
                })
                .collect(),
        };
        // Strings, enums and finite numbers always serialise.
        toml::to_string(&file).unwrap_or_default()
    }

    /// Reads a model from TOML text; `origin` names the source in errors.
    ///
    /// # Errors
    /// Malformed TOML, another format, invalid modal values or conclusions,
    /// a unit or name that does not match its component.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self> {
        let bad = |message: String| FuzzyComplianceError::File {
            path: origin.into(),
            message,
        };
        let file: ComplianceFile = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
        if file.format != COMPLIANCE_FORMAT {
            return Err(bad(format!(
                "format '{}', expected '{COMPLIANCE_FORMAT}'",
                file.format
            )));
        }
        if file.version != 1 {
            return Err(bad(format!("version {}, expected 1", file.version)));
        }
        let names: Vec<String> = file.inputs.iter().map(|i| i.name.clone()).collect();
        let mut components = Vec::with_capacity(file.components.len());
        let mut models = Vec::with_capacity(file.components.len());
        for c in file.components {
            let component = ComplianceComponent::new(c.displacement, c.wrench);
            if c.name != component.name() {
                return Err(bad(format!(
                    "component '{}' has axes {} / {}: it should be named '{}'",
                    c.name,
                    c.displacement.name(),
                    c.wrench.wrench_name(),
                    component.name()
                )));
            }
            if c.unit != component.si_unit() {
                return Err(bad(format!(
                    "component '{}': unit '{}', expected '{}'",
                    c.name,
                    c.unit,
                    component.si_unit()
                )));
            }
            if c.modal_values.len() != names.len() {
                return Err(bad(format!(
                    "component '{}': {} list(s) of modal values for {} input(s)",
                    c.name,
                    c.modal_values.len(),
                    names.len()
                )));
            }
            let partitions = c
                .modal_values
                .into_iter()
                .zip(&names)
                .map(|(values, name)| {
                    Partition::new(values)
                        .map_err(|e| bad(format!("component '{}', input '{name}': {e}", c.name)))
                })
                .collect::<Result<Vec<_>>>()?;
            let structure = FuzzyStructure::new(names.clone(), partitions)
                .map_err(|e| bad(format!("component '{}': {e}", c.name)))?;
            let model = FuzzyModel::new(structure, c.name.clone(), c.conclusions)
                .map_err(|e| bad(format!("component '{}': {e}", c.name)))?;
            components.push(component);
            models.push(model);
        }
        Self::new(file.inputs, components, models).map_err(|e| bad(e.to_string()))
    }

    /// Writes the TOML text to `path` atomically.
    ///
    /// # Errors
    /// I/O errors naming the file.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<()> {
        flexcal_io::write_atomic(path, self.to_toml_string())?;
        Ok(())
    }

    /// Reads a file written by [`write`](Self::write).
    ///
    /// # Errors
    /// I/O errors and the errors of [`from_toml_str`](Self::from_toml_str).
    pub fn read(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = flexcal_io::read_to_string(path)?;
        Self::from_toml_str(&text, &path.display().to_string())
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ComplianceFile {
    format: String,
    version: u32,
    inputs: Vec<InputSpec>,
    components: Vec<ComponentFile>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ComponentFile {
    name: String,
    displacement: Axis,
    wrench: Axis,
    /// SI unit of the conclusions.
    unit: String,
    /// Modal values of each input (SI), in input order.
    modal_values: Vec<Vec<f64>>,
    /// Conclusions (SI), last input varying fastest.
    conclusions: Vec<f64>,
}

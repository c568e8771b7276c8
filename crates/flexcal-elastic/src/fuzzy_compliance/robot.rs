//! A fuzzy compliance model bound to its robot: the elastic model that
//! compensation evaluates along a path.

use flexcal_kinematics::Model;
use nalgebra::Vector6;

use super::error::{FuzzyComplianceError, Result};
use super::inputs::RobotInputs;
use super::model::FuzzyCompliance;
use crate::tcp::{DeflectionError, TcpDeflection};

/// A fuzzy compliance model bound to its robot: the
/// [`TcpDeflection`] that compensation evaluates along a path.
/// The inputs are computed from the actuated coordinates; the modelled
/// components are applied to the wrench, the other displacement components
/// are zero. The robot's own weight is not included (the model is learnt
/// from loaded minus unloaded poses).
#[derive(Debug, Clone)]
pub struct RobotFuzzyCompliance {
    compliance: FuzzyCompliance,
    robot: Model,
    inputs: RobotInputs,
}

impl RobotFuzzyCompliance {
    /// Binds `compliance` to `robot`, resolving its input names.
    ///
    /// # Errors
    /// An input the robot does not have, or whose unit differs from the one
    /// stored in the model.
    pub fn new(compliance: FuzzyCompliance, robot: Model) -> Result<Self> {
        let names = compliance.input_names();
        let inputs = RobotInputs::resolve(&robot, &names)?;
        for (stored, resolved) in compliance.inputs().iter().zip(inputs.specs()) {
            if stored.unit != resolved.unit {
                return Err(FuzzyComplianceError::Inconsistent {
                    message: format!(
                        "input '{}' is in {} in the model but in {} on robot '{}'",
                        stored.name,
                        stored.unit.symbol(),
                        resolved.unit.symbol(),
                        robot.name()
                    ),
                });
            }
        }
        Ok(Self {
            compliance,
            robot,
            inputs,
        })
    }

    /// The compliance model.
    pub fn compliance(&self) -> &FuzzyCompliance {
        &self.compliance
    }

    /// The robot.
    pub fn robot(&self) -> &Model {
        &self.robot
    }

    /// The resolved inputs.
    pub fn inputs(&self) -> &RobotInputs {
        &self.inputs
    }

    /// Elastic TCP displacement `[dp; dphi]` (m, rad) of configuration `q`
    /// under the TCP wrench `wrench_base` (base axes).
    ///
    /// # Errors
    /// As [`RobotInputs::values`] and [`FuzzyCompliance::displacement`].
    pub fn displacement(&self, q: &[f64], wrench_base: &Vector6<f64>) -> Result<Vector6<f64>> {
        let x = self.inputs.values(&self.robot, q)?;
        self.compliance.displacement(&x, wrench_base)
    }
}

/// Workspace of a [`RobotFuzzyCompliance`]: the input values of the last
/// evaluation.
#[derive(Debug, Clone, Default)]
pub struct RobotFuzzyWorkspace {
    inputs: Vec<f64>,
}

impl TcpDeflection for RobotFuzzyCompliance {
    type Workspace = RobotFuzzyWorkspace;

    fn describe(&self) -> String {
        let components: Vec<String> = self
            .compliance
            .components()
            .iter()
            .zip(self.compliance.models())
            .map(|(c, m)| {
                let counts: Vec<String> = m
                    .structure()
                    .membership_counts()
                    .iter()
                    .map(usize::to_string)
                    .collect();
                format!(
                    "{} ({} rules, {})",
                    c.name(),
                    m.conclusions().len(),
                    counts.join(" x ")
                )
            })
            .collect();
        format!(
            "fuzzy compliance of robot '{}' in ({}): {}",
            self.robot.name(),
            self.compliance.input_names().join(", "),
            components.join(", ")
        )
    }

    fn workspace(&self) -> std::result::Result<RobotFuzzyWorkspace, DeflectionError> {
        Ok(RobotFuzzyWorkspace {
            inputs: vec![0.0; self.inputs.specs().len()],
        })
    }

    fn tcp_displacement(
        &self,
        workspace: &mut RobotFuzzyWorkspace,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> std::result::Result<Vector6<f64>, DeflectionError> {
        workspace.inputs.resize(self.inputs.specs().len(), 0.0);
        self.inputs
            .values_into(&self.robot, q, &mut workspace.inputs)?;
        Ok(self
            .compliance
            .displacement(&workspace.inputs, wrench_base)?)
    }
}

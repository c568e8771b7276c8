//! The model inputs resolved against a robot: joint coordinates computed
//! from the actuated coordinates `q`.

use flexcal_kinematics::{ActuatedKind, Model, joint_angles_from_actuated};

use super::components::{InputSpec, InputUnit};
use super::error::{FuzzyComplianceError, Result};

/// Where an input's value comes from in a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputSource {
    /// Actuated coordinate `q[k]` as it is (rad or m).
    Actuated(usize),
    /// Joint angle of the slider-crank joint driven by `q[k]` (rad), through
    /// the nominal screw relation ([`joint_angles_from_actuated`]).
    JointAngle(usize),
}

/// The model inputs resolved against a robot: how to compute them from the
/// actuated coordinates `q`.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotInputs {
    specs: Vec<InputSpec>,
    sources: Vec<InputSource>,
    n_actuated: usize,
}

impl RobotInputs {
    /// Resolves input names against `robot`. A name is either an actuated
    /// coordinate (`theta1`, `r2p`: taken as it is, in rad or m) or
    /// `theta<frame>` for a joint driven by a slider crank (`theta2`,
    /// `theta8` on the IR-663: the joint angle, in rad).
    ///
    /// # Errors
    /// No name, a repeated name, a name the robot does not have (the error
    /// lists the valid names).
    pub fn resolve(robot: &Model, names: &[&str]) -> Result<Self> {
        if names.is_empty() {
            return Err(FuzzyComplianceError::NoInputs);
        }
        let mut candidates: Vec<(String, InputSpec, InputSource)> = Vec::new();
        for (k, (name, kind)) in robot
            .actuated_names()
            .iter()
            .zip(robot.actuated_kinds())
            .enumerate()
        {
            let unit = match kind {
                ActuatedKind::Revolute => InputUnit::Rad,
                ActuatedKind::Prismatic | ActuatedKind::Screw => InputUnit::M,
            };
            candidates.push((
                name.clone(),
                InputSpec {
                    name: name.clone(),
                    unit,
                },
                InputSource::Actuated(k),
            ));
        }
        // Joint angles of slider-crank joints are named after their frame.
        let description = robot.description_with_params(robot.nominal_params())?;
        for frame in description.frames.iter().filter(|f| f.actuated) {
            if frame.slider_crank.is_none() {
                continue;
            }
            let actuated = frame
                .actuated_name
                .clone()
                .unwrap_or_else(|| format!("r{}p", frame.name));
            if let Some(k) = robot.actuated_names().iter().position(|n| *n == actuated) {
                let name = format!("theta{}", frame.name);
                if !candidates.iter().any(|c| c.0 == name) {
                    candidates.push((
                        name.clone(),
                        InputSpec::radians(&name),
                        InputSource::JointAngle(k),
                    ));
                }
            }
        }
        let mut specs = Vec::with_capacity(names.len());
        let mut sources = Vec::with_capacity(names.len());
        for (i, &name) in names.iter().enumerate() {
            if names[..i].contains(&name) {
                return Err(FuzzyComplianceError::Duplicate { name: name.into() });
            }
            let Some((_, spec, source)) = candidates.iter().find(|c| c.0 == name) else {
                return Err(FuzzyComplianceError::UnknownInput {
                    name: name.into(),
                    robot: robot.name().into(),
                    known: candidates
                        .iter()
                        .map(|c| c.0.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            };
            specs.push(spec.clone());
            sources.push(*source);
        }
        Ok(Self {
            specs,
            sources,
            n_actuated: robot.n_actuated(),
        })
    }

    /// Names and units of the inputs.
    pub fn specs(&self) -> &[InputSpec] {
        &self.specs
    }

    /// Where each input comes from.
    pub fn sources(&self) -> &[InputSource] {
        &self.sources
    }

    /// Input values (SI) of configuration `q` (actuated coordinates, rad or
    /// m).
    ///
    /// # Errors
    /// A `q` of the wrong length or not finite, a screw length out of its
    /// slider crank's range.
    pub fn values(&self, robot: &Model, q: &[f64]) -> Result<Vec<f64>> {
        let mut out = vec![0.0; self.sources.len()];
        self.values_into(robot, q, &mut out)?;
        Ok(out)
    }

    /// [`values`](Self::values) written into `out` (one value per input).
    ///
    /// # Errors
    /// As [`values`](Self::values), and an `out` of the wrong length.
    pub fn values_into(&self, robot: &Model, q: &[f64], out: &mut [f64]) -> Result<()> {
        if q.len() != self.n_actuated
            || robot.n_actuated() != self.n_actuated
            || out.len() != self.sources.len()
        {
            return Err(FuzzyComplianceError::Inconsistent {
                message: format!(
                    "q has {} value(s), the robot '{}' has {} actuated coordinates (inputs resolved for {}); {} output(s) for {} input(s)",
                    q.len(),
                    robot.name(),
                    robot.n_actuated(),
                    self.n_actuated,
                    out.len(),
                    self.sources.len()
                ),
            });
        }
        let joints = if self
            .sources
            .iter()
            .any(|s| matches!(s, InputSource::JointAngle(_)))
        {
            Some(joint_angles_from_actuated(robot, q)?)
        } else {
            None
        };
        for (o, s) in out.iter_mut().zip(&self.sources) {
            *o = match (s, &joints) {
                (InputSource::JointAngle(k), Some(j)) => j[*k],
                (InputSource::JointAngle(k), None) | (InputSource::Actuated(k), _) => q[*k],
            };
        }
        Ok(())
    }
}

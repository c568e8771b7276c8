//! Fuzzy compliance model of a robot: the components of the TCP compliance
//! matrix as zero-order Takagi-Sugeno models of chosen joint coordinates,
//! learnt from measured deflections under known loads (section 2.2.2 and
//! section 3.3.2 of the reference paper, S. Marie, E. Courteille,
//! P. Maurine, Mechanism and Machine Theory 69 (2013) 13-43).
//!
//! # Equations
//! - (38): `dS = C(q) F`: the TCP's elastic displacement is the compliance
//!   matrix of the configuration applied to the TCP wrench. Each modelled
//!   component `C_dw` (displacement axis `d`, wrench axis `w`) is one
//!   single-output fuzzy model ([`flexcal_fuzzy::FuzzyModel`], equations
//!   (33)-(37)) of the chosen inputs; components not modelled are zero.
//! - (70): in the vertical plane of the IR-663,
//!   `dx = C_xx(theta2, theta8) fx + C_xz fz`,
//!   `dz = C_zx fx + C_zz fz` ([`ComplianceComponent::plane_xz`]).
//!
//! A measured displacement is linear in the conclusions of every component
//! model, so all of them are fitted jointly by least squares
//! ([`flexcal_fuzzy::fit_joint_conclusions`]): a horizontal load informs
//! `C_xx` and `C_zx`, a vertical one `C_xz` and `C_zz`. The membership
//! functions are placed by Solis-Wets and the structure grown within a rule
//! budget, choosing by the error on a test set of configurations
//! ([`flexcal_fuzzy::search_structure`]); by default the four models share
//! one partition grid, as in the paper's Table 4 (4 x 3 = 12 rules).
//!
//! # Units
//! Inputs are SI (rad for angles, m for screw lengths and prismatic
//! joints); conclusions are SI (m/N for a force-to-translation component).
//! The fit itself works in mm and kN so that the conclusions are of order
//! one; [`FuzzyCompliance::rule_base_table`] prints degrees and mm/kN like
//! Table 4.
//!
//! # Example
//! ```
//! use flexcal_elastic::fuzzy_compliance::{
//!     ComplianceComponent, ComplianceFitParams, ComplianceSample, InputSpec, identify_compliance,
//! };
//! use nalgebra::{Vector3, Vector6};
//! // A synthetic plane robot whose compliance varies with two joint angles.
//! let c_xx = |a: f64, b: f64| 1.0e-6 * (1.0 + 0.3 * a + 0.2 * a * b);
//! let c_zz = |a: f64, b: f64| 0.8e-6 * (1.0 + 0.1 * b);
//! let mut samples = Vec::new();
//! for i in 0..8 {
//!     for j in 0..8 {
//!         let (a, b) = (-0.4 + 0.1 * i as f64, 0.5 + 0.08 * j as f64);
//!         for (fx, fz) in [(900.0, 0.0), (0.0, -900.0)] {
//!             samples.push(ComplianceSample {
//!                 pose_id: (8 * i + j) as u64,
//!                 inputs: vec![a, b],
//!                 wrench: Vector6::new(fx, 0.0, fz, 0.0, 0.0, 0.0),
//!                 deflection: Vector3::new(c_xx(a, b) * fx, 0.0, c_zz(a, b) * fz),
//!                 sigma: Vector3::zeros(),
//!             });
//!         }
//!     }
//! }
//! let inputs = vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")];
//! let fit = identify_compliance(
//!     &inputs,
//!     &ComplianceComponent::plane_xz(),
//!     &samples,
//!     &ComplianceFitParams::default(),
//!     &mut |_| {},
//! )?;
//! let c = fit.compliance.compliance_matrix(&[0.05, 0.7])?;
//! assert!((c[(0, 0)] - c_xx(0.05, 0.7)).abs() < 1e-9);
//! assert!(c[(0, 2)].abs() < 1e-9);
//! # Ok::<(), flexcal_elastic::fuzzy_compliance::FuzzyComplianceError>(())
//! ```
//!
//! # Measured accuracy (seeded tests)
//! - A bilinear compliance (noise-free) is reproduced to rounding
//!   (1e-15 m/N) anywhere inside the training range
//!   (`tests/fuzzy_compliance.rs`).
//! - A smooth, non-multilinear compliance of 0.25 to 2 mm/kN with 30 um
//!   noise per deflection component, trained at 900 N on the 7 x 9 grid:
//!   the compliance is within 0.1 mm/kN of the truth and the RMS residual on
//!   300, 600 and 1100 N is within 1.2 times the noise floor.
//! - The twin's elastic campaign (`flexcal twin elastic --seed 7`, split
//!   seed 1, the paper's 90 / 36 protocol; `tests/cli_compliance.rs` in
//!   flexcal-cli): a shared 3 x 3 grid (the search stopped there within the
//!   12-rule budget); RMS of the in-plane residual norm 0.043, 0.042, 0.047,
//!   0.059 mm at 300, 600, 900, 1100 N, 0.048 mm overall, against a noise
//!   floor of 0.042 mm (21 um per coordinate: 1.14 times the floor); the
//!   parametric beam model identified on the same files gives 0.049, 0.064,
//!   0.093, 0.105 mm, 0.081 mm overall, in the same plane.
//!
//! # Speed
//! `cargo bench -p flexcal-elastic --bench fuzzy_compliance` (shared
//! 2-core machine): the four components identified jointly from 126
//! deflections (63 configurations x 2 loads, search up to 12 rules) in
//! 50 ms; the displacement of one configuration (four 2-input models) in
//! 170 ns.
//!
//! # Limitations
//! - Zero-order models: the compliance is piecewise multilinear in the
//!   inputs and constant beyond the outermost modal values (inputs are
//!   clamped); a configuration outside the training range gets the
//!   compliance of the nearest edge.
//! - Only translational displacement axes can be fitted (the measurement
//!   files hold TCP positions); rotational components can be held by a
//!   model built by hand but not identified.
//! - Linearity in the load is assumed (equation (70)); a nonlinear
//!   load-deflection behaviour shows up as residuals growing with load.
//! - The test set chooses the structure, so its error is optimistic;
//!   validate on loads that were not used (the paper's protocol).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use flexcal_fuzzy::{
    ConclusionReport, ErrorStats, FuzzyError, FuzzyModel, FuzzyParams, FuzzyStructure,
    LinearCombinationSet, Partition, SearchProgress, StructureScore, StructureSearchParams,
    StructureSearchReport, fit_joint_conclusions, joint_error_stats, search_structure,
};
use flexcal_kinematics::{ActuatedKind, KinematicsError, Model, joint_angles_from_actuated};
use nalgebra::{Matrix6, Vector3, Vector6};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::campaign::DeflectionMeasurement;
use crate::metrics::ResidualSample;

/// Identifier written in the `format` key of fuzzy compliance files.
pub const COMPLIANCE_FORMAT: &str = "flexcal-fuzzy-compliance-0";

/// Conclusions are fitted in mm (or mrad) per kN (or kN.m): SI values
/// times this factor, so that they are of order one.
const FIT_SCALE: f64 = 1e6;

/// Errors of the fuzzy compliance model. Every variant names what it is
/// about (input, component, sample, setting, file).
#[derive(Debug, thiserror::Error)]
pub enum FuzzyComplianceError {
    /// The fuzzy learner failed (too few samples, singular conclusions,
    /// invalid settings...).
    #[error("fuzzy model: {0}")]
    Fuzzy(#[from] FuzzyError),
    /// The robot geometry failed (slider crank out of range, wrong q).
    #[error("robot geometry: {0}")]
    Kinematics(#[from] KinematicsError),
    /// A file could not be read or written.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// An input name is neither an actuated coordinate nor a joint angle of
    /// the robot.
    #[error("unknown input '{name}' for robot '{robot}' (known: {known})")]
    UnknownInput {
        /// The name asked for.
        name: String,
        /// The robot.
        robot: String,
        /// The names that exist, comma-separated.
        known: String,
    },
    /// The model needs at least one input.
    #[error("a fuzzy compliance model needs at least one input")]
    NoInputs,
    /// The model needs at least one compliance component.
    #[error("a fuzzy compliance model needs at least one compliance component")]
    NoComponents,
    /// An input or a component is listed twice.
    #[error("'{name}' is listed twice")]
    Duplicate {
        /// The repeated input or component name.
        name: String,
    },
    /// An input takes a single value over the training configurations: it
    /// cannot be partitioned.
    #[error(
        "input '{input}' is constant ({value}) over the training configurations: it cannot be partitioned"
    )]
    ConstantInput {
        /// Input name.
        input: String,
        /// Its only value (SI).
        value: f64,
    },
    /// A sample holds a NaN or infinite value.
    #[error("sample {sample} (pose {pose_id}): {field} = {value} is not a finite number")]
    NonFinite {
        /// 0-based sample index.
        sample: usize,
        /// Pose identifier of the sample.
        pose_id: u64,
        /// Which value (input name, wrench or deflection component).
        field: String,
        /// The value.
        value: f64,
    },
    /// A sample has the wrong number of input values.
    #[error(
        "sample {sample} (pose {pose_id}) has {found} input value(s), the model has {expected}"
    )]
    InputCount {
        /// 0-based sample index.
        sample: usize,
        /// Pose identifier of the sample.
        pose_id: u64,
        /// Inputs of the model.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A rotational displacement component cannot be identified from TCP
    /// position measurements.
    #[error(
        "component '{component}': rotations are not measured, only translational components can be identified"
    )]
    RotationNotMeasured {
        /// The component.
        component: String,
    },
    /// No training sample loads the wrench axis of a component: its model
    /// is not determined.
    #[error(
        "component '{component}': no training sample has a non-zero {wrench} load, so it cannot be identified"
    )]
    ComponentNotExcited {
        /// The component.
        component: String,
        /// The wrench axis (`fx`, `mz`, ...).
        wrench: &'static str,
    },
    /// Fewer training configurations than rules: the conclusions are not
    /// determined.
    #[error(
        "component '{component}': {configurations} training configuration(s) load it, fewer than the {rules} rules of the simplest model"
    )]
    TooFewSamples {
        /// The component.
        component: String,
        /// Training configurations loading its wrench axis.
        configurations: usize,
        /// Rules of the simplest model (`2^n`).
        rules: usize,
    },
    /// A setting is out of its documented range.
    #[error("setting '{name}' = {value}: {reason}")]
    InvalidParameter {
        /// Setting name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The range it must respect.
        reason: &'static str,
    },
    /// The parts of a model do not fit together (a component model with
    /// other inputs, a vector of the wrong length...).
    #[error("inconsistent fuzzy compliance model: {message}")]
    Inconsistent {
        /// What is wrong.
        message: String,
    },
    /// A compliance file has wrong content.
    #[error("{path}: {message}")]
    File {
        /// The file (or `inline`).
        path: String,
        /// What is wrong.
        message: String,
    },
}

/// Shorthand for results of this module.
pub type Result<T> = std::result::Result<T, FuzzyComplianceError>;

/// An axis of a twist or wrench, ordered `[linear; angular]`: `X`, `Y`,
/// `Z` are translations (m) or forces (N), `Rx`, `Ry`, `Rz` rotations
/// (rad) or moments (N.m), all in the robot base frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Along x.
    X,
    /// Along y.
    Y,
    /// Along z.
    Z,
    /// About x.
    Rx,
    /// About y.
    Ry,
    /// About z.
    Rz,
}

impl Axis {
    /// The six axes in twist/wrench order.
    pub const ALL: [Axis; 6] = [Axis::X, Axis::Y, Axis::Z, Axis::Rx, Axis::Ry, Axis::Rz];

    /// Index in a twist or wrench vector (0..6).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Whether the axis is a translation / force (not a rotation / moment).
    pub fn is_linear(self) -> bool {
        self.index() < 3
    }

    /// Short name: `x`, `y`, `z`, `rx`, `ry`, `rz`.
    pub fn name(self) -> &'static str {
        ["x", "y", "z", "rx", "ry", "rz"][self.index()]
    }

    /// Name of the wrench component along the axis: `fx` .. `mz`.
    pub fn wrench_name(self) -> &'static str {
        ["fx", "fy", "fz", "mx", "my", "mz"][self.index()]
    }
}

/// One entry `C_dw` of the TCP compliance matrix: the displacement along
/// `displacement` per unit of wrench along `wrench` (m/N, m/(N.m), rad/N or
/// rad/(N.m)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct ComplianceComponent {
    /// Displacement axis (row of the compliance matrix).
    pub displacement: Axis,
    /// Wrench axis (column of the compliance matrix).
    pub wrench: Axis,
}

impl ComplianceComponent {
    /// The component `C_dw`.
    pub fn new(displacement: Axis, wrench: Axis) -> Self {
        Self {
            displacement,
            wrench,
        }
    }

    /// The four in-plane components of equation (70), in the paper's order:
    /// `C_xx`, `C_xz`, `C_zx`, `C_zz`.
    pub fn plane_xz() -> Vec<Self> {
        vec![
            Self::new(Axis::X, Axis::X),
            Self::new(Axis::X, Axis::Z),
            Self::new(Axis::Z, Axis::X),
            Self::new(Axis::Z, Axis::Z),
        ]
    }

    /// The 3 x 3 translational block (force to translation), row by row.
    pub fn translational_block() -> Vec<Self> {
        let linear = [Axis::X, Axis::Y, Axis::Z];
        linear
            .iter()
            .flat_map(|&d| linear.iter().map(move |&w| Self::new(d, w)))
            .collect()
    }

    /// Name used for the component's fuzzy model: `c_xz` when both axes
    /// are linear, `c_x_rz` otherwise.
    pub fn name(&self) -> String {
        if self.displacement.is_linear() && self.wrench.is_linear() {
            format!("c_{}{}", self.displacement.name(), self.wrench.name())
        } else {
            format!("c_{}_{}", self.displacement.name(), self.wrench.name())
        }
    }

    /// Parses a name written by [`name`](Self::name).
    pub fn from_name(name: &str) -> Option<Self> {
        let rest = name.strip_prefix("c_")?;
        let parse = |s: &str| Axis::ALL.into_iter().find(|a| a.name() == s);
        if let Some((d, w)) = rest.split_once('_') {
            return Some(Self::new(parse(d)?, parse(w)?));
        }
        let mut chars = rest.chars();
        let (d, w) = (chars.next()?, chars.next()?);
        if chars.next().is_some() {
            return None;
        }
        Some(Self::new(parse(&d.to_string())?, parse(&w.to_string())?))
    }

    /// SI unit of the component: `m/N`, `m/(N.m)`, `rad/N` or `rad/(N.m)`.
    pub fn si_unit(&self) -> &'static str {
        match (self.displacement.is_linear(), self.wrench.is_linear()) {
            (true, true) => "m/N",
            (true, false) => "m/(N.m)",
            (false, true) => "rad/N",
            (false, false) => "rad/(N.m)",
        }
    }

    /// Unit used in printed tables (SI value times 1e6): `mm/kN`,
    /// `mm/(kN.m)`, `mrad/kN` or `mrad/(kN.m)`.
    pub fn table_unit(&self) -> &'static str {
        match (self.displacement.is_linear(), self.wrench.is_linear()) {
            (true, true) => "mm/kN",
            (true, false) => "mm/(kN.m)",
            (false, true) => "mrad/kN",
            (false, false) => "mrad/(kN.m)",
        }
    }
}

/// Unit of a model input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InputUnit {
    /// An angle (rad); printed in degrees.
    Rad,
    /// A length (m); printed in mm.
    M,
}

impl InputUnit {
    /// SI unit symbol.
    pub fn symbol(self) -> &'static str {
        match self {
            InputUnit::Rad => "rad",
            InputUnit::M => "m",
        }
    }

    /// Factor and symbol of the printed unit (degrees or mm).
    pub fn table_unit(self) -> (f64, &'static str) {
        match self {
            InputUnit::Rad => (180.0 / std::f64::consts::PI, "deg"),
            InputUnit::M => (1e3, "mm"),
        }
    }
}

/// A named model input and its unit.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputSpec {
    /// Input name (an actuated coordinate such as `theta1` or `r2p`, or the
    /// joint angle of a slider-crank joint such as `theta2`).
    pub name: String,
    /// Its unit.
    pub unit: InputUnit,
}

impl InputSpec {
    /// An angle input (rad).
    pub fn radians(name: &str) -> Self {
        Self {
            name: name.into(),
            unit: InputUnit::Rad,
        }
    }

    /// A length input (m).
    pub fn meters(name: &str) -> Self {
        Self {
            name: name.into(),
            unit: InputUnit::M,
        }
    }
}

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
        if q.len() != self.n_actuated || robot.n_actuated() != self.n_actuated {
            return Err(FuzzyComplianceError::Inconsistent {
                message: format!(
                    "q has {} value(s), the robot '{}' has {} actuated coordinates (inputs resolved for {})",
                    q.len(),
                    robot.name(),
                    robot.n_actuated(),
                    self.n_actuated
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
        Ok(self
            .sources
            .iter()
            .map(|s| match (s, &joints) {
                (InputSource::JointAngle(k), Some(j)) => j[*k],
                (InputSource::JointAngle(k), None) | (InputSource::Actuated(k), _) => q[*k],
            })
            .collect())
    }
}

/// One measured deflection expressed with the model's inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct ComplianceSample {
    /// Pose identifier (for messages; configurations are grouped by their
    /// input values).
    pub pose_id: u64,
    /// Input values (SI), in the order of the model's inputs.
    pub inputs: Vec<f64>,
    /// Wrench applied at the TCP `[N; N.m]`, base axes.
    pub wrench: Vector6<f64>,
    /// Measured TCP displacement (m), base axes.
    pub deflection: Vector3<f64>,
    /// Standard deviation of each deflection component (m; zero when
    /// unknown).
    pub sigma: Vector3<f64>,
}

impl ComplianceSample {
    /// Magnitude of the applied force (N).
    pub fn load_n(&self) -> f64 {
        self.wrench.fixed_rows::<3>(0).norm()
    }
}

/// Converts deflection measurements to samples of the model's inputs.
///
/// # Errors
/// As [`RobotInputs::values`], for the first failing measurement.
pub fn compliance_samples(
    robot: &Model,
    inputs: &RobotInputs,
    measurements: &[DeflectionMeasurement],
) -> Result<Vec<ComplianceSample>> {
    measurements
        .iter()
        .map(|m| {
            Ok(ComplianceSample {
                pose_id: m.pose_id,
                inputs: inputs.values(robot, &m.q)?,
                wrench: m.wrench,
                deflection: m.deflection,
                sigma: m.sigma,
            })
        })
        .collect()
}

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
        if inputs.is_empty() {
            return Err(FuzzyComplianceError::NoInputs);
        }
        if components.is_empty() {
            return Err(FuzzyComplianceError::NoComponents);
        }
        check_unique(inputs.iter().map(|i| i.name.clone()))?;
        check_unique(components.iter().map(|c| c.name()))?;
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

    /// The model as TOML text: format, inputs with units, and one table per
    /// component with its unit, modal values and conclusions (SI). Numbers
    /// round-trip exactly.
    pub fn to_toml_string(&self) -> String {
        let file = ComplianceFile {
            format: COMPLIANCE_FORMAT.into(),
            version: 1,
            inputs: self.inputs.clone(),
            components: self
                .components
                .iter()
                .zip(&self.models)
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
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        flexcal_io::write_atomic(path, self.to_toml_string())?;
        Ok(())
    }

    /// Reads a file written by [`save`](Self::save).
    ///
    /// # Errors
    /// I/O errors and the errors of [`from_toml_str`](Self::from_toml_str).
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = flexcal_io::read_to_string(path)?;
        Self::from_toml_str(&text, &path.display().to_string())
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

fn check_unique(names: impl Iterator<Item = String>) -> Result<()> {
    let mut seen = Vec::new();
    for name in names {
        if seen.contains(&name) {
            return Err(FuzzyComplianceError::Duplicate { name });
        }
        seen.push(name);
    }
    Ok(())
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

/// A fuzzy compliance model bound to its robot: the
/// [`flexcal_compensate::compensation::ElasticModel`] used by compensation.
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

impl flexcal_compensate::compensation::ElasticModel for RobotFuzzyCompliance {
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

    fn tcp_displacement(
        &self,
        q: &[f64],
        wrench_base: &Vector6<f64>,
    ) -> std::result::Result<Vector6<f64>, flexcal_compensate::compensation::ElasticEvalError> {
        Ok(self.displacement(q, wrench_base)?)
    }
}

/// Settings of [`identify_compliance`].
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `fuzzy.search.max_rules` | 12 | rule budget per component model (the paper's 4 x 3) |
/// | `fuzzy.search.patience` | 2 | growth steps without test improvement before stopping |
/// | `fuzzy.search.placement` | 200 evaluations, seed 0 | Solis-Wets placement of modal values |
/// | `fuzzy.ridge` | 1e-6 | relative pull of conclusions towards the best constant compliances |
/// | `shared_structure` | true | one partition grid for all components (paper), or one each |
/// | `test_fraction` | 0.286 | fraction of configurations held out to choose the structure (36 of 126) |
/// | `seed` | 1 | seed of the random train/test split |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComplianceFitParams {
    /// Fuzzy learning settings (structure search, ridge). Conclusions are
    /// always solved by least squares (the joint fit).
    pub fuzzy: FuzzyParams,
    /// Whether all components share one partition grid (default true).
    pub shared_structure: bool,
    /// Fraction of the configurations put in the test set (default 0.286;
    /// range (0, 1)).
    pub test_fraction: f64,
    /// Seed of the train/test split (default 1).
    pub seed: u64,
}

impl Default for ComplianceFitParams {
    fn default() -> Self {
        Self {
            fuzzy: FuzzyParams {
                search: StructureSearchParams {
                    max_rules: 12,
                    patience: 2,
                    ..StructureSearchParams::default()
                },
                ..FuzzyParams::default()
            },
            shared_structure: true,
            test_fraction: 0.286,
            seed: 1,
        }
    }
}

/// How a compliance model was identified.
#[derive(Debug, Clone, PartialEq)]
pub struct ComplianceFitReport {
    /// The structure search (history, termination, evaluations). With a
    /// shared structure it holds one structure, used by every component.
    pub search: StructureSearchReport,
    /// The final joint least-squares solve of the conclusions.
    pub conclusions: ConclusionReport,
    /// Errors of the measured displacement components on the training set
    /// (mm).
    pub training_mm: ErrorStats,
    /// Errors of the measured displacement components on the test set (mm).
    pub test_mm: ErrorStats,
    /// Number of training configurations.
    pub training_configurations: usize,
    /// Number of test configurations.
    pub test_configurations: usize,
    /// Indices (into the samples given) of the training samples.
    pub training_samples: Vec<usize>,
    /// Indices (into the samples given) of the test samples.
    pub test_samples: Vec<usize>,
    /// Wall-clock time of the identification (s).
    pub elapsed_s: f64,
}

/// A fitted fuzzy compliance model and its report: the fitted type of
/// [`identify_compliance`].
#[derive(Debug, Clone, PartialEq)]
pub struct FittedCompliance {
    /// The model.
    pub compliance: FuzzyCompliance,
    /// How it was obtained.
    pub report: ComplianceFitReport,
}

/// Identifies the fuzzy compliance components from measured deflections
/// (section 2.2.2 steps i-iii, equations (38) and (70)).
///
/// The samples are grouped into configurations (equal input values) and
/// split at random (seeded) into training and test configurations; every
/// measured translation along a modelled displacement axis gives one
/// least-squares row, linear in the conclusions of all component models.
/// The structure grows from 2 membership functions per input within the
/// rule budget, each candidate placed by Solis-Wets on the training error
/// and judged by the test error; conclusions are solved jointly.
///
/// # Errors
/// Invalid settings, no inputs or components, rotational components, a
/// sample with a wrong or non-finite value, a constant input, a component
/// whose wrench axis no training sample loads, fewer training
/// configurations than rules, a singular conclusion system.
pub fn identify_compliance(
    inputs: &[InputSpec],
    components: &[ComplianceComponent],
    samples: &[ComplianceSample],
    params: &ComplianceFitParams,
    progress: &mut dyn FnMut(&SearchProgress),
) -> Result<FittedCompliance> {
    let started = Instant::now();
    params.fuzzy.validate()?;
    if !(params.test_fraction > 0.0 && params.test_fraction < 1.0) {
        return Err(FuzzyComplianceError::InvalidParameter {
            name: "test_fraction",
            value: params.test_fraction.to_string(),
            reason: "must be in (0, 1)",
        });
    }
    if inputs.is_empty() {
        return Err(FuzzyComplianceError::NoInputs);
    }
    if components.is_empty() {
        return Err(FuzzyComplianceError::NoComponents);
    }
    check_unique(inputs.iter().map(|i| i.name.clone()))?;
    check_unique(components.iter().map(|c| c.name()))?;
    if let Some(c) = components.iter().find(|c| !c.displacement.is_linear()) {
        return Err(FuzzyComplianceError::RotationNotMeasured {
            component: c.name(),
        });
    }
    check_samples(inputs, samples)?;

    // Configurations: samples with identical inputs, in order of appearance.
    let mut groups: BTreeMap<Vec<u64>, usize> = BTreeMap::new();
    let mut configurations: Vec<Vec<usize>> = Vec::new();
    for (k, s) in samples.iter().enumerate() {
        let key: Vec<u64> = s.inputs.iter().map(|v| v.to_bits()).collect();
        let next = configurations.len();
        let c = *groups.entry(key).or_insert(next);
        if c == next {
            configurations.push(Vec::new());
        }
        configurations[c].push(k);
    }
    if configurations.len() < 2 {
        return Err(FuzzyComplianceError::TooFewSamples {
            component: components[0].name(),
            configurations: configurations.len(),
            rules: 1 << inputs.len(),
        });
    }
    let n_test = ((params.test_fraction * configurations.len() as f64).round() as usize)
        .clamp(1, configurations.len() - 1);
    let mut order: Vec<usize> = (0..configurations.len()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(params.seed));
    let (test_configurations, train_configurations) = order.split_at(n_test);
    let collect = |configs: &[usize]| {
        let mut indices: Vec<usize> = configs
            .iter()
            .flat_map(|&c| configurations[c].iter().copied())
            .collect();
        indices.sort_unstable();
        indices
    };
    let training_samples = collect(train_configurations);
    let test_samples = collect(test_configurations);

    // Every component must be loaded in enough training configurations to
    // determine the rules of the simplest model.
    let minimum_rules = 1usize << inputs.len();
    let mut rule_cap = params.fuzzy.search.max_rules;
    for c in components {
        let loaded = train_configurations
            .iter()
            .filter(|&&g| {
                configurations[g]
                    .iter()
                    .any(|&k| samples[k].wrench[c.wrench.index()] != 0.0)
            })
            .count();
        if loaded == 0 {
            return Err(FuzzyComplianceError::ComponentNotExcited {
                component: c.name(),
                wrench: c.wrench.wrench_name(),
            });
        }
        if loaded < minimum_rules {
            return Err(FuzzyComplianceError::TooFewSamples {
                component: c.name(),
                configurations: loaded,
                rules: minimum_rules,
            });
        }
        rule_cap = rule_cap.min(loaded);
    }

    let names: Vec<String> = inputs.iter().map(|i| i.name.clone()).collect();
    let train = combination_set(&names, components, samples, &training_samples)?;
    let test = combination_set(&names, components, samples, &test_samples)?;

    let mut domains = vec![(f64::INFINITY, f64::NEG_INFINITY); inputs.len()];
    for &k in &training_samples {
        for (d, &v) in domains.iter_mut().zip(&samples[k].inputs) {
            d.0 = d.0.min(v);
            d.1 = d.1.max(v);
        }
    }
    for (spec, &(lower, upper)) in inputs.iter().zip(&domains) {
        if lower >= upper {
            return Err(FuzzyComplianceError::ConstantInput {
                input: spec.name.clone(),
                value: lower,
            });
        }
    }
    let initial = FuzzyStructure::initial(names.clone(), &domains)?;
    let mut search = params.fuzzy.search.clone();
    search.max_rules = rule_cap.max(minimum_rules);
    let ridge = params.fuzzy.ridge;
    let model_count = components.len();
    let expand = |s: &[FuzzyStructure]| -> Vec<FuzzyStructure> {
        if s.len() == 1 {
            vec![s[0].clone(); model_count]
        } else {
            s.to_vec()
        }
    };
    let evaluate = |s: &[FuzzyStructure]| -> std::result::Result<StructureScore, FuzzyError> {
        let structures = expand(s);
        let (conclusions, _) = fit_joint_conclusions(&structures, &train, ridge)?;
        let models = build_models(&structures, components, conclusions, 1.0)?;
        Ok(StructureScore {
            training_error: joint_error_stats(&models, &train)?.rmse,
            test_error: joint_error_stats(&models, &test)?.rmse,
        })
    };
    let start = if params.shared_structure {
        vec![initial]
    } else {
        vec![initial; model_count]
    };
    let report = search_structure(start, &search, evaluate, progress)?;
    let structures = expand(&report.structures);
    let (conclusions, conclusion_report) = fit_joint_conclusions(&structures, &train, ridge)?;
    let fitted = build_models(&structures, components, conclusions, 1.0)?;
    let training_mm = joint_error_stats(&fitted, &train)?;
    let test_mm = joint_error_stats(&fitted, &test)?;
    let si_models = fitted
        .iter()
        .map(|m| {
            FuzzyModel::new(
                m.structure().clone(),
                m.output_name().to_string(),
                m.conclusions().iter().map(|b| b / FIT_SCALE).collect(),
            )
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let compliance = FuzzyCompliance::new(inputs.to_vec(), components.to_vec(), si_models)?;
    Ok(FittedCompliance {
        compliance,
        report: ComplianceFitReport {
            search: report,
            conclusions: conclusion_report,
            training_mm,
            test_mm,
            training_configurations: train_configurations.len(),
            test_configurations: test_configurations.len(),
            training_samples,
            test_samples,
            elapsed_s: started.elapsed().as_secs_f64(),
        },
    })
}

fn check_samples(inputs: &[InputSpec], samples: &[ComplianceSample]) -> Result<()> {
    for (k, s) in samples.iter().enumerate() {
        if s.inputs.len() != inputs.len() {
            return Err(FuzzyComplianceError::InputCount {
                sample: k,
                pose_id: s.pose_id,
                expected: inputs.len(),
                found: s.inputs.len(),
            });
        }
        let non_finite = |field: String, value: f64| FuzzyComplianceError::NonFinite {
            sample: k,
            pose_id: s.pose_id,
            field,
            value,
        };
        for (spec, &v) in inputs.iter().zip(&s.inputs) {
            if !v.is_finite() {
                return Err(non_finite(format!("input '{}'", spec.name), v));
            }
        }
        for a in Axis::ALL {
            let v = s.wrench[a.index()];
            if !v.is_finite() {
                return Err(non_finite(format!("wrench {}", a.wrench_name()), v));
            }
        }
        for a in &Axis::ALL[..3] {
            let v = s.deflection[a.index()];
            if !v.is_finite() {
                return Err(non_finite(format!("deflection d{}", a.name()), v));
            }
        }
    }
    Ok(())
}

/// Least-squares rows of the samples at `indices`: one per sample and
/// modelled displacement axis, `d_axis = sum_w C_axis,w W_w`, in mm and kN.
fn combination_set(
    names: &[String],
    components: &[ComplianceComponent],
    samples: &[ComplianceSample],
    indices: &[usize],
) -> Result<LinearCombinationSet> {
    let mut axes: Vec<Axis> = components.iter().map(|c| c.displacement).collect();
    axes.sort();
    axes.dedup();
    let rows = indices.len() * axes.len();
    let mut input_columns = vec![Vec::with_capacity(rows); names.len()];
    let mut coefficient_columns = vec![Vec::with_capacity(rows); components.len()];
    let mut targets = Vec::with_capacity(rows);
    for &k in indices {
        let s = &samples[k];
        for &axis in &axes {
            for (column, &v) in input_columns.iter_mut().zip(&s.inputs) {
                column.push(v);
            }
            for (column, c) in coefficient_columns.iter_mut().zip(components) {
                // kN (or kN.m) so that conclusions come out in mm/kN.
                column.push(if c.displacement == axis {
                    s.wrench[c.wrench.index()] * 1e-3
                } else {
                    0.0
                });
            }
            targets.push(s.deflection[axis.index()] * 1e3);
        }
    }
    Ok(LinearCombinationSet::new(
        names.to_vec(),
        &input_columns,
        &coefficient_columns,
        targets,
    )?)
}

fn build_models(
    structures: &[FuzzyStructure],
    components: &[ComplianceComponent],
    conclusions: Vec<Vec<f64>>,
    scale: f64,
) -> std::result::Result<Vec<FuzzyModel>, FuzzyError> {
    structures
        .iter()
        .zip(components)
        .zip(conclusions)
        .map(|((s, c), b)| {
            FuzzyModel::new(
                s.clone(),
                c.name(),
                b.into_iter().map(|v| v * scale).collect(),
            )
        })
        .collect()
}

/// The measurement-noise floor of a set of samples along `axes`: the RMS
/// over samples of the norm of the deflection noise restricted to those
/// axes, `sqrt(mean_k sum_axis sigma_k,axis^2)` (m), from the standard
/// deviations the samples carry. A model that predicts perfectly still
/// shows this RMS residual. Zero for no samples.
pub fn noise_floor_rms(samples: &[ComplianceSample], axes: &[Axis]) -> f64 {
    if samples.is_empty() {
        return 0.0;
    }
    let sum: f64 = samples
        .iter()
        .map(|s| {
            axes.iter()
                .filter(|a| a.is_linear())
                .map(|a| s.sigma[a.index()].powi(2))
                .sum::<f64>()
        })
        .sum();
    (sum / samples.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexcal_compensate::compensation::{Cell, ElastoGeometricModel};
    use flexcal_compensate::path::PathPoint;
    use flexcal_compensate::process::{BeamTheory, CantileverBeam, ProcessModel};
    use flexcal_fuzzy::{FuzzyStructure, Partition};
    use flexcal_kinematics::{Data, RobotDescription, actuated_from_joint_angles, inverse_pose};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    /// A 4 x 3-rule plane compliance of the IR-663's size (m/N).
    fn ir663_fuzzy(robot: &Model) -> RobotFuzzyCompliance {
        let structure = FuzzyStructure::new(
            vec!["theta2".into(), "theta8".into()],
            vec![
                Partition::new(vec![-1.2, -0.6, -0.1, 0.5]).unwrap(),
                Partition::new(vec![-0.5, 0.4, 1.3]).unwrap(),
            ],
        )
        .unwrap();
        let components = ComplianceComponent::plane_xz().to_vec();
        let models = components
            .iter()
            .zip([1.0e-6, 0.3e-6, 0.25e-6, 1.5e-6])
            .map(|(c, scale)| {
                let conclusions = (0..12)
                    .map(|rule| scale * (1.0 + 0.04 * rule as f64))
                    .collect();
                FuzzyModel::new(structure.clone(), c.name(), conclusions).unwrap()
            })
            .collect();
        let inputs = vec![InputSpec::radians("theta2"), InputSpec::radians("theta8")];
        let compliance = FuzzyCompliance::new(inputs, components, models).unwrap();
        RobotFuzzyCompliance::new(compliance, robot.clone()).unwrap()
    }

    /// The fuzzy model drives path compensation of the IR-663 (closed loops,
    /// ball screws) in the forming cell: the tracked path must equal the
    /// points compensated one by one from scratch, with and without the beam.
    #[test]
    fn tracked_ir663_path_equals_points_compensated_from_scratch() {
        let robot = RobotDescription::builtin("ir663").unwrap().build().unwrap();
        let fuzzy = ir663_fuzzy(&robot);
        let beam = CantileverBeam::reference(BeamTheory::LargeDeflection);
        let down = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI);
        let points = 150;
        let path: Vec<PathPoint> = (0..points)
            .map(|k| PathPoint {
                line: k + 2,
                x_part_tcp: Isometry3::from_parts(
                    Translation3::new(0.58 - 0.2 * k as f64 / (points - 1) as f64, 0.0, -0.025),
                    down,
                ),
            })
            .collect();
        let cell = Cell {
            x_base_part: Isometry3::translation(1.2, 0.0, 1.45),
            payload_base: Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0),
        };
        let mut data = Data::new(&robot);
        let xi = robot.nominal_params().to_vec();
        let start = actuated_from_joint_angles(&robot, &[0.0, -0.5, 0.4, 0.8, 1.6, 0.0]).unwrap();
        let first = cell.x_base_part * path[0].x_part_tcp;
        let seed = inverse_pose(&robot, &mut data, &first, &start, &xi, &Default::default())
            .unwrap()
            .q;
        for process in [None, Some(&beam as &dyn ProcessModel)] {
            let egm =
                ElastoGeometricModel::with_nominal_geometry(&robot, &fuzzy, process, cell.clone());
            let tracked = egm.compensate_path(&mut data, &path, &seed, &Default::default());
            let mut cold_seed = seed.clone();
            for (k, outcome) in tracked.iter().enumerate() {
                let t = outcome.result.as_ref().unwrap();
                let target = cell.x_base_part * path[k].x_part_tcp;
                let next = cell.x_base_part * path[(k + 1).min(points - 1)].x_part_tcp;
                let previous = cell.x_base_part * path[k.saturating_sub(1)].x_part_tcp;
                let motion = if k + 1 < points {
                    next.translation.vector - target.translation.vector
                } else {
                    target.translation.vector - previous.translation.vector
                };
                let c = egm
                    .compensate_pose(&mut data, &target, &cold_seed, &motion, &Default::default())
                    .unwrap();
                cold_seed.clone_from(&c.q_commanded);
                assert!(t.residual.fixed_rows::<3>(0).norm() <= 1e-9);
                assert!(t.residual.fixed_rows::<3>(3).norm() <= 1e-9);
                for (a, b) in t.q_commanded.iter().zip(&c.q_commanded) {
                    assert!((a - b).abs() < 1e-7, "point {k}: {a} vs {b}");
                }
                assert!((t.uncompensated_error - c.uncompensated_error).norm() < 1e-9);
            }
        }
    }
}

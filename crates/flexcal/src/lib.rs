//! # flexcal
//!
//! flexcal as a library: the whole pipeline of elasto-geometric calibration
//! and compensation of industrial robots as typed library calls. The CLI,
//! the demo, the HTML report and the Python package are thin layers over
//! this crate.
//!
//! ## The pipeline
//! Load a robot, read measurements, calibrate its geometry, validate, identify
//! an elastic model from a deflection campaign, compensate a tool path,
//! write the commanded path (here on the files the virtual robot writes):
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! # let tmp = tempfile::tempdir()?;
//! # let dir = tmp.path();
//! # let campaign = flexcal::twin::geometric::geometric_campaign(&Default::default())?;
//! # flexcal::twin::geometric::write_geometric_campaign(&campaign, dir)?;
//! # flexcal::twin::elastic::write_elastic_campaign(dir.join("elastic"), &Default::default())?;
//! # std::fs::write(dir.join("path.csv"), "x_mm,y_mm,z_mm\n560,0,0\n570,0,0\n580,0,0\n")?;
//! use flexcal::{calib, compensation as comp, elastic::workflow};
//! let robot = flexcal::load_robot("ir663")?; // built-in name or description file
//! let poses = calib::MeasurementSet::read_csv(&dir.join("identification.csv"))?;
//! let mut options = calib::CalibrationOptions::for_model(&robot);
//! // The camera's frame is registered with the robot; the target is the TCP.
//! (options.measurement_frame, options.target) = (calib::FrameTreatment::Identify, calib::FrameTreatment::Fixed);
//! let calibration = calib::calibrate(&robot, &poses, &options)?;
//! let validation = calibration.validate(&robot, &calib::MeasurementSet::read_csv(&dir.join("validation.csv"))?, false)?;
//! let fuzzy = workflow::identify_compliance_in_dir(&robot, &dir.join("elastic"), &Default::default())?;
//! fuzzy.fitted.compliance.write(dir.join("compliance.toml"))?;
//! let elastic = comp::load_elastic(&comp::ElasticSpec::Fuzzy(dir.join("compliance.toml")), &robot, &calibration.xi)?;
//! let setup = comp::CompensationSetup { x_base_part: comp::pose_mm_deg(&[1200.0, 0.0, 1450.0, 0.0, 0.0, 0.0]), payload_base: nalgebra::Vector6::new(0.0, 0.0, -920.0, 0.0, 0.0, 0.0), start_joints: comp::default_start_joints(&robot) };
//! let process: comp::ProcessSpec = "cantilever:585,50,14,al-5005".parse()?;
//! let commanded = comp::compensate_path_file(&robot, calibration.xi.clone(), elastic.as_ref(), process.as_process(), &setup, &dir.join("path.csv"))?;
//! flexcal::io::write_atomic(dir.join("commanded.csv"), commanded.to_csv(robot.n_actuated()))?;
//! assert!(validation.after.position_mean < validation.before.position_mean);
//! # Ok(())
//! # }
//! ```
//!
//! The subject crates are re-exported under short names:
//! [`kinematics`] (robot descriptions, forward and inverse models,
//! Jacobians), [`optim`] (least squares, identifiability), [`fem`] (frame
//! finite elements), [`fuzzy`] (Takagi-Sugeno models), [`calib`]
//! (measurements, geometric and elasto-geometric calibration, validation),
//! [`elastic`] (the robot's elastic models and their identification),
//! [`compensate`] (process models and compensation of tool paths) and
//! [`twin`] (the virtual robots that stand in for a real robot and
//! instrument).
//!
//! A robot argument (built-in name or description file) is resolved by one
//! rule, [`RobotSpec`]; [`load_robot`] reads and builds it. The reference
//! study behind `flexcal demo` is [`study::run_study`], which returns typed
//! results and a [`study::Summary`]; [`study::study_report`] lays them out
//! as a self-contained HTML page ([`report`]).

pub mod calibration;
pub mod campaign;
pub mod compensation;
mod error;
pub mod forming;
pub mod fuzzy_csv;
pub mod plan;
pub mod pose_file;
pub mod pose_selection;
pub mod report;
pub mod robot;
pub mod study;

pub use error::{Error, Result, cause_chain_line};
pub use robot::{RobotFileFormat, RobotSpec, load_description, load_robot, load_robot_with};

pub use flexcal_calib as calib;
pub use flexcal_compensate as compensate;
pub use flexcal_elastic as elastic;
pub use flexcal_fem as fem;
pub use flexcal_fuzzy as fuzzy;
pub use flexcal_io as io;
pub use flexcal_kinematics as kinematics;
pub use flexcal_optim as optim;
pub use flexcal_twin as twin;

/// The linear algebra crate of flexcal's types (poses, twists, wrenches, Jacobians).
pub use nalgebra;
pub mod bench;
pub mod bench_fixtures;

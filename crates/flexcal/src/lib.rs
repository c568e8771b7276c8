//! # flexcal
//!
//! flexcal as a library: the whole pipeline of elasto-geometric calibration
//! and compensation of industrial robots as typed library calls. The CLI,
//! the demo, the HTML report and the Python package are thin layers over
//! this crate.
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

mod error;
pub mod report;
pub mod robot;
pub mod study;

pub use error::{Error, Result};
pub use robot::{RobotFileFormat, RobotSpec, load_description, load_robot};

pub use flexcal_calib as calib;
pub use flexcal_compensate as compensate;
pub use flexcal_elastic as elastic;
pub use flexcal_fem as fem;
pub use flexcal_fuzzy as fuzzy;
pub use flexcal_io as io;
pub use flexcal_kinematics as kinematics;
pub use flexcal_optim as optim;
pub use flexcal_twin as twin;

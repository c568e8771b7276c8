//! flexcal-kinematics: see the crate description. Under construction.

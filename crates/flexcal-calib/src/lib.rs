//! flexcal-calib: see the crate description. Under construction.

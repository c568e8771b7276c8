//! flexcal-compensate: see the crate description. Under construction.

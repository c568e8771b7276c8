//! flexcal-twin: see the crate description. Under construction.

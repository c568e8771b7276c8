//! flexcal-fem: see the crate description. Under construction.

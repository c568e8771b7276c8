//! flexcal-elastic: see the crate description. Under construction.

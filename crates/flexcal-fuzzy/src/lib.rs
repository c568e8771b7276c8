//! flexcal-fuzzy: see the crate description. Under construction.

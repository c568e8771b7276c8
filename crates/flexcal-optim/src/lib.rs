//! flexcal-optim: robot-agnostic numerics (under construction).

pub mod solis_wets;

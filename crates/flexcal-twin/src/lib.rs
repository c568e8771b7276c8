//! flexcal-twin: see the crate description. Under construction.

/// The virtual IR-663's geometric campaign (paper section 3.2): true
/// parameters from Appendix C, simulated photogrammetry, identification and
/// validation files.
pub mod geometric;

/// The virtual IR-663's elastic campaign (paper section 3.3.1): screws as
/// configuration-dependent springs, flexible links, the 63-pose grid (65)
/// under 300-1100 N along x and z, loaded and unloaded poses.
pub mod elastic;

/// The paper's forming experiment (section 4) on the virtual IR-663: a
/// clamped beam bent by the tool under a 920 N dead weight, commanded with
/// and without elasto-geometrical compensation, "measured" by the twin.
pub mod forming;

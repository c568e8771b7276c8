//! Learning: rapid prototyping, least-squares (or gradient-descent)
//! conclusions, Solis-Wets placement of modal values and structure growth
//! (section 2.2.2, steps i-iii), for one output or for several outputs
//! observed through linear combinations (equations (38), (70)).

mod conclusions;
mod joint;
mod params;
mod report;
mod search;

pub use conclusions::{
    ConclusionMethod, ConclusionReport, NormalEquations, fit_conclusions, rapid_prototyping,
};
pub use joint::{JointFit, LinearCombinationSet, fit_joint_conclusions, joint_error_stats};
pub use params::{FuzzyFit, FuzzyParams};
pub use report::FitReport;
pub use search::{
    GrowthStep, GrowthTermination, SearchPhase, SearchProgress, StructureScore,
    StructureSearchParams, StructureSearchReport, search_structure,
};

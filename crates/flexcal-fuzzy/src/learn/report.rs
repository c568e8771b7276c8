//! What a fit reports.

use crate::model::ErrorStats;

use super::conclusions::ConclusionReport;
use super::search::StructureSearchReport;

/// Report of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// The structure search.
    pub search: StructureSearchReport,
    /// The final conclusions' solve.
    pub conclusions: ConclusionReport,
    /// Errors on the training set.
    pub training: ErrorStats,
    /// Errors on the test set.
    pub test: ErrorStats,
}

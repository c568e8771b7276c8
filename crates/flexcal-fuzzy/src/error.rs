//! The error type of flexcal-fuzzy.

use flexcal_optim::solis_wets::SolisWetsError;

/// What is wrong with the modal values of one partition.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PartitionError {
    /// A strong partition needs at least two membership functions.
    #[error("{count} modal value(s): a partition needs at least 2")]
    TooFewModalValues {
        /// Number given.
        count: usize,
    },
    /// A modal value is NaN or infinite.
    #[error("modal value {index} is {value}, not a finite number")]
    NonFinite {
        /// 0-based index of the modal value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Modal values must increase strictly (the paper's equation (34)).
    #[error(
        "modal values must increase strictly (equation (34)): value {index} = {value} follows {previous}"
    )]
    NotIncreasing {
        /// 0-based index of the offending value.
        index: usize,
        /// The value before it.
        previous: f64,
        /// The value.
        value: f64,
    },
}

/// Errors of flexcal-fuzzy. Every variant names what it concerns (input,
/// rule, sample, file, setting).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FuzzyError {
    /// A partition is invalid.
    #[error("input '{input}': {source}")]
    Partition {
        /// Name of the input.
        input: String,
        /// What is wrong.
        source: PartitionError,
    },
    /// A model needs at least one input.
    #[error("a fuzzy model needs at least one input")]
    NoInputs,
    /// More inputs than the evaluation supports (2^n rules per sample).
    #[error("{count} inputs: at most {max} are supported (each sample touches 2^n rules)")]
    TooManyInputs {
        /// Number of inputs given.
        count: usize,
        /// The maximum, [`crate::MAX_INPUTS`].
        max: usize,
    },
    /// Two inputs (or the output and an input) share a name.
    #[error("name '{name}' is used twice")]
    DuplicateName {
        /// The repeated name.
        name: String,
    },
    /// The numbers of names and of partitions (or columns) differ.
    #[error("{names} input name(s) for {items} {what}")]
    NameCount {
        /// Number of names.
        names: usize,
        /// Number of partitions or columns.
        items: usize,
        /// What the items are.
        what: &'static str,
    },
    /// A sample has the wrong number of input values.
    #[error("a sample has {found} input value(s), the model has {expected} input(s)")]
    InputCount {
        /// Inputs of the model.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A batch buffer has the wrong length.
    #[error("{what}: length {found}, expected {expected}")]
    BufferLength {
        /// Which buffer.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length given.
        found: usize,
    },
    /// The number of conclusions differs from the number of rules.
    #[error("{found} conclusion(s) for {expected} rule(s)")]
    ConclusionCount {
        /// Rules of the structure.
        expected: usize,
        /// Conclusions given.
        found: usize,
    },
    /// A conclusion is NaN or infinite.
    #[error("conclusion of rule {rule} is {value}, not a finite number")]
    NonFiniteConclusion {
        /// 0-based rule index.
        rule: usize,
        /// The value.
        value: f64,
    },
    /// An input value is NaN or infinite.
    #[error("sample {sample}, input '{input}': {value} is not a finite number")]
    NonFiniteInput {
        /// 0-based sample index.
        sample: usize,
        /// Input name.
        input: String,
        /// The value.
        value: f64,
    },
    /// An output (or target, or coefficient) value is NaN or infinite.
    #[error("sample {sample}, '{column}': {value} is not a finite number")]
    NonFiniteOutput {
        /// 0-based sample index.
        sample: usize,
        /// Column name.
        column: String,
        /// The value.
        value: f64,
    },
    /// Columns of a data set differ in length.
    #[error("column '{column}' has {found} value(s), expected {expected}")]
    ColumnLength {
        /// Column name.
        column: String,
        /// Expected length.
        expected: usize,
        /// Length found.
        found: usize,
    },
    /// An input takes a single value over the training set: it cannot be
    /// partitioned.
    #[error("input '{input}' is constant ({value}) over the {set}: it cannot be partitioned")]
    ConstantInput {
        /// Input name.
        input: String,
        /// Its only value.
        value: f64,
        /// Which data set.
        set: &'static str,
    },
    /// Fewer samples than rules: the conclusions are not determined.
    #[error("{set} has {samples} sample(s), fewer than the {rules} rules of the model")]
    TooFewSamples {
        /// Which data set.
        set: &'static str,
        /// Samples available.
        samples: usize,
        /// Rules to determine.
        rules: usize,
    },
    /// A data set that must not be empty is.
    #[error("the {set} is empty")]
    EmptySet {
        /// Which data set.
        set: &'static str,
    },
    /// Two data sets (or a data set and a model) disagree on the inputs.
    #[error("input names differ: {expected:?} expected, {found:?} found")]
    InputNames {
        /// Names expected.
        expected: Vec<String>,
        /// Names found.
        found: Vec<String>,
    },
    /// A setting is out of its documented range.
    #[error("setting '{name}' = {value}: {reason}")]
    InvalidParameter {
        /// Field name.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The range it must respect.
        reason: &'static str,
    },
    /// The least-squares system of the conclusions is singular: some rules
    /// are not activated by any training sample and no ridge term holds them.
    #[error(
        "singular least-squares system for the conclusions (rules without training data: {unsupported_rules:?}); use a ridge > 0 or fewer membership functions"
    )]
    SingularConclusions {
        /// 0-based indices of rules (in the joint numbering) without data.
        unsupported_rules: Vec<usize>,
    },
    /// A row of a least-squares system refers to a missing unknown.
    #[error("least-squares row refers to unknown {index}, the system has {size}")]
    UnknownIndex {
        /// Index given.
        index: usize,
        /// Number of unknowns.
        size: usize,
    },
    /// The Solis-Wets search refused its settings.
    #[error("modal value search: {0}")]
    Search(#[from] SolisWetsError),
    /// The caller's evaluation closure failed.
    #[error("structure evaluation failed: {0}")]
    Evaluation(Box<dyn std::error::Error + Send + Sync>),
    /// Reading or writing a file failed.
    #[error(transparent)]
    Io(#[from] flexcal_io::IoError),
    /// A model file has wrong content.
    #[error("{path}: {message}")]
    ModelFile {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
    /// A `.fis` text cannot be read back as a flexcal model.
    #[error("FIS line {line}: {message}")]
    Fis {
        /// 1-based line (0 when the problem is global).
        line: usize,
        /// What is wrong.
        message: String,
    },
}

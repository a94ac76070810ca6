//! The crate's error type.

/// Why a bundle adjustment problem was refused or could not be solved.
///
/// Every input error names the offending field with its index, e.g.
/// `observations[12].point = 900 but there are 800 points`.
#[derive(Debug, Clone, thiserror::Error)]
pub enum BaError {
    /// An index refers past the end of the array it indexes.
    #[error("{field} = {index} but there are {count} {items}")]
    IndexOutOfRange {
        /// The field holding the index, e.g. `observations[12].point`.
        field: String,
        /// The offending index.
        index: usize,
        /// The length of the indexed array.
        count: usize,
        /// What the indexed array holds, e.g. `points`.
        items: &'static str,
    },
    /// A value is NaN or infinite.
    #[error("{field} is not finite ({value})")]
    NonFinite {
        /// The field holding the value, e.g. `points_world[3][2]`.
        field: String,
        /// The offending value.
        value: f64,
    },
    /// Two arrays that must be parallel have different lengths.
    #[error("{field} has {actual} entries but {reference} has {expected}")]
    LengthMismatch {
        /// The array with the wrong length.
        field: &'static str,
        /// Its length.
        actual: usize,
        /// The array it must match.
        reference: &'static str,
        /// The length of that array.
        expected: usize,
    },
    /// A finite value outside its valid range (a non-positive focal length, a negative weight, ...).
    #[error("{field} = {value} is invalid: {reason}")]
    InvalidValue {
        /// The field holding the value.
        field: String,
        /// The offending value.
        value: f64,
        /// What the value must satisfy.
        reason: &'static str,
    },
    /// The solver could not proceed numerically (for example the damped normal equations could
    /// not be factorised even at the largest damping, or the initial cost overflowed).
    #[error("numerical failure: {reason}")]
    Numerical {
        /// What went wrong.
        reason: String,
    },
}

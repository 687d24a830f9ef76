//! The one error type of the `match` crate.

/// What can go wrong matching masks across views. Inputs are in memory here, so messages name
/// the view (by index) and the array that is inconsistent.
#[derive(Debug, thiserror::Error)]
pub enum MatchError {
    /// An input array has the wrong length.
    #[error("view {view}: {what} has {got} entries, expected {expected}")]
    Shape {
        /// View index.
        view: usize,
        /// Which array, e.g. "features".
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length it should have.
        expected: usize,
    },
    /// A Gaussian observation names a mask the view does not have.
    #[error("view {view}: a Gaussian observation names mask label {label}, but the view has {masks} masks")]
    UnknownLabel {
        /// View index.
        view: usize,
        /// The label found.
        label: u32,
        /// Number of masks of the view.
        masks: usize,
    },
    /// Observation Gaussian indices are not strictly increasing.
    #[error("view {view}: observed Gaussian indices must be strictly increasing")]
    Unsorted {
        /// View index.
        view: usize,
    },
    /// Observations were given for a different number of views than masks.
    #[error("observations cover {got} views, but masks were given for {expected} views")]
    ViewCount {
        /// Views with observations.
        got: usize,
        /// Views with masks.
        expected: usize,
    },
    /// A descriptor contains NaN or infinity.
    #[error("view {view}: mask {label} has a non-finite descriptor")]
    NonFinite {
        /// View index.
        view: usize,
        /// Local label of the mask.
        label: u32,
    },
    /// More objects than a 16-bit label map can hold.
    #[error("{count} global objects do not fit 16-bit label maps (at most 65535)")]
    TooManyObjects {
        /// Number of global objects.
        count: usize,
    },
}

/// Result alias for this crate.
pub type MatchResult<T> = Result<T, MatchError>;

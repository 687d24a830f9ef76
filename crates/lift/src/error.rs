//! The one error type of the `lift` crate.

/// What can go wrong lifting labels onto Gaussians.
#[derive(Debug, thiserror::Error)]
pub enum LiftError {
    /// A per-view label map does not have the view's camera size.
    #[error("view {view}: label map is {got_w}×{got_h}, but the camera is {want_w}×{want_h}")]
    LabelMapSize {
        /// View index.
        view: usize,
        /// Label map width.
        got_w: usize,
        /// Label map height.
        got_h: usize,
        /// Camera width.
        want_w: usize,
        /// Camera height.
        want_h: usize,
    },
    /// A label map is smaller than the image its visibility was computed for.
    #[error("view {view}: label map has only {pixels} pixels, smaller than the view's image")]
    MapTooSmall {
        /// View index.
        view: usize,
        /// Pixels in the map.
        pixels: usize,
    },
    /// Per-view inputs disagree in count.
    #[error("{what}: got {got} entries, expected {expected}")]
    Count {
        /// Which input.
        what: &'static str,
        /// Number given.
        got: usize,
        /// Number expected.
        expected: usize,
    },
    /// A view's list of visible Gaussians is not strictly increasing or names a Gaussian past the end.
    #[error("view {view}: visible Gaussians must be strictly increasing indices below {n_gaussians}")]
    VisibleList {
        /// View index (in the order views were added).
        view: usize,
        /// Number of Gaussians.
        n_gaussians: usize,
    },
    /// A Gaussian parameter is NaN or infinite.
    #[error("Gaussian {index} has a non-finite {what}")]
    NonFinite {
        /// Gaussian index.
        index: usize,
        /// Which parameter.
        what: &'static str,
    },
    /// A label map names an object the identity features do not cover.
    #[error("view {view}: label map holds object id {id}, but only {n_objects} objects are known")]
    UnknownObject {
        /// View index.
        view: usize,
        /// The id found.
        id: u32,
        /// Objects with identity features.
        n_objects: usize,
    },
    /// Tile lists kept from an earlier pass that do not fit the view.
    #[error(transparent)]
    Render(#[from] splatseg_render::RenderError),
}

/// Result alias for this crate.
pub type LiftResult<T> = Result<T, LiftError>;

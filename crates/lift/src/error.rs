//! The one error type of the `lift` crate.

/// What can go wrong lifting labels onto Gaussians.
#[derive(Debug, thiserror::Error)]
pub enum LiftError {
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
    /// Writing the labelled PLY.
    #[error(transparent)]
    Scene(#[from] splatseg_scene::SceneError),
    /// Tile lists kept from an earlier pass that do not fit the view.
    #[error(transparent)]
    Render(#[from] splatseg_render::RenderError),
}

/// Result alias for this crate.
pub type LiftResult<T> = Result<T, LiftError>;

//! The one error type of the `render` crate.

/// Result alias for this crate.
pub type RenderResult<T> = Result<T, RenderError>;

/// What can go wrong when rendering. Inputs come from files users give us, so inconsistent
/// shapes are reported, never panicked on.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// An input array has the wrong length for the number of Gaussians or pixels.
    #[error("{what} has {got} values, expected {expected}")]
    Shape {
        /// Which array, e.g. "sh_rest".
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length it should have.
        expected: usize,
    },
    /// A parameter is NaN or infinite.
    #[error("{what} of Gaussian {index} is not finite")]
    NonFinite {
        /// Which parameter, e.g. "mean".
        what: &'static str,
        /// The Gaussian's index.
        index: usize,
    },
    /// Spherical harmonics above degree 3.
    #[error("spherical harmonics of degree {0} are not supported (at most 3)")]
    ShDegree(u8),
    /// A camera that cannot be rendered (zero size, non-finite or non-positive focal length, ...).
    #[error("invalid camera: {0}")]
    Camera(String),
    /// Writing an output file failed.
    #[error(transparent)]
    Output(#[from] splatseg_scene::SceneError),
    /// Tile lists that do not fit the splats or the image they were given with.
    #[error("tile lists do not fit the view: {0}")]
    Bins(String),
    /// A gradient was given for an output the forward pass did not produce.
    #[error("gradient given for `{0}`, which the render request did not ask for")]
    GradientWithoutOutput(&'static str),
}

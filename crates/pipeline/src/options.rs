//! How a command treats suspicious inputs and whether it draws progress bars: what the binary's
//! `--strict` and `--quiet` set, carried in the run's settings rather than held process-wide.

use serde::{Deserialize, Serialize};

/// A run's conduct towards its caller; the default skips non-finite Gaussians with a warning and
/// draws progress bars (on a terminal only).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunOptions {
    /// Refuse a Gaussian file (any format) holding any non-finite value (NaN, ±Inf) or degenerate Gaussian (zero
    /// quaternion, log-scale above 20) instead of skipping those Gaussians with one warning per
    /// kind and file.
    pub strict: bool,
    /// Draw no progress bars.
    pub quiet: bool,
}

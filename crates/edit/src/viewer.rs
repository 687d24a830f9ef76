//! Making a PLY safe for standard 3DGS viewers: keep the INRIA layout only.

use serde::{Deserialize, Serialize};
use splatseg_scene::Gaussians;

/// What happens to properties outside the INRIA 3DGS layout (`object_id`, `feat_*` and any
/// other extra property) when writing an edited PLY.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ExtraFields {
    /// Drop them: the file has exactly the INRIA properties (`x y z nx ny nz f_dc_* f_rest_*
    /// opacity scale_* rot_*`), which every 3DGS viewer opens (default).
    #[default]
    Strip,
    /// Keep them (for further splatseg processing; some viewers reject unknown properties).
    Keep,
}

/// `g` with its non-INRIA properties removed or kept per `policy`.
pub fn for_output(mut g: Gaussians, policy: ExtraFields) -> Gaussians {
    if policy == ExtraFields::Strip {
        g.object_ids = None;
        g.features = None;
        g.extra.clear();
    }
    g
}

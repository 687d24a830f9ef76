//! [`RenderRequest`] (what to render) and [`RenderOutput`] (what came out).

use crate::settings::RasterSettings;
use splatseg_scene::Plane;

/// Per-Gaussian feature vectors to blend like colour (e.g. 16-d object features, one-hot ids).
#[derive(Clone, Copy, Debug)]
pub struct FeatureInput<'a> {
    /// `[N, dim]` row-major.
    pub values: &'a [f32],
    /// Feature dimension D (≥ 1).
    pub dim: usize,
}

/// What to render. Outputs not asked for are not computed.
#[derive(Clone, Copy, Debug)]
pub struct RenderRequest<'a> {
    /// Colour from the SH coefficients, blended over `background`.
    pub rgb: bool,
    /// Expected depth `Σ w_i z_i / Σ w_i` (gsplat's "ED"; 0 where nothing was blended).
    pub depth: bool,
    /// Accumulated alpha `Σ w_i = 1 − T_final`.
    pub alpha: bool,
    /// Per pixel, the index of the Gaussian with the largest blending weight `w_i = α_i T_i`.
    pub max_weight_ids: bool,
    /// Per-Gaussian features to blend (background 0).
    pub features: Option<FeatureInput<'a>>,
    /// RGB background, weighted by the final transmittance.
    pub background: [f32; 3],
    /// Highest SH degree to use (`None` = all the Gaussians have).
    pub sh_degree: Option<u8>,
    /// Projection and blending rules.
    pub settings: RasterSettings,
}

impl Default for RenderRequest<'_> {
    /// RGB only, black background, all SH degrees, 3DGS rules.
    fn default() -> Self {
        RenderRequest {
            rgb: true,
            depth: false,
            alpha: false,
            max_weight_ids: false,
            features: None,
            background: [0.0; 3],
            sh_degree: None,
            settings: RasterSettings::default(),
        }
    }
}

impl RenderRequest<'_> {
    /// Everything but features: rgb, depth, alpha and max-weight ids.
    pub fn all() -> Self {
        RenderRequest { depth: true, alpha: true, max_weight_ids: true, ..Self::default() }
    }
}

/// Counters from a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Gaussians not culled.
    pub visible: usize,
    /// (Gaussian, tile) pairs.
    pub intersections: usize,
    /// (pixel, Gaussian) pairs blended.
    pub blends: u64,
}

/// Rendered images. Fields are `Some` exactly for the outputs requested.
#[derive(Clone, Debug, Default)]
pub struct RenderOutput {
    /// Image width, px.
    pub width: usize,
    /// Image height, px.
    pub height: usize,
    /// `[H, W, 3]` row-major colour (not clamped to [0, 1]).
    pub rgb: Option<Vec<f32>>,
    /// Expected metric depth (camera z); 0 where alpha is 0.
    pub depth: Option<Plane<f32>>,
    /// Accumulated alpha in [0, 1].
    pub alpha: Option<Plane<f32>>,
    /// Index of the Gaussian with the largest blending weight, −1 = none.
    pub max_weight_ids: Option<Plane<i32>>,
    /// `[H, W, D]` blended features.
    pub features: Option<Vec<f32>>,
    /// Counters.
    pub stats: RenderStats,
}

/// Gradients of a loss w.r.t. rendered outputs; `None` = zero. Shapes as in [`RenderOutput`].
#[derive(Clone, Copy, Debug, Default)]
pub struct OutputGrads<'a> {
    /// `[H, W, 3]`.
    pub rgb: Option<&'a [f32]>,
    /// `[H, W]`.
    pub depth: Option<&'a [f32]>,
    /// `[H, W]`.
    pub alpha: Option<&'a [f32]>,
    /// `[H, W, D]`.
    pub features: Option<&'a [f32]>,
}

/// Gradients w.r.t. the Gaussians' raw parameters, laid out as in
/// [`splatseg_scene::Gaussians`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GaussianGrads {
    /// `[N, 3]`.
    pub means: Vec<[f32; 3]>,
    /// `[N, 3]`.
    pub log_scales: Vec<[f32; 3]>,
    /// `[N, 4]` w.r.t. the raw (unnormalised) quaternion `w, x, y, z`.
    pub rotations: Vec<[f32; 4]>,
    /// `[N]` w.r.t. the opacity before the sigmoid.
    pub raw_opacities: Vec<f32>,
    /// `[N, 3]`.
    pub sh_dc: Vec<[f32; 3]>,
    /// `[N, 3, K]` (INRIA channel-major layout, as `Gaussians::sh_rest`).
    pub sh_rest: Vec<f32>,
    /// `[N, D]` when features were rendered.
    pub features: Option<Vec<f32>>,
    /// `[N, 2]` w.r.t. the projected centre in pixels (what 3DGS densification accumulates;
    /// 3DGS's NDC-space gradient is this times `(W/2, H/2)`).
    pub means2d: Vec<[f32; 2]>,
}

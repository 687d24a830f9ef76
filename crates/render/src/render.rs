//! [`render`] and [`render_bwd`]: project → bin → rasterise, and back.
//!
//! Work mapping: per-Gaussian steps (projection, SH colour, their backward) run one Gaussian per
//! rayon work item (backward in fixed blocks concatenated in order); binning and rasterisation as
//! documented in [`crate::bin`] and [`crate::rasterise`]. Results do not depend on the thread count.
//!
//! Every output is one channel of a single blend: per Gaussian `[rgb (3) | features (D) |
//! depth (1)]`, whichever were asked for. Expected depth is the blended camera z divided by the
//! accumulated alpha (clamped at 1e-10), as gsplat's "ED" mode.

use crate::bin::{bin, TileBins};
use crate::camera::RenderCamera;
use crate::error::{RenderError, RenderResult};
use crate::project::{project, project_one_bwd, ParamGrad, ProjCam, Splat2d, SplatGrad};
use crate::rasterise::{
    rasterise, rasterise_bwd, RasterGrads, RasterInputs, RasterOutput, RasterOutputGrads,
};
use crate::request::{GaussianGrads, OutputGrads, RenderOutput, RenderRequest, RenderStats};
use crate::sh::{colour, colour_bwd, ShCoeffs};
use rayon::prelude::*;
use splatseg_scene::{Gaussians, Plane};

/// Accumulated alpha below which expected depth is not divided (gsplat's clamp).
const ALPHA_EPS: f32 = 1e-10;

/// Where each output lives among the blended channels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Layout {
    rgb: Option<usize>,
    features: Option<(usize, usize)>,
    depth: Option<usize>,
    count: usize,
}

impl Layout {
    fn new(request: &RenderRequest) -> Self {
        let mut count = 0;
        let rgb = request.rgb.then(|| {
            count += 3;
            0
        });
        let features = request.features.map(|f| {
            let at = count;
            count += f.dim;
            (at, f.dim)
        });
        let depth = request.depth.then(|| {
            count += 1;
            count - 1
        });
        // At least one channel, so the blend runs (alpha and ids need it too).
        Layout { rgb, features, depth, count: count.max(1) }
    }
}

/// Everything the backward needs from a forward pass.
#[derive(Clone, Debug)]
pub struct RenderState {
    /// `[N]` projected splats.
    pub splats: Vec<Splat2d>,
    /// Tile lists.
    pub bins: TileBins,
    /// Raw blend result.
    pub raster: RasterOutput,
    channels: Vec<f32>,
    layout: Layout,
    sh_degree: u8,
}

fn check_len(what: &'static str, got: usize, expected: usize) -> RenderResult<()> {
    if got == expected {
        Ok(())
    } else {
        Err(RenderError::Shape { what, got, expected })
    }
}

fn validate(g: &Gaussians, request: &RenderRequest) -> RenderResult<()> {
    let n = g.len();
    check_len("log_scales", g.log_scales.len(), n)?;
    check_len("rotations", g.rotations.len(), n)?;
    check_len("raw_opacities", g.raw_opacities.len(), n)?;
    if request.rgb {
        check_len("sh_dc", g.sh_dc.len(), n)?;
        check_len("sh_rest", g.sh_rest.len(), n * 3 * g.rest_per_channel())?;
    }
    if let Some(f) = request.features {
        if f.dim == 0 {
            return Err(RenderError::Shape { what: "feature dimension", got: 0, expected: 1 });
        }
        check_len("features", f.values.len(), n * f.dim)?;
        check_finite("feature", f.values.chunks_exact(f.dim))?;
    }
    if g.sh_degree > 3 {
        return Err(RenderError::ShDegree(g.sh_degree));
    }
    check_finite("mean", g.means.iter().map(|v| v.as_slice()))?;
    check_finite("log-scale", g.log_scales.iter().map(|v| v.as_slice()))?;
    check_finite("rotation", g.rotations.iter().map(|v| v.as_slice()))?;
    check_finite("raw opacity", g.raw_opacities.chunks_exact(1))?;
    if request.rgb {
        check_finite("SH coefficient", g.sh_dc.iter().map(|v| v.as_slice()))?;
        check_finite("SH coefficient", g.sh_rest.chunks(3 * g.rest_per_channel().max(1)))?;
    }
    Ok(())
}

/// Fails on the first row (one per Gaussian) holding a NaN or infinity.
fn check_finite<'a>(what: &'static str, rows: impl Iterator<Item = &'a [f32]>) -> RenderResult<()> {
    for (index, row) in rows.enumerate() {
        if !row.iter().all(|v| v.is_finite()) {
            return Err(RenderError::NonFinite { what, index });
        }
    }
    Ok(())
}

fn sh_coeffs(g: &Gaussians, i: usize) -> ShCoeffs<'_> {
    let k = g.rest_per_channel();
    ShCoeffs { dc: g.sh_dc[i], rest: &g.sh_rest[i * 3 * k..(i + 1) * 3 * k], k_per_channel: k }
}

fn view_dir(g: &Gaussians, i: usize, centre: [f32; 3]) -> [f32; 3] {
    let m = g.means[i];
    [m[0] - centre[0], m[1] - centre[1], m[2] - centre[2]]
}

/// `[N, C]` per-Gaussian channel values (zeros for culled Gaussians).
fn build_channels(
    g: &Gaussians,
    splats: &[Splat2d],
    request: &RenderRequest,
    layout: &Layout,
    centre: [f32; 3],
    degree: u8,
) -> Vec<f32> {
    let c = layout.count;
    let mut channels = vec![0.0f32; g.len() * c];
    channels.par_chunks_mut(c).enumerate().for_each(|(i, row)| {
        if splats[i].is_culled() {
            return;
        }
        if let Some(at) = layout.rgb {
            row[at..at + 3].copy_from_slice(&colour(&sh_coeffs(g, i), degree, view_dir(g, i, centre)));
        }
        if let (Some((at, d)), Some(f)) = (layout.features, request.features) {
            row[at..at + d].copy_from_slice(&f.values[i * d..(i + 1) * d]);
        }
        if let Some(at) = layout.depth {
            row[at] = splats[i].depth;
        }
    });
    channels
}

/// Renders the Gaussians through `camera`. See [`RenderRequest`] for what can be asked for.
pub fn render(
    gaussians: &Gaussians,
    camera: &RenderCamera,
    request: &RenderRequest,
) -> RenderResult<RenderOutput> {
    render_with_state(gaussians, camera, request).map(|(out, _)| out)
}

/// [`render`], also returning the state [`render_bwd`] needs.
pub fn render_with_state(
    gaussians: &Gaussians,
    camera: &RenderCamera,
    request: &RenderRequest,
) -> RenderResult<(RenderOutput, RenderState)> {
    validate(gaussians, request)?;
    camera.validate()?;
    let (w, h) = (camera.width as usize, camera.height as usize);
    let layout = Layout::new(request);
    let degree = request.sh_degree.unwrap_or(gaussians.sh_degree).min(gaussians.sh_degree);
    let splats = project(gaussians, camera, &request.settings);
    let channels = build_channels(gaussians, &splats, request, &layout, camera.centre_f32(), degree);
    let bins = bin(&splats, w, h);
    let mut background = vec![0.0f32; layout.count];
    if let Some(at) = layout.rgb {
        background[at..at + 3].copy_from_slice(&request.background);
    }
    let inputs = RasterInputs {
        splats: &splats,
        channels: &channels,
        channel_count: layout.count,
        background: &background,
        width: w,
        height: h,
        settings: &request.settings,
    };
    let raster = rasterise(&inputs, &bins);
    let output = assemble(&raster, &layout, request, w, h, &splats, &bins);
    let state = RenderState { splats, bins, raster, channels, layout, sh_degree: degree };
    Ok((output, state))
}

fn gather(raster: &RasterOutput, c: usize, at: usize, d: usize) -> Vec<f32> {
    raster.channels.chunks_exact(c).flat_map(|px| px[at..at + d].iter().copied()).collect()
}

fn assemble(
    raster: &RasterOutput,
    layout: &Layout,
    request: &RenderRequest,
    w: usize,
    h: usize,
    splats: &[Splat2d],
    bins: &TileBins,
) -> RenderOutput {
    let c = layout.count;
    let alpha: Vec<f32> = raster.final_t.iter().map(|t| 1.0 - t).collect();
    let depth = layout.depth.map(|at| {
        let data =
            raster.channels.chunks_exact(c).zip(&alpha).map(|(px, &a)| px[at] / a.max(ALPHA_EPS)).collect();
        Plane { width: w, height: h, data }
    });
    RenderOutput {
        width: w,
        height: h,
        rgb: layout.rgb.map(|at| gather(raster, c, at, 3)),
        depth,
        alpha: request.alpha.then_some(Plane { width: w, height: h, data: alpha }),
        max_weight_ids: request.max_weight_ids.then(|| Plane {
            width: w,
            height: h,
            data: raster.max_weight_ids.clone(),
        }),
        features: layout.features.map(|(at, d)| gather(raster, c, at, d)),
        stats: RenderStats {
            visible: splats.iter().filter(|s| !s.is_culled()).count(),
            intersections: bins.intersection_count(),
            blends: raster.blends,
        },
    }
}

/// `[H·W, C]` channel gradients and `[H·W]` final-transmittance gradients from output gradients.
fn channel_grads(
    state: &RenderState,
    grads: &OutputGrads,
    pixels: usize,
) -> RenderResult<(Vec<f32>, Vec<f32>)> {
    let layout = state.layout;
    let c = layout.count;
    let mut g_ch = vec![0.0f32; pixels * c];
    let mut g_t = vec![0.0f32; pixels];
    let mut scatter = |src: &[f32], at: usize, d: usize| {
        for (dst, s) in g_ch.chunks_exact_mut(c).zip(src.chunks_exact(d)) {
            dst[at..at + d].copy_from_slice(s);
        }
    };
    if let Some(g) = grads.rgb {
        let at = layout.rgb.ok_or(RenderError::GradientWithoutOutput("rgb"))?;
        check_len("rgb gradient", g.len(), pixels * 3)?;
        scatter(g, at, 3);
    }
    if let Some(g) = grads.features {
        let (at, d) = layout.features.ok_or(RenderError::GradientWithoutOutput("features"))?;
        check_len("feature gradient", g.len(), pixels * d)?;
        scatter(g, at, d);
    }
    if let Some(g) = grads.alpha {
        check_len("alpha gradient", g.len(), pixels)?;
        for (t, &ga) in g_t.iter_mut().zip(g) {
            *t -= ga;
        }
    }
    if let Some(g) = grads.depth {
        let at = layout.depth.ok_or(RenderError::GradientWithoutOutput("depth"))?;
        check_len("depth gradient", g.len(), pixels)?;
        for p in 0..pixels {
            let a = 1.0 - state.raster.final_t[p];
            let d_acc = state.raster.channels[p * c + at];
            g_ch[p * c + at] = g[p] / a.max(ALPHA_EPS);
            if a > ALPHA_EPS {
                // ∂(D/A)/∂A = −D/A², and A = 1 − T.
                g_t[p] += g[p] * d_acc / (a * a);
            }
        }
    }
    Ok((g_ch, g_t))
}

/// Gaussians per work item of the per-Gaussian backward.
const BLOCK: usize = 4096;

/// What the per-Gaussian backward reads.
struct GaussianBwd<'a> {
    gaussians: &'a Gaussians,
    state: &'a RenderState,
    raster: &'a RasterGrads,
    cam: ProjCam,
    centre: [f32; 3],
    settings: &'a crate::settings::RasterSettings,
}

impl GaussianBwd<'_> {
    /// Gradients of the Gaussians in `range` (SH colour, features, projection).
    fn block(&self, range: std::ops::Range<usize>) -> GaussianGrads {
        let layout = self.state.layout;
        let c = layout.count;
        let k3 = 3 * self.gaussians.rest_per_channel();
        let mut g = GaussianGrads {
            sh_rest: vec![0.0; range.len() * k3],
            features: layout.features.map(|(_, d)| vec![0.0; range.len() * d]),
            ..Default::default()
        };
        for (j, i) in range.enumerate() {
            let chg = &self.raster.channels[i * c..(i + 1) * c];
            let mut dc = [0.0f32; 3];
            let mut dir_grad = [0.0f32; 3];
            let mut pg = ParamGrad::default();
            if !self.state.splats[i].is_culled() {
                if let Some(at) = layout.rgb {
                    let rest = &mut g.sh_rest[j * k3..(j + 1) * k3];
                    let d_colour = [chg[at], chg[at + 1], chg[at + 2]];
                    let coeffs = sh_coeffs(self.gaussians, i);
                    let dir = view_dir(self.gaussians, i, self.centre);
                    dir_grad = colour_bwd(&coeffs, self.state.sh_degree, dir, d_colour, &mut dc, rest);
                }
                if let (Some((at, d)), Some(f)) = (layout.features, g.features.as_mut()) {
                    f[j * d..(j + 1) * d].copy_from_slice(&chg[at..at + d]);
                }
                let sg = SplatGrad {
                    mean2d: self.raster.mean2d[i],
                    conic: self.raster.conic[i],
                    opacity: self.raster.opacity[i],
                    depth: layout.depth.map_or(0.0, |at| chg[at]),
                };
                pg = project_one_bwd(&self.cam, self.gaussians, i, self.settings, &sg);
            }
            g.means.push([0, 1, 2].map(|k| pg.mean[k] + dir_grad[k]));
            g.log_scales.push(pg.log_scales);
            g.rotations.push(pg.rotation);
            g.raw_opacities.push(pg.raw_opacity);
            g.sh_dc.push(dc);
            g.means2d.push(self.raster.mean2d[i]);
        }
        g
    }
}

/// Backward of [`render_with_state`]: gradients w.r.t. the Gaussians' raw parameters given the
/// gradients of a loss w.r.t. the outputs. `gaussians`, `camera` and `request` must be those of
/// the forward pass that produced `state`.
pub fn render_bwd(
    gaussians: &Gaussians,
    camera: &RenderCamera,
    request: &RenderRequest,
    state: &RenderState,
    grads: &OutputGrads,
) -> RenderResult<GaussianGrads> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let layout = state.layout;
    let (g_ch, g_t) = channel_grads(state, grads, w * h)?;
    let mut background = vec![0.0f32; layout.count];
    if let Some(at) = layout.rgb {
        background[at..at + 3].copy_from_slice(&request.background);
    }
    let inputs = RasterInputs {
        splats: &state.splats,
        channels: &state.channels,
        channel_count: layout.count,
        background: &background,
        width: w,
        height: h,
        settings: &request.settings,
    };
    let rg = rasterise_bwd(
        &inputs,
        &state.bins,
        &state.raster,
        &RasterOutputGrads { channels: &g_ch, final_t: Some(&g_t) },
    );
    let ctx = GaussianBwd {
        gaussians,
        state,
        raster: &rg,
        cam: ProjCam::new(camera),
        centre: camera.centre_f32(),
        settings: &request.settings,
    };
    let n = gaussians.len();
    let blocks: Vec<GaussianGrads> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| ctx.block(b * BLOCK..((b + 1) * BLOCK).min(n)))
        .collect();
    Ok(concat(blocks, layout.features.is_some()))
}

/// Concatenates per-block gradients in block order.
fn concat(blocks: Vec<GaussianGrads>, features: bool) -> GaussianGrads {
    let mut out = GaussianGrads { features: features.then(Vec::new), ..Default::default() };
    for g in blocks {
        out.means.extend(g.means);
        out.log_scales.extend(g.log_scales);
        out.rotations.extend(g.rotations);
        out.raw_opacities.extend(g.raw_opacities);
        out.sh_dc.extend(g.sh_dc);
        out.sh_rest.extend(g.sh_rest);
        out.means2d.extend(g.means2d);
        if let (Some(o), Some(f)) = (out.features.as_mut(), g.features) {
            o.extend(f);
        }
    }
    out
}

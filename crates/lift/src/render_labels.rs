//! Label maps rendered back from the labelled Gaussians, so every view shows the same id (and
//! colour) for the same object.
//!
//! Each pixel sums the blending weights `α·T` of the Gaussians the renderer blends there
//! ([`splatseg_render::visit_contributions`]) per vote label: object ids, and 0 for Gaussians that belong to no object; the light left after
//! the last splat (`T_final`, the background) also counts for 0. Unreliable Gaussians (filtered
//! by τ_var, id −1 in the PLY) vote for their majority id with their weight scaled by
//! `unreliable_render_weight`: reliable neighbours decide where they are present, and where
//! only unreliable Gaussians cover a pixel the majority still fills it instead of leaving a
//! hole. Gaussians seen in too few views abstain (occlude, no vote).
//! A pixel shows an object when the (unscaled) weight of the object votes exceeds the light left
//! for the background plus the weight of "no object" votes (unreliable Gaussians still cover
//! the pixel), and then the object with the largest (scaled) summed weight. Up to [`PIXEL_SLOTS`] labels are
//! tracked per pixel (the weakest is replaced when a new one arrives).

use crate::config::LiftConfig;
use crate::contributions::project_view;
use crate::error::LiftResult;
use crate::lifting::{GaussianStatus, Lifted};
use crate::prepared::PreparedGaussians;
use splatseg_render::{visit_contributions, Contribution, ContributionVisitor, RasterSettings};
use splatseg_scene::{Camera, Plane, Pose};

/// Labels tracked per pixel.
pub const PIXEL_SLOTS: usize = 4;

/// Marks a Gaussian that occludes but does not vote.
pub const ABSTAIN: u32 = u32::MAX;

/// What each Gaussian votes for when label maps are rendered back.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderVotes {
    /// `[N]` object id, 0 = no object, [`ABSTAIN`] = occludes but does not vote.
    pub labels: Vec<u32>,
    /// `[N]` factor on the blending weight of each vote.
    pub weights: Vec<f32>,
}

impl RenderVotes {
    /// Every Gaussian votes for its label (`[N]`) at full weight.
    pub fn uniform(labels: Vec<u32>) -> Self {
        let weights = vec![1.0; labels.len()];
        RenderVotes { labels, weights }
    }
}

/// The votes of the lifted Gaussians (see the module docs).
pub fn render_votes(lifted: &Lifted, config: &LiftConfig) -> RenderVotes {
    let (labels, weights) = lifted
        .status
        .iter()
        .zip(&lifted.majority_ids)
        .map(|(s, &majority)| match s {
            GaussianStatus::Labelled | GaussianStatus::NoObject => (majority, 1.0),
            GaussianStatus::Unreliable => (majority, config.unreliable_render_weight),
            GaussianStatus::TooFewViews | GaussianStatus::Unseen => (ABSTAIN, 0.0),
        })
        .unzip();
    RenderVotes { labels, weights }
}

/// Per-pixel label slots of one band of the image.
struct LabelSlots<'a> {
    votes: &'a RenderVotes,
    /// Pixel index of the band's first pixel.
    first: usize,
    ids: Vec<[u32; PIXEL_SLOTS]>,
    weights: Vec<[f32; PIXEL_SLOTS]>,
    /// `[band pixels]` unscaled weight of the votes for objects (ids ≥ 1).
    covered: Vec<f32>,
    /// `[band pixels]` the winning label.
    out: Vec<u32>,
}

impl ContributionVisitor for LabelSlots<'_> {
    fn contribution(&mut self, c: Contribution) {
        let g = c.gaussian as usize;
        let label = self.votes.labels[g];
        if label == ABSTAIN {
            return;
        }
        let weight = c.weight * self.votes.weights[g];
        let p = c.pixel - self.first;
        if label != 0 {
            self.covered[p] += c.weight;
        }
        let (ids, weights) = (&mut self.ids[p], &mut self.weights[p]);
        if let Some(s) = ids.iter().position(|&x| x == label) {
            weights[s] += weight;
        } else if let Some(s) = ids.iter().position(|&x| x == ABSTAIN) {
            ids[s] = label;
            weights[s] = weight;
        } else {
            let weakest = (0..PIXEL_SLOTS).min_by(|&a, &b| weights[a].total_cmp(&weights[b])).unwrap_or(0);
            if weights[weakest] < weight {
                ids[weakest] = label;
                weights[weakest] = weight;
            }
        }
    }

    fn pixel_done(&mut self, pixel: usize, t_final: f32) {
        let p = pixel - self.first;
        let empty = t_final
            + (0..PIXEL_SLOTS).filter(|&s| self.ids[p][s] == 0).map(|s| self.weights[p][s]).sum::<f32>();
        let mut best = (0u32, 0.0f32);
        if self.covered[p] > empty {
            for s in 0..PIXEL_SLOTS {
                let (id, w) = (self.ids[p][s], self.weights[p][s]);
                if id == ABSTAIN || id == 0 {
                    continue;
                }
                if w > best.1 || (w == best.1 && id < best.0) {
                    best = (id, w);
                }
            }
        }
        self.out[p] = best.0;
    }
}

/// Renders the label map of one view: `[height, width]`, value = object id, 0 = none.
/// `votes` from [`render_votes`] (or [`RenderVotes::uniform`]).
pub fn render_label_map(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> LiftResult<Plane<u32>> {
    let view = project_view(gaussians, camera, world_from_cam, config)?;
    let (width, height) = (view.width, view.height);
    let band_px = splatseg_render::bin::TILE_SIZE * width;
    let bands = visit_contributions(&view, &RasterSettings::default(), |band| {
        let n = band_px.min(width * height - band * band_px);
        LabelSlots {
            votes,
            first: band * band_px,
            ids: vec![[ABSTAIN; PIXEL_SLOTS]; n],
            weights: vec![[0.0; PIXEL_SLOTS]; n],
            covered: vec![0.0; n],
            out: vec![0; n],
        }
    });
    let data = bands.into_iter().flat_map(|b| b.out).collect();
    Ok(Plane { width, height, data })
}

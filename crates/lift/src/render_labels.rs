//! Label maps rendered back from the labelled Gaussians, so every view shows the same id (and
//! colour) for the same object.
//!
//! Each pixel composites the Gaussians front to back (the renderer's own compositor,
//! `splatseg_render::visit_contributions`) and sums the blending weights `α·T` per
//! vote label: object ids, and 0 for Gaussians that belong to no object; the light left after
//! the last splat (`T_final`, the background) also counts for 0. Unreliable Gaussians (filtered
//! by τ_var, id −1 in the PLY) vote for their majority id with their weight scaled by
//! `unreliable_render_weight`: reliable neighbours decide where they are present, and where
//! only unreliable Gaussians cover a pixel the majority still fills it instead of leaving a
//! hole. Gaussians seen in too few views abstain (occlude, no vote).
//! The pixel takes the label with the largest summed weight. Up to [`PIXEL_SLOTS`] labels are
//! tracked per pixel (the weakest is replaced when a new one arrives).

use crate::config::LiftConfig;
use crate::lifting::{GaussianStatus, Lifted};
use crate::project::{project_view, raster_settings, PreparedGaussians};
use splatseg_render::{visit_contributions, Contribution, ContributionVisitor, ProjectedView};
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

/// Per-pixel label slots of one band of 16 rows (`[rows · width]` each), and the band's labels.
struct LabelBand<'a> {
    votes: &'a RenderVotes,
    first: usize,
    ids: Vec<[u32; PIXEL_SLOTS]>,
    weights: Vec<[f32; PIXEL_SLOTS]>,
    labels: Vec<u32>,
}

impl ContributionVisitor for LabelBand<'_> {
    #[inline]
    fn contribution(&mut self, c: Contribution) -> bool {
        let g = c.gaussian as usize;
        let label = self.votes.labels[g];
        if label == ABSTAIN {
            return true;
        }
        let weight = c.weight * self.votes.weights[g];
        let p = c.pixel - self.first;
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
        true
    }

    fn pixel_done(&mut self, pixel: usize, t_final: f32) {
        let p = pixel - self.first;
        let mut best = (0u32, t_final);
        for s in 0..PIXEL_SLOTS {
            let (id, w) = (self.ids[p][s], self.weights[p][s]);
            if id == ABSTAIN {
                continue;
            }
            let w = if id == 0 { w + t_final } else { w };
            if w > best.1 || (w == best.1 && id < best.0) {
                best = (id, w);
            }
        }
        self.labels[p] = best.0;
    }
}

/// The label map of a projected view (see the module docs): `[height, width]`, value = object
/// id, 0 = none.
pub fn label_map_of_view(view: &ProjectedView, votes: &RenderVotes) -> Plane<u32> {
    let (width, height) = (view.width, view.height);
    let band_rows = splatseg_render::bin::TILE_SIZE;
    let bands = visit_contributions(view, &raster_settings(), |b| {
        let n = band_rows.min(height - b * band_rows) * width;
        LabelBand {
            votes,
            first: b * band_rows * width,
            ids: vec![[ABSTAIN; PIXEL_SLOTS]; n],
            weights: vec![[0f32; PIXEL_SLOTS]; n],
            labels: vec![0; n],
        }
    });
    let mut data = Vec::with_capacity(width * height);
    for band in bands {
        data.extend(band.labels);
    }
    Plane { width, height, data }
}

/// Renders the label map of one view: `[height, width]`, value = object id, 0 = none.
/// `votes` from [`render_votes`] (or [`RenderVotes::uniform`]).
pub fn render_label_map(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> Plane<u32> {
    label_map_of_view(&project_view(gaussians, camera, world_from_cam, config), votes)
}

//! Label maps rendered back from the labelled Gaussians, so every view shows the same id (and
//! colour) for the same object.
//!
//! Each pixel composites the footprints front to back and sums the blending weights `α·T` per
//! vote label: object ids, and 0 for Gaussians that belong to no object; the light left after
//! the last splat (`T_final`, the background) also counts for 0. Unreliable Gaussians (filtered
//! by τ_var, id −1 in the PLY) vote for their majority id with their weight scaled by
//! `unreliable_render_weight`: reliable neighbours decide where they are present, and where
//! only unreliable Gaussians cover a pixel the majority still fills it instead of leaving a
//! hole. Gaussians seen in too few views abstain (occlude, no vote).
//! The pixel takes the label with the largest summed weight. Up to [`PIXEL_SLOTS`] labels are
//! tracked per pixel (the weakest is replaced when a new one arrives).

use crate::composite::{composite, sort_by_depth};
use crate::config::LiftConfig;
use crate::lifting::{GaussianStatus, Lifted};
use crate::project::{project_view, PreparedGaussians};
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

/// Renders the label map of one view: `[height, width]`, value = object id, 0 = none.
/// `votes` from [`render_votes`] (or [`RenderVotes::uniform`]).
pub fn render_label_map(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
) -> Plane<u32> {
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut splats = project_view(gaussians, camera, world_from_cam, config);
    sort_by_depth(&mut splats);
    let mut ids = vec![[ABSTAIN; PIXEL_SLOTS]; width * height];
    let mut weights = vec![[0f32; PIXEL_SLOTS]; width * height];
    let transmittance = composite(&splats, width, height, 1e-4, |p, k, weight, _| {
        let g = splats[k].index as usize;
        let label = votes.labels[g];
        if label == ABSTAIN {
            return;
        }
        let weight = weight * votes.weights[g];
        let (ids, weights) = (&mut ids[p], &mut weights[p]);
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
    });
    let data = (0..width * height)
        .map(|p| {
            let mut best = (0u32, transmittance[p]);
            for s in 0..PIXEL_SLOTS {
                let (id, w) = (ids[p][s], weights[p][s]);
                if id == ABSTAIN {
                    continue;
                }
                let w = if id == 0 { w + transmittance[p] } else { w };
                if w > best.1 || (w == best.1 && id < best.0) {
                    best = (id, w);
                }
            }
            best.0
        })
        .collect();
    Plane { width, height, data }
}

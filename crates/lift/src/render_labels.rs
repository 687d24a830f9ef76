//! Label maps rendered back from the labelled Gaussians, so every view shows the same id (and
//! colour) for the same object.
//!
//! Each pixel composites the Gaussians front to back (the renderer's own compositor,
//! `splatseg_render::visit_contributions`) and sums the blending weights `α·T` per
//! vote label: object ids, and 0 for Gaussians that belong to no object; the light left after
//! the last splat (`T_final`, the background) also counts for 0. Unreliable Gaussians (filtered
//! by τ_var, id −1 in the PLY) vote for their majority id with their weight scaled by
//! [`UNRELIABLE_RENDER_WEIGHT`]: reliable neighbours decide where they are present, and where
//! only unreliable Gaussians cover a pixel the majority still fills it instead of leaving a
//! hole. Gaussians seen in too few views abstain (occlude, no vote).
//! The pixel takes the label with the largest summed weight. Up to [`PIXEL_SLOTS`] labels are
//! tracked per pixel (the weakest is replaced when a new one arrives).
//!
//! A pixel is finished as soon as its label is decided: once the leading label's weight exceeds
//! every other tracked label's weight plus all the light still to come (the transmittance left,
//! times the largest vote factor), with a margin far above float rounding, nothing behind can
//! change the winner, and the compositor stops the pixel there (the same label as compositing to
//! the end; test `stopping_at_the_decision_gives_the_full_pass_labels`).

use crate::config::LiftConfig;
use crate::error::LiftResult;
use crate::lifting::{GaussianStatus, Lifted};
use crate::project::{project_view, project_view_binned, raster_settings, PreparedGaussians};
use splatseg_render::bin::TileBins;
use splatseg_render::{visit_contributions, Contribution, ContributionVisitor, ProjectedView};
use splatseg_scene::{Camera, Plane, Pose};

/// Vote factor of unreliable Gaussians (reliable ones: 1): low enough that reliable neighbours
/// decide where they are present, non-zero so a pixel only unreliable Gaussians cover is filled
/// by their majority instead of left a hole.
const UNRELIABLE_RENDER_WEIGHT: f32 = 0.25;

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
pub fn render_votes(lifted: &Lifted, _config: &LiftConfig) -> RenderVotes {
    let (labels, weights) = lifted
        .status
        .iter()
        .zip(&lifted.majority_ids)
        .map(|(s, &majority)| match s {
            GaussianStatus::Labelled | GaussianStatus::NoObject => (majority, 1.0),
            GaussianStatus::Unreliable => (majority, UNRELIABLE_RENDER_WEIGHT),
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
    /// Bound on what the light left can still add to one label, per unit of transmittance
    /// (`max(1, largest vote factor)`; +∞ disables the early decision).
    remaining_factor: f32,
}

/// Relative margin of the early decision over float rounding: the weights still to come are
/// summed in at most ~2,400 steps (α ≥ 1/255 until T ≤ 1e-4), each off by a few ulps, i.e. a
/// relative error below 1e-3 of the light left; 1/64 is far above it.
const DECISION_MARGIN: f32 = 1.0 / 64.0;

/// [`LabelBand::remaining_factor`] for `votes`.
fn remaining_factor(votes: &RenderVotes) -> f32 {
    let mut largest = 1.0f32;
    for &w in &votes.weights {
        if !(w >= 0.0 && w.is_finite()) {
            return f32::INFINITY;
        }
        largest = largest.max(w);
    }
    largest
}

/// Whether the leading label of the slots `(ids, weights)` wins whatever light `t_left` is still
/// to come (each unit of it adding at most `factor` to one label, and the background's share to
/// label 0): its weight beats every other slot's plus the most the rest can add, with margin.
#[inline(always)]
fn decided(ids: &[u32; PIXEL_SLOTS], weights: &[f32; PIXEL_SLOTS], t_left: f32, factor: f32) -> bool {
    let (mut lead, mut other) = (0.0f32, 0.0f32);
    for s in 0..PIXEL_SLOTS {
        if ids[s] != ABSTAIN {
            let w = weights[s];
            if w > lead {
                (lead, other) = (w, lead);
            } else {
                other = other.max(w);
            }
        }
    }
    lead > (other + t_left * factor) * (1.0 + DECISION_MARGIN) + 1e-6
}

/// [`decided`] for slots holding one label of weight `weight` (the others empty).
#[inline(always)]
fn decided_alone(weight: f32, t_left: f32, factor: f32) -> bool {
    // `decided` leads with `weight` when it is positive (else with 0), the other at 0.
    let lead = if weight > 0.0 { weight } else { 0.0 };
    lead > (0.0 + t_left * factor) * (1.0 + DECISION_MARGIN) + 1e-6
}

impl ContributionVisitor for LabelBand<'_> {
    #[inline(always)]
    fn prefetch(&self, gaussian: u32) {
        splatseg_render::prefetch(&self.votes.labels[gaussian as usize]);
        splatseg_render::prefetch(&self.votes.weights[gaussian as usize]);
    }

    #[inline(always)]
    fn contribution(&mut self, c: Contribution) -> bool {
        let g = c.gaussian as usize;
        let label = self.votes.labels[g];
        let p = c.pixel - self.first;
        let (ids, weights) = (&mut self.ids[p], &mut self.weights[p]);
        // The common case: the pixel has seen one label so far, and this is it. The general
        // rule below would add to slot 0 and find slot 0 leading with nothing else tracked.
        if label != ABSTAIN && ids[0] == label && ids[1..].iter().all(|&x| x == ABSTAIN) {
            weights[0] += c.weight * self.votes.weights[g];
            return !decided_alone(weights[0], c.t_after, self.remaining_factor);
        }
        if label != ABSTAIN {
            let weight = c.weight * self.votes.weights[g];
            if let Some(s) = ids.iter().position(|&x| x == label) {
                weights[s] += weight;
            } else if let Some(s) = ids.iter().position(|&x| x == ABSTAIN) {
                ids[s] = label;
                weights[s] = weight;
            } else {
                let weakest =
                    (0..PIXEL_SLOTS).min_by(|&a, &b| weights[a].total_cmp(&weights[b])).unwrap_or(0);
                if weights[weakest] < weight {
                    ids[weakest] = label;
                    weights[weakest] = weight;
                }
            }
        }
        // Finished once the leading label is decided; `pixel_done`'s rule then picks it too
        // (label 0's share of the light left is inside the bound).
        !decided(ids, weights, c.t_after, self.remaining_factor)
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
pub(crate) fn label_map_of_view(view: &ProjectedView, votes: &RenderVotes) -> Plane<u32> {
    let (width, height) = (view.width, view.height);
    let band_rows = splatseg_render::bin::TILE_SIZE;
    let factor = remaining_factor(votes);
    let bands = visit_contributions(view, &raster_settings(), |b| {
        let n = band_rows.min(height - b * band_rows) * width;
        LabelBand {
            votes,
            first: b * band_rows * width,
            ids: vec![[ABSTAIN; PIXEL_SLOTS]; n],
            weights: vec![[0f32; PIXEL_SLOTS]; n],
            labels: vec![0; n],
            remaining_factor: factor,
        }
    });
    let mut data = Vec::with_capacity(width * height);
    for band in bands {
        data.extend(band.labels);
    }
    Plane { width, height, data }
}

/// Renders the label map of one view: `[height, width]`, value = object id, 0 = none.
/// `votes` from [`render_votes`] (or [`RenderVotes::uniform`]). `tile_lists`: the view's lists
/// from an earlier pass ([`crate::view_visibility`] of the same Gaussians, camera and config),
/// to reuse instead of sorting the splats again (the same map), or `None`; lists that do not fit
/// the view are an error.
pub fn render_label_map(
    gaussians: &PreparedGaussians,
    votes: &RenderVotes,
    camera: &Camera,
    world_from_cam: &Pose,
    config: &LiftConfig,
    tile_lists: Option<TileBins>,
) -> LiftResult<Plane<u32>> {
    let view = match tile_lists {
        Some(bins) => project_view_binned(gaussians, camera, world_from_cam, config, bins)?,
        None => project_view(gaussians, camera, world_from_cam, config),
    };
    Ok(label_map_of_view(&view, votes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use splatseg_scene::Gaussians;

    /// Many overlapping Gaussians of mixed sizes and opacities in front of an 80×64 camera.
    fn crowded_view(seed: u64, n: usize) -> ProjectedView {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut g = Gaussians::default();
        for _ in 0..n {
            let z = rng.gen_range(2.0f32..6.0);
            g.means.push([rng.gen_range(-0.6..0.6) * z, rng.gen_range(-0.5..0.5) * z, z]);
            let s = rng.gen_range(-3.5f32..-1.5);
            g.log_scales.push([s, s + rng.gen_range(-0.8..0.8), s + rng.gen_range(-0.8..0.8)]);
            g.rotations.push([
                1.0,
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            ]);
            g.raw_opacities.push(rng.gen_range(-3.0..5.0));
            g.sh_dc.push([0.0; 3]);
        }
        let prepared = PreparedGaussians::new(&g).expect("finite");
        let camera = Camera::pinhole(1, 80, 64, 70.0, 70.0, 40.0, 32.0);
        project_view(&prepared, &camera, &Pose::IDENTITY, &LiftConfig::default())
    }

    /// Counts the contributions a band's visitor takes.
    struct Counted<'a>(LabelBand<'a>, u64);

    impl ContributionVisitor for Counted<'_> {
        fn contribution(&mut self, c: Contribution) -> bool {
            self.1 += 1;
            self.0.contribution(c)
        }
        fn pixel_done(&mut self, pixel: usize, t_final: f32) {
            self.0.pixel_done(pixel, t_final)
        }
    }

    /// The label map and the number of contributions taken, with the early decision on or off.
    fn render(view: &ProjectedView, votes: &RenderVotes, early: bool) -> (Vec<u32>, u64) {
        let factor = if early { remaining_factor(votes) } else { f32::INFINITY };
        let bands = visit_contributions(view, &raster_settings(), |b| {
            let n = 16.min(view.height - b * 16) * view.width;
            Counted(
                LabelBand {
                    votes,
                    first: b * 16 * view.width,
                    ids: vec![[ABSTAIN; PIXEL_SLOTS]; n],
                    weights: vec![[0f32; PIXEL_SLOTS]; n],
                    labels: vec![0; n],
                    remaining_factor: factor,
                },
                0,
            )
        });
        let taken = bands.iter().map(|b| b.1).sum();
        (bands.into_iter().flat_map(|b| b.0.labels).collect(), taken)
    }

    /// Rendering back with the tile lists the visibility pass kept gives the map of rendering
    /// from scratch, pixel for pixel; lists of another view's image are an error.
    #[test]
    fn the_kept_tile_lists_give_the_same_map() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut g = Gaussians::default();
        for _ in 0..2000 {
            let z = rng.gen_range(2.0f32..6.0);
            g.means.push([rng.gen_range(-0.6..0.6) * z, rng.gen_range(-0.5..0.5) * z, z]);
            let s = rng.gen_range(-3.5f32..-1.5);
            g.log_scales.push([s, s, s + 0.3]);
            g.rotations.push([1.0, rng.gen_range(-1.0..1.0), 0.0, 0.0]);
            g.raw_opacities.push(rng.gen_range(-1.0..5.0));
            g.sh_dc.push([0.0; 3]);
        }
        let prepared = PreparedGaussians::new(&g).expect("finite");
        let camera = Camera::pinhole(1, 90, 70, 70.0, 70.0, 45.0, 35.0);
        let config = LiftConfig::default();
        let votes = RenderVotes::uniform((0..2000u32).map(|i| i % 7).collect());
        let bins = crate::view_visibility(&prepared, &camera, &Pose::IDENTITY, None, &config).tile_lists;
        let fresh =
            render_label_map(&prepared, &votes, &camera, &Pose::IDENTITY, &config, None).expect("renders");
        let kept = render_label_map(&prepared, &votes, &camera, &Pose::IDENTITY, &config, Some(bins.clone()))
            .expect("the lists fit");
        assert_eq!(kept.data, fresh.data);
        let labels: std::collections::BTreeSet<u32> = fresh.data.iter().copied().collect();
        assert!(labels.len() >= 5, "{labels:?}");
        let other = Camera::pinhole(1, 120, 70, 70.0, 70.0, 60.0, 35.0);
        assert!(render_label_map(&prepared, &votes, &other, &Pose::IDENTITY, &config, Some(bins)).is_err());
    }

    /// The one-label shortcut decides exactly as the general rule does on such slots, over
    /// random weights, transmittances and factors and the edge values (0, −0, NaN, ∞).
    #[test]
    fn the_one_label_decision_equals_the_general_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let edges = [0.0f32, -0.0, f32::NAN, f32::INFINITY, 1e-6, 0.5, 1.0];
        let (mut yes, mut no) = (0, 0);
        for i in 0..200_000 {
            let pick = |rng: &mut ChaCha8Rng, hi: f32| {
                if rng.gen_bool(0.05) {
                    edges[rng.gen_range(0..edges.len())]
                } else {
                    rng.gen_range(0.0..hi)
                }
            };
            let (w, t) = (pick(&mut rng, 1.2), pick(&mut rng, 1.0));
            let factor = [1.0, 2.5, f32::INFINITY, 0.25][i % 4];
            let ids = [7, ABSTAIN, ABSTAIN, ABSTAIN];
            let weights = [w, rng.gen_range(0.0..1.0), 0.0, 3.0];
            let general = decided(&ids, &weights, t, factor);
            assert_eq!(decided_alone(w, t, factor), general, "w {w}, t {t}, factor {factor}");
            if general {
                yes += 1;
            } else {
                no += 1;
            }
        }
        assert!(yes > 10_000 && no > 10_000, "{yes} decided, {no} not");
    }

    /// Finishing a pixel once its label is decided gives exactly the labels of compositing every
    /// pixel to the end, with far fewer contributions: over many labels (more than the slots),
    /// label 0, abstaining Gaussians, down-weighted votes and votes weighing more than 1.
    #[test]
    fn stopping_at_the_decision_gives_the_full_pass_labels() {
        let mut stopped_early = 0;
        for (seed, labels_in_play, top_factor) in
            [(1u64, 3u32, 1.0f32), (2, 9, 1.0), (3, 6, 2.5), (4, 40, 1.0)]
        {
            let view = crowded_view(seed, 3000);
            let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
            let n = view.splats.len();
            let labels: Vec<u32> = (0..n)
                .map(|_| if rng.gen_bool(0.1) { ABSTAIN } else { rng.gen_range(0..labels_in_play) })
                .collect();
            let weights: Vec<f32> =
                (0..n).map(|_| [1.0, 0.25, 0.0, top_factor][rng.gen_range(0..4usize)]).collect();
            let votes = RenderVotes { labels, weights };
            let (full, full_taken) = render(&view, &votes, false);
            let (early, early_taken) = render(&view, &votes, true);
            assert_eq!(early, full, "seed {seed}");
            let distinct: std::collections::BTreeSet<u32> = full.iter().copied().collect();
            assert!(distinct.len() >= 3.min(labels_in_play as usize), "seed {seed}: {distinct:?}");
            assert!(early_taken <= full_taken, "seed {seed}");
            if early_taken * 10 < full_taken * 9 {
                stopped_early += 1;
            }
        }
        assert!(stopped_early >= 3, "the decision stopped few pixels early: the test proves little");
        // A non-finite or negative vote factor switches the decision off.
        let votes = RenderVotes { labels: vec![1, 2], weights: vec![1.0, -1.0] };
        assert_eq!(remaining_factor(&votes), f32::INFINITY);
    }
}

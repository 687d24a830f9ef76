//! Every view's label map after the edits, from the run's own map and the labels rendered back
//! from the Gaussians before and after them by the production path
//! ([`splatseg_lift::render_label_map`], lifting's compositor).
//!
//! A pixel takes what the edited Gaussians render there when that differs from what the run's
//! Gaussians rendered with the merges applied (a split, a lasso or an assignment moved the
//! Gaussians it shows); elsewhere it keeps the run's final id with the merges applied, so what
//! the final maps made of the rendered ids (snapped onto SAM's regions, refined by colour, filled
//! from the matched masks) stays wherever the edits do not reach. A fix made in one view so
//! holds in every view, through the Gaussians.

use splatseg_edit::Edited;
use splatseg_lift::render_labels::ABSTAIN;
use splatseg_lift::{render_label_map, LiftConfig, PosedCamera, PreparedGaussians, RenderVotes};
use splatseg_scene::Plane;

/// The votes of Gaussians with these ids (`[N]`, the rendered rows): ids ≥ 1 vote for
/// themselves, the others occlude without voting (as `train` renders its maps).
pub fn votes_of(ids: impl Iterator<Item = i32>) -> RenderVotes {
    RenderVotes::uniform(ids.map(|id| if id > 0 { id as u32 } else { ABSTAIN }).collect())
}

/// The Gaussians and their votes before and after the edits.
pub struct EditedRender<'a> {
    /// The finite Gaussians.
    pub gaussians: &'a PreparedGaussians,
    /// Votes of the run's ids.
    pub before: &'a RenderVotes,
    /// Votes of the edited ids (`None`: no Gaussian changed id).
    pub after: Option<&'a RenderVotes>,
    /// The edits' results.
    pub edited: &'a Edited,
}

impl EditedRender<'_> {
    /// `[H, W]` the edited map of the view `camera` shows, from the run's final map `run_map`.
    pub fn view_map(&self, camera: PosedCamera, run_map: &Plane<u32>) -> crate::Result<Plane<u32>> {
        let config = LiftConfig::default();
        let render = |votes: &RenderVotes| {
            render_label_map(self.gaussians, votes, camera.camera, camera.world_from_cam, &config, None)
        };
        let became = |id: u32| if id == 0 { 0 } else { self.edited.object_became(id as i32).max(0) as u32 };
        let before = render(self.before)?;
        let after = match self.after {
            Some(votes) => render(votes)?,
            None => before.clone(),
        };
        if (before.width, before.height) != (run_map.width, run_map.height) {
            crate::error::bail!(
                "the run's label map is {}×{} but its camera renders {}×{}: the scene changed since the run",
                run_map.width,
                run_map.height,
                before.width,
                before.height
            );
        }
        let data = run_map
            .data
            .iter()
            .zip(&before.data)
            .zip(&after.data)
            .map(|((&run, &b), &a)| if a != became(b) { a } else { became(run) })
            .collect();
        Ok(Plane { width: run_map.width, height: run_map.height, data })
    }
}

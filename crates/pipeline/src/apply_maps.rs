//! Every view's label map after the edits, from the run's own map and the labels rendered back
//! from the Gaussians before and after them by the production path
//! ([`splatseg_lift::render_label_map`], lifting's compositor).
//!
//! A pixel takes what the edited Gaussians render there when that differs from what the run's
//! Gaussians rendered with the merges applied (a split, a lasso or an assignment moved the
//! Gaussians it shows) and the run's final map agreed with that render; elsewhere it keeps the
//! run's final id with the merges applied, so what the final maps made of the rendered ids
//! (snapped onto SAM's regions, refined by colour, filled from the matched masks) stays wherever
//! the edits do not reach, and where the final map had overruled the render (a wall pixel the
//! render gave a box) the edits do not undo it. A fix made in one view so holds in every view,
//! through the Gaussians.
//!
//! An object some of whose Gaussians moved to other ids (a split, an assignment) may still hold
//! pixels of the run's map where neither render shows it (its silhouette, widened by the snap onto
//! SAM's regions): each such pixel takes the id of the nearest pixel (4-connected, through such
//! pixels) that renders the object or one of the ids its Gaussians moved to, so the parts of a
//! split object divide its pixels between them rather than the old id keeping the edge.

use splatseg_edit::Edited;
use splatseg_lift::render_labels::ABSTAIN;
use splatseg_lift::{render_label_map, LiftConfig, PosedCamera, PreparedGaussians, RenderVotes};
use splatseg_scene::Plane;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// For each object (its id after the merges) some of whose Gaussians the edits moved to other
/// ids: those ids (`rows`: the rendered rows; −1 and 0 left out).
pub fn moved_to(rows: &[usize], run_ids: &[i32], edited: &Edited) -> BTreeMap<u32, BTreeSet<u32>> {
    let mut moved: BTreeMap<u32, BTreeSet<u32>> = BTreeMap::new();
    for &r in rows {
        let (was, now) = (edited.object_became(run_ids[r]), edited.ids[r]);
        if was > 0 && now != was {
            let parts = moved.entry(was as u32).or_default();
            if now > 0 {
                parts.insert(now as u32);
            }
        }
    }
    moved
}

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
    /// [`moved_to`] of the edits.
    pub moved: &'a BTreeMap<u32, BTreeSet<u32>>,
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
        let mut data: Vec<u32> = run_map
            .data
            .iter()
            .zip(&before.data)
            .zip(&after.data)
            .map(|((&run, &b), &a)| if a != became(b) && became(run) == became(b) { a } else { became(run) })
            .collect();
        if !self.moved.is_empty() {
            // The pixels a moved-from object keeps by the run's map alone (not by a render).
            let kept: Vec<bool> =
                data.iter().zip(&after.data).map(|(&d, &a)| d != a && self.moved.contains_key(&d)).collect();
            fill_from_nearest_part(&mut data, &kept, run_map.width, self.moved);
        }
        Ok(Plane { width: run_map.width, height: run_map.height, data })
    }
}

/// Gives each `kept` pixel (its value an object in `moved`) the value of the nearest pixel not
/// kept whose value is that object or one of its parts, found breadth-first through kept pixels
/// (4-connected; seeds in row-major order, so the result is deterministic); unreached pixels keep
/// their value.
fn fill_from_nearest_part(
    data: &mut [u32],
    kept: &[bool],
    width: usize,
    moved: &BTreeMap<u32, BTreeSet<u32>>,
) {
    let belongs =
        |part: u32, object: u32| part == object || moved.get(&object).is_some_and(|p| p.contains(&part));
    let is_part = |v: u32| moved.iter().any(|(&object, parts)| v == object || parts.contains(&v));
    let mut open = kept.to_vec();
    let mut queue: VecDeque<usize> = (0..data.len()).filter(|&p| !kept[p] && is_part(data[p])).collect();
    while let Some(p) = queue.pop_front() {
        let (x, v) = (p % width, data[p]);
        let neighbours = [
            (x > 0).then(|| p - 1),
            (x + 1 < width).then_some(p + 1),
            p.checked_sub(width),
            (p + width < data.len()).then_some(p + width),
        ];
        for q in neighbours.into_iter().flatten() {
            if open[q] && belongs(v, data[q]) {
                open[q] = false;
                data[q] = v;
                queue.push_back(q);
            }
        }
    }
}

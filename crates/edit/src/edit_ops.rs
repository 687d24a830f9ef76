//! Applying [`Edits`](crate::edits::Edits)' operations to a run's per-Gaussian object ids, in
//! order, each checked against the ids as the operations before it left them.

use crate::edits::{Box3, LassoCamera, MoveTarget, Operation, Selection};
use crate::error::EditError;
use crate::selection::selected_rows;
use glam::{DQuat, DVec2, DVec3};
use splatseg_scene::{Camera, Pose};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// What the operations start from: the run's own results.
pub struct EditBase<'a> {
    /// `[N]` the run's object id of every row of `gaussians.ply` (−1 = none).
    pub ids: &'a [i32],
    /// `[N]` centres of those rows.
    pub means: &'a [[f32; 3]],
    /// Ids the run's label maps show that no Gaussian carries (objects the maps keep from the
    /// matched masks): they may be merged or renamed too.
    pub map_only_ids: &'a BTreeSet<i32>,
    /// `[n_views]` the scene's cameras, for lassos drawn in a view.
    pub views: &'a [(&'a Camera, &'a Pose)],
}

/// The ids after the operations.
#[derive(Clone, Debug, PartialEq)]
pub struct Edited {
    /// `[N]` object id of every row.
    pub ids: Vec<i32>,
    /// Names given, by id (the final ids).
    pub names: BTreeMap<i32, String>,
    /// The id each of the run's objects became by the merges (ids not merged: absent). Splits and
    /// assignments move Gaussians, not objects, and are not in it.
    pub merged_into: BTreeMap<i32, i32>,
    /// Rows whose id changed.
    pub changed_rows: usize,
}

impl Edited {
    /// The id the run's object `id` became by the merges.
    pub fn object_became(&self, id: i32) -> i32 {
        self.merged_into.get(&id).copied().unwrap_or(id)
    }
}

/// Applies `operations` in order to `base` (`path`: the edits file, named in errors). The first
/// operation that selects something absent (an unknown id, rows out of range, a view the scene
/// lacks) is an error naming its index; nothing is returned then.
pub fn apply_operations(
    base: &EditBase,
    operations: &[crate::edits::Operation],
    path: &Path,
) -> Result<Edited, EditError> {
    let mut state = State::start(base)?;
    for (index, op) in operations.iter().enumerate() {
        state.apply(op, base).map_err(|message| EditError::EditOperation {
            index,
            kind: op.kind(),
            message,
            path: path.to_path_buf(),
        })?;
    }
    let changed_rows = state.ids.iter().zip(base.ids).filter(|(a, b)| a != b).count();
    Ok(Edited { ids: state.ids, names: state.names, merged_into: state.merged_into, changed_rows })
}

/// `[N]` whether each row is in `selection` after `operations` (what a `move` appended to them
/// would move): the viewer's highlighted selection. Errors as [`apply_operations`]'s; a selection
/// that cannot be used is named as the operation after the last.
pub fn selection_of(
    base: &EditBase,
    operations: &[Operation],
    selection: &Selection,
    path: &Path,
) -> Result<Vec<bool>, EditError> {
    let mut state = State::start(base)?;
    for (index, op) in operations.iter().enumerate() {
        state.apply(op, base).map_err(|message| EditError::EditOperation {
            index,
            kind: op.kind(),
            message,
            path: path.to_path_buf(),
        })?;
    }
    selected_rows(selection, &state.ids, base, &state.present).map_err(|message| EditError::EditOperation {
        index: operations.len(),
        kind: "move",
        message,
        path: path.to_path_buf(),
    })
}

/// The ids as the operations so far left them.
struct State {
    ids: Vec<i32>,
    /// Object ids in use (≥ 1).
    present: BTreeSet<i32>,
    names: BTreeMap<i32, String>,
    merged_into: BTreeMap<i32, i32>,
}

impl State {
    fn start(base: &EditBase) -> Result<State, EditError> {
        if base.ids.len() != base.means.len() {
            return Err(EditError::LengthMismatch {
                what: "centres",
                got: base.means.len(),
                expected: base.ids.len(),
                path: None,
            });
        }
        Ok(State {
            ids: base.ids.to_vec(),
            present: base
                .ids
                .iter()
                .copied()
                .filter(|&id| id >= 1)
                .chain(base.map_only_ids.iter().copied())
                .collect(),
            names: BTreeMap::new(),
            merged_into: BTreeMap::new(),
        })
    }

    fn apply(&mut self, op: &Operation, base: &EditBase) -> Result<(), String> {
        match op {
            Operation::Merge { ids, into } => self.merge(ids, *into),
            Operation::SplitBox { object, region, new_id } => {
                let inside = box_test(region)?;
                self.split(*object, *new_id, base, inside)
            }
            Operation::SplitLasso { object, camera, polygon_px, new_id } => {
                let project = camera_projection(camera, base.views)?;
                check_polygon(polygon_px)?;
                self.split(*object, *new_id, base, |p| {
                    project(p).is_some_and(|uv| inside_polygon(uv, polygon_px))
                })
            }
            Operation::Assign { ranges, id } => self.assign(ranges, *id),
            Operation::Move { select, to } => self.move_selection(select, *to, base),
            Operation::Rename { id, name } => {
                self.require(*id)?;
                if name.trim().is_empty() {
                    return Err(format!("the name of object {id} is empty"));
                }
                self.names.insert(*id, name.clone());
                Ok(())
            }
        }
    }

    /// An error unless object `id` exists now.
    fn require(&self, id: i32) -> Result<(), String> {
        if self.present.contains(&id) {
            return Ok(());
        }
        let shown: Vec<String> = self.present.iter().take(40).map(|i| i.to_string()).collect();
        let more = if self.present.len() > 40 { ", …" } else { "" };
        Err(format!("no object has id {id} here (ids present: {}{more})", shown.join(", ")))
    }

    fn merge(&mut self, ids: &[i32], into: Option<i32>) -> Result<(), String> {
        let set: BTreeSet<i32> = ids.iter().copied().collect();
        if set.len() < 2 {
            return Err(format!("a merge needs at least two distinct object ids, got {ids:?}"));
        }
        for &id in &set {
            self.require(id)?;
        }
        let into = into.unwrap_or(*set.iter().next().unwrap_or(&0));
        if !set.contains(&into) {
            return Err(format!("\"into\" {into} is not one of the merged ids {ids:?}"));
        }
        for id in self.ids.iter_mut() {
            if set.contains(id) {
                *id = into;
            }
        }
        for (_, became) in self.merged_into.iter_mut() {
            if set.contains(became) {
                *became = into;
            }
        }
        for &id in set.iter().filter(|&&id| id != into) {
            self.merged_into.insert(id, into);
            self.present.remove(&id);
            // The merged object keeps its own name, else takes a merged one's.
            if let Some(name) = self.names.remove(&id) {
                self.names.entry(into).or_insert(name);
            }
        }
        Ok(())
    }

    fn split(
        &mut self,
        object: i32,
        new_id: Option<i32>,
        base: &EditBase,
        inside: impl Fn(DVec3) -> bool,
    ) -> Result<(), String> {
        self.require(object)?;
        let new_id = self.new_id(new_id)?;
        let mut moved = 0usize;
        for (id, m) in self.ids.iter_mut().zip(base.means) {
            if *id == object && inside(DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64)) {
                *id = new_id;
                moved += 1;
            }
        }
        if moved == 0 {
            return Err(format!("no Gaussian of object {object} has its centre inside the selection"));
        }
        self.present.insert(new_id);
        Ok(())
    }

    /// `wanted` when it is free, else the next id after the largest in use.
    fn new_id(&self, wanted: Option<i32>) -> Result<i32, String> {
        match wanted {
            Some(id) if id < 1 => Err(format!("a new object's id must be at least 1, got {id}")),
            Some(id) if self.present.contains(&id) => {
                Err(format!("id {id} is already an object's (a split makes a new one)"))
            }
            Some(id) => Ok(id),
            None => Ok(self.present.iter().next_back().map_or(1, |&m| m + 1)),
        }
    }

    fn move_selection(&mut self, select: &Selection, to: MoveTarget, base: &EditBase) -> Result<(), String> {
        let to = match to {
            MoveTarget::Id(-1) => -1,
            MoveTarget::Id(id) => {
                self.require(id).map_err(|e| format!("the target: {e} (\"new\" makes a new object)"))?;
                id
            }
            MoveTarget::New(_) => self.new_id(None)?,
        };
        let selected = selected_rows(select, &self.ids, base, &self.present)?;
        let mut count = 0usize;
        for (id, _) in self.ids.iter_mut().zip(&selected).filter(|(_, &s)| s) {
            *id = to;
            count += 1;
        }
        if count == 0 {
            return Err("the selection holds no Gaussian".to_string());
        }
        if to >= 1 {
            self.present.insert(to);
        }
        Ok(())
    }

    fn assign(&mut self, ranges: &[[u64; 2]], id: i32) -> Result<(), String> {
        if id == 0 || id < -1 {
            return Err(format!("Gaussians can be assigned an object id ≥ 1 or −1 (none), got {id}"));
        }
        let n = self.ids.len() as u64;
        for &[start, end] in ranges {
            if start >= end || end > n {
                return Err(format!(
                    "the range [{start}, {end}) is not a non-empty range of the {n} Gaussians' rows [0, {n})"
                ));
            }
        }
        if ranges.is_empty() {
            return Err("no range of Gaussians given".to_string());
        }
        for &[start, end] in ranges {
            self.ids[start as usize..end as usize].fill(id);
        }
        if id >= 1 {
            self.present.insert(id);
        }
        Ok(())
    }
}

/// The inside test of `b`, or why it cannot be used.
pub(crate) fn box_test(b: &Box3) -> Result<impl Fn(DVec3) -> bool, String> {
    let finite =
        b.centre.iter().chain(&b.half_size).chain(b.rotation.iter().flatten()).all(|v| v.is_finite());
    if !finite || b.half_size.iter().any(|&h| h <= 0.0) {
        return Err(format!(
            "the box needs finite numbers and a positive half size on every axis, got centre {:?}, half size {:?}",
            b.centre, b.half_size
        ));
    }
    let rotation = match b.rotation {
        Some([w, x, y, z]) => {
            let q = DQuat::from_xyzw(x, y, z, w);
            if q.length() < 1e-12 {
                return Err("the box's rotation quaternion is zero".to_string());
            }
            q.normalize()
        }
        None => DQuat::IDENTITY,
    };
    let (centre, half, to_box) = (DVec3::from(b.centre), DVec3::from(b.half_size), rotation.inverse());
    Ok(move |p: DVec3| {
        let q = to_box * (p - centre);
        q.x.abs() <= half.x && q.y.abs() <= half.y && q.z.abs() <= half.z
    })
}

/// Pixel position of a world point in the lasso's camera (`None`: behind it).
pub(crate) fn camera_projection<'a>(
    camera: &LassoCamera,
    views: &'a [(&'a Camera, &'a Pose)],
) -> Result<Box<dyn Fn(DVec3) -> Option<DVec2> + 'a>, String> {
    match camera {
        LassoCamera::View { view } => {
            let &(camera, pose) = views.get(*view).ok_or_else(|| {
                format!("view {view} is not a view of the scene, which has {}", views.len())
            })?;
            let cam_from_world = pose.inverse();
            Ok(Box::new(move |p| camera.project(cam_from_world.transform_point(p))))
        }
        LassoCamera::Pinhole { fx, fy, cx, cy, world_from_cam } => {
            let numbers = [*fx, *fy, *cx, *cy].into_iter().chain(world_from_cam.iter().flatten().copied());
            if numbers.into_iter().any(|v| !v.is_finite()) || *fx <= 0.0 || *fy <= 0.0 {
                return Err("the lasso's camera needs finite numbers and positive focal lengths".to_string());
            }
            let camera = Camera::pinhole(0, 1, 1, *fx, *fy, *cx, *cy);
            let cam_from_world = Pose::from_rows(world_from_cam).inverse();
            Ok(Box::new(move |p| camera.project(cam_from_world.transform_point(p))))
        }
    }
}

pub(crate) fn check_polygon(polygon: &[[f64; 2]]) -> Result<(), String> {
    if polygon.len() < 3 || polygon.iter().flatten().any(|v| !v.is_finite()) {
        return Err(format!("a lasso needs at least three finite vertices, got {}", polygon.len()));
    }
    Ok(())
}

/// Whether `p` lies inside `polygon` (even-odd rule; vertices in order, closed implicitly).
pub(crate) fn inside_polygon(p: DVec2, polygon: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let mut j = polygon.len() - 1;
    for i in 0..polygon.len() {
        let ([xi, yi], [xj, yj]) = (polygon[i], polygon[j]);
        if (yi > p.y) != (yj > p.y) && p.x < (xj - xi) * (p.y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
        j = i;
    }
    inside
}

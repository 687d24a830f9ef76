//! Which Gaussians a [`Selection`] holds (the `move` operation's, and the viewer's highlighted
//! selection): the union of its parts among the Gaussians of its objects, then its grow and
//! shrink steps in order ([`crate::neighbours`]).

use crate::edit_ops::{box_test, camera_projection, check_polygon, inside_polygon, EditBase};
use crate::edits::{NeighbourStep, SelectPart, Selection, MAX_NEIGHBOUR_STEPS};
use crate::neighbours::{grow, shrink};
use glam::{DVec2, DVec3};
use std::collections::BTreeSet;

/// `[N]` whether each row is selected, given the ids as the operations before left them and the
/// objects in use; `Err` says what is wrong with the selection.
pub(crate) fn selected_rows(
    selection: &Selection,
    ids: &[i32],
    base: &EditBase,
    present: &BTreeSet<i32>,
) -> Result<Vec<bool>, String> {
    let objects = match &selection.objects {
        None => None,
        Some(objects) => {
            if objects.is_empty() {
                return Err("\"objects\" is empty (leave it out to select among every Gaussian)".to_string());
            }
            if let Some(&id) = objects.iter().find(|&&id| id != -1 && !present.contains(&id)) {
                return Err(format!("the selection names object {id}, which is not here"));
            }
            Some(objects.iter().copied().collect::<BTreeSet<i32>>())
        }
    };
    let may_hold = |row: usize| objects.as_ref().is_none_or(|o| o.contains(&ids[row].max(-1)));
    if selection.parts.is_empty() {
        return Err("the selection has no part (a brush stroke, a lasso, a box or rows)".to_string());
    }
    if selection.neighbours.len() > MAX_NEIGHBOUR_STEPS {
        return Err(format!(
            "{} grow and shrink steps, at most {MAX_NEIGHBOUR_STEPS} are taken",
            selection.neighbours.len()
        ));
    }
    let mut selected = vec![false; ids.len()];
    for part in &selection.parts {
        add_part(part, base, &may_hold, &mut selected)?;
    }
    for (row, s) in selected.iter_mut().enumerate() {
        *s = *s && may_hold(row);
    }
    // the rows a grow may add, listed once for every step
    let candidates: Option<Vec<u32>> = match (&objects, selection.neighbours.is_empty()) {
        (Some(_), false) => Some((0..ids.len()).filter(|&row| may_hold(row)).map(|row| row as u32).collect()),
        _ => None,
    };
    for step in &selection.neighbours {
        match *step {
            NeighbourStep::Grow(radius) => {
                grow(&mut selected, base.means, check_radius(radius)?, candidates.as_deref())
            }
            NeighbourStep::Shrink(radius) => shrink(&mut selected, base.means, check_radius(radius)?),
        }
    }
    Ok(selected)
}

fn check_radius(radius: f64) -> Result<f64, String> {
    if radius.is_finite() && radius > 0.0 {
        Ok(radius)
    } else {
        Err(format!("a grow or shrink step needs a finite radius above 0 (world units), got {radius}"))
    }
}

fn point(m: &[f32; 3]) -> DVec3 {
    DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64)
}

/// Marks the rows `part` selects (those `may_hold` refuses are left out later; a test of
/// positions skips them at once).
fn add_part(
    part: &SelectPart,
    base: &EditBase,
    may_hold: &dyn Fn(usize) -> bool,
    selected: &mut [bool],
) -> Result<(), String> {
    let mut mark = |test: &dyn Fn(DVec3) -> bool| {
        for (row, (s, m)) in selected.iter_mut().zip(base.means).enumerate() {
            if !*s && may_hold(row) && test(point(m)) {
                *s = true;
            }
        }
    };
    match part {
        SelectPart::Brush { camera, stroke_px, radius_px } => {
            let radius = *radius_px;
            if !(radius.is_finite() && radius > 0.0) {
                return Err(format!("a brush needs a finite radius above 0 px, got {radius}"));
            }
            if stroke_px.is_empty() || stroke_px.iter().flatten().any(|v| !v.is_finite()) {
                return Err(format!(
                    "a brush stroke needs at least one finite point, got {}",
                    stroke_px.len()
                ));
            }
            let project = camera_projection(camera, base.views)?;
            let stroke: Vec<DVec2> = stroke_px.iter().map(|&[x, y]| DVec2::new(x, y)).collect();
            let (lo, hi) = stroke.iter().fold((stroke[0], stroke[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
            let (lo, hi) = (lo - DVec2::splat(radius), hi + DVec2::splat(radius));
            mark(&|p| {
                project(p).is_some_and(|uv| {
                    uv.cmpge(lo).all() && uv.cmple(hi).all() && within_stroke(uv, &stroke, radius)
                })
            });
        }
        SelectPart::Lasso { camera, polygon_px } => {
            let project = camera_projection(camera, base.views)?;
            check_polygon(polygon_px)?;
            mark(&|p| project(p).is_some_and(|uv| inside_polygon(uv, polygon_px)));
        }
        SelectPart::Box { region } => {
            let inside = box_test(region)?;
            mark(&inside);
        }
        SelectPart::Rows { ranges } => {
            let n = selected.len() as u64;
            if ranges.is_empty() {
                return Err("no range of rows given".to_string());
            }
            for &[start, end] in ranges {
                if start >= end || end > n {
                    return Err(format!(
                        "the range [{start}, {end}) is not a non-empty range of the {n} Gaussians' rows [0, {n})"
                    ));
                }
                selected[start as usize..end as usize].fill(true);
            }
        }
    }
    Ok(())
}

/// Whether `p` lies within `radius` of the polyline through `stroke` (one point: of it).
fn within_stroke(p: DVec2, stroke: &[DVec2], radius: f64) -> bool {
    let r2 = radius * radius;
    if stroke.len() == 1 {
        return p.distance_squared(stroke[0]) <= r2;
    }
    stroke.windows(2).any(|w| {
        let (a, b) = (w[0], w[1]);
        let ab = b - a;
        let t = if ab.length_squared() > 0.0 {
            ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        p.distance_squared(a + t * ab) <= r2
    })
}

//! Growing and shrinking a selection of Gaussians by 3D neighbours: two Gaussians are neighbours
//! when their centres lie within a radius (world units) of each other. Found through a grid of
//! cubes of that side holding only the centres near the selection, so a step costs one pass over
//! the rows plus work near the selection. Rows whose centre is not finite (skipped by `run`) are
//! nobody's neighbour.

use glam::DVec3;
use std::collections::HashMap;

/// Centres bucketed in cubes of side `cell`.
struct CellGrid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl CellGrid {
    fn new(cell: f64) -> CellGrid {
        CellGrid { cell, cells: HashMap::new() }
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        // `as` saturates: far-away centres share the outermost cells, still tested by distance
        let k = (p / self.cell).floor();
        [k.x as i64, k.y as i64, k.z as i64]
    }

    fn insert(&mut self, row: u32, p: DVec3) {
        let key = self.key(p);
        self.cells.entry(key).or_default().push(row);
    }

    /// Whether some centre in the grid lies within `reach` cells' side of `p` and passes `near`.
    fn any(&self, p: DVec3, reach: i64, mut near: impl FnMut(u32) -> bool) -> bool {
        let [x, y, z] = self.key(p);
        for dx in -reach..=reach {
            for dy in -reach..=reach {
                for dz in -reach..=reach {
                    let key = [x.saturating_add(dx), y.saturating_add(dy), z.saturating_add(dz)];
                    if self.cells.get(&key).is_some_and(|rows| rows.iter().any(|&r| near(r))) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

fn centre(m: &[f32; 3]) -> Option<DVec3> {
    let p = DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64);
    p.is_finite().then_some(p)
}

/// The box around the selected centres, grown by `radius` (`None`: nothing selected).
fn reach_of(selected: &[bool], means: &[[f32; 3]], radius: f64) -> Option<(DVec3, DVec3)> {
    let mut bounds: Option<(DVec3, DVec3)> = None;
    for p in means.iter().zip(selected).filter(|(_, &s)| s).filter_map(|(m, _)| centre(m)) {
        bounds = Some(bounds.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))));
    }
    bounds.map(|(lo, hi)| (lo - DVec3::splat(radius), hi + DVec3::splat(radius)))
}

fn inside(p: DVec3, (lo, hi): (DVec3, DVec3)) -> bool {
    p.cmpge(lo).all() && p.cmple(hi).all()
}

/// One grow step: every row of `candidates` (the rows the selection may hold; `None`: every row)
/// with a selected neighbour within `radius` is selected (all at once: one ring per step).
pub(crate) fn grow(selected: &mut [bool], means: &[[f32; 3]], radius: f64, candidates: Option<&[u32]>) {
    let Some(reach) = reach_of(selected, means, radius) else { return };
    let mut grid = CellGrid::new(radius);
    for (row, m) in means.iter().enumerate().filter(|&(row, _)| selected[row]) {
        if let Some(p) = centre(m) {
            grid.insert(row as u32, p);
        }
    }
    let r2 = radius * radius;
    let rows: Box<dyn Iterator<Item = usize>> = match candidates {
        Some(rows) => Box::new(rows.iter().map(|&r| r as usize)),
        None => Box::new(0..means.len()),
    };
    let added: Vec<usize> = rows
        .filter(|&row| !selected[row])
        .filter(|&row| {
            centre(&means[row]).is_some_and(|p| {
                inside(p, reach)
                    && grid.any(p, 1, |other| {
                        centre(&means[other as usize]).is_some_and(|q| q.distance_squared(p) <= r2)
                    })
            })
        })
        .collect();
    for row in added {
        selected[row] = true;
    }
}

/// One shrink step: every selected row with an unselected neighbour within `radius` (any row) is
/// dropped (all at once).
pub(crate) fn shrink(selected: &mut [bool], means: &[[f32; 3]], radius: f64) {
    let Some(reach) = reach_of(selected, means, radius) else { return };
    let mut grid = CellGrid::new(radius);
    for (row, m) in means.iter().enumerate().filter(|&(row, _)| !selected[row]) {
        if let Some(p) = centre(m).filter(|&p| inside(p, reach)) {
            grid.insert(row as u32, p);
        }
    }
    let r2 = radius * radius;
    let dropped: Vec<usize> = (0..means.len())
        .filter(|&row| selected[row])
        .filter(|&row| {
            centre(&means[row]).is_some_and(|p| {
                grid.any(p, 1, |other| {
                    centre(&means[other as usize]).is_some_and(|q| q.distance_squared(p) <= r2)
                })
            })
        })
        .collect();
    for row in dropped {
        selected[row] = false;
    }
}

/// The median distance from a centre to its nearest other centre, over up to 1,000 rows spread
/// evenly through the file (`None`: fewer than two finite centres, or none close enough to
/// tell): the scale a viewer suggests for growing and shrinking (twice it).
pub fn typical_spacing(means: &[[f32; 3]]) -> Option<f64> {
    let finite: Vec<(u32, DVec3)> =
        means.iter().enumerate().filter_map(|(row, m)| centre(m).map(|p| (row as u32, p))).collect();
    if finite.len() < 2 {
        return None;
    }
    let (lo, hi) = finite.iter().fold((finite[0].1, finite[0].1), |(lo, hi), &(_, p)| (lo.min(p), hi.max(p)));
    // a surface of n centres spread over the box: spacing ≈ diagonal / √n
    let cell = ((hi - lo).length() / (finite.len() as f64).sqrt()).max(1e-9);
    let mut grid = CellGrid::new(cell);
    for &(row, p) in &finite {
        grid.insert(row, p);
    }
    let samples = finite.len().min(1000);
    let mut nearest: Vec<f64> = (0..samples)
        .filter_map(|k| {
            let (row, p) = finite[k * finite.len() / samples];
            let mut best = f64::INFINITY;
            grid.any(p, 2, |other| {
                if other != row {
                    best = best.min(centre(&means[other as usize]).map_or(f64::INFINITY, |q| q.distance(p)));
                }
                false
            });
            // only a distance within the searched cells is surely the nearest
            (best <= 2.0 * cell).then_some(best)
        })
        .collect();
    if nearest.is_empty() {
        return None;
    }
    nearest.sort_by(f64::total_cmp);
    Some(nearest[nearest.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of centres 1 apart on x, and one far away.
    fn line() -> Vec<[f32; 3]> {
        let mut m: Vec<[f32; 3]> = (0..10).map(|i| [i as f32, 0.0, 0.0]).collect();
        m.push([100.0, 0.0, 0.0]);
        m.push([f32::NAN, 0.0, 0.0]);
        m
    }

    #[test]
    fn grow_adds_one_ring_per_step_and_shrink_drops_the_rim() {
        let means = line();
        let mut selected = vec![false; means.len()];
        selected[4] = true;
        grow(&mut selected, &means, 1.0, None);
        assert_eq!(selected.iter().filter(|&&s| s).count(), 3, "{selected:?}");
        assert!(selected[3] && selected[5]);
        let all_but_2: Vec<u32> = (0..means.len() as u32).filter(|&r| r != 2).collect();
        grow(&mut selected, &means, 1.5, Some(&all_but_2));
        assert!(
            !selected[2] && selected[6] && !selected[7],
            "only rows the selection may hold: {selected:?}"
        );
        shrink(&mut selected, &means, 1.0);
        // 3 had 2 unselected beside it, 6 had 7: both dropped; 4 and 5 stay
        let kept: Vec<usize> = (0..means.len()).filter(|&r| selected[r]).collect();
        assert_eq!(kept, vec![4, 5]);
        // the far centre and the NaN row are nobody's neighbour
        grow(&mut selected, &means, 50.0, None);
        assert!(!selected[10] && !selected[11]);
    }

    /// Centres scattered by a fixed linear congruential sequence in a 4 × 4 × 4 box, with a
    /// cluster, rows outside the box and a NaN.
    fn scattered(n: usize) -> Vec<[f32; 3]> {
        let mut state = 0x2545_f491_u64;
        let mut next = move || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 4.0
        };
        let mut m: Vec<[f32; 3]> = (0..n).map(|_| [next(), next(), next()]).collect();
        m.extend((0..50).map(|k| [1.0 + 0.01 * k as f32, 1.0, 1.0]));
        m.push([-30.0, 2.0, 2.0]);
        m.push([f32::NAN, 1.0, 1.0]);
        m
    }

    /// Grow and shrink by testing every pair: what the grid must find.
    fn brute(selected: &[bool], means: &[[f32; 3]], radius: f64, growing: bool) -> Vec<bool> {
        let near = |a: usize, b: usize| match (centre(&means[a]), centre(&means[b])) {
            (Some(p), Some(q)) => p.distance_squared(q) <= radius * radius,
            _ => false,
        };
        (0..means.len())
            .map(|a| {
                let other = (0..means.len()).any(|b| selected[b] != selected[a] && near(a, b));
                if growing {
                    selected[a] || other
                } else {
                    selected[a] && !other
                }
            })
            .collect()
    }

    #[test]
    fn grow_and_shrink_find_exactly_the_neighbours_every_pair_finds() {
        let means = scattered(1500);
        for radius in [0.05, 0.2, 0.7] {
            let mut selected: Vec<bool> =
                (0..means.len()).map(|r| r % 7 == 0 || (1500..1520).contains(&r)).collect();
            for step in 0..3 {
                let want = brute(&selected, &means, radius, step != 1);
                if step == 1 {
                    shrink(&mut selected, &means, radius);
                } else {
                    grow(&mut selected, &means, radius, None);
                }
                assert_eq!(selected, want, "radius {radius}, step {step}");
            }
        }
    }

    #[test]
    fn the_typical_spacing_is_the_median_of_every_pairs_nearest_distances() {
        // 3,000 finite centres (the far one left out: the cells are then small enough that some
        // nearest centres lie two cells away): 1,000 samples, every third one
        let mut means = scattered(2950);
        means.retain(|m| m[0] >= -1.0 || m[0].is_nan());
        let finite: Vec<DVec3> = means.iter().filter_map(centre).collect();
        assert_eq!(finite.len(), 3000);
        let (lo, hi) = finite.iter().fold((finite[0], finite[0]), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let cell = (hi - lo).length() / (finite.len() as f64).sqrt();
        let mut nearest: Vec<f64> = (0..1000)
            .map(|k| {
                let p = finite[k * 3];
                (0..finite.len())
                    .filter(|&j| j != k * 3)
                    .map(|j| finite[j].distance(p))
                    .fold(f64::INFINITY, f64::min)
            })
            .filter(|&d| d <= 2.0 * cell)
            .collect();
        nearest.sort_by(f64::total_cmp);
        assert_eq!(typical_spacing(&means), Some(nearest[nearest.len() / 2]));
    }

    #[test]
    fn the_typical_spacing_is_the_median_nearest_distance() {
        let spacing = typical_spacing(&line()).expect("a spacing");
        assert!((spacing - 1.0).abs() < 1e-9, "{spacing}");
        assert_eq!(typical_spacing(&[[0.0; 3]]), None);
    }
}

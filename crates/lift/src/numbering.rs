//! Final, stable object numbering: ids in order of first appearance in the rendered label maps
//! (view order, then row-major pixel order), as `CONVENTIONS.md` asks; objects that own
//! Gaussians but show in no view follow, in their previous order. Ids that end with neither
//! pixels nor Gaussians disappear, so the numbering has no gaps.

use crate::run_lengths::RunLengths;
use splatseg_scene::Plane;
use std::collections::{BTreeMap, BTreeSet};

/// Renumbers `maps` (`[n_views]` label maps, 0 = none) and `object_ids` (`[N]`, -1 = none) in
/// place. Returns `old_of_new`: `[n_new + 1]`, entry 0 = 0, entry `k` = the old id of new id `k`.
pub fn renumber(maps: &mut [Plane<u32>], object_ids: &mut [i32]) -> Vec<u32> {
    let max_old = maps
        .iter()
        .flat_map(|m| m.data.iter().copied())
        .chain(object_ids.iter().filter(|&&i| i > 0).map(|&i| i as u32))
        .max()
        .unwrap_or(0) as usize;
    let mut new_of_old = vec![0u32; max_old + 1];
    let mut old_of_new = vec![0u32];
    let mut assign = |old: u32, new_of_old: &mut Vec<u32>| {
        if old > 0 && new_of_old[old as usize] == 0 {
            old_of_new.push(old);
            new_of_old[old as usize] = old_of_new.len() as u32 - 1;
        }
    };
    for map in maps.iter() {
        for &old in &map.data {
            assign(old, &mut new_of_old);
        }
    }
    let mut remaining: Vec<u32> = object_ids.iter().filter(|&&i| i > 0).map(|&i| i as u32).collect();
    remaining.sort_unstable();
    remaining.dedup();
    for old in remaining {
        assign(old, &mut new_of_old);
    }
    for map in maps.iter_mut() {
        for v in map.data.iter_mut() {
            *v = new_of_old[*v as usize];
        }
    }
    for id in object_ids.iter_mut() {
        if *id > 0 {
            *id = new_of_old[*id as usize] as i32;
        }
    }
    old_of_new
}

/// The speck filter and the numbering over the final maps kept as runs (`maps: [n_views]`):
/// ids with fewer than `min_px` pixels over all maps become 0 (and −1 in `object_ids`, `[N]`),
/// then ids are numbered by first appearance (view order, row-major) by [`renumber`] on each
/// view's ids in order of first appearance. Returns `new_of_old`: the final id of every id of the
/// maps (0 for the dropped specks).
pub fn drop_specks_and_number(maps: &[RunLengths], object_ids: &mut [i32], min_px: u64) -> Vec<u32> {
    let mut area: BTreeMap<u32, u64> = BTreeMap::new();
    for map in maps {
        for &(id, n) in map.runs.iter().filter(|(id, _)| *id > 0) {
            *area.entry(id).or_insert(0) += n as u64;
        }
    }
    let small: BTreeSet<u32> = area.iter().filter(|&(_, &px)| px < min_px).map(|(&id, _)| id).collect();
    for id in object_ids.iter_mut().filter(|id| **id > 0 && small.contains(&(**id as u32))) {
        *id = -1;
    }
    tracing::info!("dropped {} speck objects under {min_px} px", small.len());
    let mut order: Vec<Plane<u32>> = maps
        .iter()
        .map(|m| {
            let ids = m.first_appearance(|id| small.contains(&id));
            Plane { width: ids.len(), height: 1, data: ids }
        })
        .collect();
    let old_of_new = renumber(&mut order, object_ids);
    let max_old =
        area.keys().next_back().copied().unwrap_or(0).max(old_of_new.iter().copied().max().unwrap_or(0));
    let mut new_of_old = vec![0u32; max_old as usize + 1];
    for (new, &old) in old_of_new.iter().enumerate().skip(1) {
        new_of_old[old as usize] = new as u32;
    }
    new_of_old
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Specks (fewer pixels than the floor over all views) go from the maps and the Gaussians,
    /// the rest are numbered by first appearance, then the ids shown in no view.
    #[test]
    fn specks_go_and_ids_are_numbered_by_first_appearance_over_runs() {
        let maps: Vec<Plane<u32>> = vec![
            Plane { width: 4, height: 3, data: vec![0, 7, 7, 3, 3, 3, 9, 0, 5, 5, 5, 5] },
            Plane { width: 3, height: 2, data: vec![9, 9, 2, 0, 11, 11] },
            Plane { width: 2, height: 2, data: vec![0, 0, 0, 0] },
        ];
        let mut ids: Vec<i32> = vec![-1, 3, 7, 2, 11, 4, 9, 5, 12];
        let runs: Vec<RunLengths> = maps.iter().map(RunLengths::encode).collect();
        let new_of_old = drop_specks_and_number(&runs, &mut ids, 2);
        // Id 2 has one pixel: a speck. 7, 3, 9, 5, 11 appear in that order; 4 and 12 show nowhere.
        assert_eq!(ids, vec![-1, 2, 1, -1, 5, 6, 3, 4, 7]);
        let numbered = |v: usize| runs[v].decode(|id| new_of_old.get(id as usize).copied().unwrap_or(0)).data;
        assert_eq!(numbered(0), vec![0, 1, 1, 2, 2, 2, 3, 0, 4, 4, 4, 4]);
        assert_eq!(numbered(1), vec![3, 3, 0, 0, 5, 5]);
        assert_eq!(numbered(2), vec![0; 4]);
    }
}

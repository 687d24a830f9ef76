//! Final, stable object numbering: ids in order of first appearance in the rendered label maps
//! (view order, then row-major pixel order), as `CONVENTIONS.md` asks; objects that own
//! Gaussians but show in no view follow, in their previous order. Ids that end with neither
//! pixels nor Gaussians disappear, so the numbering has no gaps.

use splatseg_scene::Plane;

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

/// Removes specks: ids whose pixels over all `maps` (`[n_views]` label maps) number fewer than
/// `min_px` become 0 in the maps and -1 in `object_ids` (`[N]`). Returns how many ids went.
pub fn drop_small_objects(maps: &mut [Plane<u32>], object_ids: &mut [i32], min_px: u64) -> usize {
    let mut area: std::collections::BTreeMap<u32, u64> = std::collections::BTreeMap::new();
    for map in maps.iter() {
        for &id in map.data.iter().filter(|&&id| id > 0) {
            *area.entry(id).or_insert(0) += 1;
        }
    }
    let small: std::collections::BTreeSet<u32> =
        area.into_iter().filter(|&(_, px)| px < min_px).map(|(id, _)| id).collect();
    if small.is_empty() {
        return 0;
    }
    for map in maps.iter_mut() {
        for v in map.data.iter_mut().filter(|v| small.contains(v)) {
            *v = 0;
        }
    }
    for id in object_ids.iter_mut().filter(|id| **id > 0 && small.contains(&(**id as u32))) {
        *id = -1;
    }
    small.len()
}

//! 3D evidence against over-segmentation: masks of one view that are fragments of one object.
//!
//! The merge stage leaves some objects in two or more masks of a view (a texture split it did
//! not unify, a SAM hole). Cross-view matching alone cannot join them: a cluster holds at most
//! one mask per view. But other views see the fragments' Gaussians, and where one object is one
//! mask there, both fragments' Gaussians lie inside that one mask.
//!
//! Rule: for a mask `i` of view `a` and another view `b`, the *container* of `i` in `b` is the
//! mask `j` of `b` holding the most of `i`'s Gaussians that `b` sees, when it holds at least
//! `tau_overlap` of them and `b` sees at least `min_support` of them. Two masks `i`, `i'` of
//! view `a` are fragments of one object when
//! - in at least `min_fragment_views` other views they have the same container ("together"),
//! - and those views are at least `fragment_majority` of the views where both have a
//!   container (the rest, where their containers differ, are "apart"),
//! - and, with descriptors, they look alike: `cos ≥ tau_match`. Two different objects that
//!   touch at one depth are often one mask in other views (the merge joined them there); their
//!   descriptors tell them apart, a texture split's halves look alike.
//!
//! A view where the merge joined two objects into one mask votes "together" for them; the
//! majority over the views that see them apart keeps them apart. Counts are exact integers, and
//! pairs come out sorted, so the result does not depend on the thread count.

use crate::config::MatchConfig;
use crate::evidence::Evidence;
use std::collections::BTreeMap;

/// The container of every mask in every other view: `[n_masks, n_views]`, `u32::MAX` = none.
fn containers(
    evidence: &Evidence,
    view_of_mask: &[u32],
    offsets: &[usize],
    config: &MatchConfig,
) -> Vec<u32> {
    let n_views = offsets.len() - 1;
    let n_masks = view_of_mask.len();
    // Best (shared count, mask) per (mask, view), from the pair table.
    let mut best = vec![(0u32, u32::MAX); n_masks * n_views];
    for (i, j, shared) in evidence.shared_pairs() {
        for (m, other) in [(i, j), (j, i)] {
            let slot = &mut best[m as usize * n_views + view_of_mask[other as usize] as usize];
            // Ties: the smaller mask index.
            if shared > slot.0 || (shared == slot.0 && other < slot.1) {
                *slot = (shared, other);
            }
        }
    }
    let mut out = vec![u32::MAX; n_masks * n_views];
    for m in 0..n_masks {
        for b in 0..n_views {
            let (shared, j) = best[m * n_views + b];
            let support = evidence.covisible(m, b);
            if j != u32::MAX
                && support >= config.min_support.max(1)
                && shared as f32 >= config.tau_overlap * support as f32
            {
                out[m * n_views + b] = j;
            }
        }
    }
    out
}

/// Pairs `(i, i')` of global mask indices, `i < i'`, of one view that are fragments of one
/// object (see the module docs), sorted.
pub fn fragment_pairs(
    evidence: &Evidence,
    view_of_mask: &[u32],
    offsets: &[usize],
    similar: impl Fn(usize, usize) -> bool,
    config: &MatchConfig,
) -> Vec<(u32, u32)> {
    if config.fragment_majority > 1.0 {
        return Vec::new();
    }
    let n_views = offsets.len() - 1;
    let container = containers(evidence, view_of_mask, offsets, config);
    let mut pairs = Vec::new();
    for a in 0..n_views {
        let masks = offsets[a]..offsets[a + 1];
        // (together, apart) per pair of masks of view a that both have containers.
        let mut counts: BTreeMap<(u32, u32), (u32, u32)> = BTreeMap::new();
        for b in (0..n_views).filter(|&b| b != a) {
            for i in masks.clone() {
                let ci = container[i * n_views + b];
                if ci == u32::MAX {
                    continue;
                }
                for k in i + 1..masks.end {
                    let ck = container[k * n_views + b];
                    if ck == u32::MAX {
                        continue;
                    }
                    let entry = counts.entry((i as u32, k as u32)).or_default();
                    if ci == ck {
                        entry.0 += 1;
                    } else {
                        entry.1 += 1;
                    }
                }
            }
        }
        for ((i, k), (together, apart)) in counts {
            let seen = together + apart;
            if together >= config.min_fragment_views
                && together as f32 >= config.fragment_majority * seen as f32
                && similar(i as usize, k as usize)
            {
                pairs.push((i, k));
            }
        }
    }
    pairs
}

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
use crate::evidence::MaskCounts;
use std::collections::BTreeMap;

/// The container of one mask of view `view` in every view (`out: [n_views]`, `u32::MAX` = none),
/// from its counts against every mask (`offsets: [n_views + 1]` first global mask of each view).
pub fn containers_of_mask(
    counts: &MaskCounts,
    view: usize,
    offsets: &[usize],
    config: &MatchConfig,
    out: &mut [u32],
) {
    for (b, slot) in out.iter_mut().enumerate() {
        *slot = u32::MAX;
        if b == view {
            continue;
        }
        // Best shared count of view b's masks; ties: the smaller mask index.
        let (mut shared, mut best) = (0u32, u32::MAX);
        for j in offsets[b]..offsets[b + 1] {
            if counts.shared[j] > shared {
                (shared, best) = (counts.shared[j], j as u32);
            }
        }
        let support = counts.covisible[b];
        if best != u32::MAX
            && support >= crate::config::MIN_SUPPORT
            && shared as f32 >= config.tau_overlap * support as f32
        {
            *slot = best;
        }
    }
}

/// Pairs `(i, i')` of global mask indices, `i < i'`, of view `view` that are fragments of one
/// object (see the module docs), sorted. `containers: [n_masks of the view, n_views]` from
/// [`containers_of_mask`]; `first_mask` is the view's first global mask index.
pub fn fragment_pairs_of_view(
    containers: &[u32],
    n_views: usize,
    view: usize,
    first_mask: usize,
    similar: impl Fn(usize, usize) -> bool,
    config: &MatchConfig,
) -> Vec<(u32, u32)> {
    if config.fragment_majority > 1.0 || n_views == 0 {
        return Vec::new();
    }
    let n = containers.len() / n_views;
    // (together, apart) per pair of masks of the view that both have containers.
    let mut counts: BTreeMap<(u32, u32), (u32, u32)> = BTreeMap::new();
    for b in (0..n_views).filter(|&b| b != view) {
        for i in 0..n {
            let ci = containers[i * n_views + b];
            if ci == u32::MAX {
                continue;
            }
            for k in i + 1..n {
                let ck = containers[k * n_views + b];
                if ck == u32::MAX {
                    continue;
                }
                let entry = counts.entry(((first_mask + i) as u32, (first_mask + k) as u32)).or_default();
                if ci == ck {
                    entry.0 += 1;
                } else {
                    entry.1 += 1;
                }
            }
        }
    }
    let mut pairs = Vec::new();
    for ((i, k), (together, apart)) in counts {
        let seen = together + apart;
        if together >= crate::config::MIN_FRAGMENT_VIEWS
            && together as f32 >= config.fragment_majority * seen as f32
            && similar(i as usize, k as usize)
        {
            pairs.push((i, k));
        }
    }
    pairs
}

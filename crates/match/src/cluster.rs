//! Union-find over masks that refuses unsound joins.
//!
//! A join of two clusters is refused when (a) both hold a mask of the same view — after merging,
//! one view holds at most one mask per object — or (b) some mask of one and some mask of the
//! other are a cannot-link pair (3D evidence that they cover different Gaussians).

use std::collections::HashSet;

/// Why [`ConstrainedUnionFind::union`] did or did not join two masks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JoinOutcome {
    /// The two clusters are now one.
    Joined,
    /// They were already one cluster.
    AlreadyJoined,
    /// Refused: both clusters hold a mask of the same view.
    SameView,
    /// Refused: a cannot-link pair spans the two clusters.
    CannotLink,
}

/// Disjoint sets of masks, each remembering its members and their views.
#[derive(Clone, Debug)]
pub struct ConstrainedUnionFind {
    parent: Vec<u32>,
    /// For roots: `[cluster size]` member masks, sorted.
    members: Vec<Vec<u32>>,
    /// For roots: views of the members, sorted, no duplicates.
    views: Vec<Vec<u32>>,
    cannot_link: HashSet<u64>,
}

fn pair_key(i: u32, j: u32) -> u64 {
    let (lo, hi) = if i < j { (i, j) } else { (j, i) };
    ((lo as u64) << 32) | hi as u64
}

fn sorted_disjoint(a: &[u32], b: &[u32]) -> bool {
    let (mut x, mut y) = (0, 0);
    while x < a.len() && y < b.len() {
        match a[x].cmp(&b[y]) {
            std::cmp::Ordering::Less => x += 1,
            std::cmp::Ordering::Greater => y += 1,
            std::cmp::Ordering::Equal => return false,
        }
    }
    true
}

fn merge_sorted(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    out.extend_from_slice(a);
    out.extend_from_slice(b);
    out.sort_unstable();
    out.dedup();
    out
}

impl ConstrainedUnionFind {
    /// One singleton cluster per mask. `view_of_mask: [n_masks]`.
    pub fn new(view_of_mask: &[u32]) -> Self {
        ConstrainedUnionFind {
            parent: (0..view_of_mask.len() as u32).collect(),
            members: (0..view_of_mask.len() as u32).map(|m| vec![m]).collect(),
            views: view_of_mask.iter().map(|&v| vec![v]).collect(),
            cannot_link: HashSet::new(),
        }
    }

    /// Declares that masks `i` and `j` must never share a cluster.
    pub fn add_cannot_link(&mut self, i: u32, j: u32) {
        self.cannot_link.insert(pair_key(i, j));
    }

    /// The root of `m`'s cluster (with path halving).
    pub fn find(&mut self, mut m: u32) -> u32 {
        while self.parent[m as usize] != m {
            let grand = self.parent[self.parent[m as usize] as usize];
            self.parent[m as usize] = grand;
            m = grand;
        }
        m
    }

    fn spans_cannot_link(&self, root: u32, child: u32) -> bool {
        if self.cannot_link.is_empty() {
            return false;
        }
        let a = &self.members[root as usize];
        let b = &self.members[child as usize];
        a.iter().any(|&x| b.iter().any(|&y| self.cannot_link.contains(&pair_key(x, y))))
    }

    fn join_roots(&mut self, root: u32, child: u32) {
        let members = merge_sorted(&self.members[root as usize], &self.members[child as usize]);
        let views = merge_sorted(&self.views[root as usize], &self.views[child as usize]);
        self.members[root as usize] = members;
        self.views[root as usize] = views;
        self.members[child as usize] = Vec::new();
        self.views[child as usize] = Vec::new();
        self.parent[child as usize] = root;
    }

    /// Joins the clusters of `i` and `j` unless a constraint forbids it. The smaller root index
    /// stays the root, so the result does not depend on the order of equal-score edges.
    pub fn union(&mut self, i: u32, j: u32) -> JoinOutcome {
        let (ri, rj) = (self.find(i), self.find(j));
        if ri == rj {
            return JoinOutcome::AlreadyJoined;
        }
        let (root, child) = if ri < rj { (ri, rj) } else { (rj, ri) };
        if !sorted_disjoint(&self.views[root as usize], &self.views[child as usize]) {
            return JoinOutcome::SameView;
        }
        if self.spans_cannot_link(root, child) {
            return JoinOutcome::CannotLink;
        }
        self.join_roots(root, child);
        JoinOutcome::Joined
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_two_masks_of_one_view() {
        // masks 0,1 in view 0; mask 2 in view 1.
        let mut uf = ConstrainedUnionFind::new(&[0, 0, 1]);
        assert_eq!(uf.union(0, 2), JoinOutcome::Joined);
        assert_eq!(uf.union(1, 2), JoinOutcome::SameView);
        assert_eq!(uf.union(0, 1), JoinOutcome::SameView);
        assert_eq!(uf.find(1), 1);
        assert_eq!(uf.find(2), 0);
        assert_eq!(uf.union(2, 0), JoinOutcome::AlreadyJoined);
    }

    #[test]
    fn refuses_chains_across_a_cannot_link() {
        // masks 0 (view 0), 1 (view 1), 2 (view 2); 0 and 2 must stay apart.
        let mut uf = ConstrainedUnionFind::new(&[0, 1, 2]);
        uf.add_cannot_link(2, 0);
        assert_eq!(uf.union(0, 1), JoinOutcome::Joined);
        assert_eq!(uf.union(1, 2), JoinOutcome::CannotLink);
        assert_ne!(uf.find(2), uf.find(0));
    }
}

//! The voxel grid the 3D steps share (touching and seam joins, splits): the voxel of a point,
//! 26-neighbourhoods visited once per unordered pair, and a union-find whose roots do not depend
//! on the order of the unions.

/// The voxel holding `p` for voxel edge `voxel`.
pub(crate) fn voxel_of(p: [f32; 3], voxel: f32) -> [i64; 3] {
    p.map(|x| (x / voxel).floor() as i64)
}

/// `v` itself and the 13 of its 26 neighbours that come after it, so that visiting every
/// occupied voxel meets each unordered neighbouring pair once.
pub(crate) fn self_and_forward_neighbours(v: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (-1..=1i64)
        .flat_map(|dz| (-1..=1i64).flat_map(move |dy| (-1..=1i64).map(move |dx| (dx, dy, dz))))
        .filter(|&d| d >= (0, 0, 0))
        .map(move |(dx, dy, dz)| [v[0] + dx, v[1] + dy, v[2] + dz])
}

/// Union-find whose roots are the smallest index of their set (so the result does not depend on
/// the order unions are made in).
pub(crate) struct DisjointSets {
    parent: Vec<u32>,
}

impl DisjointSets {
    /// `n` singletons `0..n`.
    pub(crate) fn new(n: usize) -> Self {
        DisjointSets { parent: (0..n as u32).collect() }
    }

    /// The root (smallest index) of `x`'s set.
    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    /// Joins the sets of `a` and `b`; false when they were one set already.
    pub(crate) fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent[ra.max(rb) as usize] = ra.min(rb);
        }
        ra != rb
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_neighbouring_pair_is_met_once_and_roots_are_the_smallest_index() {
        // Over a 4³ block, every unordered 26-neighbour pair (and each voxel with itself) once.
        let block: Vec<[i64; 3]> = (0..64).map(|k| [k % 4, k / 4 % 4, k / 16]).collect();
        let mut met = std::collections::BTreeMap::new();
        for &v in &block {
            for n in self_and_forward_neighbours(v).filter(|n| block.contains(n)) {
                *met.entry((v.min(n), v.max(n))).or_insert(0) += 1;
            }
        }
        let adjacent = |a: [i64; 3], b: [i64; 3]| (0..3).all(|k| (a[k] - b[k]).abs() <= 1);
        let expected = block
            .iter()
            .flat_map(|&a| block.iter().map(move |&b| (a, b)))
            .filter(|&(a, b)| a <= b && adjacent(a, b));
        assert_eq!(met.len(), expected.count());
        assert!(met.values().all(|&k| k == 1));
        let mut sets = DisjointSets::new(5);
        assert!(sets.union(4, 2));
        assert!(sets.union(3, 4));
        assert!(!sets.union(2, 3));
        assert_eq!((sets.find(4), sets.find(3), sets.find(0)), (2, 2, 0));
    }
}

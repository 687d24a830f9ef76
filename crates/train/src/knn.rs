//! k nearest neighbours of every Gaussian centre (the paper's `N₅(g)`), with a k-d tree.
//!
//! The tree is an index permutation: each range's median (along the axis of largest spread) sits in
//! the middle of the range, with the smaller half before it. Queries are exact, ties are broken by
//! index, queries run in parallel, and the output is deterministic.

use rayon::prelude::*;

/// Ranges at most this long are scanned directly.
const LEAF: usize = 8;

/// `[N, k]` neighbour indices (row `i`: the k nearest other points to point `i`, nearest first). When
/// there are fewer than `k + 1` points, rows are padded with the point's own index.
pub fn knn(points: &[[f32; 3]], k: usize) -> Vec<u32> {
    let n = points.len();
    if n == 0 || k == 0 {
        return Vec::new();
    }
    let tree = Tree::new(points);
    let mut out = vec![0u32; n * k];
    out.par_chunks_mut(k).enumerate().for_each(|(i, row)| {
        let mut best = Vec::with_capacity(k + 1);
        tree.search(points[i], i as u32, k, 0, n, &mut best);
        for (slot, value) in row.iter_mut().enumerate() {
            *value = best.get(slot).map_or(i as u32, |&(_, j)| j);
        }
    });
    out
}

struct Tree<'a> {
    points: &'a [[f32; 3]],
    /// Point indices, arranged as described in the module documentation.
    order: Vec<u32>,
    /// Split axis of the range whose median sits at this position.
    axis: Vec<u8>,
}

impl<'a> Tree<'a> {
    fn new(points: &'a [[f32; 3]]) -> Self {
        let mut tree =
            Self { points, order: (0..points.len() as u32).collect(), axis: vec![0; points.len()] };
        tree.build(0, points.len());
        tree
    }

    fn build(&mut self, lo: usize, hi: usize) {
        if hi - lo <= LEAF {
            return;
        }
        let points = self.points;
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for &i in &self.order[lo..hi] {
            for a in 0..3 {
                min[a] = min[a].min(points[i as usize][a]);
                max[a] = max[a].max(points[i as usize][a]);
            }
        }
        let axis = (0..3).max_by(|&a, &b| (max[a] - min[a]).total_cmp(&(max[b] - min[b]))).unwrap_or(0);
        let mid = (lo + hi) / 2;
        self.order[lo..hi].select_nth_unstable_by(mid - lo, |&i, &j| {
            points[i as usize][axis].total_cmp(&points[j as usize][axis]).then(i.cmp(&j))
        });
        self.axis[mid] = axis as u8;
        self.build(lo, mid);
        self.build(mid + 1, hi);
    }

    /// Adds to `best` the nearest points of range `lo..hi` to `query` (skipping `itself`).
    fn search(
        &self,
        query: [f32; 3],
        itself: u32,
        k: usize,
        lo: usize,
        hi: usize,
        best: &mut Vec<(f32, u32)>,
    ) {
        let consider = |j: u32, best: &mut Vec<(f32, u32)>| {
            if j != itself {
                let p = self.points[j as usize];
                let d = (0..3).map(|a| (query[a] - p[a]) * (query[a] - p[a])).sum::<f32>();
                insert(best, (d, j), k);
            }
        };
        if hi - lo <= LEAF {
            for &j in &self.order[lo..hi] {
                consider(j, best);
            }
            return;
        }
        let mid = (lo + hi) / 2;
        let axis = usize::from(self.axis[mid]);
        let pivot = self.order[mid];
        let diff = query[axis] - self.points[pivot as usize][axis];
        let (near, far) = if diff < 0.0 { ((lo, mid), (mid + 1, hi)) } else { ((mid + 1, hi), (lo, mid)) };
        self.search(query, itself, k, near.0, near.1, best);
        consider(pivot, best);
        if best.len() < k || diff * diff <= best[k - 1].0 {
            self.search(query, itself, k, far.0, far.1, best);
        }
    }
}

/// Inserts into a list sorted by (distance, index), keeping at most `k`.
fn insert(best: &mut Vec<(f32, u32)>, item: (f32, u32), k: usize) {
    if best.len() == k && (item.0, item.1) >= (best[k - 1].0, best[k - 1].1) {
        return;
    }
    let at = best.partition_point(|&(d, j)| (d, j) < (item.0, item.1));
    best.insert(at, item);
    best.truncate(k);
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    use super::*;

    #[test]
    fn matches_brute_force_on_a_surface_like_cloud() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        // points on two planes plus a dense clump: uneven density on purpose
        let mut points: Vec<[f32; 3]> = (0..1500)
            .map(|i| {
                let (u, v) = (rng.gen_range(0.0..4.0f32), rng.gen_range(0.0..3.0f32));
                if i % 2 == 0 {
                    [u, v, 0.0]
                } else {
                    [u, 0.0, v]
                }
            })
            .collect();
        points
            .extend((0..300).map(|_| [2.0 + rng.gen_range(0.0..0.01f32), 1.0, rng.gen_range(0.0..0.01f32)]));
        let k = 5;
        let ours = knn(&points, k);
        for i in (0..points.len()).step_by(7) {
            let mut all: Vec<(f32, u32)> = (0..points.len())
                .filter(|&j| j != i)
                .map(|j| {
                    let d = (0..3).map(|a| (points[i][a] - points[j][a]).powi(2)).sum::<f32>();
                    (d, j as u32)
                })
                .collect();
            all.sort_by(|a, b| a.partial_cmp(b).unwrap());
            let expected: Vec<u32> = all[..k].iter().map(|&(_, j)| j).collect();
            assert_eq!(&ours[i * k..(i + 1) * k], &expected[..], "point {i}");
        }
    }

    #[test]
    fn tiny_inputs_pad_with_the_point_itself() {
        assert!(knn(&[], 5).is_empty());
        assert_eq!(knn(&[[0.0; 3], [1.0, 0.0, 0.0]], 3), vec![1, 0, 0, 0, 1, 1]);
    }
}

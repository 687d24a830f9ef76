//! The region adjacency graph, built once per view in one pass over the pixels.
//!
//! For dilation radius `r` (= number of 3×3 dilations), pixel `p` lies in `dil_r(A)` iff label
//! `A` occurs in the `(2r+1)²` window around `p`. Every pixel whose window holds two or more
//! labels is appended to the **band** of each pair of them: `band(A, B) = dil_r(A) ∩ dil_r(B)`,
//! as a sorted list of pixel indices. The band gives
//! - adjacency: the dilated masks intersect iff the band is non-empty;
//! - the contact ratio `|band| / min(|A|, |B|)`;
//! - the shared boundary on which the LoG and `∇D` statistics are taken.
//!
//! Merging `A` and `B` into `A ∪ B` is exact on bands, because dilation distributes over union:
//! `dil(A ∪ B) ∩ dil(C) = band(A, C) ∪ band(B, C)` (a sorted merge without duplicates).
//!
//! Window label sets are computed separably: per row, the set of labels in each horizontal run of
//! `2r+1` pixels (a ring buffer of `2r+1` rows), then the union of `2r+1` such sets vertically;
//! pixels whose window holds a single label take a fast path. Label 0 (unlabelled) is ignored.

use splatseg_scene::Plane;
use std::collections::HashMap;

/// An edge of the region adjacency graph.
#[derive(Clone, Debug)]
pub(crate) struct Edge {
    /// Smaller region id.
    pub a: u32,
    /// Larger region id.
    pub b: u32,
    /// Sorted row-major pixel indices of `dil_r(A) ∩ dil_r(B)`.
    pub band: Vec<u32>,
}

/// Marks a horizontal window with two or more labels in [`RingRow::single`].
const MIXED: u32 = u32::MAX;

/// The horizontal label sets of one image row: per pixel, the distinct non-zero labels among
/// the `2r + 1` pixels around it.
struct RingRow {
    /// `[W]` 0 = no label, `l` = only label `l`, [`MIXED`] = see `labels`/`lens`.
    single: Vec<u32>,
    /// `[W, 2r+1]` the labels of mixed windows.
    labels: Vec<u32>,
    /// `[W]` number of labels of mixed windows.
    lens: Vec<u8>,
    /// `[W]` scratch: last index of the run of equal labels containing each pixel.
    run_end: Vec<usize>,
}

impl RingRow {
    fn new(w: usize, k: usize) -> Self {
        RingRow { single: vec![0; w], labels: vec![0; w * k], lens: vec![0; w], run_end: vec![0; w] }
    }

    fn fill(&mut self, row: &[u32], radius: usize) {
        let (w, k) = (row.len(), 2 * radius + 1);
        for x in (0..w).rev() {
            self.run_end[x] = if x + 1 < w && row[x + 1] == row[x] { self.run_end[x + 1] } else { x };
        }
        for x in 0..w {
            let lo = x.saturating_sub(radius);
            let hi = (x + radius).min(w - 1);
            if self.run_end[lo] >= hi {
                self.single[x] = row[lo];
                continue;
            }
            let out = &mut self.labels[x * k..(x + 1) * k];
            let mut n = 0;
            for &l in &row[lo..=hi] {
                if l != 0 && !out[..n].contains(&l) {
                    out[n] = l;
                    n += 1;
                }
            }
            self.lens[x] = n as u8;
            self.single[x] = match n {
                0 => 0,
                1 => out[0],
                _ => MIXED,
            };
        }
    }

    fn labels_at(&self, x: usize, k: usize) -> &[u32] {
        match self.single[x] {
            0 => &[],
            MIXED => &self.labels[x * k..x * k + self.lens[x] as usize],
            _ => std::slice::from_ref(&self.single[x]),
        }
    }
}

/// Pixels whose window holds three or more labels (junctions), with those labels.
#[derive(Clone, Debug, Default)]
pub(crate) struct Junctions {
    /// `[H·W]` start of the pixel's entry in `entries`, or `u32::MAX` (not a junction).
    start: Vec<u32>,
    /// Entries `[len, label_1, …, label_len]`.
    entries: Vec<u32>,
}

impl Junctions {
    /// The window labels of pixel `p` if it is a junction.
    pub fn labels(&self, p: u32) -> Option<&[u32]> {
        match self.start.get(p as usize) {
            Some(&s) if s != u32::MAX => {
                let len = self.entries[s as usize] as usize;
                Some(&self.entries[s as usize + 1..s as usize + 1 + len])
            }
            _ => None,
        }
    }
}

/// Builds all edges of `labels` (`[H, W]`, 0 = unlabelled) for dilation radius `radius` (≤ 8),
/// and the junction table. Edges are in order of their first band pixel (deterministic).
// `x` indexes several ring rows at once, not one slice.
#[allow(clippy::needless_range_loop)]
pub(crate) fn build_edges(labels: &Plane<u32>, radius: usize) -> (Vec<Edge>, Junctions) {
    let (w, h) = labels.size();
    let k = 2 * radius + 1;
    let mut index: HashMap<(u32, u32), usize> = HashMap::new();
    let mut edges: Vec<Edge> = Vec::new();
    let mut junctions = Junctions::default();
    if w == 0 || h == 0 {
        return (edges, junctions);
    }
    let mut ring: Vec<RingRow> = (0..k).map(|_| RingRow::new(w, k)).collect();
    junctions.start = vec![u32::MAX; w * h];
    // Rows y−r ..= y+r live in ring slots (row mod k).
    for y in 0..radius.min(h) {
        ring[y % k].fill(labels.row(y), radius);
    }
    let mut window: Vec<u32> = Vec::with_capacity(k * k);
    let mut rows: Vec<usize> = Vec::with_capacity(k);
    let mut last: Option<((u32, u32), usize)> = None;
    for y in 0..h {
        if y + radius < h {
            ring[(y + radius) % k].fill(labels.row(y + radius), radius);
        }
        rows.clear();
        rows.extend((y.saturating_sub(radius)..=(y + radius).min(h - 1)).map(|r| r % k));
        for x in 0..w {
            // Fast path: every row holds at most the same single label.
            let mut single = 0u32;
            let mut simple = true;
            for &r in &rows {
                match ring[r].single[x] {
                    0 => {}
                    MIXED => {
                        simple = false;
                        break;
                    }
                    l if single == 0 || single == l => single = l,
                    _ => {
                        simple = false;
                        break;
                    }
                }
            }
            if simple {
                continue;
            }
            window.clear();
            for &r in &rows {
                for &l in ring[r].labels_at(x, k) {
                    if !window.contains(&l) {
                        window.push(l);
                    }
                }
            }
            window.sort_unstable();
            let p = (y * w + x) as u32;
            if window.len() > 2 {
                junctions.start[p as usize] = junctions.entries.len() as u32;
                junctions.entries.push(window.len() as u32);
                junctions.entries.extend_from_slice(&window);
            }
            for i in 0..window.len() {
                for j in i + 1..window.len() {
                    let key = (window[i], window[j]);
                    let e = match last {
                        Some((lk, le)) if lk == key => le,
                        _ => *index.entry(key).or_insert_with(|| {
                            edges.push(Edge { a: key.0, b: key.1, band: Vec::new() });
                            edges.len() - 1
                        }),
                    };
                    last = Some((key, e));
                    edges[e].band.push(p);
                }
            }
        }
    }
    (edges, junctions)
}

/// Sorted union of two sorted, duplicate-free lists.
pub(crate) fn sorted_union(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                out.push(a[i]);
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference: band by explicit dilation.
    fn band_by_dilation(labels: &Plane<u32>, a: u32, b: u32, r: usize) -> Vec<u32> {
        let (w, h) = labels.size();
        let has = |x: usize, y: usize, l: u32| {
            let (x0, x1) = (x.saturating_sub(r), (x + r).min(w - 1));
            let (y0, y1) = (y.saturating_sub(r), (y + r).min(h - 1));
            (y0..=y1).any(|yy| (x0..=x1).any(|xx| *labels.get(xx, yy) == l))
        };
        (0..w * h).filter(|&p| has(p % w, p / w, a) && has(p % w, p / w, b)).map(|p| p as u32).collect()
    }

    #[test]
    fn bands_equal_the_intersection_of_dilations() {
        // Pseudo-random blobs with a few unlabelled pixels.
        let (w, h) = (23, 17);
        let data: Vec<u32> = (0..w * h)
            .map(|p| {
                let (x, y) = (p % w, p / w);
                if (x * 7 + y * 3) % 29 == 0 {
                    0
                } else {
                    1 + ((x / 6 + 2 * (y / 5)) % 5) as u32
                }
            })
            .collect();
        let labels = Plane::from_vec(w, h, data).unwrap();
        for r in [1, 2, 3] {
            let (edges, junctions) = build_edges(&labels, r);
            let dilated: Vec<Vec<u32>> = (1..=5u32).map(|l| band_by_dilation(&labels, l, l, r)).collect();
            for p in 0..(w * h) as u32 {
                let n_labels = dilated.iter().filter(|d| d.binary_search(&p).is_ok()).count();
                assert_eq!(
                    junctions.labels(p).map_or(0, |l| l.len()),
                    if n_labels > 2 { n_labels } else { 0 }
                );
            }
            for a in 1..=5u32 {
                for b in a + 1..=5 {
                    let expect = band_by_dilation(&labels, a, b, r);
                    let got = edges
                        .iter()
                        .find(|e| e.a == a && e.b == b)
                        .map(|e| e.band.clone())
                        .unwrap_or_default();
                    assert_eq!(got, expect, "pair ({a}, {b}) radius {r}");
                }
            }
        }
    }

    #[test]
    fn sorted_union_merges_without_duplicates() {
        assert_eq!(sorted_union(&[1, 3, 5, 9], &[2, 3, 9, 10]), vec![1, 2, 3, 5, 9, 10]);
    }
}

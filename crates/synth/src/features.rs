//! Simulated DINOv2-like patch features.
//!
//! Every instance has a base embedding: a shared component plus its own orthogonal direction,
//! so two different instances have cosine similarity `α_i · α_j ∈ [0.35, 0.6]`. The white
//! cylinder's embedding is the white box's plus a small perturbation (cosine ≈ 0.9: the same
//! look gives the same semantics, the paper's ambiguity); the two walls are alike (≈ 0.7).
//! The same-depth pair (red and blue box) is an ordinary pair of different objects.
//! Each texture part of an instance perturbs its base a little (cosine ≈ 0.95 to the base), so
//! fragments of one object stay similar.
//!
//! The grid is `[ceil(H / p), ceil(W / p), C]` (p = 14 for DINOv2, as if the image were
//! resized up to a multiple of the patch size); cell `(i, j)` covers the image area
//! `[i·H/h, (i+1)·H/h) × [j·W/w, (j+1)·W/w)`, which is what bilinear upsampling with
//! `align_corners = false` assumes. A cell's feature is the area-weighted mean of the
//! embeddings of the (instance, part) pairs it covers (boundary cells mix both sides), plus a
//! smooth spatial drift and per-patch noise.

use crate::config::CueConfig;
use crate::noise::{hash, normal, rng_for, stream, value_noise2};
use rand::Rng;
use splatseg_scene::Plane;
use std::collections::BTreeMap;

/// A dense feature map on a patch grid, `[grid_h, grid_w, dim]` row-major, channels last
/// (written as `.npy` in this shape).
#[derive(Clone, Debug, PartialEq)]
pub struct PatchFeatures {
    /// Rows of the grid.
    pub grid_h: usize,
    /// Columns of the grid.
    pub grid_w: usize,
    /// Channels.
    pub dim: usize,
    /// `[grid_h * grid_w * dim]` values.
    pub values: Vec<f32>,
}

impl PatchFeatures {
    /// The feature vector of cell `(row, col)`: `[dim]`.
    pub fn cell(&self, row: usize, col: usize) -> &[f32] {
        let start = (row * self.grid_w + col) * self.dim;
        &self.values[start..start + self.dim]
    }
}

/// Embeddings of every (instance, part) that appears, built once per scene.
#[derive(Clone, Debug)]
pub struct Embeddings {
    dim: usize,
    seed: u64,
    base: BTreeMap<u32, Vec<f64>>,
    /// The part perturbation, patch noise and drift used.
    cues: CueConfig,
}

fn normalise(v: &mut [f64]) {
    let n = v.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-12);
    v.iter_mut().for_each(|x| *x /= n);
}

fn random_unit(rng: &mut impl Rng, dim: usize) -> Vec<f64> {
    let mut v: Vec<f64> = (0..dim).map(|_| normal(rng.gen())).collect();
    normalise(&mut v);
    v
}

/// Gram–Schmidt: `v` minus its components along each of `basis` (unit vectors), normalised.
fn orthogonalise(mut v: Vec<f64>, basis: &[Vec<f64>]) -> Vec<f64> {
    for b in basis {
        let d: f64 = v.iter().zip(b).map(|(x, y)| x * y).sum();
        v.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
    }
    normalise(&mut v);
    v
}

/// Cosine similarity of two vectors.
pub fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let na = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    dot / (na * nb).max(1e-12)
}

impl Embeddings {
    /// Embeddings for instances `0..=max_id` (0 = no surface). `alike`: pairs `(a, b)` whose
    /// embedding `b` is `a`'s plus a perturbation of relative size `strength`. `cues`: the
    /// statistics (shared share, part perturbation, patch noise, drift).
    pub fn new(
        seed: u64,
        dim: usize,
        max_id: u32,
        alike: &[(u32, u32, f64)],
        cues: &CueConfig,
    ) -> Embeddings {
        let mut rng = rng_for(seed, stream::EMBEDDINGS, 0);
        let shared = random_unit(&mut rng, dim);
        let mut basis = vec![shared.clone()];
        let mut base = BTreeMap::new();
        for id in 0..=max_id {
            let own = orthogonalise(random_unit(&mut rng, dim), &basis);
            basis.push(own.clone());
            let [lo, hi] = cues.shared_share;
            let alpha: f64 = rng.gen_range(lo..hi).sqrt();
            let beta = (1.0 - alpha * alpha).sqrt();
            let v: Vec<f64> = shared.iter().zip(&own).map(|(s, o)| alpha * s + beta * o).collect();
            base.insert(id, v);
        }
        for &(a, b, strength) in alike {
            let (Some(va), true) = (base.get(&a).cloned(), base.contains_key(&b)) else { continue };
            let r = orthogonalise(random_unit(&mut rng, dim), std::slice::from_ref(&va));
            let mut v: Vec<f64> = va.iter().zip(&r).map(|(x, y)| x + strength * y).collect();
            normalise(&mut v);
            base.insert(b, v);
        }
        Embeddings { dim, seed, base, cues: cues.clone() }
    }

    /// Channels.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Base embedding of an instance (`[dim]`, unit), if the id exists.
    pub fn base(&self, id: u32) -> Option<&[f64]> {
        self.base.get(&id).map(Vec::as_slice)
    }

    /// Embedding of a part of an instance (`[dim]`, unit): the base plus a fixed perturbation.
    pub fn part(&self, id: u32, part: u8) -> Vec<f64> {
        let Some(base) = self.base.get(&id) else { return vec![0.0; self.dim] };
        let mut v: Vec<f64> = (0..self.dim)
            .map(|c| {
                let r = normal(hash(self.seed, &[stream::EMBEDDINGS, id as u64, part as u64, c as u64]));
                base[c] + self.cues.part_perturbation * r / (self.dim as f64).sqrt()
            })
            .collect();
        normalise(&mut v);
        v
    }
}

/// The smooth spatial drift of a `[gh, gw]` grid: `[gh * gw * dim]`, the same in every view
/// (computed once per scene).
pub fn drift_table(embeddings: &Embeddings, gh: usize, gw: usize) -> Vec<f64> {
    let dim = embeddings.dim();
    let mut out = Vec::with_capacity(gh * gw * dim);
    for i in 0..gh {
        for j in 0..gw {
            let (u, v) = ((j as f64 + 0.5) / gw as f64, (i as f64 + 0.5) / gh as f64);
            for c in 0..dim {
                out.push(value_noise2(
                    hash(embeddings.seed, &[stream::FEATURE_NOISE, c as u64]),
                    2.0 * u,
                    2.0 * v,
                ));
            }
        }
    }
    out
}

/// The patch grid `(gh, gw)` of an image `width × height` for patches of `patch_px`.
pub fn grid_size(width: usize, height: usize, patch_px: u32) -> (usize, usize) {
    let patch = patch_px.max(1) as usize;
    (height.div_ceil(patch), width.div_ceil(patch))
}

/// Patch features of one view. `instance`, `part`: `[H, W]` ground truth.
pub fn patch_features(
    instance: &Plane<u32>,
    part: &Plane<u8>,
    embeddings: &Embeddings,
    patch_px: u32,
    view: usize,
) -> PatchFeatures {
    let (w, h) = instance.size();
    let (gh, gw) = grid_size(w, h, patch_px);
    patch_features_with_drift(instance, part, embeddings, patch_px, view, &drift_table(embeddings, gh, gw))
}

/// [`patch_features`] with the scene's [`drift_table`] (`[gh * gw * dim]`) computed once.
pub fn patch_features_with_drift(
    instance: &Plane<u32>,
    part: &Plane<u8>,
    embeddings: &Embeddings,
    patch_px: u32,
    view: usize,
    drift_values: &[f64],
) -> PatchFeatures {
    let (w, h) = instance.size();
    let (gh, gw) = grid_size(w, h, patch_px);
    let dim = embeddings.dim();
    let mut cache: BTreeMap<(u32, u8), Vec<f64>> = BTreeMap::new();
    let mut values = Vec::with_capacity(gh * gw * dim);
    let mut counts: Vec<((u32, u8), usize)> = Vec::new();
    for i in 0..gh {
        let (y0, y1) = (i * h / gh, ((i + 1) * h / gh).max(i * h / gh + 1));
        for j in 0..gw {
            let (x0, x1) = (j * w / gw, ((j + 1) * w / gw).max(j * w / gw + 1));
            counts.clear();
            for y in y0..y1.min(h) {
                for x in x0..x1.min(w) {
                    let key = (*instance.get(x, y), *part.get(x, y));
                    match counts.iter_mut().find(|(k, _)| *k == key) {
                        Some((_, c)) => *c += 1,
                        None => counts.push((key, 1)),
                    }
                }
            }
            let total: usize = counts.iter().map(|(_, c)| c).sum();
            let mut f = vec![0.0f64; dim];
            for &(key, c) in &counts {
                let e = cache.entry(key).or_insert_with(|| embeddings.part(key.0, key.1));
                let weight = c as f64 / total.max(1) as f64;
                f.iter_mut().zip(e.iter()).for_each(|(a, b)| *a += weight * b);
            }
            let cell_drift = &drift_values[(i * gw + j) * dim..(i * gw + j + 1) * dim];
            for (c, value) in f.iter_mut().enumerate() {
                let drift = cell_drift[c];
                let noise = normal(hash(
                    embeddings.seed,
                    &[stream::FEATURE_NOISE, view as u64, i as u64, j as u64, c as u64],
                ));
                *value += embeddings.cues.drift * (drift - 0.5)
                    + embeddings.cues.patch_noise * noise / (dim as f64).sqrt();
                values.push(*value as f32);
            }
        }
    }
    PatchFeatures { grid_h: gh, grid_w: gw, dim, values }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedding_similarities_follow_the_design() {
        let e = Embeddings::new(3, 32, 10, &[(4, 5, 0.45), (2, 3, 1.0)], &CueConfig::default());
        let b = |id| e.base(id).expect("id").to_vec();
        let white = cosine(&b(4), &b(5));
        assert!(white > 0.85, "white pair {white}");
        let walls = cosine(&b(2), &b(3));
        assert!((0.55..0.85).contains(&walls), "walls {walls}");
        for (i, j) in [(6, 7), (4, 6), (1, 8), (9, 10)] {
            let c = cosine(&b(i), &b(j));
            assert!((0.3..=0.62).contains(&c), "{i} vs {j}: {c}");
        }
        let parts = cosine(&e.part(6, 0), &e.part(6, 5));
        assert!(parts > 0.85, "parts {parts}");
    }

    /// Mean cosines over instances 1..=40 of 384-d embeddings: (two parts of one instance, two
    /// instances).
    fn mean_similarities(cues: &CueConfig) -> (f64, f64) {
        let e = Embeddings::new(5, 384, 40, &[], cues);
        let mean = |v: Vec<f64>| v.iter().sum::<f64>() / v.len() as f64;
        let parts = mean((1..=40).map(|id| cosine(&e.part(id, 0), &e.part(id, 1))).collect());
        let b = |id| e.base(id).expect("id").to_vec();
        let objects = mean((1..40).map(|id| cosine(&b(id), &b(id + 1))).collect());
        (parts, objects)
    }

    #[test]
    fn the_blind_families_cues_are_the_harsher_statistics_they_claim() {
        // tuning: parts ≈ 1 / (1 + 0.3²) = 0.92, objects ≈ E√(s_i s_j) with s ∈ [0.35, 0.6]
        let (parts, objects) = mean_similarities(&CueConfig::default());
        assert!((0.90..0.94).contains(&parts) && (0.43..0.51).contains(&objects), "{parts} {objects}");
        // the blind families' extremes: parts 0.83–0.88 (the real-model figure: ≈ 0.87),
        // objects less distinct (s ∈ [0.45, 0.75])
        for p in [0.37, 0.45] {
            let harsh =
                CueConfig { part_perturbation: p, shared_share: [0.45, 0.75], ..CueConfig::default() };
            let (parts, objects) = mean_similarities(&harsh);
            assert!(
                (0.82..0.89).contains(&parts) && (0.55..0.63).contains(&objects),
                "{p}: {parts} {objects}"
            );
        }
        // blind_parts: parts ≈ 0.72–0.80, still above the objects' 0.55–0.63 on average
        for p in [0.5, 0.62] {
            let far = CueConfig { part_perturbation: p, shared_share: [0.45, 0.75], ..CueConfig::default() };
            let (parts, objects) = mean_similarities(&far);
            assert!((0.70..0.81).contains(&parts) && parts > objects + 0.08, "{p}: {parts} {objects}");
        }
    }

    #[test]
    fn cells_average_the_pixels_they_cover() {
        // Left half id 1, right half id 2; 28×14 image, patch 14 → 1×2 grid, each cell pure.
        let instance =
            Plane::from_vec(28, 14, (0..28 * 14).map(|i| if i % 28 < 14 { 1 } else { 2 }).collect())
                .expect("size");
        let part = Plane::filled(28, 14, 0u8);
        let e = Embeddings::new(1, 32, 3, &[], &CueConfig::default());
        let f = patch_features(&instance, &part, &e, 14, 0);
        assert_eq!((f.grid_h, f.grid_w, f.dim), (1, 2, 32));
        let cell = |c: usize| f.cell(0, c).iter().map(|&v| v as f64).collect::<Vec<_>>();
        let to_own = cosine(&cell(0), &e.part(1, 0));
        let to_other = cosine(&cell(0), &e.part(2, 0));
        assert!(to_own > 0.9 && to_own > to_other + 0.2, "own {to_own} other {to_other}");
    }
}

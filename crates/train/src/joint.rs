//! The paper's joint optimisation terms on the per-Gaussian object features (§4.4):
//!
//! - `L_semantic = 1/|G_valid| Σ_{g valid} ‖f_g − f̃_g‖²`,
//! - `L_3D-reg  = 1/|G| Σ_g Σ_{g' ∈ N₅(g)} ‖f_g − f_g'‖²`.
//!
//! Our reading of the target `f̃_g` (the paper calls it "the target lifted feature" of a 16-d field but
//! lifts 768-d DINOv2 features): the **code of the object id lifting gave g** — a fixed unit vector per
//! id (orthonormal while there are at most `D` ids, seeded random unit vectors beyond) — and `G_valid`
//! the Gaussians lifting labelled (id ≥ 0; the variance filter's −1 are not valid). The semantic term
//! pulls every labelled Gaussian to its object's code, the regulariser spreads codes to unlabelled
//! neighbours and smooths noisy votes; [`assign_ids`] reads the field back as ids.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::sampling::standard_normal;

/// One unit code per object id.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectCodes {
    /// Code width D.
    pub dim: usize,
    /// Sorted distinct ids (≥ 0).
    pub ids: Vec<i32>,
    /// `[ids.len(), D]` unit rows.
    pub codes: Vec<f32>,
}

impl ObjectCodes {
    /// Codes for the distinct non-negative ids in `object_ids` (`[N]`), seeded.
    pub fn new(object_ids: &[i32], dim: usize, seed: u64) -> Self {
        let mut ids: Vec<i32> = object_ids.iter().copied().filter(|&id| id >= 0).collect();
        ids.sort_unstable();
        ids.dedup();
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0b1e_c7c0_de5e_ed00);
        let mut codes: Vec<f32> = Vec::with_capacity(ids.len() * dim);
        for k in 0..ids.len() {
            let mut v: Vec<f32> = (0..dim).map(|_| standard_normal(&mut rng)).collect();
            if k < dim {
                // Gram–Schmidt against the earlier codes: orthonormal while they fit
                for prev in codes.chunks(dim) {
                    let d: f32 = v.iter().zip(prev).map(|(a, b)| a * b).sum();
                    v.iter_mut().zip(prev).for_each(|(a, b)| *a -= d * b);
                }
            }
            let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-12);
            codes.extend(v.iter().map(|x| x / norm));
        }
        Self { dim, ids, codes }
    }

    /// The code of `id`, if it has one.
    pub fn code(&self, id: i32) -> Option<&[f32]> {
        let k = self.ids.binary_search(&id).ok()?;
        Some(&self.codes[k * self.dim..(k + 1) * self.dim])
    }
}

/// `L_semantic` and adds `weight · ∂L_semantic/∂f` to `grads` (`[N, D]`); `features`: `[N, D]`,
/// `object_ids`: `[N]`.
pub fn semantic_loss(
    features: &[f32],
    object_ids: &[i32],
    codes: &ObjectCodes,
    weight: f32,
    grads: &mut [f32],
) -> f64 {
    let dim = codes.dim;
    let valid = object_ids.iter().filter(|&&id| codes.code(id).is_some()).count();
    if valid == 0 {
        return 0.0;
    }
    let scale = 1.0 / valid as f32;
    let loss: f64 = features
        .par_chunks(dim)
        .zip(grads.par_chunks_mut(dim))
        .zip(object_ids.par_iter())
        .map(|((f, g), &id)| {
            let Some(target) = codes.code(id) else { return 0.0 };
            let mut sum = 0.0f64;
            for ((fi, gi), ti) in f.iter().zip(g.iter_mut()).zip(target) {
                let d = fi - ti;
                sum += f64::from(d * d);
                *gi += weight * 2.0 * d * scale;
            }
            sum
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    loss / valid as f64
}

/// `L_3D-reg` over `neighbours` (`[N, k]` from [`crate::knn::knn`]) and adds `weight · ∂L/∂f` to `grads`.
pub fn knn_regulariser(
    features: &[f32],
    neighbours: &[u32],
    k: usize,
    weight: f32,
    grads: &mut [f32],
) -> f64 {
    let n = neighbours.len() / k.max(1);
    if n == 0 || !features.len().is_multiple_of(n) {
        return 0.0;
    }
    let dim = features.len() / n;
    let scale = 2.0 * weight / n as f32;
    // ∂/∂f_g of Σ_g Σ_{g'∈N(g)} ‖f_g − f_g'‖² = 2 Σ_{g'∈N(g)} (f_g − f_g') + 2 Σ_{h: g∈N(h)} (f_g − f_h):
    // both parts from the same differences, accumulated in index order (deterministic).
    let mut loss = 0.0f64;
    for g in 0..n {
        let fg = &features[g * dim..(g + 1) * dim];
        for &j in &neighbours[g * k..(g + 1) * k] {
            let j = j as usize;
            if j == g {
                continue;
            }
            let fj = &features[j * dim..(j + 1) * dim];
            for c in 0..dim {
                let d = fg[c] - fj[c];
                loss += f64::from(d * d);
                grads[g * dim + c] += scale * d;
                grads[j * dim + c] -= scale * d;
            }
        }
    }
    loss / n as f64
}

/// Per Gaussian, the id whose code is most similar (cosine) to its feature, or −1 when even that
/// similarity is below `min_cosine`. `features`: `[N, D]`; returns `[N]`.
pub fn assign_ids(features: &[f32], codes: &ObjectCodes, min_cosine: f32) -> Vec<i32> {
    let dim = codes.dim;
    features
        .par_chunks(dim)
        .map(|f| {
            let norm = f.iter().map(|x| x * x).sum::<f32>().sqrt();
            if norm < 1e-12 {
                return -1;
            }
            let mut best = (-1, min_cosine);
            for (k, code) in codes.codes.chunks(dim).enumerate() {
                let cos = f.iter().zip(code).map(|(a, b)| a * b).sum::<f32>() / norm;
                if cos > best.1 {
                    best = (codes.ids[k], cos);
                }
            }
            best.0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_orthonormal_while_they_fit_and_lookup_works() {
        let codes = ObjectCodes::new(&[5, -1, 2, 5, 9, 2], 4, 0);
        assert_eq!(codes.ids, vec![2, 5, 9]);
        for a in 0..3 {
            for b in 0..3 {
                let d: f32 = (0..4).map(|c| codes.codes[a * 4 + c] * codes.codes[b * 4 + c]).sum();
                assert!((d - if a == b { 1.0 } else { 0.0 }).abs() < 1e-5);
            }
        }
        assert!(codes.code(-1).is_none() && codes.code(3).is_none());
        assert_eq!(codes.code(9).unwrap(), &codes.codes[8..12]);
        assert_eq!(ObjectCodes::new(&[5, 2, 9], 4, 0), codes, "seeded");
    }

    #[test]
    fn gradients_match_finite_differences() {
        let ids = [0, 1, -1, 1, 0];
        let codes = ObjectCodes::new(&ids, 3, 1);
        let features: Vec<f32> = (0..15).map(|i| ((i * 7 % 11) as f32 - 5.0) * 0.1).collect();
        let neighbours: Vec<u32> = vec![1, 2, 0, 2, 3, 4, 1, 4, 2, 0]; // k = 2
        let total = |f: &[f32]| {
            let mut g = vec![0f32; 15];
            semantic_loss(f, &ids, &codes, 0.1, &mut g) * 0.1
                + knn_regulariser(f, &neighbours, 2, 0.01, &mut g) * 0.01
        };
        let mut grads = vec![0f32; 15];
        semantic_loss(&features, &ids, &codes, 0.1, &mut grads);
        knn_regulariser(&features, &neighbours, 2, 0.01, &mut grads);
        for i in 0..15 {
            let h = 1e-3;
            let mut plus = features.clone();
            plus[i] += h;
            let mut minus = features.clone();
            minus[i] -= h;
            let numeric = (total(&plus) - total(&minus)) / (2.0 * f64::from(h));
            assert!((numeric - f64::from(grads[i])).abs() < 1e-4, "feature {i}: {numeric} vs {}", grads[i]);
        }
    }

    #[test]
    fn assignment_picks_the_closest_code_or_none() {
        let codes = ObjectCodes::new(&[3, 4], 2, 0);
        let (c3, c4) = (codes.code(3).unwrap().to_vec(), codes.code(4).unwrap().to_vec());
        let features =
            [c3[0] * 2.0, c3[1] * 2.0, c4[0] + 0.1 * c3[0], c4[1] + 0.1 * c3[1], 0.0, 0.0, -c3[0], -c3[1]];
        assert_eq!(assign_ids(&features, &codes, 0.5), vec![3, 4, -1, -1]);
    }
}

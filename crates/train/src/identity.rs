//! The 2D half of the joint optimisation (supplement, "Object Feature Field"): the per-Gaussian object
//! features are splatted into a D-channel identity map, a learnable linear classifier (D → objects +
//! background, as Gaussian Grouping's 1×1 convolution) turns each pixel into class scores, and the
//! cross-entropy against the view's final label map (global ids from `splatseg run`) is the loss.
//!
//! - [`IdentityClasses`]: global ids ↔ class indices (class 0 = background / unlabelled, label 0).
//! - [`Classifier`]: `logits = W·f + b`, its loss and gradients, Adam state.
//! - [`identity_loss`]: mean cross-entropy over a view's pixels and `∂L/∂(identity map)`.
//!
//! Work mapping: pixels in fixed blocks of [`PIXEL_BLOCK`] (rayon), per-block partial sums of the
//! classifier gradient added in block order, so results do not depend on the thread count.

use rayon::prelude::*;

use crate::joint::ObjectCodes;
use crate::optimizer::AdamGroup;

/// Pixels per work item of [`identity_loss`].
pub const PIXEL_BLOCK: usize = 4096;

/// Logit scale of a code-initialised classifier row: `W_k = CODE_LOGIT_SCALE · code_k`, so a pixel whose
/// identity feature equals object k's code scores that class this much above an orthogonal one.
pub const CODE_LOGIT_SCALE: f32 = 4.0;

/// The classes of the classifier: 0 = background (label 0), then every global id ≥ 1 in order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IdentityClasses {
    /// Sorted distinct object ids (≥ 1); class `k ≥ 1` is `ids[k − 1]`.
    pub ids: Vec<u32>,
}

impl IdentityClasses {
    /// Every id ≥ 1 in the label maps (`[H·W]` each) and in the lifted Gaussian ids (`[N]`, −1 = none).
    pub fn new<'a>(maps: impl IntoIterator<Item = &'a [u32]>, lifted: &[i32]) -> Self {
        let mut ids: Vec<u32> =
            maps.into_iter().flat_map(|m| m.iter().copied()).filter(|&id| id > 0).collect();
        ids.extend(lifted.iter().filter(|&&id| id > 0).map(|&id| id as u32));
        ids.sort_unstable();
        ids.dedup();
        Self { ids }
    }

    /// Number of classes K (objects + background).
    pub fn count(&self) -> usize {
        self.ids.len() + 1
    }

    /// Class of a label value (0 and unknown ids = background).
    pub fn class_of(&self, id: u32) -> u32 {
        if id == 0 {
            return 0;
        }
        self.ids.binary_search(&id).map_or(0, |k| k as u32 + 1)
    }

    /// Object id of a class as a Gaussian's `object_id` (background = −1).
    pub fn id_of(&self, class: usize) -> i32 {
        if class == 0 {
            -1
        } else {
            self.ids.get(class - 1).map_or(-1, |&id| id as i32)
        }
    }

    /// `[H·W]` class indices of a label map.
    pub fn classes_of_map(&self, map: &[u32]) -> Vec<u32> {
        map.iter().map(|&id| self.class_of(id)).collect()
    }
}

/// `logits = W·f + b`, `W`: `[K, D]` row-major, `b`: `[K]`, with its Adam state.
#[derive(Clone, Debug, PartialEq)]
pub struct Classifier {
    /// Feature width D.
    pub dim: usize,
    /// Classes K.
    pub classes: usize,
    /// `[K, D]`.
    pub weights: Vec<f32>,
    /// `[K]`.
    pub bias: Vec<f32>,
    adam_w: AdamGroup,
    adam_b: AdamGroup,
    steps: u32,
}

/// Gradients of the loss w.r.t. the classifier.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClassifierGrads {
    /// `[K, D]`.
    pub weights: Vec<f32>,
    /// `[K]`.
    pub bias: Vec<f32>,
}

impl Classifier {
    /// A classifier whose row for an object with a code (the 3D terms' target) is
    /// `CODE_LOGIT_SCALE · code`, so the 2D and 3D terms agree from the start; background and objects
    /// without a code start at 0. Biases start at 0.
    pub fn from_codes(classes: &IdentityClasses, codes: &ObjectCodes) -> Self {
        let (dim, k) = (codes.dim, classes.count());
        let mut weights = vec![0.0f32; k * dim];
        for (c, &id) in classes.ids.iter().enumerate() {
            if let Some(code) = codes.code(id as i32) {
                let row = &mut weights[(c + 1) * dim..(c + 2) * dim];
                row.iter_mut().zip(code).for_each(|(w, &v)| *w = CODE_LOGIT_SCALE * v);
            }
        }
        Self {
            dim,
            classes: k,
            weights,
            bias: vec![0.0; k],
            adam_w: AdamGroup::new(k, dim),
            adam_b: AdamGroup::new(k, 1),
            steps: 0,
        }
    }

    /// Class scores of one feature vector (`[D]` → `[K]`).
    pub fn logits(&self, feature: &[f32], out: &mut [f32]) {
        for (k, o) in out.iter_mut().enumerate() {
            let row = &self.weights[k * self.dim..(k + 1) * self.dim];
            *o = self.bias[k] + row.iter().zip(feature).map(|(w, f)| w * f).sum::<f32>();
        }
    }

    /// The most likely class of each row of `features` (`[M, D]` → `[M]`; ties → lowest class).
    pub fn classify(&self, features: &[f32]) -> Vec<u32> {
        features
            .par_chunks(self.dim)
            .map_init(
                || vec![0.0f32; self.classes],
                |logits, f| {
                    self.logits(f, logits);
                    argmax(logits) as u32
                },
            )
            .collect()
    }

    /// One Adam step with learning rate `lr`.
    pub fn step(&mut self, grads: &ClassifierGrads, lr: f32) {
        self.steps += 1;
        self.adam_w.step(&mut self.weights, &grads.weights, lr, self.steps);
        self.adam_b.step(&mut self.bias, &grads.bias, lr, self.steps);
    }
}

fn argmax(v: &[f32]) -> usize {
    let mut best = 0;
    for (k, &x) in v.iter().enumerate() {
        if x > v[best] {
            best = k;
        }
    }
    best
}

/// What [`identity_loss`] returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IdentityLoss {
    /// Mean cross-entropy over the pixels (unweighted).
    pub loss: f64,
    /// `[H·W, D]` `weight · ∂L/∂(identity map)`.
    pub d_map: Vec<f32>,
    /// `weight · ∂L/∂(classifier)`.
    pub d_classifier: ClassifierGrads,
}

/// Mean cross-entropy of the classified identity map against the class map, and its gradients times
/// `weight`. `map`: `[P, D]` rendered identity features; `classes`: `[P]` class per pixel.
pub fn identity_loss(map: &[f32], classes: &[u32], classifier: &Classifier, weight: f32) -> IdentityLoss {
    let (dim, k) = (classifier.dim, classifier.classes);
    let pixels = classes.len();
    debug_assert_eq!(map.len(), pixels * dim);
    if pixels == 0 {
        return IdentityLoss::default();
    }
    let scale = weight / pixels as f32;
    let mut d_map = vec![0.0f32; map.len()];
    let partial: Vec<(f64, Vec<f32>, Vec<f32>)> = d_map
        .par_chunks_mut(PIXEL_BLOCK * dim)
        .zip(map.par_chunks(PIXEL_BLOCK * dim))
        .zip(classes.par_chunks(PIXEL_BLOCK))
        .map(|((d_block, f_block), c_block)| {
            let mut d_w = vec![0.0f32; k * dim];
            let mut d_b = vec![0.0f32; k];
            let mut logits = vec![0.0f32; k];
            let mut loss = 0.0f64;
            for ((d, f), &c) in d_block.chunks_exact_mut(dim).zip(f_block.chunks_exact(dim)).zip(c_block) {
                classifier.logits(f, &mut logits);
                let max = logits.iter().fold(f32::NEG_INFINITY, |m, &x| m.max(x));
                let sum: f32 = logits
                    .iter_mut()
                    .map(|x| {
                        *x = (*x - max).exp();
                        *x
                    })
                    .sum();
                let c = c as usize;
                loss += f64::from(sum.ln() - (logits[c].ln()));
                // softmax − one-hot, times the scale
                for (j, p) in logits.iter_mut().enumerate() {
                    *p = (*p / sum - if j == c { 1.0 } else { 0.0 }) * scale;
                }
                for (j, &g) in logits.iter().enumerate() {
                    if g == 0.0 {
                        continue;
                    }
                    let row = &classifier.weights[j * dim..(j + 1) * dim];
                    let d_row = &mut d_w[j * dim..(j + 1) * dim];
                    for ((dm, dw), (&w, &fv)) in d.iter_mut().zip(d_row.iter_mut()).zip(row.iter().zip(f)) {
                        *dm += g * w;
                        *dw += g * fv;
                    }
                    d_b[j] += g;
                }
            }
            (loss, d_w, d_b)
        })
        .collect();
    let mut d_classifier = ClassifierGrads { weights: vec![0.0; k * dim], bias: vec![0.0; k] };
    let mut loss = 0.0f64;
    for (l, d_w, d_b) in partial {
        loss += l;
        d_classifier.weights.iter_mut().zip(&d_w).for_each(|(a, b)| *a += b);
        d_classifier.bias.iter_mut().zip(&d_b).for_each(|(a, b)| *a += b);
    }
    IdentityLoss { loss: loss / pixels as f64, d_map, d_classifier }
}

/// Per Gaussian, the class with the largest summed vote (`votes`: `[N, K]`), or `None` when it got no
/// vote at all; ties → lowest class.
pub fn vote_winners(votes: &[f64], classes: usize) -> Vec<Option<usize>> {
    votes
        .chunks_exact(classes)
        .map(|v| {
            let mut best = 0;
            for (k, &x) in v.iter().enumerate() {
                if x > v[best] {
                    best = k;
                }
            }
            (v[best] > 0.0).then_some(best)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn classifier(dim: usize, classes: usize) -> Classifier {
        let weights = (0..classes * dim).map(|i| ((i * 37 % 17) as f32 - 8.0) * 0.1).collect();
        let bias = (0..classes).map(|i| i as f32 * 0.05).collect();
        Classifier {
            dim,
            classes,
            weights,
            bias,
            adam_w: AdamGroup::new(classes, dim),
            adam_b: AdamGroup::new(classes, 1),
            steps: 0,
        }
    }

    #[test]
    fn classes_number_ids_with_background_first() {
        let c = IdentityClasses::new([&[0u32, 7, 3][..], &[3, 9][..]], &[-1, 4, 7]);
        assert_eq!(c.ids, vec![3, 4, 7, 9]);
        assert_eq!(c.count(), 5);
        assert_eq!(c.classes_of_map(&[0, 3, 9, 5]), vec![0, 1, 4, 0]);
        assert_eq!((c.id_of(0), c.id_of(2), c.id_of(9)), (-1, 4, -1));
    }

    #[test]
    fn cross_entropy_gradients_match_finite_differences() {
        let (dim, k, pixels) = (3, 4, 5);
        let map: Vec<f32> = (0..pixels * dim).map(|i| ((i * 13 % 7) as f32 - 3.0) * 0.3).collect();
        let labels = [0u32, 3, 1, 1, 2];
        let cls = classifier(dim, k);
        let weight = 0.7;
        let got = identity_loss(&map, &labels, &cls, weight);
        let f = |m: &[f32], c: &Classifier| identity_loss(m, &labels, c, weight).loss * f64::from(weight);
        let h = 1e-3f32;
        for i in 0..map.len() {
            let (mut up, mut dn) = (map.clone(), map.clone());
            up[i] += h;
            dn[i] -= h;
            let fd = (f(&up, &cls) - f(&dn, &cls)) / (2.0 * f64::from(h));
            assert!((fd - f64::from(got.d_map[i])).abs() < 1e-4, "map[{i}]: {fd} vs {}", got.d_map[i]);
        }
        for i in 0..k * dim {
            let (mut up, mut dn) = (cls.clone(), cls.clone());
            up.weights[i] += h;
            dn.weights[i] -= h;
            let fd = (f(&map, &up) - f(&map, &dn)) / (2.0 * f64::from(h));
            let an = got.d_classifier.weights[i];
            assert!((fd - f64::from(an)).abs() < 1e-4, "W[{i}]: {fd} vs {an}");
        }
        for i in 0..k {
            let (mut up, mut dn) = (cls.clone(), cls.clone());
            up.bias[i] += h;
            dn.bias[i] -= h;
            let fd = (f(&map, &up) - f(&map, &dn)) / (2.0 * f64::from(h));
            let an = got.d_classifier.bias[i];
            assert!((fd - f64::from(an)).abs() < 1e-4, "b[{i}]: {fd} vs {an}");
        }
        assert!(got.loss > 0.0);
    }

    #[test]
    fn code_initialised_classifier_reads_codes_back() {
        let codes = ObjectCodes::new(&[2, 5, -1], 4, 3);
        let classes = IdentityClasses::new([&[0u32, 2, 5][..]], &[]);
        let cls = Classifier::from_codes(&classes, &codes);
        let mut features = codes.code(5).unwrap().to_vec();
        features.extend_from_slice(codes.code(2).unwrap());
        features.extend_from_slice(&[0.0; 4]);
        // background logit 0, the matching code 4, the other ≈ 0: background wins only for a zero feature
        assert_eq!(cls.classify(&features), vec![2, 1, 0]);
    }

    #[test]
    fn votes_pick_the_largest_class_or_none() {
        let votes = [0.1, 0.5, 0.2, 0.0, 0.0, 0.0, 0.3, 0.3, 0.0];
        assert_eq!(vote_winners(&votes, 3), vec![Some(1), None, Some(0)]);
    }
}

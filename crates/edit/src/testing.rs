//! Small deterministic Gaussian sets for unit tests.

use splatseg_scene::gaussians::{ExtraProperty, FeatureBlock};
use splatseg_scene::Gaussians;

/// Degree-1 Gaussians with every optional array filled, one per entry of `ids`.
pub fn labelled_gaussians(ids: &[i32]) -> Gaussians {
    let n = ids.len();
    let f = |i: usize, k: usize| (i * 7 + k) as f32 * 0.25 - 1.0;
    Gaussians {
        means: (0..n).map(|i| [f(i, 0), f(i, 1) * 2.0, -f(i, 2)]).collect(),
        normals: Some(vec![[0.0; 3]; n]),
        sh_dc: (0..n).map(|i| [f(i, 3), f(i, 4), f(i, 5)]).collect(),
        sh_degree: 1,
        sh_rest: (0..n * 9).map(|k| k as f32 * 0.01).collect(),
        raw_opacities: (0..n).map(|i| f(i, 6)).collect(),
        log_scales: (0..n).map(|i| [f(i, 7), f(i, 8), f(i, 9)]).collect(),
        rotations: (0..n).map(|i| [1.0, f(i, 10), 0.0, 0.0]).collect(),
        object_ids: Some(ids.to_vec()),
        features: Some(FeatureBlock { dim: 2, values: (0..2 * n).map(|k| k as f32).collect() }),
        extra: vec![ExtraProperty {
            name: "confidence".into(),
            ply_type: "float".into(),
            values: (0..n).map(|i| i as f64).collect(),
        }],
    }
}

//! Helpers shared by the integration tests: small random scenes and tolerant comparisons.
#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_render::RenderCamera;
use splatseg_scene::{Camera, Gaussians, Pose};

/// `n` random Gaussians in front of an identity camera (z in [2, 4]), SH degree `degree`.
pub fn random_gaussians(n: usize, degree: u8, seed: u64) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let k = (degree as usize + 1).pow(2) - 1;
    let mut g = Gaussians { sh_degree: degree, ..Default::default() };
    for _ in 0..n {
        let z = rng.gen_range(2.0..4.0);
        g.means.push([rng.gen_range(-0.6..0.6) * z / 2.0, rng.gen_range(-0.5..0.5) * z / 2.0, z]);
        g.log_scales.push([0, 1, 2].map(|_| rng.gen_range(-2.6f32..-1.4)));
        g.rotations.push([0, 1, 2, 3].map(|_| rng.gen_range(-1.0f32..1.0)));
        g.raw_opacities.push(rng.gen_range(-1.0..1.5));
        g.sh_dc.push([0, 1, 2].map(|_| rng.gen_range(-1.0f32..1.0)));
        for _ in 0..3 * k {
            g.sh_rest.push(rng.gen_range(-0.3..0.3));
        }
    }
    g
}

/// A `w × h` pinhole camera at a slightly rotated pose looking along +z.
pub fn test_camera(w: u32, h: u32) -> RenderCamera {
    let cam =
        Camera::pinhole(1, w, h, 0.9 * w as f64, 0.9 * w as f64, w as f64 / 2.0 + 0.3, h as f64 / 2.0 - 0.2);
    let pose = Pose::from_quat_translation(
        glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.02, -0.03, 0.01),
        glam::DVec3::new(0.05, -0.02, 0.1),
    );
    RenderCamera::from_scene(&cam, &pose)
}

/// Asserts `|got − want| ≤ atol + rtol·|want|` element-wise; prints the index and both values.
pub fn assert_close(what: &str, got: &[f32], want: &[f32], atol: f32, rtol: f32) {
    assert_eq!(got.len(), want.len(), "{what}: length {} vs reference {}", got.len(), want.len());
    let mut worst: Option<(usize, f32)> = None;
    let mut fails = 0;
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        let excess = (g - w).abs() - (atol + rtol * w.abs());
        if excess > 0.0 || !g.is_finite() {
            fails += 1;
            if worst.is_none_or(|(_, e)| excess > e) {
                worst = Some((i, excess));
            }
        }
    }
    if let Some((i, _)) = worst {
        panic!(
            "{what}: {fails} of {} values out of tolerance (atol {atol}, rtol {rtol}); worst at index {i}: got {} want {}",
            got.len(),
            got[i],
            want[i]
        );
    }
}

/// A safetensors fixture, every tensor converted to f64 (exact for f32 and i32).
pub struct Fixture {
    /// File name, for messages.
    pub name: String,
    tensors: std::collections::BTreeMap<String, (Vec<usize>, Vec<f64>)>,
}

impl Fixture {
    /// Reads `tests/fixtures/<name>.safetensors`.
    pub fn load(name: &str) -> Fixture {
        let path = format!("{}/tests/fixtures/{name}.safetensors", env!("CARGO_MANIFEST_DIR"));
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"));
        let st = safetensors::SafeTensors::deserialize(&bytes).expect("valid safetensors");
        let mut tensors = std::collections::BTreeMap::new();
        for (key, view) in st.tensors() {
            let data = view.data();
            let values: Vec<f64> = match view.dtype() {
                safetensors::Dtype::F32 => {
                    data.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap()) as f64).collect()
                }
                safetensors::Dtype::F64 => {
                    data.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap())).collect()
                }
                safetensors::Dtype::I32 => {
                    data.chunks_exact(4).map(|b| i32::from_le_bytes(b.try_into().unwrap()) as f64).collect()
                }
                other => panic!("{path}: {key} has unsupported dtype {other:?}"),
            };
            tensors.insert(key, (view.shape().to_vec(), values));
        }
        Fixture { name: name.to_string(), tensors }
    }

    /// Shape of tensor `key`.
    pub fn shape(&self, key: &str) -> &[usize] {
        &self.get(key).0
    }

    fn get(&self, key: &str) -> &(Vec<usize>, Vec<f64>) {
        self.tensors.get(key).unwrap_or_else(|| panic!("{}: no tensor {key}", self.name))
    }

    /// Tensor `key` as f64, row-major.
    pub fn f64(&self, key: &str) -> Vec<f64> {
        self.get(key).1.clone()
    }

    /// Tensor `key` as f32, row-major.
    pub fn f32(&self, key: &str) -> Vec<f32> {
        self.get(key).1.iter().map(|&v| v as f32).collect()
    }

    /// Tensor `key` as i32.
    pub fn i32(&self, key: &str) -> Vec<i32> {
        self.get(key).1.iter().map(|&v| v as i32).collect()
    }

    /// Tensor `key` `[N, K]` as `N` fixed-size rows.
    pub fn rows<const K: usize>(&self, key: &str) -> Vec<[f32; K]> {
        self.f32(key).chunks_exact(K).map(|c| c.try_into().unwrap()).collect()
    }
}

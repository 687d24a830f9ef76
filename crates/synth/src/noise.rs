//! Counter-based randomness: values that depend only on (seed, coordinates), so per-pixel noise
//! is identical whatever the thread schedule. Sequential choices use `ChaCha8Rng` instead.

use glam::DVec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// SplitMix64 finaliser: a well-mixed 64-bit hash of `x`.
#[inline]
pub fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Hash of a seed and a list of integer coordinates.
#[inline]
pub fn hash(seed: u64, coords: &[u64]) -> u64 {
    coords.iter().fold(mix64(seed), |h, &c| mix64(h ^ c.wrapping_mul(0xD6E8_FEB8_6659_FD93)))
}

/// Uniform value in [0, 1) from a hash.
#[inline]
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Standard normal value from a hash (Box–Muller on two derived uniforms).
#[inline]
pub fn normal(h: u64) -> f64 {
    let u1 = unit(mix64(h ^ 0x51)).max(1e-12);
    let u2 = unit(mix64(h ^ 0xA7));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// A seeded sequential RNG for one purpose (`stream`) and one index (e.g. a view).
pub fn rng_for(seed: u64, stream: u64, index: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(hash(seed, &[stream, index]))
}

/// Stream tags for [`rng_for`] and [`hash`], one per use, so changing one use never shifts the
/// random numbers of another.
pub mod stream {
    /// Scene layout (object jitter, extra objects).
    pub const LAYOUT: u64 = 1;
    /// Camera arc jitter.
    pub const CAMERAS: u64 = 2;
    /// Gaussian sample jitter.
    pub const GAUSSIANS: u64 = 3;
    /// SAM simulation, per view.
    pub const SAM: u64 = 4;
    /// Feature embeddings.
    pub const EMBEDDINGS: u64 = 5;
    /// Per-patch feature noise.
    pub const FEATURE_NOISE: u64 = 6;
    /// Monocular depth distortion and noise.
    pub const MONO_DEPTH: u64 = 7;
    /// Image sensor noise.
    pub const IMAGE_NOISE: u64 = 8;
    /// Blotch texture pattern.
    pub const TEXTURE: u64 = 9;
    /// A family's knobs.
    pub const FAMILY: u64 = 10;
    /// The random layout.
    pub const ROOM_LAYOUT: u64 = 11;
    /// The extra SAM noise (adjacent merges, dilation), per view.
    pub const SAM_EXTRA: u64 = 12;
    /// How far each Gaussian is from an exact disc on its surface.
    pub const GAUSSIAN_FIT: u64 = 13;
}

/// Smooth value noise in [0, 1] on a unit lattice (trilinear interpolation with smoothstep).
pub fn value_noise3(seed: u64, p: DVec3) -> f64 {
    let base = p.floor();
    let f = p - base;
    let s = f * f * (DVec3::splat(3.0) - 2.0 * f);
    let (ix, iy, iz) = (base.x as i64, base.y as i64, base.z as i64);
    let corner =
        |dx: i64, dy: i64, dz: i64| unit(hash(seed, &[(ix + dx) as u64, (iy + dy) as u64, (iz + dz) as u64]));
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), s.x);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), s.x);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), s.x);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// Smooth value noise in [0, 1] on a unit lattice in 2D.
pub fn value_noise2(seed: u64, x: f64, y: f64) -> f64 {
    value_noise3(seed, DVec3::new(x, y, 0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_values_lie_in_range_and_vary() {
        let values: Vec<f64> = (0..1000).map(|i| unit(hash(7, &[i]))).collect();
        assert!(values.iter().all(|v| (0.0..1.0).contains(v)));
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        assert!((mean - 0.5).abs() < 0.05, "mean {mean}");
    }

    #[test]
    fn normal_values_have_unit_variance() {
        let values: Vec<f64> = (0..20000).map(|i| normal(hash(3, &[i]))).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / values.len() as f64;
        assert!(mean.abs() < 0.03 && (var - 1.0).abs() < 0.05, "mean {mean} var {var}");
    }

    #[test]
    fn value_noise_is_continuous_and_bounded() {
        let mut prev = value_noise2(1, 0.0, 0.3);
        for i in 1..1000 {
            let v = value_noise2(1, i as f64 * 0.01, 0.3);
            assert!((0.0..=1.0).contains(&v));
            assert!((v - prev).abs() < 0.05, "jump at {i}");
            prev = v;
        }
    }
}

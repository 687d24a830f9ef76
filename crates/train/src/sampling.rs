//! Seeded random draws shared by densification, the object codes and the feature initialisation.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A standard normal sample by Box–Muller.
pub(crate) fn standard_normal(rng: &mut ChaCha8Rng) -> f32 {
    let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
    let u2: f64 = rng.gen::<f64>();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

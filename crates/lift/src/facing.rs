//! Which way each Gaussian's surface faces: the sum of the unit directions from the Gaussian to
//! the cameras that see it. A Gaussian's normal (the axis of its smallest scale) has no sign,
//! but a surface seen by a camera faces it, so these sums orient the normals outwards. The part
//! join of [`crate::touching`] needs that: the parts of one object meet at convex or smooth
//! edges (a cylinder's cap and side), different objects at concave ones (a box beside a box).

use crate::project::PreparedGaussians;
use glam::Vec3;

/// Gaussians with a flatness below this have no normal (to orient, or to measure planes by).
pub(crate) const MIN_FLATNESS: f32 = 0.3;

/// Per Gaussian, the sum of the unit directions to the cameras that saw it (`[N]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Facing {
    towards_cameras: Vec<Vec3>,
}

impl Facing {
    /// No view yet, for `n_gaussians` Gaussians.
    pub fn new(n_gaussians: usize) -> Self {
        Facing { towards_cameras: vec![Vec3::ZERO; n_gaussians] }
    }

    /// Adds one view: `visible` (`[n_visible]` Gaussian indices, any order) seen from the camera
    /// centre `camera_centre` (world). Indices out of range are skipped. Sums in the order views
    /// are added: add them in a fixed order for results independent of threads.
    pub fn add_view(&mut self, gaussians: &PreparedGaussians, visible: &[u32], camera_centre: Vec3) {
        for &g in visible {
            let g = g as usize;
            if g >= self.towards_cameras.len() || g >= gaussians.len() {
                continue;
            }
            self.towards_cameras[g] += (camera_centre - gaussians.mean(g)).normalize_or_zero();
        }
    }

    /// The outward unit normal of Gaussian `i`: its flat normal, turned towards the cameras that
    /// saw it. `None` when it is not flat, was never seen, or is seen edge-on on average.
    pub fn outward_normal(&self, gaussians: &PreparedGaussians, i: usize) -> Option<Vec3> {
        let towards = *self.towards_cameras.get(i)?;
        let normal = *gaussians.normals.get(i)?;
        if gaussians.flatness.get(i).copied().unwrap_or(0.0) < MIN_FLATNESS || normal == Vec3::ZERO {
            return None;
        }
        let side = normal.dot(towards);
        if side.abs() <= 1e-6 * towards.length().max(1e-30) || !side.is_finite() {
            return None;
        }
        Some(if side > 0.0 { normal } else { -normal })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatseg_scene::Gaussians;

    /// Flat discs at `means` with normal +z (smallest scale along z).
    fn discs(means: &[[f32; 3]]) -> PreparedGaussians {
        let n = means.len();
        let g = Gaussians {
            means: means.to_vec(),
            log_scales: vec![[0.1f32.ln(), 0.1f32.ln(), 0.001f32.ln()]; n],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
            raw_opacities: vec![2.0; n],
            ..Gaussians::default()
        };
        PreparedGaussians::new(&g).expect("finite")
    }

    #[test]
    fn a_normal_turns_towards_the_cameras_that_see_it() {
        let g = discs(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
        let mut facing = Facing::new(2);
        facing.add_view(&g, &[0, 1], Vec3::new(0.5, 0.0, 3.0));
        facing.add_view(&g, &[1], Vec3::new(1.0, 0.5, -2.0));
        facing.add_view(&g, &[1], Vec3::new(1.0, -0.5, -2.0));
        assert_eq!(facing.outward_normal(&g, 0), Some(Vec3::Z));
        // Seen once from above and twice from below: it faces down.
        assert_eq!(facing.outward_normal(&g, 1), Some(-Vec3::Z));
    }

    #[test]
    fn gaussians_never_seen_or_out_of_range_have_no_outward_normal() {
        let g = discs(&[[0.0, 0.0, 0.0]]);
        let mut facing = Facing::new(1);
        assert_eq!(facing.outward_normal(&g, 0), None);
        facing.add_view(&g, &[0, 7], Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(facing.outward_normal(&g, 0), Some(Vec3::Z));
        assert_eq!(facing.outward_normal(&g, 7), None);
    }
}

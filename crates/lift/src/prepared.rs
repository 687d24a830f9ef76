//! [`PreparedGaussians`]: the Gaussians' geometry, checked once, in the form the renderer's
//! projection reads (means, log-scales, rotations, raw opacities), plus what the 3D contact test
//! of [`crate::touching`] needs (centres and a typical size).

use crate::error::{LiftError, LiftResult};
use glam::Vec3;
use splatseg_scene::Gaussians;

/// The geometry of `N` Gaussians, every value finite.
#[derive(Clone, Debug, Default)]
pub struct PreparedGaussians {
    /// Geometry only (no colour): what `splatseg_render` projects.
    pub geometry: Gaussians,
    /// `[N]` centres.
    pub means: Vec<Vec3>,
    /// `[N]` standard deviation `sqrt(trace(Σ) / 3)`, scene units.
    pub sigmas: Vec<f32>,
}

impl PreparedGaussians {
    /// Prepares `gaussians`, rejecting non-finite parameters.
    pub fn new(gaussians: &Gaussians) -> LiftResult<Self> {
        let n = gaussians.len();
        for i in 0..n {
            let finite = |v: &[f32], what| {
                if v.iter().all(|x| x.is_finite()) {
                    Ok(())
                } else {
                    Err(LiftError::NonFinite { index: i, what })
                }
            };
            finite(&gaussians.means[i], "position")?;
            finite(&gaussians.log_scales[i], "scale")?;
            finite(&gaussians.rotations[i], "rotation")?;
            finite(&gaussians.raw_opacities[i..i + 1], "opacity")?;
        }
        let geometry = Gaussians {
            means: gaussians.means.clone(),
            log_scales: gaussians.log_scales.clone(),
            rotations: gaussians.rotations.clone(),
            raw_opacities: gaussians.raw_opacities.clone(),
            ..Gaussians::default()
        };
        let sigmas = (0..n)
            .map(|i| {
                let s = gaussians.scales(i);
                ((s[0] * s[0] + s[1] * s[1] + s[2] * s[2]) / 3.0).sqrt()
            })
            .collect();
        let means = gaussians.means.iter().map(|&m| Vec3::from(m)).collect();
        Ok(PreparedGaussians { geometry, means, sigmas })
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }
}

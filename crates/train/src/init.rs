//! Starting Gaussians when there is no PLY, as 3DGS makes them: one isotropic Gaussian per point of a
//! point cloud (COLMAP's sparse points), or random points in a cube for scenes without points
//! (3DGS's NeRF-synthetic init: uniform in [−1.3, 1.3]³, near-grey colours).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::gaussians::{sh_coeffs_for_degree, SH_C0};
use splatseg_scene::Gaussians;

use crate::knn::knn;

/// 3DGS's initial opacity.
const INITIAL_OPACITY: f32 = 0.1;
/// 3DGS's floor on the mean squared neighbour distance.
const MIN_MEAN_SQUARED_DISTANCE: f32 = 1e-7;

/// One Gaussian per point (3DGS's `create_from_pcd`): colour from `colours` as SH degree 0, higher SH
/// (up to `sh_degree`) zero, isotropic scale √(mean squared distance to the 3 nearest points),
/// identity rotation, opacity 0.1. `points`, `colours`: `[N]`.
pub fn gaussians_from_points(points: &[[f32; 3]], colours: &[[u8; 3]], sh_degree: u8) -> Gaussians {
    let n = points.len();
    let neighbours = knn(points, 3);
    let log_scales = (0..n)
        .map(|i| {
            let mean_sq = neighbours[i * 3..(i + 1) * 3]
                .iter()
                .map(|&j| (0..3).map(|a| (points[i][a] - points[j as usize][a]).powi(2)).sum::<f32>())
                .sum::<f32>()
                / 3.0;
            // a lone point (its own neighbour) gets the floor
            let log_scale = 0.5 * mean_sq.max(MIN_MEAN_SQUARED_DISTANCE).ln();
            [log_scale; 3]
        })
        .collect();
    let raw_opacity = (INITIAL_OPACITY / (1.0 - INITIAL_OPACITY)).ln();
    let rest = 3 * (sh_coeffs_for_degree(sh_degree) - 1);
    Gaussians {
        means: points.to_vec(),
        sh_dc: colours.iter().map(|c| c.map(|v| (f32::from(v) / 255.0 - 0.5) / SH_C0)).collect(),
        sh_degree,
        sh_rest: vec![0.0; n * rest],
        raw_opacities: vec![raw_opacity; n],
        log_scales,
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        ..Gaussians::default()
    }
}

/// 3DGS's start for scenes without points: `count` points uniform in `[−half_side, half_side]³` around
/// `centre` with colours `0.5 + SH_C0·u/255` (`u` uniform in [0, 1): near grey), then as
/// [`gaussians_from_points`]. Seeded.
pub fn random_gaussians_in_cube(
    count: usize,
    centre: [f32; 3],
    half_side: f32,
    sh_degree: u8,
    seed: u64,
) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let points: Vec<[f32; 3]> =
        (0..count).map(|_| centre.map(|c| c + rng.gen_range(-half_side..half_side))).collect();
    let colours: Vec<[u8; 3]> = (0..count)
        .map(|_| [(); 3].map(|()| ((0.5 + SH_C0 * rng.gen::<f32>() / 255.0) * 255.0).round() as u8))
        .collect();
    gaussians_from_points(&points, &colours, sh_degree)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_become_3dgs_initial_gaussians() {
        // a unit grid: every point's 3 nearest neighbours are at distance 1 → scale 1
        let points: Vec<[f32; 3]> =
            (0..27).map(|i| [(i % 3) as f32, ((i / 3) % 3) as f32, (i / 9) as f32]).collect();
        let colours = vec![[255, 128, 0]; 27];
        let g = gaussians_from_points(&points, &colours, 3);
        assert_eq!(g.len(), 27);
        assert_eq!(g.sh_rest.len(), 27 * 45);
        for i in 0..27 {
            assert!((g.scales(i)[0] - 1.0).abs() < 1e-5 && g.scales(i)[0] == g.scales(i)[2]);
            assert!((g.opacity(i) - 0.1).abs() < 1e-6);
            let colour = g.base_colour(i);
            assert!(
                (colour[0] - 1.0).abs() < 1e-5
                    && (colour[1] - 128.0 / 255.0).abs() < 1e-5
                    && colour[2] == 0.0
            );
        }
        let cube = random_gaussians_in_cube(500, [0.0, 1.0, 0.0], 1.3, 0, 7);
        assert!(cube
            .means
            .iter()
            .all(|p| p[0].abs() <= 1.3 && (p[1] - 1.0).abs() <= 1.3 && p[2].abs() <= 1.3));
        assert!(cube.means.iter().any(|p| p[0] > 1.0) && cube.means.iter().any(|p| p[0] < -1.0));
        assert_eq!(cube, random_gaussians_in_cube(500, [0.0, 1.0, 0.0], 1.3, 0, 7), "seeded");
    }
}

//! Real data: the points of gsplat's `test_garden.npz` rendered as small isotropic Gaussians with
//! their colours through the file's three cameras (at half resolution). Checks coverage where points
//! project, and that colour and depth agree with the front-most point where points are dense
//! Skips with a message when `../shared/data` is absent.

use rayon::prelude::*;
use splatseg_render::{render, RenderCamera, RenderRequest};
use splatseg_scene::npy::{read_npz, NpyArray};
use splatseg_scene::{Gaussians, Pose};
use std::collections::BTreeMap;
use std::path::Path;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/gsplat_garden/test_garden.npz");

fn array<'a>(npz: &'a BTreeMap<String, NpyArray>, key: &str) -> &'a NpyArray {
    npz.get(key).unwrap_or_else(|| panic!("test_garden.npz has no `{key}`"))
}

/// Median distance to the nearest other point over a fixed subsample (brute force).
fn median_nn_distance(means: &[[f32; 3]]) -> f32 {
    let step = (means.len() / 1000).max(1);
    let mut d: Vec<f32> = (0..means.len())
        .step_by(step)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&i| {
            let p = means[i];
            means
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, q)| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                .fold(f32::INFINITY, f32::min)
                .sqrt()
        })
        .collect();
    d.sort_by(f32::total_cmp);
    d[d.len() / 2]
}

fn gaussians_from_points(means: Vec<[f32; 3]>, colours: &[f32], scale: f32) -> Gaussians {
    let n = means.len();
    let c0 = splatseg_scene::gaussians::SH_C0;
    Gaussians {
        sh_dc: colours.chunks_exact(3).map(|c| [0, 1, 2].map(|k| (c[k] / 255.0 - 0.5) / c0)).collect(),
        log_scales: vec![[scale.ln(); 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        raw_opacities: vec![2.2; n], // opacity 0.9
        means,
        ..Default::default()
    }
}

/// Per pixel: number of points projecting into it, the front-most one's depth, and the mean
/// colour (0–1) of the points within 5% of that depth (the visible surface).
struct PointHits {
    count: Vec<u32>,
    front_z: Vec<f32>,
    front_rgb: Vec<[f32; 3]>,
}

fn project_points(means: &[[f32; 3]], colours: &[f32], camera: &RenderCamera) -> PointHits {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let pixels = pixel_of_points(means, camera);
    let mut hits = PointHits {
        count: vec![0; w * h],
        front_z: vec![f32::INFINITY; w * h],
        front_rgb: vec![[0.0; 3]; w * h],
    };
    for &(px, z, _) in &pixels {
        hits.count[px] += 1;
        hits.front_z[px] = hits.front_z[px].min(z);
    }
    let mut n = vec![0.0f32; w * h];
    for &(px, z, i) in &pixels {
        if z <= hits.front_z[px] * 1.05 {
            n[px] += 1.0;
            for c in 0..3 {
                hits.front_rgb[px][c] += colours[i * 3 + c] / 255.0;
            }
        }
    }
    for (rgb, n) in hits.front_rgb.iter_mut().zip(&n) {
        if *n > 0.0 {
            *rgb = rgb.map(|v| v / n);
        }
    }
    hits
}

/// `(pixel index, camera z, point index)` of every point projecting into the image.
fn pixel_of_points(means: &[[f32; 3]], camera: &RenderCamera) -> Vec<(usize, f32, usize)> {
    let (r, t) = camera.cam_from_world_f32();
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut out = Vec::new();
    for (i, p) in means.iter().enumerate() {
        let c = [0, 1, 2].map(|k| r[k][0] * p[0] + r[k][1] * p[1] + r[k][2] * p[2] + t[k]);
        if c[2] <= 0.05 {
            continue;
        }
        let u = camera.fx * c[0] / c[2] + camera.cx;
        let v = camera.fy * c[1] / c[2] + camera.cy;
        if u < 0.0 || v < 0.0 || u >= w as f32 || v >= h as f32 {
            continue;
        }
        out.push((v as usize * w + u as usize, c[2], i));
    }
    out
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

#[test]
fn garden_points_render_sensibly() {
    if !Path::new(DATA).exists() {
        eprintln!("skipping garden_points_render_sensibly: {DATA} is absent");
        return;
    }
    let npz = read_npz(Path::new(DATA)).expect("read test_garden.npz");
    let means: Vec<[f32; 3]> =
        array(&npz, "means3d").data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let colours = &array(&npz, "colors").data;
    let (viewmats, ks) = (array(&npz, "viewmats"), array(&npz, "Ks"));
    let width = array(&npz, "width").scalar().expect("width") as u32;
    let height = array(&npz, "height").scalar().expect("height") as u32;
    // Half the median point spacing: blends little across neighbouring points.
    let scale = 0.5 * median_nn_distance(&means);
    let g = gaussians_from_points(means.clone(), colours, scale);
    for view in 0..viewmats.shape[0] {
        let vm = &viewmats.data[view * 16..(view + 1) * 16];
        let rows: Vec<[f64; 4]> =
            vm.chunks_exact(4).map(|r| [r[0], r[1], r[2], r[3]].map(f64::from)).collect();
        let k = &ks.data[view * 9..(view + 1) * 9];
        let full = RenderCamera {
            width,
            height,
            fx: k[0],
            fy: k[4],
            cx: k[2],
            cy: k[5],
            world_from_cam: Pose::from_rows(&rows).inverse(),
            near: 0.01,
            far: 1e10,
        };
        let camera = full.downscaled(2.0);
        let out = render(&g, &camera, &RenderRequest::all()).expect("render");
        let (rgb, alpha, depth) = (out.rgb.unwrap(), out.alpha.unwrap().data, out.depth.unwrap().data);
        let hits = project_points(&means, colours, &camera);
        let occupied: Vec<usize> = (0..hits.count.len()).filter(|&p| hits.count[p] > 0).collect();
        let covered = occupied.iter().filter(|&&p| alpha[p] > 0.5).count() as f32 / occupied.len() as f32;
        let dense: Vec<usize> = (0..hits.count.len()).filter(|&p| hits.count[p] >= 4).collect();
        let colour_err = |p: usize, q: usize| -> f32 {
            (0..3).map(|c| (rgb[p * 3 + c] - hits.front_rgb[q][c]).abs()).sum::<f32>() / 3.0
        };
        let err = median(dense.iter().map(|&p| colour_err(p, p)).collect());
        // Baseline: the same comparison against the point of a pixel far away in the list.
        let baseline = median(
            dense
                .iter()
                .enumerate()
                .map(|(i, &p)| colour_err(p, dense[(i + dense.len() / 2) % dense.len()]))
                .collect(),
        );
        let depth_err =
            median(dense.iter().map(|&p| (depth[p] - hits.front_z[p]).abs() / hits.front_z[p]).collect());
        let bias: Vec<f32> = (0..3)
            .map(|c| {
                dense.iter().map(|&p| rgb[p * 3 + c] - hits.front_rgb[p][c]).sum::<f32>() / dense.len() as f32
            })
            .collect();
        println!(
            "view {view}: {}x{}, {} visible Gaussians, {} occupied px ({:.0}% covered), {} dense px, \
             colour error {err:.3} (baseline {baseline:.3}), bias {bias:.3?}, depth error {:.1}%",
            camera.width,
            camera.height,
            out.stats.visible,
            occupied.len(),
            100.0 * covered,
            dense.len(),
            100.0 * depth_err
        );
        assert!(
            covered > 0.95,
            "view {view}: only {:.1}% of occupied pixels have alpha > 0.5",
            100.0 * covered
        );
        assert!(dense.len() > 1000, "view {view}: only {} dense pixels", dense.len());
        assert!(bias.iter().all(|b| b.abs() < 0.03), "view {view}: colour bias {bias:?}");
        assert!(err < 0.09, "view {view}: median colour error {err} where points are dense");
        assert!(
            err < 0.5 * baseline,
            "view {view}: colour error {err} not far below the baseline {baseline}"
        );
        assert!(depth_err < 0.05, "view {view}: median relative depth error {depth_err}");
    }
}

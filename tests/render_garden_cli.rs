//! `splatseg render` on real data: gsplat's `test_garden.npz` points, turned into a COLMAP capture
//! (its three cameras) and a 3DGS PLY of small isotropic Gaussians, rendered by the CLI to PNGs that
//! must decode at the right size and show the scene. Skips with a message when `../shared/data` is
//! absent.

use splatseg_scene::image_io::{read_luma8, read_rgb8, write_png_rgb8, RgbImage};
use splatseg_scene::load::{SceneFormat, View};
use splatseg_scene::npy::{read_npz, NpyArray};
use splatseg_scene::{Camera, Gaussians, Pose, Scene};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data/gsplat_garden/test_garden.npz");

fn array<'a>(npz: &'a BTreeMap<String, NpyArray>, key: &str) -> &'a NpyArray {
    npz.get(key).unwrap_or_else(|| panic!("test_garden.npz has no `{key}`"))
}

/// The npz's cameras as a COLMAP-style scene (`viewmats` are cam_from_world, OpenCV axes).
fn garden_scene(npz: &BTreeMap<String, NpyArray>, root: &Path) -> Scene {
    let (viewmats, ks) = (array(npz, "viewmats"), array(npz, "Ks"));
    let width = array(npz, "width").scalar().expect("width") as u32;
    let height = array(npz, "height").scalar().expect("height") as u32;
    let views = viewmats.shape[0];
    let cameras = (0..views)
        .map(|v| {
            let k = &ks.data[v * 9..(v + 1) * 9];
            let [fx, cx, fy, cy] = [k[0], k[2], k[4], k[5]].map(f64::from);
            Camera::pinhole(v as u32 + 1, width, height, fx, fy, cx, cy)
        })
        .collect();
    let views = (0..views)
        .map(|v| {
            let rows: Vec<[f64; 4]> = viewmats.data[v * 16..(v + 1) * 16]
                .chunks_exact(4)
                .map(|r| [r[0], r[1], r[2], r[3]].map(f64::from))
                .collect();
            let name = format!("garden_{v}.png");
            View {
                stem: format!("garden_{v}"),
                image_path: root.join("images").join(&name),
                name,
                camera_index: v,
                world_from_cam: Pose::from_rows(&rows).inverse(),
                image_id: v as u32 + 1,
                keypoints: Vec::new(),
            }
        })
        .collect();
    Scene {
        root: root.to_path_buf(),
        format: SceneFormat::ColmapText,
        cameras,
        views,
        points: None,
        warnings: Vec::new(),
    }
}

/// Each point as a small isotropic, fairly opaque Gaussian of its colour.
fn gaussians_from_points(npz: &BTreeMap<String, NpyArray>, scale: f32) -> Gaussians {
    let means: Vec<[f32; 3]> =
        array(npz, "means3d").data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let n = means.len();
    let c0 = splatseg_scene::gaussians::SH_C0;
    Gaussians {
        sh_dc: array(npz, "colors")
            .data
            .chunks_exact(3)
            .map(|c| [0, 1, 2].map(|k| (c[k] / 255.0 - 0.5) / c0))
            .collect(),
        log_scales: vec![[scale.ln(); 3]; n],
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        raw_opacities: vec![2.2; n],
        means,
        ..Default::default()
    }
}

#[test]
fn splatseg_render_writes_viewable_pngs_for_the_garden_points() {
    if !Path::new(DATA).exists() {
        println!("skipped: {DATA} is absent");
        return;
    }
    let npz = read_npz(Path::new(DATA)).expect("read test_garden.npz");
    let tmp = tempfile::tempdir().expect("temp dir");
    let root = tmp.path().join("garden");
    let scene = garden_scene(&npz, &root);
    splatseg_scene::colmap::write_colmap_text(&root.join("sparse/0"), &scene).expect("write COLMAP");
    for view in &scene.views {
        let camera = scene.camera(view);
        let blank = RgbImage::filled(camera.width as usize, camera.height as usize, [0; 3]);
        write_png_rgb8(&view.image_path, &blank).expect("write image");
    }
    // Scale: a fraction of the scene's extent (the garden spans ≈ 10 units; points ≈ 1 cm apart
    // where dense), large enough to close gaps at a quarter of the resolution.
    let g = gaussians_from_points(&npz, 0.02);
    let ply = tmp.path().join("garden.ply");
    splatseg_scene::ply::write_ply(&ply, &g).expect("write PLY");

    let out = tmp.path().join("rendered");
    let run = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["render", root.to_str().expect("utf-8"), "--gaussians", ply.to_str().expect("utf-8")])
        .args(["--out", out.to_str().expect("utf-8"), "--resolution", "4"])
        .output()
        .expect("run splatseg render");
    assert!(run.status.success(), "splatseg render failed: {}", String::from_utf8_lossy(&run.stderr));

    let (w, h) = (162, 105); // 648×420 / 4
    for view in &scene.views {
        let file = |suffix: &str| out.join(format!("{}_{suffix}", view.stem));
        let rgb = read_rgb8(&file("rgb.png")).expect("rgb PNG decodes");
        let alpha = read_luma8(&file("alpha.png")).expect("alpha PNG decodes");
        let ids = read_rgb8(&file("ids.png")).expect("ids PNG decodes");
        let depth_png = read_luma8(&file("depth.png")).expect("depth PNG decodes");
        let depth = splatseg_scene::npy::read_npy(&file("depth.npy")).expect("depth npy");
        assert_eq!(rgb.size(), (w, h), "{}", view.stem);
        assert_eq!(alpha.size(), (w, h));
        assert_eq!(ids.size(), (w, h));
        assert_eq!(depth_png.size(), (w, h));
        assert_eq!(depth.shape, vec![h, w]);

        let covered = alpha.data.iter().filter(|&&a| a > 128).count() as f64 / (w * h) as f64;
        assert!(covered > 0.5, "{}: only {:.0}% of pixels covered", view.stem, 100.0 * covered);
        // Where it is covered the image shows colour (the garden is mostly green/brown, not black),
        // and the depth is positive and in front of the camera.
        let lit = rgb.data.chunks_exact(3).filter(|p| p.iter().map(|&c| c as u32).sum::<u32>() > 60).count();
        assert!(lit as f64 > 0.5 * covered * (w * h) as f64, "{}: image too dark", view.stem);
        let positive = depth.data.iter().filter(|&&z| z > 0.0).count();
        assert!(positive as f64 > 0.5 * covered * (w * h) as f64, "{}: depth mostly empty", view.stem);
    }
}

//! Parity with gsplat's PyTorch reference (fixtures from `tools/fixtures/make_raster_fixtures.py`,
//! float64 reference vs our float32): projection, images, and gradients of a weighted-sum loss.
//!
//! Tolerances (`atol + rtol·|ref|`): projection 1e-4 + 1e-4·|ref| (radii exact); images 2e-4 +
//! 1e-3·|ref| on the pixels the script marks as not hinging on a threshold; expected depth where
//! alpha ≥ 0.01; gradients 1e-3·max|ref| + 1e-2·|ref| per parameter group. Differences from the
//! reference we follow on purpose: none in the math; the reference's per-pixel enumeration replaces
//! gsplat's CUDA-only `rasterize_to_indices_in_range` with the same rules.

use crate::common::{assert_close, Fixture};
use splatseg_render::project::project;
use splatseg_render::{
    render_bwd, render_with_state, FeatureInput, OutputGrads, RasterSettings, RenderCamera, RenderRequest,
};
use splatseg_scene::{Gaussians, Pose};

struct Scene {
    fx: Fixture,
    gaussians: Gaussians,
    camera: RenderCamera,
    features: Vec<f32>,
    dim: usize,
    background: [f32; 3],
}

fn scene(name: &str) -> Scene {
    let fx = Fixture::load(name);
    let n = fx.shape("in_means")[0];
    let k = fx.shape("in_sh_rest")[2];
    let degree = fx.i32("in_sh_degree")[0] as u8;
    assert_eq!((degree as usize + 1).pow(2) - 1, k);
    let gaussians = Gaussians {
        means: fx.rows("in_means"),
        sh_dc: fx.rows("in_sh_dc"),
        sh_degree: degree,
        sh_rest: fx.f32("in_sh_rest"),
        raw_opacities: fx.f32("in_raw_opacities"),
        log_scales: fx.rows("in_log_scales"),
        rotations: fx.rows("in_quats"),
        ..Default::default()
    };
    assert_eq!(gaussians.len(), n);
    let view = fx.f64("in_viewmat");
    let rows: Vec<[f64; 4]> = view.chunks_exact(4).map(|r| [r[0], r[1], r[2], r[3]]).collect();
    let cam_from_world = Pose::from_rows(&rows);
    let kk = fx.f64("in_K");
    let size = fx.i32("in_size");
    let camera = RenderCamera {
        width: size[0] as u32,
        height: size[1] as u32,
        fx: kk[0] as f32,
        fy: kk[4] as f32,
        cx: kk[2] as f32,
        cy: kk[5] as f32,
        world_from_cam: cam_from_world.inverse(),
        near: 0.01,
        far: 1e10,
    };
    let bg = fx.f32("in_background");
    Scene {
        features: fx.f32("in_features"),
        dim: fx.shape("in_features")[1],
        background: [bg[0], bg[1], bg[2]],
        fx,
        gaussians,
        camera,
    }
}

fn request(s: &Scene) -> RenderRequest<'_> {
    RenderRequest {
        rgb: true,
        depth: true,
        alpha: true,
        max_weight_ids: true,
        features: Some(FeatureInput { values: &s.features, dim: s.dim }),
        background: s.background,
        sh_degree: None,
        settings: RasterSettings::gsplat_1_5(),
    }
}

fn check_projection(s: &Scene) {
    let splats = project(&s.gaussians, &s.camera, &RasterSettings::gsplat_1_5());
    let radii = s.fx.i32("proj_radii");
    let got_radii: Vec<i32> = splats.iter().flat_map(|p| p.radii).collect();
    assert_eq!(got_radii, radii, "{}: radii differ", s.fx.name);
    let visible: Vec<usize> = (0..splats.len()).filter(|&i| radii[2 * i] > 0).collect();
    let pick = |v: Vec<f32>, k: usize| -> Vec<f32> {
        visible.iter().flat_map(|&i| v[k * i..k * i + k].to_vec()).collect()
    };
    let got_m: Vec<f32> = splats.iter().flat_map(|p| p.mean2d).collect();
    let got_c: Vec<f32> = splats.iter().flat_map(|p| p.conic).collect();
    let got_d: Vec<f32> = splats.iter().map(|p| p.depth).collect();
    let name = &s.fx.name;
    assert_close(&format!("{name} means2d"), &pick(got_m, 2), &pick(s.fx.f32("proj_means2d"), 2), 1e-4, 1e-4);
    assert_close(&format!("{name} conics"), &pick(got_c, 3), &pick(s.fx.f32("proj_conics"), 3), 1e-4, 1e-4);
    assert_close(&format!("{name} depths"), &pick(got_d, 1), &pick(s.fx.f32("proj_depths"), 1), 1e-5, 1e-5);
}

/// Values of `v` (`[P, k]`) at pixels where `keep` is true.
fn masked(v: &[f32], k: usize, keep: &[bool]) -> Vec<f32> {
    v.chunks_exact(k).zip(keep).filter(|(_, &m)| m).flat_map(|(c, _)| c.to_vec()).collect()
}

fn check_images_and_grads(s: &Scene) {
    let name = &s.fx.name;
    let req = request(s);
    let (out, state) = render_with_state(&s.gaussians, &s.camera, &req).expect("render");
    let stable: Vec<bool> = s.fx.i32("out_stable").iter().map(|&v| v != 0).collect();
    let (atol, rtol) = (2e-5, 1e-4);
    let rgb = out.rgb.as_ref().unwrap();
    assert_close(
        &format!("{name} rgb"),
        &masked(rgb, 3, &stable),
        &masked(&s.fx.f32("out_rgb"), 3, &stable),
        atol,
        rtol,
    );
    let alpha = &out.alpha.as_ref().unwrap().data;
    assert_close(
        &format!("{name} alpha"),
        &masked(alpha, 1, &stable),
        &masked(&s.fx.f32("out_alpha"), 1, &stable),
        atol,
        rtol,
    );
    let feats = out.features.as_ref().unwrap();
    let want_f = s.fx.f32("out_features");
    assert_close(
        &format!("{name} features"),
        &masked(feats, s.dim, &stable),
        &masked(&want_f, s.dim, &stable),
        atol,
        rtol,
    );
    let ref_alpha = s.fx.f32("out_alpha");
    let solid: Vec<bool> = stable.iter().zip(&ref_alpha).map(|(&st, &a)| st && a >= 0.01).collect();
    let depth = &out.depth.as_ref().unwrap().data;
    assert_close(
        &format!("{name} depth"),
        &masked(depth, 1, &solid),
        &masked(&s.fx.f32("out_depth"), 1, &solid),
        atol,
        rtol,
    );
    let ids = &out.max_weight_ids.as_ref().unwrap().data;
    let tie = s.fx.i32("out_id_tie");
    let want_ids = s.fx.i32("out_ids");
    for p in 0..ids.len() {
        if stable[p] && tie[p] == 0 {
            assert_eq!(ids[p], want_ids[p], "{name}: max-weight id at pixel {p}");
        }
    }

    let (w_rgb, w_depth, w_alpha, w_feat) =
        (s.fx.f32("w_rgb"), s.fx.f32("w_depth"), s.fx.f32("w_alpha"), s.fx.f32("w_features"));
    let grads = OutputGrads {
        rgb: Some(&w_rgb),
        depth: Some(&w_depth),
        alpha: Some(&w_alpha),
        features: Some(&w_feat),
    };
    let g = render_bwd(&s.gaussians, &s.camera, &req, &state, &grads).expect("backward");
    let check = |what: &str, got: Vec<f32>, key: &str| {
        let want = s.fx.f32(key);
        let scale = want.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert_close(&format!("{name} {what}"), &got, &want, 1e-4 * scale, 1e-3);
    };
    check("grad means", g.means.iter().flatten().copied().collect(), "grad_means");
    check("grad log_scales", g.log_scales.iter().flatten().copied().collect(), "grad_log_scales");
    check("grad rotations", g.rotations.iter().flatten().copied().collect(), "grad_quats");
    check("grad raw_opacities", g.raw_opacities.clone(), "grad_raw_opacities");
    check("grad sh_dc", g.sh_dc.iter().flatten().copied().collect(), "grad_sh_dc");
    check("grad sh_rest", g.sh_rest.clone(), "grad_sh_rest");
    check("grad features", g.features.clone().unwrap(), "grad_features");
    check("grad means2d", g.means2d.iter().flatten().copied().collect(), "grad_means2d");
}

#[test]
fn random_scene_matches_gsplat() {
    let s = scene("raster_random");
    check_projection(&s);
    check_images_and_grads(&s);
}

#[test]
fn degenerate_scene_matches_gsplat() {
    let s = scene("raster_degenerate");
    check_projection(&s);
    check_images_and_grads(&s);
}

#[test]
fn dense_scene_matches_gsplat() {
    let s = scene("raster_dense");
    check_projection(&s);
    check_images_and_grads(&s);
}

/// 16 feature channels besides RGB and depth (gsplat's multi-channel colours; the joint stage's
/// identity maps), same tolerances.
#[test]
fn sixteen_channel_scene_matches_gsplat() {
    let s = scene("raster_wide");
    assert_eq!(s.dim, 16);
    check_projection(&s);
    check_images_and_grads(&s);
    check_without_depth(&s);
}

/// RGB + features without depth (19 channels here: the training pass, which has its own unrolled
/// blend): images, and the gradients a depth term does not touch (colour, features).
fn check_without_depth(s: &Scene) {
    let name = &s.fx.name;
    let req = RenderRequest { depth: false, ..request(s) };
    let (out, state) = render_with_state(&s.gaussians, &s.camera, &req).expect("render");
    let stable: Vec<bool> = s.fx.i32("out_stable").iter().map(|&v| v != 0).collect();
    let (atol, rtol) = (2e-5, 1e-4);
    let rgb = out.rgb.as_ref().unwrap();
    let want_rgb = s.fx.f32("out_rgb");
    assert_close(
        &format!("{name} rgb (no depth)"),
        &masked(rgb, 3, &stable),
        &masked(&want_rgb, 3, &stable),
        atol,
        rtol,
    );
    let feats = out.features.as_ref().unwrap();
    let want_f = s.fx.f32("out_features");
    let (got_f, want_f) = (masked(feats, s.dim, &stable), masked(&want_f, s.dim, &stable));
    assert_close(&format!("{name} features (no depth)"), &got_f, &want_f, atol, rtol);
    let (w_rgb, w_feat) = (s.fx.f32("w_rgb"), s.fx.f32("w_features"));
    let grads = OutputGrads { rgb: Some(&w_rgb), features: Some(&w_feat), ..Default::default() };
    let g = render_bwd(&s.gaussians, &s.camera, &req, &state, &grads).expect("backward");
    for (what, got, key) in [
        ("grad sh_dc (no depth)", g.sh_dc.iter().flatten().copied().collect::<Vec<f32>>(), "grad_sh_dc"),
        ("grad features (no depth)", g.features.clone().unwrap(), "grad_features"),
    ] {
        let want = s.fx.f32(key);
        let scale = want.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert_close(&format!("{name} {what}"), &got, &want, 1e-4 * scale, 1e-3);
    }
}

//! CPU ray casting of one view: one ray through each pixel centre (rayon over rows) gives the
//! colour image, the ground-truth instance and part maps, metric z depth, and how many pixels
//! of each object are hidden behind another (for the occlusion annotation).
//!
//! Shading is Lambertian with ambient light and one directional light, so a surface has the
//! same colour in every view; the Gaussians carry exactly these colours.

use crate::geometry::SurfacePoint;
use crate::layout::SceneObject;
use crate::noise::{hash, normal, stream};
use crate::texture::Rgb;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use splatseg_scene::{Camera, Plane, Pose};

/// Ambient share of the lighting.
const AMBIENT: f64 = 0.5;
/// Standard deviation of the simulated sensor noise, in 8-bit steps.
const SENSOR_NOISE: f64 = 1.5;

/// Unit direction towards the light (world).
pub fn light_dir() -> DVec3 {
    DVec3::new(0.6, 0.7, 1.0).normalize()
}

/// Shaded colour in [0, 1] of albedo `albedo` on a surface with normal `normal`.
pub fn shade(albedo: Rgb, normal: DVec3) -> Rgb {
    let k = AMBIENT + (1.0 - AMBIENT) * normal.dot(light_dir()).max(0.0);
    albedo.map(|c| (c * k).clamp(0.0, 1.0))
}

/// Everything rendered for one view.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedView {
    /// `[H, W]` 8-bit RGB image.
    pub rgb: Plane<[u8; 3]>,
    /// `[H, W]` ground-truth instance ids (0 = no surface).
    pub instance: Plane<u32>,
    /// `[H, W]` texture part of the visible surface (see [`crate::texture`]); 0 where no surface.
    pub part: Plane<u8>,
    /// `[H, W]` metric z depth; 0 where no surface.
    pub depth_z: Plane<f32>,
    /// `[objects]`, indexed by id − 1: pixels where the object lies on the ray but another
    /// surface is in front of it.
    pub hidden_px: Vec<u32>,
}

/// The nearest surface on a ray, if any.
pub fn cast(objects: &[SceneObject], origin: DVec3, dir: DVec3) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (k, o) in objects.iter().enumerate() {
        if let Some(t) = o.shape.intersect(origin, dir) {
            if best.is_none_or(|(_, bt)| t < bt) {
                best = Some((k, t));
            }
        }
    }
    best
}

struct PixelSample {
    rgb: [u8; 3],
    id: u32,
    part: u8,
    depth: f32,
}

/// Renders `objects` seen by `camera` at `world_from_cam`. `seed` and `view` key the sensor noise.
pub fn render_view(
    objects: &[SceneObject],
    camera: &Camera,
    world_from_cam: &Pose,
    seed: u64,
    view: usize,
) -> RenderedView {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let rows: Vec<(Vec<PixelSample>, Vec<u32>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut hidden = vec![0u32; objects.len()];
            let row = (0..w)
                .map(|x| {
                    let d_cam = camera.unproject(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
                    let dir = world_from_cam.rotation * d_cam;
                    let origin = world_from_cam.translation;
                    let noise_key = hash(seed, &[stream::IMAGE_NOISE, view as u64, (y * w + x) as u64]);
                    pixel(objects, origin, dir, noise_key, &mut hidden)
                })
                .collect();
            (row, hidden)
        })
        .collect();
    let mut out = RenderedView {
        rgb: Plane::filled(w, h, [0; 3]),
        instance: Plane::filled(w, h, 0),
        part: Plane::filled(w, h, 0),
        depth_z: Plane::filled(w, h, 0.0),
        hidden_px: vec![0; objects.len()],
    };
    for (y, (row, hidden)) in rows.into_iter().enumerate() {
        for (x, s) in row.into_iter().enumerate() {
            let i = y * w + x;
            out.rgb.data[i] = s.rgb;
            out.instance.data[i] = s.id;
            out.part.data[i] = s.part;
            out.depth_z.data[i] = s.depth;
        }
        for (total, v) in out.hidden_px.iter_mut().zip(hidden) {
            *total += v;
        }
    }
    out
}

/// `dir` has camera-space z = 1, so the hit distance `t` is the metric z depth.
fn pixel(
    objects: &[SceneObject],
    origin: DVec3,
    dir: DVec3,
    noise_key: u64,
    hidden: &mut [u32],
) -> PixelSample {
    let mut nearest: Option<(usize, f64)> = None;
    for (j, o) in objects.iter().enumerate() {
        if let Some(t) = o.shape.intersect(origin, dir) {
            hidden[j] += 1;
            if nearest.is_none_or(|(_, bt)| t < bt) {
                nearest = Some((j, t));
            }
        }
    }
    let Some((k, t)) = nearest else {
        return PixelSample { rgb: [0; 3], id: 0, part: 0, depth: 0.0 };
    };
    // Every object on the ray was counted as hidden; the nearest one is not.
    hidden[k] -= 1;
    let object = &objects[k];
    let sp: SurfacePoint = object.shape.surface_point(origin + dir * t);
    let (albedo, part) = object.texture.evaluate(&sp);
    let colour = shade(albedo, sp.normal);
    let rgb = [0, 1, 2].map(|c| {
        let n = SENSOR_NOISE * normal(noise_key ^ c as u64);
        (colour[c] * 255.0 + n).round().clamp(0.0, 255.0) as u8
    });
    PixelSample { rgb, id: object.id, part, depth: t as f32 }
}

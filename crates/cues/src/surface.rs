//! Surface geometry from metric depth: camera-space points per pixel and surface normals taken
//! from one region's own pixels, for the merge's crease test (two regions meeting at a concave
//! crease — a box standing on the floor, two walls at a corner — are two surfaces, where the
//! faces of one convex object meet at convex creases).
//!
//! Frames: camera space as in CONVENTIONS.md (x right, y down, z forward); the centre of pixel
//! `(x, y)` is at `(x + 0.5, y + 0.5)`. Lens distortion is ignored (normals only).

use splatseg_scene::{Camera, Plane};

/// Pinhole intrinsics in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, px.
    pub fx: f32,
    /// Focal length along y, px.
    pub fy: f32,
    /// Principal point x, px (pixel-corner origin).
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
}

impl Intrinsics {
    /// `camera`'s intrinsics for its image resampled to `width × height` pixels.
    pub fn of_camera(camera: &Camera, width: usize, height: usize) -> Self {
        let sx = width as f64 / camera.width.max(1) as f64;
        let sy = height as f64 / camera.height.max(1) as f64;
        Intrinsics {
            fx: (camera.fx * sx) as f32,
            fy: (camera.fy * sy) as f32,
            cx: (camera.cx * sx) as f32,
            cy: (camera.cy * sy) as f32,
        }
    }
}

/// `[H, W]` camera-space points of `z` (`[H, W]` metric depth along the optical axis); NaN
/// where `z` is not finite and positive.
pub fn camera_points(z: &Plane<f32>, k: &Intrinsics) -> Plane<[f32; 3]> {
    let (w, h) = z.size();
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let ry = (y as f32 + 0.5 - k.cy) / k.fy;
        for x in 0..w {
            let d = z.data[y * w + x];
            data.push(if d.is_finite() && d > 0.0 {
                [(x as f32 + 0.5 - k.cx) / k.fx * d, ry * d, d]
            } else {
                [f32::NAN; 3]
            });
        }
    }
    Plane { width: w, height: h, data }
}

/// The window a normal is estimated over, scaled with the image: samples every `step` pixels,
/// `radius` pixels around the centre (7 × 7 samples).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NormalWindow {
    /// Distance between samples, px.
    pub step: usize,
    /// Half-width of the window, px.
    pub radius: usize,
}

impl NormalWindow {
    /// One sample per pixel at 240 rows (or columns, whichever is fewer), growing with the size.
    pub fn for_size(width: usize, height: usize) -> Self {
        let step = ((width.min(height) as f32 / 240.0).round() as usize).max(1);
        NormalWindow { step, radius: 3 * step }
    }

    /// The sample positions `(x, y)` of the window around pixel `p` (row-major index) of a
    /// `w × h` image that lie inside it, row by row.
    fn samples(self, p: usize, (w, h): (usize, usize)) -> impl Iterator<Item = (isize, isize)> {
        let (x0, y0) = ((p % w) as isize, (p / w) as isize);
        let r = self.radius as isize;
        let rows = (y0 - r..=y0 + r).step_by(self.step).filter(move |&y| y >= 0 && y < h as isize);
        rows.flat_map(move |y| {
            (x0 - r..=x0 + r)
                .step_by(self.step)
                .filter(move |&x| x >= 0 && x < w as isize)
                .map(move |x| (x, y))
        })
    }
}

/// Relative depth change between two samples above which they are taken to lie on different
/// surfaces (an occlusion edge inside the region), not on one slanted surface.
const MAX_SAMPLE_DEPTH_JUMP: f32 = 0.1;

/// The unit normal of the surface at pixel `p` (row-major index), facing the camera, from the
/// points of `labels[p]`'s own region in `window` around `p`: the mean horizontal and vertical
/// differences between neighbouring samples of that region, crossed. `None` when the pixel is
/// unlabelled or too few samples of its region are around it. `points`, `labels`: `[H, W]`.
pub fn region_normal_at(
    points: &Plane<[f32; 3]>,
    labels: &Plane<u32>,
    p: usize,
    window: NormalWindow,
) -> Option<[f32; 3]> {
    let (w, h) = labels.size();
    let label = labels.data[p];
    if label == 0 || !points.data[p][2].is_finite() {
        return None;
    }
    let s = window.step as isize;
    let usable = |x: isize, y: isize| -> Option<[f32; 3]> {
        if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
            return None;
        }
        let q = y as usize * w + x as usize;
        let pt = points.data[q];
        (labels.data[q] == label && pt[2].is_finite()).then_some(pt)
    };
    let mut sums = [[0f32; 3]; 2];
    let mut counts = [0usize; 2];
    for (x, y) in window.samples(p, (w, h)) {
        let Some(a) = usable(x, y) else { continue };
        for (k, (dx, dy)) in [(s, 0), (0, s)].into_iter().enumerate() {
            if let Some(b) = usable(x + dx, y + dy) {
                if (b[2] - a[2]).abs() <= MAX_SAMPLE_DEPTH_JUMP * a[2].min(b[2]) {
                    for c in 0..3 {
                        sums[k][c] += b[c] - a[c];
                    }
                    counts[k] += 1;
                }
            }
        }
    }
    if counts[0] < 3 || counts[1] < 3 {
        return None;
    }
    let [u, v] = sums;
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    let at = points.data[p];
    let facing = if n[0] * at[0] + n[1] * at[1] + n[2] * at[2] > 0.0 { -1.0 } else { 1.0 };
    Some(n.map(|c| facing * c / len))
}

/// Fewest samples of a region's own rendered normals in the window for
/// [`region_mean_normal`]: as many as the point differences [`region_normal_at`] needs (3 in
/// each direction take 4 samples at least).
const MIN_NORMAL_SAMPLES: usize = 4;

/// The unit normal of the surface at pixel `p` (row-major index) from rendered normals
/// (`normals`: `[H, W]` camera-space unit normals facing the camera, NaN = none): the mean of
/// the normals of `labels[p]`'s own region sampled in `window` around `p`. `None` when the
/// pixel is unlabelled, too few samples of its region have a normal, or they disagree (their
/// mean shorter than ½).
pub fn region_mean_normal(
    normals: &Plane<[f32; 3]>,
    labels: &Plane<u32>,
    p: usize,
    window: NormalWindow,
) -> Option<[f32; 3]> {
    let (w, h) = labels.size();
    let label = labels.data[p];
    if label == 0 {
        return None;
    }
    let mut sum = [0f32; 3];
    let mut count = 0usize;
    for (x, y) in window.samples(p, (w, h)) {
        let q = y as usize * w + x as usize;
        let n = normals.data[q];
        if labels.data[q] == label && n[0].is_finite() {
            for c in 0..3 {
                sum[c] += n[c];
            }
            count += 1;
        }
    }
    let len = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
    (count >= MIN_NORMAL_SAMPLES && len >= 0.5 * count as f32).then(|| sum.map(|c| c / len))
}

/// True when two neighbouring pixels in `window` around pixel `p` (any regions) differ in
/// depth by more than `max_jump` of the nearer one: `p` is near an occlusion edge, not on a
/// contact where two surfaces meet (a slanted surface changes depth gradually, a step at
/// once). `points`: `[H, W]`; a pixel without depth counts as an edge.
pub fn near_depth_edge(points: &Plane<[f32; 3]>, p: usize, window: NormalWindow, max_jump: f32) -> bool {
    let (w, h) = points.size();
    let (x0, y0) = (p % w, p / w);
    let r = window.radius;
    let (xs, ys) = (x0.saturating_sub(r)..=(x0 + r).min(w - 1), y0.saturating_sub(r)..=(y0 + r).min(h - 1));
    let z = |x: usize, y: usize| points.data[y * w + x][2];
    let jump = |a: f32, b: f32| !(a.is_finite() && b.is_finite()) || (a - b).abs() > max_jump * a.min(b);
    for y in ys.clone() {
        for x in xs.clone() {
            let here = z(x, y);
            if (x < *xs.end() && jump(here, z(x + 1, y))) || (y < *ys.end() && jump(here, z(x, y + 1))) {
                return true;
            }
        }
    }
    false
}

/// [`near_depth_edge`] for many pixels of one map: which neighbouring pairs of `points` jump in
/// depth, counted in summed-area tables, so the test over a window is eight look-ups instead of
/// a scan of the window (same pairs, same rule: the same answers).
pub struct DepthJumps {
    width: usize,
    height: usize,
    /// `[(H + 1) · (W + 1)]`: entry `(y, x)` counts the jumping pairs `(x', y')–(x' + 1, y')` with
    /// `x' < x`, `y' < y`.
    right: Vec<u32>,
    /// `[(H + 1) · (W + 1)]`: the same for the pairs `(x', y')–(x', y' + 1)`.
    down: Vec<u32>,
}

impl DepthJumps {
    /// The tables of `points` (`[H, W]`) for the relative jump `max_jump`.
    pub fn new(points: &Plane<[f32; 3]>, max_jump: f32) -> Self {
        let (w, h) = points.size();
        let z = |x: usize, y: usize| points.data[y * w + x][2];
        let jump = |a: f32, b: f32| !(a.is_finite() && b.is_finite()) || (a - b).abs() > max_jump * a.min(b);
        let stride = w + 1;
        let mut right = vec![0u32; (h + 1) * stride];
        let mut down = vec![0u32; (h + 1) * stride];
        for y in 0..h {
            let (mut row_right, mut row_down) = (0u32, 0u32);
            for x in 0..w {
                let here = z(x, y);
                row_right += (x + 1 < w && jump(here, z(x + 1, y))) as u32;
                row_down += (y + 1 < h && jump(here, z(x, y + 1))) as u32;
                let at = (y + 1) * stride + x + 1;
                right[at] = right[at - stride] + row_right;
                down[at] = down[at - stride] + row_down;
            }
        }
        DepthJumps { width: w, height: h, right, down }
    }

    /// Jumping pairs counted in `table` with their first pixel in `[x0, x1) × [y0, y1)`.
    fn count(&self, table: &[u32], (x0, x1, y0, y1): (usize, usize, usize, usize)) -> u32 {
        let s = self.width + 1;
        table[y1 * s + x1]
            .wrapping_sub(table[y0 * s + x1])
            .wrapping_sub(table[y1 * s + x0])
            .wrapping_add(table[y0 * s + x0])
    }

    /// [`near_depth_edge`] at pixel `p` (row-major) over `window`.
    pub fn near_edge(&self, p: usize, window: NormalWindow) -> bool {
        let (w, h) = (self.width, self.height);
        let (x, y) = (p % w, p / w);
        let r = window.radius;
        // The window's pixels are `xa..=xb` × `ya..=yb`; a pair counts when both its pixels are in it.
        let (xa, xb, ya, yb) =
            (x.saturating_sub(r), (x + r).min(w - 1), y.saturating_sub(r), (y + r).min(h - 1));
        self.count(&self.right, (xa, xb, ya, yb + 1)) > 0 || self.count(&self.down, (xa, xb + 1, ya, yb)) > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables answer as the window scan at every pixel: steps, slants, holes, image borders,
    /// windows larger than the image.
    #[test]
    fn depth_jump_tables_answer_as_the_window_scan() {
        let (w, h) = (23, 17);
        let mut seed = 12345u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            seed >> 8
        };
        let z = Plane {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| match next() % 40 {
                    0 => f32::NAN,
                    1 => 0.0,
                    2..=4 => 6.0,
                    _ => 2.0 + 0.01 * (i % w) as f32 + 0.003 * (i / w) as f32,
                })
                .collect(),
        };
        let points = camera_points(&z, &K);
        let mut edges = 0;
        for max_jump in [0.05, 0.1, 0.5] {
            let table = DepthJumps::new(&points, max_jump);
            for radius in [0, 1, 3, 12, 40] {
                let window = NormalWindow { step: 1, radius };
                for p in 0..w * h {
                    let want = near_depth_edge(&points, p, window, max_jump);
                    assert_eq!(
                        table.near_edge(p, window),
                        want,
                        "pixel {p}, radius {radius}, jump {max_jump}"
                    );
                    edges += want as usize;
                }
            }
        }
        assert!(edges > 100 && edges < 15 * w * h, "{edges} edge answers: both kinds are tested");
    }

    const K: Intrinsics = Intrinsics { fx: 100.0, fy: 100.0, cx: 32.0, cy: 32.0 };

    /// Depth of the plane `n · X = d` along each pixel's ray.
    fn plane_depth(n: [f32; 3], d: f32, x: usize, y: usize) -> f32 {
        let ray = [(x as f32 + 0.5 - K.cx) / K.fx, (y as f32 + 0.5 - K.cy) / K.fy, 1.0];
        d / (n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2])
    }

    fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f32 {
        let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        dot.clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// A floor (normal −y, up in camera space) below a wall facing the camera: each side's
    /// normal comes from its own region, even on the pixels next to the crease.
    #[test]
    fn normals_on_both_sides_of_a_crease_are_each_sides_own() {
        let (w, h) = (64, 64);
        let wall = ([0.0, 0.0, -1.0], -4.0);
        let floor = ([0.0, -1.0, 0.0], -1.0);
        let mut z = Plane::filled(w, h, 0.0f32);
        let mut labels = Plane::filled(w, h, 0u32);
        for y in 0..h {
            for x in 0..w {
                let (zw, zf) = (plane_depth(wall.0, wall.1, x, y), plane_depth(floor.0, floor.1, x, y));
                // The nearer surface in front of the camera is the one seen.
                let floor_seen = zf > 0.0 && zf < zw;
                z.data[y * w + x] = if floor_seen { zf } else { zw };
                labels.data[y * w + x] = if floor_seen { 2 } else { 1 };
            }
        }
        let points = camera_points(&z, &K);
        let window = NormalWindow::for_size(w, h);
        let first_floor_row = (0..h).find(|&y| labels.data[y * w + 10] == 2).expect("a floor");
        let on_wall =
            region_normal_at(&points, &labels, (first_floor_row - 1) * w + 10, window).expect("wall");
        let on_floor = region_normal_at(&points, &labels, first_floor_row * w + 10, window).expect("floor");
        assert!(angle_deg(on_wall, [0.0, 0.0, -1.0]) < 1.0, "{on_wall:?}");
        assert!(angle_deg(on_floor, [0.0, -1.0, 0.0]) < 1.0, "{on_floor:?}");
    }

    #[test]
    fn pixels_without_depth_or_region_have_no_normal() {
        let z = Plane::filled(8, 8, f32::INFINITY);
        let labels = Plane::filled(8, 8, 1u32);
        let window = NormalWindow { step: 1, radius: 3 };
        assert_eq!(region_normal_at(&camera_points(&z, &K), &labels, 27, window), None);
        let z = Plane::filled(8, 8, 2.0f32);
        let labels = Plane::filled(8, 8, 0u32);
        assert_eq!(region_normal_at(&camera_points(&z, &K), &labels, 27, window), None);
    }

    #[test]
    fn a_depth_step_is_an_edge_and_a_slanted_plane_is_not() {
        let window = NormalWindow { step: 1, radius: 3 };
        let step =
            Plane { width: 16, height: 1, data: (0..16).map(|x| if x < 8 { 2.0 } else { 3.0 }).collect() };
        let points = camera_points(&step, &K);
        assert!(near_depth_edge(&points, 8, window, 0.1));
        assert!(!near_depth_edge(&points, 2, window, 0.1));
        let slant = Plane { width: 16, height: 1, data: (0..16).map(|x| 2.0 + 0.08 * x as f32).collect() };
        assert!(!near_depth_edge(&camera_points(&slant, &K), 8, window, 0.1));
    }

    #[test]
    fn the_window_grows_with_the_image() {
        assert_eq!(NormalWindow::for_size(320, 240), NormalWindow { step: 1, radius: 3 });
        assert_eq!(NormalWindow::for_size(1280, 960), NormalWindow { step: 4, radius: 12 });
    }
}

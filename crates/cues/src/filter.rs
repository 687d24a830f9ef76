//! Small image filters on [`Plane<f32>`]: separable Gaussian blur, 3×3 Laplacian, Sobel gradient
//! magnitude, min–max normalisation and bilinear resampling.
//!
//! Borders are handled by mirror reflection without repeating the edge pixel
//! (OpenCV's `BORDER_REFLECT_101`: `… 2 1 | 0 1 2 … n−1 | n−2 …`), so filters of a constant image
//! are constant up to the border. Rows are processed in parallel with rayon; results do not depend
//! on the number of threads (each output pixel is computed by exactly one task).

use rayon::prelude::*;
use splatseg_scene::Plane;

/// Mirror index `i` (possibly out of range) into `0..n` (reflect-101).
#[inline]
fn reflect(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let n = n as isize;
    let period = 2 * (n - 1);
    let mut m = i.rem_euclid(period);
    if m >= n {
        m = period - m;
    }
    m as usize
}

/// Normalised 1D Gaussian kernel of standard deviation `sigma` px and radius `ceil(3σ)`.
pub fn gaussian_kernel(sigma: f32) -> Vec<f32> {
    if sigma <= 0.0 {
        return vec![1.0];
    }
    let radius = (3.0 * sigma).ceil() as isize;
    let mut kernel: Vec<f32> =
        (-radius..=radius).map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp()).collect();
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|k| *k /= sum);
    kernel
}

/// Separable Gaussian blur with standard deviation `sigma_px` (kernel radius `ceil(3σ)`).
pub fn gaussian_blur(image: &Plane<f32>, sigma_px: f32) -> Plane<f32> {
    let kernel = gaussian_kernel(sigma_px);
    let radius = (kernel.len() / 2) as isize;
    let (w, h) = image.size();
    if w == 0 || h == 0 {
        return image.clone();
    }
    // Horizontal pass.
    let mut tmp = vec![0.0f32; w * h];
    tmp.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        let row = image.row(y);
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0;
            let first = x as isize - radius;
            if first >= 0 && x as isize + radius < w as isize {
                // Inside the row no tap is mirrored: the same sum, without the index arithmetic.
                for (&kv, &v) in kernel.iter().zip(&row[first as usize..]) {
                    acc += kv * v;
                }
            } else {
                for (k, &kv) in kernel.iter().enumerate() {
                    acc += kv * row[reflect(first + k as isize, w)];
                }
            }
            *o = acc;
        }
    });
    // Vertical pass.
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, out_row)| {
        for (k, &kv) in kernel.iter().enumerate() {
            let src = reflect(y as isize + k as isize - radius, h);
            let src_row = &tmp[src * w..(src + 1) * w];
            for (o, &s) in out_row.iter_mut().zip(src_row) {
                *o += kv * s;
            }
        }
    });
    Plane { width: w, height: h, data: out }
}

/// Applies a 3×3 stencil `f(neighbourhood)` to every pixel, neighbourhood `[row][col]` with
/// reflect-101 borders.
fn stencil3x3(image: &Plane<f32>, f: impl Fn(&[[f32; 3]; 3]) -> f32 + Sync) -> Plane<f32> {
    let (w, h) = image.size();
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, out_row)| {
        let rows =
            [image.row(reflect(y as isize - 1, h)), image.row(y), image.row(reflect(y as isize + 1, h))];
        for (x, o) in out_row.iter_mut().enumerate() {
            let xs = if x > 0 && x + 1 < w {
                [x - 1, x, x + 1]
            } else {
                [reflect(x as isize - 1, w), x, reflect(x as isize + 1, w)]
            };
            let mut n = [[0.0f32; 3]; 3];
            for (r, row) in rows.iter().enumerate() {
                for (c, &xx) in xs.iter().enumerate() {
                    n[r][c] = row[xx];
                }
            }
            *o = f(&n);
        }
    });
    Plane { width: w, height: h, data: out }
}

/// 4-neighbour Laplacian `[0 1 0; 1 −4 1; 0 1 0]` (OpenCV `Laplacian` with `ksize = 1`).
pub fn laplacian(image: &Plane<f32>) -> Plane<f32> {
    stencil3x3(image, |n| n[0][1] + n[1][0] + n[1][2] + n[2][1] - 4.0 * n[1][1])
}

/// Sobel gradient magnitude `sqrt(gx² + gy²)` with the 3×3 kernels `[−1 0 1; −2 0 2; −1 0 1]`
/// and its transpose.
pub fn sobel_magnitude(image: &Plane<f32>) -> Plane<f32> {
    stencil3x3(image, |n| {
        let gx = (n[0][2] + 2.0 * n[1][2] + n[2][2]) - (n[0][0] + 2.0 * n[1][0] + n[2][0]);
        let gy = (n[2][0] + 2.0 * n[2][1] + n[2][2]) - (n[0][0] + 2.0 * n[0][1] + n[0][2]);
        (gx * gx + gy * gy).sqrt()
    })
}

/// Maps the finite values of `image` linearly to [0, 1] (min → 0, max → 1), in place.
/// A constant image becomes all zeros; non-finite values become 0.
pub fn normalise_min_max(image: &mut Plane<f32>) {
    let (lo, hi) = image
        .data
        .iter()
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let range = hi - lo;
    for v in image.data.iter_mut() {
        *v = if v.is_finite() && range > 0.0 { (*v - lo) / range } else { 0.0 };
    }
}

/// Source sample positions for resizing `src_len` samples to `dst_len`, with PyTorch's
/// `align_corners = False` semantics: output `i` samples input position `(i + 0.5)·src/dst − 0.5`,
/// clamped to the valid range. Returns per output index `(i0, i1, weight of i1)`.
pub fn bilinear_taps(src_len: usize, dst_len: usize) -> Vec<(usize, usize, f32)> {
    let scale = src_len as f32 / dst_len.max(1) as f32;
    (0..dst_len)
        .map(|i| {
            let pos = ((i as f32 + 0.5) * scale - 0.5).max(0.0);
            let i0 = (pos.floor() as usize).min(src_len.saturating_sub(1));
            let i1 = (i0 + 1).min(src_len.saturating_sub(1));
            let t = (pos - i0 as f32).clamp(0.0, 1.0);
            (i0, i1, if i1 == i0 { 0.0 } else { t })
        })
        .collect()
}

/// Resizes `image` to `width × height` by bilinear interpolation (`align_corners = False`).
pub fn resize_bilinear(image: &Plane<f32>, width: usize, height: usize) -> Plane<f32> {
    if image.size() == (width, height) {
        return image.clone();
    }
    let xs = bilinear_taps(image.width, width);
    let ys = bilinear_taps(image.height, height);
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, out_row)| {
        let (y0, y1, ty) = ys[y];
        let (r0, r1) = (image.row(y0), image.row(y1));
        for (o, &(x0, x1, tx)) in out_row.iter_mut().zip(&xs) {
            let top = r0[x0] * (1.0 - tx) + r0[x1] * tx;
            let bottom = r1[x0] * (1.0 - tx) + r1[x1] * tx;
            *o = top * (1.0 - ty) + bottom * ty;
        }
    });
    Plane { width, height, data: out }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// The blur equals, bit for bit, the former one that mirrored every tap's index: images
    /// narrower and wider than the kernel, several σ.
    #[test]
    fn blur_equals_the_blur_mirroring_every_tap() {
        let reference = |image: &Plane<f32>, sigma: f32| {
            let kernel = gaussian_kernel(sigma);
            let radius = (kernel.len() / 2) as isize;
            let (w, h) = image.size();
            let mut tmp = vec![0.0f32; w * h];
            for y in 0..h {
                for x in 0..w {
                    let mut acc = 0.0;
                    for (k, &kv) in kernel.iter().enumerate() {
                        acc += kv * image.row(y)[reflect(x as isize + k as isize - radius, w)];
                    }
                    tmp[y * w + x] = acc;
                }
            }
            let mut out = vec![0.0f32; w * h];
            for y in 0..h {
                for (k, &kv) in kernel.iter().enumerate() {
                    let src = reflect(y as isize + k as isize - radius, h);
                    for x in 0..w {
                        out[y * w + x] += kv * tmp[src * w + x];
                    }
                }
            }
            out
        };
        let mut seed = 3u32;
        for (w, h) in [(1, 1), (3, 7), (17, 5), (64, 40), (200, 3)] {
            let data: Vec<f32> = (0..w * h)
                .map(|_| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (seed >> 8) as f32 / 65_536.0 - 100.0
                })
                .collect();
            let image = Plane { width: w, height: h, data };
            for sigma in [0.0, 0.4, 1.0, 2.5, 6.0] {
                let got: Vec<u32> = gaussian_blur(&image, sigma).data.iter().map(|v| v.to_bits()).collect();
                let want: Vec<u32> = reference(&image, sigma).iter().map(|v| v.to_bits()).collect();
                assert_eq!(got, want, "{w}×{h}, σ {sigma}");
            }
        }
    }

    /// The 3×3 stencils equal, bit for bit, a Laplacian and a Sobel magnitude that mirror every
    /// neighbour's index.
    #[test]
    fn stencils_equal_the_ones_mirroring_every_neighbour() {
        let mut seed = 9u32;
        for (w, h) in [(1, 1), (2, 5), (9, 4), (33, 21)] {
            let data: Vec<f32> = (0..w * h)
                .map(|_| {
                    seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    (seed >> 8) as f32 / 4096.0
                })
                .collect();
            let image = Plane { width: w, height: h, data };
            let at = |x: isize, y: isize| image.data[reflect(y, h) * w + reflect(x, w)];
            let (lap, sob) = (laplacian(&image), sobel_magnitude(&image));
            for y in 0..h as isize {
                for x in 0..w as isize {
                    let n = |dy: isize, dx: isize| at(x + dx, y + dy);
                    let l = n(-1, 0) + n(0, -1) + n(0, 1) + n(1, 0) - 4.0 * n(0, 0);
                    let gx = (n(-1, 1) + 2.0 * n(0, 1) + n(1, 1)) - (n(-1, -1) + 2.0 * n(0, -1) + n(1, -1));
                    let gy = (n(1, -1) + 2.0 * n(1, 0) + n(1, 1)) - (n(-1, -1) + 2.0 * n(-1, 0) + n(-1, 1));
                    let i = y as usize * w + x as usize;
                    assert_eq!(lap.data[i].to_bits(), l.to_bits(), "laplacian ({x}, {y}) of {w}×{h}");
                    let g = (gx * gx + gy * gy).sqrt();
                    assert_eq!(sob.data[i].to_bits(), g.to_bits(), "sobel ({x}, {y}) of {w}×{h}");
                }
            }
        }
    }

    #[test]
    fn reflect_101_mirrors_without_repeating_the_edge() {
        let idx: Vec<usize> = (-3..8).map(|i| reflect(i, 5)).collect();
        assert_eq!(idx, vec![3, 2, 1, 0, 1, 2, 3, 4, 3, 2, 1]);
    }

    #[test]
    fn blur_keeps_constant_images_and_mass() {
        let flat = Plane::filled(9, 7, 0.25f32);
        let blurred = gaussian_blur(&flat, 2.0);
        for v in blurred.data {
            assert_abs_diff_eq!(v, 0.25, epsilon = 1e-6);
        }
        let mut impulse = Plane::filled(41, 41, 0.0f32);
        *impulse.get_mut(20, 20) = 1.0;
        let blurred = gaussian_blur(&impulse, 2.0);
        let total: f32 = blurred.data.iter().sum();
        assert_abs_diff_eq!(total, 1.0, epsilon = 1e-5);
        // Peak of a 2D Gaussian with σ = 2 sampled on the grid is ≈ 1/(2πσ²).
        assert_abs_diff_eq!(*blurred.get(20, 20), 1.0 / (2.0 * std::f32::consts::PI * 4.0), epsilon = 2e-3);
    }

    #[test]
    fn laplacian_of_a_quadratic_is_its_constant_second_derivative() {
        // f = x² + 2y²  ⇒  Δf = 2 + 4 = 6 away from the borders.
        let data = (0..10).flat_map(|y| (0..10).map(move |x| (x * x + 2 * y * y) as f32)).collect();
        let lap = laplacian(&Plane::from_vec(10, 10, data).unwrap());
        assert_abs_diff_eq!(*lap.get(4, 5), 6.0, epsilon = 1e-4);
    }

    #[test]
    fn sobel_of_a_ramp_is_eight_times_its_slope() {
        let data = (0..8).flat_map(|_| (0..8).map(|x| 0.5 * x as f32)).collect();
        let mag = sobel_magnitude(&Plane::from_vec(8, 8, data).unwrap());
        assert_abs_diff_eq!(*mag.get(3, 3), 4.0, epsilon = 1e-5);
    }

    #[test]
    fn bilinear_resize_matches_align_corners_false() {
        // [0, 1] → 4 samples: positions −0.25, 0.25, 0.75, 1.25 → clamp → 0, .25, .75, 1.
        let src = Plane::from_vec(2, 1, vec![0.0f32, 1.0]).unwrap();
        let out = resize_bilinear(&src, 4, 1);
        for (o, e) in out.data.iter().zip([0.0, 0.25, 0.75, 1.0]) {
            assert_abs_diff_eq!(*o, e, epsilon = 1e-6);
        }
    }

    #[test]
    fn min_max_normalisation_maps_to_unit_range() {
        let mut p = Plane::from_vec(3, 1, vec![2.0f32, 4.0, f32::NAN]).unwrap();
        normalise_min_max(&mut p);
        assert_eq!(p.data, vec![0.0, 1.0, 0.0]);
    }
}

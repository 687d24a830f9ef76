//! Semantic descriptors per region (paper §4.1 "Semantic Embeddings"): the mean of a per-pixel
//! feature over the region. Two sources sit behind [`DescriptorSource`]:
//!
//! - [`DenseFeatureDescriptors`]: a dense feature map `[h, w, C]` on any grid (DINOv2's patch grid
//!   `[H/14, W/14, C]` as `.npy` today, the in-process model later), upsampled bilinearly to the
//!   image (`align_corners = False`) and averaged over the region. Grid cells are L2-normalised
//!   first (the paper uses L2-normalised DINOv2 tokens). The upsampled map is never materialised:
//!   each pixel's four bilinear weights are accumulated per region and grid cell, so the result is
//!   exactly the mean of the upsampled features at `O(pixels + Σ cells·C)` cost.
//! - [`ColourTextureDescriptors`]: the model-free fallback, so the pipeline runs with no weights.
//!   Per pixel, a soft (linearly interpolated) histogram vote in CIE Lab (5 × 5 × 5 bins: L at
//!   0, 25, …, 100; a and b at −64, −32, 0, 32, 64) plus a soft vote over 4 texture-energy bins
//!   (Sobel magnitude of the grey image blurred with σ = 1 px, bin centres 0, 0.1, 0.3, 0.9) with
//!   weight 0.5. The region mean is a normalised colour histogram plus a texture histogram, so the
//!   cosine of two regions is in [0, 1] and near 1 for regions of the same colour and texture.
//!
//! Descriptors are returned **un-normalised** (plain means over the region) so that the merged
//! descriptor of two regions is their area-weighted mean, as the paper specifies; cosine
//! similarity does not depend on the scale.

use crate::error::{CuesError, CuesResult};
use crate::filter::{bilinear_taps, gaussian_blur, sobel_magnitude};
use splatseg_scene::Plane;
use std::path::PathBuf;

/// Mean descriptor and pixel count of each region of a label map.
#[derive(Clone, Debug, PartialEq)]
pub struct RegionDescriptors {
    /// Descriptor length `C`.
    pub channels: usize,
    /// `[n, C]` row-major: row `r` is the mean descriptor of the region labelled `r + 1`.
    pub means: Vec<f32>,
    /// `[n]` pixel count of each region.
    pub areas: Vec<u64>,
}

impl RegionDescriptors {
    /// Number of regions.
    pub fn len(&self) -> usize {
        self.areas.len()
    }

    /// True when there are no regions.
    pub fn is_empty(&self) -> bool {
        self.areas.is_empty()
    }

    /// Mean descriptor `[C]` of region index `r` (label `r + 1`).
    pub fn mean(&self, r: usize) -> &[f32] {
        &self.means[r * self.channels..(r + 1) * self.channels]
    }
}

/// What a descriptor source is asked for: one view's regions.
#[derive(Clone, Copy, Debug)]
pub struct DescribeRequest<'a> {
    /// The view's image stem (the key of per-view cue files).
    pub stem: &'a str,
    /// `[H, W]` RGB in [0, 1], for sources that look at the image.
    pub rgb: Option<&'a Plane<[f32; 3]>>,
    /// `[H, W]` region labels, 0 = unlabelled, regions `1..=region_count`.
    pub labels: &'a Plane<u32>,
    /// Number of regions.
    pub region_count: usize,
}

/// Something that gives each region of a view a descriptor.
pub trait DescriptorSource: Sync {
    /// Mean descriptor per region of the request's label map.
    fn describe(&self, request: &DescribeRequest<'_>) -> CuesResult<RegionDescriptors>;
}

/// A dense feature map `[h, w, C]` (channels last, row-major), e.g. DINOv2 patch tokens.
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureGrid {
    /// Grid rows `h`.
    pub height: usize,
    /// Grid columns `w`.
    pub width: usize,
    /// Channels `C`.
    pub channels: usize,
    /// `[h, w, C]` values.
    pub data: Vec<f32>,
}

impl FeatureGrid {
    /// Wraps `data` (`[height, width, channels]`); `None` if the length disagrees.
    pub fn new(height: usize, width: usize, channels: usize, data: Vec<f32>) -> Option<Self> {
        (data.len() == height * width * channels && height > 0 && width > 0 && channels > 0)
            .then_some(FeatureGrid { height, width, channels, data })
    }

    /// Wraps `data` (`[height, width, channels]`) as [`read_feature_grid`] accepts a file's:
    /// an error when a value is non-finite or the grid is empty or of another length.
    pub fn checked(height: usize, width: usize, channels: usize, data: Vec<f32>) -> Result<Self, String> {
        if data.iter().any(|v| !v.is_finite()) {
            return Err("non-finite values".to_string());
        }
        FeatureGrid::new(height, width, channels, data).ok_or_else(|| "empty feature grid".to_string())
    }

    /// The feature vector `[C]` of cell `(x, y)`.
    pub fn cell(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }

    /// Scales every cell to unit L2 norm (zero cells stay zero).
    pub fn l2_normalise_cells(&mut self) {
        for cell in self.data.chunks_mut(self.channels) {
            let norm = cell.iter().map(|v| v * v).sum::<f32>().sqrt();
            if norm > 0.0 {
                cell.iter_mut().for_each(|v| *v /= norm);
            }
        }
    }
}

/// Inclusive pixel bounding box of every region (`[x0, y0, x1, y1]`; regions with no pixels get
/// `x0 > x1`).
pub fn region_bboxes(labels: &Plane<u32>, region_count: usize) -> Vec<[usize; 4]> {
    let mut boxes = vec![[usize::MAX, usize::MAX, 0, 0]; region_count];
    for y in 0..labels.height {
        for (x, &l) in labels.row(y).iter().enumerate() {
            if l == 0 || l as usize > region_count {
                continue;
            }
            let b = &mut boxes[l as usize - 1];
            b[0] = b[0].min(x);
            b[1] = b[1].min(y);
            b[2] = b[2].max(x);
            b[3] = b[3].max(y);
        }
    }
    boxes
}

fn check_labels(labels: &Plane<u32>, region_count: usize) -> CuesResult<()> {
    match labels.data.iter().find(|&&l| l as usize > region_count) {
        Some(l) => Err(CuesError::shape(
            "region labels",
            format!("label {l} exceeds the region count {region_count}"),
        )),
        None => Ok(()),
    }
}

/// Mean over each region of `grid` upsampled bilinearly to the label map's size.
///
/// `grid`: `[h, w, C]`; `labels`: `[H, W]`, regions `1..=region_count`. Returns means `[n, C]`.
pub fn describe_with_grid(
    grid: &FeatureGrid,
    labels: &Plane<u32>,
    region_count: usize,
) -> CuesResult<RegionDescriptors> {
    check_labels(labels, region_count)?;
    let taps_x = bilinear_taps(grid.width, labels.width);
    let taps_y = bilinear_taps(grid.height, labels.height);
    // Per region: the window of grid cells its pixels can touch, and a weight per cell.
    let boxes = region_bboxes(labels, region_count);
    let windows: Vec<[usize; 4]> = boxes
        .iter()
        .map(|b| {
            if b[0] > b[2] {
                [0, 0, 0, 0]
            } else {
                [taps_x[b[0]].0, taps_y[b[1]].0, taps_x[b[2]].1, taps_y[b[3]].1]
            }
        })
        .collect();
    let mut weights: Vec<Vec<f32>> =
        windows.iter().map(|w| vec![0.0; (w[2] - w[0] + 1) * (w[3] - w[1] + 1)]).collect();
    let mut areas = vec![0u64; region_count];
    for (y, &(y0, y1, ty)) in taps_y.iter().enumerate() {
        for (x, &l) in labels.row(y).iter().enumerate() {
            if l == 0 {
                continue;
            }
            let r = l as usize - 1;
            areas[r] += 1;
            let (x0, x1, tx) = taps_x[x];
            let win = &windows[r];
            let stride = win[2] - win[0] + 1;
            let acc = &mut weights[r];
            let (cx0, cx1, cy0, cy1) = (x0 - win[0], x1 - win[0], y0 - win[1], y1 - win[1]);
            acc[cy0 * stride + cx0] += (1.0 - tx) * (1.0 - ty);
            acc[cy0 * stride + cx1] += tx * (1.0 - ty);
            acc[cy1 * stride + cx0] += (1.0 - tx) * ty;
            acc[cy1 * stride + cx1] += tx * ty;
        }
    }
    let c = grid.channels;
    let mut means = vec![0.0f32; region_count * c];
    for r in 0..region_count {
        if areas[r] == 0 {
            continue;
        }
        let win = &windows[r];
        let stride = win[2] - win[0] + 1;
        let out = &mut means[r * c..(r + 1) * c];
        for (i, &wgt) in weights[r].iter().enumerate() {
            if wgt == 0.0 {
                continue;
            }
            let cell = grid.cell(win[0] + i % stride, win[1] + i / stride);
            out.iter_mut().zip(cell).for_each(|(o, f)| *o += wgt * f);
        }
        let inv = 1.0 / areas[r] as f32;
        out.iter_mut().for_each(|o| *o *= inv);
    }
    Ok(RegionDescriptors { channels: c, means, areas })
}

/// Where dense feature grids come from.
#[derive(Clone, Debug)]
pub enum FeatureGrids {
    /// `<dir>/<stem>.npy` holding `[h, w, C]` float32/float16.
    Folder(PathBuf),
    /// `(stem, grid)` pairs already in memory.
    InMemory(Vec<(String, FeatureGrid)>),
}

/// Dense-feature descriptors (DINOv2-like): see the module documentation.
#[derive(Clone, Debug)]
pub struct DenseFeatureDescriptors {
    /// Where each view's grid comes from.
    pub grids: FeatureGrids,
}

impl DenseFeatureDescriptors {
    /// The grid of view `stem`, cells L2-normalised.
    pub fn grid(&self, stem: &str) -> CuesResult<FeatureGrid> {
        let mut grid = match &self.grids {
            FeatureGrids::InMemory(list) => {
                list.iter().find(|(s, _)| s == stem).map(|(_, g)| g.clone()).ok_or_else(|| {
                    CuesError::Missing {
                        what: "feature map",
                        stem: stem.to_string(),
                        path: "<memory>".into(),
                    }
                })?
            }
            FeatureGrids::Folder(dir) => read_feature_grid(dir, stem)?,
        };
        grid.l2_normalise_cells();
        Ok(grid)
    }
}

/// Reads `<dir>/<stem>.npy` as a `[h, w, C]` feature grid.
pub fn read_feature_grid(dir: &std::path::Path, stem: &str) -> CuesResult<FeatureGrid> {
    let path = dir.join(format!("{stem}.npy"));
    let file_err = |reason: String| CuesError::File { what: "feature map", reason, path: path.clone() };
    let array = splatseg_scene::npy::read_cue_folder_entry(dir, stem)
        .map_err(|e| file_err(e.to_string()))?
        .ok_or_else(|| CuesError::Missing {
        what: "feature map",
        stem: stem.to_string(),
        path: path.clone(),
    })?;
    let [h, w, c] = array.shape[..] else {
        return Err(file_err(format!("shape {:?} is not [h, w, C]", array.shape)));
    };
    FeatureGrid::checked(h, w, c, array.data).map_err(file_err)
}

impl DescriptorSource for DenseFeatureDescriptors {
    fn describe(&self, request: &DescribeRequest<'_>) -> CuesResult<RegionDescriptors> {
        describe_with_grid(&self.grid(request.stem)?, request.labels, request.region_count)
    }
}

/// The model-free colour + texture fallback: see the module documentation.
#[derive(Clone, Copy, Debug, Default)]
pub struct ColourTextureDescriptors;

const LAB_BINS: usize = 5;
const L_CENTRES: [f32; LAB_BINS] = [0.0, 25.0, 50.0, 75.0, 100.0];
const AB_CENTRES: [f32; LAB_BINS] = [-64.0, -32.0, 0.0, 32.0, 64.0];
const TEXTURE_CENTRES: [f32; 4] = [0.0, 0.1, 0.3, 0.9];
const TEXTURE_WEIGHT: f32 = 0.5;
/// Descriptor length of [`ColourTextureDescriptors`].
pub const COLOUR_TEXTURE_CHANNELS: usize = LAB_BINS * LAB_BINS * LAB_BINS + TEXTURE_CENTRES.len();

/// Soft assignment of `v` to sorted bin `centres`: `(lower bin, weight of the upper bin)`.
fn soft_bin(v: f32, centres: &[f32]) -> (usize, f32) {
    let last = centres.len() - 1;
    if v <= centres[0] {
        return (0, 0.0);
    }
    if v >= centres[last] {
        return (last - 1, 1.0);
    }
    let i = centres.windows(2).position(|w| v < w[1]).unwrap_or(last - 1);
    (i, (v - centres[i]) / (centres[i + 1] - centres[i]))
}

/// CIE L*a*b* (D65) of an sRGB colour in [0, 1].
pub fn lab_from_srgb([r, g, b]: [f32; 3]) -> [f32; 3] {
    let lin = |c: f32| {
        let c = c.clamp(0.0, 1.0);
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let (r, g, b) = (lin(r), lin(g), lin(b));
    let x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047;
    let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    let z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
    let f = |t: f32| if t > 0.008856 { t.cbrt() } else { 7.787 * t + 16.0 / 116.0 };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

impl DescriptorSource for ColourTextureDescriptors {
    fn describe(&self, request: &DescribeRequest<'_>) -> CuesResult<RegionDescriptors> {
        let rgb = request.rgb.ok_or_else(|| {
            CuesError::shape("colour descriptors", "the view's image is needed but was not given")
        })?;
        describe_colour_texture(rgb, request.labels, request.region_count)
    }
}

/// Colour + texture descriptors of each region. `rgb`: `[H, W]` in [0, 1]; `labels`: `[H, W]`.
pub fn describe_colour_texture(
    rgb: &Plane<[f32; 3]>,
    labels: &Plane<u32>,
    region_count: usize,
) -> CuesResult<RegionDescriptors> {
    if rgb.size() != labels.size() {
        return Err(CuesError::shape(
            "colour descriptors",
            format!("image is {:?} but the label map is {:?}", rgb.size(), labels.size()),
        ));
    }
    check_labels(labels, region_count)?;
    let texture = sobel_magnitude(&gaussian_blur(&crate::edges::grey_from_rgb(rgb), 1.0));
    let c = COLOUR_TEXTURE_CHANNELS;
    let mut sums = vec![0.0f32; region_count * c];
    let mut areas = vec![0u64; region_count];
    for (i, &l) in labels.data.iter().enumerate() {
        if l == 0 {
            continue;
        }
        let r = l as usize - 1;
        areas[r] += 1;
        let out = &mut sums[r * c..(r + 1) * c];
        let [lum, a, b] = lab_from_srgb(rgb.data[i]);
        let (li, lt) = soft_bin(lum, &L_CENTRES);
        let (ai, at) = soft_bin(a, &AB_CENTRES);
        let (bi, bt) = soft_bin(b, &AB_CENTRES);
        for (dl, wl) in [(0, 1.0 - lt), (1, lt)] {
            for (da, wa) in [(0, 1.0 - at), (1, at)] {
                for (db, wb) in [(0, 1.0 - bt), (1, bt)] {
                    let bin = ((li + dl) * LAB_BINS + ai + da) * LAB_BINS + bi + db;
                    out[bin] += wl * wa * wb;
                }
            }
        }
        let (ti, tt) = soft_bin(texture.data[i], &TEXTURE_CENTRES);
        let base = LAB_BINS * LAB_BINS * LAB_BINS;
        out[base + ti] += TEXTURE_WEIGHT * (1.0 - tt);
        out[base + ti + 1] += TEXTURE_WEIGHT * tt;
    }
    for (r, &area) in areas.iter().enumerate() {
        if area > 0 {
            let inv = 1.0 / area as f32;
            sums[r * c..(r + 1) * c].iter_mut().for_each(|v| *v *= inv);
        }
    }
    Ok(RegionDescriptors { channels: c, means: sums, areas })
}

/// Cosine similarity of two descriptors (0 when either is zero).
pub fn cosine(a: &[f32], b: &[f32]) -> f32 {
    let (mut dot, mut na, mut nb) = (0.0f64, 0.0f64, 0.0f64);
    for (&x, &y) in a.iter().zip(b) {
        dot += x as f64 * y as f64;
        na += x as f64 * x as f64;
        nb += y as f64 * y as f64;
    }
    if na == 0.0 || nb == 0.0 {
        0.0
    } else {
        (dot / (na.sqrt() * nb.sqrt())) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::resize_bilinear;
    use approx::assert_abs_diff_eq;

    #[test]
    fn grid_descriptor_equals_mean_of_the_explicitly_upsampled_map() {
        // 3×2 grid, 2 channels, upsampled to 13×9; two regions split at an odd column.
        let data: Vec<f32> = (0..12).map(|i| ((i * 7) % 5) as f32 - 1.5).collect();
        let grid = FeatureGrid::new(2, 3, 2, data).unwrap();
        let labels =
            Plane::from_vec(13, 9, (0..117).map(|i| if i % 13 < 5 { 1 } else { 2 }).collect()).unwrap();
        let got = describe_with_grid(&grid, &labels, 2).unwrap();
        for ch in 0..2 {
            let channel = Plane::from_vec(3, 2, (0..6).map(|k| grid.data[k * 2 + ch]).collect()).unwrap();
            let up = resize_bilinear(&channel, 13, 9);
            for region in 1..=2u32 {
                let vals: Vec<f32> =
                    up.data.iter().zip(&labels.data).filter(|(_, &l)| l == region).map(|(v, _)| *v).collect();
                let mean = vals.iter().sum::<f32>() / vals.len() as f32;
                assert_abs_diff_eq!(got.mean(region as usize - 1)[ch], mean, epsilon = 1e-5);
            }
        }
        assert_eq!(got.areas, vec![45, 72]);
    }

    #[test]
    fn colour_descriptors_separate_colours_and_group_equal_ones() {
        // Red regions 1 (x < 10) and 2 (10 ≤ x < 20), blue region 3 (x ≥ 30), unlabelled between.
        let labels = Plane::from_vec(40, 1, (0..40).map(|x| [1, 2, 0, 3][x / 10]).collect()).unwrap();
        let (red, blue) = ([0.8, 0.1, 0.1], [0.1, 0.2, 0.8]);
        let rgb = Plane::from_vec(40, 1, (0..40).map(|x| if x < 25 { red } else { blue }).collect()).unwrap();
        let d = describe_colour_texture(&rgb, &labels, 3).unwrap();
        assert!(cosine(d.mean(0), d.mean(1)) > 0.99);
        assert!(cosine(d.mean(0), d.mean(2)) < 0.5);
    }

    #[test]
    fn lab_of_white_and_black() {
        let w = lab_from_srgb([1.0, 1.0, 1.0]);
        assert_abs_diff_eq!(w[0], 100.0, epsilon = 0.1);
        assert!(w[1].abs() < 0.5 && w[2].abs() < 0.5);
        assert_abs_diff_eq!(lab_from_srgb([0.0, 0.0, 0.0])[0], 0.0, epsilon = 1e-3);
    }

    #[test]
    fn labels_beyond_the_region_count_are_rejected() {
        let labels = Plane::from_vec(2, 1, vec![1, 3]).unwrap();
        let grid = FeatureGrid::new(1, 1, 1, vec![1.0]).unwrap();
        assert!(describe_with_grid(&grid, &labels, 2).is_err());
    }
}

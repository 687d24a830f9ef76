//! COLMAP's binary model files (`cameras.bin`, `images.bin`, `points3D.bin`), little-endian:
//!
//! - `cameras.bin`: `u64` count, then per camera `i32 camera_id, i32 model_id, u64 width,
//!   u64 height, f64 params[num_params(model)]`.
//! - `images.bin`: `u64` count, then per image `i32 image_id, f64 qvec[4] (w x y z),
//!   f64 tvec[3], i32 camera_id, name (NUL-terminated), u64 num_points2D,
//!   (f64 x, f64 y, i64 point3D_id)[num_points2D]`.
//! - `points3D.bin`: `u64` count, then per point `u64 point3D_id, f64 xyz[3], u8 rgb[3],
//!   f64 error, u64 track_length, (i32 image_id, i32 point2D_idx)[track_length]`.
//!
//! Reading checks every length against the bytes left, so a truncated or lying file is an error
//! naming the record, never a panic or a huge allocation.

use super::model::{unsupported_model_name, ColmapCamera, ColmapImage, ColmapModel, SUPPORTED_MODELS};
use crate::atomic::write_bytes_atomic;
use crate::camera::CameraModel;
use crate::error::{SceneError, SceneResult};
use crate::load::{Keypoint, SparsePoint};
use glam::{DVec2, DVec3};
use std::path::Path;

/// Reads `cameras.bin`, `images.bin` and `points3D.bin` from `dir`.
pub fn read_model_binary(dir: &Path) -> SceneResult<ColmapModel> {
    let (cameras, images, points) =
        (dir.join("cameras.bin"), dir.join("images.bin"), dir.join("points3D.bin"));
    Ok(ColmapModel {
        cameras: parse_cameras_bin(&read_file(&cameras)?, &cameras)?,
        images: parse_images_bin(&read_file(&images)?, &images)?,
        points: parse_points_bin(&read_file(&points)?, &points)?,
    })
}

/// Writes the three binary files into `dir` (each atomically).
pub fn write_model_binary(dir: &Path, model: &ColmapModel) -> SceneResult<()> {
    write_bytes_atomic(&dir.join("cameras.bin"), &encode_cameras(&model.cameras))?;
    write_bytes_atomic(&dir.join("images.bin"), &encode_images(&model.images))?;
    write_bytes_atomic(&dir.join("points3D.bin"), &encode_points(&model.points))
}

/// A bounds-checked little-endian reader over one file's bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
    format: &'static str,
    /// What is being read, for messages: the kind of record ("" before the first), its
    /// 1-based index, the count, and for images the name once read.
    record: Record,
}

#[derive(Default)]
struct Record {
    kind: &'static str,
    index: usize,
    count: usize,
    name: Option<String>,
}

impl std::fmt::Display for Record {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.kind.is_empty() {
            return f.write_str("the record count");
        }
        write!(f, "{} {} of {}", self.kind, self.index, self.count)?;
        match &self.name {
            Some(name) => write!(f, " ({name})"),
            None => Ok(()),
        }
    }
}

impl<'a> Reader<'a> {
    fn new(bytes: &'a [u8], path: &'a Path, format: &'static str) -> Self {
        Reader { bytes, pos: 0, path, format, record: Record::default() }
    }

    fn invalid(&self, reason: impl Into<String>) -> SceneError {
        SceneError::invalid(self.format, self.path, reason)
    }

    fn take(&mut self, n: usize, field: &str) -> SceneResult<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.invalid(format!(
                "truncated: the file ends at byte {} inside {} (reading {field})",
                self.bytes.len(),
                self.record
            )));
        };
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, field: &str) -> SceneResult<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, field)?);
        Ok(out)
    }

    fn u64(&mut self, field: &str) -> SceneResult<u64> {
        self.array(field).map(u64::from_le_bytes)
    }

    fn i64(&mut self, field: &str) -> SceneResult<i64> {
        self.array(field).map(i64::from_le_bytes)
    }

    fn i32(&mut self, field: &str) -> SceneResult<i32> {
        self.array(field).map(i32::from_le_bytes)
    }

    /// A non-negative `i32` id.
    fn id(&mut self, field: &str) -> SceneResult<u32> {
        let v = self.i32(field)?;
        u32::try_from(v).map_err(|_| self.invalid(format!("negative {field} {v} in {}", self.record)))
    }

    /// A finite `f64`.
    fn f64(&mut self, field: &str) -> SceneResult<f64> {
        let v = f64::from_le_bytes(self.array(field)?);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(format!("non-finite {field} ({v}) in {}", self.record)))
        }
    }

    /// A `u64` count of records of at least `min_bytes` each; checked against the bytes left.
    fn count(&mut self, field: &str, min_bytes: usize) -> SceneResult<usize> {
        let n = self.u64(field)?;
        let left = (self.bytes.len() - self.pos) as u64;
        if n.saturating_mul(min_bytes as u64) > left {
            return Err(self.invalid(format!(
                "truncated or corrupt: {} says {field} = {n}, but only {left} bytes remain \
                 (each entry takes at least {min_bytes})",
                self.record
            )));
        }
        Ok(n as usize)
    }

    /// Starts record `index` (0-based) of `count` records of `kind`.
    fn start(&mut self, kind: &'static str, index: usize, count: usize) {
        self.record = Record { kind, index: index + 1, count, name: None };
    }

    fn finish(&self) -> SceneResult<()> {
        if self.pos == self.bytes.len() {
            Ok(())
        } else {
            Err(self.invalid(format!(
                "{} unexpected bytes after the last record (at byte {})",
                self.bytes.len() - self.pos,
                self.pos
            )))
        }
    }
}

fn read_file(path: &Path) -> SceneResult<Vec<u8>> {
    std::fs::read(path).map_err(|e| SceneError::io("cannot read", path, e))
}

/// Parses the bytes of a `cameras.bin` file; `path` is only named in errors.
pub fn parse_cameras_bin(bytes: &[u8], path: &Path) -> SceneResult<Vec<ColmapCamera>> {
    let mut r = Reader::new(bytes, path, "COLMAP cameras.bin");
    let n = r.count("number of cameras", 24)?;
    let mut cameras = Vec::with_capacity(n);
    for i in 0..n {
        r.start("camera", i, n);
        let id = r.id("camera_id")?;
        let model_id = r.i32("model_id")?;
        let model = CameraModel::from_colmap_id(model_id).ok_or_else(|| {
            let name = unsupported_model_name(model_id).unwrap_or("unknown");
            SceneError::Unsupported {
                what: format!(
                    "COLMAP camera model {name} (model id {model_id}, camera {id}); {SUPPORTED_MODELS}"
                ),
                path: path.to_path_buf(),
            }
        })?;
        let width = r.u64("width")?;
        let height = r.u64("height")?;
        let size = |v: u64, what: &str| {
            u32::try_from(v)
                .ok()
                .filter(|&s| s > 0)
                .ok_or_else(|| r.invalid(format!("camera {id} has an invalid {what} {v}")))
        };
        let (width, height) = (size(width, "width")?, size(height, "height")?);
        crate::limits::check_pixels(&format!("camera {id}"), width as u64, height as u64)
            .map_err(|reason| r.invalid(reason))?;
        let params =
            (0..model.num_params()).map(|_| r.f64("camera parameter")).collect::<SceneResult<Vec<_>>>()?;
        cameras.push(ColmapCamera { id, model, width, height, params });
    }
    r.finish()?;
    Ok(cameras)
}

/// Parses the bytes of a `images.bin` file; `path` is only named in errors.
pub fn parse_images_bin(bytes: &[u8], path: &Path) -> SceneResult<Vec<ColmapImage>> {
    let mut r = Reader::new(bytes, path, "COLMAP images.bin");
    // id + qvec + tvec + camera id + NUL + point count.
    let n = r.count("number of images", 4 + 56 + 4 + 1 + 8)?;
    let mut images = Vec::with_capacity(n);
    for i in 0..n {
        r.start("image", i, n);
        let id = r.id("image_id")?;
        let mut qvec = [0.0; 4];
        for q in &mut qvec {
            *q = r.f64("qvec")?;
        }
        let mut tvec = [0.0; 3];
        for t in &mut tvec {
            *t = r.f64("tvec")?;
        }
        let camera_id = r.id("camera_id")?;
        let name = read_name(&mut r)?;
        r.record.name = Some(name.clone());
        let num_points = r.count("num_points2D", 24)?;
        let mut keypoints = Vec::with_capacity(num_points);
        for _ in 0..num_points {
            let x = r.f64("point2D x")?;
            let y = r.f64("point2D y")?;
            let point3d_id = r.i64("point3D_id")?;
            keypoints.push(Keypoint { xy: DVec2::new(x, y), point3d_id });
        }
        images.push(ColmapImage { id, qvec, tvec, camera_id, name, keypoints });
    }
    r.finish()?;
    Ok(images)
}

fn read_name(r: &mut Reader) -> SceneResult<String> {
    let rest = &r.bytes[r.pos..];
    let Some(len) = rest.iter().position(|&b| b == 0) else {
        return Err(r.invalid(format!("truncated: the file ends inside the name of {}", r.record)));
    };
    let name = std::str::from_utf8(&rest[..len])
        .map_err(|_| r.invalid(format!("the name of {} is not valid UTF-8", r.record)))?
        .to_string();
    r.pos += len + 1;
    if name.is_empty() {
        return Err(r.invalid(format!("{} has an empty name", r.record)));
    }
    Ok(name)
}

/// Parses the bytes of a `points3D.bin` file; `path` is only named in errors.
pub fn parse_points_bin(bytes: &[u8], path: &Path) -> SceneResult<Vec<SparsePoint>> {
    let mut r = Reader::new(bytes, path, "COLMAP points3D.bin");
    let n = r.count("number of points", 8 + 24 + 3 + 8 + 8)?;
    let mut points = Vec::with_capacity(n);
    for i in 0..n {
        r.start("point", i, n);
        let id = r.u64("point3D_id")?;
        let xyz = DVec3::new(r.f64("x")?, r.f64("y")?, r.f64("z")?);
        let rgb = r.array::<3>("rgb")?;
        let error = r.f64("error")?;
        let track_len = r.count("track_length", 8)?;
        let mut track = Vec::with_capacity(track_len);
        for _ in 0..track_len {
            track.push((r.id("track image_id")?, r.id("track point2D_idx")?));
        }
        points.push(SparsePoint { id, xyz, rgb, error, track });
    }
    r.finish()?;
    Ok(points)
}

fn encode_cameras(cameras: &[ColmapCamera]) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + cameras.len() * 96);
    out.extend_from_slice(&(cameras.len() as u64).to_le_bytes());
    for c in cameras {
        out.extend_from_slice(&(c.id as i32).to_le_bytes());
        out.extend_from_slice(&c.model.colmap_id().to_le_bytes());
        out.extend_from_slice(&(c.width as u64).to_le_bytes());
        out.extend_from_slice(&(c.height as u64).to_le_bytes());
        for p in &c.params {
            out.extend_from_slice(&p.to_le_bytes());
        }
    }
    out
}

fn encode_images(images: &[ColmapImage]) -> Vec<u8> {
    let size: usize = images.iter().map(|im| 80 + im.name.len() + 24 * im.keypoints.len()).sum();
    let mut out = Vec::with_capacity(8 + size);
    out.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for im in images {
        out.extend_from_slice(&(im.id as i32).to_le_bytes());
        for v in im.qvec.iter().chain(&im.tvec) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&(im.camera_id as i32).to_le_bytes());
        out.extend_from_slice(im.name.as_bytes());
        out.push(0);
        out.extend_from_slice(&(im.keypoints.len() as u64).to_le_bytes());
        for k in &im.keypoints {
            out.extend_from_slice(&k.xy.x.to_le_bytes());
            out.extend_from_slice(&k.xy.y.to_le_bytes());
            out.extend_from_slice(&k.point3d_id.to_le_bytes());
        }
    }
    out
}

fn encode_points(points: &[SparsePoint]) -> Vec<u8> {
    let size: usize = points.iter().map(|p| 51 + 8 * p.track.len()).sum();
    let mut out = Vec::with_capacity(8 + size);
    out.extend_from_slice(&(points.len() as u64).to_le_bytes());
    for p in points {
        out.extend_from_slice(&p.id.to_le_bytes());
        for v in p.xyz.to_array() {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&p.rgb);
        out.extend_from_slice(&p.error.to_le_bytes());
        out.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for &(image_id, idx) in &p.track {
            out.extend_from_slice(&(image_id as i32).to_le_bytes());
            out.extend_from_slice(&(idx as i32).to_le_bytes());
        }
    }
    out
}

//! COLMAP's text model files (`cameras.txt`, `images.txt`, `points3D.txt`).
//!
//! Lines starting with `#` and blank lines are skipped, except that in `images.txt` every image
//! takes two lines: `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`, then its `POINTS2D[]` as
//! `X Y POINT3D_ID` triples, a line that may be empty. Numbers are written in Rust's shortest
//! round-trip form, so text → binary → text reproduces the file.

use super::model::{ColmapCamera, ColmapImage, ColmapModel, SUPPORTED_MODELS};
use crate::atomic::write_atomic;
use crate::camera::CameraModel;
use crate::error::{SceneError, SceneResult};
use crate::load::{Keypoint, SparsePoint};
use glam::{DVec2, DVec3};
use std::fmt::Write as _;
use std::path::Path;
use std::str::FromStr;

/// Reads `cameras.txt`, `images.txt` and `points3D.txt` from `dir`.
pub fn read_model_text(dir: &Path) -> SceneResult<ColmapModel> {
    let (cameras, images, points) =
        (dir.join("cameras.txt"), dir.join("images.txt"), dir.join("points3D.txt"));
    Ok(ColmapModel {
        cameras: parse_cameras_txt(&read_text(&cameras)?, &cameras)?,
        images: parse_images_txt(&read_text(&images)?, &images)?,
        points: parse_points_txt(&read_text(&points)?, &points)?,
    })
}

/// Writes the three text files into `dir` (each atomically), with COLMAP's header comments.
pub fn write_model_text(dir: &Path, model: &ColmapModel) -> SceneResult<()> {
    write_string(&dir.join("cameras.txt"), &format_cameras(&model.cameras))?;
    write_string(&dir.join("images.txt"), &format_images(&model.images))?;
    write_string(&dir.join("points3D.txt"), &format_points(&model.points))
}

fn write_string(path: &Path, text: &str) -> SceneResult<()> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

fn read_text(path: &Path) -> SceneResult<String> {
    std::fs::read_to_string(path).map_err(|e| SceneError::io("cannot read", path, e))
}

/// Whitespace-separated fields of one line, with errors naming the file and line.
struct Fields<'a> {
    rest: &'a str,
    line_no: usize,
    path: &'a Path,
    format: &'static str,
}

impl<'a> Fields<'a> {
    fn new(line: &'a str, line_no: usize, path: &'a Path, format: &'static str) -> Self {
        Fields { rest: line, line_no, path, format }
    }

    fn invalid(&self, reason: impl std::fmt::Display) -> SceneError {
        SceneError::invalid(self.format, self.path, format!("line {}: {reason}", self.line_no))
    }

    fn next_token(&mut self) -> Option<&'a str> {
        let s = self.rest.trim_start();
        if s.is_empty() {
            return None;
        }
        let end = s.find(char::is_whitespace).unwrap_or(s.len());
        self.rest = &s[end..];
        Some(&s[..end])
    }

    fn parse<T: FromStr>(&mut self, field: &str) -> SceneResult<T> {
        let token = self.next_token().ok_or_else(|| self.invalid(format!("missing {field}")))?;
        token.parse().map_err(|_| self.invalid(format!("cannot read {field} from \"{token}\"")))
    }

    fn f64(&mut self, field: &str) -> SceneResult<f64> {
        let v: f64 = self.parse(field)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(format!("non-finite {field}")))
        }
    }

    /// Remaining fields, parsed.
    fn rest_as<T: FromStr>(&mut self, field: &str) -> SceneResult<Vec<T>> {
        let mut out = Vec::new();
        while let Some(token) = self.next_token() {
            out.push(
                token.parse().map_err(|_| self.invalid(format!("cannot read {field} from \"{token}\"")))?,
            );
        }
        Ok(out)
    }
}

/// Lines that hold data: `(1-based line number, line)`, comments and blank lines removed.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// Parses the text of a `cameras.txt` file; `path` is only named in errors.
pub fn parse_cameras_txt(text: &str, path: &Path) -> SceneResult<Vec<ColmapCamera>> {
    const FORMAT: &str = "COLMAP cameras.txt";
    let mut cameras = Vec::new();
    for (line_no, line) in data_lines(text) {
        let mut f = Fields::new(line, line_no, path, FORMAT);
        let id: u32 = f.parse("CAMERA_ID")?;
        let name = f.next_token().ok_or_else(|| f.invalid("missing MODEL"))?;
        let model = CameraModel::from_colmap_name(name).ok_or_else(|| SceneError::Unsupported {
            what: format!("COLMAP camera model {name} (camera {id}, line {line_no}); {SUPPORTED_MODELS}"),
            path: path.to_path_buf(),
        })?;
        let width: u32 = f.parse("WIDTH")?;
        let height: u32 = f.parse("HEIGHT")?;
        if width == 0 || height == 0 {
            return Err(f.invalid(format!("camera {id} has size {width}x{height}")));
        }
        crate::limits::check_pixels(&format!("camera {id}"), width as u64, height as u64)
            .map_err(|reason| f.invalid(reason))?;
        let params: Vec<f64> = f.rest_as("PARAMS")?;
        if params.len() != model.num_params() {
            return Err(f.invalid(format!(
                "camera {id} ({name}) has {} parameters, the model needs {}",
                params.len(),
                model.num_params()
            )));
        }
        if params.iter().any(|p| !p.is_finite()) {
            return Err(f.invalid(format!("camera {id} has a non-finite parameter")));
        }
        cameras.push(ColmapCamera { id, model, width, height, params });
    }
    Ok(cameras)
}

/// Parses the text of a `images.txt` file; `path` is only named in errors.
pub fn parse_images_txt(text: &str, path: &Path) -> SceneResult<Vec<ColmapImage>> {
    const FORMAT: &str = "COLMAP images.txt";
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    let mut images = Vec::new();
    while let Some((line_no, line)) = lines.next() {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut f = Fields::new(line, line_no, path, FORMAT);
        let id: u32 = f.parse("IMAGE_ID")?;
        let mut qvec = [0.0; 4];
        for (q, field) in qvec.iter_mut().zip(["QW", "QX", "QY", "QZ"]) {
            *q = f.f64(field)?;
        }
        let mut tvec = [0.0; 3];
        for (t, field) in tvec.iter_mut().zip(["TX", "TY", "TZ"]) {
            *t = f.f64(field)?;
        }
        let camera_id: u32 = f.parse("CAMERA_ID")?;
        let name = f.rest.trim().to_string();
        if name.is_empty() {
            return Err(f.invalid(format!("image {id} has no NAME")));
        }
        // The next line, whatever it holds, is this image's POINTS2D[] (possibly empty).
        let keypoints = match lines.next() {
            Some((points_line_no, points_line)) => {
                let mut p = Fields::new(points_line, points_line_no, path, FORMAT);
                read_keypoints(&mut p, id)?
            }
            None => Vec::new(),
        };
        images.push(ColmapImage { id, qvec, tvec, camera_id, name, keypoints });
    }
    Ok(images)
}

fn read_keypoints(f: &mut Fields, image_id: u32) -> SceneResult<Vec<Keypoint>> {
    let mut keypoints = Vec::new();
    while f.rest.trim_start().starts_with(|c: char| !c.is_whitespace()) {
        let x = f.f64("POINTS2D X")?;
        let y = f.f64("POINTS2D Y")?;
        let point3d_id: i64 = f.parse("POINT3D_ID").map_err(|_| {
            f.invalid(format!("the POINTS2D of image {image_id} are not (X, Y, POINT3D_ID) triples"))
        })?;
        keypoints.push(Keypoint { xy: DVec2::new(x, y), point3d_id });
    }
    Ok(keypoints)
}

/// Parses the text of a `points3D.txt` file; `path` is only named in errors.
pub fn parse_points_txt(text: &str, path: &Path) -> SceneResult<Vec<SparsePoint>> {
    const FORMAT: &str = "COLMAP points3D.txt";
    let mut points = Vec::new();
    for (line_no, line) in data_lines(text) {
        let mut f = Fields::new(line, line_no, path, FORMAT);
        let id: u64 = f.parse("POINT3D_ID")?;
        let xyz = DVec3::new(f.f64("X")?, f.f64("Y")?, f.f64("Z")?);
        let rgb = [f.parse("R")?, f.parse("G")?, f.parse("B")?];
        let error = f.f64("ERROR")?;
        let track_values: Vec<u32> = f.rest_as("TRACK")?;
        if !track_values.len().is_multiple_of(2) {
            return Err(f.invalid(format!("the TRACK of point {id} is not (IMAGE_ID, POINT2D_IDX) pairs")));
        }
        let track = track_values.chunks_exact(2).map(|c| (c[0], c[1])).collect();
        points.push(SparsePoint { id, xyz, rgb, error, track });
    }
    Ok(points)
}

fn format_cameras(cameras: &[ColmapCamera]) -> String {
    let mut s = String::new();
    s.push_str("# Camera list with one line of data per camera:\n");
    s.push_str("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    let _ = writeln!(s, "# Number of cameras: {}", cameras.len());
    for c in cameras {
        let _ = write!(s, "{} {} {} {}", c.id, c.model.colmap_name(), c.width, c.height);
        for p in &c.params {
            let _ = write!(s, " {p:?}");
        }
        s.push('\n');
    }
    s
}

fn format_images(images: &[ColmapImage]) -> String {
    let observations: usize =
        images.iter().map(|im| im.keypoints.iter().filter(|k| k.point3d_id >= 0).count()).sum();
    let mean = if images.is_empty() { 0.0 } else { observations as f64 / images.len() as f64 };
    let mut s = String::new();
    s.push_str("# Image list with two lines of data per image:\n");
    s.push_str("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
    s.push_str("#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
    let _ = writeln!(s, "# Number of images: {}, mean observations per image: {mean}", images.len());
    for im in images {
        let _ = write!(s, "{}", im.id);
        for v in im.qvec.iter().chain(&im.tvec) {
            let _ = write!(s, " {v:?}");
        }
        let _ = writeln!(s, " {} {}", im.camera_id, im.name);
        let mut first = true;
        for k in &im.keypoints {
            let sep = if first { "" } else { " " };
            first = false;
            let _ = write!(s, "{sep}{:?} {:?} {}", k.xy.x, k.xy.y, k.point3d_id);
        }
        s.push('\n');
    }
    s
}

fn format_points(points: &[SparsePoint]) -> String {
    let total_track: usize = points.iter().map(|p| p.track.len()).sum();
    let mean = if points.is_empty() { 0.0 } else { total_track as f64 / points.len() as f64 };
    let mut s = String::new();
    s.push_str("# 3D point list with one line of data per point:\n");
    s.push_str("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
    let _ = writeln!(s, "# Number of points: {}, mean track length: {mean}", points.len());
    for p in points {
        let [r, g, b] = p.rgb;
        let _ = write!(s, "{} {:?} {:?} {:?} {r} {g} {b} {:?}", p.id, p.xyz.x, p.xyz.y, p.xyz.z, p.error);
        for (image_id, idx) in &p.track {
            let _ = write!(s, " {image_id} {idx}");
        }
        s.push('\n');
    }
    s
}

//! A small hand-written COLMAP text model (all five camera models, comments, blank lines, an
//! image whose POINTS2D line is empty) and helpers to lay it out as a scene folder.
//!
//! Geometry worked out by hand: camera 1 is PINHOLE f = 100, c = (50, 40). Image 1
//! (`a_front.png`) has identity rotation and t = (0, 0, 5); image 3 (`b_side.png`) is rotated
//! 90° about y (q = (cos 45°, 0, sin 45°, 0)) with t = (0, 0, 6). Point 1 at (1, 0.5, 0) is at
//! (1, 0.5, 5) in camera a → pixel (70, 50), and at (0, 0.5, 5) in camera b → pixel (50, 50).
#![allow(dead_code)]

use splatseg_scene::image_io::{write_png_rgb8, RgbImage};
use std::path::Path;

pub const CAMERAS_TXT: &str = "# Camera list with one line of data per camera:
#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]
# Number of cameras: 5

1 PINHOLE 100 80 100 100 50 40
2 SIMPLE_PINHOLE 64 48 60 32 24
3 SIMPLE_RADIAL 64 48 60 32 24 0.01

4 RADIAL 64 48 60 32 24 0.01 -0.002
5 OPENCV 64 48 61 59 31.5 24.5 0.01 -0.002 0.0005 -0.0003
";

pub const IMAGES_TXT: &str = "# Image list with two lines of data per image:
#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME
#   POINTS2D[] as (X, Y, POINT3D_ID)
# Number of images: 4, mean observations per image: 1
3 0.7071067811865476 0 0.7071067811865476 0 0 0 6 1 b_side.png
50 50 1 10.5 20.25 -1
1 1 0 0 0 0 0 5 1 a_front.png
70 50 1
2 1 0 0 0 0.1 0.2 3 2 c_empty.png

4 0.9 0.1 0.2 0.3 1 2 3 5 sub/d_opencv.png
1.5 2.5 2
";

pub const POINTS3D_TXT: &str = "# 3D point list with one line of data per point:
#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)
# Number of points: 2, mean track length: 1.5
1 1 0.5 0 200 100 50 0.25 1 0 3 0
2 -1 -2 -3 0 0 255 1.5 4 0
";

/// `(image name, width, height)` of the fixture's images at full resolution.
pub const IMAGE_SIZES: [(&str, u32, u32); 4] = [
    ("a_front.png", 100, 80),
    ("b_side.png", 100, 80),
    ("c_empty.png", 64, 48),
    ("sub/d_opencv.png", 64, 48),
];

/// Writes the three text files into `model_dir`.
pub fn write_text_model(model_dir: &Path) {
    std::fs::create_dir_all(model_dir).expect("create model dir");
    for (name, text) in
        [("cameras.txt", CAMERAS_TXT), ("images.txt", IMAGES_TXT), ("points3D.txt", POINTS3D_TXT)]
    {
        std::fs::write(model_dir.join(name), text).expect("write fixture");
    }
}

/// Writes a `width × height` PNG (a colour ramp) at `path`.
pub fn write_png(path: &Path, width: u32, height: u32) {
    std::fs::create_dir_all(path.parent().expect("parent")).expect("create dir");
    let data =
        (0..height).flat_map(|y| (0..width).flat_map(move |x| [(x * 2) as u8, (y * 3) as u8, 90])).collect();
    let img = RgbImage::from_vec(width as usize, height as usize, data).expect("sized");
    write_png_rgb8(path, &img).expect("write png");
}

/// A COLMAP scene folder: `root/sparse/0/*.txt` and `root/images/*.png` at full resolution.
pub fn write_scene(root: &Path) {
    write_text_model(&root.join("sparse").join("0"));
    for (name, w, h) in IMAGE_SIZES {
        write_png(&root.join("images").join(name), w, h);
    }
}

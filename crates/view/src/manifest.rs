//! The scene description the page reads first (`/api/scene.json`): counts, chunking, objects,
//! cameras, per-view files. Objects are numbered by *slot* (their index in `objects`), which is
//! what the binary layout and the page's id pass carry, so sparse or negative ids cost nothing.

use crate::pack::{BYTES_PER_GAUSSIAN, CHUNK_GAUSSIANS};
use crate::source::ViewSource;
use serde::Serialize;
use splatseg_edit::{palette_colour, UnlabelledStyle};
use splatseg_scene::{Camera, Gaussians, Pose};

/// One object as the page's panel lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectEntry {
    /// Object id (`object_id` of the PLY; −1 = unlabelled Gaussians).
    pub id: i32,
    /// Palette colour, the same as the overlays (`splatseg_scene::labels::colour_of_id`; grey for −1).
    pub colour: [u8; 3],
    /// Number of Gaussians.
    pub count: u64,
    /// Smallest x, y, z of their centres.
    pub bbox_min: [f32; 3],
    /// Largest x, y, z of their centres.
    pub bbox_max: [f32; 3],
    /// Its best match among the names of `view --names` (left out without them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// The relevancy of that name to the object, in (0, 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name_relevancy: Option<f32>,
}

/// A pinhole camera in the page's terms (OpenCV axes, pixel-corner origin, `CONVENTIONS.md`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CameraEntry {
    /// Image stem, or `"overview"` for the camera made up without a scene.
    pub name: String,
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Focal lengths and principal point, px.
    pub fx: f64,
    /// See `fx`.
    pub fy: f64,
    /// See `fx`.
    pub cx: f64,
    /// See `fx`.
    pub cy: f64,
    /// `world_from_cam` as the top three rows of the 4×4 matrix, row-major.
    pub world_from_cam: [[f64; 4]; 3],
}

/// One capture view in the page's strip.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewEntry {
    /// Image stem.
    pub stem: String,
    /// URL of its overlay image, when there is one.
    pub overlay: Option<String>,
    /// True when its label map can be queried at `/api/label/<view>/<x>/<y>`.
    pub has_labels: bool,
}

/// Everything the page needs before fetching Gaussians.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Manifest {
    /// File name of the PLY.
    pub name: String,
    /// Number of Gaussians.
    pub gaussians: usize,
    /// Gaussians per chunk (`/api/gaussians/<k>.bin`); the last one may be shorter.
    pub chunk_gaussians: usize,
    /// Number of chunks.
    pub chunks: usize,
    /// Bytes per Gaussian in a chunk.
    pub bytes_per_gaussian: usize,
    /// Bounding box of all centres, min and max.
    pub bbox: [[f32; 3]; 2],
    /// True when the PLY carries `object_id` (export needs it).
    pub labelled: bool,
    /// Objects by slot.
    pub objects: Vec<ObjectEntry>,
    /// The capture's cameras (or one overview camera), the first is the start view.
    pub cameras: Vec<CameraEntry>,
    /// True when `cameras` are the capture's (false: one made-up overview camera).
    pub capture_cameras: bool,
    /// Per capture view, the strip's images.
    pub views: Vec<ViewEntry>,
    /// Folder exports are written to.
    pub export_dir: String,
    /// True when `/api/find` ranks objects against a text query (left out when false).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub search: bool,
    /// Editing (a run's output folder, `crate::editing`): the run's identity and the operations
    /// of its `edits.json` (left out when the served PLY is not a run's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub editing: Option<crate::editing::EditingEntry>,
}

/// Object slots: `[N]` slot per Gaussian and the object entries by slot (ids ascending).
pub fn object_slots(g: &Gaussians) -> (Vec<u32>, Vec<ObjectEntry>) {
    match &g.object_ids {
        Some(ids) if ids.len() == g.len() => slots_of_ids(ids, &g.means),
        _ => slots_of_ids(&vec![-1; g.len()], &g.means),
    }
}

/// [`object_slots`] of `[N]` ids and centres (an edit's preview).
pub fn slots_of_ids(ids: &[i32], means: &[[f32; 3]]) -> (Vec<u32>, Vec<ObjectEntry>) {
    let mut distinct = ids.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    let mut objects: Vec<ObjectEntry> = distinct
        .iter()
        .map(|&id| ObjectEntry {
            id,
            colour: palette_colour(id, UnlabelledStyle::Grey).unwrap_or([128, 128, 128]),
            count: 0,
            bbox_min: [f32::INFINITY; 3],
            bbox_max: [f32::NEG_INFINITY; 3],
            name: None,
            name_relevancy: None,
        })
        .collect();
    let slots: Vec<u32> = ids
        .iter()
        .zip(means)
        .map(|(id, p)| {
            let slot = distinct.binary_search(id).unwrap_or(0);
            let o = &mut objects[slot];
            o.count += 1;
            o.bbox_min = [0, 1, 2].map(|k| o.bbox_min[k].min(p[k]));
            o.bbox_max = [0, 1, 2].map(|k| o.bbox_max[k].max(p[k]));
            slot as u32
        })
        .collect();
    (slots, objects)
}

fn camera_entry(name: &str, camera: &Camera, pose: &Pose) -> CameraEntry {
    let rows = pose.to_rows();
    CameraEntry {
        name: name.to_string(),
        width: camera.width,
        height: camera.height,
        fx: camera.fx,
        fy: camera.fy,
        cx: camera.cx,
        cy: camera.cy,
        world_from_cam: [rows[0], rows[1], rows[2]],
    }
}

/// A 960×720 camera looking along +z at the centre of `bbox` from far enough to see all of it.
fn overview_camera(bbox: [[f32; 3]; 2]) -> CameraEntry {
    let centre = [0, 1, 2].map(|k| 0.5 * (bbox[0][k] + bbox[1][k]) as f64);
    let radius = (0..3).map(|k| (bbox[1][k] - bbox[0][k]) as f64).fold(0.0, f64::max).max(1e-3);
    let (width, height, f) = (960, 720, 800.0);
    CameraEntry {
        name: "overview".to_string(),
        width,
        height,
        fx: f,
        fy: f,
        cx: width as f64 / 2.0,
        cy: height as f64 / 2.0,
        world_from_cam: [
            [1.0, 0.0, 0.0, centre[0]],
            [0.0, 1.0, 0.0, centre[1]],
            [0.0, 0.0, 1.0, centre[2] - 1.5 * radius],
        ],
    }
}

/// The manifest of `source` (`objects` from [`object_slots`]).
pub fn build(source: &ViewSource, objects: Vec<ObjectEntry>) -> Manifest {
    let g = &source.gaussians;
    let mut bbox = [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
    for p in &g.means {
        for k in 0..3 {
            bbox[0][k] = bbox[0][k].min(p[k]);
            bbox[1][k] = bbox[1][k].max(p[k]);
        }
    }
    let (cameras, capture_cameras) = match &source.scene {
        Some(scene) if !scene.views.is_empty() => (
            scene.views.iter().map(|v| camera_entry(&v.stem, scene.camera(v), &v.world_from_cam)).collect(),
            true,
        ),
        _ => (vec![overview_camera(bbox)], false),
    };
    let views = source
        .views
        .iter()
        .enumerate()
        .map(|(i, v)| ViewEntry {
            stem: v.stem.clone(),
            overlay: v.overlay.as_ref().map(|_| format!("/views/{i}/overlay.png")),
            has_labels: v.mask.is_some(),
        })
        .collect();
    Manifest {
        name: source.ply_path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default(),
        gaussians: g.len(),
        chunk_gaussians: CHUNK_GAUSSIANS,
        chunks: g.len().div_ceil(CHUNK_GAUSSIANS),
        bytes_per_gaussian: BYTES_PER_GAUSSIAN,
        bbox,
        labelled: g.object_ids.is_some(),
        objects,
        cameras,
        capture_cameras,
        views,
        export_dir: source.export_dir.display().to_string(),
        search: false,
        editing: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_number_the_sorted_distinct_ids() {
        let g = Gaussians {
            means: vec![[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [-1.0, 5.0, 0.0], [4.0, 4.0, 4.0]],
            object_ids: Some(vec![9, -1, 9, 2]),
            ..Gaussians::default()
        };
        let (slots, objects) = object_slots(&g);
        assert_eq!(slots, vec![2, 0, 2, 1]);
        assert_eq!(objects.iter().map(|o| o.id).collect::<Vec<_>>(), vec![-1, 2, 9]);
        assert_eq!(objects[2].count, 2);
        assert_eq!(objects[2].bbox_min, [-1.0, 0.0, 0.0]);
        assert_eq!(objects[2].bbox_max, [0.0, 5.0, 0.0]);
        assert_eq!(objects[2].colour, splatseg_scene::labels::colour_of_id(9));
    }

    #[test]
    fn an_unlabelled_ply_is_one_object() {
        let g = Gaussians { means: vec![[0.0; 3]; 3], ..Gaussians::default() };
        let (slots, objects) = object_slots(&g);
        assert_eq!(slots, vec![0, 0, 0]);
        assert_eq!(objects.len(), 1);
        assert_eq!(objects[0].count, 3);
    }
}

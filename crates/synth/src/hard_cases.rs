//! Where the paper's hard cases show up, measured on the rendered ground truth (written to
//! `gt/objects.json` so users and tests can find the views that matter).

use crate::layout::{HardCase, ObjectKind, SceneObject};
use crate::render::RenderedView;
use crate::sam_sim::touching;
use serde::{Deserialize, Serialize};
use splatseg_scene::Plane;

/// Share of an object's on-ray pixels hidden behind another surface above which a view counts
/// as occluding it.
pub const OCCLUDED_FRACTION: f64 = 0.1;

/// A pair of objects in one view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairInView {
    /// View index.
    pub view: usize,
    /// Some pixel of one is 4-adjacent to a pixel of the other.
    pub touching: bool,
    /// Mean metric z of each object's visible pixels.
    pub mean_depth_m: [f64; 2],
    /// Visible pixels of each.
    pub area_px: [usize; 2],
}

/// A pair of objects forming a hard case, and the views where both are visible.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairCase {
    /// The two ids.
    pub ids: [u32; 2],
    /// Views where both are visible.
    pub views: Vec<PairInView>,
}

/// An object partly hidden behind another surface in a view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Occlusion {
    /// View index.
    pub view: usize,
    /// Object id.
    pub id: u32,
    /// Hidden pixels / (hidden + visible pixels).
    pub hidden_fraction: f64,
}

/// An object touching the image border in a view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameCut {
    /// View index.
    pub view: usize,
    /// Object id.
    pub id: u32,
    /// Its pixels on the border rows/columns.
    pub border_px: usize,
}

/// All hard cases of a scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HardCases {
    /// The white-on-white pair (same appearance, different depths).
    pub white_on_white: PairCase,
    /// The same-depth pair of different colours.
    pub same_depth_pair: PairCase,
    /// Objects (not floor/walls) with at least [`OCCLUDED_FRACTION`] hidden, per view.
    pub occlusions: Vec<Occlusion>,
    /// Objects (not floor/walls) cut by the image frame, per view.
    pub frame_cuts: Vec<FrameCut>,
}

fn ids_with(objects: &[SceneObject], tag: HardCase) -> [u32; 2] {
    let mut ids = objects.iter().filter(|o| o.tags.contains(&tag)).map(|o| o.id);
    [ids.next().unwrap_or(0), ids.next().unwrap_or(0)]
}

fn pair_case(ids: [u32; 2], views: &[RenderedView]) -> PairCase {
    let views = views
        .iter()
        .enumerate()
        .filter_map(|(v, r)| {
            let stats = ids.map(|id| depth_stats(&r.instance, &r.depth_z, id));
            (stats[0].1 > 0 && stats[1].1 > 0).then(|| PairInView {
                view: v,
                touching: touching(&r.instance, ids),
                mean_depth_m: [stats[0].0, stats[1].0],
                area_px: [stats[0].1, stats[1].1],
            })
        })
        .collect();
    PairCase { ids, views }
}

/// Mean depth and pixel count of instance `id`.
fn depth_stats(instance: &Plane<u32>, depth: &Plane<f32>, id: u32) -> (f64, usize) {
    let (sum, n) = instance
        .data
        .iter()
        .zip(&depth.data)
        .filter(|(&i, _)| i == id)
        .fold((0.0, 0usize), |(s, n), (_, &z)| (s + z as f64, n + 1));
    (if n > 0 { sum / n as f64 } else { 0.0 }, n)
}

fn border_pixels(instance: &Plane<u32>, id: u32) -> usize {
    let (w, h) = instance.size();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| (x == 0 || y == 0 || x + 1 == w || y + 1 == h) && *instance.get(x, y) == id)
        .count()
}

/// Measures the hard cases on the rendered views.
pub fn find_hard_cases(objects: &[SceneObject], views: &[RenderedView]) -> HardCases {
    let mut occlusions = Vec::new();
    let mut frame_cuts = Vec::new();
    let movable = objects.iter().filter(|o| !matches!(o.kind, ObjectKind::Floor | ObjectKind::Wall));
    for (v, r) in views.iter().enumerate() {
        for o in movable.clone() {
            let visible = r.instance.data.iter().filter(|&&i| i == o.id).count();
            let hidden = r.hidden_px[(o.id - 1) as usize] as usize;
            let fraction = hidden as f64 / (hidden + visible).max(1) as f64;
            if visible > 0 && fraction >= OCCLUDED_FRACTION {
                occlusions.push(Occlusion { view: v, id: o.id, hidden_fraction: fraction });
            }
            let border_px = border_pixels(&r.instance, o.id);
            if border_px > 0 {
                frame_cuts.push(FrameCut { view: v, id: o.id, border_px });
            }
        }
    }
    HardCases {
        white_on_white: pair_case(ids_with(objects, HardCase::WhiteOnWhite), views),
        same_depth_pair: pair_case(ids_with(objects, HardCase::SameDepthPair), views),
        occlusions,
        frame_cuts,
    }
}

impl crate::SynthScene {
    /// One line per hard case: which objects, and in which views (what `splatseg synth` prints).
    pub fn hard_case_lines(&self) -> String {
        let scene = self;
        let stems = |views: Vec<usize>| {
            views.into_iter().map(|v| scene.views[v].stem.clone()).collect::<Vec<_>>().join(" ")
        };
        let name =
            |id: u32| scene.objects.get((id as usize).wrapping_sub(1)).map_or("?", |o| o.name.as_str());
        let names = |mut ids: Vec<u32>| {
            ids.sort_unstable();
            ids.dedup();
            ids.iter().map(|&id| name(id)).collect::<Vec<_>>().join(", ")
        };
        let hc = &scene.hard_cases;
        let pair = |p: &PairCase| {
            format!(
                "{} + {}, touching in: {}",
                name(p.ids[0]),
                name(p.ids[1]),
                stems(p.views.iter().filter(|v| v.touching).map(|v| v.view).collect())
            )
        };
        format!(
            "  white-on-white pair: {}\n  same-depth pair:     {}\n  occluded objects:    {}\n  \
         cut by the frame:    {}\n  details per view: gt/objects.json\n",
            pair(&hc.white_on_white),
            pair(&hc.same_depth_pair),
            names(hc.occlusions.iter().map(|o| o.id).collect()),
            names(hc.frame_cuts.iter().map(|c| c.id).collect()),
        )
    }
}

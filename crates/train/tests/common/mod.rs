//! Training views built from a synthetic scene, shared by the train tests.
#![allow(dead_code)]

use splatseg_render::RenderCamera;
use splatseg_synth::SynthScene;
use splatseg_train::TrainView;

/// One training view per synthetic view: its camera, its image in [0, 1], and (with
/// `with_labels`) its ground-truth instance map as the label map (what `run`'s final maps
/// approximate).
pub fn synthetic_views(s: &SynthScene, with_labels: bool) -> Vec<TrainView> {
    s.scene
        .views
        .iter()
        .zip(&s.views)
        .map(|(view, synth)| TrainView {
            name: synth.stem.clone(),
            camera: RenderCamera::from_scene(s.scene.camera(view), &view.world_from_cam),
            image: synth.image.data.iter().flat_map(|p| p.map(|c| f32::from(c) / 255.0)).collect(),
            labels: with_labels.then(|| synth.gt_instance.data.clone()),
        })
        .collect()
}

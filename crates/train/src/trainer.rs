//! The training loop: one view per iteration, 3DGS's schedule (SH degree steps, densification window,
//! opacity resets, position learning-rate decay), and from the end of densification the paper's joint
//! optimisation of the object features.

use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use splatseg_eval::photometric::{psnr, ssim};
use splatseg_render::{
    render, render_bwd, render_with_state, FeatureInput, OutputGrads, RenderCamera, RenderRequest,
};
use splatseg_scene::Gaussians;

use crate::config::{ReadBack, TrainConfig};
use crate::densify::{densify_and_prune, reset_opacity, DensifyReport, DensifyStats, DensifyStep};
use crate::error::{TrainError, TrainResult};
use crate::identity::{identity_loss, vote_winners, Classifier, IdentityClasses};
use crate::joint::{assign_ids, knn_regulariser, semantic_loss, ObjectCodes};
use crate::knn::knn;
use crate::loss::render_loss;
use crate::optimizer::{GaussianAdam, StepRates};
use crate::readback::rendered_votes;
use crate::sampling::standard_normal;

/// One training or test image.
#[derive(Clone, Debug)]
pub struct TrainView {
    /// Name for reports (the image stem).
    pub name: String,
    /// Its camera.
    pub camera: RenderCamera,
    /// `[H, W, 3]` colour in [0, 1], composited on the configured background.
    pub image: Vec<f32>,
    /// `[H, W]` the view's final label map (global ids, 0 = unlabelled) for the identity maps' 2D
    /// supervision; `None` = no 2D supervision from this view.
    pub labels: Option<Vec<u32>>,
}

/// Reported to the progress callback after every iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainingProgress {
    /// 1-based iteration.
    pub iteration: usize,
    /// `L_render` of this iteration's view.
    pub render_loss: f64,
    /// `L_semantic` (0 before the joint stage).
    pub semantic_loss: f64,
    /// `L_3D-reg` (0 before the joint stage).
    pub reg_loss: f64,
    /// Cross-entropy of the classified identity map against the view's label map (0 when not rendered).
    pub identity_loss: f64,
    /// Gaussians now.
    pub gaussians: usize,
}

/// PSNR / SSIM of one view.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ViewQuality {
    /// View name.
    pub name: String,
    /// dB (3DGS's definition: MSE over all pixels and channels of the [0, 1]-clamped render).
    pub psnr: f64,
    /// 3DGS's SSIM.
    pub ssim: f64,
}

/// What [`train`] returns.
#[derive(Clone, Debug)]
pub struct Trained {
    /// The optimised Gaussians; `object_ids` hold the ids read back from the object features when the
    /// joint stage ran (else whatever came in, carried through densification).
    pub gaussians: Gaussians,
    /// `[N, D]` object features (empty when the joint stage did not run: off, no lifted ids, or training
    /// ended before densification did).
    pub object_features: Vec<f32>,
    /// Object-feature width D (0 when the joint stage did not run).
    pub feature_dim: usize,
    /// Every densification step, in order.
    pub densify_reports: Vec<(usize, DensifyReport)>,
    /// Every read-back the joint stage could compute (`[N]` ids each, −1 = none); `gaussians.object_ids`
    /// holds the one `config.joint.readback` chose.
    pub readbacks: Vec<(ReadBack, Vec<i32>)>,
    /// The last progress record.
    pub last: Option<TrainingProgress>,
}

/// 3DGS's scene radius: 1.1 × the largest distance of a camera centre from their mean.
pub fn cameras_extent(views: &[TrainView]) -> f64 {
    let centres: Vec<[f64; 3]> = views
        .iter()
        .map(|v| {
            let c = v.camera.centre_f32();
            [f64::from(c[0]), f64::from(c[1]), f64::from(c[2])]
        })
        .collect();
    let n = centres.len().max(1) as f64;
    let mean: Vec<f64> = (0..3).map(|a| centres.iter().map(|c| c[a]).sum::<f64>() / n).collect();
    let radius = centres
        .iter()
        .map(|c| (0..3).map(|a| (c[a] - mean[a]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    // a single camera (or coincident ones) still needs a positive scale
    1.1 * radius.max(1e-3)
}

/// Trains `gaussians` on `views`. When `config.joint.enabled` and `gaussians.object_ids` is set (the
/// lifted ids, −1 = unreliable), the object features join the optimisation once densification ends and
/// the returned ids are read back from them. With `config.joint.identity_maps` and views carrying
/// `labels`, the features are also rendered into identity maps, classified and supervised in 2D
/// ([`crate::identity`]), and the ids are read back as `config.joint.readback` says (every read-back
/// is returned in [`Trained::readbacks`]). `progress` is called after every iteration.
pub fn train(
    gaussians: Gaussians,
    views: &[TrainView],
    config: &TrainConfig,
    progress: &(dyn Fn(&TrainingProgress) + Sync),
) -> TrainResult<Trained> {
    train_with_checkpoints(gaussians, views, config, progress, &mut |_, _| Ok(()))
}

/// [`train`], also handing the Gaussians to `checkpoint` after each iteration listed in
/// `config.save_iterations` that comes before the last (their `object_id`s are still the lifted ones).
pub fn train_with_checkpoints(
    gaussians: Gaussians,
    views: &[TrainView],
    config: &TrainConfig,
    progress: &(dyn Fn(&TrainingProgress) + Sync),
    checkpoint: &mut dyn FnMut(usize, &Gaussians) -> TrainResult<()>,
) -> TrainResult<Trained> {
    config.validate()?;
    if views.is_empty() {
        return Err(TrainError::Input("no training views".into()));
    }
    if gaussians.is_empty() {
        return Err(TrainError::Input("no Gaussians to train".into()));
    }
    for v in views {
        let expected = v.camera.pixel_count() * 3;
        if v.image.len() != expected {
            return Err(TrainError::Input(format!(
                "view `{}`: image has {} values, its camera needs {expected}",
                v.name,
                v.image.len()
            )));
        }
        if let Some(labels) = &v.labels {
            if labels.len() != v.camera.pixel_count() {
                return Err(TrainError::Input(format!(
                    "view `{}`: label map has {} pixels, its camera {}",
                    v.name,
                    labels.len(),
                    v.camera.pixel_count()
                )));
            }
        }
    }
    let mut g = gaussians;
    let extent = cameras_extent(views);
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed);
    let joint = config.joint.enabled && g.object_ids.is_some();
    let dim = if joint { config.joint.feature_dim } else { 0 };
    let codes = g.object_ids.as_deref().filter(|_| joint).map(|ids| ObjectCodes::new(ids, dim, config.seed));
    let mut features: Vec<f32> =
        (0..g.len() * dim).map(|_| standard_normal(&mut rng) * config.joint.init_std as f32).collect();
    // the 2D term: classes from the label maps and the lifted ids, a classifier seeded by the codes
    let identity = config.joint.identity_maps && views.iter().any(|v| v.labels.is_some());
    let mut classifier = match (identity, codes.as_ref(), g.object_ids.as_deref()) {
        (true, Some(codes), Some(ids)) => {
            let classes = IdentityClasses::new(views.iter().filter_map(|v| v.labels.as_deref()), ids);
            Some((Classifier::from_codes(&classes, codes), classes))
        }
        _ => None,
    };
    let view_classes: Vec<Option<Vec<u32>>> =
        views.iter().map(|v| Some(classifier.as_ref()?.1.classes_of_map(v.labels.as_deref()?))).collect();
    let mut adam = GaussianAdam::new(&g, dim);
    let mut stats = DensifyStats::new(g.len());
    let mut reports = Vec::new();
    let mut order: Vec<usize> = Vec::new();
    let mut neighbours: Vec<u32> = Vec::new();
    let mut last = None;

    for iteration in 1..=config.iterations {
        if order.is_empty() {
            order = (0..views.len()).collect();
            order.shuffle(&mut rng);
        }
        let view_index = order.pop().unwrap_or(0);
        let view = &views[view_index];
        let degree = (iteration / config.sh_degree_interval).min(usize::from(g.sh_degree)) as u8;
        let joint_active = joint && iteration >= config.densify.until;
        // the identity map is rendered with the colour, in the same blend, once the features are live
        let supervised = match (&classifier, &view_classes[view_index]) {
            (Some((c, _)), Some(classes)) if joint_active => Some((c, classes)),
            _ => None,
        };
        let request = RenderRequest {
            background: config.background,
            sh_degree: Some(degree),
            features: supervised.map(|_| FeatureInput { values: &features, dim }),
            ..RenderRequest::default()
        };
        let (out, state) = render_with_state(&g, &view.camera, &request)?;
        let rgb = out.rgb.ok_or_else(|| TrainError::Input("the rasteriser returned no colour".into()))?;
        let (w, h) = (view.camera.width as usize, view.camera.height as usize);
        let photometric = render_loss(&rgb, &view.image, w, h, config.lambda_dssim)?;
        let identity_term = match (supervised, out.features.as_deref()) {
            (Some((c, classes)), Some(map)) => {
                Some(identity_loss(map, classes, c, config.joint.lambda_identity as f32))
            }
            _ => None,
        };
        let grads = OutputGrads {
            rgb: Some(&photometric.grad),
            features: identity_term.as_ref().map(|t| &t.d_map[..]),
            ..OutputGrads::default()
        };
        let gaussian_grads = render_bwd(&g, &view.camera, &request, &state, &grads)?;

        let densifying = iteration < config.densify.until;
        if densifying {
            stats.add_view(&state, &gaussian_grads, view.camera.width, view.camera.height);
        }
        let mut feature_grads = match (&identity_term, &gaussian_grads.features) {
            (Some(_), Some(f)) => f.clone(),
            _ if joint_active => vec![0f32; features.len()],
            _ => Vec::new(),
        };
        if let (Some(term), Some((c, _))) = (&identity_term, classifier.as_mut()) {
            c.step(&term.d_classifier, config.lr.classifier as f32);
        }
        let (mut semantic, mut reg) = (0.0, 0.0);
        if let (true, Some(codes), Some(ids)) = (joint_active, codes.as_ref(), g.object_ids.as_deref()) {
            if neighbours.len() != g.len() * config.joint.knn
                || (iteration - config.densify.until).is_multiple_of(config.joint.knn_refresh_interval)
            {
                neighbours = knn(&g.means, config.joint.knn);
            }
            let (lambda_s, lambda_reg) =
                (config.joint.lambda_semantic as f32, config.joint.lambda_reg as f32);
            semantic = semantic_loss(&features, ids, codes, lambda_s, &mut feature_grads);
            reg = knn_regulariser(&features, &neighbours, config.joint.knn, lambda_reg, &mut feature_grads);
        }
        let rates = StepRates {
            means: (config.position_lr(iteration) * extent) as f32,
            sh_dc: config.lr.sh_dc as f32,
            sh_rest: config.lr.sh_rest as f32,
            opacity: config.lr.opacity as f32,
            scaling: config.lr.scaling as f32,
            rotation: config.lr.rotation as f32,
            features: if joint_active { config.lr.object_features as f32 } else { 0.0 },
        };
        let feature_step = joint_active.then_some((&mut features[..], &feature_grads[..]));
        adam.step(&mut g, &gaussian_grads, feature_step, &rates);

        if densifying {
            let d = &config.densify;
            if iteration > d.from && iteration.is_multiple_of(d.interval) {
                let step =
                    DensifyStep { config: d, extent, prune_large: iteration > d.opacity_reset_interval };
                let (report, fresh) =
                    densify_and_prune(&mut g, &mut features, dim, &mut adam, &stats, &step, &mut rng);
                tracing::debug!(iteration, ?report, gaussians = g.len(), "densified");
                reports.push((iteration, report));
                stats = fresh;
                if g.is_empty() {
                    return Err(TrainError::Input(format!(
                        "every Gaussian was pruned at iteration {iteration} (opacities below {})",
                        d.min_opacity
                    )));
                }
            }
            if iteration.is_multiple_of(d.opacity_reset_interval) {
                reset_opacity(&mut g, &mut adam, d.reset_opacity);
            }
        }
        let record = TrainingProgress {
            iteration,
            render_loss: photometric.loss,
            semantic_loss: semantic,
            reg_loss: reg,
            identity_loss: identity_term.as_ref().map_or(0.0, |t| t.loss),
            gaussians: g.len(),
        };
        progress(&record);
        last = Some(record);
        if iteration < config.iterations && config.save_iterations.contains(&iteration) {
            checkpoint(iteration, &g)?;
        }
    }

    // the joint stage ran only if training reached the end of densification
    let joint_ran = joint && config.iterations >= config.densify.until;
    let mut readbacks = Vec::new();
    if let (true, Some(codes)) = (joint_ran, codes.as_ref()) {
        readbacks.push((
            ReadBack::NearestCode,
            assign_ids(&features, codes, config.joint.assign_min_cosine as f32),
        ));
        if let Some((c, classes)) = &classifier {
            let own: Vec<i32> = c.classify(&features).iter().map(|&k| classes.id_of(k as usize)).collect();
            let cameras: Vec<&RenderCamera> = views.iter().map(|v| &v.camera).collect();
            let votes = rendered_votes(&g, &features, c, &cameras)?;
            let rendered = vote_winners(&votes, c.classes)
                .iter()
                .zip(&own)
                .map(|(winner, &fallback)| winner.map_or(fallback, |k| classes.id_of(k)))
                .collect();
            readbacks.push((ReadBack::Classifier, own));
            readbacks.push((ReadBack::Rendered, rendered));
        }
        let chosen = readbacks
            .iter()
            .find(|(kind, _)| *kind == config.joint.readback)
            .or(readbacks.first())
            .map(|(_, ids)| ids.clone());
        g.object_ids = chosen;
    }
    let (object_features, feature_dim) = if joint_ran { (features, dim) } else { (Vec::new(), 0) };
    Ok(Trained { gaussians: g, object_features, feature_dim, densify_reports: reports, readbacks, last })
}

/// PSNR and SSIM of the Gaussians rendered (all SH degrees, clamped to [0, 1] as 3DGS's evaluation
/// does) against each view's image, in parallel over views.
pub fn evaluate_views(
    gaussians: &Gaussians,
    views: &[TrainView],
    background: [f32; 3],
) -> TrainResult<Vec<ViewQuality>> {
    views
        .par_iter()
        .map(|v| {
            let request = RenderRequest { background, ..RenderRequest::default() };
            let mut rgb = render(gaussians, &v.camera, &request)?
                .rgb
                .ok_or_else(|| TrainError::Input("the rasteriser returned no colour".into()))?;
            rgb.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0));
            let (w, h) = (v.camera.width as usize, v.camera.height as usize);
            Ok(ViewQuality {
                name: v.name.clone(),
                psnr: psnr(&rgb, &v.image, w, h, 3)?,
                ssim: ssim(&rgb, &v.image, w, h, 3)?,
            })
        })
        .collect()
}

//! `splatseg bench identity`: on a synthetic scene with ground truth, the joint stage with the 3D
//! terms only against the 3D terms plus the 2D identity maps (each read-back), next to the lifted ids,
//! as one Markdown table (the numbers in `BENCHMARKS.md`).

use crate::error::Context;
use splatseg_eval::{evaluate_folders, label_accuracy_3d, read_gaussian_ids_npy, Metrics};
use splatseg_train::{ReadBack, TrainConfig};
use std::path::Path;

use super::train_stage::{readback_name, run_training, TrainRun, TrainSummary};
use super::PipelineConfig;

/// One row of the table.
struct Row {
    name: String,
    metrics: Metrics,
    psnr: f64,
    ssim: f64,
}

/// Trains the run's lifted Gaussians twice (`iterations` each, joint from `joint_from`): 3D terms only,
/// then 3D terms + identity maps, and scores every result against the scene's ground truth.
/// `lifted`: the pipeline's own metrics of its final maps.
pub fn identity_study(
    scene_dir: &Path,
    run_out: &Path,
    lifted: &Metrics,
    out: &Path,
    config: &TrainConfig,
    options: crate::RunOptions,
) -> crate::Result<String> {
    let eval = PipelineConfig::default().eval;
    let gt_maps = scene_dir.join("gt").join("instance");
    let gt_ids = read_gaussian_ids_npy(&scene_dir.join("gt").join("gaussian_ids.npy"))?;
    let train = |identity_maps: bool, dir: &str| -> crate::Result<TrainSummary> {
        let mut config = config.clone();
        config.joint.identity_maps = identity_maps;
        run_training(&TrainRun {
            scene: scene_dir.to_path_buf(),
            gaussians: Some(run_out.join("gaussians.ply")),
            init: Default::default(),
            out: out.join(dir),
            config,
            resolution: 1,
            label_maps: None,
            options,
        })
        .with_context(|| format!("training {dir}"))
    };
    let score = |masks: &Path, ids: &[i32]| -> crate::Result<Metrics> {
        let mut m = evaluate_folders(&gt_maps, masks, &eval)?;
        m.label_accuracy_3d = Some(label_accuracy_3d(&gt_ids, ids)?);
        Ok(m)
    };
    let only_3d = train(false, "train_3d")?;
    let with_2d = train(true, "train_2d")?;
    let mut rows = vec![Row {
        name: "lifted ids (run)".into(),
        metrics: lifted.clone(),
        psnr: only_3d.test_before.psnr,
        ssim: only_3d.test_before.ssim,
    }];
    let ids_of = |s: &TrainSummary, kind: ReadBack| {
        s.readback_ids
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, ids)| ids.clone())
            .context("read-back missing")
    };
    rows.push(Row {
        name: "3D terms only (nearest code)".into(),
        metrics: score(&only_3d.out.join("masks"), &ids_of(&only_3d, ReadBack::NearestCode)?)?,
        psnr: only_3d.test_after.psnr,
        ssim: only_3d.test_after.ssim,
    });
    for kind in [ReadBack::NearestCode, ReadBack::Classifier, ReadBack::Rendered] {
        let name = readback_name(kind);
        let masks = with_2d.out.join("readback").join(name).join("masks");
        rows.push(Row {
            name: format!("3D + 2D identity maps ({name})"),
            metrics: score(&masks, &ids_of(&with_2d, kind)?)?,
            psnr: with_2d.test_after.psnr,
            ssim: with_2d.test_after.ssim,
        });
    }
    Ok(table(&rows))
}

fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| ids | mIoU | boundary mIoU | consistency | #masks | 3D accuracy | unlabelled | held-out PSNR | SSIM |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for r in rows {
        let m = &r.metrics;
        let (acc, unlabelled) =
            m.label_accuracy_3d.as_ref().map_or((f64::NAN, 0), |a| (a.accuracy, a.unlabelled_predictions));
        s += &format!(
            "| {} | {:.3} | {:.3} | {:.3} | {} | {:.3} | {} | {:.2} | {:.3} |\n",
            r.name, m.miou, m.boundary_miou, m.consistency, m.pred_masks, acc, unlabelled, r.psnr, r.ssim
        );
    }
    s
}

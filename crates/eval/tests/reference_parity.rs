//! Metrics against values computed independently with SciPy (`linear_sum_assignment`,
//! `binary_dilation`/`binary_erosion` with a disk) by `tools/fixtures/make_eval_fixtures.py`.

use serde::Deserialize;
use splatseg_eval::{label_accuracy_3d, EvalConfig, Metrics, ViewCounts};
use splatseg_scene::Plane;

#[derive(Deserialize)]
struct Fixture {
    band_radius_px: u32,
    cases: Vec<Case>,
    accuracy_3d: Vec<Accuracy>,
}

#[derive(Deserialize)]
struct Case {
    views: Vec<View>,
    expected: Expected,
}

#[derive(Deserialize)]
struct View {
    name: String,
    width: usize,
    height: usize,
    gt: Vec<u32>,
    pred: Vec<u32>,
}

#[derive(Deserialize)]
struct Expected {
    gt_instances: usize,
    pred_masks: usize,
    miou: f64,
    boundary_miou: f64,
    consistency: f64,
    per_view_miou: f64,
    instances: Vec<ExpectedInstance>,
}

#[derive(Deserialize)]
struct ExpectedInstance {
    gt_id: u32,
    matched_pred: Option<u32>,
    iou: f64,
    boundary_iou: f64,
    consistency: f64,
}

#[derive(Deserialize)]
struct Accuracy {
    gt_ids: Vec<i64>,
    pred_ids: Vec<i32>,
    accuracy: f64,
}

fn fixture() -> Fixture {
    let text = include_str!("fixtures/metrics_reference.json");
    serde_json::from_str(text).expect("fixture parses")
}

fn close(what: &str, got: f64, want: f64) {
    assert!((got - want).abs() <= 1e-9 + 1e-9 * want.abs(), "{what}: got {got}, SciPy {want}");
}

#[test]
fn label_map_metrics_match_scipy() {
    let fx = fixture();
    let cfg = EvalConfig { band_radius_px: fx.band_radius_px, ..EvalConfig::default() };
    for (k, case) in fx.cases.iter().enumerate() {
        let counts: Vec<ViewCounts> = case
            .views
            .iter()
            .map(|v| {
                let gt = Plane::from_vec(v.width, v.height, v.gt.clone()).unwrap();
                let pred = Plane::from_vec(v.width, v.height, v.pred.clone()).unwrap();
                ViewCounts::compute(&v.name, &gt, &pred, &cfg).unwrap()
            })
            .collect();
        let m = Metrics::from_views(&counts, &cfg).unwrap();
        let e = &case.expected;
        assert_eq!((m.gt_instances, m.pred_masks), (e.gt_instances, e.pred_masks), "case {k}");
        close(&format!("case {k} mIoU"), m.miou, e.miou);
        close(&format!("case {k} boundary mIoU"), m.boundary_miou, e.boundary_miou);
        close(&format!("case {k} consistency"), m.consistency, e.consistency);
        close(&format!("case {k} per-view mIoU"), m.per_view_miou.unwrap(), e.per_view_miou);
        for (got, want) in m.instances.iter().zip(&e.instances) {
            let what = format!("case {k} instance {}", want.gt_id);
            assert_eq!((got.gt_id, got.matched_pred), (want.gt_id, want.matched_pred), "{what}");
            close(&format!("{what} IoU"), got.iou, want.iou);
            close(&format!("{what} boundary IoU"), got.boundary_iou, want.boundary_iou);
            close(&format!("{what} consistency"), got.consistency, want.consistency);
        }
    }
}

#[test]
fn label_accuracy_3d_matches_scipy() {
    for (k, a) in fixture().accuracy_3d.iter().enumerate() {
        let got = label_accuracy_3d(&a.gt_ids, &a.pred_ids).unwrap();
        close(&format!("accuracy case {k}"), got.accuracy, a.accuracy);
    }
}

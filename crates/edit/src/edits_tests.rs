//! `edits.json`: the format round-trips, bad files are refused naming the file, and each
//! operation changes exactly the ids it selects.

use crate::edit_ops::{apply_operations, EditBase};
use crate::edits::{
    centres_digest, check_inputs, parse_edits, read_edits, write_edits, Box3, EditInputs, Edits, LassoCamera,
    Operation, EDITS_VERSION,
};
use crate::EditError;
use splatseg_scene::{Camera, Pose};
use std::collections::BTreeSet;
use std::path::Path;

fn inputs() -> EditInputs {
    EditInputs { gaussians: 6, ply_digest: "00ff".into(), run: "abc".into() }
}

fn every_operation() -> Vec<Operation> {
    vec![
        Operation::Merge { ids: vec![3, 7], into: Some(7) },
        Operation::SplitBox {
            object: 5,
            region: Box3 {
                centre: [0.0, 0.5, 1.0],
                half_size: [0.25, 0.5, 1.0],
                rotation: Some([1.0, 0.0, 0.0, 0.0]),
            },
            new_id: None,
        },
        Operation::SplitLasso {
            object: 2,
            camera: LassoCamera::View { view: 1 },
            polygon_px: vec![[0.0, 0.0], [10.0, 0.5], [4.0, 8.0]],
            new_id: Some(40),
        },
        Operation::SplitLasso {
            object: 2,
            camera: LassoCamera::Pinhole {
                fx: 100.0,
                fy: 100.0,
                cx: 50.0,
                cy: 40.0,
                world_from_cam: [
                    [1.0, 0.0, 0.0, 0.5],
                    [0.0, 1.0, 0.0, 0.0],
                    [0.0, 0.0, 1.0, -2.0],
                    [0.0, 0.0, 0.0, 1.0],
                ],
            },
            polygon_px: vec![[0.0, 0.0], [10.0, 0.5], [4.0, 8.0]],
            new_id: None,
        },
        Operation::Assign { ranges: vec![[0, 2], [4, 5]], id: -1 },
        Operation::Rename { id: 7, name: "chair \"left\" ✓".into() },
    ]
}

#[test]
fn every_operation_round_trips_through_the_file() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let path = tmp.path().join("edits.json");
    let edits = Edits { version: EDITS_VERSION, inputs: inputs(), operations: every_operation() };
    write_edits(&path, &edits).expect("write");
    let text = std::fs::read_to_string(&path).expect("read");
    assert!(text.contains("\"op\": \"split_lasso\"") && text.contains("\"view\": 1"), "{text}");
    assert_eq!(read_edits(&path).expect("read back"), edits);
    // A hand-written file with the optional fields left out reads too.
    let hand = r#"{"version": 1, "inputs": {"gaussians": 6, "ply_digest": "00ff", "run": "abc"},
        "operations": [{"op": "merge", "ids": [3, 7]},
                       {"op": "split_box", "object": 5, "box": {"centre": [0, 0, 0], "half_size": [1, 1, 1]}}]}"#;
    let read = parse_edits(hand, Path::new("OUT/edits.json")).expect("parses");
    assert_eq!(read.operations[0], Operation::Merge { ids: vec![3, 7], into: None });
}

#[test]
fn malformed_unknown_and_future_files_are_refused_naming_the_file() {
    let path = Path::new("OUT/edits.json");
    let cases = [
        ("{\"version\": 1, \"inputs\": ", "not a valid edits file"),
        ("{\"inputs\": {}}", "no \"version\""),
        (
            r#"{"version": 2, "inputs": {}, "operations": [{"op": "paint"}]}"#,
            "version 2 were written by a later splatseg",
        ),
        (
            r#"{"version": 1, "inputs": {"gaussians": 1, "ply_digest": "a", "run": "b"}, "operations": [{"op": "paint"}]}"#,
            "unknown variant `paint`",
        ),
        (
            r#"{"version": 1, "inputs": {"gaussians": 1, "ply_digest": "a", "run": "b"}, "operations": [{"op": "merge", "ids": [1, 2], "int": 1}]}"#,
            "unknown field `int`",
        ),
    ];
    for (text, expected) in cases {
        let err = parse_edits(text, path).expect_err(text).to_string();
        assert!(err.contains(expected) && err.ends_with("OUT/edits.json"), "{text}: {err}");
    }
}

#[test]
fn edits_of_another_ply_or_run_are_refused_naming_what_changed() {
    let edits = Edits { version: 1, inputs: inputs(), operations: vec![] };
    let path = Path::new("OUT/edits.json");
    assert!(check_inputs(&edits, &inputs(), path).is_ok());
    let other_ply = EditInputs { ply_digest: "1234".into(), ..inputs() };
    let err = check_inputs(&edits, &other_ply, path).expect_err("other PLY").to_string();
    assert!(err.contains("made on a PLY with digest 00ff, this run's is 1234"), "{err}");
    let other_run = EditInputs { run: "xyz".into(), ..inputs() };
    let err = check_inputs(&edits, &other_run, path).expect_err("other run").to_string();
    assert!(err.contains("made on run abc, this run is xyz"), "{err}");
    assert!(err.contains(r#"this run's inputs are "inputs": {"gaussians":"#), "{err}");
    assert!(err.contains(r#""run":"xyz"}"#), "names this run's inputs to copy: {err}");
    assert_ne!(centres_digest(&[[0.0, 0.0, 1.0]]), centres_digest(&[[0.0, 0.0, -1.0]]));
}

/// Six Gaussians on the x axis at x = 0..6, ids 1 1 2 2 3 3.
fn base_ids() -> (Vec<i32>, Vec<[f32; 3]>) {
    (vec![1, 1, 2, 2, 3, 3], (0..6).map(|i| [i as f32, 0.0, 4.0]).collect())
}

fn apply(ops: Vec<Operation>) -> Result<crate::Edited, EditError> {
    let (ids, means) = base_ids();
    let camera = Camera::pinhole(1, 64, 48, 10.0, 10.0, 0.0, 24.0);
    let views = [(&camera, &Pose::IDENTITY)];
    let map_only = BTreeSet::from([9]);
    let base = EditBase { ids: &ids, means: &means, map_only_ids: &map_only, views: &views };
    apply_operations(&base, &ops, Path::new("OUT/edits.json"))
}

#[test]
fn operations_change_exactly_what_they_select() {
    let merged = apply(vec![Operation::Merge { ids: vec![3, 1], into: None }]).expect("merge");
    assert_eq!(merged.ids, vec![1, 1, 2, 2, 1, 1]);
    assert_eq!(merged.object_became(3), 1);
    let boxed = Box3 { centre: [3.0, 0.0, 4.0], half_size: [0.4, 1.0, 1.0], rotation: None };
    let split =
        apply(vec![Operation::SplitBox { object: 2, region: boxed.clone(), new_id: None }]).expect("split");
    assert_eq!(split.ids, vec![1, 1, 2, 10, 3, 3], "the new id follows the largest in use (9, in the maps)");
    // Turned 90° about z, the box's long axis lies along x and takes both of object 2's Gaussians.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let turned =
        Box3 { centre: [2.5, 0.0, 4.0], half_size: [0.1, 0.9, 1.0], rotation: Some([h, 0.0, 0.0, h]) };
    let split =
        apply(vec![Operation::SplitBox { object: 2, region: turned, new_id: Some(20) }]).expect("split");
    assert_eq!(split.ids, vec![1, 1, 20, 20, 3, 3]);
    // The camera at the origin looking along +z: x = i lands at u = 10 i / 4 px.
    let lasso = Operation::SplitLasso {
        object: 3,
        camera: LassoCamera::View { view: 0 },
        polygon_px: vec![[11.0, 0.0], [13.0, 0.0], [13.0, 48.0], [11.0, 48.0]],
        new_id: None,
    };
    assert_eq!(apply(vec![lasso]).expect("lasso").ids, vec![1, 1, 2, 2, 3, 10]);
    let assigned = apply(vec![
        Operation::Assign { ranges: vec![[0, 1], [3, 4]], id: 12 },
        Operation::Merge { ids: vec![12, 2], into: Some(12) },
        Operation::Rename { id: 12, name: "table".into() },
    ])
    .expect("assign, merge the new object, name it");
    assert_eq!(assigned.ids, vec![12, 1, 12, 12, 3, 3]);
    assert_eq!(assigned.names.get(&12).map(String::as_str), Some("table"));
    assert_eq!(assigned.changed_rows, 3);
}

#[test]
fn an_operation_selecting_something_absent_is_named_by_its_index() {
    let cases = [
        (vec![Operation::Merge { ids: vec![1, 4], into: None }], "operation 0 (merge): no object has id 4"),
        (
            vec![
                Operation::Merge { ids: vec![1, 2], into: None },
                Operation::Rename { id: 2, name: "x".into() },
            ],
            "operation 1 (rename): no object has id 2",
        ),
        (vec![Operation::Assign { ranges: vec![[4, 7]], id: 1 }], "operation 0 (assign): the range [4, 7)"),
        (
            vec![Operation::SplitLasso {
                object: 1,
                camera: LassoCamera::View { view: 3 },
                polygon_px: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
                new_id: None,
            }],
            "view 3 is not a view of the scene",
        ),
        (
            vec![Operation::SplitBox {
                object: 1,
                region: Box3 { centre: [9.0; 3], half_size: [0.1; 3], rotation: None },
                new_id: None,
            }],
            "no Gaussian of object 1 has its centre inside",
        ),
        (
            vec![Operation::SplitBox {
                object: 1,
                region: Box3 { centre: [0.0, 0.0, 4.0], half_size: [0.1; 3], rotation: None },
                new_id: Some(3),
            }],
            "id 3 is already an object's",
        ),
    ];
    for (ops, expected) in cases {
        let err = apply(ops).expect_err(expected).to_string();
        assert!(err.contains(expected) && err.ends_with("OUT/edits.json"), "{expected}: {err}");
    }
}

#[test]
fn edits_written_by_hand_without_inputs_are_refused_naming_this_runs() {
    let path = Path::new("OUT/edits.json");
    let text = r#"{"version": 1, "operations": [{"op": "merge", "ids": [1, 2]}]}"#;
    let edits = parse_edits(text, path).expect("inputs may be left out of the file");
    let err = check_inputs(&edits, &inputs(), path).expect_err("no inputs").to_string();
    assert!(err.contains(r#"do not name the run they were made on (no "inputs")"#), "{err}");
    let this_run = serde_json::to_string(&inputs()).expect("json");
    assert!(err.contains(&this_run), "the inputs to copy in: {err}");
    // Copied in, they pass.
    let fixed: Edits = serde_json::from_str(&text.replacen('{', &format!("{{\"inputs\": {this_run}, "), 1))
        .expect("with the inputs");
    assert!(check_inputs(&fixed, &inputs(), path).is_ok());
}

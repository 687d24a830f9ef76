//! `edits.json`: the format round-trips, bad files are refused naming the file, and each
//! operation changes exactly the ids it selects.

use crate::edit_ops::{apply_operations, EditBase};
use crate::edits::{
    centres_digest, check_inputs, parse_edits, read_edits, write_edits, Box3, EditInputs, Edits, LassoCamera,
    MoveTarget, NeighbourStep, NewObject, Operation, SelectPart, Selection,
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
        Operation::Move { select: every_part(), to: MoveTarget::New(NewObject::New) },
        Operation::Move {
            select: Selection {
                objects: None,
                parts: vec![SelectPart::Rows { ranges: vec![[1, 2]] }],
                neighbours: vec![],
            },
            to: MoveTarget::Id(-1),
        },
        Operation::Rename { id: 7, name: "chair \"left\" ✓".into() },
    ]
}

fn every_part() -> Selection {
    Selection {
        objects: Some(vec![2, -1]),
        parts: vec![
            SelectPart::Brush {
                camera: LassoCamera::View { view: 0 },
                stroke_px: vec![[1.0, 2.0], [3.5, 4.0]],
                radius_px: 2.5,
            },
            SelectPart::Lasso {
                camera: LassoCamera::View { view: 1 },
                polygon_px: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            },
            SelectPart::Box { region: Box3 { centre: [0.0; 3], half_size: [1.0; 3], rotation: None } },
            SelectPart::Rows { ranges: vec![[0, 3]] },
        ],
        neighbours: vec![NeighbourStep::Grow(0.5), NeighbourStep::Shrink(0.25)],
    }
}

#[test]
fn every_operation_round_trips_through_the_file() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let path = tmp.path().join("edits.json");
    let edits = Edits::new(inputs(), every_operation());
    assert_eq!(edits.version, 2, "a move needs version 2");
    write_edits(&path, &edits).expect("write");
    let text = std::fs::read_to_string(&path).expect("read");
    assert!(text.contains("\"op\": \"split_lasso\"") && text.contains("\"view\": 1"), "{text}");
    for written in
        ["\"by\": \"brush\"", "\"radius_px\": 2.5", "\"grow\": 0.5", "\"to\": \"new\"", "\"to\": -1"]
    {
        assert!(text.contains(written), "{written} in {text}");
    }
    assert_eq!(read_edits(&path).expect("read back"), edits);
    // A hand-written file with the optional fields left out reads too.
    let hand = r#"{"version": 1, "inputs": {"gaussians": 6, "ply_digest": "00ff", "run": "abc"},
        "operations": [{"op": "merge", "ids": [3, 7]},
                       {"op": "split_box", "object": 5, "box": {"centre": [0, 0, 0], "half_size": [1, 1, 1]}}]}"#;
    let read = parse_edits(hand, Path::new("OUT/edits.json")).expect("parses");
    assert_eq!(read.operations[0], Operation::Merge { ids: vec![3, 7], into: None });
    // edits without a move are written as version 1, which older splatseg reads
    assert_eq!(Edits::new(inputs(), read.operations).version, 1);
}

#[test]
fn a_move_in_a_version_1_file_is_refused_naming_the_version_it_needs() {
    let text = r#"{"version": 1, "inputs": {"gaussians": 6, "ply_digest": "00ff", "run": "abc"},
        "operations": [{"op": "merge", "ids": [1, 2]},
                       {"op": "move", "select": {"parts": [{"by": "rows", "ranges": [[0, 1]]}]}, "to": 1}]}"#;
    let err = parse_edits(text, Path::new("OUT/edits.json")).expect_err("move is version 2").to_string();
    assert!(
        err.contains("operation 1 (move) needs version 2 of the format, the file says version 1"),
        "{err}"
    );
    let fixed = text.replacen("\"version\": 1", "\"version\": 2", 1);
    assert!(parse_edits(&fixed, Path::new("OUT/edits.json")).is_ok());
}

#[test]
fn malformed_unknown_and_future_files_are_refused_naming_the_file() {
    let path = Path::new("OUT/edits.json");
    let cases = [
        ("{\"version\": 1, \"inputs\": ", "not a valid edits file"),
        ("{\"inputs\": {}}", "no \"version\""),
        (
            r#"{"version": 3, "inputs": {}, "operations": [{"op": "paint"}]}"#,
            "version 3 were written by a later splatseg",
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

fn moved(select: Selection, to: MoveTarget) -> Result<crate::Edited, EditError> {
    apply(vec![Operation::Move { select, to }])
}

fn brush(stroke_px: Vec<[f64; 2]>, radius_px: f64) -> SelectPart {
    SelectPart::Brush { camera: LassoCamera::View { view: 0 }, stroke_px, radius_px }
}

#[test]
fn a_brush_moves_the_gaussians_projecting_within_its_radius_of_the_stroke() {
    // x = i projects to u = 2.5 i px: a stroke from u = 4 to 6 with radius 1.2 px reaches 2.8..7.2,
    // that is x = 2 (5 px); a dot at u = 12.5 with radius 0.1 reaches x = 5 only.
    let stroke = brush(vec![[4.0, 24.0], [6.0, 24.0]], 1.2);
    let one = |parts| Selection { objects: None, parts, neighbours: vec![] };
    let to_one = moved(one(vec![stroke.clone()]), MoveTarget::Id(1)).expect("to object 1");
    assert_eq!(to_one.ids, vec![1, 1, 1, 2, 3, 3]);
    let dot = brush(vec![[12.5, 24.0]], 0.1);
    let to_new =
        moved(one(vec![stroke.clone(), dot]), MoveTarget::New(NewObject::New)).expect("to a new object");
    assert_eq!(to_new.ids, vec![1, 1, 10, 2, 3, 10], "the new id follows 9, which the maps show");
    // a wide stroke limited to object 2's Gaussians
    let wide = brush(vec![[0.0, 24.0], [20.0, 24.0]], 3.0);
    let limited = Selection { objects: Some(vec![2]), parts: vec![wide], neighbours: vec![] };
    assert_eq!(moved(limited, MoveTarget::Id(-1)).expect("to none").ids, vec![1, 1, -1, -1, 3, 3]);
}

#[test]
fn grow_and_shrink_steps_replay_the_same_selection() {
    // from the Gaussian at x = 2, grown twice by 1 among objects 1 and 2: x = 0..3, not object 3's x = 4
    let seed = || vec![SelectPart::Rows { ranges: vec![[2, 3]] }];
    let grown = Selection {
        objects: Some(vec![1, 2]),
        parts: seed(),
        neighbours: vec![NeighbourStep::Grow(1.0), NeighbourStep::Grow(1.0)],
    };
    assert_eq!(moved(grown.clone(), MoveTarget::Id(3)).expect("grown").ids, vec![3, 3, 3, 3, 3, 3]);
    let unlimited = Selection { objects: None, ..grown.clone() };
    assert_eq!(moved(unlimited, MoveTarget::Id(9)).expect("grown").ids, vec![9, 9, 9, 9, 9, 3]);
    // rows 1..5 shrunk by 1: 1 and 4 touch unselected 0 and 5
    let shrunk = Selection {
        objects: None,
        parts: vec![SelectPart::Rows { ranges: vec![[1, 5]] }],
        neighbours: vec![NeighbourStep::Shrink(1.0)],
    };
    assert_eq!(moved(shrunk, MoveTarget::New(NewObject::New)).expect("shrunk").ids, vec![1, 1, 10, 10, 3, 3]);
    // the same edits twice: the same ids
    assert_eq!(
        moved(grown.clone(), MoveTarget::Id(3)).expect("again"),
        moved(grown, MoveTarget::Id(3)).expect("again")
    );
}

#[test]
fn a_bad_move_is_named_and_changes_nothing() {
    let rows = |ranges| SelectPart::Rows { ranges };
    let sel = |parts, neighbours| Selection { objects: None, parts, neighbours };
    let cases = [
        (
            moved(sel(vec![brush(vec![[4.0, 24.0]], 0.0)], vec![]), MoveTarget::Id(1)),
            "a brush needs a finite radius above 0 px, got 0",
        ),
        (moved(sel(vec![brush(vec![[4.0, 24.0]], -2.0)], vec![]), MoveTarget::Id(1)), "got -2"),
        (
            moved(sel(vec![brush(vec![], 3.0)], vec![]), MoveTarget::Id(1)),
            "a brush stroke needs at least one finite point, got 0",
        ),
        (
            moved(sel(vec![rows(vec![[0, 1]])], vec![]), MoveTarget::Id(4)),
            "the target: no object has id 4 here",
        ),
        (moved(sel(vec![], vec![]), MoveTarget::Id(1)), "the selection has no part"),
        (moved(sel(vec![rows(vec![[0, 9]])], vec![]), MoveTarget::Id(1)), "the range [0, 9) is not"),
        (
            moved(sel(vec![rows(vec![[0, 1]])], vec![NeighbourStep::Grow(0.0)]), MoveTarget::Id(1)),
            "a finite radius above 0 (world units), got 0",
        ),
        (
            moved(sel(vec![rows(vec![[0, 1]])], vec![NeighbourStep::Shrink(f64::NAN)]), MoveTarget::Id(1)),
            "got NaN",
        ),
        (
            moved(sel(vec![brush(vec![[400.0, 24.0]], 1.0)], vec![]), MoveTarget::Id(1)),
            "the selection holds no Gaussian",
        ),
        (
            moved(
                Selection { objects: Some(vec![5]), parts: vec![rows(vec![[0, 1]])], neighbours: vec![] },
                MoveTarget::Id(1),
            ),
            "the selection names object 5, which is not here",
        ),
        (
            moved(sel(vec![rows(vec![[0, 1]])], vec![NeighbourStep::Grow(1.0); 65]), MoveTarget::Id(1)),
            "65 grow and shrink steps, at most 64",
        ),
    ];
    for (result, expected) in cases {
        let err = result.expect_err(expected).to_string();
        assert!(
            err.contains("operation 0 (move)") && err.contains(expected) && err.ends_with("OUT/edits.json"),
            "{expected}: {err}"
        );
    }
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

#[test]
fn the_readmes_example_parses() {
    let readme = include_str!("../../../README.md");
    let start = readme.find("```json\n{\n  \"version\"").expect("the README shows an edits.json");
    let block = &readme[start + "```json\n".len()..];
    let text = &block[..block.find("```").expect("the block ends")];
    let edits = parse_edits(text, Path::new("README.md")).expect("the README's example parses");
    let kinds: Vec<&str> = edits.operations.iter().map(Operation::kind).collect();
    assert_eq!(kinds, ["merge", "split_box", "split_lasso", "assign", "move", "rename"]);
    assert_eq!(Edits::new(edits.inputs.clone(), edits.operations.clone()).version, edits.version);
}

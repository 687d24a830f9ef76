//! The edit endpoints on the pure request → reply path (`wire::exchange` on bytes): saving
//! `edits.json` only from the page (token and `Origin`), bounded, well-formed and of this run;
//! the preview applies the operations as `splatseg apply` does.

use crate::editing::EditSetup;
use crate::fuzzing::{request_bytes, site, ADDR, TOKEN};
use splatseg_edit::edits::{centres_digest, read_edits};
use splatseg_edit::{EditInputs, Operation};
use std::path::Path;
use std::sync::{Arc, Mutex};

fn status(reply: &[u8]) -> u16 {
    std::str::from_utf8(&reply[9..12]).ok().and_then(|s| s.parse().ok()).unwrap_or(0)
}

fn body(reply: &[u8]) -> Vec<u8> {
    let end = reply.windows(4).position(|w| w == b"\r\n\r\n").expect("head") + 4;
    reply[end..].to_vec()
}

fn text(reply: &[u8]) -> String {
    String::from_utf8_lossy(&body(reply)).into_owned()
}

fn post(path: &str, json: &str, origin: Option<&str>, token: Option<&str>) -> Vec<u8> {
    let mut head = format!("POST {path} HTTP/1.1\r\nHost: {ADDR}\r\nContent-Length: {}\r\n", json.len());
    if let Some(origin) = origin {
        head.push_str(&format!("Origin: {origin}\r\n"));
    }
    if let Some(token) = token {
        head.push_str(&format!("X-Splatseg-Token: {token}\r\n"));
    }
    format!("{head}\r\n{json}").into_bytes()
}

fn page() -> String {
    format!("http://{ADDR}")
}

/// The three Gaussians of `fuzzing::site` (objects 1, 2, 1 at x = 0, 1, 2) as a run in `dir`
/// (`dir/edits.json`), whose identity `identity` says at save time.
fn editing_site(
    dir: &Path,
    identity: Arc<Mutex<EditInputs>>,
) -> (crate::Site, crate::access::Access, EditInputs) {
    let (mut site, access) = site(dir.to_path_buf());
    let inputs = EditInputs {
        gaussians: 3,
        ply_digest: centres_digest(&site.source().gaussians.means),
        run: "run-key-1".to_string(),
    };
    *identity.lock().expect("lock") = inputs.clone();
    let setup = EditSetup {
        inputs: inputs.clone(),
        base_ids: None,
        map_only_ids: Default::default(),
        edits_path: dir.join("edits.json"),
        identity_now: Box::new(move || Ok(identity.lock().expect("lock").clone())),
    };
    site.enable_editing(setup).expect("editing on");
    (site, access, inputs)
}

fn save_json(inputs: &EditInputs, operations: &str) -> String {
    format!(r#"{{"inputs":{},"operations":{operations}}}"#, serde_json::to_string(inputs).expect("json"))
}

const MERGE_AND_NAME: &str = r#"[{"op":"merge","ids":[1,2]},{"op":"rename","id":1,"name":"chair"}]"#;

#[test]
fn saving_needs_the_token_and_the_pages_origin_and_writes_nothing_otherwise() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, inputs) = editing_site(tmp.path(), identity);
    let json = save_json(&inputs, MERGE_AND_NAME);
    let edits = tmp.path().join("edits.json");
    for (request, why) in [
        (post("/api/edits", &json, Some(&page()), None), "no token"),
        (post("/api/edits", &json, Some(&page()), Some("00112233445566778899aabbccddeefe")), "wrong token"),
        (post("/api/edits", &json, None, Some(TOKEN)), "no Origin"),
        (post("/api/edits", &json, Some("http://evil.example"), Some(TOKEN)), "foreign Origin"),
    ] {
        let reply = request_bytes(&site, &access, &request);
        assert_eq!(status(&reply), 403, "{why}: {}", text(&reply));
        assert!(!edits.exists(), "{why}: edits.json was written");
    }
    let reply = request_bytes(&site, &access, &post("/api/edits", &json, Some(&page()), Some(TOKEN)));
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    let saved = read_edits(&edits).expect("the saved file reads as edits");
    assert_eq!(saved.inputs, inputs);
    assert_eq!(
        saved.operations,
        vec![
            Operation::Merge { ids: vec![1, 2], into: None },
            Operation::Rename { id: 1, name: "chair".to_string() }
        ]
    );
}

#[test]
fn oversized_malformed_invalid_or_foreign_edits_are_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, inputs) = editing_site(tmp.path(), Arc::clone(&identity));
    let edits = tmp.path().join("edits.json");
    let send =
        |json: &str| request_bytes(&site, &access, &post("/api/edits", json, Some(&page()), Some(TOKEN)));
    // a long list is taken (a long name here), one over the edits' limit is not
    let long = save_json(&inputs, &format!(r#"[{{"op":"rename","id":1,"name":"{}"}}]"#, "x".repeat(70_000)));
    let reply = send(&long);
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    std::fs::remove_file(&edits).expect("remove");
    let limit = crate::routes::MAX_EDITS_BODY_BYTES;
    let huge = save_json(&inputs, &format!(r#"[{{"op":"rename","id":1,"name":"{}"}}]"#, "x".repeat(limit)));
    let reply = send(&huge);
    assert_eq!(status(&reply), 413, "{}", text(&reply));
    let reply = send("{\"inputs\": ");
    assert_eq!(status(&reply), 400);
    assert!(text(&reply).contains("bad edits"), "{}", text(&reply));
    let reply = send(&save_json(&inputs, r#"[{"op":"merge","ids":[1,9]}]"#));
    assert_eq!(status(&reply), 400);
    assert!(
        text(&reply).contains("operation 0 (merge)") && text(&reply).contains("id 9"),
        "{}",
        text(&reply)
    );
    let other = EditInputs { run: "another-run".to_string(), ..inputs.clone() };
    let reply = send(&save_json(&other, MERGE_AND_NAME));
    assert_eq!(status(&reply), 409);
    assert!(text(&reply).contains("another run"), "{}", text(&reply));
    // the run on disk changed since the viewer started
    identity.lock().expect("lock").run = "a-new-run".to_string();
    let reply = send(&save_json(&inputs, MERGE_AND_NAME));
    assert_eq!(status(&reply), 409);
    assert!(text(&reply).contains("changed since the viewer opened it"), "{}", text(&reply));
    assert!(!edits.exists(), "nothing was written");
    *identity.lock().expect("lock") = inputs.clone();
    assert_eq!(status(&send(&save_json(&inputs, MERGE_AND_NAME))), 200);
    // a hand edit since: not replaced
    std::fs::write(&edits, b"{\"version\": 1, \"operations\": []}\n").expect("hand edit");
    let reply = send(&save_json(&inputs, "[]"));
    assert_eq!(status(&reply), 409);
    assert!(text(&reply).contains("changed since the viewer read it"), "{}", text(&reply));
    assert_eq!(std::fs::read(&edits).expect("edits"), b"{\"version\": 1, \"operations\": []}\n");
}

#[test]
fn an_edits_file_of_another_run_is_shown_as_a_note_and_never_replaced() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let foreign =
        br#"{"version": 1, "inputs": {"gaussians": 3, "ply_digest": "0", "run": "x"}, "operations": []}"#;
    std::fs::write(tmp.path().join("edits.json"), foreign).expect("write");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, inputs) = editing_site(tmp.path(), identity);
    let note = site.manifest().editing.as_ref().and_then(|e| e.note.clone()).expect("a note");
    assert!(note.contains("digest 0"), "{note}");
    let reply = request_bytes(
        &site,
        &access,
        &post("/api/edits", &save_json(&inputs, "[]"), Some(&page()), Some(TOKEN)),
    );
    assert_eq!(status(&reply), 409, "{}", text(&reply));
    assert_eq!(std::fs::read(tmp.path().join("edits.json")).expect("edits"), foreign);
    // moved away: saved
    std::fs::remove_file(tmp.path().join("edits.json")).expect("move away");
    let reply = request_bytes(
        &site,
        &access,
        &post("/api/edits", &save_json(&inputs, "[]"), Some(&page()), Some(TOKEN)),
    );
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    let again = request_bytes(
        &site,
        &access,
        &post("/api/edits", &save_json(&inputs, MERGE_AND_NAME), Some(&page()), Some(TOKEN)),
    );
    assert_eq!(status(&again), 200, "{}", text(&again));
}

#[test]
fn an_edits_file_of_this_run_is_where_the_page_starts() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, inputs) = editing_site(tmp.path(), Arc::clone(&identity));
    let json = save_json(&inputs, MERGE_AND_NAME);
    assert_eq!(
        status(&request_bytes(&site, &access, &post("/api/edits", &json, Some(&page()), Some(TOKEN)))),
        200
    );
    // the manifest served says what was saved; a viewer started again starts from the file
    let reply = request_bytes(
        &site,
        &access,
        format!("GET /api/scene.json HTTP/1.1\r\nHost: {ADDR}\r\n\r\n").as_bytes(),
    );
    let manifest: serde_json::Value = serde_json::from_slice(&body(&reply)).expect("json");
    assert_eq!(manifest["editing"]["operations"].as_array().map(Vec::len), Some(2), "{manifest}");
    let (site, _, _) = editing_site(tmp.path(), identity);
    let entry = site.manifest().editing.clone().expect("editing");
    assert_eq!(entry.operations.len(), 2);
    assert_eq!(entry.note, None);
}

/// The preview: the ids after the operations, as objects by slot and a slot per Gaussian.
#[test]
fn the_preview_applies_the_operations_to_the_runs_ids() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, _) = editing_site(tmp.path(), identity);
    let ops = r#"{"operations":[{"op":"split_box","object":1,"box":{"centre":[2,2,2],"half_size":[0.5,0.5,0.5]}},{"op":"rename","id":3,"name":"lamp"}]}"#;
    let reply = request_bytes(&site, &access, &post("/api/edits/preview", ops, Some(&page()), Some(TOKEN)));
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    let bytes = body(&reply);
    let length = u32::from_le_bytes(bytes[..4].try_into().expect("4 bytes")) as usize;
    let head: serde_json::Value = serde_json::from_slice(&bytes[4..4 + length]).expect("json");
    let start = (4 + length).div_ceil(4) * 4;
    let slots: Vec<u32> =
        bytes[start..].chunks_exact(4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes"))).collect();
    let ids: Vec<i64> =
        head["objects"].as_array().expect("objects").iter().map(|o| o["id"].as_i64().expect("id")).collect();
    assert_eq!(ids, [1, 2, 3]);
    assert_eq!(slots, [0, 1, 2], "the Gaussian at (2, 2, 2) is the new object 3");
    assert_eq!(head["objects"][2]["name"], "lamp");
    assert_eq!(head["changed"], 1);
    assert_eq!(head["next_id"], 4, "a new object after 3");
    let bad = r#"{"operations":[{"op":"rename","id":7,"name":"x"}]}"#;
    let reply = request_bytes(&site, &access, &post("/api/edits/preview", bad, Some(&page()), Some(TOKEN)));
    assert_eq!(status(&reply), 400);
    assert!(text(&reply).contains("operation 0 (rename)"), "{}", text(&reply));
    // a served PLY that is not a run's: no editing, 404
    let (plain, access) = crate::fuzzing::site(tmp.path().to_path_buf());
    let reply = request_bytes(&plain, &access, &post("/api/edits/preview", ops, Some(&page()), Some(TOKEN)));
    assert_eq!(status(&reply), 404);
}

/// Selecting Gaussians by opacity or size among objects, after the page's operations: row ranges.
#[test]
fn gaussians_are_selected_by_opacity_and_size_among_the_objects() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, _) = editing_site(tmp.path(), identity);
    // the three Gaussians: opacity sigmoid(0) = 0.5, scale e^0 = 1
    let ask = |json: &str| {
        request_bytes(&site, &access, &post("/api/edits/select", json, Some(&page()), Some(TOKEN)))
    };
    let reply = ask(r#"{"operations":[],"objects":[1],"opacity_below":0.6}"#);
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    let got: serde_json::Value = serde_json::from_slice(&body(&reply)).expect("json");
    assert_eq!(got, serde_json::json!({ "ranges": [[0, 1], [2, 3]], "count": 2 }), "object 1's rows 0 and 2");
    let merged = r#"{"operations":[{"op":"merge","ids":[1,2]}],"objects":[1],"size_above":0.5}"#;
    let got: serde_json::Value = serde_json::from_slice(&body(&ask(merged))).expect("json");
    assert_eq!(got["ranges"], serde_json::json!([[0, 3]]), "after the merge, all three");
    let got: serde_json::Value =
        serde_json::from_slice(&body(&ask(r#"{"operations":[],"objects":[1],"opacity_below":0.4}"#)))
            .expect("json");
    assert_eq!(got["count"], 0);
    assert_eq!(status(&ask(r#"{"operations":[],"objects":[1]}"#)), 400, "no bound given");
    let unauthorised = request_bytes(&site, &access, &post("/api/edits/select", merged, Some(&page()), None));
    assert_eq!(status(&unauthorised), 403);
}

/// A `move`'s selection, after the page's operations: the rows it holds (the page's highlight),
/// and a saved list holding a move is written as version 2.
#[test]
fn a_selection_grown_by_neighbours_answers_its_rows_and_a_move_saves_as_version_2() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let identity = Arc::new(Mutex::new(EditInputs::default()));
    let (site, access, inputs) = editing_site(tmp.path(), identity);
    let ask = |json: &str| {
        request_bytes(&site, &access, &post("/api/edits/select", json, Some(&page()), Some(TOKEN)))
    };
    // the manifest suggests twice the spacing of the centres (√3 apart)
    let radius = site.manifest().editing.as_ref().and_then(|e| e.neighbour_radius).expect("a radius");
    assert!((radius - 2.0 * 3f64.sqrt()).abs() < 1e-6, "{radius}");
    let seed = r#"{"operations":[],"selection":{"parts":[{"by":"rows","ranges":[[0,1]]}]}}"#;
    let got: serde_json::Value = serde_json::from_slice(&body(&ask(seed))).expect("json");
    assert_eq!(got, serde_json::json!({ "ranges": [[0, 1]], "count": 1 }));
    let grown = r#"{"operations":[],"selection":{"parts":[{"by":"rows","ranges":[[0,1]]}],"neighbours":[{"grow":2.0}]}}"#;
    let got: serde_json::Value = serde_json::from_slice(&body(&ask(grown))).expect("json");
    assert_eq!(got["ranges"], serde_json::json!([[0, 2]]), "grown by one ring: the centre √3 away, not 2√3");
    let within_one = r#"{"operations":[],"selection":{"objects":[1],"parts":[{"by":"rows","ranges":[[0,1]]}],"neighbours":[{"grow":2.0},{"grow":2.0}]}}"#;
    let got: serde_json::Value = serde_json::from_slice(&body(&ask(within_one))).expect("json");
    assert_eq!(
        got["ranges"],
        serde_json::json!([[0, 1]]),
        "object 1's other Gaussian is reached only through object 2's"
    );
    let bad = r#"{"operations":[],"selection":{"parts":[{"by":"brush","camera":{"view":0},"stroke_px":[],"radius_px":3}]}}"#;
    let reply = ask(bad);
    assert_eq!(status(&reply), 400);
    assert!(text(&reply).contains("a brush stroke needs at least one finite point"), "{}", text(&reply));
    let both = r#"{"operations":[],"objects":[1],"opacity_below":0.6,"selection":{"parts":[{"by":"rows","ranges":[[0,1]]}]}}"#;
    assert_eq!(status(&ask(both)), 400, "a filter and a selection at once");
    let save = serde_json::json!({
        "inputs": inputs,
        "operations": [{ "op": "move", "select": { "parts": [{ "by": "rows", "ranges": [[1, 2]] }] }, "to": "new" }],
    })
    .to_string();
    let reply = request_bytes(&site, &access, &post("/api/edits", &save, Some(&page()), Some(TOKEN)));
    assert_eq!(status(&reply), 200, "{}", text(&reply));
    let saved = read_edits(&tmp.path().join("edits.json")).expect("saved");
    assert_eq!((saved.version, saved.operations.len()), (2, 1));
}

//! Benchmark of the viewer's edit endpoints on 1M Gaussians (issue 60: ≤ 200 ms per answer): the
//! whole `POST /api/edits/preview` (the page's operations applied to the run's ids with edit's
//! `apply_operations`, the objects by slot, the reply's 4 MB of slots) for a merge, a box split,
//! a lasso split in a pinhole camera, a list of all of them with a rename, and a `move` of a brush
//! selection (plain, and grown twice and shrunk once by 3D neighbours), through
//! `Site::respond` as the server calls it. Prints a Markdown table for BENCHMARKS.md.
//!
//! `cargo run --release -p splatseg-view --features bench --example edit_bench -- [N]`

use splatseg_edit::edits::centres_digest;
use splatseg_edit::EditInputs;
use splatseg_scene::Gaussians;
use splatseg_view::editing::EditSetup;
use splatseg_view::{Site, ViewSource};
use std::path::PathBuf;
use std::time::Instant;

/// `n` Gaussians with pseudo-random centres in a 2-unit cube, in 100 objects by x–y cell.
fn scene(n: usize) -> Gaussians {
    let mut seed = 0x2545_f491_u64;
    let mut next = move || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut g = Gaussians::default();
    let mut ids = Vec::with_capacity(n);
    for _ in 0..n {
        let p = [2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.0 * next() - 1.0];
        let cell = |v: f32| ((v + 1.0) * 5.0).clamp(0.0, 9.0) as i32;
        ids.push(1 + cell(p[0]) * 10 + cell(p[1]));
        g.means.push(p);
        g.log_scales.push([-5.0; 3]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.raw_opacities.push(0.0);
        g.sh_dc.push([0.0; 3]);
    }
    g.object_ids = Some(ids);
    g
}

fn median_ms(mut run: impl FnMut() -> usize, repeats: usize) -> (f64, usize) {
    let mut times = Vec::new();
    let mut bytes = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        bytes = run();
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], bytes)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args().nth(1).map(|a| a.parse()).transpose()?.unwrap_or(1_000_000);
    let dir = std::env::temp_dir().join(format!("splatseg-edit-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let gaussians = scene(n);
    let inputs =
        EditInputs { gaussians: n as u64, ply_digest: centres_digest(&gaussians.means), run: "bench".into() };
    let source = ViewSource {
        ply_path: PathBuf::from("bench.ply"),
        gaussians,
        scene: None,
        views: Vec::new(),
        export_dir: dir.clone(),
        warnings: Vec::new(),
    };
    let mut site = Site::new(source);
    let identity = inputs.clone();
    site.enable_editing(EditSetup {
        inputs,
        base_ids: None,
        map_only_ids: Default::default(),
        edits_path: dir.join("edits.json"),
        identity_now: Box::new(move || Ok(identity.clone())),
    })?;
    let merge = r#"{"op":"merge","ids":[12,13,22,23]}"#;
    let split_box =
        r#"{"op":"split_box","object":45,"box":{"centre":[-0.1,-0.1,0],"half_size":[0.05,0.05,0.5]}}"#;
    let lasso = r#"{"op":"split_lasso","object":56,"camera":{"fx":800,"fy":800,"cx":480,"cy":360,"world_from_cam":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]]},"polygon_px":[[470,350],[530,352],[520,420],[480,400],[465,380]]}"#;
    let rename = r#"{"op":"rename","id":12,"name":"table"}"#;
    let brush_move = r#"{"op":"move","select":{"objects":[56],"parts":[{"by":"brush","camera":{"fx":800,"fy":800,"cx":480,"cy":360,"world_from_cam":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]]},"stroke_px":[[470,350],[530,352],[520,420]],"radius_px":12}]},"to":"new"}"#;
    let grown_move = r#"{"op":"move","select":{"objects":[56],"parts":[{"by":"brush","camera":{"fx":800,"fy":800,"cx":480,"cy":360,"world_from_cam":[[1,0,0,0],[0,1,0,0],[0,0,1,-3],[0,0,0,1]]},"stroke_px":[[470,350],[530,352],[520,420]],"radius_px":12}],"neighbours":[{"grow":0.02},{"grow":0.02},{"shrink":0.02}]},"to":12}"#;
    let all = format!("{merge},{split_box},{lasso},{rename}");
    println!("| edit preview on {n} Gaussians (100 objects), through Site::respond | median of 9 | reply |");
    println!("| --- | ---: | ---: |");
    for (what, ops) in [
        ("merge of 4 objects", merge),
        ("box split", split_box),
        ("lasso split (pinhole camera, 5 vertices)", lasso),
        ("the three and a rename", all.as_str()),
        ("move: a brush stroke (3 points, 12 px) among one object's Gaussians, to a new object", brush_move),
        ("move: the same stroke grown twice and shrunk once by neighbours within 0.02", grown_move),
    ] {
        let body = format!(r#"{{"operations":[{ops}]}}"#);
        let (ms, bytes) = median_ms(
            || {
                let reply = site.respond("POST", "/api/edits/preview", body.as_bytes());
                assert_eq!(reply.status, 200, "{}", String::from_utf8_lossy(&reply.body));
                reply.body.len()
            },
            9,
        );
        println!("| {what} | {ms:.1} ms | {:.1} MB |", bytes as f64 / 1e6);
    }
    let save = format!(
        r#"{{"inputs":{{"gaussians":{n},"ply_digest":"{}","run":"bench"}},"operations":[{all}]}}"#,
        { site.manifest().editing.as_ref().map(|e| e.inputs.ply_digest.clone()).unwrap_or_default() }
    );
    let (ms, _) = median_ms(
        || {
            let _ = std::fs::remove_file(dir.join("edits.json"));
            let reply = site.respond("POST", "/api/edits", save.as_bytes());
            assert_eq!(reply.status, 200, "{}", String::from_utf8_lossy(&reply.body));
            reply.body.len()
        },
        9,
    );
    println!("| save (checked, then edits.json written) | {ms:.1} ms | |");
    std::fs::remove_dir_all(&dir)?;
    Ok(())
}

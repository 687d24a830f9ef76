//! Issue 61 on the production path: every command that reads Gaussians, run as the binary, given
//! the scene's PLY written as an SPZ, a `.splat`, a `.ksplat` and a compressed PLY by our writers.
//! `run --gaussians`, `view` and `train --gaussians` take each and give the same scene (positions
//! within the format's quantisation, the same objects); `objects`, `extract`, `remove` and
//! `recolor`, which need `object_id` (no compact format holds it), refuse each naming the format and
//! where the ids go, and on the `gaussians.ply` of a run made from it write each format back with
//! the right Gaussians and colours.

use splatseg_scene::gaussians::SH_C0;
use splatseg_scene::splats::{read_gaussians, write_gaussians, SplatFormat};
use splatseg_scene::Gaussians;
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

/// The four compact formats.
const COMPACT: [SplatFormat; 4] =
    [SplatFormat::Spz, SplatFormat::Splat, SplatFormat::Ksplat, SplatFormat::CompressedPly];

fn splatseg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

/// Runs `splatseg ARGS`, which must succeed.
fn ok(args: &[&str]) -> String {
    let out = splatseg(args);
    assert!(out.status.success(), "splatseg {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn utf8(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// A synthetic capture (3 views 160×120, seed 2, its unlabelled `gaussians.ply` and SAM masks)
/// and the scene's Gaussians written by our writers in each compact format, named by its
/// extension (`scene.spz`, …).
struct Capture {
    _tmp: tempfile::TempDir,
    dir: PathBuf,
    scene: PathBuf,
    ply: PathBuf,
    source: Gaussians,
}

impl Capture {
    fn new() -> Capture {
        let tmp = tempfile::tempdir().expect("temp dir");
        let dir = tmp.path().to_path_buf();
        let scene = dir.join("scene");
        ok(&["synth", "--out", utf8(&scene), "--views", "3", "--size", "160x120", "--seed", "2"]);
        let ply = scene.join("gaussians.ply");
        let source = read_gaussians(&ply).expect("the scene's PLY");
        for format in COMPACT {
            write_gaussians(&dir.join(format!("scene{}", format.extension())), &source).expect("written");
        }
        Capture { _tmp: tmp, dir, scene, ply, source }
    }

    fn compact(&self, format: SplatFormat) -> PathBuf {
        self.dir.join(format!("scene{}", format.extension()))
    }

    /// `splatseg run SCENE --masks SCENE/sam [--gaussians FILE] --out OUT`; OUT.
    fn run(&self, gaussians: Option<&Path>, out: &str) -> PathBuf {
        let out = self.dir.join(out);
        let sam = self.scene.join("sam");
        let mut args = vec!["run", utf8(&self.scene), "--masks", utf8(&sam), "--out", utf8(&out), "-q"];
        if let Some(g) = gaussians {
            args.extend(["--gaussians", utf8(g)]);
        }
        ok(&args);
        out
    }
}

/// The largest difference a position may have after `format` stored it: half a quantisation
/// step (SPZ: 12 fractional bits; compressed PLY: 10 or 11 bits of a chunk's range, never larger
/// than the scene's extent), none for the formats that store f32.
fn position_tolerance(format: SplatFormat, source: &Gaussians) -> [f32; 3] {
    match format {
        SplatFormat::Spz => [0.5 / 4096.0 + 1e-6; 3],
        SplatFormat::CompressedPly => [0, 1, 2].map(|a| {
            let (lo, hi) =
                source.means.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p[a]), hi.max(p[a])));
            0.5 * (hi - lo) / 1023.0 + 1e-5
        }),
        _ => [1e-6; 3],
    }
}

/// Asserts that `got[i]` is `want[i]` within `tol` per axis, naming the first row that is not.
fn assert_positions(got: &[[f32; 3]], want: &[[f32; 3]], tol: [f32; 3], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: count");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        for a in 0..3 {
            assert!((g[a] - w[a]).abs() <= tol[a], "{what}: row {i} axis {a}: {} vs {}", g[a], w[a]);
        }
    }
}

/// Per Gaussian, the share whose object in one labelling is the object most of its object's
/// Gaussians have in the other, the smaller of both ways (neither a split nor a merge scores well).
fn label_agreement(a: &[i32], b: &[i32]) -> f64 {
    let one_way = |from: &[i32], to: &[i32]| {
        let mut pairs = BTreeMap::<(i32, i32), usize>::new();
        for (&x, &y) in from.iter().zip(to) {
            *pairs.entry((x, y)).or_default() += 1;
        }
        let mut best = BTreeMap::<i32, usize>::new();
        for (&(x, _), &count) in &pairs {
            let slot = best.entry(x).or_default();
            *slot = (*slot).max(count);
        }
        best.values().sum::<usize>() as f64 / from.len() as f64
    };
    one_way(a, b).min(one_way(b, a))
}

fn object_ids(ply: &Path) -> Vec<i32> {
    read_gaussians(ply).expect("a labelled PLY").object_ids.expect("object_id")
}

#[test]
fn run_labels_each_compact_format_as_it_labels_the_ply() {
    let capture = Capture::new();
    let on_ply = object_ids(&capture.run(None, "out_ply").join("gaussians.ply"));
    for format in COMPACT {
        let input = capture.compact(format);
        let out = capture.run(Some(&input), &format!("out{}", format.extension()));
        let labelled = read_gaussians(&out.join("gaussians.ply")).expect("run's PLY");
        // Every row of the input in its place, as decoded, and so where the PLY had it.
        let decoded = read_gaussians(&input).expect("the compact file");
        assert_eq!(labelled.means, decoded.means, "{}: run's rows are not the file's", format.name());
        let tol = position_tolerance(format, &capture.source);
        assert_positions(&labelled.means, &capture.source.means, tol, format.name());
        let ids = labelled.object_ids.expect("object_id");
        let agreement = label_agreement(&on_ply, &ids);
        eprintln!("{}: per-Gaussian label agreement with the PLY's run {agreement:.4}", format.name());
        assert!(agreement >= 0.99, "{}: agreement {agreement:.4} < 0.99", format.name());
    }
}

#[test]
fn train_starts_from_each_compact_format() {
    let capture = Capture::new();
    let psnr_from = |gaussians: &Path, out: &str| {
        let out = capture.dir.join(out);
        ok(&[
            "train",
            utf8(&capture.scene),
            "--gaussians",
            utf8(gaussians),
            "--iterations",
            "0",
            "--out",
            utf8(&out),
            "-q",
        ]);
        let quality: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("quality.json")).expect("quality.json"))
                .expect("JSON");
        let trained = read_gaussians(&out.join("gaussians.ply")).expect("train's PLY");
        (quality["test_before"]["psnr"].as_f64().expect("a PSNR"), trained)
    };
    let (on_ply, _) = psnr_from(&capture.ply, "train_ply");
    for format in COMPACT {
        let input = capture.compact(format);
        let (psnr, trained) = psnr_from(&input, &format!("train{}", format.extension()));
        // No iteration: what train writes is what it read.
        let decoded = read_gaussians(&input).expect("the compact file");
        assert_eq!(trained.means, decoded.means, "{}", format.name());
        assert_eq!(trained.raw_opacities, decoded.raw_opacities, "{}", format.name());
        let tol = position_tolerance(format, &capture.source);
        assert_positions(&trained.means, &capture.source.means, tol, format.name());
        // The same scene renders the same test view.
        eprintln!("{}: test PSNR {psnr:.3} dB, the PLY's {on_ply:.3} dB", format.name());
        assert!((psnr - on_ply).abs() < 0.1, "{}: PSNR {psnr:.3} vs the PLY's {on_ply:.3}", format.name());
    }
}

/// `splatseg view FILE --listen 127.0.0.1:0`, stopped on drop.
struct Served {
    child: Child,
    url: String,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(file: &Path, scene: &Path) -> Served {
    let mut child = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["view", utf8(file), "--scene", utf8(scene), "--listen", "127.0.0.1:0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("splatseg view starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut served = Served { child, url: String::new() };
    for line in BufReader::new(stdout).lines() {
        if let Some(url) = line.expect("stdout line").strip_prefix("open ") {
            served.url = url.trim_end_matches('/').to_string();
            break;
        }
    }
    assert!(served.url.starts_with("http://127.0.0.1:"), "no URL printed for {}", file.display());
    served
}

fn get(url: &str) -> Vec<u8> {
    let r =
        splatseg_view::browser::http::request("GET", url, None, Duration::from_secs(30)).expect("request");
    assert_eq!(r.status, 200, "{url}");
    r.body
}

#[test]
fn view_serves_each_compact_format_where_the_ply_was() {
    let capture = Capture::new();
    let n = capture.source.len();
    assert!(n <= splatseg_view::pack::CHUNK_GAUSSIANS, "one chunk holds the scene");
    for format in COMPACT {
        let server = serve(&capture.compact(format), &capture.scene);
        let manifest: serde_json::Value =
            serde_json::from_slice(&get(&format!("{}/api/scene.json", server.url))).expect("JSON");
        assert_eq!(manifest["gaussians"].as_u64(), Some(n as u64), "{}", format.name());
        assert_eq!(manifest["cameras"].as_array().map(Vec::len), Some(3), "{}", format.name());
        let chunk = get(&format!("{}/api/gaussians/0.bin", server.url));
        assert_eq!(chunk.len(), n * splatseg_view::pack::BYTES_PER_GAUSSIAN, "{}", format.name());
        let word = |i: usize, k: usize| {
            let at = i * splatseg_view::pack::BYTES_PER_GAUSSIAN + 4 * k;
            u32::from_le_bytes(chunk[at..at + 4].try_into().expect("4 bytes"))
        };
        let centres: Vec<[f32; 3]> = (0..n).map(|i| [0, 1, 2].map(|k| f32::from_bits(word(i, k)))).collect();
        let tol = position_tolerance(format, &capture.source);
        assert_positions(&centres, &capture.source.means, tol, format.name());
        // The colour byte the page draws: within two steps of the PLY's (every format keeps
        // colour to a byte or better).
        for (i, dc) in capture.source.sh_dc.iter().enumerate() {
            let want = dc.map(|c| ((SH_C0 * c + 0.5).clamp(0.0, 1.0) * 255.0).round() as i32);
            let got = [0, 8, 16].map(|shift| ((word(i, 10) >> shift) & 0xff) as i32);
            let off = (0..3).map(|c| (got[c] - want[c]).abs()).max().unwrap_or(0);
            assert!(off <= 2, "{}: colour of {i}: {got:?} vs {want:?}", format.name());
        }
    }
}

#[test]
fn object_commands_refuse_a_compact_file_and_say_where_the_ids_go() {
    let capture = Capture::new();
    for format in COMPACT {
        let input = capture.compact(format);
        let written = capture.dir.join(format!("written{}", format.extension()));
        let name = input.file_name().expect("name").to_string_lossy().into_owned();
        for args in [
            vec!["objects", utf8(&input)],
            vec!["extract", utf8(&input), "--ids", "1", "--out", utf8(&written)],
            vec!["remove", utf8(&input), "--ids", "1", "--out", utf8(&written)],
            vec!["recolor", utf8(&input), "--out", utf8(&written)],
        ] {
            let out = splatseg(&args);
            let err = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{args:?} succeeded");
            assert!(!err.contains("panicked"), "{args:?}: {err}");
            for needle in [name.as_str(), format.name(), "object_id", "--gaussians", "OUT/gaussians.ply"] {
                assert!(err.contains(needle), "{args:?}: {needle:?} not in: {err}");
            }
            assert!(!written.exists(), "{args:?} wrote {}", written.display());
        }
    }
}

/// Reads `path` and, for `format`, the largest colour error (in bytes of 255) a Gaussian of the
/// read file has against `want(i)`, the colour row `i` should have.
fn colour_error(path: &Path, want: impl Fn(usize) -> [u8; 3]) -> f32 {
    let g = read_gaussians(path).expect("written file");
    let mut worst = 0.0f32;
    for (i, dc) in g.sh_dc.iter().enumerate() {
        let colour = dc.map(|c| (SH_C0 * c + 0.5) * 255.0);
        let w = want(i);
        for c in 0..3 {
            worst = worst.max((colour[c] - w[c] as f32).abs());
        }
    }
    worst
}

#[test]
fn extract_remove_and_recolor_of_a_run_on_each_compact_format_write_each_format() {
    let capture = Capture::new();
    for format in COMPACT {
        let out = capture.run(Some(&capture.compact(format)), &format!("out{}", format.extension()));
        let labelled_path = out.join("gaussians.ply");
        let labelled = read_gaussians(&labelled_path).expect("run's PLY");
        let ids = labelled.object_ids.clone().expect("object_id");
        let present: BTreeSet<i32> = ids.iter().copied().filter(|&id| id > 0).collect();
        let chosen: Vec<i32> = present.iter().copied().take(2).collect();
        assert_eq!(chosen.len(), 2, "{}: the run found objects", format.name());
        let chosen_text = chosen.iter().map(i32::to_string).collect::<Vec<_>>().join(",");
        let inside: Vec<usize> = (0..ids.len()).filter(|&i| chosen.contains(&ids[i])).collect();
        let outside: Vec<usize> = (0..ids.len()).filter(|&i| !chosen.contains(&ids[i])).collect();
        for written in COMPACT {
            let tol = position_tolerance(written, &labelled);
            let what = format!("{} run, {} written", format.name(), written.name());
            let from = format.extension().trim_start_matches('.').replace('.', "_");
            let file = |stem: &str| capture.dir.join(format!("{stem}_of_{from}{}", written.extension()));
            let (extracted, removed, painted) = (file("extracted"), file("removed"), file("painted"));
            let ply = utf8(&labelled_path);
            ok(&["extract", ply, "--ids", &chosen_text, "--out", utf8(&extracted)]);
            ok(&["remove", ply, "--ids", &chosen_text, "--out", utf8(&removed)]);
            ok(&["recolor", ply, "--out", utf8(&painted)]);
            let rows = |picked: &[usize]| picked.iter().map(|&i| labelled.means[i]).collect::<Vec<_>>();
            let extracted = read_gaussians(&extracted).expect("extracted file");
            assert_positions(&extracted.means, &rows(&inside), tol, &format!("{what}: extract"));
            let removed = read_gaussians(&removed).expect("removed file");
            assert_positions(&removed.means, &rows(&outside), tol, &format!("{what}: remove"));
            let worst = colour_error(&painted, |i| {
                splatseg_edit::palette_colour(ids[i], splatseg_edit::UnlabelledStyle::Grey)
                    .expect("a colour for every id")
            });
            assert!(worst <= 2.5, "{what}: recolor's colours off by {worst:.2} of 255");
        }
    }
}

//! Issue 28's cases as one table: each row damages a copy of a small synthetic scene (or misuses
//! the command line), runs the binary, and checks what a user sees — the exit status, the file the
//! message names and the words that say what was expected (an error), or the warning on stderr
//! and in `report.md` (a run that goes on with less) — and that no input changed (every file of
//! the scene folder has the bytes it had before the command).

use splatseg_pipeline::digest::folder_digests;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// What a case must give.
enum Expect {
    /// A non-zero exit; stderr contains every string.
    Error(&'static [&'static str]),
    /// Exit 0; stderr and `OUT/report.md` contain every string.
    Warning(&'static [&'static str]),
    /// Exit 0; stdout or stderr contains every string (a command that writes no report).
    Notice(&'static [&'static str]),
}

/// One row: a name, what it does to the scene folder, the command (`SCENE` and `OUT` are replaced
/// by the paths), and what it must give.
struct Case {
    name: &'static str,
    damage: fn(&Path),
    args: &'static [&'static str],
    expect: Expect,
}

fn nothing(_: &Path) {}

fn first_view_json(scene: &Path) -> PathBuf {
    scene.join("sam/view_000.json")
}

fn remove_first_masks(scene: &Path) {
    std::fs::remove_file(first_view_json(scene)).expect("remove the masks");
}

#[cfg(unix)]
fn first_masks_a_fifo(scene: &Path) {
    let path = first_view_json(scene);
    std::fs::remove_file(&path).expect("remove the masks");
    mkfifo(&path);
}

#[cfg(unix)]
fn first_masks_dev_zero(scene: &Path) {
    let path = first_view_json(scene);
    std::fs::remove_file(&path).expect("remove the masks");
    std::os::unix::fs::symlink("/dev/zero", &path).expect("symlink");
}

fn edit(path: &Path, change: impl Fn(&str) -> String) {
    let text = std::fs::read_to_string(path).expect("read");
    std::fs::write(path, change(&text)).expect("write");
}

/// The first two views' SAM JSON with the `area` of their first two masks off by one (a file
/// edited by hand, or written by a tool with another convention): the masks are right, their
/// metadata is not.
fn mask_areas_that_disagree(scene: &Path) {
    for stem in ["view_000", "view_001"] {
        edit(&scene.join(format!("sam/{stem}.json")), |text| {
            let mut out = String::new();
            let mut rest = text;
            for _ in 0..2 {
                let at = rest.find("\"area\":").expect("an area field") + "\"area\":".len();
                let digits = rest[at..].find(|c: char| !c.is_ascii_digit()).expect("the area's end");
                let area: u64 = rest[at..at + digits].parse().expect("an integer area");
                out.push_str(&rest[..at]);
                out.push_str(&(area + 1).to_string());
                rest = &rest[at + digits..];
            }
            out + rest
        });
    }
}

/// `cameras.txt` with a focal length of 0.
fn zero_focal_length(scene: &Path) {
    edit(&scene.join("sparse/0/cameras.txt"), |t| {
        t.lines()
            .map(|l| {
                if l.starts_with('#') {
                    return l.to_string();
                }
                let mut f: Vec<&str> = l.split_whitespace().collect();
                if f.len() >= 6 {
                    f[4] = "0";
                    f[5] = "0";
                }
                f.join(" ")
            })
            .collect::<Vec<_>>()
            .join("\n")
    });
}

/// `images.txt` with its comments and no image.
fn no_images(scene: &Path) {
    edit(&scene.join("sparse/0/images.txt"), |t| {
        t.lines().filter(|l| l.starts_with('#')).map(|l| format!("{l}\n")).collect()
    });
}

/// `images.txt` whose second image repeats the first one's IMAGE_ID.
fn duplicate_image_id(scene: &Path) {
    edit(&scene.join("sparse/0/images.txt"), |t| {
        let mut data = 0;
        t.lines()
            .map(|l| {
                if l.starts_with('#') {
                    return format!("{l}\n");
                }
                data += 1;
                // Lines 1, 3, 5 … are the images; the third data line is the second image.
                if data == 3 {
                    let rest = l.split_once(' ').map_or("", |(_, r)| r);
                    return format!("1 {rest}\n");
                }
                format!("{l}\n")
            })
            .collect()
    });
}

/// Three Gaussians of the scene's PLY given a NaN position.
fn non_finite_gaussians(scene: &Path) {
    let path = scene.join("gaussians.ply");
    let mut g = splatseg_scene::ply::read_ply(&path).expect("the scene's PLY");
    for i in [0, 10, 20] {
        g.means[i][0] = f32::NAN;
    }
    splatseg_scene::ply::write_ply_rows(&path, &g).expect("write the PLY");
}

/// Three Gaussians of the scene's PLY with degenerate shapes: a log-scale of 80, a zero
/// quaternion, a log-scale of 1e30.
fn degenerate_gaussians(scene: &Path) {
    let path = scene.join("gaussians.ply");
    let mut g = splatseg_scene::ply::read_ply(&path).expect("the scene's PLY");
    g.log_scales[0] = [80.0; 3];
    g.rotations[10] = [0.0; 4];
    g.log_scales[20][1] = 1e30;
    splatseg_scene::ply::write_ply_rows(&path, &g).expect("write the PLY");
}

/// The scene's Gaussians moved 1,000 units away: a reconstruction of nothing the views show.
fn gaussians_elsewhere(scene: &Path) {
    let path = scene.join("gaussians.ply");
    let mut g = splatseg_scene::ply::read_ply(&path).expect("the scene's PLY");
    for m in &mut g.means {
        m[0] += 1000.0;
    }
    splatseg_scene::ply::write_ply(&path, &g).expect("write the PLY");
}

/// `SCENE/empty.ply`: a valid header and no vertex.
fn empty_ply(scene: &Path) {
    let props: String = [
        "x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2", "rot_0",
        "rot_1", "rot_2", "rot_3",
    ]
    .iter()
    .map(|p| format!("property float {p}\n"))
    .collect();
    let text = format!("ply\nformat ascii 1.0\nelement vertex 0\n{props}end_header\n");
    std::fs::write(scene.join("empty.ply"), text).expect("write");
}

/// `SCENE/uchar.ply`: one Gaussian whose opacity is stored as `uchar` 200.
fn uchar_opacity_ply(scene: &Path) {
    let floats: String = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2"]
        .iter()
        .map(|p| format!("property float {p}\n"))
        .collect();
    let rest: String = ["scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
        .iter()
        .map(|p| format!("property float {p}\n"))
        .collect();
    let text = format!(
        "ply\nformat ascii 1.0\nelement vertex 1\n{floats}property uchar opacity\n{rest}end_header\n\
         0 0 1 0.5 0.5 0.5 200 -3 -3 -3 1 0 0 0\n"
    );
    std::fs::write(scene.join("uchar.ply"), text).expect("write");
}

/// The second view's features with half their channels (as from another model).
fn features_of_another_width(scene: &Path) {
    let path = scene.join("features/view_001.npy");
    let a = splatseg_scene::npy::read_npy(&path).expect("the features");
    let (h, w, c) = a.hwc().expect("[h, w, C] features");
    let half: Vec<f32> = a.data.chunks(c).flat_map(|px| px[..c / 2].iter().copied()).collect();
    splatseg_scene::npy::write_npy_f32(&path, &[h, w, c / 2], &half).expect("write the features");
}

/// The second image listed as `sub/view_000.png`, a copy of `view_001.png`: two views with the
/// stem `view_000`.
fn two_images_with_one_stem(scene: &Path) {
    std::fs::create_dir_all(scene.join("images/sub")).expect("mkdir");
    std::fs::copy(scene.join("images/view_001.png"), scene.join("images/sub/view_000.png")).expect("copy");
    edit(&scene.join("sparse/0/images.txt"), |t| t.replace("view_001.png", "sub/view_000.png"));
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().expect("utf-8 path")).expect("path");
    // SAFETY: `c` is a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
}

/// The first view's masks as SAM's PNG folder (`sam/view_000/metadata.csv` + `<i>.png`) in
/// place of its JSON; returns the folder.
fn first_masks_as_png_folder(scene: &Path) -> PathBuf {
    let json = first_view_json(scene);
    let masks = splatseg_scene::sam::read_sam_json(&json).expect("the masks").masks;
    assert!(masks.len() >= 2, "the synthetic view has {} masks", masks.len());
    let dir = scene.join("sam/view_000");
    std::fs::create_dir_all(&dir).expect("mkdir");
    splatseg_scene::sam::write_sam_png_folder(&dir, &masks).expect("write the PNG folder");
    std::fs::remove_file(json).expect("remove the JSON");
    dir
}

/// A PNG folder whose mask `0.png` is all zeros.
fn png_mask_all_zeros(scene: &Path) {
    let dir = first_masks_as_png_folder(scene);
    let (w, h) = splatseg_scene::image_io::image_size(&dir.join("0.png")).expect("size");
    let zeros = splatseg_scene::Plane::filled(w as usize, h as usize, 0u8);
    splatseg_scene::image_io::write_png_luma8(&dir.join("0.png"), &zeros).expect("write");
}

/// A PNG folder whose mask `1.png` is RGB noise (a photo, not a mask).
fn png_mask_rgb_noise(scene: &Path) {
    let dir = first_masks_as_png_folder(scene);
    let (w, h) = splatseg_scene::image_io::image_size(&dir.join("1.png")).expect("size");
    let mut state = 12345u32;
    let data: Vec<u8> = (0..w * h * 3)
        .map(|_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 24) as u8
        })
        .collect();
    let noise = splatseg_scene::image_io::RgbImage::from_vec(w as usize, h as usize, data).expect("image");
    splatseg_scene::image_io::write_png_rgb8(&dir.join("1.png"), &noise).expect("write");
}

/// The first view's depth map stored `[W, H]`.
fn transposed_depth(scene: &Path) {
    let path = scene.join("depth/view_000.npy");
    let a = splatseg_scene::npy::read_npy(&path).expect("the depth map");
    let (h, w) = (a.shape[0], a.shape[1]);
    let t: Vec<f32> =
        (0..w).flat_map(|x| (0..h).map(move |y| (x, y))).map(|(x, y)| a.data[y * w + x]).collect();
    splatseg_scene::npy::write_npy_f32(&path, &[w, h], &t).expect("write the depth map");
}

/// The second view's depth map all NaN and ±Inf.
fn non_finite_depth(scene: &Path) {
    let path = scene.join("depth/view_001.npy");
    let a = splatseg_scene::npy::read_npy(&path).expect("the depth map");
    let bad: Vec<f32> =
        (0..a.data.len()).map(|i| if i % 2 == 0 { f32::NAN } else { f32::INFINITY }).collect();
    splatseg_scene::npy::write_npy_f32(&path, &a.shape, &bad).expect("write the depth map");
}

/// `SCENE/labelled.ply`: the scene's Gaussians, every one with object id 1.
fn labelled_ply(scene: &Path) {
    let mut g = splatseg_scene::ply::read_ply(&scene.join("gaussians.ply")).expect("the scene's PLY");
    g.object_ids = Some(vec![1; g.len()]);
    splatseg_scene::ply::write_ply(&scene.join("labelled.ply"), &g).expect("write the PLY");
}

/// The training views' images (all but view 0, which `train` holds out) painted black: training
/// fits them and the held-out view gets worse.
fn black_training_images(scene: &Path) {
    for v in 1..3 {
        let path = scene.join(format!("images/view_{v:03}.png"));
        let (w, h) = splatseg_scene::image_io::image_size(&path).expect("size");
        let black = splatseg_scene::image_io::RgbImage::filled(w as usize, h as usize, [0; 3]);
        splatseg_scene::image_io::write_png_rgb8(&path, &black).expect("write");
    }
}

/// `SCENE/negative.ply`: the scene's Gaussians, the even ones with object id −5, the odd ones 1.
fn negative_ids_ply(scene: &Path) {
    let mut g = splatseg_scene::ply::read_ply(&scene.join("gaussians.ply")).expect("the scene's PLY");
    g.object_ids = Some((0..g.len()).map(|i| if i % 2 == 0 { -5 } else { 1 }).collect());
    splatseg_scene::ply::write_ply(&scene.join("negative.ply"), &g).expect("write the PLY");
}

fn config_tau_merge_negative(scene: &Path) {
    std::fs::write(scene.join("bad.toml"), "[merge]\ntau_merge = -0.5\n").expect("write");
}

fn config_tau_match_nan(scene: &Path) {
    std::fs::write(scene.join("bad.toml"), "[match]\ntau_match = nan\n").expect("write");
}

/// `splatseg ARGS`, which must succeed (a case's preparation).
fn prepared(args: &[&Path]) {
    let out = splatseg(args);
    assert!(out.status.success(), "splatseg {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// A tiny random CLIP (`seed`) with the tokenizer's merges in `SCENE/clip`.
fn random_clip(scene: &Path, seed: u64) -> PathBuf {
    use splatseg_models::clip::testing::{write_random_checkpoint, RandomClipSpec};
    let dir = scene.join("clip");
    write_random_checkpoint(&dir, RandomClipSpec::tiny(651), seed).expect("writes the checkpoint");
    copy_tiny_merges(&dir);
    dir
}

fn copy_tiny_merges(dir: &Path) {
    let merges =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_bpe_tiny.txt.gz");
    std::fs::copy(merges, dir.join(splatseg_models::clip::MERGES_FILE)).expect("copies the merges");
}

/// `run --clip SCENE/clip` into `SCENE/<name>` (SCENE/clip written first when missing); returns
/// the output folder, part of the scene folder, so that the table checks it does not change.
fn run_with_clip(scene: &Path, name: &str) -> PathBuf {
    let clip = match scene.join("clip").is_dir() {
        true => scene.join("clip"),
        false => random_clip(scene, 30),
    };
    let out = scene.join(name);
    let sam = scene.join("sam");
    prepared(&[
        Path::new("run"),
        scene,
        Path::new("--masks"),
        &sam,
        Path::new("--out"),
        &out,
        Path::new("--clip"),
        &clip,
    ]);
    out
}

/// `run` without `--clip`, with `tau_merge = 0.5` (other settings: another run key), into `SCENE/<name>`.
fn run_with_other_settings(scene: &Path, name: &str) -> PathBuf {
    let config = scene.join("other.toml");
    std::fs::write(&config, "[merge]\ntau_merge = 0.5\n").expect("write");
    let (out, sam) = (scene.join(name), scene.join("sam"));
    let args = [Path::new("run"), scene, Path::new("--masks"), &sam, Path::new("--out"), &out];
    prepared(&[&args[..], &[Path::new("--config"), &config]].concat());
    out
}

/// A finished `run --clip` in `SCENE/run`.
fn clip_run(scene: &Path) {
    run_with_clip(scene, "run");
}

/// `run --clip` into `SCENE/run`, then a rerun there without `--clip` and with other settings.
fn clip_run_then_rerun_without_clip(scene: &Path) {
    run_with_clip(scene, "run");
    run_with_other_settings(scene, "run");
}

/// `run --clip` into `SCENE/a`, another run into `SCENE/b`, and a's `objects/` copied beside b's PLY.
fn objects_of_another_run(scene: &Path) {
    let a = run_with_clip(scene, "a");
    let b = run_with_other_settings(scene, "b");
    std::fs::create_dir_all(b.join("objects")).expect("mkdir");
    for file in ["objects.json", "clip.npy"] {
        std::fs::copy(a.join("objects").join(file), b.join("objects").join(file)).expect("copy");
    }
}

/// `run --clip` into `SCENE/run`, then its `gaussians.ply` replaced by one whose ids 1 and 2 are
/// swapped (the PLY of another run of the scene).
fn clip_run_with_another_ply(scene: &Path) {
    let ply = run_with_clip(scene, "run").join("gaussians.ply");
    let mut rows = splatseg_scene::ply::read_ply_rows(&ply).expect("the run's PLY");
    let ids = rows.gaussians.object_ids.as_mut().expect("a labelled PLY");
    for id in ids.iter_mut() {
        *id = match *id {
            1 => 2,
            2 => 1,
            other => other,
        };
    }
    splatseg_scene::ply::write_ply_rows(&ply, &rows.gaussians).expect("write the PLY");
}

/// `run --clip` into `SCENE/run`, then the checkpoint replaced by another of the same shapes (and
/// size).
fn clip_run_then_another_checkpoint(scene: &Path) {
    run_with_clip(scene, "run");
    random_clip(scene, 31);
}

/// A CLIP in `SCENE/clip` whose `ln_final.weight` is all NaN.
fn clip_with_nan_weights(scene: &Path) {
    use splatseg_models::clip::testing::{write_random_checkpoint_with_nan, RandomClipSpec};
    let dir = scene.join("clip");
    write_random_checkpoint_with_nan(&dir, RandomClipSpec::tiny(651), 30, "ln_final.weight").expect("write");
    copy_tiny_merges(&dir);
}

/// transformers' CLIP folder (the models crate's fixture) in `SCENE/clip`, its `tokenizer.json` not JSON.
fn clip_with_broken_tokenizer_json(scene: &Path) {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_tiny_hf");
    let dir = scene.join("clip");
    std::fs::create_dir_all(&dir).expect("mkdir");
    for file in ["model.safetensors", "config.json"] {
        std::fs::copy(fixture.join(file), dir.join(file)).expect("copies the fixture");
    }
    std::fs::write(dir.join("tokenizer.json"), "{\"model\": {\"type\": \"BPE\", \"vocab\": ").expect("write");
}

/// `SCENE/clip/model.safetensors` a FIFO.
#[cfg(unix)]
fn clip_weights_a_fifo(scene: &Path) {
    std::fs::create_dir_all(scene.join("clip")).expect("mkdir");
    mkfifo(&scene.join("clip/model.safetensors"));
}

/// `SCENE/clip/model.safetensors` a link to `/dev/zero`.
#[cfg(unix)]
fn clip_weights_dev_zero(scene: &Path) {
    std::fs::create_dir_all(scene.join("clip")).expect("mkdir");
    std::os::unix::fs::symlink("/dev/zero", scene.join("clip/model.safetensors")).expect("symlink");
}

/// A finished run in `SCENE/run` copied to `SCENE.copy` (outside the scene folder).
fn run_then_copy_of_its_folder(scene: &Path) {
    let (out, sam) = (scene.join("run"), scene.join("sam"));
    prepared(&[Path::new("run"), scene, Path::new("--masks"), &sam, Path::new("--out"), &out]);
    let copied =
        Command::new("cp").arg("-r").arg(&out).arg(scene.with_extension("copy")).status().expect("cp");
    assert!(copied.success(), "copying the output folder");
}

const RUN: &[&str] = &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT"];

fn cases() -> Vec<Case> {
    let mut cases = vec![
        Case {
            name: "a view without its masks file",
            damage: remove_first_masks,
            args: RUN,
            expect: Expect::Warning(&["1 of 3 views have no masks", "view_000"]),
        },
        Case {
            name: "fx = fy = 0",
            damage: zero_focal_length,
            args: RUN,
            expect: Expect::Error(&["cameras.txt"]),
        },
        Case {
            name: "images.txt without images",
            damage: no_images,
            args: RUN,
            expect: Expect::Error(&["images.txt"]),
        },
        Case {
            name: "a repeated IMAGE_ID",
            damage: duplicate_image_id,
            args: RUN,
            expect: Expect::Error(&["images.txt", "image id 1 appears twice"]),
        },
        Case {
            name: "two images with one stem in different folders",
            damage: two_images_with_one_stem,
            args: &["render", "SCENE", "--gaussians", "SCENE/gaussians.ply", "--out", "OUT"],
            expect: Expect::Error(&["sub/view_000.png", "same file stem `view_000`", "images.txt"]),
        },
        Case {
            name: "a PNG mask of all zeros",
            damage: png_mask_all_zeros,
            args: RUN,
            expect: Expect::Warning(&["are empty (all zeros)", "view_000 (1)"]),
        },
        Case {
            name: "SAM JSON whose areas disagree with its masks",
            damage: mask_areas_that_disagree,
            args: RUN,
            expect: Expect::Warning(&[
                "4 SAM masks in 2 of 3 views have an area or bbox that disagrees",
                "view_000 (2), view_001 (2)",
                "the values recomputed from the masks are used",
            ]),
        },
        Case {
            name: "an RGB noise PNG as a mask",
            damage: png_mask_rgb_noise,
            args: RUN,
            expect: Expect::Error(&["view_000/1.png", "must be grey"]),
        },
        Case {
            name: "a transposed depth map",
            damage: transposed_depth,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--depth", "SCENE/depth", "--out", "OUT"],
            expect: Expect::Error(&[
                "view_000.npy",
                "shape [64, 48] (transposed?)",
                "[48, 64]",
                "--resize-depth",
            ]),
        },
        Case {
            name: "a depth map of NaN and Inf",
            damage: non_finite_depth,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--depth", "SCENE/depth", "--out", "OUT"],
            expect: Expect::Error(&["view_001.npy", "are NaN or ±Inf"]),
        },
        Case {
            name: "train a labelled PLY for fewer iterations than densification lasts",
            damage: labelled_ply,
            args: &[
                "train",
                "SCENE",
                "--gaussians",
                "SCENE/labelled.ply",
                "--iterations",
                "5",
                "--out",
                "OUT",
            ],
            expect: Expect::Notice(&["carries object ids", "stops at 5", "no label maps are written"]),
        },
        Case {
            name: "training that makes the held-out view worse",
            damage: black_training_images,
            args: &[
                "train",
                "SCENE",
                "--gaussians",
                "SCENE/gaussians.ply",
                "--iterations",
                "60",
                "--out",
                "OUT",
            ],
            expect: Expect::Notice(&["held-out views worse", "dB before"]),
        },
        Case {
            name: "extract --ids -5 where objects shows −5 as unlabelled",
            damage: negative_ids_ply,
            args: &["extract", "SCENE/negative.ply", "--ids", "-5", "--out", "OUT/x.ply"],
            expect: Expect::Error(&["no Gaussian has object id -5", "ids present: -1, 1", "negative.ply"]),
        },
        Case {
            name: "tau_merge = -0.5",
            damage: config_tau_merge_negative,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--config", "SCENE/bad.toml"],
            expect: Expect::Error(&["bad.toml", "tau_merge"]),
        },
        Case {
            name: "tau_match = nan",
            damage: config_tau_match_nan,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--config", "SCENE/bad.toml"],
            expect: Expect::Error(&["bad.toml", "tau_match"]),
        },
        Case {
            name: "--resolution 3",
            damage: nothing,
            args: &[
                "render",
                "SCENE",
                "--gaussians",
                "SCENE/gaussians.ply",
                "--out",
                "OUT",
                "--resolution",
                "3",
            ],
            expect: Expect::Error(&["1, 2, 4 or 8"]),
        },
        Case {
            name: "run --out SCENE",
            damage: nothing,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "SCENE"],
            expect: Expect::Error(&["SCENE"]),
        },
        Case {
            name: "extract --out equal to its input",
            damage: nothing,
            args: &["extract", "SCENE/gaussians.ply", "--ids", "1", "--out", "SCENE/gaussians.ply"],
            expect: Expect::Error(&["gaussians.ply"]),
        },
        Case {
            name: "view --out naming a file",
            damage: nothing,
            // A host that does not resolve: were the check gone, the command would fail on it, not serve forever.
            args: &[
                "view",
                "SCENE/gaussians.ply",
                "--out",
                "SCENE/sparse/0/cameras.txt",
                "--listen",
                "no-such-host.invalid:0",
            ],
            expect: Expect::Error(&["cameras.txt", "must be a folder"]),
        },
        Case {
            name: "--shard -1/2",
            damage: nothing,
            args: &["merge", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--shard", "-1/2"],
            expect: Expect::Error(&["-1/2"]),
        },
        Case {
            name: "Gaussians with NaN positions",
            damage: non_finite_gaussians,
            args: RUN,
            expect: Expect::Warning(&["skipping 3 of", "non-finite"]),
        },
        Case {
            name: "degenerate Gaussians (log-scale 80, zero quaternion, log-scale 1e30)",
            damage: degenerate_gaussians,
            args: RUN,
            expect: Expect::Warning(&["skipping 3 of", "degenerate shape", "gaussians.ply"]),
        },
        Case {
            name: "degenerate Gaussians, rendered",
            damage: degenerate_gaussians,
            args: &["render", "SCENE", "--gaussians", "SCENE/gaussians.ply", "--out", "OUT"],
            expect: Expect::Notice(&["skipping 3 of", "degenerate shape", "gaussians.ply"]),
        },
        Case {
            name: "features of two channel counts",
            damage: features_of_another_width,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--features", "SCENE/features", "--out", "OUT"],
            expect: Expect::Error(&["view_001", "view_000", "features", "channel count"]),
        },
        Case {
            name: "Gaussians that reconstruct nothing the views show",
            damage: gaussians_elsewhere,
            args: RUN,
            expect: Expect::Warning(&["the Gaussians label", "reconstruct the scene poorly"]),
        },
        Case {
            name: "a PLY without Gaussians",
            damage: empty_ply,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--gaussians", "SCENE/empty.ply", "--out", "OUT"],
            expect: Expect::Error(&["empty.ply"]),
        },
        Case {
            name: "opacity stored as uchar",
            damage: uchar_opacity_ply,
            args: &["render", "SCENE", "--gaussians", "SCENE/uchar.ply", "--out", "OUT"],
            expect: Expect::Error(&["uchar.ply", "opacity"]),
        },
        Case {
            name: "find with an empty query",
            damage: clip_run,
            args: &["find", "SCENE/run", ""],
            expect: Expect::Error(&["the query \"\" is empty or blank"]),
        },
        Case {
            name: "find with a blank query",
            damage: clip_run,
            args: &["find", "SCENE/run", "   "],
            expect: Expect::Error(&["the query \"   \" is empty or blank"]),
        },
        Case {
            name: "extract --query ''",
            damage: clip_run,
            args: &["extract", "SCENE/run/gaussians.ply", "--query", "", "--out", "OUT/x.ply"],
            expect: Expect::Error(&["is empty or blank"]),
        },
        Case {
            name: "remove --query '  '",
            damage: clip_run,
            args: &["remove", "SCENE/run/gaussians.ply", "--query", "  ", "--out", "OUT/x.ply"],
            expect: Expect::Error(&["is empty or blank"]),
        },
        Case {
            name: "find with a query longer than CLIP's context",
            damage: clip_run,
            args: &["find", "SCENE/run", "LONG_QUERY"],
            expect: Expect::Error(&["tokens long, more than the 75 CLIP reads", "shorten it"]),
        },
        Case {
            name: "extract --query longer than CLIP's context",
            damage: clip_run,
            args: &["extract", "SCENE/run/gaussians.ply", "--query", "LONG_QUERY", "--out", "OUT/x.ply"],
            expect: Expect::Error(&["tokens long, more than the 75 CLIP reads"]),
        },
        Case {
            name: "remove --query after a rerun without --clip",
            damage: clip_run_then_rerun_without_clip,
            args: &["remove", "SCENE/run/gaussians.ply", "--query", "a chair", "--out", "OUT/x.ply"],
            expect: Expect::Error(&["run/objects/objects.json", "run `splatseg run --clip CKPT`"]),
        },
        Case {
            name: "find on another run's objects/",
            damage: objects_of_another_run,
            args: &["find", "SCENE/b", "a chair"],
            expect: Expect::Error(&[
                "do not belong",
                "the run: the index was made for the run of key",
                "b/objects/objects.json",
            ]),
        },
        Case {
            name: "extract --query on the PLY of another run",
            damage: clip_run_with_another_ply,
            args: &["extract", "SCENE/run/gaussians.ply", "--query", "a chair", "--out", "OUT/x.ply"],
            expect: Expect::Error(&[
                "do not belong",
                "the PLY: the index was made for a gaussians.ply of digest",
                "run/gaussians.ply is of digest",
            ]),
        },
        Case {
            name: "find with another checkpoint in place of the run's",
            damage: clip_run_then_another_checkpoint,
            args: &["find", "SCENE/run", "a chair"],
            expect: Expect::Error(&[
                "do not belong",
                "the CLIP checkpoint: the objects were embedded by",
                "open_clip_model.safetensors",
            ]),
        },
        Case {
            name: "run --clip with NaN text weights",
            damage: clip_with_nan_weights,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--clip", "SCENE/clip"],
            expect: Expect::Error(&[
                "`ln_final.weight` holds 32 NaN",
                "SCENE/clip/open_clip_model.safetensors",
            ]),
        },
        Case {
            name: "run --clip with a broken tokenizer.json",
            damage: clip_with_broken_tokenizer_json,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--clip", "SCENE/clip"],
            expect: Expect::Error(&["--clip", "cannot read the CLIP tokenizer", "SCENE/clip/tokenizer.json"]),
        },
        Case {
            name: "extract --ids -1,1 (negative first)",
            damage: negative_ids_ply,
            args: &["extract", "SCENE/negative.ply", "--ids", "-1,1", "--out", "OUT/x.ply"],
            expect: Expect::Notice(&["wrote", "OUT/x.ply"]),
        },
        Case {
            name: "run into a copy of an output folder",
            damage: run_then_copy_of_its_folder,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "SCENE.copy"],
            expect: Expect::Notice(&["report: SCENE.copy/report.md"]),
        },
    ];
    #[cfg(unix)]
    cases.extend([
        Case {
            name: "an --out that is not UTF-8",
            damage: nothing,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "NON_UTF8_OUT"],
            expect: Expect::Error(&["not valid UTF-8"]),
        },
        Case {
            name: "a masks file that is a FIFO",
            damage: first_masks_a_fifo,
            args: RUN,
            expect: Expect::Warning(&["1 of 3 views have no masks", "view_000"]),
        },
        Case {
            name: "info on a masks file that is a FIFO",
            damage: first_masks_a_fifo,
            args: &["info", "SCENE"],
            expect: Expect::Notice(&["SAM masks", "2 of 3 views", "not regular files", "view_000.json"]),
        },
        Case {
            name: "run --clip whose model.safetensors is a FIFO",
            damage: clip_weights_a_fifo,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--clip", "SCENE/clip"],
            expect: Expect::Error(&["not a regular file", "SCENE/clip/model.safetensors"]),
        },
        Case {
            name: "run --clip whose model.safetensors links to /dev/zero",
            damage: clip_weights_dev_zero,
            args: &["run", "SCENE", "--masks", "SCENE/sam", "--out", "OUT", "--clip", "SCENE/clip"],
            expect: Expect::Error(&["not a regular file", "SCENE/clip/model.safetensors"]),
        },
        Case {
            name: "a masks file linked to /dev/zero",
            damage: first_masks_dev_zero,
            args: RUN,
            expect: Expect::Warning(&["1 of 3 views have no masks", "view_000"]),
        },
    ]);
    cases
}

fn splatseg<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs")
}

/// `arg` with `SCENE` and `OUT` replaced by the case's paths; `NON_UTF8_OUT` is `OUT` with a byte
/// that is not UTF-8 appended; `LONG_QUERY` a query of 10,080 characters (2,160 tokens).
fn argument(arg: &str, scene: &Path, out: &Path) -> std::ffi::OsString {
    if arg == "LONG_QUERY" {
        return "a red mug on the wooden table ".repeat(336).into();
    }
    #[cfg(unix)]
    if arg == "NON_UTF8_OUT" {
        use std::os::unix::ffi::OsStringExt;
        let mut bytes = out.as_os_str().to_os_string().into_vec();
        bytes.push(0xff);
        return std::ffi::OsString::from_vec(bytes);
    }
    let utf8 = |p: &Path| p.to_str().expect("utf-8 temp path").to_string();
    arg.replace("SCENE", &utf8(scene)).replace("OUT", &utf8(out)).into()
}

/// An expected text with `SCENE` and `OUT` replaced by the case's paths.
fn with_paths(text: &str, scene: &Path, out: &Path) -> String {
    text.replace("SCENE", scene.to_str().unwrap_or_default()).replace("OUT", out.to_str().unwrap_or_default())
}

/// Every file's digest under `dir`, FIFOs and links to devices left out (read, they would block
/// or never end).
fn inputs_digest(dir: &Path) -> Vec<(String, String)> {
    let special =
        |rel: &str| std::fs::metadata(dir.join(rel)).map(|m| !m.is_file() && !m.is_dir()).unwrap_or(false);
    folder_digests(dir, special).expect("digests of the scene folder")
}

#[test]
fn every_bad_input_is_an_error_or_a_warning_and_no_input_changes() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let pristine = tmp.path().join("pristine");
    let out =
        splatseg(&["synth", "--out", pristine.to_str().expect("utf-8"), "--views", "3", "--size", "64x48"]);
    assert!(out.status.success(), "synth: {}", String::from_utf8_lossy(&out.stderr));
    let mut failures = Vec::new();
    for (i, case) in cases().into_iter().enumerate() {
        let scene = tmp.path().join(format!("case_{i}"));
        let copied = Command::new("cp").arg("-r").arg(&pristine).arg(&scene).status().expect("cp");
        assert!(copied.success(), "copying the scene");
        (case.damage)(&scene);
        let before = inputs_digest(&scene);
        let out_dir = tmp.path().join(format!("out_{i}"));
        let args: Vec<std::ffi::OsString> = case.args.iter().map(|a| argument(a, &scene, &out_dir)).collect();
        let output = splatseg(&args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        let mut problems = Vec::new();
        match case.expect {
            Expect::Error(words) => {
                if output.status.success() {
                    problems.push("exit 0, expected an error".to_string());
                }
                if stderr.contains("panicked") {
                    problems.push("a panic".to_string());
                }
                let wanted = words.iter().map(|w| with_paths(w, &scene, &out_dir));
                problems.extend(wanted.filter(|w| !stderr.contains(w.as_str())).map(|w| format!("no `{w}`")));
                // refused before anything was written: no edited PLY, no run's outputs
                for written in ["x.ply", "report.md", "objects"] {
                    if out_dir.join(written).exists() {
                        problems.push(format!("OUT/{written} was written"));
                    }
                }
            }
            Expect::Warning(words) => {
                if !output.status.success() {
                    problems.push(format!("exit {:?}, expected a warning", output.status.code()));
                }
                // Each warning once: a run reads a view's files more than once (the masks for the
                // other views' wholes, then for the merge), and says what it found once for the run.
                let mut said: Vec<&str> =
                    stderr.lines().filter_map(|l| l.split_once(" WARN ").map(|(_, w)| w.trim())).collect();
                said.sort_unstable();
                if let Some(twice) = said.windows(2).find(|w| w[0] == w[1]) {
                    problems.push(format!("a warning said twice: `{}`", twice[0]));
                }
                let report = std::fs::read_to_string(out_dir.join("report.md")).unwrap_or_default();
                if !report.contains("## Warnings") {
                    problems.push("report.md lists no warnings".to_string());
                }
                for w in words {
                    if !stderr.contains(w) {
                        problems.push(format!("stderr lacks `{w}`"));
                    }
                    if !report.contains(w) {
                        problems.push(format!("report.md lacks `{w}`"));
                    }
                }
            }
            Expect::Notice(words) => {
                if !output.status.success() {
                    problems.push(format!("exit {:?}, expected success", output.status.code()));
                }
                let said = format!("{}{stderr}", String::from_utf8_lossy(&output.stdout));
                let wanted = words.iter().map(|w| with_paths(w, &scene, &out_dir));
                problems.extend(wanted.filter(|w| !said.contains(w.as_str())).map(|w| format!("no `{w}`")));
            }
        }
        if inputs_digest(&scene) != before {
            problems.push("an input changed".to_string());
        }
        if !problems.is_empty() {
            failures.push(format!("{}: {}\n  stderr: {}", case.name, problems.join("; "), stderr.trim()));
        }
    }
    assert!(failures.is_empty(), "{} case(s) failed:\n{}", failures.len(), failures.join("\n"));
}

/// A write `extract` did not finish (killed mid-write of a large PLY) leaves its temporary file in the
/// output folder, named `.splatseg-partial-<pid>-…`; the next `extract` into that folder removes it
/// (its process is gone), and leaves the folder's other files, another program's `.tmp*` included.
#[cfg(unix)]
#[test]
fn a_killed_extracts_partial_file_is_removed_by_the_next_write_there() {
    let tmp = tempfile::tempdir().expect("temp dir");
    let scene = tmp.path().join("scene");
    let out =
        splatseg(&["synth", "--out", scene.to_str().expect("utf-8"), "--views", "3", "--size", "64x48"]);
    assert!(out.status.success(), "synth: {}", String::from_utf8_lossy(&out.stderr));
    labelled_ply(&scene);
    let before = inputs_digest(&scene);
    let exports = tmp.path().join("exports");
    std::fs::create_dir_all(&exports).expect("mkdir");
    // 2^22 + 1 is past Linux's largest process id: that writer is gone
    let left = exports.join(".splatseg-partial-4194305-Xy12Zw");
    std::fs::write(&left, vec![0u8; 1 << 20]).expect("write");
    let theirs = exports.join(".tmpAb12Cd");
    std::fs::write(&theirs, b"another program's").expect("write");
    let picked = exports.join("picked.ply");
    let (ply, picked_s) = (scene.join("labelled.ply"), picked.to_str().expect("utf-8").to_string());
    let output = splatseg(&["extract", ply.to_str().expect("utf-8"), "--ids", "1", "--out", &picked_s]);
    assert!(output.status.success(), "extract: {}", String::from_utf8_lossy(&output.stderr));
    assert!(picked.is_file(), "the extract is written");
    assert!(!left.exists(), "the killed write's partial file is removed");
    assert!(theirs.exists(), "another program's temporary file is kept");
    let names: Vec<String> = std::fs::read_dir(&exports)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "nothing else is left: {names:?}");
    assert_eq!(inputs_digest(&scene), before, "no input changed");
}

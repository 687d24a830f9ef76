//! `splatseg view` in a real headless Chromium (software WebGL through SwiftShader), driven over
//! WebDriver by `splatseg_view::browser`, on the demo's pipeline result (synthetic scene → `run`,
//! without training):
//!
//! - the first frame arrives and matches `splatseg render`'s image of the same camera (PSNR ≥ 20 dB);
//! - clicking the centre of each object visible in the first view selects its id (≥ 90 %);
//! - clicking an object in the strip of overlays selects it;
//! - hide and isolate change the pixels as expected;
//! - the exported selection is byte-identical to `splatseg extract --ids …`;
//! - on a run with object embeddings, the search box ranks as `splatseg find` and Enter selects the best;
//!   with `--names FILE`, the object list shows each object's best name as `find` scores the names.
//!
//! Skips (with a message) only when Chromium or chromedriver is not installed and `CI` is not set
//! (`chromium.rs`); `.ci/run` installs both. `SPLATSEG_UPDATE_SCREENSHOT=1 cargo test --release --test integration view_browser` also writes the
//! README's screenshot, `docs/viewer.png`.

use crate::chromium::chromium_or_skip;
use splatseg_scene::Plane;
use splatseg_view::browser::Browser;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

pub(crate) fn splatseg(args: &[&str]) -> Output {
    let out =
        Command::new(env!("CARGO_BIN_EXE_splatseg")).args(args).output().expect("the splatseg binary runs");
    assert!(out.status.success(), "splatseg {args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    out
}

pub(crate) fn utf8(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `splatseg view` running in the background, stopped on drop.
pub(crate) struct Served {
    child: Child,
    pub(crate) url: String,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(crate) fn serve(run: &Path, exports: &Path) -> Served {
    serve_with(run, exports, &[])
}

/// `serve` with more arguments of `splatseg view`.
fn serve_with(run: &Path, exports: &Path, more: &[&str]) -> Served {
    let mut child = Command::new(env!("CARGO_BIN_EXE_splatseg"))
        .args(["view", utf8(run), "--listen", "127.0.0.1:0", "--out", utf8(exports)])
        .args(more)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("splatseg view starts");
    let stdout = child.stdout.take().expect("stdout");
    let url = BufReader::new(stdout)
        .lines()
        .map_while(Result::ok)
        .find_map(|l| l.strip_prefix("open ").map(str::to_string))
        .expect("splatseg view prints the URL");
    Served { child, url }
}

/// An RGB image as floats in [0, 1], `[H, W, 3]`.
struct Rgb {
    width: usize,
    height: usize,
    data: Vec<f32>,
}

fn canvas_pixels(browser: &Browser) -> Rgb {
    let value = browser.await_promise("viewer.readPixels()").expect("readPixels");
    assert!(value["error"].is_null(), "readPixels: {value}");
    let bytes = splatseg_view::browser::base64::decode(value["rgb"].as_str().expect("rgb")).expect("base64");
    Rgb {
        width: value["width"].as_u64().expect("width") as usize,
        height: value["height"].as_u64().expect("height") as usize,
        data: bytes.iter().map(|&b| b as f32 / 255.0).collect(),
    }
}

fn read_png_rgb(path: &Path) -> Rgb {
    let img = splatseg_scene::image_io::read_rgb8(path).expect("png");
    Rgb { width: img.width, height: img.height, data: img.data.iter().map(|&b| b as f32 / 255.0).collect() }
}

/// Per label, the pixel farthest (4-neighbour steps) from any other label or the image border,
/// and how many pixels the label has: `(id, (x, y), distance, area)`.
pub(crate) fn label_centres(map: &Plane<u32>) -> Vec<(u32, (usize, usize), u32, usize)> {
    let (w, h) = (map.width, map.height);
    let mut dist = vec![u32::MAX; w * h];
    let mut queue = std::collections::VecDeque::new();
    for y in 0..h {
        for x in 0..w {
            let id = map.data[y * w + x];
            let edge = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let differs = !edge
                && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                    .iter()
                    .any(|&(a, b)| map.data[b * w + a] != id);
            if edge || differs {
                dist[y * w + x] = 0;
                queue.push_back((x, y));
            }
        }
    }
    while let Some((x, y)) = queue.pop_front() {
        let d = dist[y * w + x];
        for (a, b) in [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)] {
            if a < w && b < h && dist[b * w + a] == u32::MAX {
                dist[b * w + a] = d + 1;
                queue.push_back((a, b));
            }
        }
    }
    let mut best: std::collections::BTreeMap<u32, ((usize, usize), u32, usize)> = Default::default();
    for y in 0..h {
        for x in 0..w {
            let id = map.data[y * w + x];
            if id == 0 {
                continue;
            }
            let entry = best.entry(id).or_insert(((x, y), 0, 0));
            entry.2 += 1;
            if dist[y * w + x] > entry.1 {
                entry.0 = (x, y);
                entry.1 = dist[y * w + x];
            }
        }
    }
    best.into_iter().map(|(id, (p, d, a))| (id, p, d, a)).collect()
}

/// Mean absolute difference over the pixels where `mask` holds.
fn mean_abs_diff(a: &Rgb, b: &Rgb, mask: &[bool]) -> f64 {
    let mut sum = 0.0;
    let mut n = 0usize;
    for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
        for c in 0..3 {
            sum += (a.data[3 * i + c] - b.data[3 * i + c]).abs() as f64;
        }
        n += 3;
    }
    sum / n.max(1) as f64
}

/// Pixels of label `id` at least `margin` steps inside it (`inside`), and pixels at least
/// `margin` steps away from it (`outside`).
fn regions(map: &Plane<u32>, id: u32, margin: usize) -> (Vec<bool>, Vec<bool>) {
    let (w, h) = (map.width as i64, map.height as i64);
    let m = margin as i64;
    let near = |x: i64, y: i64, want: bool| {
        (-m..=m).all(|dy| {
            (-m..=m).all(|dx| {
                let (a, b) = (x + dx, y + dy);
                let is = a >= 0 && b >= 0 && a < w && b < h && map.data[(b * w + a) as usize] == id;
                is == want
            })
        })
    };
    let mut inside = vec![false; map.data.len()];
    let mut outside = vec![false; map.data.len()];
    for y in 0..h {
        for x in 0..w {
            inside[(y * w + x) as usize] = near(x, y, true);
            outside[(y * w + x) as usize] = near(x, y, false);
        }
    }
    (inside, outside)
}

pub(crate) fn state(browser: &Browser) -> serde_json::Value {
    browser.execute("return viewer.state();", serde_json::json!([])).expect("state")
}

#[test]
fn the_viewer_renders_picks_hides_and_exports_in_headless_chromium() {
    let Some(paths) = chromium_or_skip("the browser test") else { return };
    let tmp = tempfile::tempdir().expect("temp dir");
    let [scene, run, renders, exports] = ["scene", "run", "renders", "exports"].map(|d| tmp.path().join(d));
    // Gaussians twice as far apart as the default (a quarter as many, ≈ 10k): every frame here is
    // drawn by SwiftShader on the CPU, and the page draws one after each click.
    let synth_config = tmp.path().join("synth.toml");
    std::fs::write(&synth_config, "gaussian_spacing_px = 5.0\n").expect("write the synth config");
    splatseg(&["synth", "--out", utf8(&scene), "--views", "4", "--config", utf8(&synth_config)]);
    splatseg(&[
        "run",
        utf8(&scene),
        "--masks",
        utf8(&scene.join("sam")),
        "--features",
        utf8(&scene.join("features")),
        "--out",
        utf8(&run),
    ]);
    splatseg(&[
        "render",
        utf8(&scene),
        "--gaussians",
        utf8(&run.join("gaussians.ply")),
        "--out",
        utf8(&renders),
        "--what",
        "rgb",
    ]);
    let first = std::fs::read_dir(scene.join("images"))
        .expect("images")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().to_string()))
        .min()
        .expect("a view");

    let server = serve(&run, &exports);
    let browser = Browser::launch(&paths, 1280, 900).expect("headless chromium starts");
    browser.goto(&format!("{}?canvas=native", server.url)).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    println!(
        "first frame after {:.0} ms, {} sorts",
        ready["firstFrameMs"].as_f64().unwrap_or(0.0),
        ready["sorts"]
    );

    // 1. The first frame is `splatseg render`'s image of the first camera.
    let shown = canvas_pixels(&browser);
    let reference = read_png_rgb(&renders.join(format!("{first}_rgb.png")));
    assert_eq!((shown.width, shown.height), (reference.width, reference.height));
    let psnr = splatseg_eval::photometric::psnr(&shown.data, &reference.data, shown.width, shown.height, 3)
        .expect("same size");
    println!("PSNR of the first frame against `splatseg render`: {psnr:.2} dB");
    assert!(psnr >= 20.0, "first frame PSNR {psnr:.2} dB < 20 dB");

    // 2. Clicking the centre of each visible object selects it.
    let labels = splatseg_scene::labels::read_label_png(&run.join("masks").join(format!("{first}.png")))
        .expect("label map");
    let visible: Vec<_> =
        label_centres(&labels).into_iter().filter(|&(_, _, d, area)| d >= 3 && area >= 100).collect();
    assert!(visible.len() >= 4, "only {} objects visible in {first}", visible.len());
    let mut hits = 0;
    for &(id, (x, y), _, _) in &visible {
        browser.click_at("#canvas", x as f64, y as f64).expect("click");
        let selected = state(&browser)["selected"].clone();
        if selected == serde_json::json!([id]) {
            hits += 1;
        } else {
            println!("clicked object {id} at ({x}, {y}): selected {selected}");
        }
    }
    println!("picking: {hits} of {} visible objects", visible.len());
    assert!(hits * 10 >= visible.len() * 9, "picking: {hits} of {} objects", visible.len());

    // 3. Hide and isolate the largest visible object.
    let &(target, (tx, ty), _, _) = visible.iter().max_by_key(|v| v.3).expect("an object");

    // The strip: clicking the object in the first view's overlay selects it in 3D.
    browser.execute("viewer.select([]);", serde_json::json!([])).expect("clear");
    let thumb = browser
        .await_promise(
            "(async () => { const img = document.querySelector('#strip figure:first-child img'); \
             await img.decode(); return [img.naturalWidth, img.getBoundingClientRect().width]; })()",
        )
        .expect("strip image");
    let scale = thumb[1].as_f64().expect("shown width") / thumb[0].as_f64().expect("natural width");
    browser
        .click_at("#strip figure:first-child img", tx as f64 * scale, ty as f64 * scale)
        .expect("strip click");
    let mut selected = serde_json::Value::Null;
    for _ in 0..50 {
        selected = state(&browser)["selected"].clone();
        if selected == serde_json::json!([target]) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    assert_eq!(selected, serde_json::json!([target]), "clicking object {target} in the strip");

    let (inside, outside) = regions(&labels, target, 4);
    browser
        .execute("viewer.select([]); viewer.hide([arguments[0]]);", serde_json::json!([target]))
        .expect("hide");
    let hidden = canvas_pixels(&browser);
    let (hid_in, hid_out) =
        (mean_abs_diff(&hidden, &shown, &inside), mean_abs_diff(&hidden, &shown, &outside));
    println!("hide {target}: mean |Δ| inside {hid_in:.3}, outside {hid_out:.3}");
    assert!(hid_in > 0.05 && hid_out < 0.01, "hide {target}: inside {hid_in:.3}, outside {hid_out:.3}");
    browser.execute("viewer.isolate([arguments[0]]);", serde_json::json!([target])).expect("isolate");
    let isolated = canvas_pixels(&browser);
    // Inside: the object as before. Outside: every other object gone, so mostly background
    // (the isolated object's own parts that others hid may now show there).
    let iso_in = mean_abs_diff(&isolated, &shown, &inside);
    let iso_changed = mean_abs_diff(&isolated, &shown, &outside);
    let outside_count = outside.iter().filter(|&&o| o).count();
    let dark = (0..outside.len())
        .filter(|&i| outside[i] && (0..3).all(|c| isolated.data[3 * i + c] < 0.02))
        .count() as f64
        / outside_count.max(1) as f64;
    println!("isolate {target}: mean |Δ| inside {iso_in:.3}, outside {iso_changed:.3}; {:.1} % of outside is background", 100.0 * dark);
    assert!(
        iso_in < 0.02 && iso_changed > 0.05 && dark > 0.8,
        "isolate {target}: inside {iso_in:.3}, outside {iso_changed:.3}, background {dark:.3}"
    );
    browser.execute("viewer.showAll();", serde_json::json!([])).expect("show all");
    let again = canvas_pixels(&browser);
    assert_eq!(again.data, shown.data, "show all restores the first frame");

    // 4. Export = `splatseg extract`.
    browser.execute("viewer.select([arguments[0]]);", serde_json::json!([target])).expect("select");
    let done = browser.await_promise("viewer.exportSelection('extract')").expect("export");
    assert!(done["error"].is_null(), "export: {done}");
    let exported = PathBuf::from(done["path"].as_str().expect("path"));
    assert!(exported.starts_with(&exports), "{} is not in --out", exported.display());
    let reference_ply = tmp.path().join("extract.ply");
    splatseg(&[
        "extract",
        utf8(&run.join("gaussians.ply")),
        "--ids",
        &target.to_string(),
        "--out",
        utf8(&reference_ply),
    ]);
    assert!(
        std::fs::read(&exported).expect("export") == std::fs::read(&reference_ply).expect("extract"),
        "export differs from `splatseg extract`"
    );

    if std::env::var_os("SPLATSEG_UPDATE_SCREENSHOT").is_some() {
        // an object of median size, to show a selection
        let mut by_area: Vec<_> = visible.iter().map(|v| (v.3, v.0)).collect();
        by_area.sort_unstable();
        let shown_id = by_area[by_area.len() / 2].1;
        write_screenshot(&browser, &server.url, shown_id);
    }
}

/// The search box, on a run with object embeddings (`run --clip`, a random CLIP the test writes): it
/// is shown, typing marks the ranked matches at the top of the table in the order `splatseg find`
/// gives, Enter selects the best; `/api/find` refuses a request without the page's token. With
/// `--names FILE` the table has a name column: each object's name is the one of the file that
/// `splatseg find NAME --json` gives it the highest relevancy. The page of a run without embeddings
/// has no search box and no name column.
#[test]
fn the_search_box_ranks_as_find_and_enter_selects_the_best() {
    let Some(paths) = chromium_or_skip("the browser search test") else { return };
    let tmp = tempfile::tempdir().expect("temp dir");
    let [scene, run, clip, exports] = ["scene", "run", "clip", "exports"].map(|d| tmp.path().join(d));
    let synth_config = tmp.path().join("synth.toml");
    std::fs::write(&synth_config, "gaussian_spacing_px = 5.0\n").expect("write the synth config");
    splatseg(&[
        "synth",
        "--out",
        utf8(&scene),
        "--views",
        "3",
        "--size",
        "160x120",
        "--config",
        utf8(&synth_config),
    ]);
    splatseg_models::clip::testing::write_random_checkpoint(
        &clip,
        splatseg_models::clip::testing::RandomClipSpec::tiny(651),
        30,
    )
    .expect("writes a random CLIP");
    let merges =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/models/tests/fixtures/clip_bpe_tiny.txt.gz");
    std::fs::copy(merges, clip.join(splatseg_models::clip::MERGES_FILE)).expect("merges");
    splatseg(&[
        "run",
        utf8(&scene),
        "--masks",
        utf8(&scene.join("sam")),
        "--out",
        utf8(&run),
        "--clip",
        utf8(&clip),
    ]);
    let query = "a red mug";
    let find = String::from_utf8(splatseg(&["find", utf8(&run), query]).stdout).expect("utf-8");
    let ranked: Vec<u32> = find
        .lines()
        .skip(2)
        .map(|l| l.split_whitespace().nth(1).expect("id").parse().expect("an id"))
        .take(splatseg_view::search::SEARCH_TOP)
        .collect();
    assert!(ranked.len() >= 2, "{find}");
    // the names: every object's best among them, from `find --json` (the first name on a tie)
    let names = ["chair", "a red mug", "lamp", "the floor", "a wooden table"];
    let names_file = tmp.path().join("names.txt");
    std::fs::write(&names_file, format!("# objects of the room\n{}\n\n# the end\n", names.join("\n")))
        .expect("write the names");
    let mut best: std::collections::BTreeMap<u64, (f64, &str)> = Default::default();
    for name in names {
        let json = String::from_utf8(splatseg(&["find", utf8(&run), name, "--json"]).stdout).expect("utf-8");
        let rows: serde_json::Value = serde_json::from_str(&json).expect("find --json");
        for row in rows.as_array().expect("rows") {
            let (id, relevancy) = (row["id"].as_u64().expect("id"), row["relevancy"].as_f64().expect("r"));
            let entry = best.entry(id).or_insert((f64::NEG_INFINITY, ""));
            if relevancy > entry.0 {
                *entry = (relevancy, name);
            }
        }
    }

    let server = serve_with(&run, &exports, &["--names", utf8(&names_file)]);
    let refused = splatseg_view::browser::http::request(
        "GET",
        &format!("{}/api/find?q=mug", server.url.trim_end_matches('/')),
        None,
        std::time::Duration::from_secs(10),
    )
    .expect("the server answers");
    assert_eq!(refused.status, 403, "a search without the page's token");
    let browser = Browser::launch(&paths, 1280, 900).expect("headless chromium starts");
    browser.goto(&server.url).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    let script = format!(
        "(async () => {{
            const input = document.getElementById('search');
            if (!input) return {{ error: 'no search box' }};
            const table = () => [...document.querySelectorAll('#objects tr')];
            input.value = {query:?};
            input.dispatchEvent(new Event('input'));
            for (let k = 0; k < 400 && !table()[0].classList.contains('match'); k++) await new Promise(r => setTimeout(r, 25));
            const marked = table().filter(r => r.classList.contains('match')).map(r => Number(r.dataset.id));
            const selectedWhileTyping = viewer.ids(viewer.selected);
            input.dispatchEvent(new KeyboardEvent('keydown', {{ key: 'Enter' }}));
            for (let k = 0; k < 400 && viewer.selected.size === 0; k++) await new Promise(r => setTimeout(r, 25));
            return {{ marked, selectedWhileTyping, selected: viewer.ids(viewer.selected),
                     results: document.getElementById('search-results').textContent }};
        }})()"
    );
    let got = browser.await_promise(&script).expect("search");
    assert!(got["error"].is_null(), "{got}");
    let marked: Vec<u32> =
        got["marked"].as_array().expect("marked").iter().map(|v| v.as_u64().expect("id") as u32).collect();
    assert_eq!(marked, ranked, "the table's marked rows, top down, are `find`'s ranking: {got}");
    assert_eq!(got["selectedWhileTyping"], serde_json::json!([]), "typing selects nothing");
    assert_eq!(got["selected"], serde_json::json!([ranked[0]]), "Enter selects the best: {got}");
    let shown = browser
        .execute(
            "return { header: [...document.querySelectorAll('#table thead th')].map(h => h.textContent),
                      rows: [...document.querySelectorAll('#objects tr')].map(r =>
                        [Number(r.dataset.id), r.querySelector('td.name')?.textContent ?? null]) };",
            serde_json::json!([]),
        )
        .expect("reads the table");
    assert_eq!(shown["header"][3], "name", "{shown}");
    let rows = shown["rows"].as_array().expect("rows");
    let mut named = 0;
    for row in rows {
        let id = row[0].as_i64().expect("id");
        let name = row[1].as_str().expect("every row has a name cell");
        match best.get(&(id as u64)) {
            Some((_, expected)) => {
                assert_eq!(name, *expected, "object {id}: {shown}");
                named += 1;
            }
            None => assert_eq!(name, "", "object {id} has no embedding, so no name: {shown}"),
        }
    }
    assert_eq!(named, best.len(), "every embedded object is named: {shown}");
    drop(browser);
    drop(server);

    // a run without embeddings: no search box
    std::fs::remove_dir_all(run.join("objects")).expect("remove the embeddings");
    let server = serve(&run, &exports);
    let browser = Browser::launch(&paths, 1280, 900).expect("headless chromium starts");
    browser.goto(&server.url).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "the page failed: {ready}");
    let search = browser.execute(
        "return document.getElementById('search') === null && document.querySelector('td.name') === null;",
        serde_json::json!([]),
    );
    assert_eq!(search.expect("runs"), serde_json::json!(true), "no search box and no names");
}

/// The README's screenshot: the page at its normal layout, one object selected, frusta shown.
fn write_screenshot(browser: &Browser, url: &str, selected: u32) {
    browser.goto(url).expect("page opens");
    let ready = browser.await_promise("viewer.whenReady(120000)").expect("ready");
    assert!(ready["error"].is_null(), "{ready}");
    browser
        .execute("viewer.setFrusta(true); viewer.select([arguments[0]]);", serde_json::json!([selected]))
        .expect("state");
    browser.await_promise("viewer.whenDrawn()").expect("drawn");
    let png = browser.screenshot_png().expect("screenshot");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs").join("viewer.png");
    std::fs::create_dir_all(path.parent().expect("docs")).expect("mkdir docs");
    std::fs::write(&path, png).expect("write docs/viewer.png");
    println!("wrote {}", path.display());
}

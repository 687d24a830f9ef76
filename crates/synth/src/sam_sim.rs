//! Simulated Segment Anything automatic masks for one view, over-segmenting the way SAM does:
//!
//! 1. every connected piece of one texture part (a stripe, a half of a two-tone object, a face
//!    of a box) is its own mask; pieces under `min_area_px` get none (uncovered pixels);
//! 2. large pieces (floor, walls) are cut by 1–3 random near-vertical lines, some object
//!    pieces by one or two lines at any angle;
//! 3. some masks get a small hole, some lose their outline pixels (more uncovered pixels);
//! 4. some objects made of several masks also get one whole-object mask (overlapping);
//! 5. where the white-on-white pair touches, sometimes one wrong mask covers both, either in
//!    addition to their masks or replacing them;
//! 6. (stress knobs, off by default) some masks grow by one pixel; where two other objects
//!    touch, sometimes one wrong mask covers both;
//! 7. masks are shuffled: ids and order carry no meaning across views.
//!
//! Everything is drawn from an RNG seeded by (seed, view), so a view's masks are reproducible.

use crate::components::{components_by_key, split_connected};
use crate::config::SamSimConfig;
use crate::noise::{rng_for, stream};
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use splatseg_scene::rle::Rle;
use splatseg_scene::sam::SamMask;
use splatseg_scene::Plane;

/// First object id (ids below are floor and walls).
const FIRST_OBJECT_ID: u32 = 4;

/// What the simulation needs to know about the scene.
pub struct SamSimInput<'a> {
    /// `[H, W]` ground-truth instance ids.
    pub instance: &'a Plane<u32>,
    /// `[H, W]` texture parts.
    pub part: &'a Plane<u8>,
    /// Ids of the white-on-white pair.
    pub white_pair: [u32; 2],
    /// Scene seed.
    pub seed: u64,
    /// View index.
    pub view: usize,
}

/// A mask while it is being built: its pixels (ascending indices) and the instance it came
/// from (0 for a wrong merge).
struct Draft {
    pixels: Vec<u32>,
    source_id: u32,
}

/// The simulated SAM masks of one view, in SAM's JSON representation.
pub fn simulate_sam(input: &SamSimInput, config: &SamSimConfig) -> Vec<SamMask> {
    let (w, h) = input.instance.size();
    let mut rng = rng_for(input.seed, stream::SAM, input.view as u64);
    let mut scratch = vec![false; w * h];
    let keyed = components_by_key(w, h, |i| {
        let id = input.instance.data[i];
        (id != 0).then_some((id, input.part.data[i]))
    });
    let mut drafts = Vec::new();
    for comp in keyed {
        let id = input.instance.data[comp[0] as usize];
        for piece in cut_piece(comp, id, w, h, config, &mut rng, &mut scratch) {
            if piece.len() >= config.min_area_px {
                drafts.push(Draft { pixels: piece, source_id: id });
            }
        }
    }
    damage_masks(&mut drafts, w, h, config, &mut rng);
    add_whole_object_masks(&mut drafts, input.instance, config, &mut rng);
    add_wrong_merge(&mut drafts, input, config, &mut rng);
    // The stress knobs draw from their own stream, so the default masks stay as they were.
    if config.dilate_probability > 0.0 || config.adjacent_merge_probability > 0.0 {
        let mut extra = rng_for(input.seed, stream::SAM_EXTRA, input.view as u64);
        dilate_some(&mut drafts, w, h, config.dilate_probability, &mut extra, &mut scratch);
        add_adjacent_merges(&mut drafts, input, config, &mut extra);
    }
    drafts.retain(|d| d.pixels.len() >= config.min_area_px.max(1));
    drafts.shuffle(&mut rng);
    drafts.into_iter().map(|d| to_sam_mask(&d.pixels, w, h, &mut rng)).collect()
}

/// Cuts one connected piece by random lines when it is large; returns the connected pieces.
fn cut_piece(
    comp: Vec<u32>,
    id: u32,
    w: usize,
    h: usize,
    config: &SamSimConfig,
    rng: &mut ChaCha8Rng,
    scratch: &mut [bool],
) -> Vec<Vec<u32>> {
    let large = comp.len() as f64 > config.large_cut_fraction * (w * h) as f64;
    let object_cut = id >= FIRST_OBJECT_ID
        && comp.len() >= config.object_cut_min_px
        && rng.gen_bool(config.object_cut_probability.clamp(0.0, 1.0));
    let second_cut = object_cut
        && comp.len() >= 4 * config.object_cut_min_px
        && rng.gen_bool(config.object_second_cut_probability.clamp(0.0, 1.0));
    let lines =
        if large { rng.gen_range(1..=3usize) } else { usize::from(object_cut) + usize::from(second_cut) };
    if lines == 0 {
        return vec![comp];
    }
    let (x0, x1) = bounds(comp.iter().map(|&p| (p as usize % w) as f64));
    let (y0, y1) = bounds(comp.iter().map(|&p| (p as usize / w) as f64));
    let cuts: Vec<(f64, f64, f64, f64)> = (0..lines)
        .map(|k| {
            // Line through (cx, cy) with unit normal (nx, ny); near-vertical lines for large
            // pieces (so floor pieces keep a similar depth range), any angle otherwise.
            let share = (k as f64 + rng.gen_range(0.35..0.65)) / lines as f64;
            let cx = x0 + share * (x1 - x0);
            let cy = y0 + rng.gen_range(0.3..0.7) * (y1 - y0);
            let angle: f64 =
                if large { rng.gen_range(-0.45..0.45) } else { rng.gen_range(0.0..std::f64::consts::PI) };
            (cx, cy, angle.cos(), angle.sin())
        })
        .collect();
    let mut sides: Vec<Vec<u32>> = vec![Vec::new(); 1 << lines];
    for &p in &comp {
        let (x, y) = ((p as usize % w) as f64 + 0.5, (p as usize / w) as f64 + 0.5);
        let code = cuts
            .iter()
            .enumerate()
            .map(|(k, &(cx, cy, nx, ny))| usize::from((x - cx) * nx + (y - cy) * ny > 0.0) << k)
            .sum::<usize>();
        sides[code].push(p);
    }
    sides.into_iter().filter(|s| !s.is_empty()).flat_map(|s| split_connected(&s, w, h, scratch)).collect()
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)))
}

/// Punches small holes into some masks and erodes the outline of others (the drafts partition
/// their pixels at this point, so "outline" is where a 4-neighbour belongs to another draft).
fn damage_masks(drafts: &mut [Draft], w: usize, h: usize, config: &SamSimConfig, rng: &mut ChaCha8Rng) {
    let mut owner = vec![u32::MAX; w * h];
    for (k, d) in drafts.iter().enumerate() {
        for &p in &d.pixels {
            owner[p as usize] = k as u32;
        }
    }
    for (k, d) in drafts.iter_mut().enumerate() {
        let erode = rng.gen_bool(config.erode_probability.clamp(0.0, 1.0));
        let hole =
            d.pixels.len() > config.hole_min_area_px && rng.gen_bool(config.hole_probability.clamp(0.0, 1.0));
        if hole {
            let centre = d.pixels[rng.gen_range(0..d.pixels.len())] as usize;
            let (cx, cy) = ((centre % w) as i64, (centre / w) as i64);
            let [lo, hi] = config.hole_radius_px;
            let r: i64 = rng.gen_range(lo..=hi);
            d.pixels.retain(|&p| {
                let (x, y) = ((p as usize % w) as i64, (p as usize / w) as i64);
                (x - cx) * (x - cx) + (y - cy) * (y - cy) > r * r
            });
        }
        if erode {
            let me = k as u32;
            d.pixels.retain(|&p| {
                let i = p as usize;
                let (x, y) = (i % w, i / w);
                let other = |j: usize| owner[j] != me;
                !((x > 0 && other(i - 1))
                    || (x + 1 < w && other(i + 1))
                    || (y > 0 && other(i - w))
                    || (y + 1 < h && other(i + w)))
            });
        }
    }
}

/// For objects split into several masks, sometimes one more mask covering the whole object.
fn add_whole_object_masks(
    drafts: &mut Vec<Draft>,
    instance: &Plane<u32>,
    config: &SamSimConfig,
    rng: &mut ChaCha8Rng,
) {
    let mut per_id: std::collections::BTreeMap<u32, usize> = std::collections::BTreeMap::new();
    for d in drafts.iter().filter(|d| d.source_id >= FIRST_OBJECT_ID) {
        *per_id.entry(d.source_id).or_default() += 1;
    }
    for (id, count) in per_id {
        if count >= 2 && rng.gen_bool(config.whole_object_probability.clamp(0.0, 1.0)) {
            let pixels = pixels_of(instance, &[id]);
            drafts.push(Draft { pixels, source_id: id });
        }
    }
}

/// Where the white pair touches in this view, sometimes a wrong mask covering both.
fn add_wrong_merge(
    drafts: &mut Vec<Draft>,
    input: &SamSimInput,
    config: &SamSimConfig,
    rng: &mut ChaCha8Rng,
) {
    if !touching(input.instance, input.white_pair)
        || !rng.gen_bool(config.wrong_merge_probability.clamp(0.0, 1.0))
    {
        return;
    }
    if rng.gen_bool(config.wrong_merge_replaces_probability.clamp(0.0, 1.0)) {
        drafts.retain(|d| !input.white_pair.contains(&d.source_id));
    }
    drafts.push(Draft { pixels: pixels_of(input.instance, &input.white_pair), source_id: 0 });
}

/// Grows some masks by one pixel (4-neighbourhood), onto whatever is next to them.
/// `scratch`: `[w · h]`, all `false` on entry and on return.
fn dilate_some(
    drafts: &mut [Draft],
    w: usize,
    h: usize,
    probability: f64,
    rng: &mut ChaCha8Rng,
    scratch: &mut [bool],
) {
    for d in drafts.iter_mut() {
        if !rng.gen_bool(probability.clamp(0.0, 1.0)) {
            continue;
        }
        for &p in &d.pixels {
            scratch[p as usize] = true;
        }
        let mut grown = d.pixels.clone();
        for &p in &d.pixels {
            let i = p as usize;
            let (x, y) = (i % w, i / w);
            let around = [
                (x > 0).then(|| i - 1),
                (x + 1 < w).then(|| i + 1),
                (y > 0).then(|| i - w),
                (y + 1 < h).then(|| i + w),
            ];
            for j in around.into_iter().flatten() {
                if !scratch[j] {
                    scratch[j] = true;
                    grown.push(j as u32);
                }
            }
        }
        for &p in &grown {
            scratch[p as usize] = false;
        }
        grown.sort_unstable();
        d.pixels = grown;
    }
}

/// Minimum length of the contact (4-adjacent pixel pairs) for two objects to count as
/// touching in the image, for the wrong adjacent merges.
const ADJACENT_CONTACT_PX: usize = 6;

/// Pairs of objects (ids ≥ [`FIRST_OBJECT_ID`], other than the white pair) touching in the
/// image along at least [`ADJACENT_CONTACT_PX`] pixel pairs, sorted.
fn touching_object_pairs(instance: &Plane<u32>, white_pair: [u32; 2]) -> Vec<[u32; 2]> {
    let (w, h) = instance.size();
    let mut contacts: std::collections::BTreeMap<[u32; 2], usize> = Default::default();
    let mut count = |a: u32, b: u32| {
        if a != b && a >= FIRST_OBJECT_ID && b >= FIRST_OBJECT_ID {
            *contacts.entry([a.min(b), a.max(b)]).or_default() += 1;
        }
    };
    for y in 0..h {
        for x in 0..w {
            let a = *instance.get(x, y);
            if x + 1 < w {
                count(a, *instance.get(x + 1, y));
            }
            if y + 1 < h {
                count(a, *instance.get(x, y + 1));
            }
        }
    }
    let mut white = white_pair;
    white.sort_unstable();
    contacts.into_iter().filter(|&(p, n)| n >= ADJACENT_CONTACT_PX && p != white).map(|(p, _)| p).collect()
}

/// Where two objects touch in the image, sometimes one wrong mask covering both (SAM merging
/// adjacent objects), added or replacing their masks.
fn add_adjacent_merges(
    drafts: &mut Vec<Draft>,
    input: &SamSimInput,
    config: &SamSimConfig,
    rng: &mut ChaCha8Rng,
) {
    if config.adjacent_merge_probability <= 0.0 {
        return;
    }
    for pair in touching_object_pairs(input.instance, input.white_pair) {
        if !rng.gen_bool(config.adjacent_merge_probability.clamp(0.0, 1.0)) {
            continue;
        }
        if rng.gen_bool(config.wrong_merge_replaces_probability.clamp(0.0, 1.0)) {
            drafts.retain(|d| !pair.contains(&d.source_id));
        }
        drafts.push(Draft { pixels: pixels_of(input.instance, &pair), source_id: 0 });
    }
}

/// Pixel indices whose instance is one of `ids`.
fn pixels_of(instance: &Plane<u32>, ids: &[u32]) -> Vec<u32> {
    (0..instance.data.len()).filter(|&i| ids.contains(&instance.data[i])).map(|i| i as u32).collect()
}

/// True when a pixel of `ids[0]` is 4-adjacent to a pixel of `ids[1]`.
pub fn touching(instance: &Plane<u32>, ids: [u32; 2]) -> bool {
    let (w, h) = instance.size();
    let is = |x: usize, y: usize, id: u32| *instance.get(x, y) == id;
    (0..h).any(|y| {
        (0..w).any(|x| {
            let a = *instance.get(x, y);
            let other = if a == ids[0] {
                ids[1]
            } else if a == ids[1] {
                ids[0]
            } else {
                return false;
            };
            (x + 1 < w && is(x + 1, y, other)) || (y + 1 < h && is(x, y + 1, other))
        })
    })
}

/// SAM's JSON record of a mask: RLE, box, area, quality scores and the prompt point.
fn to_sam_mask(pixels: &[u32], w: usize, h: usize, rng: &mut ChaCha8Rng) -> SamMask {
    let mut plane = Plane::filled(w, h, false);
    for &p in pixels {
        plane.data[p as usize] = true;
    }
    let mut mask = SamMask::from_rle(Rle::encode(&plane));
    mask.predicted_iou = rng.gen_range(0.86..0.995);
    mask.stability_score = rng.gen_range(0.88..0.99);
    let p = pixels[rng.gen_range(0..pixels.len())] as usize;
    mask.point_coords = vec![[(p % w) as f64 + 0.5, (p / w) as f64 + 0.5]];
    mask
}

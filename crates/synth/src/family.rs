//! Families of synthetic scenes: a name and a seed give a [`SynthConfig`] whose knobs are drawn
//! at random within the family's ranges (`splatseg synth --family rooms --seed 7`).
//!
//! | family | what varies |
//! | --- | --- |
//! | `default` | today's scene: the fixed plan, 12 views of 320×240 (byte-identical to before the suite) |
//! | `rooms` | random rooms: 6–14 objects placed at random, walls plain / two-tone / striped, floors of planks, stripes or checkers at several scales, 0–1 thin post, border-cut foreground object, stacked and touching pair; 24 views of 320×240, 384-d features |
//! | `multi_tone` | rooms whose walls and floor are always two-toned and most objects striped or two-tone |
//! | `thin` | rooms with 2–4 posts 2–4 px wide |
//! | `border` | rooms with 1–2 large textured objects near the cameras, cut by the image border |
//! | `clutter` | 10–14 objects, 1–2 stacked, 1–2 touching pairs |
//! | `sam_noise` | rooms with heavy SAM noise: holes, wrong merges of adjacent objects, whole-object masks over their parts, 1-px dilation |
//! | `hires` | the `rooms` scene of the same seed at 1280×960 (SAM's pixel settings scaled) |
//! | `many_views` | the `rooms` scene of the same seed seen by 12–100 views |
//! | `rough` | the `rooms` scene of the same seed with Gaussians as a trained 3DGS leaves them: tilted 10°–30° off their surfaces, thicker and moved off them (a tuning family: `blind_rough` judges what is chosen on it) |
//! | `blind_cues` | **blind**: rooms with harsher cues — features noisier, parts of one object and different objects closer, depth with 3× the smooth error and a blur, more nested whole-object masks and wrong merges |
//! | `blind_lens` | **blind**: rooms seen through lenses of 40°–75° horizontal field of view |
//! | `blind_512` | **blind**: rooms at 512×384, harsher cues, lenses of 40°–75° |
//! | `blind_hires` | **blind**: rooms at 1280×960 with fine stripes and checkers on most objects, harsher cues |
//! | `blind_sam` | **blind**: rooms whose SAM output seldom nests a whole-object mask over an object's parts and often has one mask over two touching objects; 400×300, 16 views, lenses of 45°–70°, harsher cues |
//! | `blind_near` | **blind**: 2–3 large textured objects near the cameras, cut by the border, 1–2 stacks, parts of one object further apart in feature space, SAM seldom nesting wholes; 480×360, 20 views, lenses of 50°–65°, harsher cues |
//! | `blind_rough` | **blind**: Gaussians as a trained 3DGS leaves them — discs tilted 15°–25° off their surfaces, thicker and moved off them — in cluttered rooms with touching and stacked objects; 400×300, 24 views, lenses of 45°–70°, harsher cues |
//! | `blind_trained` | **blind**: Gaussians as a trained 3DGS leaves them in more ways — tilted 5°–35°, thicker, off the surface, in-plane sizes spread and elongated, 1–3 % floaters in free space — in rooms with striped or checkered floors, touching and multi-coloured objects; 512×384, 28 views, lenses of 50°–75°, harsher cues |
//! | `blind_parts` | **blind**: rooms of multi-coloured objects whose parts are far apart in feature space (cos ≈ 0.72–0.80), 1–2 large objects near the cameras, touching and stacked objects, SAM nesting wholes 40 % of the time; 448×336, 22 views, lenses of 45°–70°, harsher cues |
//! | `blind_closeup` | **blind**: 2–3 large multi-coloured objects near the cameras, parts far apart in feature space, seen through Gaussians as a trained 3DGS leaves them (tilted 8°–20°), SAM seldom nesting wholes; 384×288, 30 views, lenses of 55°–75°, harsher cues |
//! | `blind_alike` | **blind**: rooms whose objects are closer in feature space than any other family's (two objects ≈ 0.6–0.85 alike), 2–3 touching pairs, stacks, multi-coloured objects SAM seldom covers whole, often one mask over two touching objects; 576×432, 26 views, lenses of 45°–65°, harsher cues |
//! | `blind_contact` | **blind**: rooms full of objects in contact — 2–3 touching pairs, 2 stacks, one post, 12–16 objects — most of them multi-coloured with finer patterns, seen through a trained 3DGS's Gaussians (tilted 5°–15°, 0.5–1.5 % floaters), SAM seldom covering an object whole and often one mask over two touching objects; 416×312, 28 views, lenses of 50°–72°, harsher cues |
//! | `blind_fine` | **blind**: rooms of multi-coloured objects (85 %) with the finest stripes of any family but `blind_hires` (periods × 0.3–0.5), one large object near the cameras, touching and stacked objects, Gaussians mildly tilted (3°–12°), SAM seldom covering an object whole; 544×408, 32 views, lenses of 42°–62°, harsher cues |
//! | `blind_capture` | **blind**: a capture as a person takes it — 100 views of 1280×960 through lenses of 50°–70°, 10–14 objects with touching and stacked ones, harsher cues, SAM nesting wholes half the time |
//!
//! Every random family places the white-on-white pair and the same-depth pair.
//!
//! The **blind** families ([`Family::BLIND`]) are for judging, never for choosing a setting: their
//! rooms have their own layouts (their own salt) and their cue statistics are ones no tuning family
//! uses. A setting changed because of a blind result needs a new blind family afterwards.

use crate::config::{CueConfig, FloorPattern, LayoutKind, RoomConfig, SamSimConfig, SynthConfig, WallPaint};
use crate::noise::{rng_for, stream};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// A family of scenes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// The scene every test and floor was measured on.
    #[default]
    Default,
    /// Random rooms with every failure class now and then.
    Rooms,
    /// Multi-tone walls, floors and objects.
    MultiTone,
    /// Thin posts.
    Thin,
    /// Foreground objects cut by the image border.
    Border,
    /// Many objects, stacked and touching.
    Clutter,
    /// Heavy SAM noise.
    SamNoise,
    /// The rooms at 1280×960.
    Hires,
    /// The rooms with 12–100 views.
    ManyViews,
    /// Blind: harsher cue statistics.
    BlindCues,
    /// Blind: other lenses.
    BlindLens,
    /// Blind: 512×384, harsher cues, other lenses.
    Blind512,
    /// Blind: 1280×960, fine patterns on objects, harsher cues.
    BlindHires,
    /// Blind: SAM with few whole-object masks and more masks over touching objects (added after
    /// the merge's separate-wholes gate, which reads SAM's wholes, was motivated by blind results).
    BlindSam,
    /// Blind: 100 views of 1280×960, cluttered rooms (added after the touching joins' veto by
    /// SAM's wholes, which was motivated by blind results).
    BlindCapture,
    /// Blind: every wall and floor patterned, more touching and stacked objects, parts further
    /// apart in feature space, 640×480 (added after the merge's kept creases and the seam
    /// cosine of 0.5, whose diagnosis read blind scenes).
    BlindRooms,
    /// Blind: 2–3 large textured objects near the cameras, cut by the border, stacked objects,
    /// parts further apart in feature space, few whole-object masks, 480×360, 20 views (added when
    /// the suite began counting objects by their share of the image: the large objects under IoU
    /// 0.5 of the other blind families are border-cut foreground objects and same-depth pairs).
    BlindNear,
    /// Blind: Gaussians tilted off their surfaces, thicker and moved off them, as a trained 3DGS
    /// leaves them, in cluttered rooms (added after the crease gate read normals rendered from
    /// the Gaussians, which are exact on the other families' discs).
    BlindRough,
    /// The rooms with Gaussians tilted off their surfaces, thicker and moved off them (a tuning
    /// family; last in the enum so that the families before it keep their layout salts).
    Rough,
    /// Blind: Gaussians as a trained 3DGS leaves them in more ways than `blind_rough`'s — sizes
    /// spread, elongated, floaters in free space — in rooms with patterned floors and many
    /// multi-coloured objects (added after the lift's plane test took the Gaussians' centres as
    /// evidence beside their normals, which `blind_rough`'s result motivated).
    BlindTrained,
    /// Blind: multi-coloured objects everywhere whose parts are far apart in feature space (cos
    /// ≈ 0.72–0.80), large objects near the cameras, touching and stacked objects (added after
    /// the part join's feature floor became the seam's, whose diagnosis read blind scenes).
    BlindParts,
    /// Blind: 2–3 large multi-coloured objects near the cameras whose parts are far apart in
    /// feature space, seen through a trained 3DGS's Gaussians, few whole-object masks (added after
    /// the part join took a mostly convex edge or a curved surface as evidence, and every join
    /// refused two sets meeting at a concave edge, whose diagnosis read blind scenes).
    BlindCloseup,
    /// Blind: objects closer in feature space than any other family's, more touching pairs,
    /// multi-coloured objects SAM seldom covers whole and touching ones it often covers with one
    /// mask (added after every look-alike join came to need the views, whose diagnosis read
    /// blind scenes).
    BlindAlike,
    /// Blind: objects in contact everywhere (touching pairs, stacks, a post), most of them
    /// multi-coloured with finer patterns, seen through a trained 3DGS's Gaussians, SAM seldom
    /// covering an object whole and often covering two touching ones with one mask (added after the
    /// lift's crease split, cutting an object where two colours meet at a concave edge, whose
    /// diagnosis read blind scenes).
    BlindContact,
    /// Blind: multi-coloured objects nearly everywhere with fine stripes (each band its own SAM
    /// part; on a cylinder or sphere the bands meet with no edge), one large object near the
    /// cameras, touching and stacked objects, mildly tilted Gaussians, SAM seldom covering an
    /// object whole (added after the part join took pieces meeting with no edge, asked against
    /// the two sets' edge, whose diagnosis read blind scenes).
    BlindFine,
}

impl Family {
    /// Every family, in documentation order.
    pub const ALL: [Family; 25] = [
        Family::Default,
        Family::Rooms,
        Family::MultiTone,
        Family::Thin,
        Family::Border,
        Family::Clutter,
        Family::SamNoise,
        Family::Hires,
        Family::ManyViews,
        Family::Rough,
        Family::BlindCues,
        Family::BlindLens,
        Family::Blind512,
        Family::BlindHires,
        Family::BlindSam,
        Family::BlindCapture,
        Family::BlindRooms,
        Family::BlindNear,
        Family::BlindRough,
        Family::BlindTrained,
        Family::BlindParts,
        Family::BlindCloseup,
        Family::BlindAlike,
        Family::BlindContact,
        Family::BlindFine,
    ];

    /// The blind families: scored and reported apart, never used to choose a setting.
    pub const BLIND: &'static [Family] = Family::ALL.split_at(Family::FIRST_BLIND).1;

    /// Where the blind families start in [`Family::ALL`] (every family after them is blind).
    const FIRST_BLIND: usize = 10;

    /// True for the blind families.
    pub fn is_blind(self) -> bool {
        Family::BLIND.contains(&self)
    }

    /// Its name (`rooms`, `multi_tone`, …).
    pub fn name(self) -> &'static str {
        match self {
            Family::Default => "default",
            Family::Rooms => "rooms",
            Family::MultiTone => "multi_tone",
            Family::Thin => "thin",
            Family::Border => "border",
            Family::Clutter => "clutter",
            Family::SamNoise => "sam_noise",
            Family::Hires => "hires",
            Family::ManyViews => "many_views",
            Family::Rough => "rough",
            Family::BlindCues => "blind_cues",
            Family::BlindLens => "blind_lens",
            Family::Blind512 => "blind_512",
            Family::BlindHires => "blind_hires",
            Family::BlindSam => "blind_sam",
            Family::BlindCapture => "blind_capture",
            Family::BlindRooms => "blind_rooms",
            Family::BlindNear => "blind_near",
            Family::BlindRough => "blind_rough",
            Family::BlindTrained => "blind_trained",
            Family::BlindParts => "blind_parts",
            Family::BlindCloseup => "blind_closeup",
            Family::BlindAlike => "blind_alike",
            Family::BlindContact => "blind_contact",
            Family::BlindFine => "blind_fine",
        }
    }

    /// The family of a name (`-` and `_` alike).
    pub fn from_name(name: &str) -> Option<Family> {
        let name = name.trim().replace('-', "_");
        Family::ALL.into_iter().find(|f| f.name() == name)
    }

    /// True for [`Family::Default`] (serde: the field is left out).
    pub fn is_default(&self) -> bool {
        *self == Family::Default
    }

    /// Salt of the random layout: families that are the same room at another resolution or
    /// view count share the `rooms` layout of their seed.
    pub fn layout_salt(self) -> u64 {
        match self {
            Family::Hires | Family::ManyViews | Family::Rough => Family::Rooms as u64,
            f => f as u64,
        }
    }

    /// The config of scene `seed` of this family.
    pub fn config(self, seed: u64) -> SynthConfig {
        if self == Family::Default {
            return SynthConfig { seed, ..SynthConfig::default() };
        }
        let mut rng = rng_for(seed, stream::FAMILY, self.layout_salt());
        let mut c = rooms_config(seed, &mut rng);
        c.family = self;
        let r = &mut c.room;
        match self {
            Family::Default | Family::Rooms => {}
            Family::MultiTone => {
                r.walls = if rng.gen_bool(0.5) { WallPaint::TwoTone } else { WallPaint::Stripes };
                r.wall_scale_m = wall_scale(r.walls, &mut rng);
                r.floor = if rng.gen_bool(0.5) { FloorPattern::Stripes } else { FloorPattern::Checkers };
                r.floor_scale_m = rng.gen_range(0.35..1.4);
                r.multi_tone_share = 0.7;
            }
            Family::Thin => r.thin_posts = rng.gen_range(2..=4),
            Family::Border => r.foreground_objects = rng.gen_range(1..=2),
            Family::Clutter => {
                r.objects = [10, 14];
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
            }
            Family::SamNoise => {
                c.sam = SamSimConfig {
                    hole_probability: 0.6,
                    hole_radius_px: [2, 5],
                    whole_object_probability: 0.7,
                    wrong_merge_probability: 0.6,
                    adjacent_merge_probability: 0.35,
                    dilate_probability: 0.3,
                    erode_probability: 0.3,
                    ..c.sam
                };
            }
            Family::Hires => resize(&mut c, 1280, 960),
            Family::ManyViews => c.views = rng.gen_range(12..=100),
            Family::Rough => {
                c.cues.gaussian_tilt_deg = rng.gen_range(10.0..30.0);
                c.cues.gaussian_thickness = rng.gen_range(0.1..0.35);
                c.cues.gaussian_offset = rng.gen_range(0.05..0.3);
            }
            Family::BlindCues => harsher_cues(&mut c, &mut rng),
            Family::BlindLens => c.fov_x_deg = rng.gen_range(40.0..75.0),
            Family::Blind512 => {
                c.fov_x_deg = rng.gen_range(40.0..75.0);
                resize(&mut c, 512, 384);
                harsher_cues(&mut c, &mut rng);
            }
            Family::BlindHires => {
                let r = &mut c.room;
                r.multi_tone_share = 0.6;
                r.pattern_scale = rng.gen_range(0.35..0.6);
                resize(&mut c, 1280, 960);
                harsher_cues(&mut c, &mut rng);
            }
            Family::BlindSam => {
                c.fov_x_deg = rng.gen_range(45.0..70.0);
                c.views = 16;
                resize(&mut c, 400, 300);
                harsher_cues(&mut c, &mut rng);
                // SAM's hierarchy at its weakest: an object cut into parts seldom gets a mask
                // over the whole (tuning 0.45, the other blind families 0.8), and touching
                // objects often share one wrong mask (tuning 0.1; replacing their masks half
                // the time), which says "together" where the objects are two.
                c.sam.whole_object_probability = 0.15;
                c.sam.adjacent_merge_probability = 0.35;
            }
            Family::BlindCapture => {
                let r = &mut c.room;
                r.objects = [10, 14];
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
                c.fov_x_deg = rng.gen_range(50.0..70.0);
                c.views = 100;
                resize(&mut c, 1280, 960);
                harsher_cues(&mut c, &mut rng);
                c.sam.whole_object_probability = 0.5;
                c.sam.adjacent_merge_probability = 0.2;
            }
            Family::BlindRooms => {
                let r = &mut c.room;
                r.walls = if rng.gen_bool(0.5) { WallPaint::TwoTone } else { WallPaint::Stripes };
                r.wall_scale_m = wall_scale(r.walls, &mut rng);
                r.floor = if rng.gen_bool(0.5) { FloorPattern::Stripes } else { FloorPattern::Checkers };
                r.floor_scale_m = rng.gen_range(0.5..1.8);
                r.objects = [8, 12];
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.5;
                c.fov_x_deg = rng.gen_range(45.0..70.0);
                c.views = 32;
                resize(&mut c, 640, 480);
                harsher_cues(&mut c, &mut rng);
                // Parts of one object further apart than in the other blind families (0.37–0.45).
                c.cues.part_perturbation = rng.gen_range(0.45..0.52);
                c.sam.adjacent_merge_probability = 0.3;
            }
            Family::BlindNear => {
                let r = &mut c.room;
                r.foreground_objects = rng.gen_range(2..=3);
                r.stacked = rng.gen_range(1..=2);
                r.multi_tone_share = 0.6;
                c.fov_x_deg = rng.gen_range(50.0..65.0);
                c.views = 20;
                resize(&mut c, 480, 360);
                harsher_cues(&mut c, &mut rng);
                c.cues.part_perturbation = rng.gen_range(0.45..0.52);
                // Few masks over a whole object: its parts must be joined from 3D and the views.
                c.sam.whole_object_probability = 0.3;
            }
            Family::BlindRough => {
                let r = &mut c.room;
                r.objects = [8, 12];
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.6;
                c.fov_x_deg = rng.gen_range(45.0..70.0);
                c.views = 24;
                resize(&mut c, 400, 300);
                harsher_cues(&mut c, &mut rng);
                // A trained 3DGS's Gaussians: shortest axes 15°–25° off the surface normal (per
                // tangent axis), thickness a quarter to a half of the in-plane σ (0.6 spacing),
                // centres 0.1–0.3 spacing off the surface.
                c.cues.gaussian_tilt_deg = rng.gen_range(15.0..25.0);
                c.cues.gaussian_thickness = rng.gen_range(0.15..0.3);
                c.cues.gaussian_offset = rng.gen_range(0.1..0.3);
                c.sam.whole_object_probability = 0.5;
            }
            Family::BlindTrained => {
                let r = &mut c.room;
                r.floor = if rng.gen_bool(0.5) { FloorPattern::Stripes } else { FloorPattern::Checkers };
                r.floor_scale_m = rng.gen_range(0.4..1.6);
                r.objects = [7, 11];
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.6;
                c.fov_x_deg = rng.gen_range(50.0..75.0);
                c.views = 28;
                resize(&mut c, 512, 384);
                harsher_cues(&mut c, &mut rng);
                // A trained 3DGS's Gaussians in more ways than blind_rough's: tilted 5°–35°,
                // thickness 0.1–0.4 of the spacing, centres 0.05–0.25 spacing off the surface,
                // in-plane sizes spread by a factor of e^±(0.25–0.45) per axis, and 1–3 % floaters.
                c.cues.gaussian_tilt_deg = rng.gen_range(5.0..35.0);
                c.cues.gaussian_thickness = rng.gen_range(0.1..0.4);
                c.cues.gaussian_offset = rng.gen_range(0.05..0.25);
                c.cues.gaussian_scale_spread = rng.gen_range(0.25..0.45);
                c.cues.gaussian_floaters = rng.gen_range(0.01..0.03);
            }
            Family::BlindParts => {
                let r = &mut c.room;
                r.objects = [10, 14];
                r.foreground_objects = rng.gen_range(1..=2);
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.8;
                c.fov_x_deg = rng.gen_range(45.0..70.0);
                c.views = 22;
                resize(&mut c, 448, 336);
                harsher_cues(&mut c, &mut rng);
                // Parts of one object further apart than in any other family (cos ≈ 0.72–0.80;
                // blind_rooms and blind_near ≈ 0.79–0.83), closer to what two different objects
                // share (≈ 0.55–0.63): the parts must be joined by the geometry and the views.
                c.cues.part_perturbation = rng.gen_range(0.5..0.62);
                c.sam.whole_object_probability = 0.4;
                c.sam.adjacent_merge_probability = 0.2;
            }
            Family::BlindCloseup => {
                let r = &mut c.room;
                r.objects = [10, 16];
                r.foreground_objects = rng.gen_range(2..=3);
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.7;
                c.fov_x_deg = rng.gen_range(55.0..75.0);
                c.views = 30;
                resize(&mut c, 384, 288);
                harsher_cues(&mut c, &mut rng);
                // Parts between blind_near's and blind_parts' distance in feature space, and
                // Gaussians tilted, thickened and moved off their surfaces (milder than
                // blind_rough's), so that the edges the joins read are noisy.
                c.cues.part_perturbation = rng.gen_range(0.45..0.58);
                c.cues.gaussian_tilt_deg = rng.gen_range(8.0..20.0);
                c.cues.gaussian_thickness = rng.gen_range(0.1..0.3);
                c.cues.gaussian_offset = rng.gen_range(0.05..0.2);
                c.sam.whole_object_probability = 0.25;
            }
            Family::BlindAlike => {
                let r = &mut c.room;
                r.objects = [8, 12];
                r.stacked = rng.gen_range(1..=2);
                r.touching = rng.gen_range(2..=3);
                r.multi_tone_share = 0.6;
                c.fov_x_deg = rng.gen_range(45.0..65.0);
                c.views = 26;
                resize(&mut c, 576, 432);
                harsher_cues(&mut c, &mut rng);
                // Objects less distinct than anywhere else (two objects ≈ 0.6–0.85 alike; the other
                // blind families 0.45–0.75, tuning 0.35–0.6): look-alike touching objects are the
                // rule, and SAM seldom gives a mask over a whole object but often one over two
                // touching objects (which says "together" where the objects are two).
                c.cues.shared_share = [0.6, 0.85];
                c.sam.whole_object_probability = 0.2;
                c.sam.adjacent_merge_probability = 0.3;
            }
            Family::BlindContact => {
                let r = &mut c.room;
                // The pairs, stacks, post and the two hard-case pairs alone are 11–15 objects.
                r.objects = [12, 16];
                r.stacked = 2;
                r.touching = rng.gen_range(2..=3);
                r.thin_posts = 1;
                r.multi_tone_share = 0.75;
                r.pattern_scale = rng.gen_range(0.5..0.9);
                c.fov_x_deg = rng.gen_range(50.0..72.0);
                c.views = 28;
                resize(&mut c, 416, 312);
                harsher_cues(&mut c, &mut rng);
                // Gaussians as a trained 3DGS leaves them, milder than blind_trained's (tilted
                // 5°–15°, 0.5–1.5 % floaters), so the contacts the lift reads are noisy; SAM seldom
                // covers an object whole and often covers two touching objects with one mask.
                c.cues.gaussian_tilt_deg = rng.gen_range(5.0..15.0);
                c.cues.gaussian_thickness = rng.gen_range(0.1..0.25);
                c.cues.gaussian_offset = rng.gen_range(0.05..0.15);
                c.cues.gaussian_scale_spread = rng.gen_range(0.15..0.3);
                c.cues.gaussian_floaters = rng.gen_range(0.005..0.015);
                c.sam.whole_object_probability = 0.35;
                c.sam.adjacent_merge_probability = 0.3;
            }
            Family::BlindFine => {
                let r = &mut c.room;
                r.objects = [9, 13];
                r.foreground_objects = 1;
                r.stacked = 1;
                r.touching = rng.gen_range(1..=2);
                r.multi_tone_share = 0.85;
                r.pattern_scale = rng.gen_range(0.3..0.5);
                c.fov_x_deg = rng.gen_range(42.0..62.0);
                c.views = 32;
                resize(&mut c, 544, 408);
                harsher_cues(&mut c, &mut rng);
                // Parts a little further apart than harsher_cues' (0.37–0.45), Gaussians tilted
                // less than any other blind family's but thinner and nearer their surfaces, and few
                // whole-object masks: the bands of a striped object must be joined in 3D.
                c.cues.part_perturbation = rng.gen_range(0.42..0.55);
                c.cues.gaussian_tilt_deg = rng.gen_range(3.0..12.0);
                c.cues.gaussian_thickness = rng.gen_range(0.05..0.2);
                c.cues.gaussian_offset = rng.gen_range(0.03..0.12);
                c.sam.whole_object_probability = 0.3;
                c.sam.adjacent_merge_probability = 0.25;
            }
        }
        c
    }
}

impl std::fmt::Display for Family {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `c` at `width × height` (SAM's pixel settings scaled by the width's factor).
fn resize(c: &mut SynthConfig, width: u32, height: u32) {
    let scale = width as f64 / c.width as f64;
    c.width = width;
    c.height = height;
    c.sam = c.sam.scaled(scale);
}

/// Cue statistics nearer what real models give on real captures than the tuning families':
/// DINOv2-like tokens whose parts of one object are ≈ 0.83–0.88 alike (the tuning families: ≈ 0.92),
/// noisier patches, objects less distinct, a monocular depth with three times the smooth error, twice
/// the pixel noise and a blur of 2 px per 320 px of width, SAM output with more nested whole-object
/// masks and more wrong merges.
fn harsher_cues(c: &mut SynthConfig, rng: &mut ChaCha8Rng) {
    c.cues = CueConfig {
        part_perturbation: rng.gen_range(0.37..0.45),
        patch_noise: rng.gen_range(0.3..0.4),
        drift: rng.gen_range(0.14..0.2),
        shared_share: [0.45, 0.75],
        depth_scale_error: 0.36,
        depth_shift_error: 0.15,
        depth_pixel_noise: 0.016,
        depth_blur_px: (2 * c.width as usize).div_ceil(320),
        ..CueConfig::default()
    };
    c.sam.whole_object_probability = 0.8;
    c.sam.wrong_merge_probability = 0.5;
    c.sam.adjacent_merge_probability = 0.25;
}

fn wall_scale(walls: WallPaint, rng: &mut ChaCha8Rng) -> f64 {
    match walls {
        WallPaint::TwoTone => rng.gen_range(0.7..1.4),
        _ => rng.gen_range(0.3..0.9),
    }
}

/// The `rooms` family: the base every random family starts from.
fn rooms_config(seed: u64, rng: &mut ChaCha8Rng) -> SynthConfig {
    let walls = match rng.gen_range(0..4) {
        0 | 1 => WallPaint::Plain,
        2 => WallPaint::TwoTone,
        _ => WallPaint::Stripes,
    };
    let wall_scale_m = wall_scale(walls, rng);
    let floor = match rng.gen_range(0..10) {
        0..=3 => FloorPattern::Planks,
        4..=6 => FloorPattern::Stripes,
        _ => FloorPattern::Checkers,
    };
    let room = RoomConfig {
        layout: LayoutKind::Random,
        objects: [6, 14],
        walls,
        wall_scale_m,
        floor,
        floor_scale_m: rng.gen_range(0.35..1.4),
        tone_parts: true,
        thin_posts: rng.gen_range(0..=1),
        thin_post_px: 3.0,
        foreground_objects: rng.gen_range(0..=1),
        stacked: rng.gen_range(0..=1),
        touching: rng.gen_range(0..=1),
        multi_tone_share: 0.3,
        pattern_scale: 1.0,
    };
    let sam = SamSimConfig {
        whole_object_probability: 0.45,
        adjacent_merge_probability: 0.1,
        dilate_probability: 0.1,
        ..SamSimConfig::default()
    };
    SynthConfig { seed, views: 24, feature_dim: 384, room, sam, ..SynthConfig::default() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_default_is_the_default_config() {
        for f in Family::ALL {
            assert_eq!(Family::from_name(f.name()), Some(f));
        }
        assert_eq!(Family::from_name("sam-noise"), Some(Family::SamNoise));
        assert_eq!(Family::from_name("nope"), None);
        assert_eq!(Family::Default.config(4), SynthConfig { seed: 4, ..SynthConfig::default() });
    }

    #[test]
    fn families_set_their_knobs_and_hires_is_the_rooms_scene_scaled() {
        for seed in 0..20 {
            let rooms = Family::Rooms.config(seed);
            assert_eq!(rooms.room.layout, LayoutKind::Random);
            assert!((2..=4).contains(&Family::Thin.config(seed).room.thin_posts));
            assert!(Family::Border.config(seed).room.foreground_objects >= 1);
            let hires = Family::Hires.config(seed);
            assert_eq!((hires.width, hires.height), (1280, 960));
            assert_eq!(hires.room, rooms.room);
            assert_eq!(hires.sam.min_area_px, rooms.sam.min_area_px * 16);
            let many = Family::ManyViews.config(seed);
            assert!((12..=100).contains(&many.views));
            assert_eq!(many.room, rooms.room);
        }
        let walls: std::collections::BTreeSet<String> =
            (0..20).map(|s| format!("{:?}", Family::Rooms.config(s).room.walls)).collect();
        assert_eq!(walls.len(), 3, "rooms draw every wall paint: {walls:?}");
    }

    #[test]
    fn blind_families_use_settings_no_tuning_family_uses() {
        let tuning: Vec<Family> = Family::ALL.into_iter().filter(|f| !f.is_blind()).collect();
        for f in Family::ALL {
            assert_eq!(f.is_blind(), f.name().starts_with("blind_"), "{f}: blind exactly when named so");
        }
        for seed in 0..20 {
            for f in tuning.iter() {
                let c = f.config(seed);
                // The tuning families' features and depth are the defaults (only `rough` moves
                // its Gaussians off the exact discs).
                let d = CueConfig::default();
                let cues = CueConfig {
                    gaussian_tilt_deg: d.gaussian_tilt_deg,
                    gaussian_thickness: d.gaussian_thickness,
                    gaussian_offset: d.gaussian_offset,
                    gaussian_scale_spread: d.gaussian_scale_spread,
                    gaussian_floaters: d.gaussian_floaters,
                    ..c.cues.clone()
                };
                assert!(cues.is_default() && c.fov_x_deg == 60.0 && c.room.pattern_scale == 1.0, "{f}");
                assert!(c.cues.is_default() || *f == Family::Rough, "{f}");
            }
            let rooms = Family::Rooms.config(seed).room;
            for &f in Family::BLIND {
                let c = f.config(seed);
                assert_ne!(c.room, rooms, "{f} has a layout of its own");
                let new_cues = !c.cues.is_default();
                let new_lens = c.fov_x_deg != 60.0;
                assert!(new_cues || new_lens, "{f} seed {seed}");
            }
            let hires = Family::BlindHires.config(seed);
            assert_eq!((hires.width, hires.height), (1280, 960));
            assert!(hires.room.pattern_scale < 0.6 && hires.cues.depth_blur_px == 8);
            let lens = Family::BlindLens.config(seed).fov_x_deg;
            assert!((40.0..75.0).contains(&lens));
            assert_eq!(Family::Blind512.config(seed).width, 512);
            let sam = Family::BlindSam.config(seed);
            assert_eq!((sam.width, sam.height, sam.views), (400, 300, 16));
            assert!(sam.sam.whole_object_probability < 0.2 && sam.sam.adjacent_merge_probability > 0.3);
            let capture = Family::BlindCapture.config(seed);
            assert_eq!((capture.width, capture.height, capture.views), (1280, 960, 100));
            assert!((50.0..70.0).contains(&capture.fov_x_deg) && capture.room.touching >= 1);
            let rooms = Family::BlindRooms.config(seed);
            assert_eq!((rooms.width, rooms.height, rooms.views), (640, 480, 32));
            assert!(
                rooms.cues.part_perturbation >= 0.45 && rooms.room.touching >= 1 && rooms.room.stacked >= 1
            );
            assert!(rooms.room.walls != WallPaint::Plain && rooms.room.floor != FloorPattern::Planks);
            let near = Family::BlindNear.config(seed);
            assert_eq!((near.width, near.height, near.views), (480, 360, 20));
            assert!(near.room.foreground_objects >= 2 && near.cues.part_perturbation >= 0.45);
            assert!(near.sam.whole_object_probability < 0.35 && (50.0..65.0).contains(&near.fov_x_deg));
            let tuned = Family::Rough.config(seed);
            let rooms = SynthConfig { cues: CueConfig::default(), family: Family::Rooms, ..tuned.clone() };
            assert_eq!(rooms, Family::Rooms.config(seed), "the rooms scene of the same seed");
            assert!((10.0..30.0).contains(&tuned.cues.gaussian_tilt_deg) && !tuned.family.is_blind());
            let rough = Family::BlindRough.config(seed);
            assert_eq!((rough.width, rough.height, rough.views), (400, 300, 24));
            assert!(rough.cues.gaussian_tilt_deg >= 15.0 && rough.cues.gaussian_thickness >= 0.15);
            assert!(rough.cues.gaussian_offset >= 0.1 && rough.room.touching >= 1);
            let trained = Family::BlindTrained.config(seed);
            assert_eq!((trained.width, trained.height, trained.views), (512, 384, 28));
            assert!(trained.cues.gaussian_scale_spread >= 0.25 && trained.cues.gaussian_floaters >= 0.01);
            assert!(tuned.cues.gaussian_scale_spread == 0.0 && tuned.cues.gaussian_floaters == 0.0);
            let parts = Family::BlindParts.config(seed);
            assert_eq!((parts.width, parts.height, parts.views), (448, 336, 22));
            assert!(parts.cues.part_perturbation >= 0.5 && parts.room.multi_tone_share >= 0.8);
            assert!(
                parts.room.foreground_objects >= 1 && parts.room.touching >= 1 && parts.room.stacked >= 1
            );
            let closeup = Family::BlindCloseup.config(seed);
            assert_eq!((closeup.width, closeup.height, closeup.views), (384, 288, 30));
            assert!(closeup.room.foreground_objects >= 2 && closeup.cues.part_perturbation >= 0.45);
            assert!(
                (8.0..20.0).contains(&closeup.cues.gaussian_tilt_deg)
                    && closeup.sam.whole_object_probability < 0.3
            );
            let alike = Family::BlindAlike.config(seed);
            assert_eq!((alike.width, alike.height, alike.views), (576, 432, 26));
            assert!(alike.cues.shared_share[0] >= 0.6 && alike.room.touching >= 2);
            assert!(alike.sam.whole_object_probability < 0.25 && alike.family.is_blind());
            let contact = Family::BlindContact.config(seed);
            assert_eq!((contact.width, contact.height, contact.views), (416, 312, 28));
            assert!(contact.room.touching >= 2 && contact.room.stacked == 2 && contact.room.thin_posts == 1);
            assert!(
                (5.0..15.0).contains(&contact.cues.gaussian_tilt_deg)
                    && contact.cues.gaussian_floaters >= 0.005
                    && contact.family.is_blind()
            );
            let fine = Family::BlindFine.config(seed);
            assert_eq!((fine.width, fine.height, fine.views), (544, 408, 32));
            assert!(fine.room.multi_tone_share >= 0.85 && fine.room.pattern_scale < 0.5);
            assert!(
                (3.0..12.0).contains(&fine.cues.gaussian_tilt_deg)
                    && (42.0..62.0).contains(&fine.fov_x_deg)
                    && fine.sam.whole_object_probability <= 0.3
            );
        }
    }
}

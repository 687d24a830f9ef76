//! Failure classes: what makes a ground-truth instance hard, so scores can be broken down per
//! class (`splatseg bench quality`). Some are by construction (a thin post, a stacked box),
//! some measured on the rendered views (cut by the border, occluded).

use crate::hard_cases::HardCases;
use crate::layout::{HardCase, ObjectKind, SceneObject};
use serde::{Deserialize, Serialize};

/// Share of the views showing an object in which the image border must cut it for
/// [`FailureClass::BorderCut`].
pub const BORDER_CUT_SHARE: f64 = 0.5;
/// Share of the views showing an object in which it must be partly hidden for
/// [`FailureClass::Occluded`].
pub const OCCLUDED_SHARE: f64 = 0.25;

/// Why an instance may be hard to segment.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FailureClass {
    /// Floor or wall (large, cut into pieces by SAM, always cut by the border).
    Room,
    /// Several tones (stripes, two tones; walls and floors of two tones): SAM gives each tone
    /// its own masks, the features of the parts agree (cos ≈ 0.9).
    MultiTone,
    /// A post 2–4 pixels wide in the image.
    Thin,
    /// An object (not floor or wall) the image border cuts in at least half the views that
    /// show it.
    BorderCut,
    /// Stands on another object, or carries one.
    Stacked,
    /// Touches another object in 3D (besides the same-depth pair).
    Touching,
    /// One of the white-on-white pair.
    WhitePair,
    /// One of the same-depth pair.
    SameDepthPair,
    /// Partly hidden (≥ 10 % of its pixels) in at least a quarter of the views that show it.
    Occluded,
    /// An object in none of the classes above (the control group).
    Plain,
}

impl FailureClass {
    /// Every class, in table order.
    pub const ALL: [FailureClass; 10] = [
        FailureClass::Room,
        FailureClass::MultiTone,
        FailureClass::Thin,
        FailureClass::BorderCut,
        FailureClass::Stacked,
        FailureClass::Touching,
        FailureClass::WhitePair,
        FailureClass::SameDepthPair,
        FailureClass::Occluded,
        FailureClass::Plain,
    ];

    /// Its name in tables and JSON (`multi_tone`, …).
    pub fn name(self) -> &'static str {
        match self {
            FailureClass::Room => "room",
            FailureClass::MultiTone => "multi_tone",
            FailureClass::Thin => "thin",
            FailureClass::BorderCut => "border_cut",
            FailureClass::Stacked => "stacked",
            FailureClass::Touching => "touching",
            FailureClass::WhitePair => "white_pair",
            FailureClass::SameDepthPair => "same_depth_pair",
            FailureClass::Occluded => "occluded",
            FailureClass::Plain => "plain",
        }
    }
}

/// The classes of every object (`[objects]`, same order), sorted. `visible_views[k]`: how
/// many views show object `k`.
pub fn failure_classes(
    objects: &[SceneObject],
    hard_cases: &HardCases,
    visible_views: &[usize],
) -> Vec<Vec<FailureClass>> {
    objects
        .iter()
        .zip(visible_views)
        .map(|(o, &seen)| {
            let mut classes = o.design.clone();
            let room = matches!(o.kind, ObjectKind::Floor | ObjectKind::Wall);
            if room {
                classes.push(FailureClass::Room);
            }
            if o.texture.is_multi_tone() {
                classes.push(FailureClass::MultiTone);
            }
            if o.tags.contains(&HardCase::WhiteOnWhite) {
                classes.push(FailureClass::WhitePair);
            }
            if o.tags.contains(&HardCase::SameDepthPair) {
                classes.push(FailureClass::SameDepthPair);
            }
            let share = |n: usize| n as f64 / seen.max(1) as f64;
            let cut = hard_cases.frame_cuts.iter().filter(|c| c.id == o.id).count();
            if !room && seen > 0 && share(cut) >= BORDER_CUT_SHARE {
                classes.push(FailureClass::BorderCut);
            }
            let hidden = hard_cases.occlusions.iter().filter(|c| c.id == o.id).count();
            if !room && seen > 0 && share(hidden) >= OCCLUDED_SHARE {
                classes.push(FailureClass::Occluded);
            }
            if classes.is_empty() {
                classes.push(FailureClass::Plain);
            }
            classes.sort_unstable();
            classes.dedup();
            classes
        })
        .collect()
}

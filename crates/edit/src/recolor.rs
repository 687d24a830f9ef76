//! Recolouring Gaussians by object id, for looking at a segmentation in any 3DGS viewer.

use crate::error::EditError;
use crate::select::object_ids;
use serde::{Deserialize, Serialize};
use splatseg_scene::gaussians::SH_C0;
use splatseg_scene::Gaussians;

/// What colour Gaussians without an object (id ≤ 0) get.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnlabelledStyle {
    /// A flat dark grey, so labelled objects stand out (default).
    #[default]
    Grey,
    /// Their own colours, view-dependent part included.
    Keep,
}

/// The dark grey given to unlabelled Gaussians with [`UnlabelledStyle::Grey`].
pub const UNLABELLED_GREY: [u8; 3] = [64, 64, 64];

/// The palette colour of object `id` (the same as in every label-map overlay), or for id ≤ 0
/// what `style` says (`None` = keep the Gaussian's own colour).
pub fn palette_colour(id: i32, style: UnlabelledStyle) -> Option<[u8; 3]> {
    if id > 0 {
        Some(splatseg_scene::labels::colour_of_id(id as u32))
    } else {
        match style {
            UnlabelledStyle::Grey => Some(UNLABELLED_GREY),
            UnlabelledStyle::Keep => None,
        }
    }
}

/// The degree-0 SH coefficient that renders as `rgb` (inverse of `colour = SH_C0 · f_dc + 0.5`).
pub fn sh_dc_of_rgb(rgb: [u8; 3]) -> [f32; 3] {
    rgb.map(|c| (c as f32 / 255.0 - 0.5) / SH_C0)
}

/// A copy of `g` where every Gaussian for which `palette(object_id)` gives a colour has that flat
/// colour (`f_dc` set, its `f_rest` zeroed so it looks the same from every side); Gaussians
/// where it gives `None` and every other property are unchanged. Fails without object ids.
pub fn recolor(g: &Gaussians, palette: impl Fn(i32) -> Option<[u8; 3]>) -> Result<Gaussians, EditError> {
    let ids = object_ids(g)?;
    let mut out = g.clone();
    let k3 = 3 * g.rest_per_channel();
    for (i, &id) in ids.iter().enumerate() {
        if let Some(rgb) = palette(id) {
            out.sh_dc[i] = sh_dc_of_rgb(rgb);
            out.sh_rest[i * k3..(i + 1) * k3].fill(0.0);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::labelled_gaussians;

    #[test]
    fn colours_render_back_to_the_palette() {
        let g = labelled_gaussians(&[5, -1, 2]);
        let out = recolor(&g, |id| palette_colour(id, UnlabelledStyle::Grey)).unwrap();
        for (i, id) in [5, -1, 2].into_iter().enumerate() {
            let want = palette_colour(id, UnlabelledStyle::Grey).unwrap();
            let got = out.base_colour(i).map(|c| (c * 255.0).round() as u8);
            assert_eq!(got, want, "Gaussian {i}");
            assert!(out.sh_rest[i * 9..(i + 1) * 9].iter().all(|v| *v == 0.0));
        }
        // Everything but colour is untouched.
        assert_eq!((&out.means, &out.log_scales, &out.rotations), (&g.means, &g.log_scales, &g.rotations));
        assert_eq!(
            (&out.raw_opacities, &out.object_ids, &out.extra),
            (&g.raw_opacities, &g.object_ids, &g.extra)
        );
    }

    #[test]
    fn keep_style_leaves_unlabelled_gaussians_alone() {
        let g = labelled_gaussians(&[-1, 4]);
        let out = recolor(&g, |id| palette_colour(id, UnlabelledStyle::Keep)).unwrap();
        assert_eq!(out.sh_dc[0], g.sh_dc[0]);
        assert_eq!(out.sh_rest[..9], g.sh_rest[..9]);
        assert_ne!(out.sh_dc[1], g.sh_dc[1]);
    }

    #[test]
    fn unlabelled_ply_is_an_error() {
        let mut g = labelled_gaussians(&[1]);
        g.object_ids = None;
        assert!(matches!(recolor(&g, |_| None), Err(EditError::NoObjectIds { .. })));
    }
}

//! Cropping by a box: the Gaussians whose centres lie in a box (`edits::Box3`, the box of a
//! `split_box`), every property kept, in file order. What the viewer's "Export box crop" writes.

use crate::edit_ops::box_test;
use crate::edits::Box3;
use crate::error::EditError;
use glam::DVec3;
use splatseg_scene::Gaussians;

/// The Gaussians of `g` whose centre lies inside `region` (borders included); an error for a box
/// without finite numbers and positive half sizes, or one holding no Gaussian.
pub fn crop(g: &Gaussians, region: &Box3) -> Result<Gaussians, EditError> {
    let inside = box_test(region).map_err(EditError::BadBox)?;
    let rows: Vec<usize> = (0..g.len())
        .filter(|&i| {
            let m = g.means[i];
            inside(DVec3::new(m[0] as f64, m[1] as f64, m[2] as f64))
        })
        .collect();
    if rows.is_empty() {
        return Err(EditError::BadBox(format!(
            "no Gaussian has its centre inside the box (centre {:?}, half size {:?})",
            region.centre, region.half_size
        )));
    }
    Ok(g.select(&rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line_of_five() -> Gaussians {
        Gaussians {
            means: (0..5).map(|i| [i as f32, 0.0, 0.0]).collect(),
            sh_dc: vec![[0.0; 3]; 5],
            raw_opacities: (0..5).map(|i| i as f32).collect(),
            log_scales: vec![[0.0; 3]; 5],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]; 5],
            object_ids: Some(vec![1, 1, 2, 2, -1]),
            ..Gaussians::default()
        }
    }

    #[test]
    fn the_gaussians_with_centres_in_the_box_are_kept_whatever_their_object() {
        let g = line_of_five();
        let region = Box3 { centre: [2.0, 0.0, 0.0], half_size: [1.0, 0.5, 0.5], rotation: None };
        let out = crop(&g, &region).expect("crop");
        assert_eq!(out.means, vec![[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]], "borders included");
        assert_eq!(out.raw_opacities, vec![1.0, 2.0, 3.0]);
        assert_eq!(out.object_ids, Some(vec![1, 2, 2]));
        // turned 90° about z, the box's long side lies along y: only the centre is inside
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let turned = Box3 { rotation: Some([h, 0.0, 0.0, h]), ..region };
        assert_eq!(crop(&g, &turned).expect("crop").means, vec![[2.0, 0.0, 0.0]]);
    }

    #[test]
    fn an_empty_or_bad_box_is_an_error() {
        let g = line_of_five();
        let far = Box3 { centre: [9.0, 9.0, 9.0], half_size: [1.0; 3], rotation: None };
        assert!(crop(&g, &far).unwrap_err().to_string().contains("no Gaussian"));
        let flat = Box3 { centre: [0.0; 3], half_size: [1.0, 0.0, 1.0], rotation: None };
        assert!(crop(&g, &flat).unwrap_err().to_string().contains("positive half size"));
    }
}

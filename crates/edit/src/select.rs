//! Extracting and removing objects: index selection on the object ids.

use crate::error::EditError;
use splatseg_scene::Gaussians;

/// The object ids of `g` (`[N]`), or an error if it has none or their count is wrong.
pub fn object_ids(g: &Gaussians) -> Result<&[i32], EditError> {
    let ids = g.object_ids.as_deref().ok_or(EditError::NoObjectIds { path: None })?;
    if ids.len() != g.len() {
        return Err(EditError::LengthMismatch {
            what: "object_id",
            got: ids.len(),
            expected: g.len(),
            path: None,
        });
    }
    Ok(ids)
}

/// The id a Gaussian's stored id stands for: every negative id means unlabelled, written −1 (as
/// `splatseg objects` counts them; PLYs of other tools may store other negative values).
fn canonical(id: i32) -> i32 {
    id.max(-1)
}

/// Distinct object ids present in `g`, sorted (−1 = unlabelled, any negative stored id, is
/// included when present).
pub fn ids_present(g: &Gaussians) -> Result<Vec<i32>, EditError> {
    let mut ids: Vec<i32> = object_ids(g)?.iter().map(|&id| canonical(id)).collect();
    ids.sort_unstable();
    ids.dedup();
    Ok(ids)
}

/// Checks that `wanted` is non-empty and every id in it is carried by some Gaussian.
fn check_ids(g: &Gaussians, wanted: &[i32]) -> Result<Vec<i32>, EditError> {
    if wanted.is_empty() {
        return Err(EditError::NoIdsGiven);
    }
    let available = ids_present(g)?;
    let mut missing: Vec<i32> =
        wanted.iter().copied().filter(|w| available.binary_search(w).is_err()).collect();
    missing.sort_unstable();
    missing.dedup();
    if !missing.is_empty() {
        return Err(EditError::UnknownIds { missing, available, path: None });
    }
    let mut wanted = wanted.to_vec();
    wanted.sort_unstable();
    wanted.dedup();
    Ok(wanted)
}

/// Indices (ascending) of the Gaussians whose id is in `ids` (`in_ids = true`) or is not.
fn indices_where(g: &Gaussians, ids: &[i32], in_ids: bool) -> Result<Vec<usize>, EditError> {
    let wanted = check_ids(g, ids)?;
    Ok(object_ids(g)?
        .iter()
        .enumerate()
        .filter(|(_, &id)| wanted.binary_search(&canonical(id)).is_ok() == in_ids)
        .map(|(i, _)| i)
        .collect())
}

/// The Gaussians of objects `ids`, in their original order, every per-Gaussian array kept.
/// Fails if `g` has no object ids or an id is absent (the error lists the ids present).
pub fn extract(g: &Gaussians, ids: &[i32]) -> Result<Gaussians, EditError> {
    Ok(g.select(&indices_where(g, ids, true)?))
}

/// Everything but the Gaussians of objects `ids`, in the original order. Same errors as
/// [`extract`]. `remove(g, ids)` and `extract(g, ids)` partition `g`.
pub fn remove(g: &Gaussians, ids: &[i32]) -> Result<Gaussians, EditError> {
    Ok(g.select(&indices_where(g, ids, false)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::labelled_gaussians;

    #[test]
    fn every_negative_id_is_unlabelled_as_objects_counts_it() {
        let g = labelled_gaussians(&[3, -5, 7, -1, -2]);
        assert_eq!(ids_present(&g).unwrap(), vec![-1, 3, 7]);
        assert_eq!(extract(&g, &[-1]).unwrap(), g.select(&[1, 3, 4]));
        assert_eq!(remove(&g, &[-1]).unwrap(), g.select(&[0, 2]));
        let err = extract(&g, &[-5]).expect_err("−5 is not an object id");
        assert!(matches!(&err, EditError::UnknownIds { missing, .. } if missing == &vec![-5]), "{err}");
    }

    #[test]
    fn extract_and_remove_partition() {
        let g = labelled_gaussians(&[3, -1, 7, 3, 2, 7]);
        let e = extract(&g, &[3, 7]).unwrap();
        assert_eq!(e.object_ids.as_deref(), Some(&[3, 7, 3, 7][..]));
        assert_eq!(e, g.select(&[0, 2, 3, 5]));
        let r = remove(&g, &[3, 7, 7]).unwrap();
        assert_eq!(r, g.select(&[1, 4]));
    }

    #[test]
    fn unknown_ids_list_what_is_there() {
        let g = labelled_gaussians(&[3, -1, 7]);
        let err = extract(&g, &[4, 3, 9]).unwrap_err();
        assert_eq!(err.to_string(), "no Gaussian has object id 4, 9; ids present: -1, 3, 7");
        assert!(matches!(remove(&g, &[]), Err(EditError::NoIdsGiven)));
    }

    #[test]
    fn unlabelled_ply_says_what_to_do() {
        let mut g = labelled_gaussians(&[1, 2]);
        g.object_ids = None;
        let err = extract(&g, &[1]).unwrap_err().with_path(std::path::Path::new("scene/point_cloud.ply"));
        let msg = err.to_string();
        assert!(msg.contains("no `object_id`") && msg.contains("splatseg run"), "{msg}");
        assert!(msg.ends_with("scene/point_cloud.ply"), "{msg}");
    }

    #[test]
    fn inconsistent_id_count_is_an_error() {
        let mut g = labelled_gaussians(&[1, 2, 3]);
        g.object_ids = Some(vec![1, 2]);
        assert!(matches!(extract(&g, &[1]), Err(EditError::LengthMismatch { got: 2, expected: 3, .. })));
    }
}

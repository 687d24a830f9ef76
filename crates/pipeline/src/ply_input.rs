//! Reading Gaussians for a command (a 3DGS or compressed PLY, an SPZ, a `.splat` or a `.ksplat`, chosen by content:
//! `splatseg_scene::splats::read_gaussian_rows`): Gaussians with a non-finite value (NaN, ±Inf — 3DGS
//! trainers leave a few behind) or a degenerate shape (a zero rotation quaternion, a log-scale
//! above 20, which the rasteriser would cull) are skipped with one warning per kind and file, or
//! refused with `--strict`.

use splatseg_scene::ply::PlyRows;
use splatseg_scene::splats::read_gaussian_rows;
use splatseg_scene::Gaussians;
use std::path::Path;

/// Every row of the Gaussians file at `path` (PLY, compressed PLY, SPZ, `.splat` or `.ksplat`)
/// with the skipped ones listed. With `strict` (`--strict`) a
/// file with non-finite values or degenerate Gaussians is an error naming the first one;
/// otherwise one warning per kind says how many rows are skipped and `consequence` (what happens to them in the outputs).
pub fn read_rows(path: &Path, consequence: &str, strict: bool) -> crate::Result<PlyRows> {
    let rows = read_rows_quietly(path, strict)?;
    for warning in rows.skip_warnings(path, consequence) {
        tracing::warn!("{warning} (--strict refuses such files)");
    }
    Ok(rows)
}

/// [`read_rows`] without the warning, for a caller that reports it itself
/// ([`PlyRows::skip_warnings`]).
pub fn read_rows_quietly(path: &Path, strict: bool) -> crate::Result<PlyRows> {
    let rows = read_gaussian_rows(path)?;
    if strict {
        rows.refuse_skipped(path)?;
    }
    Ok(rows)
}

/// The usable Gaussians of the PLY at `path` (finite, not degenerate), in file order (see [`read_rows`]); the skipped
/// rows are left out of whatever the command writes.
pub fn read_finite(path: &Path, strict: bool) -> crate::Result<Gaussians> {
    let gaussians = read_rows(path, "they are left out", strict)?.into_usable();
    refuse_empty(gaussians.len(), path)?;
    Ok(gaussians)
}

/// An error when a PLY has no Gaussian to render or label (`finite`: its finite rows).
pub fn refuse_empty(finite: usize, path: &Path) -> crate::Result<()> {
    if finite == 0 {
        crate::error::bail!(
            "the PLY holds no Gaussians with finite values (nothing to render or label): {}",
            path.display()
        );
    }
    Ok(())
}

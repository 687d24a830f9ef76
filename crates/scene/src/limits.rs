//! The one cap on the size of any input: pixels per image (cameras, label maps, masks) and
//! Gaussians per PLY. Sizes a file declares are checked against these (and against the file's
//! own length) before anything of that size is allocated, so a corrupt or hostile header is a
//! clear error, never an out-of-memory abort.

/// Most pixels one image, camera, label map or mask may have: 2^28 (e.g. 16384 × 16384; a
/// `[H, W]` f32 map of that size is 1 GiB). No capture splatseg handles comes near it.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Most Gaussians one PLY may hold: 2^27 (134 million; 33 GB as an SH-degree-3 PLY). Real
/// 3DGS scenes hold 0.1–10 million.
pub const MAX_GAUSSIANS: u64 = 1 << 27;

/// Checks `width × height` against [`MAX_PIXELS`]; the error says which `what` and both numbers.
pub fn check_pixels(what: &str, width: u64, height: u64) -> Result<(), String> {
    let pixels = width.saturating_mul(height);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "{what} is {width}x{height} = {pixels} pixels, more than the {MAX_PIXELS} (2^28) pixels \
             splatseg accepts per image"
        ));
    }
    Ok(())
}

/// Checks a Gaussian count against [`MAX_GAUSSIANS`].
pub fn check_gaussians(count: u64) -> Result<(), String> {
    if count > MAX_GAUSSIANS {
        return Err(format!(
            "{count} Gaussians declared, more than the {MAX_GAUSSIANS} (2^27) splatseg accepts per PLY"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_accept_the_limit_and_refuse_one_more() {
        assert!(check_pixels("camera 1", 16384, 16384).is_ok());
        let err = check_pixels("camera 1", 3_200_000_000, 240_000_000).unwrap_err();
        assert!(err.contains("camera 1 is 3200000000x240000000"), "{err}");
        assert!(check_gaussians(MAX_GAUSSIANS).is_ok());
        assert!(check_gaussians(MAX_GAUSSIANS + 1).unwrap_err().contains("2^27"));
    }
}

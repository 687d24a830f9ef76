//! Every splat's [`Reach`] for a contribution pass, eight splats at a time.
//!
//! Each lane does [`Reach::new`]'s operations in its order (IEEE products, quotients and square
//! roots, no fused multiply-adds; the floor on the clamped value), written over fixed-size arrays
//! so the compiler vectorises them; only the logarithm stays one call per live splat. A lane whose
//! centre is NaN (clamping differs for NaN) is made by [`Reach::new`] itself. So every reach equals
//! [`Reach::new`]'s, bit for bit (test `lanes_equal_reach_new`). Compiled for AVX2 and used when
//! the CPU has it.

use crate::footprint::{pixel_span, Reach, MARGIN_PX};
use crate::project::Splat2d;
use crate::project_lanes::{lanes_available, LANES};
use rayon::prelude::*;

/// `[N]` the reach of every splat of `splats` (`[N]`) for the threshold `alpha_min`.
pub(crate) fn reaches(splats: &[Splat2d], alpha_min: f32) -> Vec<Reach> {
    const CHUNK: usize = 4096;
    let avx2 = lanes_available();
    let mut out = vec![Reach::default(); splats.len()];
    out.par_chunks_mut(CHUNK).zip(splats.par_chunks(CHUNK)).for_each(|(out, splats)| {
        let mut lanes = splats.chunks_exact(LANES);
        let mut outs = out.chunks_exact_mut(LANES);
        for (s, o) in (&mut lanes).zip(&mut outs) {
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: `avx2` is only true when the CPU has AVX2 (`lanes_available`).
                unsafe { reaches_of_lanes_avx2(s, alpha_min, o) };
                continue;
            }
            let _ = avx2;
            reaches_of_lanes(s, alpha_min, o);
        }
        for (s, o) in lanes.remainder().iter().zip(outs.into_remainder()) {
            *o = Reach::new(s, alpha_min);
        }
    });
    out
}

/// [`reaches_of_lanes`] compiled for AVX2.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn reaches_of_lanes_avx2(splats: &[Splat2d], alpha_min: f32, out: &mut [Reach]) {
    reaches_of_lanes(splats, alpha_min, out)
}

/// The reaches of `splats` (`[LANES]`) into `out` (`[LANES]`).
#[inline(always)]
fn reaches_of_lanes(splats: &[Splat2d], alpha_min: f32, out: &mut [Reach]) {
    let (mut mx, mut my, mut a, mut c, mut det, mut two_smax) =
        ([0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES]);
    let mut live = [false; LANES];
    for l in 0..LANES {
        let s = &splats[l];
        let [sa, sb, sc] = s.conic;
        (a[l], c[l]) = (sa, sc);
        det[l] = sa * sc - sb * sb;
        [mx[l], my[l]] = s.mean2d;
        live[l] = !(s.opacity < alpha_min || s.is_culled());
        if live[l] {
            two_smax[l] = 2.0 * (s.opacity / alpha_min).ln();
        }
    }
    let (mut ex, mut ey) = ([0f32; LANES], [0f32; LANES]);
    for l in 0..LANES {
        ex[l] = (two_smax[l] * c[l] / det[l]).sqrt() + MARGIN_PX;
        ey[l] = (two_smax[l] * a[l] / det[l]).sqrt() + MARGIN_PX;
    }
    let mut span = [[0i32; 4]; LANES];
    for l in 0..LANES {
        span[l] = pixel_span(mx[l], my[l], ex[l], ey[l]);
    }
    for l in 0..LANES {
        let ellipse = det[l] > 0.0 && a[l] > 0.0 && two_smax[l].is_finite();
        out[l] = if !live[l] {
            Reach::default()
        } else if mx[l].is_nan() || my[l].is_nan() || ex[l].is_nan() || ey[l].is_nan() {
            Reach::new(&splats[l], alpha_min)
        } else if ellipse {
            Reach::ellipse(span[l], two_smax[l], det[l])
        } else {
            Reach::whole_tile(two_smax[l], det[l])
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::footprint::awkward_splat;

    /// Every lane's reach is [`Reach::new`]'s, bit for bit (compared as printed, NaN included),
    /// over splats near and far off the image, with conics that are not positive definite,
    /// opacities below the threshold, culled splats and non-finite values, in both builds.
    #[test]
    fn lanes_equal_reach_new() {
        let mut seed = 17u32;
        let mut unit = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let alpha_min = 1.0 / 255.0;
        let splats: Vec<Splat2d> = (0..100_003).map(|i| awkward_splat(i, &mut unit, alpha_min)).collect();
        let print = |r: &[Reach]| r.iter().map(|r| format!("{r:?}")).collect::<Vec<_>>();
        let expected: Vec<Reach> = splats.iter().map(|s| Reach::new(s, alpha_min)).collect();
        let mut portable = vec![Reach::default(); splats.len()];
        for (s, o) in splats.chunks_exact(LANES).zip(portable.chunks_exact_mut(LANES)) {
            reaches_of_lanes(s, alpha_min, o);
        }
        let whole = splats.len() / LANES * LANES;
        portable[whole..].copy_from_slice(&expected[whole..]);
        assert_eq!(print(&portable), print(&expected));
        assert_eq!(print(&reaches(&splats, alpha_min)), print(&expected));
        let kinds: std::collections::BTreeSet<String> = expected
            .iter()
            .map(|r| format!("{r:?}").split("kind: ").nth(1).unwrap_or("").to_string())
            .collect();
        assert_eq!(kinds.len(), 3, "every kind of reach is made: {kinds:?}");
    }
}

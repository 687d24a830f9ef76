//! Every code an SPZ body can hold decodes to a finite value, and every Gaussian to a usable shape
//! (a log-scale at most 5.94, a rotation whose norm is not 0): why the SPZ reader lists no non-finite and no
//! degenerate rows without looking ([`crate::ply::PlyRows::usable_by_construction`]). Each test
//! runs the reader's own decoder ([`SpzDecoder::decode`]) over the codes.

use super::spz_decode::{BodyShape, Rows, SpzDecoder};
use crate::ply::{degenerate_shape, MAX_LOG_SCALE};

/// A decoder for SH degree 3 (15 rest coefficients per channel).
fn decoder(rotation_bytes: usize, fractional_bits: u8) -> SpzDecoder {
    SpzDecoder::new(BodyShape { fractional_bits, rotation_bytes, rest_per_channel: 15 })
}

/// Each of the 256 byte values repeated `width` times: one element per byte value.
fn every_byte(width: usize) -> Vec<u8> {
    (0..=255u8).flat_map(|b| std::iter::repeat_n(b, width)).collect()
}

fn assert_finite(values: &[f32], what: &str) {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        panic!("{what}: element {i} decodes to {}", values[i]);
    }
}

#[test]
fn every_byte_of_alphas_colours_scales_and_sh_decodes_finite() {
    let d = decoder(4, 12);
    let mut opacities = vec![f32::NAN; 256];
    d.decode(Rows::Opacities(&mut opacities), &every_byte(1));
    assert_finite(&opacities, "alpha byte");
    let mut colours = vec![[f32::NAN; 3]; 256];
    d.decode(Rows::Colours(&mut colours), &every_byte(3));
    assert_finite(colours.as_flattened(), "colour byte");
    let mut scales = vec![[f32::NAN; 3]; 256];
    d.decode(Rows::Scales(&mut scales), &every_byte(3));
    assert_finite(scales.as_flattened(), "scale byte");
    let largest = scales.as_flattened().iter().copied().fold(f32::MIN, f32::max);
    assert!(largest <= MAX_LOG_SCALE, "the largest log-scale is {largest}");
    assert_eq!(largest, 255.0 / 16.0 - 10.0);
    let mut sh = vec![f32::NAN; 256 * 45];
    d.decode(Rows::Sh(&mut sh), &every_byte(45));
    assert_finite(&sh, "SH byte");
}

#[test]
fn the_extreme_position_codes_decode_finite_at_every_fractional_bits() {
    // A coordinate is `±code · 2^-bits` with |code| ≤ 2^23 and bits ≤ 23 (the header's bound):
    // monotonic in the code, so the extremes bound every other.
    let codes: [i32; 5] = [0, 1, -1, (1 << 23) - 1, -(1 << 23)];
    let bytes: Vec<u8> =
        codes.iter().flat_map(|c| [c, c, c]).flat_map(|c| c.to_le_bytes()[..3].to_vec()).collect();
    for bits in 0..=23u8 {
        let mut means = vec![[f32::NAN; 3]; codes.len()];
        decoder(4, bits).decode(Rows::Means(&mut means), &bytes);
        assert_finite(means.as_flattened(), &format!("position at {bits} fractional bits"));
        let unit = (-(bits as f32)).exp2();
        assert_eq!(means[4][0], -(1 << 23) as f32 * unit, "the most negative code at {bits} bits");
    }
}

/// Rotations decoded from `bytes` (`rotation_bytes` each) are finite and none is degenerate.
fn assert_unit_rotations(rotation_bytes: usize, bytes: &[u8]) {
    let mut rotations = vec![[f32::NAN; 4]; bytes.len() / rotation_bytes];
    decoder(rotation_bytes, 12).decode(Rows::Rotations(&mut rotations), bytes);
    for (r, code) in rotations.iter().zip(bytes.chunks_exact(rotation_bytes)) {
        assert!(r.iter().all(|v| v.is_finite()), "{code:?} decodes to {r:?}");
        assert!(degenerate_shape([0.0; 3], *r).is_none(), "{code:?} decodes to {r:?}");
    }
}

#[test]
fn every_version_2_rotation_code_decodes_finite_and_not_degenerate() {
    // All 2^24 codes, 65,536 at a time. x y z are `b/127.5 − 1`, never 0, so the norm never is.
    for z in 0..=255u8 {
        let bytes: Vec<u8> = (0..=u16::MAX).flat_map(|xy| [xy as u8, (xy >> 8) as u8, z]).collect();
        assert_unit_rotations(3, &bytes);
    }
}

#[test]
fn every_version_3_rotation_slot_code_decodes_finite_and_not_degenerate() {
    // The largest component's index (2 bits) and three 10-bit slots (sign, 9-bit magnitude ≤ 1/√2):
    // every code of each slot, with the other two at every extreme (0, ±511, −0). The largest is
    // √max(0, 1 − Σ others²): finite, and 1 when the others are 0, so the norm is never 0 (codes
    // whose others' squares sum past 1 decode to a norm up to √1.5, which the renderer normalises).
    let extremes = [0u32, 0x1ff, 0x3ff, 0x200];
    let mut bytes = Vec::new();
    for largest in 0..4u32 {
        for slot in 0..3 {
            for code in 0..1024u32 {
                for a in extremes {
                    for b in extremes {
                        let mut slots = [0; 3];
                        slots[slot] = code;
                        slots[(slot + 1) % 3] = a;
                        slots[(slot + 2) % 3] = b;
                        let packed = largest << 30 | slots[0] << 20 | slots[1] << 10 | slots[2];
                        bytes.extend_from_slice(&packed.to_le_bytes());
                    }
                }
            }
        }
    }
    assert_unit_rotations(4, &bytes);
}

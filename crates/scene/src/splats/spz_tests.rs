//! The SPZ reader that inflates and decodes chunk by chunk on two threads gives bit for bit what
//! decoding the whole inflated body at once gives (the reader before the pipeline, kept here as
//! the reference), on files of many chunks, of both versions and every SH degree.

use super::quantise::logit_of_byte;
use super::spz::read_spz_in_chunks;
use super::spz_decode::{COLOUR_SCALE, SH_FLIP, SQRT1_2};
use crate::gaussians::{sh_coeffs_for_degree, Gaussians};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::io::{Read, Write};

/// A gzip SPZ of `count` Gaussians whose body is random bytes (every byte value in every
/// attribute), with the header given.
fn random_spz(version: u32, count: u32, sh_degree: u8, fractional_bits: u8, seed: u64) -> Vec<u8> {
    let rotation_bytes = if version >= 3 { 4 } else { 3 };
    let row = 9 + 1 + 3 + 3 + rotation_bytes + 3 * (sh_coeffs_for_degree(sh_degree) - 1);
    let mut raw = Vec::new();
    raw.extend_from_slice(b"NGSP");
    raw.extend_from_slice(&version.to_le_bytes());
    raw.extend_from_slice(&count.to_le_bytes());
    raw.extend_from_slice(&[sh_degree, fractional_bits, 0, 0]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    raw.extend((0..count as usize * row).map(|_| rng.gen::<u8>()));
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&raw).unwrap();
    gz.finish().unwrap()
}

/// The whole body inflated at once and decoded attribute by attribute, value by value: the
/// reader as it was before chunks and tables.
fn reference_decode(file: &[u8]) -> Gaussians {
    let mut raw = Vec::new();
    flate2::read::GzDecoder::new(file).read_to_end(&mut raw).unwrap();
    let u32_at = |o: usize| u32::from_le_bytes([raw[o], raw[o + 1], raw[o + 2], raw[o + 3]]);
    let (version, n, sh_degree, fractional_bits) = (u32_at(4), u32_at(8) as usize, raw[12], raw[13]);
    let k = sh_coeffs_for_degree(sh_degree) - 1;
    let rotation_bytes = if version >= 3 { 4 } else { 3 };
    let mut at = 16;
    let mut next = |len: usize| {
        at += len;
        &raw[at - len..at]
    };
    let unit = 1.0 / (1u32 << fractional_bits) as f32;
    let flip = [1.0, -1.0, -1.0];
    let means = next(9 * n)
        .chunks_exact(9)
        .map(|p| {
            [0, 1, 2].map(|a| {
                let b = &p[3 * a..3 * a + 3];
                let fixed = i32::from_le_bytes([b[0], b[1], b[2], 0]) << 8 >> 8;
                flip[a] * fixed as f32 * unit
            })
        })
        .collect();
    let raw_opacities = next(n).iter().map(|&a| logit_of_byte(a)).collect();
    let sh_dc = next(3 * n)
        .chunks_exact(3)
        .map(|c| [0, 1, 2].map(|i| (c[i] as f32 / 255.0 - 0.5) / COLOUR_SCALE))
        .collect();
    let log_scales =
        next(3 * n).chunks_exact(3).map(|s| [0, 1, 2].map(|i| s[i] as f32 / 16.0 - 10.0)).collect();
    let rotations = next(rotation_bytes * n)
        .chunks_exact(rotation_bytes)
        .map(|r| {
            let [x, y, z, w] = if rotation_bytes == 4 {
                let mut packed = u32::from_le_bytes([r[0], r[1], r[2], r[3]]);
                let largest = (packed >> 30) as usize;
                let mut q = [0.0f32; 4];
                let mut sum_squares = 0.0;
                for i in (0..4).rev().filter(|&i| i != largest) {
                    let magnitude = (packed & 0x1ff) as f32 / 511.0 * SQRT1_2;
                    q[i] = if packed & 0x200 != 0 { -magnitude } else { magnitude };
                    sum_squares += q[i] * q[i];
                    packed >>= 10;
                }
                q[largest] = (1.0 - sum_squares).max(0.0).sqrt();
                q
            } else {
                let [x, y, z] = [0, 1, 2].map(|i| r[i] as f32 / 127.5 - 1.0);
                [x, y, z, (1.0 - x * x - y * y - z * z).max(0.0).sqrt()]
            };
            [w, x, -y, -z]
        })
        .collect();
    let mut sh_rest = vec![0.0f32; 3 * k * n];
    if k > 0 {
        for (row, q) in sh_rest.chunks_mut(3 * k).zip(next(3 * k * n).chunks_exact(3 * k)) {
            for j in 0..k {
                for c in 0..3 {
                    row[c * k + j] = SH_FLIP[j] * (q[3 * j + c] as f32 - 128.0) / 128.0;
                }
            }
        }
    }
    Gaussians {
        means,
        sh_dc,
        sh_degree,
        sh_rest,
        raw_opacities,
        log_scales,
        rotations,
        ..Gaussians::default()
    }
}

/// Every decoded float of `g` as bits, attribute by attribute (so −0.0 ≠ 0.0).
fn bits(g: &Gaussians) -> Vec<Vec<u32>> {
    let flat = |v: &mut dyn Iterator<Item = f32>| v.map(f32::to_bits).collect::<Vec<u32>>();
    vec![
        flat(&mut g.means.iter().flatten().copied()),
        flat(&mut g.raw_opacities.iter().copied()),
        flat(&mut g.sh_dc.iter().flatten().copied()),
        flat(&mut g.log_scales.iter().flatten().copied()),
        flat(&mut g.rotations.iter().flatten().copied()),
        flat(&mut g.sh_rest.iter().copied()),
    ]
}

#[test]
fn chunked_two_thread_decode_equals_the_whole_body_decode_bit_for_bit() {
    let cases =
        [(3, 5_000, 3, 12), (2, 4_001, 3, 10), (3, 3_000, 1, 23), (2, 2_500, 2, 0), (3, 2_000, 0, 12)];
    for (seed, &(version, count, sh_degree, fractional_bits)) in cases.iter().enumerate() {
        let file = random_spz(version, count, sh_degree, fractional_bits, seed as u64);
        let expected = reference_decode(&file);
        assert_eq!(expected.len(), count as usize);
        // 1000 bytes: dozens of chunks per section, none a multiple of the 45-byte SH row; the
        // default: the positions in one chunk, the SH in several.
        for chunk_bytes in [1000, 4096, super::spz::CHUNK_BYTES] {
            let g = read_spz_in_chunks(&file[..], file.len() as u64, chunk_bytes).unwrap();
            let what =
                format!("version {version}, {count} Gaussians, SH {sh_degree}, chunks of {chunk_bytes}");
            assert_eq!(g.sh_degree, sh_degree, "{what}");
            for (attribute, (got, want)) in bits(&g).iter().zip(&bits(&expected)).enumerate() {
                assert_eq!(got.len(), want.len(), "{what}: attribute {attribute}'s length");
                if let Some(i) = (0..got.len()).find(|&i| got[i] != want[i]) {
                    panic!(
                        "{what}: attribute {attribute}, value {i}: {} where the whole-body decode gives {}",
                        f32::from_bits(got[i]),
                        f32::from_bits(want[i])
                    );
                }
            }
        }
    }
}

#[test]
fn a_stream_ending_in_a_later_chunk_names_the_attribute_and_the_bytes_read() {
    let file = random_spz(3, 3_000, 3, 12, 9);
    let mut raw = Vec::new();
    flate2::read::GzDecoder::new(&file[..]).read_to_end(&mut raw).unwrap();
    // Cut the body in the SH section, past several of its 1000-byte chunks.
    let kept = 16 + 20 * 3_000 + 7_777;
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&raw[..kept]).unwrap();
    let cut = gz.finish().unwrap();
    for chunk_bytes in [1000, super::spz::CHUNK_BYTES] {
        let err = read_spz_in_chunks(&cut[..], cut.len() as u64, chunk_bytes).unwrap_err();
        assert!(
            err.contains("ends after 67777 of them, in the SH coefficients"),
            "chunks of {chunk_bytes}: {err}"
        );
    }
}

#[test]
fn a_header_declaring_more_gaussians_than_memory_holds_is_an_error_not_an_abort() {
    // 2^27 Gaussians of SH degree 3 (31.7 GB of arrays) and no body; the file claims to be long
    // enough for deflate to reach that many. Either the arrays are refused up front or the body
    // is missing: an error either way, never an allocation failure's abort.
    let mut raw = Vec::new();
    raw.extend_from_slice(b"NGSP");
    raw.extend_from_slice(&3u32.to_le_bytes());
    raw.extend_from_slice(&(1u32 << 27).to_le_bytes());
    raw.extend_from_slice(&[3, 12, 0, 0]);
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(&raw).unwrap();
    let file = gz.finish().unwrap();
    let err = read_spz_in_chunks(&file[..], u64::MAX / 2048, 1 << 20).expect_err("no such body");
    assert!(err.contains("Gaussians") || err.contains("byte"), "{err}");
}

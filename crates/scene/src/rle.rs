//! COCO run-length encoding of binary masks, as pycocotools and Segment Anything write it.
//!
//! Runs go over the mask in **column-major** (Fortran) order and start with a run of zeros
//! (possibly of length 0): `counts = [zeros, ones, zeros, ones, ...]`, summing to `h · w`.
//! The compressed string form ([`Rle::to_coco_string`]) writes each count (for `i > 2` as the
//! difference to `counts[i - 2]`) as a little-endian sequence of 5-bit groups, one character
//! per group: bit `0x20` = more groups follow, bit `0x10` of the last group = sign, plus 48
//! to land in printable ASCII.

use crate::plane::Plane;

/// The largest mask [`Rle::check`] (and so [`Rle::decode`] and [`Rle::from_coco_string`])
/// accepts: [`crate::limits::MAX_PIXELS`], 2^28 pixels (e.g. 16384 × 16384, 256 MB as a `bool`
/// mask). Larger declared sizes are refused before anything of that size is allocated; no
/// camera image splatseg handles comes near it, so a bigger `size` in a mask file is corrupt
/// or hostile.
pub const MAX_MASK_PIXELS: u64 = crate::limits::MAX_PIXELS;

/// Checks a declared mask size (`height × width`, as a file states it) against
/// [`MAX_MASK_PIXELS`] and the `u32` range, without allocating anything.
pub fn check_declared_size(height: u64, width: u64) -> Result<(), String> {
    if height > u32::MAX as u64 || width > u32::MAX as u64 {
        return Err(format!(
            "declared mask size [{height}, {width}] (height, width) has a side beyond 32 bits"
        ));
    }
    let pixels = height.saturating_mul(width);
    if pixels > MAX_MASK_PIXELS {
        return Err(format!(
            "declared mask size [{height}, {width}] (height, width) is {pixels} pixels, more than the \
             {MAX_MASK_PIXELS} (2^28) a mask may have"
        ));
    }
    Ok(())
}

/// A COCO RLE mask. `counts` alternate zeros/ones runs in column-major order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rle {
    /// Mask height (rows).
    pub height: u32,
    /// Mask width (columns).
    pub width: u32,
    /// Run lengths, starting with zeros; they sum to `height · width`.
    pub counts: Vec<u32>,
}

/// Side of the square tiles used to transpose between row- and column-major order.
const TILE: usize = 32;

/// Transposes `src` (`[rows, cols]` row-major) into `dst` (`[cols, rows]` row-major), tile by
/// tile so both sides stay in cache.
fn transpose<T: Copy>(src: &[T], rows: usize, cols: usize, dst: &mut [T]) {
    for r0 in (0..rows).step_by(TILE) {
        for c0 in (0..cols).step_by(TILE) {
            for r in r0..(r0 + TILE).min(rows) {
                let src_row = &src[r * cols..(r + 1) * cols];
                for c in c0..(c0 + TILE).min(cols) {
                    dst[c * rows + r] = src_row[c];
                }
            }
        }
    }
}

impl Rle {
    /// Encodes a mask (`[height, width]` row-major, `true` = inside).
    pub fn encode(mask: &Plane<bool>) -> Rle {
        let (w, h) = (mask.width, mask.height);
        let mut column_major = vec![false; w * h];
        transpose(&mask.data, h, w, &mut column_major);
        let mut counts = Vec::new();
        let mut current = false;
        let mut run = 0u32;
        for &v in &column_major {
            if v != current {
                counts.push(run);
                run = 0;
                current = v;
            }
            run += 1;
        }
        if run > 0 || counts.is_empty() {
            counts.push(run);
        }
        Rle { height: h as u32, width: w as u32, counts }
    }

    /// Number of pixels, `height · width`.
    pub fn pixel_count(&self) -> u64 {
        self.height as u64 * self.width as u64
    }

    /// Checks that the size is at most [`MAX_MASK_PIXELS`] and that the counts sum to exactly
    /// `height · width`.
    pub fn check(&self) -> Result<(), String> {
        check_declared_size(self.height as u64, self.width as u64)?;
        let total: u64 = self.counts.iter().map(|&c| c as u64).sum();
        if total != self.pixel_count() {
            return Err(format!(
                "RLE counts sum to {total} but the mask is {}×{} = {} pixels",
                self.height,
                self.width,
                self.pixel_count()
            ));
        }
        Ok(())
    }

    /// Decodes into a mask (`[height, width]` row-major). Fails, before allocating, if the size
    /// is above [`MAX_MASK_PIXELS`] or the counts do not sum to `height · width`.
    pub fn decode(&self) -> Result<Plane<bool>, String> {
        self.check()?;
        let (w, h) = (self.width as usize, self.height as usize);
        let mut column_major = vec![false; w * h];
        let mut pos = 0usize;
        for (i, &c) in self.counts.iter().enumerate() {
            let end = pos + c as usize;
            if i % 2 == 1 {
                column_major[pos..end].fill(true);
            }
            pos = end;
        }
        let mut data = vec![false; w * h];
        transpose(&column_major, w, h, &mut data);
        Ok(Plane { width: w, height: h, data })
    }

    /// Number of pixels inside the mask (sum of the ones runs).
    pub fn area(&self) -> u64 {
        self.counts.iter().skip(1).step_by(2).map(|&c| c as u64).sum()
    }

    /// Tight bounding box `[x, y, w, h]` in pixels of the inside pixels (`w` = number of
    /// columns spanned, as pycocotools' `toBbox`); `[0, 0, 0, 0]` for an empty mask.
    /// SAM's JSON `bbox` has `w, h` one smaller than this (it subtracts max and min indices):
    /// see [`Rle::bbox_xywh_sam`].
    pub fn bbox_xywh(&self) -> [u32; 4] {
        let h = self.height.max(1) as u64;
        let (mut x0, mut y0, mut x1, mut y1) = (u64::MAX, u64::MAX, 0u64, 0u64);
        let mut pos = 0u64;
        for (i, &c) in self.counts.iter().enumerate() {
            let start = pos;
            pos += c as u64;
            if i % 2 == 0 || c == 0 {
                continue;
            }
            let last = pos - 1;
            let (first_col, last_col) = (start / h, last / h);
            x0 = x0.min(first_col);
            x1 = x1.max(last_col);
            if last_col > first_col {
                // The run reaches the bottom row of its first column and the top row of the
                // next one.
                y0 = 0;
                y1 = h - 1;
            } else {
                y0 = y0.min(start % h);
                y1 = y1.max(last % h);
            }
        }
        if x0 == u64::MAX {
            return [0, 0, 0, 0];
        }
        [x0 as u32, y0 as u32, (x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32]
    }

    /// Tight bounding box as Segment Anything writes it in its JSON and `metadata.csv`:
    /// `[x_min, y_min, x_max - x_min, y_max - y_min]` with inclusive max indices (its
    /// `box_xyxy_to_xywh` of `batched_mask_to_box`), so a single pixel has `w = h = 0`;
    /// `[0, 0, 0, 0]` for an empty mask.
    pub fn bbox_xywh_sam(&self) -> [u32; 4] {
        let [x, y, w, h] = self.bbox_xywh();
        [x, y, w.saturating_sub(1), h.saturating_sub(1)]
    }

    /// The compressed COCO string of the counts (what pycocotools' `encode` and SAM's
    /// `coco_rle` output store in `segmentation.counts`).
    pub fn to_coco_string(&self) -> String {
        let mut s = String::with_capacity(self.counts.len() * 2);
        for (i, &count) in self.counts.iter().enumerate() {
            let mut x = count as i64;
            if i > 2 {
                x -= self.counts[i - 2] as i64;
            }
            loop {
                let mut group = (x & 0x1f) as u8;
                x >>= 5;
                let more = if group & 0x10 != 0 { x != -1 } else { x != 0 };
                if more {
                    group |= 0x20;
                }
                s.push(char::from(group + 48));
                if !more {
                    break;
                }
            }
        }
        s
    }

    /// Parses a compressed COCO counts string for a `height × width` mask. Fails on characters
    /// outside the alphabet, a string ending inside a count, negative counts, a size above
    /// [`MAX_MASK_PIXELS`] (checked first), or counts that do not sum to `height · width`.
    pub fn from_coco_string(height: u32, width: u32, s: &str) -> Result<Rle, String> {
        /// 12 groups of 5 bits hold any delta of two u32 counts.
        const MAX_GROUPS: u32 = 12;
        check_declared_size(height as u64, width as u64)?;
        let bytes = s.as_bytes();
        let mut counts: Vec<u32> = Vec::with_capacity(bytes.len());
        let mut p = 0;
        while p < bytes.len() {
            let mut x: i64 = 0;
            let mut groups = 0u32;
            loop {
                let Some(&b) = bytes.get(p) else {
                    return Err(format!("RLE string ends inside count {}", counts.len()));
                };
                if !(48..48 + 64).contains(&b) {
                    return Err(format!(
                        "invalid character {:?} at position {p} of the RLE string",
                        char::from(b)
                    ));
                }
                if groups == MAX_GROUPS {
                    return Err(format!("count {} of the RLE string is too long", counts.len()));
                }
                let c = (b - 48) as i64;
                x |= (c & 0x1f) << (5 * groups);
                p += 1;
                groups += 1;
                if c & 0x20 == 0 {
                    if c & 0x10 != 0 {
                        x |= -1i64 << (5 * groups);
                    }
                    break;
                }
            }
            let i = counts.len();
            if i > 2 {
                x += counts[i - 2] as i64;
            }
            let count =
                u32::try_from(x).map_err(|_| format!("count {i} of the RLE string decodes to {x}"))?;
            counts.push(count);
        }
        let rle = Rle { height, width, counts };
        rle.check()?;
        Ok(rle)
    }
}

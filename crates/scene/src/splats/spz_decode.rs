//! SPZ's attribute sections (positions, alphas, colours, scales, rotations, SH rest) decoded a
//! chunk at a time and appended to the Gaussians' arrays, so that the reader can hand each
//! chunk over as soon as it is inflated ([`super::spz`]). Every byte-valued attribute goes
//! through a 256-entry table made with the same expression the value has, so the decoded floats
//! are bit for bit those of decoding each byte on its own.

use super::prefault::prefault;
use super::quantise::logit_of_byte;
use crate::gaussians::Gaussians;

/// DC colours are stored as `f_dc · COLOUR_SCALE`, a smaller factor than SH_C0 so that colours a
/// little outside [0, 1] survive.
pub(super) const COLOUR_SCALE: f32 = 0.15;

/// 1/√2: the largest magnitude the three smallest components of a unit quaternion can have.
pub(super) const SQRT1_2: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Sign of each SH rest coefficient `k` (INRIA order, bands 1–3) under the 180° turn about x
/// between SPZ's frame and the PLY's: −1 where the basis function is odd in y and z together.
pub(super) const SH_FLIP: [f32; 15] = [-1., -1., 1., -1., 1., 1., -1., 1., -1., 1., -1., -1., 1., -1., 1.];

/// The attribute sections of an SPZ body, in file order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Section {
    Positions,
    Alphas,
    Colours,
    Scales,
    Rotations,
    Sh,
}

impl Section {
    /// Every section, in the order the body holds them.
    pub(super) const ALL: [Section; 6] = [
        Section::Positions,
        Section::Alphas,
        Section::Colours,
        Section::Scales,
        Section::Rotations,
        Section::Sh,
    ];

    /// What the section holds, as errors say it.
    pub(super) fn name(self) -> &'static str {
        match self {
            Section::Positions => "positions",
            Section::Alphas => "alphas",
            Section::Colours => "colours",
            Section::Scales => "scales",
            Section::Rotations => "rotations",
            Section::Sh => "SH coefficients",
        }
    }
}

/// The shape of one file's body: what each section's element is.
#[derive(Clone, Copy, Debug)]
pub(super) struct BodyShape {
    pub(super) fractional_bits: u8,
    /// 3 (version 2) or 4 (version 3).
    pub(super) rotation_bytes: usize,
    /// SH rest coefficients per colour channel.
    pub(super) rest_per_channel: usize,
}

impl BodyShape {
    /// Bytes one Gaussian takes in `section`.
    pub(super) fn element_bytes(&self, section: Section) -> usize {
        match section {
            Section::Positions => 9,
            Section::Alphas => 1,
            Section::Colours | Section::Scales => 3,
            Section::Rotations => self.rotation_bytes,
            Section::Sh => 3 * self.rest_per_channel,
        }
    }
}

/// A 256-entry table of `f` over the byte values.
fn byte_table(f: impl Fn(u8) -> f32) -> [f32; 256] {
    std::array::from_fn(|b| f(b as u8))
}

/// Where one chunk's Gaussians go: their rows of the section's array in the Gaussians being read.
pub(super) enum Rows<'a> {
    Means(&'a mut [[f32; 3]]),
    Opacities(&'a mut [f32]),
    Colours(&'a mut [[f32; 3]]),
    Scales(&'a mut [[f32; 3]]),
    Rotations(&'a mut [[f32; 4]]),
    /// `[rows, 3, K]`.
    Sh(&'a mut [f32]),
}

impl Rows<'_> {
    /// Makes the rows' pages writable in one call before they are written ([`prefault`]).
    fn prefault(&mut self) {
        match self {
            Rows::Means(out) | Rows::Colours(out) | Rows::Scales(out) => prefault(out),
            Rows::Opacities(out) | Rows::Sh(out) => prefault(out),
            Rows::Rotations(out) => prefault(out),
        }
    }
}

/// The arrays of `g` (made for every Gaussian) handed out a chunk of rows at a time, section
/// after section, in the body's order.
pub(super) struct RowsOf<'a> {
    means: &'a mut [[f32; 3]],
    opacities: &'a mut [f32],
    colours: &'a mut [[f32; 3]],
    scales: &'a mut [[f32; 3]],
    rotations: &'a mut [[f32; 4]],
    sh: &'a mut [f32],
    rest_per_channel: usize,
}

impl<'a> RowsOf<'a> {
    pub(super) fn new(g: &'a mut Gaussians, rest_per_channel: usize) -> RowsOf<'a> {
        RowsOf {
            means: &mut g.means,
            opacities: &mut g.raw_opacities,
            colours: &mut g.sh_dc,
            scales: &mut g.log_scales,
            rotations: &mut g.rotations,
            sh: &mut g.sh_rest,
            rest_per_channel,
        }
    }

    /// The next `count` rows of `section`'s array (the caller asks for no more than there are).
    pub(super) fn next(&mut self, section: Section, count: usize) -> Rows<'a> {
        fn take<'a, T>(rest: &mut &'a mut [T], count: usize) -> &'a mut [T] {
            let (head, tail) = std::mem::take(rest).split_at_mut(count);
            *rest = tail;
            head
        }
        match section {
            Section::Positions => Rows::Means(take(&mut self.means, count)),
            Section::Alphas => Rows::Opacities(take(&mut self.opacities, count)),
            Section::Colours => Rows::Colours(take(&mut self.colours, count)),
            Section::Scales => Rows::Scales(take(&mut self.scales, count)),
            Section::Rotations => Rows::Rotations(take(&mut self.rotations, count)),
            Section::Sh => Rows::Sh(take(&mut self.sh, 3 * self.rest_per_channel * count)),
        }
    }
}

/// What decoding needs besides the bytes: the body's shape and a table per byte-valued attribute.
pub(super) struct SpzDecoder {
    shape: BodyShape,
    alpha: [f32; 256],
    colour: [f32; 256],
    scale: [f32; 256],
    /// Each SH rest coefficient's table: its byte's value with the coefficient's sign flip.
    sh: [[f32; 256]; 15],
}

impl SpzDecoder {
    pub(super) fn new(shape: BodyShape) -> SpzDecoder {
        SpzDecoder {
            shape,
            alpha: byte_table(logit_of_byte),
            colour: byte_table(|c| (c as f32 / 255.0 - 0.5) / COLOUR_SCALE),
            scale: byte_table(|s| s as f32 / 16.0 - 10.0),
            sh: SH_FLIP.map(|flip| byte_table(|q| flip * (q as f32 - 128.0) / 128.0)),
        }
    }

    /// Decodes `bytes`, whole elements of one section, into `rows` (as many), their pages made
    /// writable first in one call ([`prefault`]).
    pub(super) fn decode(&self, mut rows: Rows<'_>, bytes: &[u8]) {
        rows.prefault();
        match rows {
            Rows::Means(out) => {
                let unit = 1.0 / (1u32 << self.shape.fractional_bits) as f32;
                for (out, p) in out.iter_mut().zip(bytes.chunks_exact(9)) {
                    *out = position(p, unit);
                }
            }
            Rows::Opacities(out) => {
                for (out, &a) in out.iter_mut().zip(bytes) {
                    *out = self.alpha[a as usize];
                }
            }
            Rows::Colours(out) => three_from_table(&self.colour, out, bytes),
            Rows::Scales(out) => three_from_table(&self.scale, out, bytes),
            Rows::Rotations(out) => {
                let rotation_bytes = self.shape.rotation_bytes;
                for (out, r) in out.iter_mut().zip(bytes.chunks_exact(rotation_bytes)) {
                    *out = rdf_quaternion(if rotation_bytes == 4 {
                        smallest_three_xyzw(r)
                    } else {
                        first_three_xyzw(r)
                    });
                }
            }
            Rows::Sh(out) => decode_sh(&self.sh, self.shape.rest_per_channel, bytes, out),
        }
    }
}

/// Three bytes per row, each through `table`.
fn three_from_table(table: &[f32; 256], out: &mut [[f32; 3]], bytes: &[u8]) {
    for (out, b) in out.iter_mut().zip(bytes.chunks_exact(3)) {
        *out = [table[b[0] as usize], table[b[1] as usize], table[b[2] as usize]];
    }
}

/// SH rest stored `[rows, K, 3]` (channel fastest) into `out`, `[rows, 3, K]`, in the PLY's frame.
fn decode_sh(tables: &[[f32; 256]; 15], k: usize, bytes: &[u8], out: &mut [f32]) {
    if k == 0 {
        return;
    }
    for (row, q) in out.chunks_exact_mut(3 * k).zip(bytes.chunks_exact(3 * k)) {
        let (r, rest) = row.split_at_mut(k);
        let (g, b) = rest.split_at_mut(k);
        for (j, (table, q)) in tables.iter().zip(q.chunks_exact(3)).enumerate() {
            r[j] = table[q[0] as usize];
            g[j] = table[q[1] as usize];
            b[j] = table[q[2] as usize];
        }
    }
}

/// A centre in the PLY's frame from 3 × 24-bit fixed-point coordinates.
fn position(p: &[u8], unit: f32) -> [f32; 3] {
    let flip = [1.0, -1.0, -1.0];
    [0, 1, 2].map(|a| {
        let b = &p[3 * a..3 * a + 3];
        let fixed = i32::from_le_bytes([b[0], b[1], b[2], 0]) << 8 >> 8;
        flip[a] * fixed as f32 * unit
    })
}

/// Version 2: x y z of a unit quaternion with w ≥ 0; w is what makes the norm 1.
fn first_three_xyzw(r: &[u8]) -> [f32; 4] {
    let [x, y, z] = [0, 1, 2].map(|i| r[i] as f32 / 127.5 - 1.0);
    [x, y, z, (1.0 - x * x - y * y - z * z).max(0.0).sqrt()]
}

/// Version 3: a little-endian u32 whose top 2 bits index the largest of x y z w (stored
/// positive, so not stored), then the other three from the first (highest bits) to the last,
/// each a sign bit and 9 bits of magnitude in units of (1/√2)/511.
pub(super) fn smallest_three_xyzw(r: &[u8]) -> [f32; 4] {
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
}

/// An SPZ-frame quaternion `x y z w` as the PLY's `w x y z` in the PLY's frame.
fn rdf_quaternion([x, y, z, w]: [f32; 4]) -> [f32; 4] {
    [w, x, -y, -z]
}

//! Procedural textures. Each gives a surface point its albedo and its **part**: the piece of the
//! object a SAM-like segmenter would cut out on its own (a stripe, a half of a two-tone object,
//! a face of a box). Parts drive the simulated over-segmentation and the feature fragments.

use crate::geometry::SurfacePoint;
use crate::noise::{hash, value_noise3};
use serde::{Deserialize, Serialize};

/// Linear RGB albedo in [0, 1].
pub type Rgb = [f64; 3];

/// A procedural texture.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Texture {
    /// One colour; parts are the shape's faces.
    Plain {
        /// Albedo.
        albedo: Rgb,
    },
    /// Horizontal bands of two alternating colours; each band is its own part.
    Stripes {
        /// Colour of even bands.
        a: Rgb,
        /// Colour of odd bands.
        b: Rgb,
        /// Band height, metres.
        period_m: f64,
    },
    /// Two colours split at a height; each half is its own part.
    TwoTone {
        /// Colour below the split.
        bottom: Rgb,
        /// Colour above the split.
        top: Rgb,
        /// Split height above the object's base, metres.
        split_m: f64,
    },
    /// A checkerboard on each face; parts are the faces.
    Checkers {
        /// First colour.
        a: Rgb,
        /// Second colour.
        b: Rgb,
        /// Square size, metres.
        cell_m: f64,
    },
    /// Irregular blotches of a second colour (thresholded 3D value noise); parts are the faces.
    Blotches {
        /// Base colour.
        base: Rgb,
        /// Blotch colour.
        blotch: Rgb,
        /// Noise frequency, cycles per metre.
        frequency: f64,
        /// Noise seed.
        seed: u64,
    },
    /// Floor planks: bands along the face's first axis, each plank's colour varied a little.
    Planks {
        /// Mean colour.
        base: Rgb,
        /// Plank width, metres.
        width_m: f64,
        /// Per-plank brightness variation (fraction).
        variation: f64,
        /// Seed of the per-plank variation.
        seed: u64,
    },
    /// A painted wall: one colour with faint low-frequency mottling.
    Wall {
        /// Colour.
        base: Rgb,
        /// Seed of the mottling.
        seed: u64,
    },
    /// Two tones over a room surface, with the faint mottling of [`Texture::Wall`]. Coordinates:
    /// on a floor (normal up) the local x, y; on a wall the horizontal distance from the room
    /// corner and the height.
    Room {
        /// First tone (lower paint, even stripes and cells).
        a: Rgb,
        /// Second tone.
        b: Rgb,
        /// The pattern.
        pattern: RoomPattern,
        /// Split height, stripe width or cell size, metres.
        scale_m: f64,
        /// Each tone is its own part (else the whole surface is part 0).
        tone_parts: bool,
        /// Seed of the mottling.
        seed: u64,
    },
}

/// The two-tone patterns of [`Texture::Room`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RoomPattern {
    /// Lower and upper tone, split at `scale_m` height.
    Split,
    /// Stripes: along the floor's x, vertical on a wall.
    Stripes,
    /// Checkers.
    Checkers,
}

/// A part index for band `band` on face `face` (bands of a cylinder's side and cap differ).
fn band_part(band: i64, face: u8) -> u8 {
    (band.clamp(0, 30) as u8) * 8 + face
}

fn mix(a: Rgb, b: Rgb, t: f64) -> Rgb {
    [0, 1, 2].map(|c| a[c] + (b[c] - a[c]) * t)
}

impl Texture {
    /// Albedo and part of a surface point.
    pub fn evaluate(&self, sp: &SurfacePoint) -> (Rgb, u8) {
        match *self {
            Texture::Plain { albedo } => (albedo, sp.face),
            Texture::Stripes { a, b, period_m } => {
                let band = (sp.local.z / period_m).floor() as i64;
                (if band % 2 == 0 { a } else { b }, band_part(band, sp.face))
            }
            Texture::TwoTone { bottom, top, split_m } => {
                let upper = sp.local.z >= split_m;
                (if upper { top } else { bottom }, band_part(i64::from(upper), sp.face))
            }
            Texture::Checkers { a, b, cell_m } => {
                let i = (sp.face_uv.x / cell_m).floor() as i64 + (sp.face_uv.y / cell_m).floor() as i64;
                (if i.rem_euclid(2) == 0 { a } else { b }, sp.face)
            }
            Texture::Blotches { base, blotch, frequency, seed } => {
                let v = value_noise3(seed, sp.position * frequency);
                let t = ((v - 0.58) / 0.04).clamp(0.0, 1.0);
                (mix(base, blotch, t), sp.face)
            }
            Texture::Planks { base, width_m, variation, seed } => {
                let plank = (sp.face_uv.x / width_m).floor() as i64;
                let jitter = crate::noise::unit(hash(seed, &[plank as u64])) * 2.0 - 1.0;
                let grain = value_noise3(seed ^ 0x5A, sp.position * 3.0) - 0.5;
                let k = 1.0 + variation * jitter + 0.04 * grain;
                (base.map(|c| (c * k).clamp(0.0, 1.0)), 0)
            }
            Texture::Wall { base, seed } => {
                let k = 1.0 + 0.04 * (value_noise3(seed, sp.position * 1.5) - 0.5);
                (base.map(|c| (c * k).clamp(0.0, 1.0)), 0)
            }
            Texture::Room { a, b, pattern, scale_m, tone_parts, seed } => {
                let floor = sp.normal.z.abs() > 0.9;
                let (u, v) =
                    if floor { (sp.local.x, sp.local.y) } else { (sp.local.x.hypot(sp.local.y), sp.local.z) };
                let cell = |t: f64| (t / scale_m).floor() as i64;
                let second = match pattern {
                    RoomPattern::Split => v >= scale_m,
                    RoomPattern::Stripes => cell(u).rem_euclid(2) == 1,
                    RoomPattern::Checkers => (cell(u) + cell(v)).rem_euclid(2) == 1,
                };
                let base = if second { b } else { a };
                let k = 1.0 + 0.04 * (value_noise3(seed, sp.position * 1.5) - 0.5);
                let part = if tone_parts { u8::from(second) } else { 0 };
                (base.map(|c| (c * k).clamp(0.0, 1.0)), part)
            }
        }
    }

    /// True when the texture splits a surface into parts by tone (stripes, two tones): the
    /// simulated SAM cuts one instance into several masks along colour edges.
    pub fn is_multi_tone(&self) -> bool {
        match self {
            Texture::Stripes { .. } | Texture::TwoTone { .. } => true,
            Texture::Room { tone_parts, .. } => *tone_parts,
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    fn point_at_height(z: f64, face: u8) -> SurfacePoint {
        SurfacePoint {
            position: DVec3::new(0.0, 0.0, z),
            normal: DVec3::X,
            local: DVec3::new(0.0, 0.0, z),
            face,
            face_uv: DVec2::new(0.0, z),
        }
    }

    #[test]
    fn stripes_alternate_colours_and_give_each_band_a_part() {
        let t = Texture::Stripes { a: [1.0, 0.0, 0.0], b: [0.0, 0.0, 1.0], period_m: 0.2 };
        let (c0, p0) = t.evaluate(&point_at_height(0.1, 0));
        let (c1, p1) = t.evaluate(&point_at_height(0.3, 0));
        let (c2, p2) = t.evaluate(&point_at_height(0.5, 0));
        assert_eq!(c0, [1.0, 0.0, 0.0]);
        assert_eq!(c1, [0.0, 0.0, 1.0]);
        assert_eq!(c2, c0);
        assert!(p0 != p1 && p1 != p2 && p0 != p2);
    }

    #[test]
    fn two_tone_splits_at_height() {
        let t = Texture::TwoTone { bottom: [0.1; 3], top: [0.9; 3], split_m: 0.4 };
        assert_eq!(t.evaluate(&point_at_height(0.39, 0)).0, [0.1; 3]);
        assert_eq!(t.evaluate(&point_at_height(0.41, 0)).0, [0.9; 3]);
        assert_ne!(t.evaluate(&point_at_height(0.39, 0)).1, t.evaluate(&point_at_height(0.41, 0)).1);
    }

    #[test]
    fn plain_parts_are_faces() {
        let t = Texture::Plain { albedo: [0.5; 3] };
        assert_eq!(t.evaluate(&point_at_height(0.2, 3)).1, 3);
        assert_eq!(t.evaluate(&point_at_height(0.2, 5)).1, 5);
    }
}

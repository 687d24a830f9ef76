//! PLY scalar property types and their byte-level conversions.

/// A PLY scalar type (`char`/`int8`, `uchar`/`uint8`, ..., `double`/`float64`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

/// Copies `K` bytes at `offset` out of `bytes`. Offsets come from the header layout, which
/// guarantees rows are long enough.
#[inline(always)]
fn bytes_at<const K: usize>(bytes: &[u8], offset: usize) -> [u8; K] {
    let mut a = [0u8; K];
    a.copy_from_slice(&bytes[offset..offset + K]);
    a
}

impl ScalarType {
    /// Parses a header type name, including the sized aliases (`float32`, `uint8`, ...).
    pub(crate) fn from_name(name: &str) -> Option<ScalarType> {
        Some(match name {
            "char" | "int8" => ScalarType::I8,
            "uchar" | "uint8" => ScalarType::U8,
            "short" | "int16" => ScalarType::I16,
            "ushort" | "uint16" => ScalarType::U16,
            "int" | "int32" => ScalarType::I32,
            "uint" | "uint32" => ScalarType::U32,
            "float" | "float32" => ScalarType::F32,
            "double" | "float64" => ScalarType::F64,
            _ => return None,
        })
    }

    /// Size in bytes.
    pub(crate) fn size(self) -> usize {
        match self {
            ScalarType::I8 | ScalarType::U8 => 1,
            ScalarType::I16 | ScalarType::U16 => 2,
            ScalarType::I32 | ScalarType::U32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    /// Inclusive value range of an integer type (`None` for floats).
    pub(crate) fn integer_range(self) -> Option<(f64, f64)> {
        Some(match self {
            ScalarType::I8 => (i8::MIN as f64, i8::MAX as f64),
            ScalarType::U8 => (0.0, u8::MAX as f64),
            ScalarType::I16 => (i16::MIN as f64, i16::MAX as f64),
            ScalarType::U16 => (0.0, u16::MAX as f64),
            ScalarType::I32 => (i32::MIN as f64, i32::MAX as f64),
            ScalarType::U32 => (0.0, u32::MAX as f64),
            ScalarType::F32 | ScalarType::F64 => return None,
        })
    }

    /// True when `value` can be stored in this type without change (integers: integral and in
    /// range; floats: always, `float` rounds to the nearest f32).
    pub(crate) fn can_store(self, value: f64) -> bool {
        match self.integer_range() {
            Some((lo, hi)) => value.fract() == 0.0 && value >= lo && value <= hi,
            None => true,
        }
    }

    /// Reads a value at `offset` of `row` as f64 (exact for every PLY type).
    /// `BIG` selects big-endian byte order.
    #[inline(always)]
    pub(crate) fn read_f64<const BIG: bool>(self, row: &[u8], offset: usize) -> f64 {
        macro_rules! get {
            ($t:ty, $k:literal) => {{
                let b = bytes_at::<$k>(row, offset);
                if BIG {
                    <$t>::from_be_bytes(b)
                } else {
                    <$t>::from_le_bytes(b)
                }
            }};
        }
        match self {
            ScalarType::I8 => row[offset] as i8 as f64,
            ScalarType::U8 => row[offset] as f64,
            ScalarType::I16 => get!(i16, 2) as f64,
            ScalarType::U16 => get!(u16, 2) as f64,
            ScalarType::I32 => get!(i32, 4) as f64,
            ScalarType::U32 => get!(u32, 4) as f64,
            ScalarType::F32 => get!(f32, 4) as f64,
            ScalarType::F64 => get!(f64, 8),
        }
    }

    /// Reads a value at `offset` of `row` as f32 (the fast path for `float` properties).
    #[inline(always)]
    pub(crate) fn read_f32<const BIG: bool>(self, row: &[u8], offset: usize) -> f32 {
        if self == ScalarType::F32 {
            let b = bytes_at::<4>(row, offset);
            if BIG {
                f32::from_be_bytes(b)
            } else {
                f32::from_le_bytes(b)
            }
        } else {
            self.read_f64::<BIG>(row, offset) as f32
        }
    }

    /// Writes `value` little-endian into `out[..self.size()]`. Integer values must satisfy
    /// [`ScalarType::can_store`] (checked by validation; otherwise the cast saturates).
    #[inline(always)]
    pub(crate) fn write_le(self, value: f64, out: &mut [u8]) {
        match self {
            ScalarType::I8 => out[0] = (value as i8) as u8,
            ScalarType::U8 => out[0] = value as u8,
            ScalarType::I16 => out[..2].copy_from_slice(&(value as i16).to_le_bytes()),
            ScalarType::U16 => out[..2].copy_from_slice(&(value as u16).to_le_bytes()),
            ScalarType::I32 => out[..4].copy_from_slice(&(value as i32).to_le_bytes()),
            ScalarType::U32 => out[..4].copy_from_slice(&(value as u32).to_le_bytes()),
            ScalarType::F32 => out[..4].copy_from_slice(&(value as f32).to_le_bytes()),
            ScalarType::F64 => out[..8].copy_from_slice(&value.to_le_bytes()),
        }
    }

    /// Parses an ASCII token as this type and writes it little-endian into `out`.
    pub(crate) fn parse_ascii_le(self, token: &str, out: &mut [u8]) -> Option<()> {
        match self {
            ScalarType::I8 => out[0] = token.parse::<i8>().ok()? as u8,
            ScalarType::U8 => out[0] = token.parse::<u8>().ok()?,
            ScalarType::I16 => out[..2].copy_from_slice(&token.parse::<i16>().ok()?.to_le_bytes()),
            ScalarType::U16 => out[..2].copy_from_slice(&token.parse::<u16>().ok()?.to_le_bytes()),
            ScalarType::I32 => out[..4].copy_from_slice(&token.parse::<i32>().ok()?.to_le_bytes()),
            ScalarType::U32 => out[..4].copy_from_slice(&token.parse::<u32>().ok()?.to_le_bytes()),
            ScalarType::F32 => out[..4].copy_from_slice(&token.parse::<f32>().ok()?.to_le_bytes()),
            ScalarType::F64 => out[..8].copy_from_slice(&token.parse::<f64>().ok()?.to_le_bytes()),
        }
        Some(())
    }
}

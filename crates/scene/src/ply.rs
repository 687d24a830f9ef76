//! The INRIA 3D Gaussian Splatting PLY layout: [`read_ply`] and [`write_ply`].
//!
//! Vertex properties (any order on read, any PLY scalar type):
//! `x y z`, optional `nx ny nz`, `f_dc_0..2`, `f_rest_0..(3K-1)` (K = 0, 3, 8 or 15, so SH
//! degree 0–3 is inferred from the count), `opacity`, `scale_0..2`, `rot_0..3` (w, x, y, z),
//! optional `object_id` (integer) and `feat_0..feat_{D-1}` (float). Every other vertex property
//! is kept in [`Gaussians::extra`] and written back with its type, in its order.
//!
//! Written files are `binary_little_endian` with the properties in the INRIA order, then
//! `object_id`, `feat_*`, then the extras. Read accepts `binary_little_endian`,
//! `binary_big_endian` and `ascii`. Other elements (none in 3DGS files) are skipped when they
//! have fixed-size rows and rejected when they have list properties.
//!
//! Reading parses the header by hand, checks the declared size against the file, then decodes
//! whole rows with byte offsets precomputed per property (`layout.rs`, `rows.rs`), in parallel
//! chunks.

mod ascii;
mod decode;
mod encode;
pub(crate) mod header;
mod layout;
mod rows;
pub(crate) mod scalar;
mod validate;

pub use decode::{parse_ply_bytes, parse_ply_bytes_rows, read_ply, read_ply_rows, PlyRows};
pub use encode::{
    to_ply_bytes, write_ply, write_ply_rows, write_ply_rows_with_features, write_ply_swept, FeatureRows,
};
pub use validate::{degenerate_shape, MAX_LOG_SCALE, MIN_QUATERNION_NORM};

/// Format name used in error messages.
pub(crate) const FORMAT: &str = "3DGS PLY";

#[cfg(doc)]
use crate::gaussians::Gaussians;

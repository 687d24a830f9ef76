//! `format ascii 1.0` bodies: the vertex rows are parsed token by token into the equivalent
//! little-endian binary rows, which the binary decoder then reads.

use super::header::ElementDecl;

/// Parses the ASCII body up to the end of the vertex element and returns the vertex rows as
/// little-endian binary (`[count * stride]` bytes). Elements before the vertex element are
/// skipped (scalar properties only); anything after it is ignored.
pub(crate) fn ascii_vertices_to_le(
    body: &[u8],
    elements: &[ElementDecl],
    vertex_index: usize,
) -> Result<Vec<u8>, String> {
    let mut tokens = body
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| std::str::from_utf8(t).unwrap_or("\u{FFFD}"));
    for e in &elements[..vertex_index] {
        let values = e.count.saturating_mul(e.properties.len());
        if tokens.by_ref().take(values).count() < values {
            return Err(format!(
                "the ASCII body ends inside element '{}' (the header declares {} rows)",
                e.name, e.count
            ));
        }
    }
    let vertex = &elements[vertex_index];
    let stride = vertex.row_bytes();
    // Each ASCII value takes at least two bytes: never reserve more than the body can hold.
    let capacity = vertex.count.min(body.len() / 2 + 1).saturating_mul(stride);
    let mut out = Vec::with_capacity(capacity);
    let mut row = vec![0u8; stride];
    for i in 0..vertex.count {
        let mut offset = 0;
        for p in &vertex.properties {
            let token = tokens.next().ok_or_else(|| {
                format!(
                    "truncated: the ASCII body ends in vertex {i} but the header declares {} \
                     vertices",
                    vertex.count
                )
            })?;
            p.ty.parse_ascii_le(token, &mut row[offset..]).ok_or_else(|| {
                format!("vertex {i}: property '{}' = '{token}' is not a valid {}", p.name, p.type_name)
            })?;
            offset += p.ty.size();
        }
        out.extend_from_slice(&row);
    }
    Ok(out)
}

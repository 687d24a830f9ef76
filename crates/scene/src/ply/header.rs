//! Hand-written PLY header parser: format, elements and their properties, and where the body
//! starts.

use super::scalar::ScalarType;

/// Headers longer than this without `end_header` are rejected (3DGS headers are a few KB).
pub(crate) const MAX_HEADER_BYTES: usize = 1 << 20;

/// How the body is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BodyFormat {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// One scalar property of an element.
#[derive(Clone, Debug)]
pub(crate) struct PropertyDecl {
    /// Property name.
    pub name: String,
    /// Type name exactly as written in the header (`float`, `uint8`, ...).
    pub type_name: String,
    /// Parsed type.
    pub ty: ScalarType,
}

/// One `element` with its properties.
#[derive(Clone, Debug)]
pub(crate) struct ElementDecl {
    /// Element name (`vertex`, ...).
    pub name: String,
    /// Declared number of rows.
    pub count: usize,
    /// Scalar properties, in header order.
    pub properties: Vec<PropertyDecl>,
    /// Name of the first list property, if the element has one.
    pub first_list_property: Option<String>,
}

impl ElementDecl {
    /// Bytes per row in a binary body (lists excluded).
    pub(crate) fn row_bytes(&self) -> usize {
        self.properties.iter().map(|p| p.ty.size()).sum()
    }
}

/// A parsed header.
#[derive(Clone, Debug)]
pub(crate) struct Header {
    pub format: BodyFormat,
    pub elements: Vec<ElementDecl>,
    /// Byte offset of the body (just after the `end_header` line).
    pub body_offset: usize,
}

/// Parses the header at the start of `bytes`. Errors say what is wrong and on which line.
pub(crate) fn parse_header(bytes: &[u8]) -> Result<Header, String> {
    if bytes.is_empty() {
        return Err("the file is empty".to_string());
    }
    if !(bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")) {
        return Err("not a PLY file: it does not start with a 'ply' line".to_string());
    }
    let mut format = None;
    let mut elements: Vec<ElementDecl> = Vec::new();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    loop {
        if pos >= bytes.len() || pos > MAX_HEADER_BYTES {
            return Err(format!("header has no end_header line (searched {} bytes)", pos.min(bytes.len())));
        }
        let end = match bytes[pos..].iter().position(|&b| b == b'\n') {
            Some(i) => pos + i,
            None => {
                return Err(format!("header has no end_header line (file ends after {} bytes)", bytes.len()))
            }
        };
        let raw = &bytes[pos..end];
        let next = end + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| format!("header line {line_no} is not text (is end_header missing?)"))?
            .trim_end_matches('\r');
        let mut tokens = line.split_ascii_whitespace();
        let keyword = tokens.next().unwrap_or("");
        if line_no == 1 {
            // The 'ply' magic line, checked above.
            pos = next;
            continue;
        }
        match keyword {
            "" | "comment" | "obj_info" => {}
            "format" => format = Some(parse_format(tokens.next(), line_no)?),
            "element" => elements.push(parse_element(&mut tokens, line, line_no)?),
            "property" => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| format!("header line {line_no}: property before any element: '{line}'"))?;
                parse_property(&mut tokens, line, line_no, element)?;
            }
            "end_header" => {
                let format = format.ok_or_else(|| "header has no 'format' line".to_string())?;
                return Ok(Header { format, elements, body_offset: next });
            }
            _ => return Err(format!("header line {line_no}: unexpected line '{line}'")),
        }
        pos = next;
    }
}

fn parse_format(token: Option<&str>, line_no: usize) -> Result<BodyFormat, String> {
    match token {
        Some("ascii") => Ok(BodyFormat::Ascii),
        Some("binary_little_endian") => Ok(BodyFormat::BinaryLittleEndian),
        Some("binary_big_endian") => Ok(BodyFormat::BinaryBigEndian),
        other => Err(format!(
            "header line {line_no}: unknown format '{}' (expected ascii, binary_little_endian or \
             binary_big_endian)",
            other.unwrap_or("")
        )),
    }
}

fn parse_element<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    line: &str,
    line_no: usize,
) -> Result<ElementDecl, String> {
    let (Some(name), Some(count), None) = (tokens.next(), tokens.next(), tokens.next()) else {
        return Err(format!("header line {line_no}: expected 'element <name> <count>', found '{line}'"));
    };
    let count = count
        .parse::<usize>()
        .map_err(|_| format!("header line {line_no}: element '{name}' has an invalid count '{count}'"))?;
    Ok(ElementDecl { name: name.to_string(), count, properties: Vec::new(), first_list_property: None })
}

fn parse_property<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    line: &str,
    line_no: usize,
    element: &mut ElementDecl,
) -> Result<(), String> {
    let words: Vec<&str> = tokens.collect();
    match words.as_slice() {
        ["list", _count_type, _item_type, name] => {
            element.first_list_property.get_or_insert_with(|| name.to_string());
            Ok(())
        }
        [type_name, name] => {
            let ty = ScalarType::from_name(type_name).ok_or_else(|| {
                format!(
                    "header line {line_no}: unknown type '{type_name}' for property '{name}' \
                     (expected char, uchar, short, ushort, int, uint, float, double or a sized \
                     alias such as float32)"
                )
            })?;
            if element.properties.iter().any(|p| p.name == *name) {
                return Err(format!(
                    "header line {line_no}: property '{name}' appears twice in element '{}'",
                    element.name
                ));
            }
            element.properties.push(PropertyDecl {
                name: name.to_string(),
                type_name: type_name.to_string(),
                ty,
            });
            Ok(())
        }
        _ => Err(format!(
            "header line {line_no}: expected 'property <type> <name>' or 'property list <count \
             type> <item type> <name>', found '{line}'"
        )),
    }
}

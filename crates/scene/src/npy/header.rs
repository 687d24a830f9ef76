//! The `.npy` header: magic, version, and the Python-dict literal that gives `descr`,
//! `fortran_order` and `shape` (NumPy's format spec, versions 1.0, 2.0 and 3.0).

use super::NpyDtype;

/// The six magic bytes every `.npy` file starts with.
pub(crate) const MAGIC: &[u8; 6] = b"\x93NUMPY";

/// What the header says about the array that follows it.
#[derive(Debug)]
pub(crate) struct Header {
    pub dtype: NpyDtype,
    pub little_endian: bool,
    pub shape: Vec<usize>,
    /// Offset of the first data byte from the start of the file.
    pub data_offset: usize,
}

/// Parses the header at the start of `bytes`. Errors are human-readable reasons.
pub(crate) fn parse_header(bytes: &[u8]) -> Result<Header, String> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err("not a NumPy .npy array (missing the \\x93NUMPY magic)".into());
    }
    let (major, minor) = (bytes[6], bytes[7]);
    let (len_size, prefix) = match major {
        1 => (2, 10),
        2 | 3 => (4, 12),
        _ => {
            return Err(format!(
                "unsupported .npy format version {major}.{minor} (1.0, 2.0 and 3.0 are read)"
            ))
        }
    };
    if bytes.len() < prefix {
        return Err("file ends inside the header".into());
    }
    let header_len = if len_size == 2 {
        u16::from_le_bytes([bytes[8], bytes[9]]) as usize
    } else {
        u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize
    };
    let data_offset = prefix
        .checked_add(header_len)
        .filter(|&end| end <= bytes.len())
        .ok_or_else(|| format!("header says it is {header_len} bytes long but the file ends before"))?;
    let text = std::str::from_utf8(&bytes[prefix..data_offset])
        .map_err(|_| "header is not valid text".to_string())?;
    let fields = parse_dict(text)?;
    let descr = fields.descr.ok_or("header has no 'descr'")?;
    let (dtype, little_endian) = parse_descr(&descr)?;
    if fields.fortran_order.ok_or("header has no 'fortran_order'")? {
        return Err("array is in Fortran (column-major) order; save it in C order \
                    (numpy.ascontiguousarray) before passing it to splatseg"
            .into());
    }
    let shape = fields.shape.ok_or("header has no 'shape'")?;
    Ok(Header { dtype, little_endian, shape, data_offset })
}

/// Formats the header for a little-endian float32 C-order array, padded as NumPy pads it
/// (total header length a multiple of 64, ending in `\n`). Returns the full prefix + header.
pub(crate) fn format_f32_header(shape: &[usize]) -> Vec<u8> {
    let shape_text = match shape {
        [] => "()".to_string(),
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape_text}, }}");
    let padded_len = |prefix: usize| (prefix + dict.len() + 1).div_ceil(64) * 64 - prefix;
    let (version, prefix) = if padded_len(10) <= u16::MAX as usize { (1u8, 10) } else { (2u8, 12) };
    let header_len = padded_len(prefix);
    let mut out = Vec::with_capacity(prefix + header_len);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&[version, 0]);
    if version == 1 {
        out.extend_from_slice(&(header_len as u16).to_le_bytes());
    } else {
        out.extend_from_slice(&(header_len as u32).to_le_bytes());
    }
    out.extend_from_slice(dict.as_bytes());
    out.resize(prefix + header_len - 1, b' ');
    out.push(b'\n');
    out
}

fn parse_descr(descr: &str) -> Result<(NpyDtype, bool), String> {
    let unsupported = || {
        format!("unsupported dtype '{descr}' (supported: bool, int8–64, uint8–64, float16, float32, float64)")
    };
    let mut chars = descr.chars();
    let order = chars.next().ok_or_else(unsupported)?;
    let little_endian = match order {
        '<' | '|' | '=' => true,
        '>' => false,
        _ => return Err(unsupported()),
    };
    let dtype = match chars.as_str() {
        "b1" => NpyDtype::Bool,
        "i1" => NpyDtype::Int8,
        "u1" => NpyDtype::UInt8,
        "i2" => NpyDtype::Int16,
        "u2" => NpyDtype::UInt16,
        "i4" => NpyDtype::Int32,
        "u4" => NpyDtype::UInt32,
        "i8" => NpyDtype::Int64,
        "u8" => NpyDtype::UInt64,
        "f2" => NpyDtype::Float16,
        "f4" => NpyDtype::Float32,
        "f8" => NpyDtype::Float64,
        _ => return Err(unsupported()),
    };
    Ok((dtype, little_endian))
}

#[derive(Default)]
struct Fields {
    descr: Option<String>,
    fortran_order: Option<bool>,
    shape: Option<Vec<usize>>,
}

/// A value in the header dict.
enum Value {
    Str(String),
    Bool(bool),
    Tuple(Vec<usize>),
}

/// Parses the dict literal `{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }`.
fn parse_dict(text: &str) -> Result<Fields, String> {
    let mut p = Cursor { rest: text.trim_end() };
    p.expect('{')?;
    let mut fields = Fields::default();
    loop {
        p.skip_ws();
        if p.eat('}') {
            break;
        }
        let key = p.string()?;
        p.skip_ws();
        p.expect(':')?;
        p.skip_ws();
        let value = p.value(&key)?;
        match (key.as_str(), value) {
            ("descr", Value::Str(s)) => fields.descr = Some(s),
            ("fortran_order", Value::Bool(b)) => fields.fortran_order = Some(b),
            ("shape", Value::Tuple(t)) => fields.shape = Some(t),
            (k, _) => return Err(format!("unexpected header entry '{k}'")),
        }
        p.skip_ws();
        if !p.eat(',') {
            p.skip_ws();
            p.expect('}')?;
            break;
        }
    }
    if !p.rest.trim().is_empty() {
        return Err("unexpected text after the header dict".into());
    }
    Ok(fields)
}

struct Cursor<'a> {
    rest: &'a str,
}

impl Cursor<'_> {
    fn skip_ws(&mut self) {
        self.rest = self.rest.trim_start();
    }

    fn eat(&mut self, c: char) -> bool {
        match self.rest.strip_prefix(c) {
            Some(r) => {
                self.rest = r;
                true
            }
            None => false,
        }
    }

    fn expect(&mut self, c: char) -> Result<(), String> {
        self.skip_ws();
        if self.eat(c) {
            Ok(())
        } else {
            Err(format!("malformed header dict: expected '{c}' at \"{}\"", self.snippet()))
        }
    }

    fn snippet(&self) -> &str {
        let end = self.rest.char_indices().nth(20).map_or(self.rest.len(), |(i, _)| i);
        &self.rest[..end]
    }

    fn string(&mut self) -> Result<String, String> {
        let quote = match self.rest.chars().next() {
            Some(q @ ('\'' | '"')) => q,
            _ => {
                return Err(format!("malformed header dict: expected a quoted key at \"{}\"", self.snippet()))
            }
        };
        let body = &self.rest[1..];
        let end = body.find(quote).ok_or("malformed header dict: unterminated string")?;
        let s = body[..end].to_string();
        self.rest = &body[end + 1..];
        Ok(s)
    }

    fn value(&mut self, key: &str) -> Result<Value, String> {
        if self.rest.starts_with(['\'', '"']) {
            return self.string().map(Value::Str);
        }
        for (word, b) in [("True", true), ("False", false)] {
            if let Some(r) = self.rest.strip_prefix(word) {
                self.rest = r;
                return Ok(Value::Bool(b));
            }
        }
        if key == "descr" && self.rest.starts_with('[') {
            return Err("structured (record) dtypes are not supported".into());
        }
        self.expect('(')?;
        let mut dims = Vec::new();
        loop {
            self.skip_ws();
            if self.eat(')') {
                return Ok(Value::Tuple(dims));
            }
            let digits_end = self.rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(self.rest.len());
            let dim = self.rest[..digits_end]
                .parse::<usize>()
                .map_err(|_| format!("malformed shape in header at \"{}\"", self.snippet()))?;
            dims.push(dim);
            self.rest = &self.rest[digits_end..];
            self.skip_ws();
            if !self.eat(',') {
                self.expect(')')?;
                return Ok(Value::Tuple(dims));
            }
        }
    }
}

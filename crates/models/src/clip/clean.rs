//! The text cleaning CLIP's tokenizer applies before splitting (open_clip's default `lower` cleaning):
//! ftfy's `fix_text` with its default settings, HTML unescaped twice, surrounding whitespace removed,
//! runs of whitespace joined into one space, lower case.
//!
//! Of ftfy's fixes, these are done as ftfy documents them, per line, repeated until nothing changes:
//! HTML entities (only in lines without `<`), C1 controls read as Windows-1252, Latin ligatures split,
//! half- and full-width forms to their usual width (NFKC of U+FF01..U+FFEF, U+3000 → space), curly
//! quotes straightened, ANSI terminal escapes and control characters removed, NFC normalisation.
//! Not done: ftfy's mojibake repair (`fix_encoding`: text decoded with the wrong codec), which needs its
//! statistical tables; such text is tokenized as it stands. Named HTML entities beyond the common ones
//! listed in [`named_entity`] are left as written (Python's `html.unescape` knows all 2,231).

use unicode_normalization::UnicodeNormalization;

/// `text` cleaned as open_clip's `_clean_lower` does (see the module docs for what differs).
pub fn clean_lower(text: &str) -> String {
    let fixed = fix_text(text);
    let unescaped = unescape_html(&unescape_html(&fixed, false), false);
    let mut out = String::with_capacity(unescaped.len());
    for word in unescaped.split(is_python_space).filter(|w| !w.is_empty()) {
        if !out.is_empty() {
            out.push(' ');
        }
        out.push_str(word);
    }
    out.to_lowercase()
}

/// Python's `str.isspace`: Unicode White_Space plus the information separators U+001C..U+001F.
pub(crate) fn is_python_space(c: char) -> bool {
    c.is_whitespace() || ('\u{1c}'..='\u{1f}').contains(&c)
}

/// ftfy's `fix_text` (default configuration, without the mojibake repair), line by line.
fn fix_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        out.push_str(&fix_segment(line));
    }
    out
}

fn fix_segment(segment: &str) -> String {
    let unescape = !segment.contains('<');
    let mut text = segment.to_string();
    // the fixes run until none changes the text (each pass is finite: the text only shrinks or is
    // mapped onto characters the later passes leave alone; the bound is a guard)
    for _ in 0..16 {
        let before = text.clone();
        if unescape {
            text = unescape_html(&text, true);
        }
        text = text.chars().map(c1_as_windows_1252).collect();
        text = text.chars().flat_map(split_ligature).collect();
        text = text.chars().flat_map(usual_width).collect();
        text = text.chars().map(straight_quote).collect();
        text = fix_line_breaks(&text);
        text = remove_terminal_escapes(&text);
        text.retain(|c| !is_removed_control(c));
        text = text.nfc().collect();
        if text == before {
            break;
        }
    }
    text
}

/// U+0080..U+009F read as the Windows-1252 byte of the same value (its five undefined bytes stay).
fn c1_as_windows_1252(c: char) -> char {
    const TABLE: [u32; 32] = [
        0x20AC, 0x81, 0x201A, 0x0192, 0x201E, 0x2026, 0x2020, 0x2021, 0x02C6, 0x2030, 0x0160, 0x2039, 0x0152,
        0x8D, 0x017D, 0x8F, 0x90, 0x2018, 0x2019, 0x201C, 0x201D, 0x2022, 0x2013, 0x2014, 0x02DC, 0x2122,
        0x0161, 0x203A, 0x0153, 0x9D, 0x017E, 0x0178,
    ];
    match c as u32 {
        v @ 0x80..=0x9F => char::from_u32(TABLE[(v - 0x80) as usize]).unwrap_or(c),
        _ => c,
    }
}

/// ftfy's Latin ligatures and digraphs, split into their letters.
fn split_ligature(c: char) -> LigatureChars {
    let split: &'static str = match c {
        'Ĳ' => "IJ",
        'ĳ' => "ij",
        'ŉ' => "ʼn",
        'Ǳ' => "DZ",
        'ǲ' => "Dz",
        'ǳ' => "dz",
        'Ǆ' => "DŽ",
        'ǅ' => "Dž",
        'ǆ' => "dž",
        'Ǉ' => "LJ",
        'ǈ' => "Lj",
        'ǉ' => "lj",
        'Ǌ' => "NJ",
        'ǋ' => "Nj",
        'ǌ' => "nj",
        'ﬀ' => "ff",
        'ﬁ' => "fi",
        'ﬂ' => "fl",
        'ﬃ' => "ffi",
        'ﬄ' => "ffl",
        'ﬅ' => "ſt",
        'ﬆ' => "st",
        _ => return LigatureChars::One(Some(c)),
    };
    LigatureChars::Many(split.chars())
}

enum LigatureChars {
    One(Option<char>),
    Many(std::str::Chars<'static>),
}

impl Iterator for LigatureChars {
    type Item = char;
    fn next(&mut self) -> Option<char> {
        match self {
            LigatureChars::One(c) => c.take(),
            LigatureChars::Many(chars) => chars.next(),
        }
    }
}

/// Half- and full-width forms (U+FF01..U+FFEF) to their NFKC form, the ideographic space to a space.
fn usual_width(c: char) -> Vec<char> {
    match c as u32 {
        0x3000 => vec![' '],
        0xFF01..=0xFFEF => c.to_string().nfkc().collect(),
        _ => vec![c],
    }
}

/// Curly single quotes (and U+02BC) to `'`, curly double quotes to `"`.
fn straight_quote(c: char) -> char {
    match c {
        '\u{02bc}' | '\u{2018}'..='\u{201b}' => '\'',
        '\u{201c}'..='\u{201f}' => '"',
        _ => c,
    }
}

/// `\r\n`, `\r`, U+2028, U+2029 and U+0085 to `\n`.
fn fix_line_breaks(text: &str) -> String {
    text.replace("\r\n", "\n").replace(['\r', '\u{2028}', '\u{2029}', '\u{85}'], "\n")
}

/// ANSI escapes `ESC [ digits-and-semicolons letter` removed.
fn remove_terminal_escapes(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] == '\u{1b}' && chars.get(i + 1) == Some(&'[') {
            let mut j = i + 2;
            while j < chars.len() && (chars[j].is_ascii_digit() || chars[j] == ';') {
                j += 1;
            }
            if j < chars.len() && chars[j].is_ascii_alphabetic() {
                i = j + 1;
                continue;
            }
        }
        out.push(chars[i]);
        i += 1;
    }
    out
}

/// The control and format characters ftfy removes.
fn is_removed_control(c: char) -> bool {
    matches!(c as u32,
        0x00..=0x08 | 0x0B | 0x0E..=0x1F | 0x7F | 0x206A..=0x206F | 0xFEFF | 0xFFF9..=0xFFFC)
}

/// HTML character references decoded. `strict` (ftfy's rule): only `&name;` and `&#...;` with their
/// semicolon, a reference that does not decode whole stays as written; otherwise Python's
/// `html.unescape` rules: numeric references without the semicolon too, and the legacy entities
/// (`&amp`, `&lt`, `&eacute`, ...) without it as the longest known prefix of the name.
pub(crate) fn unescape_html(text: &str, strict: bool) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find('&') {
        out.push_str(&rest[..at]);
        let tail = &rest[at + 1..];
        match decode_reference(tail, strict) {
            Some((decoded, used)) => {
                out.push_str(&decoded);
                rest = &tail[used..];
            }
            None => {
                out.push('&');
                rest = tail;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The reference at the start of `tail` (after `&`): its text and how many bytes of `tail` it used.
fn decode_reference(tail: &str, strict: bool) -> Option<(String, usize)> {
    if let Some(number) = tail.strip_prefix('#') {
        let (hex, digits) = match number.strip_prefix(['x', 'X']) {
            Some(hex) => (true, hex),
            None => (false, number),
        };
        let len = digits
            .bytes()
            .take_while(|b| if hex { b.is_ascii_hexdigit() } else { b.is_ascii_digit() })
            .count();
        if len == 0 {
            return None;
        }
        let has_semicolon = digits.as_bytes().get(len) == Some(&b';');
        if strict && (!has_semicolon || len + usize::from(hex) > 23) {
            return None;
        }
        let value = u32::from_str_radix(&digits[..len], if hex { 16 } else { 10 }).unwrap_or(u32::MAX);
        let used = 1 + usize::from(hex) + len + usize::from(has_semicolon);
        return Some((numeric_reference(value), used));
    }
    let name_len = tail.bytes().take_while(|b| b.is_ascii_alphanumeric()).count();
    let name = &tail[..name_len];
    if tail.as_bytes().get(name_len) == Some(&b';') {
        let found =
            named_entity(name).map(|(v, _)| v.to_string()).or_else(|| upper_case_entity(name, strict));
        if let Some(value) = found {
            return Some((value, name_len + 1));
        }
    }
    if strict {
        return None;
    }
    // Python: the longest prefix that is a legacy entity (one valid without its semicolon)
    (1..=name_len.min(32)).rev().find_map(|len| match named_entity(&name[..len]) {
        Some((value, true)) => Some((value.to_string(), len)),
        _ => None,
    })
}

/// ftfy also decodes all-caps spellings of entities (`&EACUTE;` → `É`).
fn upper_case_entity(name: &str, strict: bool) -> Option<String> {
    if !strict || name.len() < 2 || !name.bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit()) {
        return None;
    }
    let lower = name.to_ascii_lowercase();
    let (value, _) = named_entity(&lower)?;
    Some(value.to_uppercase())
}

/// Python's `html.unescape` for `&#N;`: the HTML5 replacements of invalid code points.
fn numeric_reference(value: u32) -> String {
    match value {
        0x80..=0x9F => c1_as_windows_1252(char::from_u32(value).unwrap_or('\u{fffd}')).to_string(),
        0 | 0xD800..=0xDFFF => '\u{fffd}'.to_string(),
        0x0D => "\r".to_string(),
        v if v > 0x10FFFF => '\u{fffd}'.to_string(),
        0x01..=0x08 | 0x0B | 0x0E..=0x1F | 0x7F | 0xFDD0..=0xFDEF => String::new(),
        v if (v & 0xFFFE) == 0xFFFE => String::new(),
        v => char::from_u32(v).map(String::from).unwrap_or_else(|| '\u{fffd}'.to_string()),
    }
}

/// The common named entities (HTML5 values) and whether each is a legacy one, valid without `;`.
fn named_entity(name: &str) -> Option<(&'static str, bool)> {
    let legacy = |v: &'static str| Some((v, true));
    let modern = |v: &'static str| Some((v, false));
    match name {
        "amp" | "AMP" => legacy("&"),
        "lt" | "LT" => legacy("<"),
        "gt" | "GT" => legacy(">"),
        "quot" | "QUOT" => legacy("\""),
        "nbsp" => legacy("\u{a0}"),
        "copy" | "COPY" => legacy("©"),
        "reg" | "REG" => legacy("®"),
        "deg" => legacy("°"),
        "plusmn" => legacy("±"),
        "middot" => legacy("·"),
        "times" => legacy("×"),
        "divide" => legacy("÷"),
        "frac12" => legacy("½"),
        "frac14" => legacy("¼"),
        "frac34" => legacy("¾"),
        "sup2" => legacy("²"),
        "sup3" => legacy("³"),
        "pound" => legacy("£"),
        "yen" => legacy("¥"),
        "cent" => legacy("¢"),
        "sect" => legacy("§"),
        "para" => legacy("¶"),
        "laquo" => legacy("«"),
        "raquo" => legacy("»"),
        "iexcl" => legacy("¡"),
        "iquest" => legacy("¿"),
        "aacute" => legacy("á"),
        "agrave" => legacy("à"),
        "acirc" => legacy("â"),
        "auml" => legacy("ä"),
        "aring" => legacy("å"),
        "atilde" => legacy("ã"),
        "aelig" => legacy("æ"),
        "ccedil" => legacy("ç"),
        "eacute" => legacy("é"),
        "egrave" => legacy("è"),
        "ecirc" => legacy("ê"),
        "euml" => legacy("ë"),
        "iacute" => legacy("í"),
        "igrave" => legacy("ì"),
        "icirc" => legacy("î"),
        "iuml" => legacy("ï"),
        "ntilde" => legacy("ñ"),
        "oacute" => legacy("ó"),
        "ograve" => legacy("ò"),
        "ocirc" => legacy("ô"),
        "ouml" => legacy("ö"),
        "otilde" => legacy("õ"),
        "oslash" => legacy("ø"),
        "uacute" => legacy("ú"),
        "ugrave" => legacy("ù"),
        "ucirc" => legacy("û"),
        "uuml" => legacy("ü"),
        "yacute" => legacy("ý"),
        "yuml" => legacy("ÿ"),
        "szlig" => legacy("ß"),
        "Aacute" => legacy("Á"),
        "Agrave" => legacy("À"),
        "Auml" => legacy("Ä"),
        "Ccedil" => legacy("Ç"),
        "Eacute" => legacy("É"),
        "Egrave" => legacy("È"),
        "Ntilde" => legacy("Ñ"),
        "Ouml" => legacy("Ö"),
        "Uuml" => legacy("Ü"),
        "apos" => modern("'"),
        "hellip" => modern("…"),
        "mdash" => modern("—"),
        "ndash" => modern("–"),
        "lsquo" => modern("‘"),
        "rsquo" => modern("’"),
        "sbquo" => modern("‚"),
        "ldquo" => modern("“"),
        "rdquo" => modern("”"),
        "bdquo" => modern("„"),
        "bull" => modern("•"),
        "trade" => modern("™"),
        "euro" => modern("€"),
        "larr" => modern("←"),
        "rarr" => modern("→"),
        "uarr" => modern("↑"),
        "darr" => modern("↓"),
        "hearts" => modern("♥"),
        "infin" => modern("∞"),
        "ne" => modern("≠"),
        "le" => modern("≤"),
        "ge" => modern("≥"),
        "minus" => modern("−"),
        "prime" => modern("′"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cleans_as_the_reference_describes() {
        assert_eq!(clean_lower("  A  Red\tMUG \n"), "a red mug");
        assert_eq!(clean_lower("&amp;amp; &lt;b&gt;"), "& <b>");
        assert_eq!(clean_lower("\u{201c}Hi\u{201d} \u{2018}x\u{2019}"), "\"hi\" 'x'");
        assert_eq!(clean_lower("\u{fb01}ne"), "fine");
        assert_eq!(clean_lower("\u{ff26}\u{ff35}\u{3000}\u{ff11}"), "fu 1");
        assert_eq!(clean_lower("cafe\u{301}"), "caf\u{e9}");
        assert_eq!(clean_lower("a\u{1b}[31mred\u{1b}[0m\u{7}"), "ared");
        assert_eq!(clean_lower("\u{93}q\u{94}"), "\"q\"");
        // lines holding `<` keep their entities for the two html.unescape passes only
        assert_eq!(unescape_html("&amp;amp;amp;", false), "&amp;amp;");
        assert_eq!(unescape_html("&eacutex &#233 &#x41;&bogus;", false), "éx é A&bogus;");
        assert_eq!(unescape_html("&eacutex &#233 &#x41;", true), "&eacutex &#233 A");
        assert_eq!(clean_lower(""), "");
    }
}

//! The split of cleaned text into pre-tokens, CLIP's pattern
//! `(?i)<start_of_text>|<end_of_text>|'s|'t|'re|'ve|'m|'ll|'d|\p{L}+|\p{N}|[^\s\p{L}\p{N}]+`
//! (the special tokens are the vocabulary file's: Hugging Face's `tokenizer.json` has
//! `<|startoftext|>` and `<|endoftext|>`)
//! read as a regex engine reads it: at each position the first alternative that matches wins
//! (leftmost-first), the repeated classes are greedy, whitespace between matches is skipped.
//!
//! Written as a scanner rather than with a regex engine (which costs more to build than the rest of
//! the tokenizer). `\p{L}` is the general category Letter, `\p{N}` Number (`char::is_numeric`: Nd, Nl,
//! No) and `\s` White_Space (`char::is_whitespace`); case-insensitive literals match under simple case
//! folding, which for the literals' letters only adds `ſ` (U+017F) as an `s`.

use unicode_general_category::{get_general_category, GeneralCategory};

/// open_clip's special tokens (the merges file's); a Hugging Face `tokenizer.json` names them
/// `<|startoftext|>` and `<|endoftext|>`.
pub const OPEN_CLIP_SPECIALS: [&str; 2] = ["<start_of_text>", "<end_of_text>"];
/// The contractions after the apostrophe, in the pattern's order.
const CONTRACTIONS: [&str; 7] = ["s", "t", "re", "ve", "m", "ll", "d"];

/// The pre-tokens of `text`, in order; `specials` (ASCII, e.g. [`OPEN_CLIP_SPECIALS`]) are the
/// pattern's first alternatives.
pub fn pretokens<'t>(text: &'t str, specials: &[&str]) -> Vec<&'t str> {
    let mut out = Vec::new();
    let mut at = 0;
    while let Some(c) = text[at..].chars().next() {
        let rest = &text[at..];
        let len = if let Some(n) = specials.iter().find_map(|s| folded_prefix(rest, s)) {
            n
        } else if let Some(n) = contraction(rest) {
            n
        } else if is_letter(c) {
            run_length(rest, is_letter)
        } else if c.is_numeric() {
            c.len_utf8()
        } else if !c.is_whitespace() {
            run_length(rest, |c| !c.is_whitespace() && !is_letter(c) && !c.is_numeric())
        } else {
            at += c.len_utf8();
            continue;
        };
        out.push(&rest[..len]);
        at += len;
    }
    out
}

/// `\p{L}`: the general categories Lu, Ll, Lt, Lm and Lo.
fn is_letter(c: char) -> bool {
    use GeneralCategory::*;
    matches!(
        get_general_category(c),
        UppercaseLetter | LowercaseLetter | TitlecaseLetter | ModifierLetter | OtherLetter
    )
}

/// Bytes of the longest prefix of `text` whose characters all satisfy `class` (`text` starts with one).
fn run_length(text: &str, class: impl Fn(char) -> bool) -> usize {
    text.char_indices().find(|&(_, c)| !class(c)).map_or(text.len(), |(i, _)| i)
}

/// Bytes of `'` + the first contraction `text` starts with, if any.
fn contraction(text: &str) -> Option<usize> {
    let after = text.strip_prefix('\'')?;
    CONTRACTIONS.iter().find_map(|c| folded_prefix(after, c)).map(|n| n + 1)
}

/// Bytes of `text`'s prefix that equals the ASCII `literal` under simple case folding.
fn folded_prefix(text: &str, literal: &str) -> Option<usize> {
    let mut chars = text.char_indices();
    for want in literal.chars() {
        let (_, c) = chars.next()?;
        if fold(c) != want {
            return None;
        }
    }
    Some(chars.next().map_or(text.len(), |(i, _)| i))
}

/// The simple case fold of `c` as far as ASCII literals need it.
fn fold(c: char) -> char {
    match c {
        '\u{17f}' => 's',
        '\u{212a}' => 'k',
        c => c.to_ascii_lowercase(),
    }
}

#[cfg(test)]
mod tests {
    use super::OPEN_CLIP_SPECIALS;

    fn pretokens(text: &str) -> Vec<&str> {
        super::pretokens(text, &OPEN_CLIP_SPECIALS)
    }

    #[test]
    fn splits_as_the_pattern_does() {
        assert_eq!(pretokens("a photo of 2 cats!"), ["a", "photo", "of", "2", "cats", "!"]);
        assert_eq!(pretokens("it's 123"), ["it", "'s", "1", "2", "3"]);
        // a run of other characters swallows an apostrophe that does not start the run
        assert_eq!(pretokens("x?'s"), ["x", "?'", "s"]);
        // an apostrophe before no contraction is a run of its own
        assert_eq!(pretokens("'re'll'x"), ["'re", "'ll", "'", "x"]);
        assert_eq!(pretokens("<start_of_text>hi<end_of_text>"), ["<start_of_text>", "hi", "<end_of_text>"]);
        assert_eq!(pretokens("!<start_of_text>"), ["!<", "start", "_", "of", "_", "text", ">"]);
        assert_eq!(pretokens("<START_OF_TEXT>"), ["<START_OF_TEXT>"]);
        assert_eq!(pretokens("'ſ x"), ["'ſ", "x"]);
        assert_eq!(pretokens("  \t\n "), Vec::<&str>::new());
        let hf = ["<|startoftext|>", "<|endoftext|>"];
        assert_eq!(
            super::pretokens("<|startoftext|>hi<start_of_text>", &hf),
            ["<|startoftext|>", "hi", "<", "start", "_", "of", "_", "text", ">"]
        );
    }

    #[test]
    fn letters_are_the_letter_category_not_alphabetic() {
        // U+093F (Devanagari vowel sign i, Mc) is Alphabetic but not a Letter: it ends the letter run
        // and forms a run of its own; U+24B6 (circled A, So) likewise
        assert_eq!(pretokens("ह\u{93f}न"), ["ह", "\u{93f}", "न"]);
        assert_eq!(pretokens("a\u{24b6}b"), ["a", "\u{24b6}", "b"]);
        // Nl (Roman numeral twelve) and No (superscript two) are numbers, one per pre-token
        assert_eq!(pretokens("Ⅻ²½"), ["Ⅻ", "²", "½"]);
    }
}

//! CLIP's byte-level BPE tokenizer (Radford et al. 2021), read from the vocabulary file a checkpoint
//! comes with: OpenAI's and open_clip's merges file (`bpe_simple_vocab_16e6.txt.gz`, gzipped or plain),
//! or a Hugging Face `tokenizer.json` (a `BPE` model with `vocab`, `merges` as `"a b"` strings or
//! `["a", "b"]` pairs, `end_of_word_suffix` `</w>`, specials `<|startoftext|>` and `<|endoftext|>`), as
//! the hub's CLIP repositories (OpenAI's and open_clip's) hold beside the weights. The file gives the
//! ids and the merges; the text is cleaned and split as CLIP's own tokenizer does whichever file it is
//! (Hugging Face's fast tokenizer only approximates the cleaning: NFC, whitespace and lower case, no
//! ftfy fixes, so on text those fixes change, e.g. curly quotes or ligatures, its ids differ from the
//! reference's and ours).
//!
//! The format's facts, as OpenAI's and open_clip's tokenizers define them:
//! - every UTF-8 byte is a character: the printable Latin-1 bytes (`!`..`~`, `¡`..`¬`, `®`..`ÿ`) stand
//!   for themselves, the other 68 for U+0100, U+0101, ... in byte order;
//! - the vocabulary is those 256 characters, the same with `</w>` (end of word) appended, then one entry
//!   per merge line (lines 1 ..= 48,894 of the file; line 0 is a header), then `<start_of_text>` and
//!   `<end_of_text>`: 49,408 ids for OpenAI's file, SOT 49,406, EOT 49,407;
//! - text is cleaned ([`clean::clean_lower`]) and split by the pattern (see `pretokens`)
//!   `<start_of_text>|<end_of_text>|'s|'t|'re|'ve|'m|'ll|'d|\p{L}+|\p{N}|[^\s\p{L}\p{N}]+` (one digit per
//!   piece); each piece's bytes are merged pairwise, lowest-ranked merge first, all its occurrences left
//!   to right, the last character carrying `</w>`;
//! - a text becomes `[SOT] + ids + [EOT]`, cut to the context length (77) with EOT as its last id, padded
//!   with zeros.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use super::clean;
use super::pretokens::{pretokens, OPEN_CLIP_SPECIALS};
use crate::error::{ModelsError, ModelsResult};

/// Merge lines OpenAI's tokenizer reads (`49152 - 256 - 2`).
pub const MAX_MERGES: usize = 48_894;
/// The context length of every released CLIP.
pub const CONTEXT_LENGTH: usize = 77;
/// The special tokens of a Hugging Face `tokenizer.json` for CLIP.
pub const HF_SPECIALS: [&str; 2] = ["<|startoftext|>", "<|endoftext|>"];

/// A CLIP tokenizer.
#[derive(Debug, Clone)]
pub struct ClipTokenizer {
    /// Token text → id.
    ids: HashMap<String, u32>,
    /// Merge `(left, right)` → rank (lower merges first).
    ranks: HashMap<(String, String), usize>,
    /// Byte → its character.
    byte_chars: [char; 256],
    start: u32,
    end: u32,
    /// The text of the start and end tokens (the file's: [`OPEN_CLIP_SPECIALS`] or [`HF_SPECIALS`]).
    specials: [&'static str; 2],
    path: PathBuf,
}

impl ClipTokenizer {
    /// Reads a merges file (gzip by its magic bytes, else plain UTF-8 text) or a Hugging Face
    /// `tokenizer.json` (UTF-8 text starting with `{`).
    pub fn load(path: &Path) -> ModelsResult<Self> {
        let error = |reason: String| ModelsError::Tokenizer { reason, path: path.to_path_buf() };
        if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
            return Err(error(
                "not a regular file (a folder, a FIFO, a socket or a device, or a link to one)".into(),
            ));
        }
        let bytes = std::fs::read(path).map_err(|e| error(e.to_string()))?;
        let text = if bytes.starts_with(&[0x1f, 0x8b]) {
            let mut text = String::new();
            flate2::read::GzDecoder::new(bytes.as_slice())
                .read_to_string(&mut text)
                .map_err(|e| error(format!("not a gzipped UTF-8 text: {e}")))?;
            text
        } else {
            String::from_utf8(bytes).map_err(|_| error("not UTF-8 text".into()))?
        };
        if text.trim_start().starts_with('{') {
            return Self::from_tokenizer_json(&text, path);
        }
        Self::from_merges_text(&text, path)
    }

    /// Builds the tokenizer from the merges file's text (`path` is only used in messages).
    pub fn from_merges_text(text: &str, path: &Path) -> ModelsResult<Self> {
        let error = |reason: String| ModelsError::Tokenizer { reason, path: path.to_path_buf() };
        let byte_chars = byte_characters();
        let order = vocab_order(&byte_chars);
        let mut vocab: Vec<String> = order.iter().map(|c| c.to_string()).collect();
        vocab.extend(order.iter().map(|c| format!("{c}</w>")));
        let mut ranks = HashMap::new();
        // like the reference, every line of the range is an entry, the file's final empty line included
        for (index, line) in text.split('\n').skip(1).take(MAX_MERGES).enumerate() {
            let parts: Vec<&str> = line.split(clean::is_python_space).filter(|p| !p.is_empty()).collect();
            match parts.as_slice() {
                [] => vocab.push(String::new()),
                [left, right] => {
                    ranks.insert((left.to_string(), right.to_string()), index);
                    vocab.push(format!("{left}{right}"));
                }
                _ => {
                    return Err(error(format!(
                        "line {} is `{line}`, expected two symbols separated by a space",
                        index + 2
                    )))
                }
            }
        }
        if ranks.is_empty() {
            return Err(error(
                "it holds no merges (a header line, then one `left right` pair per line)".into(),
            ));
        }
        let [start, end] = OPEN_CLIP_SPECIALS;
        vocab.push(start.into());
        vocab.push(end.into());
        let mut ids = HashMap::with_capacity(vocab.len());
        for (id, token) in vocab.into_iter().enumerate() {
            // a later duplicate takes the id, as in the reference's dictionary
            ids.insert(token, id as u32);
        }
        let (start, end) = (ids[start], ids[end]);
        let specials = OPEN_CLIP_SPECIALS;
        Ok(Self { ids, ranks, byte_chars, start, end, specials, path: path.to_path_buf() })
    }

    /// Builds the tokenizer from a Hugging Face `tokenizer.json`'s text: `model.vocab` (token → id),
    /// `model.merges` (in rank order, `"left right"` or `["left", "right"]`), the specials from
    /// `added_tokens` or the vocabulary (`path` is only used in messages).
    pub fn from_tokenizer_json(text: &str, path: &Path) -> ModelsResult<Self> {
        let error = |reason: String| ModelsError::Tokenizer { reason, path: path.to_path_buf() };
        let doc: serde_json::Value = serde_json::from_str(text).map_err(|e| {
            error(format!("not a JSON tokenizer file ({e}); expected a Hugging Face tokenizer.json"))
        })?;
        let model = &doc["model"];
        if model["type"].as_str().is_some_and(|t| t != "BPE") {
            return Err(error(format!("its model is `{}`, expected CLIP's byte-level `BPE`", model["type"])));
        }
        match model["end_of_word_suffix"].as_str() {
            Some("</w>") => {}
            other => {
                return Err(error(format!(
                "its BPE model's end_of_word_suffix is {other:?}, expected \"</w>\" (not a CLIP tokenizer?)"
            )))
            }
        }
        let vocab =
            model["vocab"].as_object().ok_or_else(|| error("it has no `model.vocab` object".into()))?;
        let mut ids = HashMap::with_capacity(vocab.len() + 2);
        for (token, id) in vocab {
            let id = id.as_u64().and_then(|id| u32::try_from(id).ok()).ok_or_else(|| {
                error(format!("the id of `{token}` in `model.vocab` is {id}, expected a whole number"))
            })?;
            ids.insert(token.clone(), id);
        }
        let merges =
            model["merges"].as_array().ok_or_else(|| error("it has no `model.merges` list".into()))?;
        let mut ranks = HashMap::with_capacity(merges.len());
        for (rank, merge) in merges.iter().enumerate() {
            let pair = match merge {
                serde_json::Value::String(line) => {
                    line.split_once(' ').map(|(a, b)| (a.to_string(), b.to_string()))
                }
                serde_json::Value::Array(pair) => match pair.as_slice() {
                    [serde_json::Value::String(a), serde_json::Value::String(b)] => {
                        Some((a.clone(), b.clone()))
                    }
                    _ => None,
                },
                _ => None,
            };
            let pair = pair.filter(|(a, b)| !a.is_empty() && !b.is_empty()).ok_or_else(|| {
                error(format!("merge {rank} is {merge}, expected \"left right\" or [\"left\", \"right\"]"))
            })?;
            // a later duplicate takes the rank, as in the references' maps of ranks
            ranks.insert(pair, rank);
        }
        if ranks.is_empty() {
            return Err(error("its `model.merges` list is empty".into()));
        }
        for added in doc["added_tokens"].as_array().into_iter().flatten() {
            if let (Some(content), Some(id)) = (added["content"].as_str(), added["id"].as_u64()) {
                if HF_SPECIALS.contains(&content) {
                    ids.insert(content.to_string(), id as u32);
                }
            }
        }
        let special = |name: &str| {
            ids.get(name)
                .copied()
                .ok_or_else(|| error(format!("it has no `{name}` token (not a CLIP tokenizer?)")))
        };
        let (start, end) = (special(HF_SPECIALS[0])?, special(HF_SPECIALS[1])?);
        let byte_chars = byte_characters();
        Ok(Self { ids, ranks, byte_chars, start, end, specials: HF_SPECIALS, path: path.to_path_buf() })
    }

    /// Vocabulary size (49,408 for OpenAI's file): one more than the largest id.
    pub fn vocab_size(&self) -> usize {
        self.ids.values().map(|&id| id as usize + 1).max().unwrap_or(0)
    }

    /// The id of `<start_of_text>`.
    pub fn start_id(&self) -> u32 {
        self.start
    }

    /// The id of `<end_of_text>` (the largest id: the text tower pools at the first one).
    pub fn end_id(&self) -> u32 {
        self.end
    }

    /// BPE ids of `text` without SOT/EOT and without truncation.
    pub fn encode(&self, text: &str) -> ModelsResult<Vec<u32>> {
        let cleaned = clean::clean_lower(text);
        let mut out = Vec::new();
        for piece in pretokens(&cleaned, &self.specials) {
            if piece == self.specials[0] || piece == self.specials[1] {
                out.push(if piece == self.specials[0] { self.start } else { self.end });
                continue;
            }
            let chars: String = piece.bytes().map(|b| self.byte_chars[b as usize]).collect();
            for token in self.merge(&chars) {
                let id = self.ids.get(&token).ok_or_else(|| ModelsError::Tokenizer {
                    reason: format!("the merges make `{token}`, which has no id"),
                    path: self.path.clone(),
                })?;
                out.push(*id);
            }
        }
        Ok(out)
    }

    /// `[SOT] + encode(text) + [EOT]`, cut to `context_length` (EOT kept last) and padded with 0.
    pub fn tokenize(&self, text: &str, context_length: usize) -> ModelsResult<Vec<u32>> {
        if context_length < 2 {
            return Err(ModelsError::Input(format!(
                "a context of {context_length} tokens cannot hold SOT and EOT"
            )));
        }
        let mut ids = Vec::with_capacity(context_length);
        ids.push(self.start);
        ids.extend(self.encode(text)?);
        ids.push(self.end);
        if ids.len() > context_length {
            ids.truncate(context_length);
            ids[context_length - 1] = self.end;
        }
        ids.resize(context_length, 0);
        Ok(ids)
    }

    /// A query's ids, as [`ClipTokenizer::tokenize`] makes them, but refused rather than cut: a text
    /// without a token (empty, or only spaces) matches nothing in particular, and one whose tokens do
    /// not fit the context (with SOT and EOT) would lose its end without a word. The errors quote the
    /// text (its beginning, when long) and say what is expected; every front end (`find`, `extract`
    /// and `remove --query`, the viewer's search, `view --names`) gets them from here.
    pub fn tokenize_query(&self, text: &str, context_length: usize) -> ModelsResult<Vec<u32>> {
        let ids = self.encode(text)?;
        if ids.is_empty() {
            return Err(ModelsError::Query(format!(
                "the query {text:?} is empty or blank: give the words to look for, e.g. \"a red mug\""
            )));
        }
        let room = context_length.saturating_sub(2);
        if ids.len() > room {
            let start: String = text.chars().take(40).collect();
            return Err(ModelsError::Query(format!(
                "the query is {} tokens long, more than the {room} CLIP reads (its context of {context_length} \
                 tokens holds a start and an end token too): shorten it ({} characters, starting {start:?})",
                ids.len(),
                text.chars().count(),
            )));
        }
        self.tokenize(text, context_length)
    }

    /// The BPE tokens of one piece (its byte characters).
    fn merge(&self, piece: &str) -> Vec<String> {
        let mut word: Vec<String> = piece.chars().map(String::from).collect();
        match word.last_mut() {
            Some(last) => last.push_str("</w>"),
            None => return word,
        }
        while word.len() > 1 {
            let best = word
                .windows(2)
                .filter_map(|pair| self.ranks.get(&(pair[0].clone(), pair[1].clone())))
                .min()
                .copied();
            let Some(best) = best else { break };
            let mut merged = Vec::with_capacity(word.len());
            let mut i = 0;
            while i < word.len() {
                if i + 1 < word.len()
                    && self.ranks.get(&(word[i].clone(), word[i + 1].clone())) == Some(&best)
                {
                    merged.push(format!("{}{}", word[i], word[i + 1]));
                    i += 2;
                } else {
                    merged.push(std::mem::take(&mut word[i]));
                    i += 1;
                }
            }
            word = merged;
        }
        word
    }
}

/// The byte → character table of the format.
fn byte_characters() -> [char; 256] {
    let printable =
        |b: u32| (0x21..=0x7E).contains(&b) || (0xA1..=0xAC).contains(&b) || (0xAE..=0xFF).contains(&b);
    let mut table = ['\0'; 256];
    let mut extra = 0;
    for (b, slot) in table.iter_mut().enumerate() {
        let b = b as u32;
        let code = if printable(b) {
            b
        } else {
            extra += 1;
            255 + extra
        };
        *slot = char::from_u32(code).unwrap_or('\u{fffd}');
    }
    table
}

/// The vocabulary's first 256 entries are the byte characters in this order: printable bytes in byte
/// order first, then the others; [`byte_characters`] is indexed by byte, so reorder for the ids.
fn vocab_order(table: &[char; 256]) -> Vec<char> {
    let mut chars: Vec<char> = table.to_vec();
    chars.sort_by_key(|&c| if (c as u32) < 256 { (0, c as u32) } else { (1, c as u32) });
    chars
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_table_is_a_bijection_in_the_reference_order() {
        let table = byte_characters();
        assert_eq!(table[b'a' as usize], 'a');
        assert_eq!(table[0], '\u{100}');
        assert_eq!(table[b' ' as usize], '\u{120}');
        let mut seen: Vec<char> = table.to_vec();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 256);
        let order = vocab_order(&table);
        assert_eq!((order[0], order[93], order[188]), ('!', '~', '\u{100}'));
    }
}

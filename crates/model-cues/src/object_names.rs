//! Objects named from a list the user gives (`splatseg view --names FILE`, issue 30): each object of a
//! run with CLIP embeddings (`run --clip`) gets the name it is most relevant to, every name scored as
//! `splatseg find` scores a query (LERF's relevancy against the canonical phrases,
//! [`splatseg_models::clip::relevancy::best_names`]).
//!
//! The list is a text file, one name (a noun or a short phrase) per line; `#` starts a comment (to the
//! end of the line), blank lines are skipped, a name given twice counts once.

use crate::clip_objects::ObjectSearch;
use crate::{Context, ModelCuesError};
use serde::Serialize;
use splatseg_models::clip::relevancy::{best_names, Embeddings, LERF_SCALE};
use std::path::Path;

/// Names embedded per call of the text tower.
pub const NAMES_PER_BATCH: usize = 16;

/// One object and its best name.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectName {
    /// The object's id.
    pub id: u32,
    /// The name it is most relevant to (the first of the list on a tie).
    pub name: String,
    /// Its relevancy to that name, in (0, 1): above 0.5, closer to it than to every generic phrase.
    pub relevancy: f32,
}

/// The names of a list's text, in order: `#` comments and blank lines left out, each line trimmed,
/// repeats dropped.
pub fn parse_names(text: &str) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for line in text.lines() {
        let name = line.split('#').next().unwrap_or("").trim();
        if !name.is_empty() && !names.iter().any(|n| n == name) {
            names.push(name.to_string());
        }
    }
    names
}

/// Reads a names file (see the module docs); an unreadable file, one that is not UTF-8 text or one
/// holding no name is an error naming it.
pub fn read_names(path: &Path) -> crate::Result<Vec<String>> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("cannot read the names file (--names) {}", path.display()))?;
    let text = String::from_utf8(bytes).map_err(|_| {
        ModelCuesError::Invalid(format!(
            "the names file (--names) is not UTF-8 text (one name per line): {}",
            path.display()
        ))
    })?;
    let names = parse_names(&text);
    if names.is_empty() {
        return Err(ModelCuesError::Invalid(format!(
            "the names file (--names) holds no name (one name per line; `#` starts a comment): {}",
            path.display()
        )));
    }
    Ok(names)
}

impl ObjectSearch {
    /// Every embedded object with the name of `names` (at least one) it is most relevant to, by id.
    pub fn name_objects(&self, names: &[String]) -> crate::Result<Vec<ObjectName>> {
        if names.is_empty() {
            return Err(ModelCuesError::Invalid("no names to give the objects".into()));
        }
        let mut text = Vec::with_capacity(names.len() * self.index().dim);
        for batch in names.chunks(NAMES_PER_BATCH) {
            let batch: Vec<&str> = batch.iter().map(String::as_str).collect();
            text.extend(self.embed_texts(&batch)?);
        }
        let dim = self.index().dim;
        let (ids, embeddings) = self.embedded();
        let named = best_names(
            &ids,
            Embeddings::new(embeddings, dim, "object embeddings")?,
            Embeddings::new(&text, dim, "names")?,
            Embeddings::new(self.negatives(), dim, "canonical phrases")?,
            LERF_SCALE,
        )?;
        Ok(named
            .into_iter()
            .map(|n| ObjectName { id: n.id, name: names[n.name].clone(), relevancy: n.relevancy })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_skip_comments_blank_lines_and_repeats() {
        let text = "# furniture\nchair\n\n  table  # the dining one\nchair\n#lamp\r\na red mug\r\n   \n";
        assert_eq!(parse_names(text), vec!["chair", "table", "a red mug"]);
        assert!(parse_names("# only comments\n\n").is_empty());
    }

    #[test]
    fn an_unreadable_or_empty_names_file_is_an_error_naming_it() {
        let dir = std::env::temp_dir().join(format!("splatseg-names-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("no-such-names.txt");
        let err = read_names(&missing).unwrap_err().report();
        assert!(err.contains("no-such-names.txt") && err.contains("--names"), "{err}");
        let empty = dir.join("empty-names.txt");
        std::fs::write(&empty, "# nothing but a comment\n\n").unwrap();
        let err = read_names(&empty).unwrap_err().report();
        assert!(err.contains("empty-names.txt") && err.contains("holds no name"), "{err}");
        let binary = dir.join("binary-names.txt");
        std::fs::write(&binary, [0xff, 0xfe, b'\n']).unwrap();
        let err = read_names(&binary).unwrap_err().report();
        assert!(err.contains("binary-names.txt") && err.contains("UTF-8"), "{err}");
        let good = dir.join("names.txt");
        std::fs::write(&good, "mug\nchair\n").unwrap();
        assert_eq!(read_names(&good).unwrap(), vec!["mug", "chair"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

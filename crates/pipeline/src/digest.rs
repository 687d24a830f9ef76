//! Checksums of a folder of outputs, one per file, to tell whether two runs wrote the same bytes
//! (the golden-output tests pin the demo's and the reduced suite's outputs with them, so a change
//! meant to change no result proves it).

use crate::cache::KeyHasher;
use crate::error::Context;
use std::path::Path;

/// Every file under `dir` (recursively, sorted by relative path, `/`-separated) with the
/// [`KeyHasher`] digest of its bytes, skipping the paths `skip` accepts (relative paths). In
/// files ending in `.md` or `.json`, the text `dir` itself is replaced by `OUT` first, so a run
/// written to another folder gives the same digests.
pub fn folder_digests(dir: &Path, skip: impl Fn(&str) -> bool) -> crate::Result<Vec<(String, String)>> {
    let mut files = Vec::new();
    collect(dir, dir, &mut files)?;
    files.sort();
    let alias = dir.to_string_lossy().into_owned();
    let mut out = Vec::new();
    for rel in files {
        if skip(&rel) {
            continue;
        }
        let path = dir.join(&rel);
        let bytes = std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let digest = if rel.ends_with(".md") || rel.ends_with(".json") {
            let text = String::from_utf8_lossy(&bytes).replace(&alias, "OUT");
            KeyHasher::default().text(&text).finish()
        } else {
            KeyHasher::default().bytes(&bytes).finish()
        };
        out.push((rel, digest));
    }
    Ok(out)
}

/// The digest of a file's bytes, read in pieces of 1 MiB (a PLY of gigabytes is not held in memory):
/// what an output that belongs to a run records of the file it was made from (`run --clip`'s object
/// index of `gaussians.ply`).
pub fn file_digest(path: &Path) -> crate::Result<String> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut hasher = KeyHasher::default();
    let mut piece = vec![0u8; 1 << 20];
    loop {
        let mut filled = 0;
        while filled < piece.len() {
            match file.read(&mut piece[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
            }
        }
        if filled == 0 {
            break;
        }
        hasher.bytes(&piece[..filled]);
    }
    Ok(hasher.finish())
}

/// The digest of a text (what a command printed, say).
pub fn text_digest(text: &str) -> String {
    KeyHasher::default().text(text).finish()
}

/// Compares digests with the golden file `golden` (lines `digest  path`): `Ok` when they are
/// equal, else a message naming every path whose digest differs, is new or is missing. With
/// `update`, writes the digests to `golden` instead (how a change that is meant to change the
/// outputs records them: say so in its commit).
pub fn compare_with_golden(digests: &[(String, String)], golden: &Path, update: bool) -> Result<(), String> {
    let text: String = digests.iter().map(|(path, digest)| format!("{digest}  {path}\n")).collect();
    if update {
        return std::fs::write(golden, text).map_err(|e| format!("cannot write {}: {e}", golden.display()));
    }
    let want =
        std::fs::read_to_string(golden).map_err(|e| format!("cannot read {}: {e}", golden.display()))?;
    let parse = |t: &str| -> std::collections::BTreeMap<String, String> {
        t.lines().filter_map(|l| l.split_once("  ")).map(|(d, p)| (p.to_string(), d.to_string())).collect()
    };
    let (want, got) = (parse(&want), parse(&text));
    let mut problems = Vec::new();
    for (path, digest) in &got {
        match want.get(path) {
            None => problems.push(format!("new file {path}")),
            Some(d) if d != digest => problems.push(format!("{path}: {digest}, golden {d}")),
            Some(_) => {}
        }
    }
    problems.extend(want.keys().filter(|p| !got.contains_key(*p)).map(|p| format!("missing {p}")));
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!("{} outputs differ from {}:\n{}", problems.len(), golden.display(), problems.join("\n")))
    }
}

fn collect(root: &Path, dir: &Path, files: &mut Vec<String>) -> crate::Result<()> {
    let entries = std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))?;
    for entry in entries {
        let path = entry.with_context(|| format!("cannot list {}", dir.display()))?.path();
        if path.is_dir() {
            collect(root, &path, files)?;
        } else if let Ok(rel) = path.strip_prefix(root) {
            let parts: Vec<_> =
                rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
            files.push(parts.join("/"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digests_follow_bytes_and_ignore_the_folders_name() {
        let a = tempfile::tempdir().expect("temp dir");
        let b = tempfile::tempdir().expect("temp dir");
        for (root, byte) in [(a.path(), 1u8), (b.path(), 1u8)] {
            std::fs::create_dir_all(root.join("masks")).expect("mkdir");
            std::fs::write(root.join("masks/v.png"), [0, byte]).expect("write");
            std::fs::write(root.join("report.md"), format!("out: {}", root.display())).expect("write");
            std::fs::write(root.join("skip.me"), root.to_string_lossy().as_bytes()).expect("write");
        }
        let skip = |rel: &str| rel == "skip.me";
        let da = folder_digests(a.path(), skip).expect("digests");
        assert_eq!(da.iter().map(|(p, _)| p.as_str()).collect::<Vec<_>>(), ["masks/v.png", "report.md"]);
        assert_eq!(da, folder_digests(b.path(), skip).expect("digests"));
        let golden = a.path().join("golden.txt");
        compare_with_golden(&da, &golden, true).expect("written");
        compare_with_golden(&da, &golden, false).expect("equal");
        std::fs::write(b.path().join("masks/v.png"), [0, 2]).expect("write");
        let db = folder_digests(b.path(), skip).expect("digests");
        assert_ne!(da, db);
        let err = compare_with_golden(&db, &golden, false).expect_err("differs");
        assert!(err.contains("masks/v.png"), "{err}");
        let err = compare_with_golden(&db[1..], &golden, false).expect_err("one missing");
        assert!(err.contains("missing masks/v.png"), "{err}");
    }
}

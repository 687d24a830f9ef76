//! No input is ever overwritten: the one check every command makes on its paths before it reads
//! anything ([`refuse_overwrite`]).
//!
//! Each command declares what it reads and what it writes, and how:
//! - an input is a [`Kind::File`], a [`Kind::Folder`] whose named parts are read (a scene folder),
//!   or a [`Kind::Tree`], a folder whose every file may be read (masks, features, depth, ground
//!   truth, label maps);
//! - an output is a [`Kind::File`], a [`Kind::Folder`] the command creates and writes named parts
//!   into (`run`'s OUT), or a [`Kind::Tree`], a folder whose contents it writes (OUT/masks).
//!
//! Refused: an output equal to an input; an input inside an output tree; an output inside an input
//! tree. Paths are compared after resolving them: an existing path is canonicalized (symlinks,
//! `./x`, `x/../x`), one that does not exist yet is its nearest existing ancestor canonicalized
//! followed by the rest, normalised.

use crate::error::{SceneError, SceneResult};
use std::path::{Component, Path, PathBuf};

/// How a path is read or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// One file.
    File,
    /// A folder of which only named parts are read or written.
    Folder,
    /// A folder whose every file may be read, or into which files are written.
    Tree,
}

/// One path a command reads or writes, with what it is for the message (e.g. "--masks").
#[derive(Clone, Debug)]
pub struct Role {
    /// The path as the user gave it (named in the message).
    pub path: PathBuf,
    /// What it is, e.g. "--masks" or "the input PLY".
    pub what: String,
    /// How it is read or written.
    pub kind: Kind,
}

impl Role {
    /// A file.
    pub fn file(what: impl Into<String>, path: impl Into<PathBuf>) -> Role {
        Role { path: path.into(), what: what.into(), kind: Kind::File }
    }

    /// A folder of which only named parts are read or written.
    pub fn folder(what: impl Into<String>, path: impl Into<PathBuf>) -> Role {
        Role { path: path.into(), what: what.into(), kind: Kind::Folder }
    }

    /// A folder whose every file is read, or into which files are written.
    pub fn tree(what: impl Into<String>, path: impl Into<PathBuf>) -> Role {
        Role { path: path.into(), what: what.into(), kind: Kind::Tree }
    }
}

/// An output that would overwrite an input: the message of [`SceneError::Overwrite`].
#[derive(Debug)]
pub struct Clash {
    /// The output, as given.
    pub output: Role,
    /// "is", "contains" or "is inside".
    pub how: &'static str,
    /// The input, as given.
    pub input: Role,
}

impl std::fmt::Display for Clash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "refusing to overwrite an input: {} {} {} {} {}; choose another output path",
            self.output.what,
            self.output.path.display(),
            self.how,
            self.input.what,
            self.input.path.display()
        )
    }
}

/// Refuses (with [`SceneError::Overwrite`], naming both paths) any output equal to an input, any
/// input inside an output tree and any output inside an input tree. Reads no file.
pub fn refuse_overwrite(inputs: &[Role], outputs: &[Role]) -> SceneResult<()> {
    let resolve_all =
        |roles: &[Role]| -> SceneResult<Vec<PathBuf>> { roles.iter().map(|r| resolve(&r.path)).collect() };
    let (ins, outs) = (resolve_all(inputs)?, resolve_all(outputs)?);
    for (output, out_path) in outputs.iter().zip(&outs) {
        for (input, in_path) in inputs.iter().zip(&ins) {
            let how = if in_path == out_path {
                Some("is")
            } else if output.kind == Kind::Tree && in_path.starts_with(out_path) {
                Some("contains")
            } else if input.kind == Kind::Tree && out_path.starts_with(in_path) {
                Some("is inside")
            } else {
                None
            };
            if let Some(how) = how {
                return Err(SceneError::Overwrite(Box::new(Clash {
                    output: output.clone(),
                    how,
                    input: input.clone(),
                })));
            }
        }
    }
    Ok(())
}

/// `path` made absolute and resolved: canonicalized when it exists, otherwise its nearest existing
/// ancestor canonicalized and the rest appended with `.` and `..` applied.
pub fn resolve(path: &Path) -> SceneResult<PathBuf> {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map_err(|e| SceneError::io("cannot read the current folder", ".", e))?
            .join(path)
    };
    let mut existing = absolute.as_path();
    let mut rest = Vec::new();
    loop {
        match existing.canonicalize() {
            Ok(base) => {
                let mut resolved = base;
                for part in rest.iter().rev() {
                    match part {
                        Component::ParentDir => {
                            resolved.pop();
                        }
                        Component::CurDir => {}
                        other => resolved.push(other.as_os_str()),
                    }
                }
                return Ok(resolved);
            }
            Err(_) => match (existing.parent(), existing.components().next_back()) {
                (Some(parent), Some(last)) => {
                    rest.push(last);
                    existing = parent;
                }
                _ => return Ok(absolute),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir() -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(d.path().join("scene/masks")).unwrap();
        std::fs::write(d.path().join("scene/g.ply"), b"x").unwrap();
        d
    }

    #[test]
    fn same_file_by_another_spelling_is_refused() {
        let tmp = dir();
        let d = tmp.path();
        let input = [Role::file("the input PLY", d.join("scene/g.ply"))];
        let err =
            refuse_overwrite(&input, &[Role::file("--out", d.join("scene/masks/../g.ply"))]).unwrap_err();
        assert!(err.to_string().contains("g.ply"), "{err}");
        assert!(refuse_overwrite(&input, &[Role::file("--out", d.join("scene/./g.ply"))]).is_err());
        assert!(refuse_overwrite(&input, &[Role::file("--out", d.join("scene/h.ply"))]).is_ok());
    }

    #[test]
    fn trees_refuse_what_is_inside() {
        let tmp = dir();
        let d = tmp.path();
        let masks = [Role::tree("--masks", d.join("scene/masks"))];
        assert!(refuse_overwrite(&masks, &[Role::folder("--out", d.join("scene/masks/new/out"))]).is_err());
        assert!(refuse_overwrite(&masks, &[Role::tree("OUT/masks", d.join("scene"))]).is_err());
        assert!(refuse_overwrite(&masks, &[Role::folder("--out", d.join("scene"))]).is_ok());
        let scene = [Role::folder("SCENE", d.join("scene"))];
        assert!(refuse_overwrite(&scene, &[Role::folder("--out", d.join("scene/out"))]).is_ok());
        assert!(refuse_overwrite(&scene, &[Role::folder("--out", d.join("scene/out/.."))]).is_err());
    }
}

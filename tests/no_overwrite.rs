//! Issue 28, point 1: no input is ever overwritten. Every command whose output path is (or holds, or
//! lies inside) one of its inputs is refused before it reads anything: non-zero exit, the paths
//! named in the message, and not one byte of the folder changed. The same commands with a sibling
//! output still work.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the binary in `dir` (the rows use relative paths, spelled several ways).
fn splatseg(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_splatseg")).current_dir(dir).args(args).output().expect("splatseg runs")
}

/// Every file (with its bytes) and folder under `root`.
fn snapshot(root: &Path) -> BTreeMap<PathBuf, Option<Vec<u8>>> {
    let mut all = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("readable folder") {
            let path = entry.expect("entry").path();
            let meta = std::fs::symlink_metadata(&path).expect("metadata");
            if meta.is_dir() {
                stack.push(path.clone());
                all.insert(path, None);
            } else if meta.is_file() {
                all.insert(path.clone(), Some(std::fs::read(&path).expect("readable file")));
            } else {
                all.insert(path, None);
            }
        }
    }
    all
}

/// What differs between two snapshots, for the failure message.
fn differences(
    before: &BTreeMap<PathBuf, Option<Vec<u8>>>,
    after: &BTreeMap<PathBuf, Option<Vec<u8>>>,
) -> Vec<String> {
    let mut diffs = Vec::new();
    for (path, bytes) in before {
        match after.get(path) {
            None => diffs.push(format!("removed {}", path.display())),
            Some(b) if b != bytes => diffs.push(format!("changed {}", path.display())),
            Some(_) => {}
        }
    }
    diffs.extend(after.keys().filter(|p| !before.contains_key(*p)).map(|p| format!("added {}", p.display())));
    diffs
}

/// A synthetic capture in `scene/` and a finished run on it in `run/` (labelled PLY, label maps).
fn fixture() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().expect("temp dir");
    let ok = |args: &[&str]| {
        let out = splatseg(tmp.path(), args);
        assert!(out.status.success(), "{args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    };
    ok(&["synth", "--out", "scene", "--views", "3", "--size", "64x48", "-q"]);
    ok(&["run", "scene", "--masks", "scene/sam", "--out", "run", "-q"]);
    std::fs::write(tmp.path().join("settings.toml"), "").expect("write settings");
    std::fs::create_dir_all(tmp.path().join("x/masks")).expect("create x/masks");
    std::fs::write(tmp.path().join("x/masks/s.toml"), "").expect("write settings");
    std::fs::write(tmp.path().join("scene/gt/synth.toml"), "views = 2").expect("write settings");
    #[cfg(unix)]
    std::os::unix::fs::symlink("run", tmp.path().join("run_link")).expect("symlink");
    tmp
}

/// One refused command line and the path its message must name (besides "refusing to overwrite").
struct Refused {
    args: &'static [&'static str],
    names: &'static str,
}

const REFUSED: &[Refused] = &[
    // Data loss on the code before the check: the input is replaced and the command exits 0.
    Refused {
        args: &["extract", "run/gaussians.ply", "--ids", "1", "--out", "run/gaussians.ply"],
        names: "--out run/gaussians.ply is the input PLY run/gaussians.ply",
    },
    Refused {
        args: &["remove", "run/gaussians.ply", "--ids", "1", "--out", "./run/gaussians.ply"],
        names: "./run/gaussians.ply",
    },
    Refused {
        args: &["recolor", "run/gaussians.ply", "--out", "run/masks/../gaussians.ply"],
        names: "run/masks/../gaussians.ply",
    },
    Refused {
        args: &["extract", "run_link/gaussians.ply", "--ids", "1", "--out", "run/gaussians.ply"],
        names: "run_link/gaussians.ply",
    },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--out", "scene"],
        names: "--out scene is SCENE scene",
    },
    Refused { args: &["run", "scene", "--masks", "scene/sam", "--out", "scene/."], names: "scene/." },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--gaussians", "run/gaussians.ply", "--out", "run"],
        names: "run/gaussians.ply",
    },
    Refused {
        args: &["train", "scene", "--gaussians", "run/gaussians.ply", "--out", "run", "--iterations", "1"],
        names: "the label maps beside --gaussians run/masks",
    },
    // Outputs written into (or over) an input folder.
    Refused {
        args: &["run", "scene", "--masks", "run/masks", "--out", "run"],
        names: "--out's masks/ run/masks is --masks run/masks",
    },
    Refused {
        args: &[
            "run",
            "scene",
            "--masks",
            "scene/sam",
            "--features",
            "scene/features",
            "--out",
            "scene/features",
        ],
        names: "--out scene/features is --features scene/features",
    },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--depth", "scene/depth", "--out", "scene/depth/out"],
        names: "is inside --depth scene/depth",
    },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--out", "scene/sam/out"],
        names: "is inside --masks scene/sam",
    },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--gt", "scene/gt", "--out", "scene/gt/instance/new"],
        names: "is inside --gt scene/gt",
    },
    Refused {
        args: &[
            "run",
            "scene",
            "--masks",
            "scene/sam",
            "--config",
            "settings.toml",
            "--out",
            "settings.toml",
        ],
        names: "--out settings.toml is --config settings.toml",
    },
    Refused {
        args: &["run", "scene", "--masks", "scene/sam", "--config", "x/masks/s.toml", "--out", "x"],
        names: "contains --config x/masks/s.toml",
    },
    Refused {
        args: &["merge", "scene", "--masks", "scene/sam", "--out", "scene/sam"],
        names: "--out scene/sam is --masks scene/sam",
    },
    Refused {
        args: &["merge", "scene", "--masks", "scene/sam", "--out", "scene"],
        names: "--out scene is SCENE scene",
    },
    Refused {
        args: &[
            "train",
            "scene",
            "--gaussians",
            "scene/gaussians.ply",
            "--out",
            "scene",
            "--iterations",
            "1",
        ],
        names: "--out scene is SCENE scene",
    },
    Refused {
        args: &[
            "train",
            "scene",
            "--gaussians",
            "run/gaussians.ply",
            "--label-maps",
            "run/masks",
            "--out",
            "run/masks/t",
            "--iterations",
            "1",
        ],
        names: "is inside --label-maps run/masks",
    },
    Refused {
        args: &["render", "scene", "--gaussians", "scene/gaussians.ply", "--out", "scene"],
        names: "--out scene is SCENE scene",
    },
    Refused {
        args: &["render", "scene", "--gaussians", "run/gaussians.ply", "--out", "run"],
        names: "--out run contains --gaussians run/gaussians.ply",
    },
    Refused { args: &["cues", "scene", "--out", "scene"], names: "--out scene is SCENE scene" },
    Refused {
        args: &["eval", "--gt", "scene/gt/instance", "--pred", "run/masks", "--write", "run/masks/m.json"],
        names: "--write run/masks/m.json is inside --pred run/masks",
    },
    Refused {
        args: &[
            "eval",
            "--gt",
            "scene/gt/instance",
            "--pred",
            "lifted=run/masks",
            "--write",
            "scene/gt/instance/m.md",
        ],
        names: "is inside --gt scene/gt/instance",
    },
    Refused {
        args: &["synth", "--config", "scene/gt/synth.toml", "--out", "scene"],
        names: "--out's gt/ scene/gt contains --config scene/gt/synth.toml",
    },
    Refused {
        args: &["bench", "quality", "--seeds", "0", "--config", "q/quality.md", "--out", "q"],
        names: "--out's quality.md q/quality.md is --config q/quality.md",
    },
];

#[test]
fn an_output_on_an_input_is_refused_before_anything_is_read_or_written() {
    let mut tmp = fixture();
    let mut before = snapshot(tmp.path());
    let mut failures = Vec::new();
    for row in REFUSED {
        let out = splatseg(tmp.path(), row.args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let changed = differences(&before, &snapshot(tmp.path()));
        if out.status.success()
            || !stderr.contains("refusing to overwrite an input")
            || !stderr.contains(row.names)
        {
            failures.push(format!(
                "{:?}: exit {:?}, expected a refusal naming {:?}; stderr: {}",
                row.args,
                out.status.code(),
                row.names,
                stderr.trim()
            ));
        }
        if !changed.is_empty() {
            failures.push(format!("{:?} changed the folder: {}", row.args, changed.join(", ")));
            // The next rows start from the same bytes.
            tmp = fixture();
            before = snapshot(tmp.path());
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} rows wrong:\n{}",
        failures.len(),
        REFUSED.len(),
        failures.join("\n")
    );
}

#[test]
fn outputs_beside_the_inputs_still_work() {
    let tmp = fixture();
    let before = snapshot(tmp.path());
    let rows: &[&[&str]] = &[
        &["extract", "run/gaussians.ply", "--ids", "1", "--out", "out/one.ply"],
        &["remove", "run_link/gaussians.ply", "--ids", "1", "--out", "out/without_one.ply"],
        &["recolor", "run/gaussians.ply", "--out", "out/painted.ply"],
        &["render", "scene", "--gaussians", "run/gaussians.ply", "--out", "out/renders", "--what", "rgb"],
        &["eval", "--gt", "scene/gt/instance", "--pred", "run/masks", "--write", "out/metrics.json"],
        &["merge", "scene", "--masks", "scene/sam", "--out", "out/merged", "-q"],
    ];
    for args in rows {
        let out = splatseg(tmp.path(), args);
        assert!(out.status.success(), "{args:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    let written: Vec<String> = differences(&before, &snapshot(tmp.path()))
        .into_iter()
        .filter(|d| !d.starts_with(&format!("added {}", tmp.path().join("out").display())))
        .collect();
    assert!(written.is_empty(), "the inputs changed: {}", written.join(", "));
    // A run's OUT may be a new folder inside its scene folder (only named parts of SCENE are read).
    let inside =
        splatseg(tmp.path(), &["run", "scene", "--masks", "scene/sam", "--out", "scene/result", "-q"]);
    assert!(
        inside.status.success(),
        "run --out scene/result failed: {}",
        String::from_utf8_lossy(&inside.stderr)
    );
    assert_eq!(
        std::fs::read(tmp.path().join("scene/result/gaussians.ply")).expect("labelled PLY").len(),
        std::fs::read(tmp.path().join("run/gaussians.ply")).expect("labelled PLY").len()
    );
}

//! Agreement with COLMAP itself: the fixture model as COLMAP's own writers wrote it (pycolmap
//! 4.2.1, `tools/fixtures/colmap_pycolmap.py`) reads to the same model, and our binary writer
//! reproduces COLMAP's files byte for byte.

use crate::colmap_fixture::write_text_model;
use splatseg_scene::colmap::{read_model_binary, read_model_text, write_model_binary, ColmapModel};
use std::path::PathBuf;

fn reference(kind: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/colmap_pycolmap")).join(kind)
}

/// The model with every list sorted by id, so COLMAP's map order does not matter.
fn sorted(mut m: ColmapModel) -> ColmapModel {
    m.cameras.sort_by_key(|c| c.id);
    m.images.sort_by_key(|i| i.id);
    m.points.sort_by_key(|p| p.id);
    m
}

fn fixture_model() -> ColmapModel {
    let dir = tempfile::tempdir().expect("tempdir");
    write_text_model(dir.path());
    read_model_text(dir.path()).expect("fixture parses")
}

#[test]
fn colmaps_binary_and_text_output_read_to_the_fixture_model() {
    let ours = sorted(fixture_model());
    let colmap_bin = read_model_binary(&reference("bin")).expect("COLMAP binary reads");
    assert_eq!(sorted(colmap_bin), ours);
    // COLMAP's text has 17 significant digits and a trailing space after each POINTS2D line.
    let colmap_txt = read_model_text(&reference("txt")).expect("COLMAP text reads");
    assert_eq!(sorted(colmap_txt), ours);
}

#[test]
fn our_binary_writer_reproduces_colmaps_bytes() {
    let colmap_model = read_model_binary(&reference("bin")).expect("COLMAP binary reads");
    let out = tempfile::tempdir().expect("tempdir");
    write_model_binary(out.path(), &colmap_model).expect("write");
    for name in ["cameras.bin", "images.bin", "points3D.bin"] {
        let ours = std::fs::read(out.path().join(name)).expect("ours");
        let theirs = std::fs::read(reference("bin").join(name)).expect("COLMAP's");
        assert_eq!(ours, theirs, "{name} differs from COLMAP's");
    }
}

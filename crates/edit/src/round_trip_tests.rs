//! Extract / remove through real PLY files: what comes back is bit-for-bit the selected subset.

use crate::io::{read_labelled_ply, write_edited_ply};
use crate::{extract, remove, EditError, ExtraFields};
use rand::{Rng, SeedableRng};
use splatseg_scene::gaussians::{ExtraProperty, FeatureBlock};
use splatseg_scene::Gaussians;

/// `n` random degree-3 Gaussians with ids in 1..=5 (and some −1), features and an extra
/// property, including awkward floats (negative zero, subnormals, large magnitudes).
fn random_scene(n: usize, seed: u64) -> Gaussians {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut f = move || -> f32 {
        match rng.gen_range(0..20) {
            0 => -0.0,
            1 => f32::from_bits(rng.gen_range(1..0x007f_ffff)), // subnormal
            2 => rng.gen_range(-1e30..1e30),
            _ => rng.gen_range(-3.0..3.0),
        }
    };
    let mut v3 = || [f(), f(), f()];
    let means: Vec<[f32; 3]> = (0..n).map(|_| v3()).collect();
    let normals: Vec<[f32; 3]> = (0..n).map(|_| v3()).collect();
    let sh_dc: Vec<[f32; 3]> = (0..n).map(|_| v3()).collect();
    let log_scales: Vec<[f32; 3]> = (0..n).map(|_| v3()).collect();
    let sh_rest: Vec<f32> = (0..n * 45).map(|_| f()).collect();
    let raw_opacities: Vec<f32> = (0..n).map(|_| f()).collect();
    let rotations: Vec<[f32; 4]> = (0..n).map(|_| [f(), f(), f(), f()]).collect();
    let features = FeatureBlock { dim: 4, values: (0..n * 4).map(|_| f()).collect() };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 1);
    let object_ids: Vec<i32> =
        (0..n).map(|_| if rng.gen_bool(0.1) { -1 } else { rng.gen_range(1..=5) }).collect();
    let extra = vec![ExtraProperty {
        name: "confidence".into(),
        ply_type: "float".into(),
        values: (0..n).map(|i| (i as f32 * 0.5) as f64).collect(),
    }];
    Gaussians {
        means,
        normals: Some(normals),
        sh_dc,
        sh_degree: 3,
        sh_rest,
        raw_opacities,
        log_scales,
        rotations,
        object_ids: Some(object_ids),
        features: Some(features),
        extra,
    }
}

fn bits3(v: &[[f32; 3]]) -> Vec<[u32; 3]> {
    v.iter().map(|a| a.map(f32::to_bits)).collect()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Compares every array bit for bit (`PartialEq` on floats would miss −0.0 vs 0.0).
fn assert_bit_identical(a: &Gaussians, b: &Gaussians) {
    assert_eq!(a.len(), b.len(), "Gaussian count");
    assert_eq!(bits3(&a.means), bits3(&b.means), "means");
    assert_eq!(a.normals.as_deref().map(bits3), b.normals.as_deref().map(bits3), "normals");
    assert_eq!(bits3(&a.sh_dc), bits3(&b.sh_dc), "f_dc");
    assert_eq!(a.sh_degree, b.sh_degree, "SH degree");
    assert_eq!(bits(&a.sh_rest), bits(&b.sh_rest), "f_rest");
    assert_eq!(bits(&a.raw_opacities), bits(&b.raw_opacities), "opacity");
    assert_eq!(bits3(&a.log_scales), bits3(&b.log_scales), "scales");
    let rot = |g: &Gaussians| g.rotations.iter().map(|r| r.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(rot(a), rot(b), "rotations");
    assert_eq!(a.object_ids, b.object_ids, "object ids");
    let feat = |g: &Gaussians| g.features.as_ref().map(|f| (f.dim, bits(&f.values)));
    assert_eq!(feat(a), feat(b), "features");
    assert_eq!(a.extra.len(), b.extra.len(), "extras");
    for (x, y) in a.extra.iter().zip(&b.extra) {
        assert_eq!((&x.name, &x.ply_type), (&y.name, &y.ply_type));
        let b64 = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(b64(&x.values), b64(&y.values), "extra {}", x.name);
    }
}

fn indices_of(g: &Gaussians, keep: impl Fn(i32) -> bool) -> Vec<usize> {
    g.object_ids.as_ref().unwrap().iter().enumerate().filter(|(_, id)| keep(**id)).map(|(i, _)| i).collect()
}

#[test]
fn extracted_object_rereads_with_exactly_its_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let input_path = dir.path().join("gaussians.ply");
    let scene = random_scene(500, 1);
    splatseg_scene::ply::write_ply(&input_path, &scene).unwrap();
    let input = read_labelled_ply(&input_path).unwrap();
    assert_bit_identical(&input, &scene);

    // Keep extras: the subset must come back with every property.
    let out_path = dir.path().join("object_3_5.ply");
    write_edited_ply(&out_path, extract(&input, &[3, 5]).unwrap(), ExtraFields::Keep).unwrap();
    let back = splatseg_scene::ply::read_ply(&out_path).unwrap();
    let expected = input.select(&indices_of(&input, |id| id == 3 || id == 5));
    assert!(!expected.is_empty());
    assert_bit_identical(&back, &expected);

    // Default: stripped to the INRIA layout, the Gaussian data otherwise identical.
    let stripped_path = dir.path().join("object_3_stripped.ply");
    write_edited_ply(&stripped_path, extract(&input, &[3]).unwrap(), ExtraFields::default()).unwrap();
    let back = splatseg_scene::ply::read_ply(&stripped_path).unwrap();
    let mut expected = input.select(&indices_of(&input, |id| id == 3));
    (expected.object_ids, expected.features) = (None, None);
    expected.extra.clear();
    assert_bit_identical(&back, &expected);
    let header = std::fs::read(&stripped_path).unwrap();
    let header =
        String::from_utf8_lossy(&header[..header.windows(10).position(|w| w == b"end_header").unwrap()]);
    assert!(!header.contains("object_id") && !header.contains("feat_") && !header.contains("confidence"));
}

#[test]
fn removal_leaves_the_rest_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let input_path = dir.path().join("gaussians.ply");
    let scene = random_scene(400, 2);
    splatseg_scene::ply::write_ply(&input_path, &scene).unwrap();
    let input = read_labelled_ply(&input_path).unwrap();
    let out_path = dir.path().join("without_2.ply");
    write_edited_ply(&out_path, remove(&input, &[2, -1]).unwrap(), ExtraFields::Keep).unwrap();
    let back = splatseg_scene::ply::read_ply(&out_path).unwrap();
    assert_bit_identical(&back, &input.select(&indices_of(&input, |id| id != 2 && id != -1)));
}

#[test]
fn unlabelled_ply_and_unknown_ids_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plain.ply");
    let mut scene = random_scene(10, 3);
    scene.object_ids = None;
    splatseg_scene::ply::write_ply(&path, &scene).unwrap();
    let err = read_labelled_ply(&path).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, EditError::NoObjectIds { .. }));
    assert!(msg.contains("splatseg run") && msg.ends_with("plain.ply"), "{msg}");

    let labelled = random_scene(50, 4);
    let err = extract(&labelled, &[42]).unwrap_err();
    assert!(
        err.to_string().contains("no Gaussian has object id 42; ids present: -1, 1, 2, 3, 4, 5"),
        "{err}"
    );
}

#[test]
fn an_spz_or_splat_out_path_writes_that_format_without_ids() {
    let dir = tempfile::tempdir().unwrap();
    let scene = crate::testing::labelled_gaussians(&[1, 1, 2, 2, -1]);
    let picked = extract(&scene, &[2]).unwrap();
    for name in ["object.spz", "object.splat", "object.ksplat", "object.compressed.ply"] {
        let path = dir.path().join(name);
        write_edited_ply(&path, picked.clone(), ExtraFields::Strip).unwrap();
        let (format, rows) = splatseg_scene::splats::read_gaussian_rows_with_format(&path).unwrap();
        let expected =
            [("spz", "SPZ"), (".splat", ".splat"), ("ksplat", ".ksplat"), ("ply", "compressed PLY")];
        assert_eq!(Some(format.name()), expected.iter().find(|(e, _)| name.ends_with(e)).map(|(_, f)| *f));
        assert_eq!(rows.gaussians.len(), 2);
        assert!(rows.gaussians.object_ids.is_none());
        // Keeping `object_id` in a format without properties is refused before anything is written.
        let kept = dir.path().join(format!("kept_{name}"));
        let err = write_edited_ply(&kept, picked.clone(), ExtraFields::Keep).unwrap_err();
        assert!(matches!(err, EditError::ExtrasNotHeld { .. }), "{err}");
        assert!(err.to_string().contains("--keep-extras") && err.to_string().ends_with(name), "{err}");
        assert!(!kept.exists());
    }
}

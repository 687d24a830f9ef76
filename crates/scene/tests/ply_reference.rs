//! 3DGS PLY files written by a reference exporter (gsplat's `export_splats`, fixture made by
//! `tools/fixtures/make_ply_fixtures.py`) read to exactly the values it was given.

use serde::Deserialize;
use splatseg_scene::ply::{read_ply, to_ply_bytes};
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures")).join(name)
}

/// The tensors given to gsplat's exporter (f32 values written as JSON numbers).
#[derive(Deserialize)]
struct Exported {
    /// `[N, 3]`
    means: Vec<[f64; 3]>,
    /// `[N, 3]` log-scales.
    scales: Vec<[f64; 3]>,
    /// `[N, 4]` w, x, y, z.
    quats: Vec<[f64; 4]>,
    /// `[N]` raw opacities.
    opacities: Vec<f64>,
    /// `[N, 1, 3]`
    sh0: Vec<[[f64; 3]; 1]>,
    /// `[N, K, 3]`: coefficient-major, channels last.
    #[serde(rename = "shN")]
    sh_n: Vec<Vec<[f64; 3]>>,
}

fn f32s<const K: usize>(v: &[f64; K]) -> [f32; K] {
    v.map(|x| x as f32)
}

#[test]
fn gsplat_export_reads_to_the_exported_values() {
    let path = fixture("ply_gsplat_sh3.ply");
    let g = read_ply(&path).unwrap();
    let text = std::fs::read_to_string(fixture("ply_gsplat_sh3.json")).unwrap();
    let e: Exported = serde_json::from_str(&text).unwrap();
    let n = e.means.len();
    assert_eq!((g.len(), g.sh_degree, g.rest_per_channel()), (n, 3, 15));
    assert!(g.normals.is_none() && g.object_ids.is_none() && g.features.is_none() && g.extra.is_empty());
    for i in 0..n {
        assert_eq!(g.means[i], f32s(&e.means[i]), "mean {i}");
        assert_eq!(g.log_scales[i], f32s(&e.scales[i]), "scale {i}");
        assert_eq!(g.rotations[i], f32s(&e.quats[i]), "rotation {i}");
        assert_eq!(g.raw_opacities[i], e.opacities[i] as f32, "opacity {i}");
        assert_eq!(g.sh_dc[i], f32s(&e.sh0[i][0]), "sh dc {i}");
        // Channel-major f_rest: coefficient k of channel c at c * K + k.
        for (k, coeff) in e.sh_n[i].iter().enumerate() {
            for (c, &value) in coeff.iter().enumerate() {
                assert_eq!(g.sh_rest[i * 45 + c * 15 + k], value as f32, "sh rest {i} k={k} c={c}");
            }
        }
    }
    // Our writer produces the very same file (same property order, same bytes).
    assert_eq!(to_ply_bytes(&g).unwrap(), std::fs::read(&path).unwrap());
}

#[test]
fn compressed_ply_is_rejected_with_a_hint() {
    let path = fixture("ply_gsplat_compressed.ply");
    let err = read_ply(&path).unwrap_err().to_string();
    assert!(err.contains("compressed PLY") && err.contains("ply_gsplat_compressed.ply"), "{err}");
}

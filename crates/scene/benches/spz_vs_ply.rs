//! Issue 61's target side by side: reading 1M Gaussians of SH degree 3 as SPZ (version 3) takes no
//! longer than reading the same Gaussians as a PLY. On a machine others share, one run alternates
//! the two reads (PLY, SPZ, PLY, SPZ, …) so that both see the same load, and prints each round, the
//! medians and their ratio; beside them the time to only inflate the SPZ's gzip stream into memory
//! (the floor of any SPZ reader that inflates on one thread). Under load the ratio approaches the
//! ratio of CPU time the two reads take; on an idle machine it shows what the second core gives.
//!
//! `cargo bench -p splatseg-scene --features bench --bench spz_vs_ply [-- ROUNDS]`

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::splats::{read_gaussians, write_gaussians};
use splatseg_scene::Gaussians;
use std::io::Read;
use std::path::Path;
use std::time::Instant;

const N: usize = 1_000_000;

/// `n` random degree-3 Gaussians inside every format's ranges (a 20 m scene, SH within ±0.5);
/// the same as `splats_read`'s.
fn random_gaussians(n: usize) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut v3 = |lo: f32, hi: f32| -> Vec<[f32; 3]> {
        (0..n).map(|_| [0; 3].map(|_| rng.gen_range(lo..hi))).collect()
    };
    let (means, sh_dc, log_scales) = (v3(-10.0, 10.0), v3(-1.5, 1.5), v3(-7.0, -2.0));
    Gaussians {
        means,
        sh_dc,
        sh_degree: 3,
        sh_rest: (0..n * 45).map(|_| rng.gen_range(-0.5..0.5)).collect(),
        raw_opacities: (0..n).map(|_| rng.gen_range(-4.0..4.0)).collect(),
        log_scales,
        rotations: (0..n).map(|_| [0; 4].map(|_| rng.gen_range(-1.0..1.0))).collect(),
        ..Default::default()
    }
}

/// Seconds `f` takes.
fn seconds(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

/// Reads and inflates the whole file through a 1 MB buffer filled again and again, decoding
/// nothing; the number of bytes inflated.
fn inflate_only(path: &Path) -> u64 {
    let file = std::io::BufReader::new(std::fs::File::open(path).expect("open SPZ"));
    let mut stream = flate2::bufread::GzDecoder::new(file);
    let (mut buffer, mut total) = (vec![0u8; 1 << 20], 0);
    loop {
        match stream.read(&mut buffer).expect("inflate SPZ") {
            0 => return total,
            read => total += read as u64,
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds = std::env::args().skip(1).find_map(|a| a.parse::<usize>().ok()).unwrap_or(9);
    let dir = tempfile::tempdir().expect("temporary folder");
    let g = random_gaussians(N);
    let (ply, spz) = (dir.path().join("scene.ply"), dir.path().join("scene.spz"));
    write_gaussians(&ply, &g).expect("write PLY");
    write_gaussians(&spz, &g).expect("write SPZ");
    drop(g);
    let mb = |p: &Path| std::fs::metadata(p).expect("written").len() as f64 / 1e6;
    println!("1M Gaussians, SH 3: PLY {:.1} MB, SPZ {:.1} MB; {rounds} rounds", mb(&ply), mb(&spz));
    // One of each first, so that both files are in the page cache and the allocator warm.
    read_gaussians(&ply).expect("read PLY");
    read_gaussians(&spz).expect("read SPZ");
    let (mut ply_s, mut spz_s, mut inflate_s) = (Vec::new(), Vec::new(), Vec::new());
    for round in 0..rounds {
        // Alternate which goes first so that neither always follows the other's frees.
        let (a, b) = if round % 2 == 0 { (&ply, &spz) } else { (&spz, &ply) };
        let ta = seconds(|| drop(read_gaussians(a).expect("read")));
        let tb = seconds(|| drop(read_gaussians(b).expect("read")));
        let (tp, ts) = if round % 2 == 0 { (ta, tb) } else { (tb, ta) };
        let ti = seconds(|| assert_eq!(inflate_only(&spz), 16 + 65 * N as u64));
        println!(
            "round {round}: PLY {:.0} ms, SPZ {:.0} ms, inflate only {:.0} ms",
            tp * 1e3,
            ts * 1e3,
            ti * 1e3
        );
        ply_s.push(tp);
        spz_s.push(ts);
        inflate_s.push(ti);
    }
    let ratios: Vec<f64> = spz_s.iter().zip(&ply_s).map(|(s, p)| s / p).collect();
    let (p, s, i) = (median(ply_s), median(spz_s), median(inflate_s));
    println!(
        "median: PLY {:.0} ms, SPZ {:.0} ms (SPZ/PLY {:.2}; median of the rounds' ratios {:.2}), inflate only {:.0} ms",
        p * 1e3,
        s * 1e3,
        s / p,
        median(ratios),
        i * 1e3
    );
}

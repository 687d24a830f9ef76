//! Issue 61's target side by side: reading 1M Gaussians of SH degree 3 as SPZ (version 3) takes no
//! longer than reading the same Gaussians as a PLY, through `splats::read_gaussians` (what every
//! command calls). On a machine others share, one run alternates the two reads (PLY, SPZ, PLY,
//! SPZ, …; which goes first alternates too) so that both see the same load, and prints each round,
//! the medians and their ratios, each read's wall time and the CPU time of the whole process during
//! it (both threads of the SPZ read, every core of the PLY's; under load the wall ratio approaches
//! the CPU ratio), beside the time to only inflate the SPZ's gzip stream into memory (the floor of
//! any SPZ reader that inflates on one thread).
//!
//! Two settings per round: **warm**, both files in the page cache (a file just written or read
//! again), and **cold**, each file's cached pages dropped before each read with
//! `posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED)` after an `fsync` (Linux only): that touches only
//! the two benchmark files, no other process's cache, so it is safe on a shared machine. Cold is
//! what a user opening a capture from disk meets; on a virtual machine the host may still cache the
//! disk, so cold here may be faster than a real disk.
//!
//! `cargo bench -p splatseg-scene --features bench --bench spz_vs_ply [-- ROUNDS [DIR]]`: DIR
//! (default: a temporary folder) must be on a disk, not tmpfs, for cold reads to mean anything.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::splats::{read_gaussians, write_gaussians};
use splatseg_scene::Gaussians;
use std::io::Read;
use std::path::{Path, PathBuf};
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

/// Seconds of CPU (user and system) the whole process has used, every thread included.
#[cfg(unix)]
fn process_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes into the struct it is given and reads nothing else.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    seconds(usage.ru_utime) + seconds(usage.ru_stime)
}

#[cfg(not(unix))]
fn process_cpu_seconds() -> f64 {
    f64::NAN
}

/// Drops the page cache's copy of the file at `path` (its own pages only; written back first);
/// false where the system cannot.
#[cfg(target_os = "linux")]
fn evict_from_page_cache(path: &Path) -> bool {
    use std::os::fd::AsRawFd;
    let Ok(file) = std::fs::File::open(path) else { return false };
    if file.sync_all().is_err() {
        return false;
    }
    // SAFETY: the descriptor is open for the call; the advice changes no memory of this process.
    unsafe { libc::posix_fadvise(file.as_raw_fd(), 0, 0, libc::POSIX_FADV_DONTNEED) == 0 }
}

#[cfg(not(target_os = "linux"))]
fn evict_from_page_cache(_path: &Path) -> bool {
    false
}

/// Wall and CPU seconds `f` takes.
fn timed(f: impl FnOnce()) -> (f64, f64) {
    let (cpu, start) = (process_cpu_seconds(), Instant::now());
    f();
    (start.elapsed().as_secs_f64(), process_cpu_seconds() - cpu)
}

/// Wall and CPU seconds of reading the Gaussians at `path` and dropping them.
fn timed_read(path: &Path) -> (f64, f64) {
    timed(|| drop(read_gaussians(path).expect("read")))
}

/// One round of one setting: the PLY and the SPZ read, `spz_first` or not, each evicted from the
/// page cache just before when `cold`; `[(wall, cpu) of the PLY, (wall, cpu) of the SPZ]`.
fn read_both(ply: &Path, spz: &Path, spz_first: bool, cold: bool) -> [(f64, f64); 2] {
    let read = |path: &Path| {
        if cold {
            assert!(evict_from_page_cache(path), "cannot drop {} from the page cache", path.display());
        }
        timed_read(path)
    };
    if spz_first {
        let s = read(spz);
        [read(ply), s]
    } else {
        let p = read(ply);
        [p, read(spz)]
    }
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

/// The times of one setting over the rounds, `[PLY, SPZ]` each.
#[derive(Default)]
struct Times {
    wall: [Vec<f64>; 2],
    cpu: [Vec<f64>; 2],
}

impl Times {
    fn push(&mut self, reads: [(f64, f64); 2]) {
        for (i, (wall, cpu)) in reads.into_iter().enumerate() {
            self.wall[i].push(wall);
            self.cpu[i].push(cpu);
        }
    }

    /// One line: the medians of each read's wall and CPU time and the ratios SPZ/PLY, of the
    /// medians and the median of the rounds' own ratios.
    fn summary(&self, setting: &str) -> String {
        let ratios = |t: &[Vec<f64>; 2]| -> Vec<f64> { t[1].iter().zip(&t[0]).map(|(s, p)| s / p).collect() };
        let (pw, sw) = (median(self.wall[0].clone()), median(self.wall[1].clone()));
        let (pc, sc) = (median(self.cpu[0].clone()), median(self.cpu[1].clone()));
        format!(
            "{setting}: PLY {:.0} ms (CPU {:.0} ms), SPZ {:.0} ms (CPU {:.0} ms); SPZ/PLY wall {:.2} \
             (rounds' median {:.2}), CPU {:.2} (rounds' median {:.2})",
            pw * 1e3,
            pc * 1e3,
            sw * 1e3,
            sc * 1e3,
            sw / pw,
            median(ratios(&self.wall)),
            sc / pc,
            median(ratios(&self.cpu)),
        )
    }
}

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let rounds = args.next().and_then(|a| a.parse::<usize>().ok()).unwrap_or(9);
    let temporary = tempfile::tempdir().expect("temporary folder");
    let dir = args.next().map(PathBuf::from).unwrap_or_else(|| temporary.path().to_path_buf());
    let g = random_gaussians(N);
    let (ply, spz) = (dir.join("spz_vs_ply_scene.ply"), dir.join("spz_vs_ply_scene.spz"));
    write_gaussians(&ply, &g).expect("write PLY");
    write_gaussians(&spz, &g).expect("write SPZ");
    drop(g);
    let mb = |p: &Path| std::fs::metadata(p).expect("written").len() as f64 / 1e6;
    println!("1M Gaussians, SH 3: PLY {:.1} MB, SPZ {:.1} MB; {rounds} rounds", mb(&ply), mb(&spz));
    // One of each first, so that both files are in the page cache and the allocator warm.
    read_gaussians(&ply).expect("read PLY");
    read_gaussians(&spz).expect("read SPZ");
    let cold_possible = evict_from_page_cache(&ply) && evict_from_page_cache(&spz);
    if !cold_possible {
        println!(
            "COLD READS NOT MEASURED: this system cannot drop a file's pages (posix_fadvise, Linux only)"
        );
    }
    let (mut warm, mut cold) = (Times::default(), Times::default());
    let (mut inflate_wall, mut inflate_cpu) = (Vec::new(), Vec::new());
    for round in 0..rounds {
        let spz_first = round % 2 == 1;
        let w = read_both(&ply, &spz, spz_first, false);
        let c = cold_possible.then(|| read_both(&ply, &spz, spz_first, true));
        let inflate = timed(|| assert_eq!(inflate_only(&spz), 16 + 65 * N as u64));
        let ms = |(wall, cpu): (f64, f64)| format!("{:.0} ms (CPU {:.0})", wall * 1e3, cpu * 1e3);
        let cold_line = c.map(|c| format!("; cold PLY {}, SPZ {}", ms(c[0]), ms(c[1]))).unwrap_or_default();
        println!(
            "round {round}: warm PLY {}, SPZ {}{cold_line}; inflate only {}",
            ms(w[0]),
            ms(w[1]),
            ms(inflate)
        );
        warm.push(w);
        if let Some(c) = c {
            cold.push(c);
        }
        inflate_wall.push(inflate.0);
        inflate_cpu.push(inflate.1);
    }
    println!("median {}", warm.summary("warm"));
    if cold_possible {
        println!("median {}", cold.summary("cold"));
    }
    println!(
        "median inflate only (warm): {:.0} ms (CPU {:.0} ms)",
        median(inflate_wall) * 1e3,
        median(inflate_cpu) * 1e3
    );
    for path in [&ply, &spz] {
        let _ = std::fs::remove_file(path);
    }
}

//! The binary's allocator settings, set once by `main` (libraries set none): for a program that
//! allocates and frees large buffers over and over (per-view maps of several MB in the pipeline,
//! per-operation tensors in the models).
//!
//! With glibc's defaults, blocks above its (adaptive) mmap threshold are mapped and unmapped on
//! every allocation, memory freed at the top of a heap is returned to the kernel beyond the trim
//! threshold, and each thread that allocates gets its own arena whose heaps shrink as soon as
//! their tops are free; so every new buffer takes fresh zeroed pages. Measured here: ~0.9 M page
//! faults for one MobileSAM embedding (~40 % of its time on this virtual machine); 4.1 M page
//! faults and 13 s of system time in a `run` of 100 views × 1280×960 × 1M Gaussians, 0.3 M and
//! 4.7 s with these settings (BENCHMARKS.md, issue 13). Raising both thresholds and keeping one
//! arena makes freed memory serve the next buffer instead of going back to the kernel; the peak
//! resident memory is what it was (the same buffers are alive at the peak). The few large
//! allocations per view do not contend for the single arena's lock.

/// Sets glibc's mmap threshold to 256 MB, its trim threshold to 1 GB and its arena count to one
/// (once per process; a no-op on other C libraries). Memory freed is then reused instead of
/// returned to the kernel.
pub fn keep_freed_memory_for_reuse() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            // glibc's <malloc.h>
            const M_TRIM_THRESHOLD: i32 = -1;
            const M_MMAP_THRESHOLD: i32 = -3;
            const M_ARENA_MAX: i32 = -8;
            extern "C" {
                fn mallopt(param: i32, value: i32) -> i32;
            }
            // SAFETY: mallopt only changes the allocator's parameters; every value is in range.
            let (mmap, trim, arenas) = unsafe {
                (
                    mallopt(M_MMAP_THRESHOLD, 256 << 20),
                    mallopt(M_TRIM_THRESHOLD, 1 << 30),
                    mallopt(M_ARENA_MAX, 1),
                )
            };
            tracing::debug!("allocator settings (mmap {mmap}, trim {trim}, arenas {arenas}; 1 = accepted)");
        });
    }
}

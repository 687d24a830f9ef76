//! Process-wide allocator settings for the models' large per-operation buffers.
//!
//! The image encoders allocate and free many tensors of several MB per image (candle allocates each
//! op's output). With glibc's defaults, blocks above its (adaptive) mmap threshold are mapped and
//! unmapped on every allocation, and freed memory at the top of the heap is returned to the kernel
//! beyond 2× that threshold, so each new tensor takes fresh zeroed pages: ~0.9 M page faults for
//! one MobileSAM embedding here, ~40 % of its time on this virtual machine. Raising both thresholds
//! keeps freed memory in the process for the next tensor (the peak resident memory is what it was:
//! the same buffers are alive at the peak).

/// Sets glibc's mmap threshold to 256 MB and its trim threshold to 1 GB (once per process; a no-op on
/// other C libraries). Memory freed by the models is then reused instead of returned to the kernel.
pub fn keep_freed_memory_for_reuse() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            // glibc's <malloc.h>
            const M_TRIM_THRESHOLD: i32 = -1;
            const M_MMAP_THRESHOLD: i32 = -3;
            extern "C" {
                fn mallopt(param: i32, value: i32) -> i32;
            }
            // SAFETY: mallopt only changes the allocator's parameters; both values are in range.
            let (mmap, trim) =
                unsafe { (mallopt(M_MMAP_THRESHOLD, 256 << 20), mallopt(M_TRIM_THRESHOLD, 1 << 30)) };
            tracing::debug!("allocator thresholds set (mmap {mmap}, trim {trim}; 1 = accepted)");
        });
    }
}

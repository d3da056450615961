//! Whether the vector fills may run their AVX2 build (x86-64 only), decided at run time
//! without `std`.
//!
//! The fills' decode passes are loops LLVM vectorises: the crate is built for the x86-64
//! baseline (SSE2, 4 `f32` lanes), and the same loops compiled with AVX2 enabled run 8 lanes
//! per instruction. Both builds perform the same IEEE operations in the same order (Rust never
//! fuses a multiply and an add, and `sqrtps` is correctly rounded at every width), so they give
//! the same bits (tested against the per-sample reads).
//!
//! The `unsafe` here has a measured reason: decoding a 1080p frame's worth of voxels of a
//! 128×128×64 mask (`fill_vector_row` a mask width at a time), built without and with AVX2 in
//! one sitting (Zen 4): octahedral Unorm16 3.5 against 2.6 ms, signed Unorm8 3.9 against 2.4 ms,
//! Vec2 Unorm8 0.75 against 0.34 ms (there with the one-pass loop only the AVX2 build runs).

/// Whether this CPU runs AVX2 code and the operating system saves its registers: decided once
/// per process (`cpuid` and `xgetbv`, what `std::is_x86_feature_detected!` checks).
pub(crate) fn has_avx2() -> bool {
    use core::sync::atomic::{AtomicU8, Ordering};
    // Targets without SSE (soft-float kernels, where the vector registers may not be saved) and
    // SGX enclaves (where `cpuid` faults) never take the AVX2 build.
    if cfg!(any(not(target_feature = "sse2"), target_env = "sgx")) {
        return false;
    }
    // 0: not yet known, 1: no, 2: yes.
    static KNOWN: AtomicU8 = AtomicU8::new(0);
    match KNOWN.load(Ordering::Relaxed) {
        0 => {
            let yes = detect_avx2();
            KNOWN.store(if yes { 2 } else { 1 }, Ordering::Relaxed);
            yes
        }
        known => known == 2,
    }
}

/// The checks behind [`has_avx2`]: the CPU reports AVX and AVX2, and `XSAVE` enabled by the
/// operating system, which saves the SSE and AVX register state (bits 1 and 2 of `XCR0`).
#[allow(unsafe_code)]
// `__cpuid` is an `unsafe fn` on the crate's MSRV and safe on later compilers.
#[allow(unused_unsafe)]
fn detect_avx2() -> bool {
    use core::arch::x86_64::{__cpuid, __cpuid_count};
    // SAFETY: `cpuid` exists on every x86-64 CPU; leaves 1 and 7 exist when leaf 0 says so.
    let max_leaf = unsafe { __cpuid(0) }.eax;
    if max_leaf < 7 {
        return false;
    }
    // SAFETY: as above.
    let leaf1 = unsafe { __cpuid(1) };
    let (osxsave, avx) = (leaf1.ecx & (1 << 27) != 0, leaf1.ecx & (1 << 28) != 0);
    if !(osxsave && avx) {
        return false;
    }
    // SAFETY: the CPU has XSAVE enabled by the operating system (OSXSAVE), all `xgetbv` needs.
    let xcr0 = unsafe { xcr0() };
    // SAFETY: as for leaf 1.
    let avx2 = unsafe { __cpuid_count(7, 0) }.ebx & (1 << 5) != 0;
    xcr0 & 0b110 == 0b110 && avx2
}

/// `XCR0`, the register-state mask the operating system enabled.
///
/// # Safety
/// The CPU must have XSAVE enabled (`cpuid` leaf 1, `ECX` bit 27).
#[allow(unsafe_code)]
#[target_feature(enable = "xsave")]
unsafe fn xcr0() -> u64 {
    // SAFETY: the caller guarantees XSAVE, and this function is compiled with it enabled.
    unsafe { core::arch::x86_64::_xgetbv(0) }
}

//! A `no_std`, allocator-free static library exercising stbn-runtime's
//! zero-copy view, sampling and no-alloc decoding.
#![no_std]

use core::panic::PanicInfo;

use stbn_runtime::{PackedStbn, Stbn};

/// Parses an uncompressed blob, samples it, and decodes it again into `buf`.
///
/// Returns the sum of the sample at `(x, y, frame)` from the zero-copy view and
/// from the decoded copy, plus the vector read's length and pdf (the octahedral decode
/// and normalisation go through glam's `libm` path), or a negative value if the blob or
/// buffer is invalid.
///
/// # Safety
/// `blob` must point to `blob_len` readable bytes and `buf` to `buf_len`
/// writable bytes that do not overlap `blob`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn stbn_check(
    blob: *const u8,
    blob_len: usize,
    buf: *mut u8,
    buf_len: usize,
    x: i32,
    y: i32,
    frame: u32,
) -> f32 {
    // SAFETY: the caller guarantees both regions are valid and disjoint.
    let (blob, buf) = unsafe {
        (
            core::slice::from_raw_parts(blob, blob_len),
            core::slice::from_raw_parts_mut(buf, buf_len),
        )
    };
    let Ok(view) = Stbn::from_bytes(blob) else {
        return -1.0;
    };
    let vector = view.dimension(2).sample_vector(x, y, frame);
    let direct = view.dimension(1).sample(x, y, frame) + vector.value.length() + vector.pdf;
    let Ok(packed) = PackedStbn::from_bytes(blob) else {
        return -2.0;
    };
    match packed.decode_into(buf) {
        Ok(decoded) => direct + decoded.dimension(1).sample(x, y, frame),
        Err(_) => -3.0,
    }
}

#[panic_handler]
fn panic(_: &PanicInfo<'_>) -> ! {
    loop {}
}

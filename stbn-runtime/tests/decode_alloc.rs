//! `PackedStbn::decode`'s allocation: bounded by the stream before it is made, and fallible.
//!
//! This binary's global allocator records the largest request and refuses requests above a
//! limit (returns null, as an allocator out of memory does), so the test sees what `decode`
//! asks for and what it does when refused. One test function: the limit is process-wide.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use common::{Rng, blob, packed_blob};
use stbn_runtime::{Compression, Encoding, Error, MaskHeader, PackedStbn};

/// The system allocator, with a ceiling on one request and a record of the largest.
struct Limited;

static LARGEST: AtomicUsize = AtomicUsize::new(0);
static LIMIT: AtomicUsize = AtomicUsize::new(usize::MAX);

// SAFETY: every call forwards to `System` unchanged or returns null, which `GlobalAlloc`
// allows for a failed allocation.
unsafe impl GlobalAlloc for Limited {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        if layout.size() > LIMIT.load(Ordering::Relaxed) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract is `System`'s.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Limited = Limited;

/// The largest single allocation `f` makes.
fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.store(0, Ordering::Relaxed);
    let out = f();
    (out, LARGEST.load(Ordering::Relaxed))
}

#[test]
fn decode_allocates_within_the_stream_bound_and_reports_a_refusal() {
    // The 69-byte LZ4 blob whose header claims 32768 × 32768 × 2 bytes (2 GiB): refused
    // before any allocation the size of the claim.
    let header = MaskHeader {
        compression: Compression::Lz4,
        ..MaskHeader::new(32768, 32768, 1, 2, Encoding::Unorm8)
    };
    let tiny = blob(header, &[0x1f, 0, 0, 0, 0]);
    assert_eq!(tiny.len(), 69);
    let (result, largest) = largest_allocation(|| PackedStbn::from_bytes(&tiny).map(|_| ()));
    assert!(
        matches!(
            result,
            Err(Error::InvalidField {
                field: "payload_len",
                ..
            })
        ),
        "{result:?}"
    );
    assert!(largest < 4096, "{largest} bytes allocated");

    // A garbage LZ4 payload just large enough for its header's 8 MiB: decode may allocate the
    // 8 MiB (at most 255 times the blob), then reports the bad stream.
    let header = MaskHeader {
        compression: Compression::Lz4,
        ..MaskHeader::new(2048, 2048, 2, 1, Encoding::Unorm8)
    };
    let stored_len = header.decoded_len().div_ceil(255);
    let garbage = blob(header, &Rng(9).bytes(stored_len));
    let packed = PackedStbn::from_bytes(&garbage).unwrap();
    let (result, largest) = largest_allocation(|| packed.decode().map(|_| ()));
    assert!(result.is_err(), "{result:?}");
    assert!(largest <= 255 * garbage.len(), "{largest} bytes allocated");

    // A valid blob whose decoded size the allocator refuses: an error, not an abort.
    let header = MaskHeader::new(1024, 1024, 4, 1, Encoding::Unorm8);
    let data = Rng(3).bytes(header.decoded_len());
    let bytes = packed_blob(header, Compression::Lz4, &data);
    let packed = PackedStbn::from_bytes(&bytes).unwrap();
    LIMIT.store(header.decoded_len() - 1, Ordering::Relaxed);
    let refused = packed.decode().map(|_| ());
    LIMIT.store(usize::MAX, Ordering::Relaxed);
    assert_eq!(
        refused,
        Err(Error::OutOfMemory {
            bytes: header.decoded_len()
        })
    );
    assert_eq!(packed.decode().unwrap().data(), &data[..]);
}

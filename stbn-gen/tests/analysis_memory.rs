//! The analysis holds bounded memory beside the field it reads, whatever the field's size: each
//! measure that grows with a frame, a plane or a pixel's series is run on a field large enough
//! to take its bounded path, under an allocator that counts the bytes live at once.
#![cfg(feature = "analysis")]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use stbn_gen::analysis::{
    Field, FilteredErrorOptions, MAX_FILTERED_FRAME, MAX_SPECTRUM_PLANE, dft_xy_image,
    dft_xz_image, filtered_error, radial_spectrum, spatial_low_band, spectrum_fold,
    temporal_spectrum,
};

/// The system allocator, counting the bytes live and the most live at once.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded to `System` with the caller's arguments, so `System`'s
// guarantees hold; the counters only observe sizes.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller upholds `alloc`'s contract, which `System.alloc` shares.
        let ptr = unsafe { System.alloc(layout) };
        if !ptr.is_null() {
            let live = LIVE.fetch_add(layout.size(), Ordering::SeqCst) + layout.size();
            PEAK.fetch_max(live, Ordering::SeqCst);
        }
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` / `realloc` above with this layout.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller upholds `realloc`'s contract, which `System.realloc` shares.
        let new = unsafe { System.realloc(ptr, layout, new_size) };
        if !new.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::SeqCst);
            let live = LIVE.fetch_add(new_size, Ordering::SeqCst) + new_size;
            PEAK.fetch_max(live, Ordering::SeqCst);
        }
        new
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

const MIB: usize = 1 << 20;

/// The most bytes `measure` had live at once beyond those live before it, and its result.
fn peak_during<T>(measure: impl FnOnce() -> T) -> (usize, T) {
    let before = LIVE.load(Ordering::SeqCst);
    PEAK.store(before, Ordering::SeqCst);
    let result = measure();
    (PEAK.load(Ordering::SeqCst) - before, result)
}

/// `len` values in `[0, 1)` (SplitMix64), a stand-in for a mask.
fn noise(len: usize) -> Vec<f64> {
    let mut state = 7u64;
    (0..len)
        .map(|_| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) as f64 / 2f64.powi(64)
        })
        .collect()
}

/// One test, so no other test allocates while a peak is measured; four threads, so the bounds
/// do not depend on the machine.
#[test]
fn large_fields_are_measured_in_bounded_memory() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    pool.install(|| {
        // Spectra: an 8 Mi-pixel slice is folded to the 4 Mi-pixel grid of every second x
        // frequency. Unbounded, one transform held 48 bytes a pixel (384 MiB) and the XY image
        // copied the field.
        let (w, h) = (4096, 2048);
        assert_eq!(spectrum_fold(w, h), (2, 1));
        let values = noise(w * h);
        let field = Field::new(w, h, 1, &values).unwrap();
        for (name, peak) in [
            ("low band", peak_during(|| spatial_low_band(&field)).0),
            ("radial", peak_during(|| radial_spectrum(&field)).0),
            ("XY image", peak_during(|| dft_xy_image(&field)).0),
        ] {
            assert!(
                peak <= 56 * MAX_SPECTRUM_PLANE,
                "{name}: {} MiB",
                peak / MIB
            );
        }
        // The white-noise figures survive the fold.
        let band = spatial_low_band(&field).unwrap();
        assert!((band - 1.0).abs() < 0.02, "{band}");
        drop(values);

        // The XZ image of a one-row field: one 8 Mi-pixel x–frame plane, folded alike.
        let (w, d) = (4096, 2048);
        let values = noise(w * d);
        let field = Field::new(w, 1, d, &values).unwrap();
        let (peak, image) = peak_during(|| dft_xz_image(&field));
        assert_eq!((image.width, image.height), (2048, 2048));
        assert!(peak <= 56 * MAX_SPECTRUM_PLANE, "XZ: {} MiB", peak / MIB);
        drop(values);

        // Long series: 16,384 frames. Unbounded, one task of 1024 series held 256 MiB.
        let (n, d) = (1024, 16384);
        let values = noise(n * d);
        let field = Field::new(32, 32, d, &values).unwrap();
        let (peak, spectrum) = peak_during(|| temporal_spectrum(&field));
        assert_eq!(spectrum.len(), d / 2 + 1);
        assert!(
            peak <= 4 * 16 * MIB + 8 * MIB,
            "temporal: {} MiB",
            peak / MIB
        );
        drop(values);

        // The filtered error of 2 Mi-pixel frames is averaged over a 1024 × 512 window.
        // Unbounded, each task of four thresholds held 96 bytes a pixel of the whole frame
        // (192 MiB), one per thread.
        let (w, h) = (4096, 512);
        let options = FilteredErrorOptions {
            thresholds: 16,
            ..FilteredErrorOptions::default()
        };
        assert!(w * h > MAX_FILTERED_FRAME);
        assert_eq!(options.window(w, h), (1024, 512));
        let values = noise(w * h * 2);
        let field = Field::new(w, h, 2, &values).unwrap();
        let (peak, error) = peak_during(|| filtered_error(&field, options));
        assert!(
            peak <= 4 * 112 * (1024 + 12) * 512,
            "filtered: {} MiB",
            peak / MIB
        );
        // White noise (analysis docs, "Expected value for white noise"): √(1/6 · (Σ wᵢ²)² · cₖ)
        // with cₖ = 1 at frame 0 and 0.82 at frame 1: about 0.086 and 0.078.
        assert!(error[0] > 0.075 && error[0] < 0.095, "{error:?}");
        assert!(error[1] > 0.068 && error[1] < 0.087, "{error:?}");
    });
}

/// The plan at the documented limits: 2²⁴ pixels per frame, 2²⁶ per mask, 65536 per axis.
#[test]
fn the_documented_limits_fold_and_window_as_stated() {
    let default = FilteredErrorOptions::default();
    // (width, height, frames), XY fold, XZ fold, filtered-error window.
    for (size, xy, xz, window) in [
        ((4096, 4096, 4), (2, 2), (1, 1), (1024, 1024)),
        ((2048, 2048, 16), (1, 1), (1, 1), (1024, 1024)),
        ((1024, 1024, 64), (1, 1), (1, 1), (1024, 1024)),
        ((256, 256, 1024), (1, 1), (1, 1), (256, 256)),
        ((65536, 256, 4), (4, 1), (1, 1), (1024, 256)),
        ((65536, 1, 1024), (1, 1), (16, 1), (65536, 1)),
        ((16, 16, 65536), (1, 1), (1, 1), (16, 16)),
        ((4093, 4093, 4), (4093, 1), (1, 1), (1024, 1024)),
    ] {
        let (w, h, d) = size;
        assert_eq!(spectrum_fold(w, h), xy, "{size:?} XY");
        assert_eq!(spectrum_fold(w, d), xz, "{size:?} XZ");
        assert_eq!(default.window(w, h), window, "{size:?} window");
        for (a, b, (fa, fb)) in [(w, h, xy), (w, d, xz)] {
            assert!(a.is_multiple_of(fa) && b.is_multiple_of(fb));
            assert!((a / fa) * (b / fb) <= MAX_SPECTRUM_PLANE, "{size:?}");
        }
    }
}

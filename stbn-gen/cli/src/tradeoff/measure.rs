//! What every knob measures: wall-clock time, peak memory, the machine's load, and the quality
//! figures of a scalar field ([`Quality`]).
//!
//! # Peak memory
//!
//! Linux keeps each process's peak resident set size (`VmHWM` in `/proc/self/status`), and
//! writing `5` to `/proc/self/clear_refs` resets it to the current resident size (Linux ≥ 4.0).
//! [`with_peak_memory`] first hands the allocator's free memory back to the kernel (glibc's
//! `malloc_trim(0)`: memory an earlier run freed but the allocator kept resident would otherwise
//! be reused without raising the peak), resets the peak, reads `VmRSS`, runs the work, reads
//! `VmHWM` again and reports the difference: the resident memory the work added at its peak,
//! whichever thread allocated it. Where the files are missing or not writable (not Linux) it
//! reports nothing.

use std::fs;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use stbn_gen::analysis::{
    ConvergenceOptions, Field, FilteredErrorOptions, Integrand, convergence, filtered_error,
    spatial_low_band, temporal_low_band,
};

use crate::output::Cell;

/// The sample counts the convergence RMSE is reported at.
pub const RMSE_AT: [usize; 3] = [8, 32, 64];

/// The quality figures of one scalar field (values in `[0, 1]`), all from `stbn_gen::analysis`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    /// [`spatial_low_band`]: white noise = 1, lower is bluer within a frame.
    pub spatial: Option<f64>,
    /// [`temporal_low_band`]: white noise = 1, lower is bluer over time.
    pub temporal: Option<f64>,
    /// [`filtered_error`] (EA's FAST, default options) of the last frame.
    pub filtered_last: f64,
    /// Monte Carlo RMSE over pixels of ∫₀¹ step(x) dx (step = 1 where x < ½) after each of [`RMSE_AT`] samples (one
    /// per frame from frame 0, wrapping after the last frame).
    pub mc_step: [f64; 3],
    /// The EMA (α = 0.1) RMSE of the same integral after 64 samples.
    pub ema_step_64: f64,
}

impl Quality {
    /// Measures `field`.
    pub fn measure(field: &Field) -> Quality {
        let samples = RMSE_AT[RMSE_AT.len() - 1];
        let curves = convergence(field, Integrand::Step, ConvergenceOptions::new(samples));
        let filtered = filtered_error(field, FilteredErrorOptions::default());
        Quality {
            spatial: spatial_low_band(field),
            temporal: temporal_low_band(field),
            filtered_last: *filtered.last().expect("a field has a frame"),
            mc_step: RMSE_AT.map(|n| curves.monte_carlo[n - 1]),
            ema_step_64: curves.ema[samples - 1],
        }
    }

    /// Measures the field of `values` (`width × height × depth`, in `[0, 1]`).
    pub fn of_values(width: u32, height: u32, depth: u32, values: &[f64]) -> Quality {
        let field = Field::new(width as usize, height as usize, depth as usize, values)
            .expect("the values form a field in [0, 1]");
        Quality::measure(&field)
    }

    /// The columns of [`Quality::cells`], as `(csv name, markdown heading, numeric)`.
    pub const COLUMNS: [(&'static str, &'static str, bool); 7] = [
        ("spatial_low_band", "spatial low band", true),
        ("temporal_low_band", "temporal low band", true),
        ("filtered_error_last_frame", "filtered error", true),
        ("mc_step_rmse_8", "MC RMSE 8", true),
        ("mc_step_rmse_32", "MC RMSE 32", true),
        ("mc_step_rmse_64", "MC RMSE 64", true),
        ("ema_step_rmse_64", "EMA RMSE 64", true),
    ];

    /// The figures, in the order of [`Quality::COLUMNS`].
    pub fn cells(&self) -> Vec<Cell> {
        let mut cells = vec![
            Cell::opt_fixed(self.spatial, 4),
            Cell::opt_fixed(self.temporal, 4),
            Cell::fixed(self.filtered_last, 5),
        ];
        cells.extend(self.mc_step.iter().map(|&e| Cell::fixed(e, 4)));
        cells.push(Cell::fixed(self.ema_step_64, 4));
        cells
    }
}

/// What the quality columns mean, for the report.
pub const QUALITY_LEGEND: &str = "Quality columns, all from `stbn_gen::analysis` on the mask's \
values (exact generator values unless a table says it measured decoded ones): **spatial / \
temporal low band**: mean normalised power over the lowest eighth of the frequencies of each \
frame / of each pixel over the frames, white noise = 1, lower is bluer; **filtered error**: EA's \
FAST metric at the last frame (256 thresholds, Gaussian σ 1.3435 px, EMA α 0.1; white noise \
≈ 0.0197), lower is better; **MC RMSE n**: root-mean-square error over pixels of the Monte \
Carlo estimate of ∫₀¹ [x < ½] dx = ½ after n samples (one per frame from frame 0; masks with \
fewer than n frames wrap around, as a renderer cycling them would); **EMA RMSE 64**: the same \
with an exponential moving average (α = 0.1) after 64 samples.";

/// The result of [`timed`].
#[derive(Clone, Debug, PartialEq)]
pub struct Timing {
    /// Wall-clock seconds of every run, in order.
    pub runs: Vec<f64>,
    /// The resident memory the first run added at its peak ([module docs](self)).
    pub peak_bytes: Option<u64>,
    /// Whether every repeated run returned what the first one did.
    pub repeatable: bool,
}

impl Timing {
    /// The median of [`Timing::runs`] (the mean of the middle two for an even count).
    pub fn median(&self) -> f64 {
        let mut sorted = self.runs.clone();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        if n % 2 == 1 {
            sorted[n / 2]
        } else {
            0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
        }
    }
}

/// Runs `work` once under [`with_peak_memory`], then again while the runs so far total less than
/// `min_total` seconds, up to `max_runs` runs in all; returns the first run's result and the
/// times, and whether each later run returned an equal result.
pub fn timed<T: PartialEq>(
    max_runs: usize,
    min_total: f64,
    mut work: impl FnMut() -> T,
) -> (T, Timing) {
    let start = Instant::now();
    let (first, peak_bytes) = with_peak_memory(&mut work);
    let mut runs = vec![start.elapsed().as_secs_f64()];
    let mut repeatable = true;
    while runs.len() < max_runs && runs.iter().sum::<f64>() < min_total {
        let start = Instant::now();
        let again = work();
        runs.push(start.elapsed().as_secs_f64());
        repeatable &= again == first;
    }
    let timing = Timing {
        runs,
        peak_bytes,
        repeatable,
    };
    (first, timing)
}

/// Runs `work` and returns its result with the resident memory it added at its peak, or `None`
/// where `/proc/self/clear_refs` and `/proc/self/status` are not available ([module
/// docs](self)).
pub fn with_peak_memory<T>(work: impl FnOnce() -> T) -> (T, Option<u64>) {
    release_free_memory();
    let reset = fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = status_bytes("VmRSS");
    let value = work();
    let peak = status_bytes("VmHWM");
    let added = match (reset, before, peak) {
        (true, Some(before), Some(peak)) => Some(peak.saturating_sub(before)),
        _ => None,
    };
    (value, added)
}

/// Returns the allocator's free memory to the kernel: glibc's `malloc_trim(0)` (every arena,
/// free pages in the middle of a heap too). A no-op with other C libraries.
fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        unsafe extern "C" {
            fn malloc_trim(pad: usize) -> i32;
        }
        // SAFETY: `malloc_trim` takes no pointers, only releases memory the allocator holds free,
        // and is thread-safe (it locks each arena).
        unsafe {
            malloc_trim(0);
        }
    }
}

/// A `kB` field of `/proc/self/status`, in bytes.
fn status_bytes(field: &str) -> Option<u64> {
    proc_kib_field("/proc/self/status", field)
}

/// The 1, 5 and 15 minute load averages (`/proc/loadavg`, what `uptime` prints), e.g.
/// `1.32 1.10 0.87`, or `n/a`.
pub fn load_average() -> String {
    fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|text| {
            text.split_whitespace()
                .take(3)
                .collect::<Vec<_>>()
                .join(" ")
        })
        .filter(|text| !text.is_empty())
        .unwrap_or_else(|| "n/a".to_owned())
}

/// The machine, for the report's header: CPU model, logical CPUs, memory, rayon's threads and the
/// build profile.
pub fn machine() -> String {
    let cpuinfo = fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name")?.split(':').nth(1))
        .map_or("unknown CPU".to_owned(), |m| m.trim().to_owned());
    let cpus = std::thread::available_parallelism().map_or(0, |n| n.get());
    let memory = proc_kib_field("/proc/meminfo", "MemTotal").map_or("unknown".to_owned(), |b| {
        format!("{:.1} GiB", b as f64 / f64::from(1u32 << 30))
    });
    let profile = if cfg!(debug_assertions) {
        "debug build (timings are not representative; stbn-gen itself is optimised)"
    } else {
        "release build"
    };
    format!(
        "{model}, {cpus} logical CPUs, {memory} memory; rayon uses {} threads; {profile}",
        rayon::current_num_threads()
    )
}

/// A `kB` field of a `/proc` file in `key: value kB` form, in bytes.
fn proc_kib_field(path: &str, field: &str) -> Option<u64> {
    let text = fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// The current UTC time as `YYYY-MM-DD HH:MM UTC`.
pub fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        rest / 3600,
        rest % 3600 / 60
    )
}

/// The proleptic Gregorian date of day `z` after 1970-01-01 (H. Hinnant's `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(19_723), (2024, 1, 1));
        assert_eq!(civil_from_days(19_782), (2024, 2, 29));
    }

    #[test]
    fn median_and_repeats() {
        let mut calls = 0;
        let (value, timing) = timed(3, f64::INFINITY, || {
            calls += 1;
            7
        });
        assert_eq!((value, calls, timing.runs.len()), (7, 3, 3));
        assert!(timing.repeatable);
        let mut n = 0;
        let (_, timing) = timed(3, f64::INFINITY, || {
            n += 1;
            n
        });
        assert!(!timing.repeatable);
        let t = Timing {
            runs: vec![3.0, 1.0, 2.0, 10.0],
            peak_bytes: None,
            repeatable: true,
        };
        assert_eq!(t.median(), 2.5);
    }

    #[test]
    fn peak_memory_sees_a_large_allocation() {
        let (sum, added) = with_peak_memory(|| {
            let v = vec![1u8; 64 << 20];
            v.iter().map(|&b| u64::from(b)).sum::<u64>()
        });
        assert_eq!(sum, 64 << 20);
        if let Some(added) = added {
            assert!(added >= 60 << 20, "{added}");
        } else {
            errln!("no /proc/self/clear_refs: peak memory untested");
        }
    }

    #[test]
    fn quality_of_white_and_constant_like_fields() {
        // A per-pixel ramp over 8 frames: each pixel holds every (k + 0.5) / 8 once.
        let (w, h, d) = (8u32, 8u32, 8u32);
        let values: Vec<f64> = (0..w * h * d)
            .map(|i| {
                let (p, z) = (i % (w * h), i / (w * h));
                f64::from((z + p) % d) / f64::from(d) + 0.5 / f64::from(d)
            })
            .collect();
        let q = Quality::of_values(w, h, d, &values);
        // After 8 samples every pixel has seen each stratum once: [x < ½] averages exactly ½.
        assert!(q.mc_step[0].abs() < 1e-12, "{q:?}");
        assert_eq!(q.cells().len(), Quality::COLUMNS.len());
    }
}

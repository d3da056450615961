//! What a caller sees of a generation: [`Observer`] and its [`Progress`] reports.

use std::fmt;

use crate::EnergyTrace;

/// What a caller sees of one generation while it runs and when it ends: progress reports
/// ([`Observer::with_progress`]) and the optimiser's energy trace ([`Observer::with_trace`]).
/// Every entry point takes one; [`Observer::default()`] sees nothing. Observing never changes the
/// mask.
///
/// ```
/// use stbn_gen::{EnergyTrace, FilterAdaptedSpec, Observer, Progress};
/// let spec = FilterAdaptedSpec::new(16, 16, 4, 7).with_swaps_per_pixel(3.0);
/// let mut reports = Vec::new();
/// let mut progress = |p: Progress| reports.push(p);
/// let mut trace = EnergyTrace::default();
/// let observer = Observer::default()
///     .with_progress(&mut progress)
///     .with_trace(&mut trace);
/// stbn_gen::generate_filter_adapted(&spec, observer).unwrap();
/// assert_eq!(reports.last(), Some(&Progress { done: 3, total: 3 }));
/// assert_eq!(trace.points.len(), 1 + 3);
/// ```
#[derive(Default)]
pub struct Observer<'a> {
    progress: Option<&'a mut dyn FnMut(Progress)>,
    trace: Option<&'a mut EnergyTrace>,
}

impl<'a> Observer<'a> {
    /// The same observer, calling `progress` on the calling thread as the generation advances,
    /// in the steps [`Progress`] lists per entry point: first with `done == 0`, last with
    /// `done == total`.
    pub fn with_progress(mut self, progress: &'a mut dyn FnMut(Progress)) -> Observer<'a> {
        self.progress = Some(progress);
        self
    }

    /// The same observer, replacing `trace` when the generation ends: by the swap optimiser's
    /// energy before the first pass and after each ([`generate_vector`](crate::generate_vector),
    /// [`generate_filter_adapted`](crate::generate_filter_adapted),
    /// [`generate_filter_adapted_vector`](crate::generate_filter_adapted_vector)), or by an empty
    /// trace for the generators that optimise no energy ([`generate`](crate::generate),
    /// [`generate_baseline`](crate::generate_baseline)). Left as it is if the spec is invalid.
    pub fn with_trace(mut self, trace: &'a mut EnergyTrace) -> Observer<'a> {
        self.trace = Some(trace);
        self
    }

    /// Reports `done` of `total` steps, if a progress callback is set.
    pub(crate) fn report(&mut self, done: u64, total: u64) {
        if let Some(progress) = self.progress.as_mut() {
            progress(Progress { done, total });
        }
    }

    /// Hands the finished generation's trace to the caller, if it asked for one.
    pub(crate) fn finish(self, trace: EnergyTrace) {
        if let Some(out) = self.trace {
            *out = trace;
        }
    }
}

impl fmt::Debug for Observer<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Observer")
            .field("progress", &self.progress.is_some())
            .field("trace", &self.trace)
            .finish()
    }
}

/// How far one generation has come: `done` of `total` steps. `total` is the same in every report
/// of a generation, and `done` never decreases.
///
/// The steps, per entry point:
/// - [`generate`](crate::generate): pixels ranked, of the volume's `width · height · depth`
///   (the initial pattern's relaxation reports 0).
/// - [`generate_baseline`](crate::generate_baseline): pixels ranked, of the volume's; a slice
///   animated from one 2D slice counts as ranked with that slice, so
///   [`GoldenRatio2D`](crate::BaselineKind::GoldenRatio2D) and
///   [`RandomShift2D`](crate::BaselineKind::RandomShift2D) advance `depth` pixels per pixel of
///   their slice.
/// - [`generate_vector`](crate::generate_vector): quarter passes (a quarter of a pass's tile
///   colours each), of `4 · (⌈swaps_per_pixel⌉ + assignment_passes)`; a multiple of 4 ends a pass.
/// - [`generate_filter_adapted`](crate::generate_filter_adapted) and
///   [`generate_filter_adapted_vector`](crate::generate_filter_adapted_vector): passes, of
///   `⌈swaps_per_pixel⌉`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Progress {
    /// Steps completed, `0..=total`.
    pub done: u64,
    /// Steps of the whole generation.
    pub total: u64,
}

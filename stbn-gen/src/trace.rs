//! Energy against work: what both swap optimisers report after each pass.

/// One point of an [`EnergyTrace`]: the totals after a pass (the first point is the initial
/// state, before any swap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    /// Swaps proposed so far (an assignment pass's moves count one each).
    pub swaps_attempted: u64,
    /// Swaps kept so far (an assignment pass's kept permutations count one each).
    pub swaps_accepted: u64,
    /// The running energy: the energy at the start plus the exact delta of every accepted swap
    /// or permutation (vector masks: [`crate::swap`]; filter-adapted masks, per pixel:
    /// [`crate::generate_filter_adapted_with_trace`]).
    pub energy: f64,
}

/// Energy against work: one [`TracePoint`] before optimisation and one after each pass.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnergyTrace {
    /// In order of work done.
    pub points: Vec<TracePoint>,
}

//! Energy against work: what both swap optimisers report after each pass
//! ([`Observer::with_trace`](crate::Observer::with_trace)).

/// One point of an [`EnergyTrace`]: the totals after a pass (the first point is the initial
/// state, before any swap).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    /// Swaps proposed so far (an assignment pass's moves count one each).
    pub swaps_attempted: u64,
    /// Swaps kept so far (an assignment pass's kept permutations count one each).
    pub swaps_accepted: u64,
    /// The running energy, dimensionless: the energy at the start plus the exact delta of every
    /// accepted swap or permutation. Vector masks: the paper's §4.2 energy summed over
    /// interacting pixel pairs ([`generate_vector`](crate::generate_vector)), `≥ 0`;
    /// filter-adapted masks: per pixel, relative to the start for the distance kernel
    /// ([`generate_filter_adapted`](crate::generate_filter_adapted)).
    pub energy: f64,
}

/// Energy against work: one [`TracePoint`] before optimisation and one after each pass, as
/// [`Observer::with_trace`](crate::Observer::with_trace) receives it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EnergyTrace {
    /// In order of work done.
    pub points: Vec<TracePoint>,
}

//! The filter-adapted optimiser checked against itself: exact incremental deltas and energies,
//! screening that only skips proposals, and the partner rule.

use super::filters::{FilterCombination, SpatialFilter, TemporalFilter};
use super::optimizer::{Energy, Optimizer, PARTNER_CANDIDATES};
use super::{FilterAdaptedSpec, ValueKernel, scalar_energy, vector_setup};
use crate::SampleSpace;

/// A scalar optimiser for `spec` over per-pixel ranks `ranks` (each frame a permutation), with
/// screening disabled when `screen` is `None`.
fn scalar_optimizer(spec: &FilterAdaptedSpec, ranks: Vec<u32>, screen: Option<f64>) -> Optimizer {
    spec.validate().expect("a valid spec");
    let (mut energy, _) = scalar_energy(spec, spec.slice_pixels() as usize);
    if let Energy::Distance { screen: kept, .. } = &mut energy {
        *kept = screen;
    }
    Optimizer::new(
        energy,
        (spec.width, spec.height, spec.depth),
        ranks,
        spec.seed,
    )
}

/// A vector optimiser for `spec` over `space`'s arranged stratified sets, as
/// [`super::generate_vector`] builds it, with screening disabled when `screen` is `None`.
fn vector_optimizer(
    spec: &FilterAdaptedSpec,
    space: &SampleSpace,
    screen: Option<f64>,
) -> Optimizer {
    spec.clone()
        .with_space(space.clone())
        .validate()
        .expect("a valid spec");
    let (_, mut energy, _) = vector_setup(spec, space).expect("a valid spec");
    if let Energy::Distance { screen: kept, .. } = &mut energy {
        *kept = screen;
    }
    let n = spec.slice_pixels() as u32;
    let perm = (0..spec.depth).flat_map(|_| 0..n).collect();
    Optimizer::new(
        energy,
        (spec.width, spec.height, spec.depth),
        perm,
        spec.seed,
    )
}

/// A seeded permutation of `0..n` per frame (a simple LCG shuffle: independent of the crate).
fn shuffled(n: usize, depth: usize, seed: u64) -> Vec<u32> {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as usize
    };
    let mut out = Vec::with_capacity(n * depth);
    for _ in 0..depth {
        let mut frame: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            frame.swap(i, next() % (i + 1));
        }
        out.extend(frame);
    }
    out
}

/// The filter configurations the exactness tests cover.
fn configurations() -> Vec<(SpatialFilter, TemporalFilter, FilterCombination)> {
    vec![
        (
            SpatialFilter::DEFAULT,
            TemporalFilter::DEFAULT,
            FilterCombination::Product,
        ),
        (
            SpatialFilter::Box { size: 3 },
            TemporalFilter::ExponentialHistory {
                alpha: 0.2,
                beta: 0.1,
            },
            FilterCombination::Separate {
                spatial_weight: 0.6,
            },
        ),
        (
            SpatialFilter::Binomial { order: 4 },
            TemporalFilter::Gaussian { sigma: 1.5 },
            FilterCombination::Product,
        ),
        (
            SpatialFilter::Gaussian { sigma: 0.8 },
            TemporalFilter::Box { size: 4 },
            FilterCombination::Separate {
                spatial_weight: 1.0,
            },
        ),
    ]
}

#[test]
fn deltas_are_exact_and_the_running_energy_matches_a_recomputation() {
    // 28×24 is two tiles wide at the default filter's reach (6 px): passes exercise the tiled
    // path with halos; 7×5 wraps a single tile around both axes.
    for (w, h, d) in [(28, 24, 4), (7, 5, 3)] {
        for (spatial, temporal, combination) in configurations() {
            for kernel in [ValueKernel::Distance, ValueKernel::Product] {
                let spec = FilterAdaptedSpec::new(w, h, d, 5)
                    .with_filters(spatial, temporal, combination)
                    .with_value_kernel(kernel);
                let n = (w * h) as usize;
                let mut o = scalar_optimizer(&spec, shuffled(n, d as usize, 9), None);
                let what = format!("{w}×{h}×{d} {spatial} / {temporal} / {combination} {kernel:?}");
                let start = o.recompute_energy();
                let running = |o: &Optimizer| {
                    // The distance energy runs relative to the start.
                    match kernel {
                        ValueKernel::Distance => start + o.energy(),
                        ValueKernel::Product => o.energy(),
                    }
                };
                assert_eq!(running(&o), start, "{what}");
                let mut state = 12345u64;
                let mut rand = |m: u32| {
                    state = state
                        .wrapping_mul(2862933555777941757)
                        .wrapping_add(3037000493);
                    ((state >> 33) % u64::from(m)) as u32
                };
                for _ in 0..40 {
                    let z = rand(d);
                    let (a, b) = ((rand(w), rand(h)), (rand(w), rand(h)));
                    let predicted = o.swap_delta(z, a, b);
                    let before = o.recompute_energy();
                    // Apply the swap by hand when it would be rejected, to check positive
                    // deltas too: swapping back restores the energy.
                    match o.try_swap(z, a, b) {
                        Some(delta) => {
                            assert_eq!(delta, predicted, "{what}");
                            assert_eq!(o.recompute_energy(), before + delta, "{what}");
                        }
                        None => assert!(predicted >= 0, "{what}: {predicted}"),
                    }
                    assert_eq!(running(&o), o.recompute_energy(), "{what}");
                }
                assert!(o.field_is_exact(), "{what}");
                for _ in 0..2 {
                    o.run_pass(1.0);
                    assert_eq!(running(&o), o.recompute_energy(), "{what}: after a pass");
                    assert!(o.field_is_exact(), "{what}: after a pass");
                }
                assert!(running(&o) < start, "{what}: no swap lowered the energy");
            }
        }
    }
}

#[test]
fn vector_deltas_are_exact() {
    for space in [
        SampleSpace::Vec { dims: 2 },
        SampleSpace::Vec { dims: 4 },
        SampleSpace::UnitVec1,
        SampleSpace::UnitVec3,
    ] {
        for kernel in [ValueKernel::Distance, ValueKernel::Product] {
            let spec = FilterAdaptedSpec::new(24, 24, 2, 8).with_value_kernel(kernel);
            // Screening only matters to the distance kernel.
            let screens: &[Option<f64>] = match kernel {
                ValueKernel::Distance => &[None, Some(1e-3)],
                ValueKernel::Product => &[None],
            };
            for &screen in screens {
                let mut o = vector_optimizer(&spec, &space, screen);
                let what = format!("{} {kernel:?} {screen:?}", space.name());
                let start = o.recompute_energy();
                let running = |o: &Optimizer| match kernel {
                    ValueKernel::Distance => start + o.energy(),
                    ValueKernel::Product => o.energy(),
                };
                let mut state = 99u64;
                let mut rand = |m: u32| {
                    state = state
                        .wrapping_mul(2862933555777941757)
                        .wrapping_add(3037000493);
                    ((state >> 33) % u64::from(m)) as u32
                };
                for _ in 0..12 {
                    let z = rand(2);
                    let (a, b) = ((rand(24), rand(24)), (rand(24), rand(24)));
                    let predicted = o.swap_delta(z, a, b);
                    if let Some(delta) = o.try_swap(z, a, b) {
                        assert_eq!(delta, predicted, "{what}");
                    }
                    assert_eq!(running(&o), o.recompute_energy(), "{what}");
                }
                o.run_pass(1.0);
                assert_eq!(running(&o), o.recompute_energy(), "{what}: after a pass");
                assert!(o.field_is_exact(), "{what}");
                assert!(running(&o) < start, "{what}");
            }
        }
    }
}

#[test]
fn screening_only_skips_proposals() {
    // With screening, every kept swap still has its exact delta (the running energy matches),
    // and fewer proposals are fully evaluated than without: under half of them with uniform
    // partners, under three quarters with the default nearest ones (whose deltas are closer to
    // 0, so the core decides fewer; measured 50%).
    let spec = FilterAdaptedSpec::new(32, 32, 6, 2);
    let ranks = shuffled(32 * 32, 6, 4);
    for (candidates, most) in [(1, 0.5), (PARTNER_CANDIDATES, 0.75)] {
        let optimizer = |screen| {
            scalar_optimizer(&spec, ranks.clone(), screen).with_partner_candidates(candidates)
        };
        let (mut screened, mut full) = (optimizer(Some(1e-3)), optimizer(None));
        let start = screened.recompute_energy();
        screened.run_pass(1.0);
        full.run_pass(1.0);
        assert_eq!(start + screened.energy(), screened.recompute_energy());
        let (attempted, evaluated, accepted) = (
            screened.swaps_attempted(),
            screened.swaps_screened(),
            screened.swaps_accepted(),
        );
        let (all, all_evaluated) = (full.swaps_attempted(), full.swaps_screened());
        assert_eq!(attempted, all);
        assert!(
            (evaluated as f64) < most * all_evaluated as f64,
            "{candidates} candidates: {evaluated} of {all_evaluated}"
        );
        assert!(accepted > 0 && accepted <= evaluated);
    }
}

#[test]
fn nearest_partners_beat_uniform_partners_from_stbn() {
    // The default partner rule's reason: from the STBN start, proposals to the nearest levels
    // of a few candidates lower the energy at least twice as much per pass as uniform partners
    // (32×32×16, 3 passes: 2.8×).
    let spec = FilterAdaptedSpec::new(32, 32, 16, 3);
    let stbn = crate::generate(
        &crate::MaskSpec::new(32, 32, 16, 3),
        crate::Observer::default(),
    )
    .unwrap()
    .ranks()
    .to_vec();
    let energy_after = |candidates: u32| {
        let mut o =
            scalar_optimizer(&spec, stbn.clone(), Some(1e-3)).with_partner_candidates(candidates);
        for _ in 0..3 {
            o.run_pass(1.0);
        }
        o.energy()
    };
    let (uniform, nearest) = (energy_after(1), energy_after(PARTNER_CANDIDATES));
    assert!(
        uniform < 0,
        "uniform partners lower the energy too: {uniform}"
    );
    assert!(
        nearest < 2 * uniform,
        "nearest {nearest} against uniform {uniform}"
    );
}

//! The swap optimiser checked against itself and through the vector generator: exact deltas and
//! running energies, extreme shapes and σs, and the partner rule against uniform partners.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{ASSIGNMENT_SET, SwapKernel, SwapOptimizer};
use crate::{
    EnergyTrace, InitialArrangement, Observer, SampleSpace, VectorSpec, VectorSpecError,
    VectorVolume,
};

/// The mask of `spec` and its energy trace.
fn generate_with_trace(spec: &VectorSpec) -> Result<(VectorVolume, EnergyTrace), VectorSpecError> {
    let mut trace = EnergyTrace::default();
    let volume = crate::generate_vector(spec, Observer::default().with_trace(&mut trace))?;
    Ok((volume, trace))
}

/// The bit patterns of `values` (`dims` components each) in sorted order: the multiset a slice
/// must keep.
pub(super) fn multiset(values: &[f32], dims: usize) -> Vec<Vec<u32>> {
    let mut bits: Vec<Vec<u32>> = values
        .chunks_exact(dims)
        .map(|value| value.iter().map(|c| c.to_bits()).collect())
        .collect();
    bits.sort_unstable();
    bits
}

/// Each slice's [`multiset`].
fn multisets(volume: &VectorVolume) -> Vec<Vec<Vec<u32>>> {
    let dims = volume.dims();
    volume
        .values()
        .chunks(volume.slice_pixels() * dims)
        .map(|slice| multiset(slice, dims))
        .collect()
}

#[test]
fn every_accepted_swap_lowers_the_exact_energy() {
    for (space, (w, h, d)) in [
        (SampleSpace::Vec { dims: 2 }, (9, 7, 4)),
        (SampleSpace::UnitVec3, (6, 5, 3)),
        (SampleSpace::Vec { dims: 1 }, (2, 2, 2)),
        (SampleSpace::Vec { dims: 4 }, (3, 1, 5)),
    ] {
        let spec = VectorSpec::new(w, h, d, 5, space.clone());
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let values: Vec<f32> = (0..w * h * d)
            .flat_map(|_| {
                let n = space.dims();
                (0..n).map(|_| rng.random::<f32>()).collect::<Vec<_>>()
            })
            .collect();
        let mut optimizer = SwapOptimizer::new(&spec, values);
        let mut accepted = 0;
        for _ in 0..300 {
            let z = rng.random_range(0..d);
            let a = (rng.random_range(0..w), rng.random_range(0..h));
            let b = (rng.random_range(0..w), rng.random_range(0..h));
            let before = optimizer.recompute_energy();
            let predicted = optimizer.swap_delta(z, a, b);
            let result = optimizer.try_swap(z, a, b);
            let after = optimizer.recompute_energy();
            let scale = before.abs().max(1.0);
            match result {
                Some(delta) => {
                    accepted += 1;
                    assert_eq!(delta, predicted);
                    assert!(
                        after < before,
                        "{}: accepted {delta} but {before} → {after}",
                        space.name()
                    );
                    assert!(
                        (before + delta - after).abs() < 1e-12 * scale,
                        "{} {delta}",
                        after - before
                    );
                }
                None => {
                    assert_eq!(before, after);
                    // The local delta is the exact change a swap would make.
                    if a != b {
                        let mut probe = optimizer.values();
                        let (ia, ib) = (
                            ((z * h + a.1) * w + a.0) as usize,
                            ((z * h + b.1) * w + b.0) as usize,
                        );
                        for c in 0..space.dims() {
                            probe.swap(ia * space.dims() + c, ib * space.dims() + c);
                        }
                        let swapped = optimizer.kernel().energy(&probe);
                        assert!(
                            (swapped - before - predicted).abs() < 1e-12 * scale,
                            "{}: predicted {predicted}, actual {}",
                            space.name(),
                            swapped - before
                        );
                        assert!(predicted > -1e-9, "{predicted}");
                    }
                }
            }
            assert!((optimizer.energy() - after).abs() < 1e-10 * scale);
        }
        assert!(accepted > 0, "{}: no swap accepted", space.name());
        assert_eq!(optimizer.swaps_attempted(), 300);
        assert_eq!(optimizer.swaps_accepted(), accepted);
    }
}

#[test]
fn running_energy_matches_a_recomputation_after_passes() {
    let spec = VectorSpec::new(24, 16, 6, 3, SampleSpace::UnitVec2)
        .with_swaps_per_pixel(6.5)
        .with_assignment_passes(0);
    let (volume, trace) = generate_with_trace(&spec).unwrap();
    let exact = SwapKernel::new(&spec).energy(volume.values());
    let running = trace.points.last().unwrap().energy;
    assert!(
        (running - exact).abs() < 1e-9 * exact,
        "running {running}, exact {exact}"
    );
    // 6 whole passes and a half one, each attempting one swap per pixel (half for the last).
    let pixels = 24 * 16 * 6;
    assert_eq!(trace.points.len(), 8);
    assert_eq!(trace.points[6].swaps_attempted, 6 * pixels);
    assert_eq!(trace.points[7].swaps_attempted, 6 * pixels + pixels / 2);

    // The cached per-pixel energies stay exact too.
    let mut optimizer = SwapOptimizer::new(&spec, volume.values().to_vec());
    for _ in 0..3 {
        optimizer.run_pass(1.0, &mut |_| {});
    }
    assert!(
        optimizer.pixel_energy_drift() < 1e-12,
        "{}",
        optimizer.pixel_energy_drift()
    );
    let exact = optimizer.recompute_energy();
    assert!((optimizer.energy() - exact).abs() < 1e-9 * exact);
}

#[test]
fn extreme_shapes_generate_and_keep_their_multisets() {
    let shapes = [
        (1, 1, 1),
        (1, 9, 1),
        (9, 1, 3),
        (2, 2, 2),
        (17, 31, 5),
        (20, 12, 1),
        (1, 1, 7),
        (3, 64, 2),
    ];
    for (w, h, d) in shapes {
        for space in [
            SampleSpace::Vec { dims: 2 },
            SampleSpace::UnitVec1,
            SampleSpace::CosineHemisphere,
        ] {
            for arrangement in [
                InitialArrangement::Random,
                InitialArrangement::ScalarStbn,
                InitialArrangement::ScalarStbnPerAxis,
            ] {
                let spec = VectorSpec {
                    initial_arrangement: arrangement,
                    ..VectorSpec::new(w, h, d, 4, space.clone()).with_swaps_per_pixel(2.0)
                };
                let (before, _) = generate_with_trace(&spec.clone().unoptimised()).unwrap();
                let (after, trace) = generate_with_trace(&spec).unwrap();
                assert_eq!((after.width(), after.height(), after.depth()), (w, h, d));
                assert_eq!(after.values().len(), (w * h * d) as usize * space.dims());
                assert_eq!(
                    multisets(&before),
                    multisets(&after),
                    "{w}x{h}x{d} {}",
                    space.name()
                );
                let exact = SwapKernel::new(&spec).energy(after.values());
                let running = trace.points.last().unwrap().energy;
                assert!(
                    (running - exact).abs() <= 1e-9 * exact.max(1.0),
                    "{w}x{h}x{d}: {running} vs {exact}"
                );
                if w * h == 1 {
                    assert_eq!(trace.points.last().unwrap().swaps_attempted, 0);
                }
            }
        }
    }
}

#[test]
fn tiny_and_huge_value_sigma_terminate() {
    // Vec3's assignment passes cost exactly, Vec2's on models; 1e-20 overflows 1/σs² in single
    // precision, 1e20 underflows it. The generator refuses all four (the factors underflow or
    // round to 1); the optimiser driven directly still terminates and keeps each slice.
    let spaces = [SampleSpace::Vec { dims: 3 }, SampleSpace::Vec { dims: 2 }];
    for (sigma_value, space) in [1e-20, 1e-6, 1e6, 1e20]
        .into_iter()
        .flat_map(|s| spaces.iter().map(move |space| (s, space.clone())))
    {
        let valid = VectorSpec::new(16, 12, 4, 2, space).with_swaps_per_pixel(3.0);
        let spec = VectorSpec {
            sigma_value,
            ..valid.clone()
        };
        let refusal = generate_with_trace(&spec).unwrap_err().to_string();
        assert!(refusal.contains("`sigma_value`"), "{refusal}");
        let (before, _) = generate_with_trace(&valid.unoptimised()).unwrap();
        let mut optimizer = SwapOptimizer::new(&spec, before.values().to_vec());
        let mut energies = vec![optimizer.energy()];
        for _ in 0..3 {
            energies.push(optimizer.run_pass(1.0, &mut |_| {}).energy);
        }
        assert_eq!(optimizer.swaps_attempted(), 3 * 16 * 12 * 4);
        for _ in 0..VectorSpec::DEFAULT_ASSIGNMENT_PASSES {
            energies.push(
                optimizer
                    .run_assignment_pass(ASSIGNMENT_SET, &mut |_| {})
                    .energy,
            );
        }
        for pair in energies.windows(2) {
            assert!(pair[1] <= pair[0]);
        }
        let after = VectorVolume::new((16, 12, 4), &spec.space, optimizer.into_values());
        assert_eq!(multisets(&before), multisets(&after));
    }
    // Huge σi (the largest accepted, 1.7 slice lengths): the footprint covers whole (small)
    // slices and many frames.
    let spec = VectorSpec {
        sigma_image: 10.2,
        ..VectorSpec::new(6, 5, 3, 2, SampleSpace::UnitVec2).with_swaps_per_pixel(2.0)
    };
    let (volume, trace) = generate_with_trace(&spec).unwrap();
    let exact = SwapKernel::new(&spec).energy(volume.values());
    assert!((trace.points.last().unwrap().energy - exact).abs() < 1e-9 * exact);
}

#[test]
fn partners_nearest_in_value_beat_uniform_partners() {
    // The optimiser's proposal rule against uniform partners, from the same start, for the same
    // number of passes: the rule must end at a lower energy.
    for space in [SampleSpace::Vec { dims: 2 }, SampleSpace::UnitVec3] {
        let spec = VectorSpec::new(32, 32, 16, 4, space.clone()).unoptimised();
        let start = generate_with_trace(&spec).unwrap().0.values().to_vec();
        let run = |optimizer: SwapOptimizer| {
            let mut optimizer = optimizer;
            for _ in 0..48 {
                optimizer.run_pass(1.0, &mut |_| {});
            }
            optimizer.energy()
        };
        let nearest = run(SwapOptimizer::new(&spec, start.clone()));
        let uniform = run(SwapOptimizer::new(&spec, start).with_partner_candidates(1));
        eprintln!(
            "{}: nearest {nearest:.3}, uniform {uniform:.3}",
            space.name()
        );
        assert!(nearest < uniform, "{}: {nearest} ≥ {uniform}", space.name());
    }
}

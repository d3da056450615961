//! The vector generator and its swap optimiser: per-slice multisets, exact energies, thread-count
//! determinism, spectra, extreme shapes and parameters, and spec validation.

use std::sync::Arc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stbn_gen::analysis::{Field, spatial_low_band, temporal_low_band};
use stbn_gen::baselines::white_noise;
use stbn_gen::swap::SwapOptimizer;
use stbn_gen::{
    ImagePdf, InitialArrangement, SampleSpace, VectorSpec, VectorSpecError, VectorVolume,
    generate_vector,
};

/// Each slice's values as sorted bit patterns (the slice's multiset).
fn slice_multisets(volume: &VectorVolume) -> Vec<Vec<Vec<u32>>> {
    (0..volume.depth())
        .map(|z| {
            let mut values: Vec<Vec<u32>> = volume
                .slice_values(z)
                .chunks_exact(volume.dims())
                .map(|v| v.iter().map(|c| c.to_bits()).collect())
                .collect();
            values.sort_unstable();
            values
        })
        .collect()
}

fn image() -> Arc<ImagePdf> {
    let lum = (0..64).map(|i| ((i * 37) % 11) as f32 * 0.5).collect();
    Arc::new(ImagePdf::from_luminance(8, 8, lum).unwrap())
}

fn every_space() -> Vec<SampleSpace> {
    vec![
        SampleSpace::Vec { dims: 1 },
        SampleSpace::Vec { dims: 2 },
        SampleSpace::Vec { dims: 3 },
        SampleSpace::Vec { dims: 4 },
        SampleSpace::UnitVec1,
        SampleSpace::UnitVec2,
        SampleSpace::UnitVec3,
        SampleSpace::UniformHemisphere,
        SampleSpace::CosineHemisphere,
        SampleSpace::ImagePoints(image()),
        SampleSpace::EnvironmentDirections(image()),
    ]
}

#[test]
fn optimisation_keeps_each_slice_multiset_and_lowers_the_energy() {
    for space in every_space() {
        let spec = VectorSpec::new(12, 10, 4, 21, space.clone());
        // No optimisation at all, then 3 swap passes and the default assignment passes.
        let unoptimised = spec.clone().unoptimised();
        let (before, start) = generate_vector(&unoptimised).unwrap();
        let (after, trace) = generate_vector(&spec.clone().with_swaps_per_pixel(3.0)).unwrap();
        assert_eq!(
            slice_multisets(&before),
            slice_multisets(&after),
            "{}",
            space.name()
        );
        assert_ne!(
            before.values(),
            after.values(),
            "{}: nothing moved",
            space.name()
        );
        assert_eq!(start.points.len(), 1);
        assert_eq!(
            trace.points.len(),
            1 + 3 + VectorSpec::DEFAULT_ASSIGNMENT_PASSES as usize
        );
        assert_eq!(trace.points[0], start.points[0]);
        for pair in trace.points.windows(2) {
            assert!(
                pair[1].energy <= pair[0].energy,
                "{}: {pair:?}",
                space.name()
            );
            assert!(pair[1].swaps_attempted > pair[0].swaps_attempted);
        }
        assert!(
            trace.points[3].energy < trace.points[0].energy,
            "{}",
            space.name()
        );
        assert_eq!(after.pdf().is_some(), space.stores_pdf());
        if let Some(pdf) = after.pdf() {
            for (p, v) in pdf.iter().zip(after.values().chunks_exact(space.dims())) {
                assert_eq!(*p, space.pdf(v));
                assert!(*p > 0.0);
            }
        }
    }
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
    let (volume, trace) = generate_vector(&spec).unwrap();
    let exact = stbn_gen::swap::SwapKernel::new(&spec).energy(volume.values());
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
fn output_is_identical_for_any_thread_count() {
    let spaces = [
        SampleSpace::UnitVec3,
        SampleSpace::Vec { dims: 2 },
        SampleSpace::EnvironmentDirections(image()),
    ];
    for space in spaces {
        let spec = VectorSpec::new(40, 36, 6, 77, space.clone())
            .with_swaps_per_pixel(2.5)
            .with_assignment_passes(2);
        let runs: Vec<_> = [1, 2, 3]
            .into_iter()
            .map(|threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| generate_vector(&spec).unwrap())
            })
            .collect();
        for run in &runs[1..] {
            let bits =
                |v: &VectorVolume| v.values().iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&run.0), bits(&runs[0].0), "{}", space.name());
            assert_eq!(run.0.pdf(), runs[0].0.pdf());
            assert_eq!(run.1, runs[0].1);
        }
    }
}

#[test]
fn seeds_matter() {
    let spec = VectorSpec::new(16, 16, 4, 1, SampleSpace::UnitVec2).with_swaps_per_pixel(1.0);
    let other = VectorSpec {
        seed: 2,
        ..spec.clone()
    };
    assert_ne!(
        generate_vector(&spec).unwrap().0,
        generate_vector(&other).unwrap().0
    );
    assert_eq!(
        generate_vector(&spec).unwrap(),
        generate_vector(&spec).unwrap()
    );
}

/// Spatial and temporal low-band power of one component (mapped to `[0, 1]`).
fn low_bands(volume: &VectorVolume, component: usize, signed: bool) -> (f64, f64) {
    let values: Vec<f64> = volume
        .values()
        .chunks_exact(volume.dims())
        .map(|v| {
            let x = f64::from(v[component]);
            if signed { x * 0.5 + 0.5 } else { x }
        })
        .collect();
    let (w, h, d) = (
        volume.width() as usize,
        volume.height() as usize,
        volume.depth() as usize,
    );
    let field = Field::new(w, h, d, &values).unwrap();
    (
        spatial_low_band(&field).unwrap(),
        temporal_low_band(&field).unwrap(),
    )
}

#[test]
fn masks_are_blue_in_space_and_time() {
    let white = white_noise(32, 32, 16, 4);
    let white = Field::new(32, 32, 16, &white).unwrap();
    let (white_s, white_t) = (
        spatial_low_band(&white).unwrap(),
        temporal_low_band(&white).unwrap(),
    );
    assert!(white_s > 0.7 && white_t > 0.7, "{white_s} {white_t}");

    // The swap optimiser alone, from white noise.
    let spec = VectorSpec {
        initial_arrangement: InitialArrangement::Random,
        ..VectorSpec::new(32, 32, 16, 8, SampleSpace::Vec { dims: 1 }).with_swaps_per_pixel(16.0)
    };
    let unoptimised = spec.clone().unoptimised();
    let (start, _) = generate_vector(&unoptimised).unwrap();
    let (volume, _) = generate_vector(&spec).unwrap();
    let (s0, t0) = low_bands(&start, 0, false);
    let (s, t) = low_bands(&volume, 0, false);
    eprintln!("vec1 from white noise: spatial {s0:.3} → {s:.4}, temporal {t0:.3} → {t:.4}");
    assert!(s0 > 0.7 && t0 > 0.7);
    assert!(
        s < 0.15 * white_s && t < 0.5 * white_t,
        "spatial {s}, temporal {t}"
    );

    // The default: scalar-STBN arrangement, then swaps.
    for (space, signed) in [
        (SampleSpace::Vec { dims: 1 }, false),
        (SampleSpace::Vec { dims: 2 }, false),
        (SampleSpace::UnitVec3, true),
    ] {
        let spec = VectorSpec::new(32, 32, 16, 8, space.clone()).with_swaps_per_pixel(8.0);
        let (volume, _) = generate_vector(&spec).unwrap();
        for c in 0..space.dims() {
            let (s, t) = low_bands(&volume, c, signed);
            eprintln!(
                "{} component {c}: spatial {s:.4}, temporal {t:.4}",
                space.name()
            );
            assert!(
                s < 0.15 * white_s && t < 0.5 * white_t,
                "{} component {c}: {s} {t}",
                space.name()
            );
        }
    }
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
            for arrangement in [InitialArrangement::Random, InitialArrangement::ScalarStbn] {
                let spec = VectorSpec {
                    initial_arrangement: arrangement,
                    ..VectorSpec::new(w, h, d, 4, space.clone()).with_swaps_per_pixel(2.0)
                };
                let (before, _) = generate_vector(&spec.clone().unoptimised()).unwrap();
                let (after, trace) = generate_vector(&spec).unwrap();
                assert_eq!((after.width(), after.height(), after.depth()), (w, h, d));
                assert_eq!(after.values().len(), (w * h * d) as usize * space.dims());
                assert_eq!(
                    slice_multisets(&before),
                    slice_multisets(&after),
                    "{w}x{h}x{d} {}",
                    space.name()
                );
                let exact = stbn_gen::swap::SwapKernel::new(&spec).energy(after.values());
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
    for sigma_value in [1e-6, 1e6] {
        let spec = VectorSpec {
            sigma_value,
            ..VectorSpec::new(16, 12, 4, 2, SampleSpace::Vec { dims: 3 }).with_swaps_per_pixel(3.0)
        };
        let (before, _) = generate_vector(&spec.clone().unoptimised()).unwrap();
        let (after, trace) = generate_vector(&spec).unwrap();
        assert_eq!(slice_multisets(&before), slice_multisets(&after));
        // 3 swap passes, then the default assignment passes.
        assert_eq!(trace.points[3].swaps_attempted, 3 * 16 * 12 * 4);
        assert_eq!(
            trace.points.len(),
            4 + VectorSpec::DEFAULT_ASSIGNMENT_PASSES as usize
        );
        for pair in trace.points.windows(2) {
            assert!(pair[1].energy <= pair[0].energy);
        }
    }
    // Huge σi: the footprint covers whole (small) slices and many frames.
    let spec = VectorSpec {
        sigma_image: 40.0,
        ..VectorSpec::new(6, 5, 3, 2, SampleSpace::UnitVec2).with_swaps_per_pixel(2.0)
    };
    let (volume, trace) = generate_vector(&spec).unwrap();
    let exact = stbn_gen::swap::SwapKernel::new(&spec).energy(volume.values());
    assert!((trace.points.last().unwrap().energy - exact).abs() < 1e-9 * exact);
}

#[test]
fn invalid_specs_are_refused_before_allocating() {
    let base = VectorSpec::new(8, 8, 8, 0, SampleSpace::UnitVec3);
    assert_eq!(base.validate(), Ok(()));
    let cases: Vec<(VectorSpec, &str)> = vec![
        (
            VectorSpec {
                width: 0,
                ..base.clone()
            },
            "`width`",
        ),
        (
            VectorSpec {
                depth: 1 << 17,
                ..base.clone()
            },
            "`depth`",
        ),
        (
            VectorSpec {
                width: 8192,
                height: 8192,
                depth: 2,
                ..base.clone()
            },
            "GiB",
        ),
        (
            VectorSpec {
                space: SampleSpace::Vec { dims: 0 },
                ..base.clone()
            },
            "`dims`",
        ),
        (
            VectorSpec {
                space: SampleSpace::Vec { dims: 5 },
                ..base.clone()
            },
            "`dims`",
        ),
        (
            VectorSpec {
                sigma_image: 0.0,
                ..base.clone()
            },
            "`sigma_image`",
        ),
        (
            VectorSpec {
                sigma_value: f64::NAN,
                ..base.clone()
            },
            "`sigma_value`",
        ),
        (
            VectorSpec {
                kernel_tolerance: 0.0,
                ..base.clone()
            },
            "`kernel_tolerance`",
        ),
        (base.clone().with_swaps_per_pixel(-1.0), "`swaps_per_pixel`"),
        (
            base.clone().with_swaps_per_pixel(f64::NAN),
            "`swaps_per_pixel`",
        ),
        (base.clone().with_swaps_per_pixel(1e9), "`swaps_per_pixel`"),
    ];
    for (spec, needle) in cases {
        let err = generate_vector(&spec).unwrap_err();
        let message = err.to_string();
        assert!(message.contains(needle), "{message:?} lacks {needle:?}");
    }
    let big = VectorSpec {
        width: 8192,
        height: 8192,
        depth: 2,
        ..base
    };
    match big.validate() {
        Err(VectorSpecError::TooLarge { bytes_needed, .. }) => {
            assert_eq!(bytes_needed, big.pixels() * big.bytes_per_pixel())
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn volume_accessors_agree() {
    let spec = VectorSpec::new(5, 4, 3, 1, SampleSpace::UnitVec2).with_swaps_per_pixel(1.0);
    let (volume, _) = generate_vector(&spec).unwrap();
    assert_eq!(volume.dims(), 2);
    assert_eq!(volume.slice_pixels(), 20);
    assert_eq!(volume.value(4, 3, 2), &volume.values()[(59 * 2)..(60 * 2)]);
    assert_eq!(volume.slice_values(1), &volume.values()[40..80]);
    assert_eq!(volume.pdf(), None);
}

/// FNV-1a over the values' little-endian bits: a digest stable across Rust releases.
fn value_digest(volume: &VectorVolume) -> u64 {
    volume
        .values()
        .iter()
        .flat_map(|v| v.to_bits().to_le_bytes())
        .fold(0xcbf2_9ce4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
}

#[test]
fn vector_output_is_pinned_to_the_generator_version() {
    // If this fails, the vector generator's output changed: bump `GENERATOR_VERSION` (so caches
    // regenerate) and record the new digests here.
    let pinned: [(u32, [u64; 2]); 3] = [
        (2, [0xe771_d128_545c_0a6e, 0x1e35_58a8_091d_8515]),
        (3, [0xd8ff_adde_347a_3f4a, 0x5f23_3700_e909_b65d]),
        (4, [0x0a80_1d94_e495_758e, 0x4eb2_1f0c_9762_b331]),
    ];
    let digests = [SampleSpace::Vec { dims: 2 }, SampleSpace::UnitVec3].map(|space| {
        let spec = VectorSpec::new(16, 16, 8, 2026, space).with_swaps_per_pixel(4.0);
        value_digest(&generate_vector(&spec).unwrap().0)
    });
    let expected = pinned
        .iter()
        .find(|(version, _)| *version == stbn_gen::GENERATOR_VERSION)
        .map(|&(_, digests)| digests);
    assert_eq!(Some(digests), expected, "digests {digests:#018x?}");
}

#[test]
fn partners_nearest_in_value_beat_uniform_partners() {
    // The optimiser's proposal rule against uniform partners, from the same start, for the same
    // number of passes: the rule must end at a lower energy.
    for space in [SampleSpace::Vec { dims: 2 }, SampleSpace::UnitVec3] {
        let spec = VectorSpec::new(32, 32, 16, 4, space.clone()).unoptimised();
        let start = generate_vector(&spec).unwrap().0.values().to_vec();
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

//! The working range of every σ: swept across decades for each family of masks, every value is
//! either refused with a message naming the field and its range, or gives a mask measurably
//! better than its start. Tiny masks, so the sweep takes seconds.

use std::f64::consts::PI;

use stbn_gen::analysis::{Field, spatial_power, temporal_spectrum};
use stbn_gen::{
    BaselineKind, BaselineSpec, EnergyTopology, EnergyTrace, FilterAdaptedSpec, FilterCombination,
    MaskSpec, Observer, SampleSpace, SpatialFilter, TemporalFilter, VectorSpec, generate,
    generate_baseline, generate_filter_adapted, generate_vector,
};

/// Every decade from 1e-300 to 1e300 (coarsely at the extremes), the values that break
/// arithmetic, and values near the bounds of small masks.
fn sweep() -> Vec<f64> {
    let mut values = vec![
        0.0,
        -0.0,
        -1.0,
        -1e300,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        5e-324,
        f64::MIN_POSITIVE,
        f64::MAX,
    ];
    for exponent in (-300..=300).step_by(50) {
        values.push(10f64.powi(exponent));
    }
    for exponent in -20..=20 {
        values.push(10f64.powi(exponent));
    }
    values.extend([
        0.2, 0.3, 0.31, 0.4, 0.44, 0.5, 0.7, 1.5, 1.9, 3.0, 4.0, 4.4, 4.5, 6.0, 8.0, 8.8, 9.0,
        13.6, 14.0, 3e3, 4e3, 4.4e3, 5e3,
    ]);
    values
}

/// Asserts that `message` names `field` and states a range.
fn assert_refusal(message: &str, field: &str, value: f64) {
    assert!(
        message.contains(&format!("`{field}`")),
        "{field} = {value:e}: {message:?} does not name the field"
    );
    assert!(
        [
            "must be in",
            "must be at least",
            "must be finite",
            "it must be"
        ]
        .iter()
        .any(|needle| message.contains(needle)),
        "{field} = {value:e}: {message:?} states no range"
    );
}

/// The mask's values as a field.
fn field(w: u32, h: u32, d: u32, values: &[f64]) -> Field<'_> {
    Field::new(w as usize, h as usize, d as usize, values).unwrap()
}

/// The spectrum of the truncated kernel void-and-cluster uses for σ `sigmas` along axes of
/// `sizes` pixels, at the default tolerance: `Σ exp(−Σ oᵢ²/(2σᵢ²)) cos(2π ν·o)` over the offsets
/// `o` whose weight is at least the tolerance, at most two periods out (as the kernel enumerates
/// them), for every frequency `ν` of the axes (index as the analysis module's: the last axis
/// varies slowest). Less its mean over the non-DC frequencies, DC set to 0.
fn kernel_spectrum(sizes: &[usize], sigmas: &[f64]) -> Vec<f64> {
    let cutoff = 2.0 * (1.0 / MaskSpec::DEFAULT_KERNEL_TOLERANCE).ln();
    let reach: Vec<(i64, i64)> = sizes
        .iter()
        .zip(sigmas)
        .map(|(&n, &sigma)| {
            let r = ((sigma * cutoff.sqrt()).floor() as i64).min(2 * n as i64);
            (-r, r)
        })
        .collect();
    spectrum(sizes, &reach, |o| {
        let q: f64 = o
            .iter()
            .zip(sigmas)
            .map(|(&d, &sigma)| (d * d) as f64 / (sigma * sigma))
            .sum();
        if q > cutoff { 0.0 } else { (-0.5 * q).exp() }
    })
}

/// [`kernel_spectrum`] of Tellusim's layer kernel `exp(−d²/σ²) + 0.01 / (1 + d²)` over the
/// slice's shortest offsets, untruncated, for σ `sigma` in Tellusim's convention.
fn tellusim_spectrum(w: usize, h: usize, sigma: f64) -> Vec<f64> {
    let half = |n: usize| (-((n as i64 - 1) / 2), n as i64 / 2);
    spectrum(&[w, h], &[half(w), half(h)], |o| {
        let d2 = (o[0] * o[0] + o[1] * o[1]) as f64;
        (-d2 / (sigma * sigma)).exp() + 0.01 / (1.0 + d2)
    })
}

/// `Σ weight(o) cos(2π ν·o)` over the offsets `o` in `ranges` (inclusive, per axis), for every
/// frequency `ν` of axes of `sizes`, less its mean over the non-DC frequencies, DC set to 0.
fn spectrum(sizes: &[usize], ranges: &[(i64, i64)], weight: impl Fn(&[i64]) -> f64) -> Vec<f64> {
    let count: usize = sizes.iter().product();
    let mut offsets = vec![Vec::new()];
    for &(low, high) in ranges {
        offsets = offsets
            .iter()
            .flat_map(|o: &Vec<i64>| {
                (low..=high).map(move |d| {
                    let mut o = o.clone();
                    o.push(d);
                    o
                })
            })
            .collect();
    }
    let mut spectrum = vec![0.0; count];
    for o in &offsets {
        let weight = weight(o);
        if weight == 0.0 {
            continue;
        }
        for (index, k) in spectrum.iter_mut().enumerate() {
            let (mut rest, mut phase) = (index, 0.0);
            for (axis, &n) in sizes.iter().enumerate() {
                phase += (rest % n) as f64 * o[axis] as f64 / n as f64;
                rest /= n;
            }
            *k += weight * (2.0 * PI * phase).cos();
        }
    }
    let mean = spectrum[1..].iter().sum::<f64>() / (count - 1) as f64;
    spectrum[0] = mean;
    spectrum.iter().map(|k| k - mean).collect()
}

/// `Σ P(ν) K(ν) / Σ |K(ν)|` over the non-DC frequencies, for the mask's power `P` and a kernel
/// spectrum from [`kernel_spectrum`]: by Parseval the energy void-and-cluster lowers, less its
/// constant part, on a fixed scale. About 0 for white noise, negative for a mask the energy
/// ordered.
fn figure(power: &[f64], kernel: &[f64]) -> f64 {
    let dot: f64 = power.iter().zip(kernel).skip(1).map(|(p, k)| p * k).sum();
    let norm: f64 = kernel.iter().skip(1).map(|k| k.abs()).sum();
    dot / norm
}

/// [`figure`] of the mask's spatial power for the kernel of σ `sigma`.
fn spatial_figure(f: &Field, sigma: f64) -> f64 {
    let kernel = kernel_spectrum(&[f.width(), f.height()], &[sigma, sigma]);
    figure(&spatial_power(f), &kernel)
}

/// [`figure`] of each pixel's series over time for the kernel of σ `sigma` (the spectrum's
/// half `0..=depth/2`, the other half mirroring it).
fn temporal_figure(f: &Field, sigma: f64) -> f64 {
    let power = temporal_spectrum(f);
    let kernel = kernel_spectrum(&[f.depth()], &[sigma]);
    figure(&power, &kernel[..power.len()])
}

/// The power of the whole volume's values per 3D frequency (a separable DFT of the values less
/// their mean, index `(ft · height + fy) · width + fx`), scaled so that its mean over the non-DC
/// frequencies is 1.
fn volume_power(f: &Field) -> Vec<f64> {
    let sizes = [f.width(), f.height(), f.depth()];
    let values = f.values();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let mut data: Vec<(f64, f64)> = values.iter().map(|v| (v - mean, 0.0)).collect();
    let mut stride = 1;
    for &n in &sizes {
        let mut next = data.clone();
        for (index, out) in next.iter_mut().enumerate() {
            let k = index / stride % n;
            let base = index - k * stride;
            let (mut re, mut im) = (0.0, 0.0);
            for j in 0..n {
                let (a, b) = data[base + j * stride];
                let phase = -2.0 * PI * (k * j) as f64 / n as f64;
                let (c, s) = (phase.cos(), phase.sin());
                re += a * c - b * s;
                im += a * s + b * c;
            }
            *out = (re, im);
        }
        data = next;
        stride *= n;
    }
    let power: Vec<f64> = data.iter().map(|(re, im)| re * re + im * im).collect();
    let scale = power[1..].iter().sum::<f64>() / (power.len() - 1) as f64;
    power.iter().map(|p| p / scale).collect()
}

/// [`figure`] of the volume's 3D power for the isotropic kernel of σs `(sigma_xy, sigma_xy,
/// sigma_z)`.
fn volume_figure(f: &Field, sigma_xy: f64, sigma_z: f64) -> f64 {
    let kernel = kernel_spectrum(
        &[f.width(), f.height(), f.depth()],
        &[sigma_xy, sigma_xy, sigma_z],
    );
    figure(&volume_power(f), &kernel)
}

/// [`spatial_figure`] or [`temporal_figure`] of white noise at `w × h × d`, averaged over
/// seeds: the start a void-and-cluster mask improves on.
fn white_figure(w: u32, h: u32, d: u32, measure: &dyn Fn(&Field) -> f64) -> f64 {
    let seeds = 8;
    let total: f64 = (0..seeds)
        .map(|seed| {
            let spec = BaselineSpec::new(BaselineKind::White, w, h, d, seed);
            let values = generate_baseline(&spec, Observer::default())
                .unwrap()
                .values();
            measure(&field(w, h, d, &values))
        })
        .sum();
    total / f64::from(seeds as u32)
}

/// A mask is measurably better than white noise when its [`figure`] is below white noise's by
/// this much.
const BETTER: f64 = 0.05;

#[test]
fn void_and_cluster_sigmas_are_refused_or_give_blue_noise() {
    let (w, h, d) = (8, 8, 16);
    let mut accepted = 0;
    let mut failures = Vec::new();
    for topology in [
        EnergyTopology::Spatiotemporal,
        EnergyTopology::Independent2D,
        EnergyTopology::Isotropic3D,
    ] {
        for z in [false, true] {
            for value in sweep() {
                let mut spec = MaskSpec::new(w, h, d, 3).with_topology(topology);
                let name = if z {
                    spec.sigma_z = value;
                    "sigma_z"
                } else {
                    spec.sigma_xy = value;
                    "sigma_xy"
                };
                let values = match generate(&spec, Observer::default()) {
                    Err(e) => {
                        assert_refusal(&e.to_string(), name, value);
                        continue;
                    }
                    Ok(volume) => volume.values(),
                };
                let Some(range) = spec.sigma_range(z) else {
                    // Independent2D reads no `sigma_z`: any σ that keeps `1/σ²` finite is
                    // accepted and changes nothing.
                    assert_eq!(topology, EnergyTopology::Independent2D);
                    let reference = MaskSpec::new(w, h, d, 3).with_topology(topology);
                    assert_eq!(
                        generate(&reference, Observer::default()).unwrap().values(),
                        values
                    );
                    continue;
                };
                assert!(range.contains(value), "{name} {value:e} outside {range}");
                // Each topology by the energy it lowers: the slices' and the pixels' series for
                // the spatiotemporal one, the slices for 2D, the whole volume for 3D.
                let measure = |f: &Field| match (topology, z) {
                    (EnergyTopology::Isotropic3D, _) => {
                        volume_figure(f, spec.sigma_xy, spec.sigma_z)
                    }
                    (_, true) => temporal_figure(f, value),
                    (_, false) => spatial_figure(f, value),
                };
                let figure = measure(&field(w, h, d, &values));
                let white = white_figure(w, h, d, &measure);
                if figure >= white - BETTER {
                    failures.push(format!(
                        "{topology:?} {name} = {value:e}: figure {figure:.3} against white \
                         noise's {white:.3}"
                    ));
                }
                accepted += 1;
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(accepted > 40, "only {accepted} values accepted");
}

#[test]
fn baseline_sigmas_are_refused_or_give_blue_slices() {
    let (w, h, d) = (8, 8, 4);
    for kind in [
        BaselineKind::GoldenRatio2D,
        BaselineKind::RandomShift2D,
        BaselineKind::TellusimLayered,
    ] {
        for value in sweep() {
            let mut spec = BaselineSpec::new(kind, w, h, d, 3);
            spec.mask.sigma_xy = value;
            let values = match generate_baseline(&spec, Observer::default()) {
                Err(e) => {
                    assert_refusal(&e.to_string(), "sigma_xy", value);
                    continue;
                }
                Ok(volume) => volume.values(),
            };
            // Tellusim's σ is in its convention, for its own kernel.
            let measure = |f: &Field| {
                if kind == BaselineKind::TellusimLayered {
                    figure(
                        &spatial_power(f),
                        &tellusim_spectrum(f.width(), f.height(), value),
                    )
                } else {
                    spatial_figure(f, value)
                }
            };
            let figure = measure(&field(w, h, d, &values));
            let white = white_figure(w, h, d, &measure);
            assert!(
                figure < white - BETTER,
                "{kind:?} sigma {value:e}: figure {figure:.3} against white noise's {white:.3}"
            );
        }
    }
}

/// The vector spaces of the sweep: the two the optimiser's underflow was found on, and a sphere.
fn spaces() -> [SampleSpace; 3] {
    [
        SampleSpace::Vec { dims: 2 },
        SampleSpace::CosineHemisphere,
        SampleSpace::UnitVec3,
    ]
}

#[test]
fn vector_sigmas_are_refused_or_lower_the_energy() {
    let (w, h, d) = (8, 8, 4);
    for space in spaces() {
        for field in ["sigma_image", "sigma_value"] {
            let mut accepted = 0;
            for value in sweep() {
                let mut spec = VectorSpec::new(w, h, d, 3, space.clone())
                    .with_swaps_per_pixel(2.0)
                    .with_assignment_passes(1);
                if field == "sigma_image" {
                    spec.sigma_image = value;
                } else {
                    spec.sigma_value = value;
                }
                let mut trace = EnergyTrace::default();
                let result = generate_vector(&spec, Observer::default().with_trace(&mut trace));
                if let Err(e) = result {
                    assert_refusal(&e.to_string(), field, value);
                    continue;
                }
                let (first, last) = (trace.points[0], *trace.points.last().unwrap());
                assert!(
                    last.swaps_accepted > 0 && last.energy < first.energy,
                    "{} {field} = {value:e}: {} of {} swaps kept, energy {} → {}",
                    space.name(),
                    last.swaps_accepted,
                    last.swaps_attempted,
                    first.energy,
                    last.energy
                );
                accepted += 1;
            }
            assert!(
                accepted > 10,
                "{} {field}: only {accepted} accepted",
                space.name()
            );
        }
    }
}

/// Vec2 and the cosine hemisphere at 32×32×8 with σs 0.01 and 10⁴, and σi 0.2: the optimiser
/// would keep no swap and return its start after the whole budget; each is refused naming its
/// field.
#[test]
fn vector_sigmas_that_freeze_the_optimiser_are_refused_with_the_field() {
    for space in [SampleSpace::Vec { dims: 2 }, SampleSpace::CosineHemisphere] {
        for (field, value) in [
            ("sigma_value", 0.01),
            ("sigma_value", 1e4),
            ("sigma_image", 0.2),
        ] {
            let mut spec = VectorSpec::new(32, 32, 8, 1, space.clone()).with_swaps_per_pixel(2.0);
            if field == "sigma_image" {
                spec.sigma_image = value;
            } else {
                spec.sigma_value = value;
            }
            let message = generate_vector(&spec, Observer::default())
                .unwrap_err()
                .to_string();
            assert_refusal(&message, field, value);
            eprintln!("{message}");
        }
    }
}

/// Generates a `w × h × 4` filter-adapted mask (2 swaps per pixel) with the filters `s` and `t`:
/// it must be refused naming `field` and a range, or keep swaps that lower the energy.
fn assert_filter_adapted_refused_or_better(
    (w, h): (u32, u32),
    s: SpatialFilter,
    t: TemporalFilter,
    field: &str,
    value: f64,
) {
    let spec = FilterAdaptedSpec::new(w, h, 4, 3)
        .with_filters(s, t, FilterCombination::Product)
        .with_swaps_per_pixel(2.0);
    let mut trace = EnergyTrace::default();
    match generate_filter_adapted(&spec, Observer::default().with_trace(&mut trace)) {
        Err(e) => assert_refusal(&e.to_string(), field, value),
        Ok(_) => {
            let (first, last) = (trace.points[0], *trace.points.last().unwrap());
            assert!(
                last.swaps_accepted > 0 && last.energy < first.energy,
                "{w}×{h}, {s}, {t}: {} swaps kept, energy {} → {}",
                last.swaps_accepted,
                first.energy,
                last.energy
            );
        }
    }
}

#[test]
fn filter_adapted_sigmas_are_refused_or_lower_the_energy() {
    for spatial in [true, false] {
        let field = if spatial {
            "spatial_filter"
        } else {
            "temporal_filter"
        };
        for value in sweep() {
            let (s, t) = if spatial {
                (
                    SpatialFilter::Gaussian { sigma: value },
                    TemporalFilter::DEFAULT,
                )
            } else {
                (
                    SpatialFilter::DEFAULT,
                    TemporalFilter::Gaussian { sigma: value },
                )
            };
            assert_filter_adapted_refused_or_better((8, 8), s, t, field, value);
        }
    }
}

/// Box sizes and binomial orders, on a square and an oblong slice: each is refused naming
/// `spatial_filter` and its range (a box a whole number of periods long on both axes, a
/// binomial whose σ passes half the slice: both fold flat) or keeps swaps that lower the energy.
#[test]
fn filter_adapted_box_and_binomial_sizes_are_refused_or_lower_the_energy() {
    let boxes = (0..=40).chain([64, 65, SpatialFilter::MAX_SIZE, SpatialFilter::MAX_SIZE + 1]);
    let orders = (0..=20).chain([63, 64, 65, 100, 256, 257]);
    let filters: Vec<SpatialFilter> = boxes
        .map(|size| SpatialFilter::Box { size })
        .chain(orders.map(|order| SpatialFilter::Binomial { order }))
        .collect();
    for slice in [(8, 8), (16, 8)] {
        for &filter in &filters {
            let t = TemporalFilter::DEFAULT;
            assert_filter_adapted_refused_or_better(slice, filter, t, "spatial_filter", f64::NAN);
        }
    }
    // The bounds themselves: a box a period long on one axis only, and the widest binomial.
    let accepted = |w, h, filter| {
        FilterAdaptedSpec::new(w, h, 4, 3)
            .with_filters(filter, TemporalFilter::DEFAULT, FilterCombination::Product)
            .validate()
            .is_ok()
    };
    assert!(accepted(16, 8, SpatialFilter::Box { size: 8 }));
    assert!(!accepted(16, 8, SpatialFilter::Box { size: 16 }));
    assert!(accepted(8, 8, SpatialFilter::Binomial { order: 64 }));
    assert!(!accepted(8, 8, SpatialFilter::Binomial { order: 65 }));
}

/// σ far beyond the mask would cost a footprint of the whole slice per pixel for white noise; it
/// is refused before any work.
#[test]
fn a_huge_sigma_is_refused_at_once() {
    let start = std::time::Instant::now();
    let spec = MaskSpec::new(128, 128, 32, 1).with_sigma(1e300);
    let message = generate(&spec, Observer::default())
        .unwrap_err()
        .to_string();
    assert_refusal(&message, "sigma_xy", 1e300);
    assert!(message.contains("in [0.3072, 64]"), "{message}");
    let spec = VectorSpec::new(128, 128, 32, 1, SampleSpace::UnitVec3);
    let message = generate_vector(
        &VectorSpec {
            sigma_image: 1e300,
            ..spec
        },
        Observer::default(),
    )
    .unwrap_err()
    .to_string();
    assert_refusal(&message, "sigma_image", 1e300);
    assert!(start.elapsed().as_secs() < 5, "{:?}", start.elapsed());
}

/// The bound on σs is the factor's own arithmetic: its figure is accepted, a hair above is not,
/// for every space; and it is in the thousands, far above any useful σs.
#[test]
fn the_sigma_value_bound_is_where_the_factors_round_to_one() {
    for space in [
        SampleSpace::Vec { dims: 1 },
        SampleSpace::Vec { dims: 2 },
        SampleSpace::Vec { dims: 3 },
        SampleSpace::Vec { dims: 4 },
        SampleSpace::UnitVec1,
        SampleSpace::UnitVec2,
        SampleSpace::UnitVec3,
        SampleSpace::UniformHemisphere,
        SampleSpace::CosineHemisphere,
    ] {
        let spec = VectorSpec::new(8, 8, 2, 0, space.clone());
        let max = spec.sigma_value_range().max;
        eprintln!("{}: sigma_value at most {max}", space.name());
        assert!((1e3..1e5).contains(&max), "{}: {max}", space.name());
        let at = VectorSpec {
            sigma_value: max,
            ..spec.clone()
        };
        assert_eq!(at.validate(), Ok(()), "{}", space.name());
        let above = VectorSpec {
            sigma_value: max * 1.01,
            ..spec
        };
        let message = above.validate().unwrap_err().to_string();
        assert!(message.contains("`sigma_value`"), "{message}");
    }
}

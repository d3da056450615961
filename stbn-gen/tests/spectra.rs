//! The analysis measures on known signals and on generated masks.
//!
//! Run with `cargo test --release -p stbn-gen --test spectra -- --nocapture` to see the measured
//! low-band figures.

use std::f64::consts::PI;
use std::sync::OnceLock;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use stbn_gen::analysis::{
    Field, SpectrumImage, dft_xy_image, dft_xz_image, pixel_histogram_deviation, radial_spectrum,
    slice_histogram_deviation, spatial_low_band, spatial_power, temporal_low_band,
    temporal_spectrum,
};
use stbn_gen::{EnergyTopology, MaskSpec, Observer, Volume};

const W: usize = 64;
const H: usize = 64;
const D: usize = 32;

fn white_noise(seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..W * H * D).map(|_| rng.random::<f64>()).collect()
}

fn spec(topology: EnergyTopology) -> MaskSpec {
    MaskSpec::new(W as u32, H as u32, D as u32, 7).with_topology(topology)
}

/// The 64×64×32 spatiotemporal mask, shared by the tests.
fn stbn() -> &'static Volume {
    static VOLUME: OnceLock<Volume> = OnceLock::new();
    VOLUME.get_or_init(|| {
        stbn_gen::generate(&spec(EnergyTopology::Spatiotemporal), Observer::default()).unwrap()
    })
}

fn field(values: &[f64]) -> Field<'_> {
    Field::new(W, H, D, values).unwrap()
}

fn bands(values: &[f64]) -> (f64, f64) {
    let field = field(values);
    (
        spatial_low_band(&field).unwrap(),
        temporal_low_band(&field).unwrap(),
    )
}

#[test]
fn white_noise_is_flat_on_both_axes() {
    for seed in [1, 2, 3] {
        let values = white_noise(seed);
        let (spatial, temporal) = bands(&values);
        eprintln!("white noise seed {seed}: spatial {spatial:.4}, temporal {temporal:.4}");
        assert!((0.85..1.15).contains(&spatial), "{spatial}");
        assert!((0.85..1.15).contains(&temporal), "{temporal}");
        let rings = radial_spectrum(&field(&values));
        let mean = rings[1..=W / 2].iter().sum::<f64>() / (W / 2) as f64;
        assert!((0.9..1.1).contains(&mean), "{mean}");
        // 64 bins of 64 expected values: Poisson noise of about 1/8 per bin, never 60%.
        let deviation = slice_histogram_deviation(&field(&values), 64);
        assert!((0.1..0.6).contains(&deviation), "{deviation}");
    }
}

#[test]
fn constant_field_measures_zero_not_nan() {
    let values = vec![0.3; W * H * D];
    let field = field(&values);
    assert_eq!(spatial_low_band(&field), Some(0.0));
    assert_eq!(temporal_low_band(&field), Some(0.0));
    assert!(spatial_power(&field).iter().all(|&p| p == 0.0));
    assert!(radial_spectrum(&field).iter().all(|&p| p == 0.0));
    assert!(temporal_spectrum(&field).iter().all(|&p| p == 0.0));
    // Every value in one of 16 bins: that bin holds 16 times its share.
    assert_eq!(slice_histogram_deviation(&field, 16), 15.0);
}

#[test]
fn sinusoid_along_x_puts_all_power_at_its_frequency() {
    let f = 5;
    let values: Vec<f64> = (0..W * H * D)
        .map(|i| 0.5 + 0.4 * (2.0 * PI * (f * (i % W)) as f64 / W as f64).cos())
        .collect();
    let field = field(&values);
    // The n − 1 non-DC frequencies average 1, so ±f share n − 1 equally.
    let half = (W * H - 1) as f64 / 2.0;
    let power = spatial_power(&field);
    for (i, &p) in power.iter().enumerate() {
        let expected = if i == f || i == W - f { half } else { 0.0 };
        assert!((p - expected).abs() < 1e-9, "frequency {i}: {p}");
    }
    let rings = radial_spectrum(&field);
    let peak = (0..rings.len())
        .max_by(|&a, &b| rings[a].total_cmp(&rings[b]))
        .unwrap();
    assert_eq!(peak, f);
    // f = 5 is inside the low band (radius ≤ 8): the band average is the two peaks over its size.
    let band = spatial_low_band(&field).unwrap();
    let band_size = (1..=8i32)
        .flat_map(|y| (-8..=8).map(move |x| (x, y)))
        .chain((1..=8).map(|x| (x, 0)))
        .filter(|(x, y)| x * x + y * y <= 64)
        .count()
        * 2;
    assert!(
        (band - 2.0 * half / band_size as f64).abs() < 1e-9,
        "{band}"
    );
    // Constant over time: no temporal power.
    assert_eq!(temporal_low_band(&field), Some(0.0));
}

#[test]
fn sinusoid_over_time_puts_all_power_at_its_frequency() {
    let f = 3;
    let values: Vec<f64> = (0..W * H * D)
        .map(|i| 0.5 + 0.4 * (2.0 * PI * (f * (i / (W * H))) as f64 / D as f64).cos())
        .collect();
    let field = field(&values);
    let spectrum = temporal_spectrum(&field);
    for (ft, &p) in spectrum.iter().enumerate() {
        let expected = if ft == f { (D - 1) as f64 / 2.0 } else { 0.0 };
        assert!((p - expected).abs() < 1e-9, "frequency {ft}: {p}");
    }
    // Band 1..=4 holds the peak: (D − 1) / 2 / 4.
    let band = temporal_low_band(&field).unwrap();
    assert!((band - (D - 1) as f64 / 8.0).abs() < 1e-9, "{band}");
    assert_eq!(spatial_low_band(&field), Some(0.0));
}

#[test]
fn spatiotemporal_mask_is_blue_in_space_and_time() {
    let volume = stbn();
    let values = volume.values();
    let (spatial, temporal) = bands(&values);
    eprintln!("spatiotemporal STBN: spatial {spatial:.4}, temporal {temporal:.4}");
    // Measured 0.0013 and 0.045 (seeds 7 to 10); white noise measures about 1 on both.
    assert!(spatial < 0.02, "{spatial}");
    assert!(temporal < 0.15, "{temporal}");
    assert_eq!(slice_histogram_deviation(&field(&values), 64), 0.0);
}

#[test]
fn independent_2d_mask_is_blue_in_space_white_in_time() {
    let volume =
        stbn_gen::generate(&spec(EnergyTopology::Independent2D), Observer::default()).unwrap();
    let (spatial, temporal) = bands(&volume.values());
    eprintln!("independent 2D: spatial {spatial:.4}, temporal {temporal:.4}");
    // Measured 0.0002 and 0.99 to 1.01 (seeds 7 to 10).
    assert!(spatial < 0.02, "{spatial}");
    assert!((0.8..1.2).contains(&temporal), "{temporal}");
}

#[test]
fn isotropic_3d_mask_is_blue_on_neither_axis() {
    let volume =
        stbn_gen::generate(&spec(EnergyTopology::Isotropic3D), Observer::default()).unwrap();
    let (spatial, temporal) = bands(&volume.values());
    eprintln!("isotropic 3D: spatial {spatial:.4}, temporal {temporal:.4}");
    // Measured 0.52 and 0.86: some low-frequency power removed, far less than by STBN.
    assert!((0.2..0.9).contains(&spatial), "{spatial}");
    assert!((0.5..1.1).contains(&temporal), "{temporal}");
}

/// Mean and standard deviation of `image` over every frequency but DC.
fn non_dc_mean_and_spread(image: &SpectrumImage) -> (f64, f64) {
    let centre = (image.height / 2) * image.width + image.width / 2;
    let values: Vec<f64> = (0..image.values.len())
        .filter(|&i| i != centre)
        .map(|i| image.values[i])
        .collect();
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64;
    (mean, variance.sqrt())
}

/// Mean of `image` over the frequencies `(fx, fy)` (signed) that `keep` selects.
fn mean_where(image: &SpectrumImage, keep: impl Fn(isize, isize) -> bool) -> f64 {
    let (w, h) = (image.width as isize, image.height as isize);
    let mut sum = 0.0;
    let mut count = 0;
    for fy in -h / 2..h - h / 2 {
        for fx in -w / 2..w - w / 2 {
            if keep(fx, fy) {
                sum += image.at(fx, fy);
                count += 1;
            }
        }
    }
    sum / count as f64
}

#[test]
fn dft_images_of_white_noise_are_flat() {
    let values = white_noise(4);
    let field = field(&values);
    for (plane, image) in [("XY", dft_xy_image(&field)), ("XZ", dft_xz_image(&field))] {
        let (mean, spread) = non_dc_mean_and_spread(&image);
        eprintln!(
            "white noise {plane}: mean {mean:.4}, std/mean {:.4}",
            spread / mean
        );
        // E[√P] = √π/2 for P exponential with mean 1; averaging 32 (XY) or 64 (XZ) images of
        // std √(1 − π/4) = 0.46 leaves about 0.08 / 0.06 of the mean.
        let expected = PI.sqrt() / 2.0;
        assert!((mean / expected - 1.0).abs() < 0.03, "{plane}: {mean}");
        assert!(spread / mean < 0.12, "{plane}: {}", spread / mean);
        assert_eq!(image.at(0, 0), 0.0);
    }
}

#[test]
fn dft_images_of_stbn_are_dark_at_low_frequencies() {
    let volume = stbn();
    let values = volume.values();
    let field = field(&values);
    let xy = dft_xy_image(&field);
    let r2 = |fx: isize, fy: isize| fx * fx + fy * fy;
    let centre = mean_where(&xy, |fx, fy| (1..=16).contains(&r2(fx, fy)));
    let outer = mean_where(&xy, |fx, fy| r2(fx, fy) >= 256);
    eprintln!("STBN XY: mean magnitude {centre:.4} at radius ≤ 4, {outer:.4} at radius ≥ 16");
    assert!(centre < 0.1 * outer, "{centre} vs {outer}");
    // XZ: blue over time makes the rows of low temporal frequency dark at every x frequency.
    let xz = dft_xz_image(&field);
    let slow = mean_where(&xz, |fx, ft| ft != 0 && ft.abs() <= 2 && fx != 0);
    let fast = mean_where(&xz, |_, ft| ft.abs() >= 8);
    eprintln!("STBN XZ: mean magnitude {slow:.4} at 1 ≤ |ft| ≤ 2, {fast:.4} at |ft| ≥ 8");
    assert!(slow < 0.5 * fast, "{slow} vs {fast}");
}

#[test]
fn pixel_histogram_deviation_separates_white_from_stratified_sequences() {
    let values = white_noise(5);
    let white = pixel_histogram_deviation(&field(&values));
    // Kolmogorov's limit 0.87/√32 = 0.154; small samples run a little higher.
    eprintln!("white noise: pixel KS {white:.4}");
    assert!((0.14..0.19).contains(&white), "{white}");
    // Every pixel's sequence a shuffled stratification (i + ½)/D: exactly 1/(2D).
    let stratified: Vec<f64> = (0..W * H * D)
        .map(|i| {
            let (p, z) = (i % (W * H), i / (W * H));
            ((z * 7 + p) % D) as f64 / D as f64 + 0.5 / D as f64
        })
        .collect();
    let measured = pixel_histogram_deviation(&field(&stratified));
    assert!((measured - 0.5 / D as f64).abs() < 1e-12, "{measured}");
    // STBN lies in between: blue over time, not stratified.
    let volume = stbn();
    let stbn_values = volume.values();
    let stbn = pixel_histogram_deviation(&field(&stbn_values));
    eprintln!("STBN: pixel KS {stbn:.4}");
    assert!(stbn < 0.6 * white && stbn > 0.5 / D as f64, "{stbn}");
}

//! Sample spaces and image densities: each space's per-slice distribution (moments, norms,
//! hemisphere sign, pixel frequencies), the pdfs' integrals, and the image errors.

use std::f64::consts::PI;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Arc;

use rand::RngExt;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use stbn_gen::{
    ImageError, ImagePdf, InitialArrangement, Observer, PixelProblem, SampleSpace, VectorSpec,
    generate_vector,
};

/// One slice of `n` values of `space` as the generator starts it: the unoptimised `n × 1 × 1`
/// mask from `seed`, in the stratified set's own order.
fn stratified(space: &SampleSpace, n: usize, seed: u64) -> Vec<f32> {
    let spec = VectorSpec {
        initial_arrangement: InitialArrangement::Random,
        ..VectorSpec::new(n as u32, 1, 1, seed, space.clone()).unoptimised()
    };
    generate_vector(&spec, Observer::default())
        .unwrap()
        .values()
        .to_vec()
}

/// Mean of `f` over the values (`dims` components each).
fn mean(values: &[f32], dims: usize, f: impl Fn(&[f32]) -> f64) -> f64 {
    let n = values.len() / dims;
    values.chunks_exact(dims).map(f).sum::<f64>() / n as f64
}

/// A moment to check: its name, its exact expectation and the function averaged.
type Moment<'a> = (&'a str, f64, &'a dyn Fn(&[f32]) -> f64);

/// The largest |sample mean − exact| over several moments, for a stratified slice and for the
/// same number of independent (white-noise) draws with the same distribution.
fn moment_errors(
    space: &SampleSpace,
    n: usize,
    moments: &[Moment],
    white: impl Fn(&mut ChaCha8Rng) -> Vec<f32>,
) -> (f64, f64) {
    let dims = space.dims();
    let strat = stratified(space, n, 11);
    assert_eq!(strat.len(), n * dims);
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let noise: Vec<f32> = (0..n).flat_map(|_| white(&mut rng)).collect();
    let mut worst = (0.0f64, 0.0f64);
    for (name, exact, f) in moments {
        let (s, w) = (mean(&strat, dims, f), mean(&noise, dims, f));
        eprintln!(
            "{}: {name}: stratified {s:.6}, white {w:.6}, exact {exact:.6}",
            space.name()
        );
        worst.0 = worst.0.max((s - exact).abs());
        worst.1 = worst.1.max((w - exact).abs());
    }
    worst
}

fn unit_sphere(rng: &mut ChaCha8Rng) -> [f32; 3] {
    let z: f64 = 1.0 - 2.0 * rng.random::<f64>();
    let phi = 2.0 * PI * rng.random::<f64>();
    let r = (1.0 - z * z).sqrt();
    [(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32]
}

#[test]
fn vec_spaces_are_stratified_per_component_and_jointly() {
    for dims in 1..=4u8 {
        let space = SampleSpace::Vec { dims };
        let n = 1024;
        let values = stratified(&space, n, 5);
        let d = usize::from(dims);
        assert!(values.iter().all(|&v| (0.0..1.0).contains(&v)));
        for c in 0..d {
            let mut strata: Vec<usize> = values
                .chunks_exact(d)
                .map(|v| (f64::from(v[c]) * n as f64) as usize)
                .collect();
            strata.sort_unstable();
            assert_eq!(
                strata,
                (0..n).collect::<Vec<_>>(),
                "vec{dims} component {c}"
            );
        }
        if d >= 2 {
            // Jointly: a 32 × 32 grid over the first two components has far fewer empty cells than
            // independent points would leave (e^−1 ≈ 37%, 377 ± 15 of 1024).
            let mut counts = vec![0u32; 1024];
            for v in values.chunks_exact(d) {
                let (i, j) = ((v[0] * 32.0) as usize, (v[1] * 32.0) as usize);
                counts[j * 32 + i] += 1;
            }
            let empty = counts.iter().filter(|&&c| c == 0).count();
            assert!(empty < 300, "vec{dims}: {empty} of 1024 cells empty");
        }
    }
}

#[test]
fn unit_vec1_is_half_plus_half_minus() {
    for n in [1usize, 2, 7, 64] {
        let values = stratified(&SampleSpace::UnitVec1, n, 3);
        assert!(values.iter().all(|&v| v == 1.0 || v == -1.0));
        let plus = values.iter().filter(|&&v| v == 1.0).count();
        assert!(plus == n / 2 || plus == n.div_ceil(2), "{plus} of {n}");
    }
}

#[test]
fn circle_moments_beat_white_noise() {
    let space = SampleSpace::UnitVec2;
    let values = stratified(&space, 1024, 1);
    for v in values.chunks_exact(2) {
        let norm = (v[0] * v[0] + v[1] * v[1]).sqrt();
        assert!((norm - 1.0).abs() < 1e-6);
    }
    let (s, w) = moment_errors(
        &space,
        1024,
        &[
            ("x", 0.0, &|v| f64::from(v[0])),
            ("y", 0.0, &|v| f64::from(v[1])),
            ("x²", 0.5, &|v| f64::from(v[0] * v[0])),
            ("xy", 0.0, &|v| f64::from(v[0] * v[1])),
        ],
        |rng| {
            let phi = 2.0 * PI * rng.random::<f64>();
            vec![phi.cos() as f32, phi.sin() as f32]
        },
    );
    assert!(s < 1e-3 && s * 10.0 < w, "stratified {s}, white {w}");
}

#[test]
fn sphere_moments_beat_white_noise() {
    let space = SampleSpace::UnitVec3;
    let values = stratified(&space, 4096, 2);
    for v in values.chunks_exact(3) {
        let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        assert!((norm - 1.0).abs() < 1e-6);
    }
    let (s, w) = moment_errors(
        &space,
        4096,
        &[
            ("x", 0.0, &|v| f64::from(v[0])),
            ("y", 0.0, &|v| f64::from(v[1])),
            ("z", 0.0, &|v| f64::from(v[2])),
            ("z²", 1.0 / 3.0, &|v| f64::from(v[2] * v[2])),
            ("x²", 1.0 / 3.0, &|v| f64::from(v[0] * v[0])),
        ],
        |rng| unit_sphere(rng).to_vec(),
    );
    assert!(s < 2e-3 && s * 4.0 < w, "stratified {s}, white {w}");
}

#[test]
fn hemispheres_have_the_right_moments_and_sign() {
    let uniform = SampleSpace::UniformHemisphere;
    let (s, w) = moment_errors(
        &uniform,
        4096,
        &[
            ("z", 0.5, &|v| f64::from(v[2])),
            ("z²", 1.0 / 3.0, &|v| f64::from(v[2] * v[2])),
            ("x", 0.0, &|v| f64::from(v[0])),
        ],
        |rng| {
            let v = unit_sphere(rng);
            vec![v[0], v[1], v[2].abs()]
        },
    );
    assert!(
        s < 2e-3 && s * 4.0 < w,
        "uniform hemisphere: stratified {s}, white {w}"
    );

    let cosine = SampleSpace::CosineHemisphere;
    let (s, w) = moment_errors(
        &cosine,
        4096,
        &[
            ("z", 2.0 / 3.0, &|v| f64::from(v[2])),
            ("z²", 0.5, &|v| f64::from(v[2] * v[2])),
            ("y", 0.0, &|v| f64::from(v[1])),
            ("x²", 0.25, &|v| f64::from(v[0] * v[0])),
        ],
        |rng| {
            let (a, b): (f64, f64) = (rng.random(), rng.random());
            let r = a.sqrt();
            let phi = 2.0 * PI * b;
            vec![
                (r * phi.cos()) as f32,
                (r * phi.sin()) as f32,
                (1.0 - a).sqrt() as f32,
            ]
        },
    );
    assert!(
        s < 2e-3 && s * 4.0 < w,
        "cosine hemisphere: stratified {s}, white {w}"
    );

    for space in [uniform, cosine] {
        let values = stratified(&space, 2048, 9);
        for v in values.chunks_exact(3) {
            assert!(v[2] >= 0.0, "{}: {v:?}", space.name());
            let norm = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!((norm - 1.0).abs() < 1e-6);
            assert!(space.pdf(v) > 0.0);
        }
    }
}

#[test]
fn derivable_pdfs() {
    assert_eq!(SampleSpace::Vec { dims: 2 }.pdf(&[0.3, 0.9]), 1.0);
    assert_eq!(SampleSpace::Vec { dims: 2 }.pdf(&[0.3, 1.0]), 0.0);
    assert_eq!(SampleSpace::UnitVec1.pdf(&[-1.0]), 0.5);
    assert!(
        (SampleSpace::UnitVec3.pdf(&[0.0, 0.0, 1.0]) - 0.25 / std::f32::consts::PI).abs() < 1e-9
    );
    assert_eq!(SampleSpace::UniformHemisphere.pdf(&[0.0, 1.0, -0.1]), 0.0);
    assert!(
        (SampleSpace::CosineHemisphere.pdf(&[0.0, 0.6, 0.8]) - 0.8 / std::f32::consts::PI).abs()
            < 1e-7
    );
    for space in [
        SampleSpace::Vec { dims: 3 },
        SampleSpace::UnitVec1,
        SampleSpace::UnitVec2,
        SampleSpace::UnitVec3,
        SampleSpace::UniformHemisphere,
        SampleSpace::CosineHemisphere,
    ] {
        assert!(!space.stores_pdf(), "{}", space.name());
    }
}

/// A 32 × 16 test image: a dark gradient, one bright band near the top and a hot pixel.
fn test_luminance() -> (u32, u32, Vec<f32>) {
    let (w, h) = (32u32, 16u32);
    let mut lum = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let mut l = 0.01 * (x as f32 + 1.0);
            if y == 1 {
                l += 2.0;
            }
            if (x, y) == (20, 11) {
                l += 50.0;
            }
            lum.push(l);
        }
    }
    (w, h, lum)
}

#[test]
fn image_points_follow_the_luminance() {
    let (w, h, lum) = test_luminance();
    let image = Arc::new(ImagePdf::from_luminance(w, h, lum.clone()).unwrap());
    let space = SampleSpace::ImagePoints(image.clone());
    assert!(space.stores_pdf());
    let n = 8192;
    let values = stratified(&space, n, 4);
    let total: f64 = lum.iter().map(|&l| f64::from(l)).sum();
    let mut counts = vec![0usize; (w * h) as usize];
    for v in values.chunks_exact(2) {
        assert!((0.0..1.0).contains(&v[0]) && (0.0..1.0).contains(&v[1]));
        let (x, y) = ((v[0] * w as f32) as usize, (v[1] * h as f32) as usize);
        counts[y * w as usize + x] += 1;
        let expected = f64::from(lum[y * w as usize + x]) / (total / f64::from(w * h));
        assert!((f64::from(space.pdf(v)) - expected).abs() < 1e-4 * expected);
    }
    // Stratified inversion: every pixel gets close to its expected count (independent draws
    // would be off by ±45 for the hot pixel alone), and the χ² statistic is far below the pixel
    // count that independent draws give.
    let mut chi2 = 0.0;
    for (i, &count) in counts.iter().enumerate() {
        let expected = n as f64 * f64::from(lum[i]) / total;
        chi2 += (count as f64 - expected).powi(2) / expected;
        assert!(
            (count as f64 - expected).abs() <= 5.0,
            "pixel {i}: {count} samples, {expected:.2} expected"
        );
    }
    assert!(chi2 < 0.25 * f64::from(w * h), "χ² {chi2}");
}

#[test]
fn image_points_pdf_integrates_to_one() {
    let (w, h, lum) = test_luminance();
    let image = ImagePdf::from_luminance(w, h, lum).unwrap();
    // Midpoint rule on a grid not aligned with the pixels.
    let m = 4001;
    let mut sum = 0.0;
    for j in 0..m {
        for i in 0..m {
            let p = [(i as f32 + 0.5) / m as f32, (j as f32 + 0.5) / m as f32];
            sum += f64::from(image.point_pdf(p));
        }
    }
    let integral = sum / f64::from(m * m);
    assert!((integral - 1.0).abs() < 2e-3, "∫ pdf = {integral}");
}

/// `count` equal-area points on the unit sphere (a spherical Fibonacci set).
fn fibonacci_sphere(count: usize) -> impl Iterator<Item = [f32; 3]> {
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    (0..count).map(move |i| {
        let z = 1.0 - (2.0 * i as f64 + 1.0) / count as f64;
        let phi = 2.0 * PI * (i as f64 / golden).fract();
        let r = (1.0 - z * z).sqrt();
        [(r * phi.cos()) as f32, z as f32, (r * phi.sin()) as f32]
    })
}

#[test]
fn environment_pdf_integrates_to_one_over_the_sphere() {
    let (w, h, lum) = test_luminance();
    let image = ImagePdf::from_luminance(w, h, lum.clone()).unwrap();
    let count = 400_000;
    let integral: f64 = fibonacci_sphere(count)
        .map(|d| f64::from(image.direction_pdf(d)))
        .sum::<f64>()
        * 4.0
        * PI
        / count as f64;
    assert!((integral - 1.0).abs() < 5e-3, "∫ pdf dω = {integral}");

    // Without the sin θ Jacobian (pdf ∝ L per unit of (u, v)), the bright band near the pole
    // would be over-weighted and the integral far from 1: the check above is sensitive to it.
    let total: f64 = lum.iter().map(|&l| f64::from(l)).sum();
    let naive: f64 = fibonacci_sphere(count)
        .map(|d| {
            let [u, v] = ImagePdf::direction_uv(d).unwrap();
            let (x, y) = (
                ((u * f64::from(w)) as usize).min(31),
                ((v * f64::from(h)) as usize).min(15),
            );
            f64::from(lum[y * w as usize + x]) / total * f64::from(w * h) / (2.0 * PI * PI)
        })
        .sum::<f64>()
        * 4.0
        * PI
        / count as f64;
    assert!((naive - 1.0).abs() > 0.05, "naive integral {naive}");
}

#[test]
fn environment_directions_follow_luminance_times_solid_angle() {
    let (w, h, lum) = test_luminance();
    let image = Arc::new(ImagePdf::from_luminance(w, h, lum.clone()).unwrap());
    let space = SampleSpace::EnvironmentDirections(image.clone());
    let n = 16384;
    let values = stratified(&space, n, 8);
    let omega = |y: u32| {
        let (t0, t1) = (
            PI * f64::from(y) / f64::from(h),
            PI * f64::from(y + 1) / f64::from(h),
        );
        2.0 * PI / f64::from(w) * (t0.cos() - t1.cos())
    };
    let weighted: f64 = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| f64::from(lum[(y * w + x) as usize]) * omega(y))
        .sum();
    let mut counts = vec![0usize; (w * h) as usize];
    for d in values.chunks_exact(3) {
        let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert!((norm - 1.0).abs() < 1e-6);
        let [u, v] = ImagePdf::direction_uv([d[0], d[1], d[2]]).unwrap();
        let (x, y) = ((u * f64::from(w)) as u32, (v * f64::from(h)) as u32);
        let (x, y) = (x.min(w - 1), y.min(h - 1));
        counts[(y * w + x) as usize] += 1;
        // The density per steradian of the pixel the sample lies in.
        let expected = f64::from(lum[(y * w + x) as usize]) / weighted;
        let got = f64::from(space.pdf(d));
        assert!(
            (got - expected).abs() <= 1e-4 * expected,
            "{got} vs {expected}"
        );
    }
    let mut chi2 = 0.0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let expected = n as f64 * f64::from(lum[i]) * omega(y) / weighted;
            chi2 += (counts[i] as f64 - expected).powi(2) / expected;
            assert!(
                (counts[i] as f64 - expected).abs() <= 5.0,
                "pixel ({x}, {y}): {} samples, {expected:.2} expected",
                counts[i]
            );
        }
    }
    assert!(chi2 < 0.25 * f64::from(w * h), "χ² {chi2}");
    // +Y is up: the bright band of row 1 puts many samples near the zenith.
    let high = values.chunks_exact(3).filter(|d| d[1] > 0.9).count();
    assert!(high as f64 > 0.05 * n as f64, "{high}");
}

#[test]
fn a_single_hot_pixel_or_mostly_black_image_works() {
    let (w, h) = (16u32, 8u32);
    let mut lum = vec![0.0f32; (w * h) as usize];
    lum[(5 * w + 3) as usize] = 7.0;
    let image = Arc::new(ImagePdf::from_luminance(w, h, lum).unwrap());
    for space in [
        SampleSpace::ImagePoints(image.clone()),
        SampleSpace::EnvironmentDirections(image.clone()),
    ] {
        let spec = VectorSpec::new(8, 8, 2, 3, space.clone()).with_swaps_per_pixel(2.0);
        let volume = generate_vector(&spec, Observer::default()).unwrap();
        let pdf = volume.pdf().expect("image spaces store their pdf");
        assert!(
            pdf.iter().all(|&p| p > 0.0 && p == pdf[0]),
            "{}",
            space.name()
        );
        for v in volume.values().chunks_exact(space.dims()) {
            let pixel = if space.dims() == 2 {
                ((v[0] * w as f32) as u32, (v[1] * h as f32) as u32)
            } else {
                let [u, t] = ImagePdf::direction_uv([v[0], v[1], v[2]]).unwrap();
                ((u * f64::from(w)) as u32, (t * f64::from(h)) as u32)
            };
            assert_eq!(pixel, (3, 5), "{}: {v:?}", space.name());
        }
    }
    // Mostly black: one dim row among zeros.
    let mut lum = vec![0.0f32; (w * h) as usize];
    for x in 0..w {
        lum[(2 * w + x) as usize] = 1e-3 * (x + 1) as f32;
    }
    let image = Arc::new(ImagePdf::from_luminance(w, h, lum).unwrap());
    let spec = VectorSpec::new(8, 8, 2, 3, SampleSpace::EnvironmentDirections(image));
    let volume = generate_vector(&spec, Observer::default()).unwrap();
    assert!(volume.pdf().unwrap().iter().all(|&p| p > 0.0));
}

#[test]
fn bad_luminance_is_refused_naming_the_pixel() {
    let cases: [(f32, &str); 4] = [
        (f32::NAN, "pixel (2, 1) is NaN"),
        (f32::INFINITY, "pixel (2, 1) is infinite"),
        (f32::NEG_INFINITY, "pixel (2, 1) is infinite"),
        (-0.5, "pixel (2, 1) is negative (-0.5)"),
    ];
    for (bad, needle) in cases {
        let mut lum = vec![1.0f32; 12];
        lum[4 + 2] = bad;
        let err = ImagePdf::from_luminance(4, 3, lum).unwrap_err();
        assert!(
            matches!(err, ImageError::BadPixel { x: 2, y: 1, .. }),
            "{err:?}"
        );
        let message = err.to_string();
        assert!(message.contains(needle), "{message:?} lacks {needle:?}");
    }
    let err = ImagePdf::from_luminance(4, 3, vec![0.0; 12]).unwrap_err();
    assert_eq!(err, ImageError::AllZero { path: None });
    assert!(
        err.to_string().contains("zero luminance everywhere"),
        "{err}"
    );
    let err = ImagePdf::from_luminance(4, 3, vec![1.0; 11]).unwrap_err();
    assert!(err.to_string().contains("11 luminance values"), "{err}");
    let err = ImagePdf::from_luminance(0, 3, vec![]).unwrap_err();
    assert!(err.to_string().contains("0x3"), "{err}");
    let err = ImagePdf::from_luminance(1 << 13, 1 << 13, vec![]).unwrap_err();
    assert!(matches!(err, ImageError::BadSize { .. }), "{err:?}");
    assert_eq!(
        ImagePdf::from_luminance(2, 1, vec![f32::NAN, 1.0]).unwrap_err(),
        ImageError::BadPixel {
            path: None,
            x: 0,
            y: 0,
            problem: PixelProblem::NaN
        }
    );
}

fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) {
    let file = File::create(path).unwrap();
    let mut encoder = png::Encoder::new(BufWriter::new(file), width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(data).unwrap();
}

fn write_hdr(path: &Path, width: usize, height: usize, rgb: &[[f32; 3]]) {
    let pixels: Vec<image::Rgb<f32>> = rgb.iter().map(|&p| image::Rgb(p)).collect();
    let file = BufWriter::new(File::create(path).unwrap());
    image::codecs::hdr::HdrEncoder::new(file)
        .encode(&pixels, width, height)
        .unwrap();
}

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn png_and_hdr_files_load_as_luminance() {
    let dir = tempfile::tempdir().unwrap();
    // 8-bit gray, sRGB-decoded.
    let gray = dir.path().join("gray.png");
    write_png(
        &gray,
        3,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0, 64, 128, 255, 10, 200],
    );
    let image = ImagePdf::load(&gray).unwrap();
    assert_eq!((image.width(), image.height()), (3, 2));
    for (&got, code) in image.luminance().iter().zip([0u8, 64, 128, 255, 10, 200]) {
        let expected = srgb_to_linear(f64::from(code) / 255.0);
        assert!(
            (f64::from(got) - expected).abs() < 1e-5,
            "{code}: {got} vs {expected}"
        );
    }
    // 16-bit RGB: pure red, green and blue give the Rec. 709 weights.
    let rgb = dir.path().join("rgb16.PNG");
    let mut data = Vec::new();
    for c in 0..3 {
        for k in 0..3 {
            data.extend(if c == k { 65535u16 } else { 0 }.to_be_bytes());
        }
    }
    write_png(
        &rgb,
        3,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Sixteen,
        &data,
    );
    let image = ImagePdf::load(&rgb).unwrap();
    for (got, expected) in image.luminance().iter().zip([0.2126f32, 0.7152, 0.0722]) {
        assert!((got - expected).abs() < 1e-5, "{got} vs {expected}");
    }
    // RGBA: alpha is ignored.
    let rgba = dir.path().join("rgba.png");
    write_png(
        &rgba,
        1,
        1,
        png::ColorType::Rgba,
        png::BitDepth::Eight,
        &[255, 255, 255, 0],
    );
    assert!((ImagePdf::load(&rgba).unwrap().luminance()[0] - 1.0).abs() < 1e-5);
    // Radiance HDR: linear, 8-bit shared-exponent precision.
    let hdr = dir.path().join("sky.hdr");
    let pixels = [
        [1.0, 1.0, 1.0],
        [4.0, 0.0, 0.0],
        [0.0, 0.5, 0.0],
        [0.0, 0.0, 0.0],
    ];
    write_hdr(&hdr, 2, 2, &pixels);
    let image = ImagePdf::load(&hdr).unwrap();
    let expected = [1.0, 4.0 * 0.2126, 0.5 * 0.7152, 0.0];
    for (got, want) in image.luminance().iter().zip(expected) {
        assert!(
            (got - want).abs() <= 0.01 * want.max(0.01),
            "{got} vs {want}"
        );
    }
    let space = SampleSpace::EnvironmentDirections(Arc::new(image));
    let spec = VectorSpec::new(4, 4, 2, 1, space);
    assert!(
        generate_vector(&spec, Observer::default())
            .unwrap()
            .pdf()
            .unwrap()
            .iter()
            .all(|&p| p > 0.0)
    );
}

#[test]
fn bad_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.hdr");
    let err = ImagePdf::load(&missing).unwrap_err();
    assert!(matches!(err, ImageError::Unreadable { .. }), "{err:?}");
    assert!(err.to_string().contains("missing.hdr"), "{err}");

    let black = dir.path().join("black.png");
    write_png(
        &black,
        4,
        2,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &[0; 8],
    );
    let err = ImagePdf::load(&black).unwrap_err();
    assert_eq!(
        err,
        ImageError::AllZero {
            path: Some(black.clone())
        }
    );
    let message = err.to_string();
    assert!(
        message.contains("black.png") && message.contains("zero luminance"),
        "{message}"
    );

    let black_hdr = dir.path().join("black.hdr");
    write_hdr(&black_hdr, 2, 1, &[[0.0; 3], [0.0; 3]]);
    assert!(matches!(
        ImagePdf::load(&black_hdr),
        Err(ImageError::AllZero { .. })
    ));

    let corrupt = dir.path().join("corrupt.png");
    std::fs::write(&corrupt, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let err = ImagePdf::load(&corrupt).unwrap_err();
    assert!(err.to_string().contains("corrupt.png"), "{err}");

    let text = dir.path().join("sky.jpg");
    std::fs::write(&text, b"hello").unwrap();
    let err = ImagePdf::load(&text).unwrap_err();
    assert!(
        matches!(err, ImageError::UnsupportedFormat { .. }),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("sky.jpg") && message.contains(".png or .hdr"),
        "{message}"
    );
}

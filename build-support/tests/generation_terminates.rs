//! Property: any value of any field, through manifest validation and generation of a tiny mask,
//! either is refused with a located error or makes a valid blob, within a time bound. Values are
//! drawn from everyday ranges and from the extremes (NaN, infinities, subnormals, 1e±300) that
//! broke the arithmetic before.

use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use stbn_build_support::Manifest;
use stbn_runtime::PackedStbn;

/// How long one case may take, validation and generation together (a tiny mask takes
/// milliseconds; the bound is for slow machines, and catches a loop that never ends).
const DEADLINE: Duration = Duration::from_secs(60);

const KINDS: &[&str] = &[
    "Scalar",
    "Blue2D",
    "Blue3D",
    "White",
    "GoldenRatio2D",
    "RandomShift2D",
    "TellusimLayered",
    "Vec1",
    "Vec2",
    "Vec3",
    "Vec4",
    "UnitVec1",
    "UnitVec2",
    "UnitVec3",
    "UniformHemisphere",
    "CosineHemisphere",
    "FilterAdapted",
];

/// Any `f64`, weighted towards the values that break arithmetic.
fn float() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => 0.01f64..8.0,
        1 => prop::sample::select(vec![
            0.0,
            -0.0,
            -1.0,
            1.0,
            0.5,
            1e-300,
            1e-200,
            1e-160,
            1e-150,
            5e-324,
            1e300,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ]),
        1 => any::<f64>(),
    ]
}

/// `value` as RON writes it: `NaN`, `inf`, `-inf` or a number with a decimal point or exponent.
fn ron(value: f64) -> String {
    if value.is_nan() {
        "NaN".to_owned()
    } else if value.is_infinite() {
        if value > 0.0 { "inf" } else { "-inf" }.to_owned()
    } else {
        format!("{value:?}")
    }
}

/// Mostly `everyday`, sometimes any value of [`float`].
fn mostly(everyday: std::ops::Range<f64>) -> impl Strategy<Value = String> {
    prop_oneof![3 => everyday, 1 => float()].prop_map(ron)
}

/// The optional fields each kind takes (the others are refused, which is tested too, but less
/// often).
fn applies(kind: &str, field: &str) -> bool {
    let fields: &[&str] = match kind {
        "Scalar" | "Blue2D" | "Blue3D" => &["sigma", "sigma_time", "density", "kernel_tolerance"],
        "GoldenRatio2D" | "RandomShift2D" => &["sigma", "density", "kernel_tolerance"],
        "TellusimLayered" => &["sigma", "density"],
        "White" => &[],
        "FilterAdapted" => &[
            "spatial_filter",
            "temporal_filter",
            "filter_combination",
            "swaps_per_pixel",
            "kernel_tolerance",
        ],
        _ => &[
            "sigma",
            "sigma_value",
            "swaps_per_pixel",
            "assignment_passes",
            "kernel_tolerance",
        ],
    };
    fields.contains(&field)
}

/// A one-mask manifest of a tiny size with a subset of the optional fields, each any value.
fn manifest() -> impl Strategy<Value = String> {
    let spatial = prop_oneof![
        float().prop_map(|s| format!("Gaussian({})", ron(s))),
        (0u32..70000).prop_map(|n| format!("Box({n})")),
        (0u32..300).prop_map(|n| format!("Binomial({n})")),
    ];
    let temporal = prop_oneof![
        mostly(0.001..1.0).prop_map(|a| format!("Exponential({a})")),
        (mostly(0.001..1.0), mostly(0.001..1.0))
            .prop_map(|(a, b)| format!("ExponentialHistory({a}, {b})")),
        float().prop_map(|s| format!("Gaussian({})", ron(s))),
        (0u32..70000).prop_map(|n| format!("Box({n})")),
    ];
    let combination = prop_oneof![
        Just("Product".to_owned()),
        mostly(0.0..1.0).prop_map(|w| format!("Separate({w})")),
    ];
    let fields = (
        (
            mostly(0.01..8.0),
            mostly(0.01..8.0),
            mostly(0.01..0.5),
            mostly(1e-4..0.5),
            mostly(0.01..4.0),
        ),
        (
            mostly(0.0..4.0),
            (0u32..1200).prop_map(|n| n.to_string()),
            spatial,
            temporal,
            combination,
        ),
        prop::collection::vec(any::<bool>(), 10),
    )
        .prop_map(|((a, b, c, d, e), (f, g, h, i, j), written)| {
            let names = [
                "sigma",
                "sigma_time",
                "density",
                "kernel_tolerance",
                "sigma_value",
                "swaps_per_pixel",
                "assignment_passes",
                "spatial_filter",
                "temporal_filter",
                "filter_combination",
            ];
            let values = [a, b, c, d, e, f, g, h, i, j];
            names
                .into_iter()
                .zip(values)
                .zip(written)
                .filter_map(|(field, written)| written.then_some(field))
                .collect::<Vec<_>>()
        });
    (
        prop::sample::select(KINDS),
        (1u32..=6, 1u32..=6, 1u32..=4),
        any::<u64>(),
        fields,
        prop::bool::weighted(0.8),
        prop::sample::select(vec!["Unorm8", "Unorm16", "F32"]),
    )
        .prop_map(
            |(kind, (w, h, d), seed, fields, only_applicable, encoding)| {
                let written: String = fields
                    .into_iter()
                    .filter(|(name, _)| !only_applicable || applies(kind, name))
                    .map(|(name, value)| format!(", {name}: {value}"))
                    .collect();
                format!(
                    "(masks: [(name: \"m\", kind: {kind}, size: ({w}, {h}, {d}), seed: {seed}\
                 {written}, encoding: {encoding})])"
                )
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn validation_then_generation_ends_in_a_blob_or_a_located_error(text in manifest()) {
        let (send, receive) = mpsc::channel();
        let input = text.clone();
        std::thread::spawn(move || {
            let outcome = match Manifest::parse(&input, "prop.ron") {
                Err(error) => Err(error.to_string()),
                Ok(manifest) => {
                    let entry = &manifest.masks()[0];
                    match entry.recipe().make(entry.encoding, entry.compression) {
                        // A σs too small for the values' spacing is refused after the first
                        // pass, naming the field: its bound depends on the values, so the
                        // manifest cannot check it.
                        Err(stbn_gen::VectorSpecError::Spec(
                            stbn_gen::SpecError::SigmaOutOfRange {
                                field: "sigma_value",
                                ..
                            },
                        )) => {}
                        Err(error) => panic!("a validated entry generates: {error:?}"),
                        Ok((_, blob)) => {
                            PackedStbn::from_bytes(&blob)
                                .expect("the blob is valid")
                                .decode()
                                .expect("the blob decodes");
                        }
                    }
                    Ok(())
                }
            };
            let _ = send.send(outcome);
        });
        match receive.recv_timeout(DEADLINE) {
            Ok(Ok(())) => {}
            Ok(Err(error)) => prop_assert!(error.starts_with("prop.ron:1:"), "{}", error),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                prop_assert!(false, "no result within {:?} for {}", DEADLINE, text)
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                prop_assert!(false, "validation or generation panicked on {}", text)
            }
        }
    }
}

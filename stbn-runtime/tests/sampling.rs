//! Sampling, offsets and fills against a slow, obviously-correct reference.

mod common;

use common::{Rng, blob, header, random_payload};
use stbn_runtime::{Encoding, MaskHeader, OffsetStbn, SampleOffset, Stbn};

/// Reference: plain i64/u64 `rem_euclid` indexing and the documented decode formulas.
fn reference(h: &MaskHeader, data: &[u8], x: i64, y: i64, frame: u64, channel: usize) -> f32 {
    let (w, hh, d, c) = (
        i64::from(h.width),
        i64::from(h.height),
        u64::from(h.depth),
        usize::from(h.channels),
    );
    let x = x.rem_euclid(w) as usize;
    let y = y.rem_euclid(hh) as usize;
    let z = (frame % d) as usize;
    let index = ((z * hh as usize + y) * w as usize + x) * c + channel;
    match h.encoding {
        Encoding::Unorm8 => (f32::from(data[index]) + 0.5) / 256.0,
        Encoding::Unorm16 => {
            let q = u16::from_le_bytes([data[2 * index], data[2 * index + 1]]);
            (f32::from(q) + 0.5) / 65536.0
        }
        Encoding::F32 => f32::from_le_bytes(data[4 * index..4 * index + 4].try_into().unwrap()),
    }
}

const SHAPES: [(u32, u32, u32); 7] = [
    (4, 4, 4),
    (3, 5, 7),
    (1, 1, 1),
    (8, 3, 16),
    (6, 16, 1),
    (1, 7, 2),
    (32, 32, 8),
];
const ENCODINGS: [Encoding; 3] = [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32];

/// Every test mask: all shapes × encodings × 1..=4 channels, as (header, blob).
fn masks() -> Vec<(MaskHeader, Vec<u8>)> {
    let mut rng = Rng(0x5EED);
    let mut out = Vec::new();
    for (w, h, d) in SHAPES {
        for encoding in ENCODINGS {
            for channels in 1..=4 {
                let hd = header(w, h, d, channels, encoding);
                let bytes = blob(hd, &random_payload(&hd, &mut rng));
                out.push((*Stbn::from_bytes(&bytes).unwrap().header(), bytes));
            }
        }
    }
    out
}

fn signed_coords(size: u32, rng: &mut Rng) -> Vec<i32> {
    let s = size as i32;
    let mut v = vec![
        0,
        1,
        -1,
        2,
        -2,
        s - 1,
        s,
        s + 1,
        -s,
        -s - 1,
        i32::MIN,
        i32::MIN + 1,
        i32::MAX,
        i32::MAX - 1,
        i32::MIN / 2,
    ];
    v.extend((0..6).map(|_| rng.next_u32() as i32));
    v
}

fn frames(depth: u32, rng: &mut Rng) -> Vec<u32> {
    let mut v = vec![
        0,
        1,
        depth - 1,
        depth,
        depth + 1,
        u32::MAX,
        u32::MAX - 1,
        1 << 31,
    ];
    v.extend((0..4).map(|_| rng.next_u32()));
    v
}

#[test]
fn sample_and_sample_channel_match_reference() {
    let mut rng = Rng(1);
    let mut checked = 0u64;
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let data = &bytes[64..];
        let xs = signed_coords(h.width, &mut rng);
        let ys = signed_coords(h.height, &mut rng);
        for &frame in &frames(h.depth, &mut rng) {
            for &y in &ys {
                for &x in &xs {
                    let r = reference(&h, data, x.into(), y.into(), frame.into(), 0);
                    assert_eq!(
                        s.sample(x, y, frame).to_bits(),
                        r.to_bits(),
                        "{h:?} {x} {y} {frame}"
                    );
                    for c in 0..h.channels {
                        let r = reference(&h, data, x.into(), y.into(), frame.into(), c.into());
                        let v = s.sample_channel(x, y, frame, c.into());
                        assert_eq!(v.to_bits(), r.to_bits());
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 100_000, "{checked}");
}

#[test]
fn offset_views_wrap_overflowing_sums_exactly() {
    let mut rng = Rng(2);
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let data = &bytes[64..];
        let xs = signed_coords(h.width, &mut rng);
        let ys = signed_coords(h.height, &mut rng);
        let fs = frames(h.depth, &mut rng);
        for _ in 0..400 {
            let pick = |v: &[i32], r: &mut Rng| v[r.next_u32() as usize % v.len()];
            let (x, y) = (pick(&xs, &mut rng), pick(&ys, &mut rng));
            let (ox, oy) = (pick(&xs, &mut rng), pick(&ys, &mut rng));
            let frame = fs[rng.next_u32() as usize % fs.len()];
            let of = fs[rng.next_u32() as usize % fs.len()];
            let offset = SampleOffset {
                x: ox,
                y: oy,
                frame: of,
            };
            let r = reference(
                &h,
                data,
                i64::from(x) + i64::from(ox),
                i64::from(y) + i64::from(oy),
                u64::from(frame) + u64::from(of),
                0,
            );
            assert_eq!(
                s.offset(offset).sample(x, y, frame).to_bits(),
                r.to_bits(),
                "{h:?} ({x},{y},{frame}) + {offset:?}"
            );
        }
        // The extreme corners explicitly.
        for (x, ox) in [
            (i32::MAX, i32::MAX),
            (i32::MIN, i32::MIN),
            (i32::MAX, i32::MIN),
        ] {
            let offset = SampleOffset {
                x: ox,
                y: ox,
                frame: u32::MAX,
            };
            let r = reference(
                &h,
                data,
                i64::from(x) + i64::from(ox),
                i64::from(x) + i64::from(ox),
                u64::from(u32::MAX) * 2,
                0,
            );
            assert_eq!(
                s.offset(offset).sample(x, x, u32::MAX).to_bits(),
                r.to_bits()
            );
        }
        assert_eq!(
            s.offset(SampleOffset::ZERO).sample(3, 4, 5).to_bits(),
            s.sample(3, 4, 5).to_bits()
        );
    }
}

#[test]
fn offset_views_compose_exactly() {
    let mut rng = Rng(5);
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let data = &bytes[64..];
        let xs = signed_coords(h.width, &mut rng);
        let ys = signed_coords(h.height, &mut rng);
        let fs = frames(h.depth, &mut rng);
        let pick = |v: &[i32], r: &mut Rng| v[r.next_u32() as usize % v.len()];
        let pick_frame = |r: &mut Rng| fs[r.next_u32() as usize % fs.len()];
        for _ in 0..200 {
            let (x, y, frame) = (
                pick(&xs, &mut rng),
                pick(&ys, &mut rng),
                pick_frame(&mut rng),
            );
            let a = SampleOffset {
                x: pick(&xs, &mut rng),
                y: pick(&ys, &mut rng),
                frame: pick_frame(&mut rng),
            };
            let b = SampleOffset {
                x: pick(&xs, &mut rng),
                y: pick(&ys, &mut rng),
                frame: pick_frame(&mut rng),
            };
            let (sx, sy, sf) = (
                i64::from(a.x) + i64::from(b.x),
                i64::from(a.y) + i64::from(b.y),
                u64::from(a.frame) + u64::from(b.frame),
            );
            let view = s.offset(a).offset(b);
            assert_eq!(
                view.sample_offset(),
                SampleOffset {
                    x: sx.rem_euclid(h.width.into()) as i32,
                    y: sy.rem_euclid(h.height.into()) as i32,
                    frame: (sf % u64::from(h.depth)) as u32,
                },
                "{h:?} {a:?} + {b:?}"
            );
            for c in 0..h.channels {
                let r = reference(
                    &h,
                    data,
                    i64::from(x) + sx,
                    i64::from(y) + sy,
                    u64::from(frame) + sf,
                    c.into(),
                );
                let v = view.sample_channel(x, y, frame, c.into());
                assert_eq!(
                    v.to_bits(),
                    r.to_bits(),
                    "{h:?} ({x},{y},{frame}) + {a:?} + {b:?}"
                );
                if c == 0 {
                    assert_eq!(view.sample(x, y, frame).to_bits(), r.to_bits());
                }
            }
            let i = rng.next_u32();
            let dim = s.dimension(i).sample_offset();
            let expected = s.offset(a).offset(dim).sample(x, y, frame).to_bits();
            assert_eq!(
                s.offset(a).dimension(i).sample(x, y, frame).to_bits(),
                expected
            );
            assert_eq!(
                s.dimension(i).offset(a).sample(x, y, frame).to_bits(),
                expected
            );
            assert_eq!(
                OffsetStbn::from(&s).sample(x, y, frame).to_bits(),
                s.sample(x, y, frame).to_bits()
            );
        }
    }
}

#[test]
#[should_panic(expected = "channel 2 out of range for a mask with 2 channels")]
fn sample_channel_panics_at_the_channel_count() {
    let h = header(4, 4, 4, 2, Encoding::Unorm8);
    let bytes = blob(h, &[0; 4 * 4 * 4 * 2]);
    let s = Stbn::from_bytes(&bytes).unwrap();
    assert_eq!(s.sample_channel(0, 0, 0, 1), 1.0 / 512.0);
    let _ = s.sample_channel(0, 0, 0, 2);
}

#[test]
#[should_panic(expected = "channel 4294967295 out of range for a mask with 1 channels")]
fn offset_view_sample_channel_panics_above_the_channel_count() {
    let h = header(3, 5, 7, 1, Encoding::F32);
    let bytes = blob(h, &[0; 3 * 5 * 7 * 4]);
    let s = Stbn::from_bytes(&bytes).unwrap();
    let view = s.dimension(1);
    assert_eq!(view.sample_channel(0, 0, 0, 0), 0.0);
    let _ = view.sample_channel(0, 0, 0, u32::MAX);
}

/// `floor(fract(i * a) * size)` in f64, or `None` when too close to a bin edge to
/// decide in f64 precision.
fn r2_component_f64(i: u32, a: f64, size: u32) -> Option<u32> {
    let t = (f64::from(i) * a).fract() * f64::from(size);
    let nearest = t.round();
    if (t - nearest).abs() < 1e-6 * f64::from(size) {
        None
    } else {
        Some(t.floor() as u32)
    }
}

#[test]
fn dimension_offsets_follow_r2() {
    let g = 1.324_717_957_244_746_f64;
    let (a1, a2) = (1.0 / g, 1.0 / (g * g));
    let mut checked = 0;
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        assert_eq!(s.dimension(0).sample_offset(), SampleOffset::ZERO);
        for i in (0..2000).chain([u32::MAX, u32::MAX - 1, 1 << 31]) {
            let o = s.dimension(i).sample_offset();
            assert!((0..h.width as i32).contains(&o.x));
            assert!((0..h.height as i32).contains(&o.y));
            assert_eq!(o.frame, 0);
            if i < 2000 {
                if let Some(x) = r2_component_f64(i, a1, h.width) {
                    assert_eq!(o.x as u32, x, "dim {i} width {}", h.width);
                    checked += 1;
                }
                if let Some(y) = r2_component_f64(i, a2, h.height) {
                    assert_eq!(o.y as u32, y, "dim {i} height {}", h.height);
                    checked += 1;
                }
            }
            for (x, y, f) in [(0, 0, 0), (-7, 3, 9), (i32::MIN, i32::MAX, u32::MAX)] {
                assert_eq!(
                    s.dimension(i).sample(x, y, f).to_bits(),
                    s.offset(o).sample(x, y, f).to_bits()
                );
            }
        }
    }
    assert!(checked > 100_000, "{checked}");
}

#[test]
fn dimension_offsets_known_values_and_spread() {
    let h = header(128, 128, 1, 1, Encoding::Unorm8);
    let bytes = blob(h, &vec![0; 128 * 128]);
    let s = Stbn::from_bytes(&bytes).unwrap();
    // fract(1/g) = 0.7548776662..., fract(1/g^2) = 0.5698402909...
    assert_eq!(
        s.dimension(1).sample_offset(),
        SampleOffset {
            x: 96,
            y: 72,
            frame: 0
        }
    );
    // fract(2/g) = 0.5097553324..., fract(2/g^2) = 0.1396805819...
    assert_eq!(
        s.dimension(2).sample_offset(),
        SampleOffset {
            x: 65,
            y: 17,
            frame: 0
        }
    );
    // A low-discrepancy sequence: the first 128 offsets are pairwise distinct.
    let mut seen = std::collections::HashSet::new();
    for i in 0..128 {
        let o = s.dimension(i).sample_offset();
        assert!(seen.insert((o.x, o.y)), "dimension {i} repeats {o:?}");
    }
}

#[test]
fn fill_row_matches_sample() {
    let mut rng = Rng(3);
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let xs = signed_coords(h.width, &mut rng);
        let ys = signed_coords(h.height, &mut rng);
        for len in [0usize, 1, h.width as usize, 3 * h.width as usize + 2, 37] {
            for &x0 in xs.iter().step_by(2) {
                for &y in ys.iter().step_by(3) {
                    for frame in [0, h.depth + 1, u32::MAX] {
                        let mut out = vec![f32::NAN; len];
                        s.fill_row(x0, y, frame, &mut out);
                        for (i, v) in out.iter().enumerate() {
                            let x = (i64::from(x0) + i as i64) as i32; // wraps like the torus
                            let xr = i64::from(x0) + i as i64;
                            let r = reference(&h, &bytes[64..], xr, y.into(), frame.into(), 0);
                            assert_eq!(v.to_bits(), r.to_bits(), "{h:?} x0 {x0} i {i}");
                            if (i64::from(x0) + i as i64) <= i64::from(i32::MAX) {
                                assert_eq!(v.to_bits(), s.sample(x, y, frame).to_bits());
                            }
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn fill_frame_matches_sample_and_handles_any_length() {
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let area = (h.width * h.height) as usize;
        for frame in [0, 1, h.depth, u32::MAX] {
            for len in [0, 1, area - 1, area, area + 5] {
                let mut out = vec![-1.0f32; len];
                let n = s.fill_frame(frame, &mut out);
                assert_eq!(n, len.min(area));
                for (i, v) in out.iter().enumerate() {
                    if i < n {
                        let (x, y) = ((i % h.width as usize) as i32, (i / h.width as usize) as i32);
                        assert_eq!(v.to_bits(), s.sample(x, y, frame).to_bits(), "{h:?} {i}");
                    } else {
                        assert_eq!(*v, -1.0, "tail must be untouched");
                    }
                }
            }
        }
    }
}

#[test]
fn offset_view_fills_match_the_reference() {
    let mut rng = Rng(6);
    for (h, bytes) in masks() {
        let s = Stbn::from_bytes(&bytes).unwrap();
        let data = &bytes[64..];
        let xs = signed_coords(h.width, &mut rng);
        let ys = signed_coords(h.height, &mut rng);
        let area = (h.width * h.height) as usize;
        for (k, offset) in [
            SampleOffset {
                x: 0,
                y: 0,
                frame: u32::MAX,
            },
            SampleOffset {
                x: i32::MIN,
                y: 1,
                frame: 0,
            },
            SampleOffset {
                x: 5,
                y: i32::MAX,
                frame: 3,
            },
            s.dimension(7).sample_offset(),
        ]
        .into_iter()
        .enumerate()
        {
            let view = s.offset(offset);
            let (ox, oy, of) = (
                i64::from(offset.x),
                i64::from(offset.y),
                u64::from(offset.frame),
            );
            for frame in [0, h.depth + 1, u32::MAX] {
                for len in [0, 1, area - 1, area, area + 5] {
                    let mut out = vec![-1.0f32; len];
                    assert_eq!(view.fill_frame(frame, &mut out), len.min(area));
                    for (i, v) in out.iter().enumerate() {
                        if i < area {
                            let (x, y) =
                                ((i % h.width as usize) as i64, (i / h.width as usize) as i64);
                            let r = reference(&h, data, x + ox, y + oy, u64::from(frame) + of, 0);
                            assert_eq!(v.to_bits(), r.to_bits(), "{h:?} {offset:?} {i}");
                        } else {
                            assert_eq!(*v, -1.0, "tail must be untouched");
                        }
                    }
                }
                for &x0 in xs.iter().step_by(3 + k) {
                    for &y in ys.iter().step_by(4) {
                        let mut out = vec![f32::NAN; 2 * h.width as usize + 3];
                        view.fill_row(x0, y, frame, &mut out);
                        for (i, v) in out.iter().enumerate() {
                            let xr = i64::from(x0) + i as i64 + ox;
                            let yr = i64::from(y) + oy;
                            let r = reference(&h, data, xr, yr, u64::from(frame) + of, 0);
                            assert_eq!(v.to_bits(), r.to_bits(), "{h:?} {offset:?} x0 {x0} i {i}");
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn unorm8_values_are_bin_midpoints_with_mean_one_half() {
    // Every byte value once per frame: the values are (q + 0.5) / 256, mean exactly 0.5.
    let h = header(16, 16, 2, 1, Encoding::Unorm8);
    let payload: Vec<u8> = (0..512).map(|i| (i * 7 % 256) as u8).collect();
    let bytes = blob(h, &payload);
    let s = Stbn::from_bytes(&bytes).unwrap();
    let mut frame = [0.0f32; 256];
    for f in 0..2 {
        s.fill_frame(f, &mut frame);
        let mut sorted = frame;
        sorted.sort_by(f32::total_cmp);
        for (q, v) in sorted.iter().enumerate() {
            assert_eq!(*v, (q as f32 + 0.5) / 256.0);
        }
        assert_eq!(
            frame.iter().map(|&v| f64::from(v)).sum::<f64>() / 256.0,
            0.5
        );
        assert!(frame.iter().all(|v| (0.0..1.0).contains(v)));
    }
}

//! Progressive views (`Stbn::progressive`, `OffsetStbn::progressive`): the first epoch is the
//! view itself, later epochs are the documented R2 offsets, every sampling method agrees with
//! `sample` at the view's offset for the frame, and every extreme is exact.

mod common;

use common::{Rng, blob, header, random_payload};
use stbn_runtime::glam::Vec4;
use stbn_runtime::{Encoding, OffsetStbn, SampleOffset, Stbn, include_stbn};

static SCALAR: Stbn<'static> = include_stbn!("data/scalar_16.stbn");
static COSINE: Stbn<'static> = include_stbn!("data/cosine_8.stbn");

/// The documented epoch offset, computed independently in `u128`/`f64`-free integers:
/// `floor(fract(e · step / 2^32) · len)`.
fn epoch_offset(mask: &Stbn<'_>, epoch: u32) -> (i64, i64) {
    let step =
        |s: u32, len: u32| ((u64::from(epoch.wrapping_mul(s)) * u64::from(len)) >> 32) as i64;
    (
        step(0x91E1_0DA6, mask.width()),
        step(0xC13F_A9A9, mask.height()),
    )
}

/// A random mask of the given shape.
fn random_mask(w: u32, h: u32, d: u32, channels: u8, encoding: Encoding, seed: u64) -> Vec<u8> {
    let hd = header(w, h, d, channels, encoding);
    blob(hd, &random_payload(&hd, &mut Rng(seed)))
}

const FRAMES: [u32; 12] = [
    0,
    1,
    7,
    8,
    15,
    16,
    1000,
    65_535,
    1 << 31,
    (1 << 31) + 5,
    u32::MAX - 1,
    u32::MAX,
];
const COORDS: [i32; 7] = [i32::MIN, -17, -1, 0, 5, 1000, i32::MAX];

/// Channel 0 of `mask` at `(x, y, frame)` shifted by `o` and the epoch offset of `frame`,
/// summed exactly in `i64`.
fn expected(mask: &Stbn<'_>, o: SampleOffset, x: i32, y: i32, frame: u32, channel: u32) -> f32 {
    let (ex, ey) = epoch_offset(mask, frame / mask.depth());
    let wx = (i64::from(x) + i64::from(o.x) + ex).rem_euclid(i64::from(mask.width()));
    let wy = (i64::from(y) + i64::from(o.y) + ey).rem_euclid(i64::from(mask.height()));
    let wz = (i64::from(frame) + i64::from(o.frame)).rem_euclid(i64::from(mask.depth()));
    mask.sample_channel(wx as i32, wy as i32, wz as u32, channel)
}

#[test]
fn the_first_epoch_is_the_view_itself() {
    let offsets = [
        SampleOffset::ZERO,
        SampleOffset {
            x: i32::MIN,
            y: 9,
            frame: u32::MAX,
        },
    ];
    for o in offsets {
        let plain = SCALAR.offset(o);
        let progressive = plain.progressive();
        assert!(progressive.is_progressive() && !plain.is_progressive());
        for frame in 0..SCALAR.depth() {
            assert_eq!(progressive.sample_offset_at(frame), plain.sample_offset());
            for &x in &COORDS {
                for &y in &COORDS {
                    assert_eq!(
                        progressive.sample(x, y, frame).to_bits(),
                        plain.sample(x, y, frame).to_bits()
                    );
                }
            }
            let (mut a, mut b) = ([0.0; 256], [0.0; 256]);
            progressive.fill_frame(frame, &mut a);
            plain.fill_frame(frame, &mut b);
            assert_eq!(a, b);
        }
        let cosine = COSINE.offset(o);
        for frame in 0..COSINE.depth() {
            for &x in &COORDS {
                assert_eq!(
                    cosine
                        .progressive()
                        .sample_vector(x, x.wrapping_neg(), frame),
                    cosine.sample_vector(x, x.wrapping_neg(), frame)
                );
            }
        }
    }
    // `Stbn::progressive` is the progressive view at offset zero.
    assert_eq!(
        SCALAR.progressive().sample(3, 4, 9),
        OffsetStbn::from(&SCALAR).progressive().sample(3, 4, 9)
    );
}

#[test]
fn later_epochs_read_the_documented_r2_offsets() {
    let odd = random_mask(7, 5, 3, 2, Encoding::Unorm16, 4);
    let odd = Stbn::from_bytes(&odd).expect("valid mask");
    let wide = random_mask(1000, 1, 2, 1, Encoding::F32, 5);
    let wide = Stbn::from_bytes(&wide).expect("valid mask");
    for mask in [&SCALAR, &odd, &wide] {
        let o = SampleOffset {
            x: -3,
            y: i32::MAX,
            frame: 2,
        };
        let view = mask.offset(o).progressive();
        for &frame in &FRAMES {
            for &x in &COORDS {
                for &y in &COORDS {
                    for c in 0..u32::from(mask.channels()) {
                        assert_eq!(
                            view.sample_channel(x, y, frame, c).to_bits(),
                            expected(mask, o, x, y, frame, c).to_bits(),
                            "{}x{}x{} at ({x}, {y}, {frame}) channel {c}",
                            mask.width(),
                            mask.height(),
                            mask.depth()
                        );
                    }
                }
            }
        }
    }
}

/// Rows and frames are the per-sample values, in every epoch, for scalar and vector masks.
#[test]
fn fills_match_per_sample_reads_in_every_epoch() {
    let odd = random_mask(7, 5, 3, 1, Encoding::Unorm8, 6);
    let odd = Stbn::from_bytes(&odd).expect("valid mask");
    for mask in [&SCALAR, &odd] {
        let view = mask.dimension(3).progressive();
        let (w, h) = (mask.width() as usize, mask.height() as usize);
        for &frame in &FRAMES {
            let mut image = vec![0.0; w * h];
            assert_eq!(view.fill_frame(frame, &mut image), w * h);
            let mut row = vec![0.0; 2 * w + 3];
            view.fill_row(-5, 2, frame, &mut row);
            for (i, v) in row.iter().enumerate() {
                assert_eq!(*v, view.sample(-5 + i as i32, 2, frame));
            }
            for (i, v) in image.iter().enumerate() {
                assert_eq!(*v, view.sample((i % w) as i32, (i / w) as i32, frame));
            }
        }
    }
    let view = COSINE
        .offset(SampleOffset {
            x: 1,
            y: -2,
            frame: 3,
        })
        .progressive();
    for &frame in &FRAMES {
        let mut image = vec![Vec4::ZERO; 64];
        assert_eq!(view.fill_vector_frame(frame, &mut image), 64);
        let mut row = vec![Vec4::ZERO; 11];
        view.fill_vector_row(6, -1, frame, &mut row);
        for (i, v) in image.iter().enumerate() {
            let s = view.sample_vec4((i % 8) as i32, (i / 8) as i32, frame);
            assert_eq!(*v, s);
        }
        for (i, v) in row.iter().enumerate() {
            assert_eq!(*v, view.sample_vec4(6 + i as i32, -1, frame));
        }
        let s = view.sample_vector(2, 3, frame);
        assert_eq!(s.value, view.sample_vec4(2, 3, frame));
        assert_eq!(s.pdf, view.sample_pdf(2, 3, frame));
        assert_eq!(s.value.truncate(), view.sample_vec3(2, 3, frame));
        assert_eq!(s.value.truncate().truncate(), view.sample_vec2(2, 3, frame));
    }
}

/// Offsets added before or after `progressive` give the same view; the epoch counts frames
/// as passed, not the start-frame offset.
#[test]
fn offsets_and_progressive_commute() {
    let o = SampleOffset {
        x: 11,
        y: -4,
        frame: 6,
    };
    let a = SCALAR.progressive().offset(o).dimension(2);
    let b = SCALAR.dimension(2).offset(o).progressive();
    for &frame in &FRAMES {
        assert_eq!(a.sample_offset_at(frame), b.sample_offset_at(frame));
        assert_eq!(a.sample(1, 2, frame), b.sample(1, 2, frame));
    }
    // Frame 8 (epoch 1) of a view starting 6 frames in reads slice 6 at the epoch-1 offset.
    let (ex, ey) = epoch_offset(&SCALAR, 1);
    let at = a.sample_offset_at(8);
    let base = a.sample_offset();
    assert_eq!(i64::from(at.x), (i64::from(base.x) + ex) % 16);
    assert_eq!(i64::from(at.y), (i64::from(base.y) + ey) % 16);
    assert_eq!(at.frame, base.frame);
}

/// Degenerate masks: one frame (every frame its own epoch), one pixel (every offset zero).
#[test]
fn one_frame_and_one_pixel_masks() {
    let one_frame = random_mask(16, 16, 1, 1, Encoding::Unorm8, 7);
    let one_frame = Stbn::from_bytes(&one_frame).expect("valid mask");
    let view = one_frame.progressive();
    assert_eq!(view.sample_offset_at(0), SampleOffset::ZERO);
    let mut distinct = std::collections::BTreeSet::new();
    for frame in 0..64 {
        let o = view.sample_offset_at(frame);
        distinct.insert((o.x, o.y));
        assert_eq!(view.sample(0, 0, frame), one_frame.sample(o.x, o.y, 0));
    }
    assert!(
        distinct.len() > 48,
        "{} distinct offsets in 64 epochs",
        distinct.len()
    );
    assert_eq!(view.sample_offset_at(u32::MAX), {
        let (x, y) = epoch_offset(&one_frame, u32::MAX);
        SampleOffset {
            x: x as i32,
            y: y as i32,
            frame: 0,
        }
    });
    let pixel = random_mask(1, 1, 1, 4, Encoding::F32, 8);
    let pixel = Stbn::from_bytes(&pixel).expect("valid mask");
    for &frame in &FRAMES {
        assert_eq!(
            pixel.progressive().sample_offset_at(frame),
            SampleOffset::ZERO
        );
        assert_eq!(
            pixel.progressive().sample(-1, 7, frame),
            pixel.sample(0, 0, 0)
        );
    }
}

/// Two views built the same way sample the same bits (no hidden state).
#[test]
fn progressive_sampling_is_deterministic() {
    let a = SCALAR.dimension(1).progressive();
    let b = SCALAR.dimension(1).progressive();
    let mut rng = Rng(11);
    for _ in 0..10_000 {
        let (x, y, f) = (rng.next_u32() as i32, rng.next_u32() as i32, rng.next_u32());
        assert_eq!(a.sample(x, y, f).to_bits(), b.sample(x, y, f).to_bits());
    }
}

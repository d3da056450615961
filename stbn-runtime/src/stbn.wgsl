// stbn.wgsl: sample an STBN mask uploaded by stbn_runtime::gpu::create_texture_3d or
// create_texture_2d_array, returning exactly what the CPU's Stbn / OffsetStbn return.
//
// Prepend this file to your shader (it declares no bindings), bind the texture
// (sample type float, filterable or not: only textureLoad is used) and a uniform
// StbnMask filled from stbn_runtime::gpu::MaskUniform::new(view, &texture).to_bytes().
//
// Coordinates: x, y are any i32 and frame any u32 (voxels / frames); the lookup is
// toroidal on every axis, negative values and i32::MIN / u32::MAX included.
// stbn_sample_3d(tex, m, x, y, frame) == view.sample_channel(x, y, frame, c) in component c
// bit for bit, where m is the MaskUniform of view (an OffsetStbn, progressive or not, or the
// Stbn itself for offset zero); components at or beyond the mask's channel count carry no
// meaning.

// The 32-byte uniform (MaskUniform on the CPU).
struct StbnMask {
    // Width, height, depth (frames) in voxels; each in 1..=2^31.
    size: vec3<u32>,
    // 0: texel is the value (f32 formats); 1: unorm8; 2: unorm16.
    decode: u32,
    // The view's offset (x, y, start frame), each component in [0, size).
    offset: vec3<u32>,
    // 1: frames past the depth read the mask at their epoch's offset (OffsetStbn::progressive).
    progressive: u32,
}

// 1/g² and 1/g in 0.32 fixed point (g the plastic number): the steps of the epoch offsets.
const STBN_EPOCH_STEP_X: u32 = 0x91E10DA6u;
const STBN_EPOCH_STEP_Y: u32 = 0xC13FA9A9u;

// Euclidean v mod n in [0, n) for every i32 v and 1 <= n <= 2^31. WGSL's % truncates
// toward zero, so negative v is handled through its magnitude.
fn stbn_wrap(v: i32, n: u32) -> u32 {
    if v >= 0 {
        return u32(v) % n;
    }
    // 0 - bitcast(v) wraps to |v| (2^31 for i32::MIN) without overflow.
    let r = (0u - bitcast<u32>(v)) % n;
    return select(n - r, 0u, r == 0u);
}

// m shifted further by (xy, frame), any i32 / u32: the CPU's OffsetStbn::offset. The
// offsets add exactly, as if summed in unbounded integers.
fn stbn_offset(m: StbnMask, xy: vec2<i32>, frame: u32) -> StbnMask {
    var out = m;
    let n = m.size;
    // Each term is below n <= 2^31, so the sums cannot wrap.
    out.offset = vec3<u32>(
        (m.offset.x + stbn_wrap(xy.x, n.x)) % n.x,
        (m.offset.y + stbn_wrap(xy.y, n.y)) % n.y,
        (m.offset.z + frame % n.z) % n.z,
    );
    return out;
}

// m made progressive: the CPU's OffsetStbn::progressive.
fn stbn_progressive(m: StbnMask) -> StbnMask {
    var out = m;
    out.progressive = 1u;
    return out;
}

// floor(a * b / 2^32): the high word of the 64-bit product, from 16-bit halves (exact).
fn stbn_mul_hi(a: u32, b: u32) -> u32 {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let low = a0 * b0;
    let mid0 = a1 * b0;
    let mid1 = a0 * b1;
    // Each term is below 2^16, so the sum cannot wrap.
    let carry = ((low >> 16u) + (mid0 & 0xFFFFu) + (mid1 & 0xFFFFu)) >> 16u;
    return a1 * b1 + (mid0 >> 16u) + (mid1 >> 16u) + carry;
}

// The texel (x, y, frame) + m.offset, wrapped into [0, size); for a progressive m, plus the
// offset of epoch frame / depth: (floor(fract(e / g²) * width), floor(fract(e / g) * height)).
fn stbn_texel(m: StbnMask, x: i32, y: i32, frame: u32) -> vec3<u32> {
    let n = m.size;
    // Each term is below n <= 2^31, so the sums cannot wrap.
    var t = vec3<u32>(
        (stbn_wrap(x, n.x) + m.offset.x) % n.x,
        (stbn_wrap(y, n.y) + m.offset.y) % n.y,
        (frame % n.z + m.offset.z) % n.z,
    );
    if m.progressive != 0u {
        let epoch = frame / n.z;
        t.x = (t.x + stbn_mul_hi(epoch * STBN_EPOCH_STEP_X, n.x)) % n.x;
        t.y = (t.y + stbn_mul_hi(epoch * STBN_EPOCH_STEP_Y, n.y)) % n.y;
    }
    return t;
}

// A textureLoad result to the CPU value: unorm texels come back as q / (2^bits - 1);
// the CPU value is the bin midpoint (q + 0.5) / 2^bits. round() recovers q exactly,
// and the sum and the multiply by a power of two are exact.
fn stbn_decode(raw: vec4<f32>, decode: u32) -> vec4<f32> {
    if decode == 1u {
        return (round(raw * 255.0) + 0.5) * 0.00390625;
    }
    if decode == 2u {
        return (round(raw * 65535.0) + 0.5) * 0.0000152587890625;
    }
    return raw;
}

// All channels at (x, y, frame) + m.offset, wrapped, from a texture made by
// create_texture_3d.
fn stbn_sample_3d(tex: texture_3d<f32>, m: StbnMask, x: i32, y: i32, frame: u32) -> vec4<f32> {
    let t = stbn_texel(m, x, y, frame);
    return stbn_decode(textureLoad(tex, t, 0), m.decode);
}

// As stbn_sample_3d, from a texture made by create_texture_2d_array (layer = frame).
fn stbn_sample_2d_array(
    tex: texture_2d_array<f32>,
    m: StbnMask,
    x: i32,
    y: i32,
    frame: u32,
) -> vec4<f32> {
    let t = stbn_texel(m, x, y, frame);
    return stbn_decode(textureLoad(tex, t.xy, t.z, 0), m.decode);
}

// ---- Vectors: what Stbn::sample_vector / OffsetStbn::sample_vector do on the CPU ----
// Apply these to the vec4 s returned by stbn_sample_3d / stbn_sample_2d_array, as the
// mask's header says (space and value map are fixed per mask, so pick them when writing
// the shader):
//   value map Unit (Space Scalar, Vec, ImagePoints): s itself;
//   value map Signed: stbn_signed(s), then normalize() the value components for unit
//     spaces (UnitVec, hemispheres, environment directions);
//   value map Octahedral (3D directions in .xy): stbn_octahedral(s.xy);
//   stored pdf (ImagePoints: .z; EnvironmentDirections: .z when octahedral, .w when signed):
//     stbn_stored_pdf(that component, bits, header.pdf_min, header.pdf_max), with bits the
//     mask's encoding: 8 (Unorm8), 16 (Unorm16, whichever texture format it got) or 0 (F32).
// Derivable pdfs are as on the CPU: cosine hemisphere max(z, 0) / pi, uniform hemisphere
// 1 / (2 pi), unit sphere 1 / (4 pi), circle 1 / (2 pi).

// Each component c in [0, 1) to 2c - 1 in [-1, 1).
fn stbn_signed(s: vec4<f32>) -> vec4<f32> {
    return s * 2.0 - 1.0;
}

// The unit vector whose octahedral map is stored (as unit values) in s.
fn stbn_octahedral(s: vec2<f32>) -> vec3<f32> {
    let e = s * 2.0 - 1.0;
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    if n.z < 0.0 {
        let sign_xy = select(vec2<f32>(-1.0), vec2<f32>(1.0), e >= vec2<f32>(0.0));
        n = vec3<f32>((1.0 - abs(e.yx)) * sign_xy, n.z);
    }
    return normalize(n);
}

// The pdf from the stored pdf channel's sampled value c: the channel is stored full-range
// (q / (2^bits - 1)), while sampling returns the bin midpoint (q + 0.5) / 2^bits.
fn stbn_stored_pdf(c: f32, bits: u32, pdf_min: f32, pdf_max: f32) -> f32 {
    var t = c;
    if bits == 8u {
        t = (c * 256.0 - 0.5) / 255.0;
    } else if bits == 16u {
        t = (c * 65536.0 - 0.5) / 65535.0;
    }
    return max(pdf_min + clamp(t, 0.0, 1.0) * (pdf_max - pdf_min), 0.0);
}

//! GPU upload and the WGSL snippet (feature `wgpu`), on real adapters: Vulkan (lavapipe
//! on a machine without a GPU) and GL (Mesa through EGL). A missing adapter fails the
//! test: `scripts/test.sh` installs the CPU drivers when they are missing.

mod common;

use common::{Rng, blob, header};
use stbn_runtime::gpu::{self, GpuError, MaskUniform, TextureOptions};
use stbn_runtime::{Encoding, OffsetStbn, SampleOffset, Space, Stbn, ValueMap};
use wgpu::util::DeviceExt;

struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    name: String,
}

/// Whether [`gpu`] asks for `TEXTURE_FORMAT_16BIT_NORM`.
#[derive(Clone, Copy, PartialEq)]
enum Norm16 {
    /// Request it; the adapter must offer it.
    Require,
    /// Request it where the adapter offers it.
    IfAvailable,
    /// Do not request it (Unorm16 then uses the f32 fallback).
    Off,
}

/// A device on the first adapter of `backends`, with the adapter's own limits and
/// `TEXTURE_FORMAT_16BIT_NORM` as `norm16` says.
fn gpu(backends: wgpu::Backends, norm16: Norm16) -> Gpu {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::None,
        compatible_surface: None,
        ..Default::default()
    }))
    .unwrap_or_else(|e| {
        panic!(
            "no {backends:?} adapter ({e}). Without a GPU, install Mesa's CPU drivers: \
             `apt-get install mesa-vulkan-drivers libvulkan1` for Vulkan (lavapipe); GL needs \
             libegl1 and libgl1-mesa-dri. scripts/test.sh installs lavapipe when it is missing."
        )
    });
    let info = adapter.get_info();
    let norm16_feature = wgpu::Features::TEXTURE_FORMAT_16BIT_NORM;
    let offered = adapter.features().contains(norm16_feature);
    assert!(
        offered || norm16 != Norm16::Require,
        "{} lacks TEXTURE_FORMAT_16BIT_NORM",
        info.name
    );
    let required_features = if offered && norm16 != Norm16::Off {
        norm16_feature
    } else {
        wgpu::Features::empty()
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("stbn test"),
        required_features,
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .unwrap_or_else(|e| panic!("request_device on {}: {e}", info.name));
    Gpu {
        device,
        queue,
        name: format!("{} ({:?}, {})", info.name, info.backend, info.driver),
    }
}

/// A mask of the given shape whose payload covers the extremes (0 and the largest
/// code / value first) and is random after that. F32 values are multiples of 2^-24 in
/// [0, 1), so none is subnormal.
fn mask_blob(w: u32, h: u32, d: u32, channels: u8, encoding: Encoding, seed: u64) -> Vec<u8> {
    let hd = header(w, h, d, channels, encoding);
    let n = hd.decoded_len() / encoding.bytes_per_element();
    let mut rng = Rng(seed);
    let mut payload = Vec::with_capacity(hd.decoded_len());
    for i in 0..n {
        let r = rng.next_u32();
        match encoding {
            Encoding::Unorm8 => payload.push([0, u8::MAX].get(i).copied().unwrap_or(r as u8)),
            Encoding::Unorm16 => payload.extend(
                [0, u16::MAX]
                    .get(i)
                    .copied()
                    .unwrap_or(r as u16)
                    .to_le_bytes(),
            ),
            Encoding::F32 => {
                let q = [0, (1 << 24) - 1].get(i).copied().unwrap_or(r >> 8);
                payload.extend((q as f32 / (1u32 << 24) as f32).to_le_bytes());
            }
        }
    }
    blob(hd, &payload)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    D3,
    D2Array,
}

fn upload(g: &Gpu, mask: &Stbn<'_>, kind: Kind) -> wgpu::Texture {
    let desc = TextureOptions {
        label: Some("stbn mask"),
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
    };
    match kind {
        Kind::D3 => gpu::create_texture_3d(&g.device, &g.queue, mask, desc),
        Kind::D2Array => gpu::create_texture_2d_array(&g.device, &g.queue, mask, desc),
    }
    .unwrap_or_else(|e| panic!("upload on {}: {e}", g.name))
}

/// Waits for `buffer` to map and returns its contents.
fn read_buffer(g: &Gpu, buffer: &wgpu::Buffer) -> Vec<u8> {
    buffer.map_async(wgpu::MapMode::Read, .., |r| r.expect("map_async"));
    g.device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    let bytes = buffer.get_mapped_range(..).expect("mapped range").to_vec();
    buffer.unmap();
    bytes
}

/// The texture's texels, copied back through a buffer with rows padded to 256 bytes and
/// returned tightly packed, frame by frame.
fn read_texture(g: &Gpu, texture: &wgpu::Texture) -> Vec<u8> {
    let size = texture.size();
    let texel = texture
        .format()
        .block_copy_size(None)
        .expect("plain format");
    let row = size.width * texel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = g.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read back"),
        size: u64::from(padded) * u64::from(size.height) * u64::from(size.depth_or_array_layers),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = g.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(size.height),
            },
        },
        size,
    );
    g.queue.submit([encoder.finish()]);
    read_buffer(g, &buffer)
        .chunks_exact(padded as usize)
        .flat_map(|r| &r[..row as usize])
        .copied()
        .collect()
}

/// What the texture must hold, computed independently of the crate: the mask's elements,
/// Unorm16 decoded to f32 when the device has no 16-bit norm formats, 3 channels padded
/// with a zero fourth.
fn expected_texels(mask: &Stbn<'_>, norm16: bool) -> Vec<u8> {
    let channels = usize::from(mask.channels());
    let bpe = mask.encoding().bytes_per_element();
    let fallback = mask.encoding() == Encoding::Unorm16 && !norm16;
    let mut out = Vec::new();
    for voxel in mask.data().chunks_exact(channels * bpe) {
        for c in 0..if channels == 3 { 4 } else { channels } {
            let element = voxel.get(c * bpe..(c + 1) * bpe);
            match (element, fallback) {
                (Some(e), false) => out.extend_from_slice(e),
                (Some(e), true) => {
                    let q = f32::from(u16::from_le_bytes([e[0], e[1]]));
                    out.extend(((q + 0.5) / 65536.0).to_le_bytes());
                }
                (None, _) => out.extend(std::iter::repeat_n(0, if fallback { 4 } else { bpe })),
            }
        }
    }
    out
}

/// One lookup: `(x, y, frame)`, a `SampleOffset` and an R2 dimension offset, both added
/// in the shader with `stbn_offset`.
#[derive(Clone, Copy, Debug)]
struct Query {
    x: i32,
    y: i32,
    frame: u32,
    offset: SampleOffset,
    dim: SampleOffset,
}

const QUERIES: usize = 4096;

fn queries(mask: &Stbn<'_>, seed: u64) -> Vec<Query> {
    let mut rng = Rng(seed);
    let coord = |rng: &mut Rng| -> i32 {
        let special = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX, -7];
        let r = rng.next_u32();
        match r % 4 {
            0 => special[(r >> 8) as usize % special.len()],
            1 => (rng.next_u32() % 64) as i32 - 32,
            _ => rng.next_u32() as i32,
        }
    };
    let frame = |rng: &mut Rng| -> u32 {
        let special = [0, 1, u32::MAX, u32::MAX - 1, 1 << 31, (1 << 31) - 1, 63];
        let r = rng.next_u32();
        match r % 3 {
            0 => special[(r >> 8) as usize % special.len()],
            1 => rng.next_u32() % 200,
            _ => rng.next_u32(),
        }
    };
    (0..QUERIES)
        .map(|i| {
            let (x, y, f) = (coord(&mut rng), coord(&mut rng), frame(&mut rng));
            // Cycle through no offset, an offset, a dimension and both at once.
            let offset = if i % 2 == 1 {
                SampleOffset {
                    x: coord(&mut rng),
                    y: coord(&mut rng),
                    frame: frame(&mut rng),
                }
            } else {
                SampleOffset::ZERO
            };
            let dim = if i % 4 >= 2 {
                mask.dimension(rng.next_u32() % 1000).sample_offset()
            } else {
                SampleOffset::ZERO
            };
            Query {
                x,
                y,
                frame: f,
                offset,
                dim,
            }
        })
        .collect()
}

/// The CPU value of channel `c` for `q` through `view` (the view the uniform was made
/// from): the view shifted by `q.offset` and `q.dim` for channel 0, `sample_channel` of the
/// mask at the coordinate wrapped by hand from that view's offset at the frame otherwise.
fn cpu_value(mask: &Stbn<'_>, view: OffsetStbn<'_>, q: &Query, c: u32) -> f32 {
    let shifted = view.offset(q.offset).offset(q.dim);
    if c == 0 {
        return shifted.sample(q.x, q.y, q.frame);
    }
    let (w, h, d) = (
        i64::from(mask.width()),
        i64::from(mask.height()),
        i64::from(mask.depth()),
    );
    let o = shifted.sample_offset_at(q.frame);
    let x = (i64::from(q.x) + i64::from(o.x)).rem_euclid(w);
    let y = (i64::from(q.y) + i64::from(o.y)).rem_euclid(h);
    let z = (i64::from(q.frame) + i64::from(o.frame)).rem_euclid(d);
    mask.sample_channel(x as i32, y as i32, z as u32, c)
}

/// A compute pipeline that runs the snippet's sampler for `kind` over a query buffer.
struct Sampler {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    kind: Kind,
}

fn sampler(g: &Gpu, kind: Kind) -> Sampler {
    sampler_with(g, kind, "s")
}

/// A sampler whose result is the WGSL expression `result` of the sample `s` (a `vec4<f32>`).
fn sampler_with(g: &Gpu, kind: Kind, result: &str) -> Sampler {
    let (texture_type, function, view_dimension) = match kind {
        Kind::D3 => (
            "texture_3d<f32>",
            "stbn_sample_3d",
            wgpu::TextureViewDimension::D3,
        ),
        Kind::D2Array => (
            "texture_2d_array<f32>",
            "stbn_sample_2d_array",
            wgpu::TextureViewDimension::D2Array,
        ),
    };
    let source = format!(
        "{}
struct Query {{ x: i32, y: i32, frame: u32, ox: i32, oy: i32, oframe: u32, dx: i32, dy: i32 }}
@group(0) @binding(0) var mask: {texture_type};
@group(0) @binding(1) var<uniform> params: StbnMask;
@group(0) @binding(2) var<storage, read> queries: array<Query>;
@group(0) @binding(3) var<storage, read_write> results: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if i >= arrayLength(&queries) {{
        return;
    }}
    let q = queries[i];
    let m = stbn_offset(stbn_offset(params, vec2<i32>(q.ox, q.oy), q.oframe),
        vec2<i32>(q.dx, q.dy), 0u);
    let s = {function}(mask, m, q.x, q.y, q.frame);
    results[i] = {result};
}}
",
        gpu::WGSL
    );
    let module = g.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("stbn test sampler"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    };
    let storage = |read_only| wgpu::BindingType::Buffer {
        ty: wgpu::BufferBindingType::Storage { read_only },
        has_dynamic_offset: false,
        min_binding_size: None,
    };
    let layout = g
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension,
                        multisampled: false,
                    },
                ),
                entry(
                    1,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(MaskUniform::SIZE),
                    },
                ),
                entry(2, storage(true)),
                entry(3, storage(false)),
            ],
        });
    let pipeline_layout = g
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
    let pipeline = g
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("stbn test sampler"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
    Sampler {
        layout,
        pipeline,
        kind,
    }
}

/// Runs every query on the GPU with `uniform` bound as `params`; returns one `[f32; 4]` (all
/// channels) per query.
fn gpu_values(
    g: &Gpu,
    s: &Sampler,
    texture: &wgpu::Texture,
    uniform: MaskUniform,
    qs: &[Query],
) -> Vec<[f32; 4]> {
    let words: Vec<u8> = qs
        .iter()
        .flat_map(|q| {
            [
                q.x as u32,
                q.y as u32,
                q.frame,
                q.offset.x as u32,
                q.offset.y as u32,
                q.offset.frame,
                q.dim.x as u32,
                q.dim.y as u32,
            ]
        })
        .flat_map(u32::to_le_bytes)
        .collect();
    let init = |label, contents: &[u8], usage| {
        g.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    };
    let params = init("params", &uniform.to_bytes(), wgpu::BufferUsages::UNIFORM);
    let queries = init("queries", &words, wgpu::BufferUsages::STORAGE);
    let out_size = (qs.len() * 16) as u64;
    let results = g.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("results"),
        size: out_size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = g.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size: out_size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(match s.kind {
            Kind::D3 => wgpu::TextureViewDimension::D3,
            Kind::D2Array => wgpu::TextureViewDimension::D2Array,
        }),
        ..Default::default()
    });
    let bind_group = g.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &s.layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: queries.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: results.as_entire_binding(),
            },
        ],
    });
    let mut encoder = g.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&s.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((qs.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&results, 0, &staging, 0, out_size);
    g.queue.submit([encoder.finish()]);
    read_buffer(g, &staging)
        .chunks_exact(16)
        .map(|v| {
            let f = |i: usize| f32::from_le_bytes([v[i], v[i + 1], v[i + 2], v[i + 3]]);
            [f(0), f(4), f(8), f(12)]
        })
        .collect()
}

/// Uploads masks of every encoding, channel count and kind (power-of-two and other
/// sizes), checks the texels byte for byte and the WGSL sampler against the CPU bit for
/// bit, for the given `encodings`, with the uniform made from the mask itself and from an
/// offset view, each also progressive. Unorm16 uses 16-bit norm formats where the device has
/// them, the f32 fallback otherwise.
fn check_backend(g: &Gpu, encodings: &[Encoding]) {
    let norm16 = g
        .device
        .features()
        .contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM);
    eprintln!("adapter: {}, 16-bit norm formats: {norm16}", g.name);
    let samplers = [sampler(g, Kind::D3), sampler(g, Kind::D2Array)];
    let mut seed = 1;
    for &encoding in encodings {
        for channels in 1..=4 {
            for (w, h, d) in [(8, 4, 16), (7, 5, 3)] {
                seed += 1;
                let bytes = mask_blob(w, h, d, channels, encoding, seed);
                let mask = Stbn::from_bytes(&bytes).expect("valid test mask");
                let expected = expected_texels(&mask, norm16);
                let qs = queries(&mask, seed);
                for s in &samplers {
                    let what = format!("{encoding:?} x{channels} {w}x{h}x{d} {:?}", s.kind);
                    let texture = upload(g, &mask, s.kind);
                    assert_eq!(
                        texture.format(),
                        gpu::texture_format(encoding, channels, g.device.features()),
                        "{what}"
                    );
                    assert!(
                        read_texture(g, &texture) == expected,
                        "{what}: texels differ from the mask on {}",
                        g.name
                    );
                    let shifted = mask.offset(BASE_OFFSET).dimension(5);
                    let views = [
                        OffsetStbn::from(&mask),
                        shifted,
                        mask.progressive(),
                        shifted.progressive(),
                    ];
                    for view in views {
                        let uniform = MaskUniform::new(view, &texture);
                        let got = gpu_values(g, s, &texture, uniform, &qs);
                        for (q, v) in qs.iter().zip(&got) {
                            for c in 0..u32::from(channels) {
                                let cpu = cpu_value(&mask, view, q, c);
                                assert_eq!(
                                    v[c as usize].to_bits(),
                                    cpu.to_bits(),
                                    "{what} {view:?} channel {c} at {q:?} on {}: GPU {} CPU {cpu}",
                                    g.name,
                                    v[c as usize]
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

const ALL: [Encoding; 3] = [Encoding::Unorm8, Encoding::Unorm16, Encoding::F32];

/// The offset of the view whose uniform [`check_backend`] tests beside the mask's own.
const BASE_OFFSET: SampleOffset = SampleOffset {
    x: i32::MIN + 3,
    y: 77,
    frame: u32::MAX,
};

#[test]
fn vulkan_upload_and_wgsl_sampling_match_the_cpu() {
    check_backend(&gpu(wgpu::Backends::VULKAN, Norm16::Require), &ALL);
}

#[test]
fn vulkan_unorm16_without_16bit_norm_uses_the_f32_fallback() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Off);
    assert_eq!(
        gpu::texture_format(Encoding::Unorm16, 1, g.device.features()),
        wgpu::TextureFormat::R32Float
    );
    check_backend(&g, &[Encoding::Unorm16]);
}

#[test]
fn gl_upload_and_wgsl_sampling_match_the_cpu() {
    check_backend(&gpu(wgpu::Backends::GL, Norm16::IfAvailable), &ALL);
}

/// A 20 MiB mask goes up in two `write_texture` chunks (32 frames of 512 KiB, then 8);
/// every frame must land at its own depth / layer.
#[test]
fn large_masks_upload_in_chunks_to_the_right_frames() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Off);
    let bytes = mask_blob(1024, 512, 40, 1, Encoding::Unorm8, 5);
    let mask = Stbn::from_bytes(&bytes).expect("valid test mask");
    for kind in [Kind::D3, Kind::D2Array] {
        let texture = upload(&g, &mask, kind);
        assert!(
            read_texture(&g, &texture) == mask.data(),
            "{kind:?}: texels differ from the mask"
        );
    }
}

#[test]
fn oversized_masks_are_rejected_before_any_upload() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Off);
    let limits = g.device.limits();
    let wide = mask_blob(
        limits.max_texture_dimension_3d + 1,
        1,
        1,
        1,
        Encoding::Unorm8,
        1,
    );
    let wide = Stbn::from_bytes(&wide).expect("valid test mask");
    assert_eq!(
        gpu::create_texture_3d(&g.device, &g.queue, &wide, TextureOptions::default()).err(),
        Some(GpuError::TooLarge {
            axis: "width",
            size: limits.max_texture_dimension_3d + 1,
            limit: limits.max_texture_dimension_3d,
        })
    );
    let deep = mask_blob(
        1,
        1,
        limits.max_texture_array_layers + 1,
        1,
        Encoding::Unorm8,
        1,
    );
    let deep = Stbn::from_bytes(&deep).expect("valid test mask");
    assert_eq!(
        gpu::create_texture_2d_array(&g.device, &g.queue, &deep, TextureOptions::default()).err(),
        Some(GpuError::TooLarge {
            axis: "depth",
            size: limits.max_texture_array_layers + 1,
            limit: limits.max_texture_array_layers,
        })
    );
}

#[test]
fn mask_uniform_layout_matches_the_wgsl_struct() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Require);
    let bytes = mask_blob(7, 5, 3, 1, Encoding::Unorm16, 3);
    let mask = Stbn::from_bytes(&bytes).expect("valid test mask");
    let texture = upload(&g, &mask, Kind::D3);
    let view = mask.offset(SampleOffset {
        x: -1,
        y: 7,
        frame: 4,
    });
    let b = MaskUniform::new(view, &texture).to_bytes();
    assert_eq!(b.len() as u64, MaskUniform::SIZE);
    // size (7, 5, 3), decode 2 (unorm16), offset (-1 mod 7, 7 mod 5, 4 mod 3), not progressive.
    assert_eq!(
        b,
        [
            7, 0, 0, 0, 5, 0, 0, 0, 3, 0, 0, 0, 2, 0, 0, 0, 6, 0, 0, 0, 2, 0, 0, 0, 1, 0, 0, 0, 0,
            0, 0, 0
        ]
    );
    // The mask itself is the view at offset zero; 8-bit and float formats decode as 1 and 0.
    let unorm8 = mask_blob(7, 5, 3, 1, Encoding::Unorm8, 3);
    let unorm8 = Stbn::from_bytes(&unorm8).expect("valid test mask");
    let b = MaskUniform::new(&unorm8, &upload(&g, &unorm8, Kind::D2Array)).to_bytes();
    assert_eq!(
        &b[12..],
        [1, 0, 0, 0]
            .iter()
            .chain(&[0; 16])
            .copied()
            .collect::<Vec<u8>>()
    );
    // A progressive view sets the last word.
    let b = MaskUniform::new(view.progressive(), &texture).to_bytes();
    assert_eq!(b[28..], [1, 0, 0, 0]);
    let f32_mask = mask_blob(7, 5, 3, 1, Encoding::F32, 3);
    let f32_mask = Stbn::from_bytes(&f32_mask).expect("valid test mask");
    let b = MaskUniform::new(&f32_mask, &upload(&g, &f32_mask, Kind::D3)).to_bytes();
    assert_eq!(b[12..16], [0, 0, 0, 0]);
}

/// `stbn_mul_hi`, which the progressive epoch offsets use, is the high word of the exact
/// 64-bit product for every pair of `u32`s, extremes included.
#[test]
fn wgsl_mul_hi_is_the_high_word_of_the_product() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Require);
    let bytes = mask_blob(4, 4, 2, 1, Encoding::Unorm8, 9);
    let mask = Stbn::from_bytes(&bytes).expect("valid test mask");
    let texture = upload(&g, &mask, Kind::D3);
    // Both halves of the result as exact floats.
    let s = sampler_with(
        &g,
        Kind::D3,
        "vec4<f32>(f32(stbn_mul_hi(bitcast<u32>(q.x), q.frame) & 0xFFFFu), \
         f32(stbn_mul_hi(bitcast<u32>(q.x), q.frame) >> 16u), 0.0, 0.0)",
    );
    let special = [
        0,
        1,
        2,
        0xFFFF,
        0x1_0000,
        0x8000_0000,
        u32::MAX - 1,
        u32::MAX,
    ];
    let mut rng = Rng(17);
    let mut pairs: Vec<(u32, u32)> = special
        .iter()
        .flat_map(|&a| special.iter().map(move |&b| (a, b)))
        .collect();
    pairs.extend((0..4096).map(|_| (rng.next_u32(), rng.next_u32())));
    let qs: Vec<Query> = pairs
        .iter()
        .map(|&(a, b)| Query {
            x: a as i32,
            y: 0,
            frame: b,
            offset: SampleOffset::ZERO,
            dim: SampleOffset::ZERO,
        })
        .collect();
    let got = gpu_values(&g, &s, &texture, MaskUniform::new(&mask, &texture), &qs);
    for (&(a, b), v) in pairs.iter().zip(&got) {
        let expected = ((u64::from(a) * u64::from(b)) >> 32) as u32;
        let gpu = v[0] as u32 | (v[1] as u32) << 16;
        assert_eq!(gpu, expected, "stbn_mul_hi({a}, {b}) on {}", g.name);
    }
}

#[test]
#[should_panic(expected = "the texture is not an upload of this mask")]
fn mask_uniform_rejects_another_masks_texture() {
    let g = gpu(wgpu::Backends::VULKAN, Norm16::Off);
    let small = mask_blob(7, 5, 3, 1, Encoding::Unorm8, 3);
    let small = Stbn::from_bytes(&small).expect("valid test mask");
    let large = mask_blob(8, 5, 3, 1, Encoding::Unorm8, 3);
    let large = Stbn::from_bytes(&large).expect("valid test mask");
    let _ = MaskUniform::new(&small, &upload(&g, &large, Kind::D3));
}

/// The WGSL vector helpers (`stbn_octahedral`, `stbn_signed` + `normalize`,
/// `stbn_stored_pdf`) give what `Stbn::sample_vector` gives on the CPU, for environment
/// direction masks (octahedral pair + pdf) and signed hemisphere masks, in every encoding,
/// with and without 16-bit norm formats.
#[test]
fn vulkan_vector_helpers_match_sample_vector() {
    for norm16 in [Norm16::Require, Norm16::Off] {
        let g = gpu(wgpu::Backends::VULKAN, norm16);
        for encoding in ALL {
            let bits = match encoding {
                Encoding::Unorm8 => 8,
                Encoding::Unorm16 => 16,
                Encoding::F32 => 0,
            };
            let (pdf_min, pdf_max) = (0.03125f32, 9.5f32);
            let cases = [
                (
                    header(7, 5, 3, 3, encoding).with_space(
                        Space::EnvironmentDirections,
                        ValueMap::Octahedral,
                        pdf_min,
                        pdf_max,
                    ),
                    format!(
                        "vec4<f32>(stbn_octahedral(s.xy), \
                         stbn_stored_pdf(s.z, {bits}u, {pdf_min:?}, {pdf_max:?}))"
                    ),
                ),
                (
                    header(8, 4, 4, 3, encoding).with_space(
                        Space::CosineHemisphere,
                        ValueMap::Signed,
                        0.0,
                        0.0,
                    ),
                    "vec4<f32>(normalize(stbn_signed(s).xyz), 0.0)".to_owned(),
                ),
            ];
            for (hd, expr) in cases {
                let source = mask_blob(hd.width, hd.height, hd.depth, 3, encoding, 99);
                // Same payload, now declared as the vector space: random, so some hemisphere
                // directions lie below the horizon, which `from_bytes` refuses; the GPU must
                // still match the CPU on the values as stored.
                let bytes = blob(hd, &source[64..]);
                let mask = Stbn::from_bytes_unverified(&bytes).expect("valid vector mask header");
                let s = sampler_with(&g, Kind::D3, &expr);
                let texture = upload(&g, &mask, Kind::D3);
                let qs = queries(&mask, 5);
                let uniform = MaskUniform::new(&mask, &texture);
                let got = gpu_values(&g, &s, &texture, uniform, &qs);
                for (q, v) in qs.iter().zip(&got) {
                    let cpu = mask
                        .offset(q.offset)
                        .offset(q.dim)
                        .sample_vector(q.x, q.y, q.frame);
                    let what = format!("{:?} {encoding:?} {q:?} on {}", hd.space, g.name);
                    for c in 0..3 {
                        assert!(
                            (v[c] - cpu.value[c]).abs() <= 2e-6,
                            "{what}: component {c} GPU {v:?} CPU {cpu:?}"
                        );
                    }
                    if hd.space.stores_pdf() {
                        assert!(
                            (v[3] - cpu.pdf).abs() <= 1e-5 * pdf_max,
                            "{what}: pdf GPU {} CPU {}",
                            v[3],
                            cpu.pdf
                        );
                    }
                }
            }
        }
    }
}

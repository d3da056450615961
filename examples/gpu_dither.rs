//! Renders one frame of a gray ramp dithered to black and white by a spatiotemporal blue-noise
//! mask with wgpu, headless, and checks it against the same dither on the CPU.
//!
//! The mask, `SCALAR_64` (64×64×32, embedded by this package's `build.rs` from `assets.ron`), is
//! uploaded as a 3D texture, depth = frames, with `stbn_runtime::gpu::create_texture_3d`. The
//! fragment shader starts with the WGSL snippet `stbn_runtime::gpu::WGSL` and reads the mask with
//! `stbn_sample_3d(texture, mask, x, y, frame)`, where `mask` is a 32-byte `StbnMask` uniform
//! filled from `MaskUniform::new(&SCALAR_64, &texture)`. The snippet returns exactly the values
//! `SCALAR_64.sample(x, y, frame)` returns on the CPU, so the two frames agree pixel for pixel.
//!
//! Run: `cargo run --example gpu_dither --features gpu [-- <out dir>]` (default `out/gpu_dither`).
//! Needs a Vulkan, Metal, DX12 or GL adapter; on a machine without a GPU, Mesa's lavapipe
//! (`apt-get install mesa-vulkan-drivers libvulkan1`) works. `WGPU_BACKEND=vulkan` (or `gl`,
//! `metal`, `dx12`) picks the backend.
//!
//! Writes `frame_<FRAME>.png`, 256×64 8-bit grayscale, and prints the adapter it ran on.

use std::error::Error;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

use stbn_demo::masks::SCALAR_64;
use stbn_runtime::gpu::{self, MaskUniform, TextureOptions};
use wgpu::util::DeviceExt;

/// Image size in pixels; 256 one-byte pixels make a row that needs no padding for the copy.
const WIDTH: u32 = 256;
const HEIGHT: u32 = 64;
/// The frame rendered, any `u32`: the mask repeats every 32 frames.
const FRAME: u32 = 5;

/// A triangle covering the target, and a fragment shader that thresholds the ramp against the
/// mask. `pixel.x` is the pixel centre, x + 0.5, so the ramp is the CPU's value exactly.
const SHADER: &str = "
@group(0) @binding(0) var noise: texture_3d<f32>;
@group(0) @binding(1) var<uniform> mask: StbnMask;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let corner = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(corner * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) pixel: vec4<f32>) -> @location(0) vec4<f32> {
    let ramp = pixel.x * (1.0 / WIDTH);
    let threshold = stbn_sample_3d(noise, mask, i32(pixel.x), i32(pixel.y), FRAME).x;
    return vec4<f32>(select(0.0, 1.0, ramp > threshold));
}
";

fn main() -> Result<(), Box<dyn Error>> {
    let out = std::env::args_os()
        .nth(1)
        .map_or_else(|| PathBuf::from("out/gpu_dither"), PathBuf::from);
    std::fs::create_dir_all(&out)?;

    // A headless device: no window, no surface.
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))?;
    let info = adapter.get_info();
    println!("adapter: {} ({:?})", info.name, info.backend);
    let (device, queue) = pollster::block_on(adapter.request_device(&Default::default()))?;

    // The mask as a texture, and the uniform that tells the snippet how to read it.
    let noise = gpu::create_texture_3d(&device, &queue, &SCALAR_64, TextureOptions::default())?;
    let mask = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("StbnMask"),
        contents: &MaskUniform::new(&SCALAR_64, &noise).to_bytes(),
        usage: wgpu::BufferUsages::UNIFORM,
    });

    // The snippet goes in front of the shader; it declares no bindings.
    let source = format!(
        "{}\nconst WIDTH: f32 = {WIDTH}.0;\nconst FRAME: u32 = {FRAME}u;\n{SHADER}",
        gpu::WGSL
    );
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("dither"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let format = wgpu::TextureFormat::R8Unorm;
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("dither"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(
                    &noise.create_view(&Default::default()),
                ),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: mask.as_entire_binding(),
            },
        ],
    });

    // Render into a texture and copy it to a buffer the CPU can map.
    let size = wgpu::Extent3d {
        width: WIDTH,
        height: HEIGHT,
        depth_or_array_layers: 1,
    };
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("frame"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(WIDTH * HEIGHT),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let view = target.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("dither"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    encoder.copy_texture_to_buffer(
        target.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(WIDTH),
                rows_per_image: None,
            },
        },
        size,
    );
    queue.submit([encoder.finish()]);
    readback.map_async(wgpu::MapMode::Read, .., |result| {
        result.expect("map the readback buffer")
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let pixels = readback.get_mapped_range(..)?.to_vec();

    // The same frame on the CPU, from the same embedded mask.
    let expected: Vec<u8> = (0..HEIGHT as i32)
        .flat_map(|y| (0..WIDTH as i32).map(move |x| (x, y)))
        .map(|(x, y)| {
            let ramp = (x as f32 + 0.5) / WIDTH as f32;
            if ramp > SCALAR_64.sample(x, y, FRAME) {
                255
            } else {
                0
            }
        })
        .collect();
    let differing = pixels.iter().zip(&expected).filter(|(a, b)| a != b).count();
    if differing > 0 {
        return Err(format!("{differing} of {} pixels differ from the CPU", pixels.len()).into());
    }
    println!("all {} pixels agree with the CPU", pixels.len());

    let path = out.join(format!("frame_{FRAME}.png"));
    let mut png = png::Encoder::new(BufWriter::new(File::create(&path)?), WIDTH, HEIGHT);
    png.set_color(png::ColorType::Grayscale);
    png.set_depth(png::BitDepth::Eight);
    png.write_header()?.write_image_data(&pixels)?;
    println!("wrote {}", path.display());
    Ok(())
}

//! The GPU renderer: the same frames as [`crate::render`], computed by a wgpu compute shader that
//! samples the noise through [`stbn_runtime::gpu::WGSL`] from a texture made by
//! [`stbn_runtime::gpu::create_texture_3d`] (turned into a pixel's sample by
//! [`wgsl_pixel_sample`]), shades with the scene's WGSL and accumulates with
//! [`crate::accumulate::WGSL`] in a storage buffer.

use std::fmt;

use stbn_runtime::gpu::{self as stbn_gpu, MaskUniform, TextureOptions};
use stbn_runtime::{Stbn, ValueMap};
use wgpu::util::DeviceExt;

use crate::accumulate::{self, EMA_ALPHA};
use crate::image::Image;
use crate::render::{Checkpoint, frames_to_render};
use crate::sample::{FrameOrder, SampleMode, wgsl_pixel_sample};
use crate::scene::Scene;

/// Why no GPU device could be set up.
#[derive(Debug)]
pub enum GpuSetupError {
    /// No adapter for the requested backends.
    NoAdapter {
        /// The backends asked for.
        backends: wgpu::Backends,
        /// wgpu's reason.
        reason: String,
    },
    /// The adapter refused the device.
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        reason: String,
    },
}

impl fmt::Display for GpuSetupError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuSetupError::NoAdapter { backends, reason } => write!(
                f,
                "no {backends:?} adapter ({reason}). On a machine without a GPU install Mesa's \
                 CPU Vulkan driver, lavapipe: `apt-get install mesa-vulkan-drivers libvulkan1` \
                 (scripts/test.sh does this when run as root)"
            ),
            GpuSetupError::RequestDevice { adapter, reason } => {
                write!(f, "request_device on {adapter}: {reason}")
            }
        }
    }
}

impl std::error::Error for GpuSetupError {}

/// A wgpu device and queue on the first adapter of some backends.
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// "name (backend, driver)" of the adapter, for reports.
    pub adapter: String,
}

impl GpuContext {
    /// A device on the first adapter of `backends` (e.g. `wgpu::Backends::VULKAN`, which is
    /// lavapipe on a machine without a GPU), with the adapter's own limits and, where offered,
    /// `TEXTURE_FORMAT_16BIT_NORM` (so `Unorm16` masks upload as `R16Unorm`).
    pub fn new(backends: wgpu::Backends) -> Result<GpuContext, GpuSetupError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| GpuSetupError::NoAdapter {
            backends,
            reason: e.to_string(),
        })?;
        let info = adapter.get_info();
        let name = format!("{} ({:?}, {})", info.name, info.backend, info.driver);
        let required_features = adapter.features() & wgpu::Features::TEXTURE_FORMAT_16BIT_NORM;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("stbn-scenes"),
            required_features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuSetupError::RequestDevice {
            adapter: name.clone(),
            reason: e.to_string(),
        })?;
        Ok(GpuContext {
            device,
            queue,
            adapter: name,
        })
    }
}

/// The per-frame uniform `FrameParams`: `frame`, `width`, `height`, `alpha` (f32 bits): 16 bytes.
const FRAME_UNIFORM_SIZE: u64 = 16;

/// A scene ready for the device: its shader source (without the sampling function) and its
/// data in a storage buffer. Pipelines are compiled per [`SampleMode`] in
/// [`render`](Self::render).
pub struct GpuSceneRenderer<'a> {
    ctx: &'a GpuContext,
    name: String,
    width: u32,
    height: u32,
    scene_wgsl: String,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    scene_data: wgpu::Buffer,
}

/// Workgroup edge: 8 × 8 invocations, one per pixel.
const WORKGROUP: u32 = 8;

impl<'a> GpuSceneRenderer<'a> {
    /// Prepares `scene` (its WGSL, its bind-group layout) and uploads its data.
    pub fn new(ctx: &'a GpuContext, scene: &dyn Scene) -> GpuSceneRenderer<'a> {
        let device = &ctx.device;
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty,
            count: None,
        };
        let uniform = |size| wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        };
        let storage = |read_only| wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene"),
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D3,
                        multisampled: false,
                    },
                ),
                entry(1, uniform(MaskUniform::SIZE)),
                entry(2, uniform(FRAME_UNIFORM_SIZE)),
                entry(3, storage(true)),
                entry(4, storage(false)),
                entry(5, uniform(MaskUniform::SIZE)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let data = scene.gpu_data();
        assert!(!data.is_empty(), "scene data must not be empty");
        let scene_data = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene data"),
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::STORAGE,
        });
        GpuSceneRenderer {
            ctx,
            name: scene.name().to_owned(),
            width: scene.width(),
            height: scene.height(),
            scene_wgsl: scene.wgsl(),
            layout,
            pipeline_layout,
            scene_data,
        }
    }

    /// The compute pipeline for samples read under `mode` from masks with `value_map`: the
    /// runtime's WGSL snippet, [`wgsl_pixel_sample`], the scene's `scene_shade` and the
    /// accumulation.
    fn pipeline(&self, mode: SampleMode, value_map: ValueMap) -> wgpu::ComputePipeline {
        let source = format!(
            "{stbn}
struct FrameParams {{ frame: u32, width: u32, height: u32, alpha: f32 }}
@group(0) @binding(0) var noise: texture_3d<f32>;
@group(0) @binding(1) var<uniform> noise_dim0: StbnMask;
@group(0) @binding(2) var<uniform> frame_params: FrameParams;
@group(0) @binding(3) var<storage, read> scene_data: array<f32>;
@group(0) @binding(4) var<storage, read_write> history: array<vec2<f32>>;
@group(0) @binding(5) var<uniform> noise_dim1: StbnMask;
{accumulate}
{sample}
{scene}
@compute @workgroup_size({WORKGROUP}, {WORKGROUP})
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    if id.x >= frame_params.width || id.y >= frame_params.height {{
        return;
    }}
    let s = pixel_sample(i32(id.x), i32(id.y), frame_params.frame);
    let i = id.y * frame_params.width + id.x;
    history[i] = accumulate(history[i], scene_shade(id.x, id.y, s), frame_params.frame,
        frame_params.alpha);
}}
",
            stbn = stbn_gpu::WGSL,
            accumulate = accumulate::WGSL,
            sample = wgsl_pixel_sample(mode, value_map),
            scene = self.scene_wgsl,
        );
        let device = &self.ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&self.name),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(&self.name),
            layout: Some(&self.pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        })
    }

    /// Uploads `noise`, renders frames `0..last checkpoint` with samples read in `order` (the
    /// uniforms of [`FrameOrder::view`]) under `mode` (one dispatch per frame) and reads the
    /// accumulated images back at each checkpoint (frame counts, strictly increasing, from 1;
    /// panics otherwise, see [`frames_to_render`]).
    ///
    /// # Errors
    /// The runtime's upload error if the mask exceeds the device's 3D texture limits.
    pub fn render(
        &self,
        noise: &Stbn<'_>,
        order: FrameOrder,
        mode: SampleMode,
        checkpoints: &[u32],
    ) -> Result<Vec<Checkpoint>, stbn_gpu::GpuError> {
        let frames = frames_to_render(checkpoints).unwrap_or_else(|e| panic!("{e}"));
        let pipeline = self.pipeline(mode, noise.header().value_map);
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let texture = stbn_gpu::create_texture_3d(
            device,
            queue,
            noise,
            TextureOptions {
                label: Some("noise"),
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
            },
        )?;
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D3),
            ..Default::default()
        });
        let mask_uniform = |label, uniform: MaskUniform| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &uniform.to_bytes(),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let noise_view = order.view(noise);
        let noise_dim0 = mask_uniform("noise dimension 0", MaskUniform::new(noise_view, &texture));
        let noise_dim1 = mask_uniform(
            "noise dimension 1",
            MaskUniform::new(noise_view.dimension(1), &texture),
        );
        let frame_params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame params"),
            size: FRAME_UNIFORM_SIZE,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pixels = u64::from(self.width) * u64::from(self.height);
        let history_size = pixels * 8;
        let history = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("history"),
            size: history_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size: history_size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: noise_dim0.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: frame_params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: self.scene_data.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: history.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: noise_dim1.as_entire_binding(),
                },
            ],
        });
        let mut out = Vec::with_capacity(checkpoints.len());
        for frame in 0..frames {
            let words = [frame, self.width, self.height, EMA_ALPHA.to_bits()];
            let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
            // Written before this frame's submit, so each dispatch sees its own frame number.
            queue.write_buffer(&frame_params, 0, &bytes);
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups(
                    self.width.div_ceil(WORKGROUP),
                    self.height.div_ceil(WORKGROUP),
                    1,
                );
            }
            let checkpoint = checkpoints.contains(&(frame + 1));
            if checkpoint {
                encoder.copy_buffer_to_buffer(&history, 0, &staging, 0, history_size);
            }
            queue.submit([encoder.finish()]);
            if checkpoint {
                out.push(self.read_checkpoint(&staging, frame + 1));
            }
        }
        Ok(out)
    }

    fn read_checkpoint(&self, staging: &wgpu::Buffer, frames: u32) -> Checkpoint {
        staging.map_async(wgpu::MapMode::Read, .., |r| r.expect("map_async"));
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("device poll");
        let pairs: Vec<f32> = staging
            .get_mapped_range(..)
            .expect("mapped range")
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        staging.unmap();
        let (ema, mean): (Vec<f32>, Vec<f32>) = pairs.chunks_exact(2).map(|p| (p[0], p[1])).unzip();
        Checkpoint {
            frames,
            ema: Image::from_pixels(self.width, self.height, ema),
            mean: Image::from_pixels(self.width, self.height, mean),
        }
    }
}

//! GPU upload throughput (feature `wgpu`): `gpu::create_texture_3d` against a plain
//! `create_texture` + one `queue.write_texture` of the same bytes (the baseline, same run),
//! each followed by a submit and a wait, for a 128×128×64 mask in Unorm8 (1 channel), Unorm16
//! (1 channel) and Unorm8 RGBA (4 channels).
//!
//! Runs on the first adapter wgpu finds (`WGPU_BACKEND` chooses the backend); on a machine
//! without a GPU that is Mesa's lavapipe, so the figures measure its CPU copies, not a GPU's.
//! `cargo bench -p stbn-runtime --features wgpu --bench upload`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use stbn_runtime::gpu::{self, TextureOptions};
use stbn_runtime::{Compression, Encoding, MaskHeader, Stbn};

const W: u32 = 128;
const H: u32 = 128;
const D: u32 = 64;

fn device() -> (wgpu::Device, wgpu::Queue, String) {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("no wgpu adapter: install mesa-vulkan-drivers for lavapipe");
    let info = adapter.get_info();
    let features = adapter.features() & wgpu::Features::TEXTURE_FORMAT_16BIT_NORM;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_features: features,
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .expect("request_device");
    (device, queue, format!("{} ({:?})", info.name, info.backend))
}

fn blob(channels: u8, encoding: Encoding) -> Vec<u8> {
    let header = MaskHeader::new(W, H, D, channels, encoding);
    let payload: Vec<u8> = (0..header.decoded_len())
        .map(|i| (i as u32).wrapping_mul(2_654_435_761) as u8)
        .collect();
    let mut out = header
        .with_payload(Compression::None, &payload)
        .to_bytes()
        .to_vec();
    out.extend_from_slice(&payload);
    out
}

/// Waits until the queue has finished everything submitted so far.
fn finish(device: &wgpu::Device, queue: &wgpu::Queue) {
    queue.submit([]);
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
}

fn bench(c: &mut Criterion) {
    let (device, queue, name) = device();
    eprintln!("upload bench on {name}");
    let usage = wgpu::TextureUsages::TEXTURE_BINDING;
    for (label, channels, encoding) in [
        ("unorm8", 1, Encoding::Unorm8),
        ("unorm16", 1, Encoding::Unorm16),
        ("unorm8x4", 4, Encoding::Unorm8),
    ] {
        let bytes = blob(channels, encoding);
        let mask = Stbn::from_bytes(&bytes).unwrap();
        let mut group = c.benchmark_group(format!("upload_128x128x64_{label}"));
        group.throughput(Throughput::Bytes(mask.data().len() as u64));
        group.sample_size(20);
        group.bench_function("create_texture_3d", |b| {
            b.iter(|| {
                let options = TextureOptions { label: None, usage };
                let texture = gpu::create_texture_3d(&device, &queue, &mask, options).unwrap();
                finish(&device, &queue);
                black_box(texture);
            })
        });
        let format = gpu::texture_format(encoding, channels, device.features());
        let row_bytes = mask.data().len() as u32 / (H * D);
        let texel = format.block_copy_size(None).unwrap_or(0);
        if texel * W != row_bytes {
            // The device lacks 16-bit norm formats: the mask uploads through the f32 fallback,
            // which a raw copy of its bytes cannot reproduce.
            eprintln!("{label}: no baseline on this device ({format:?})");
            group.finish();
            continue;
        }
        group.bench_function("baseline_write_texture", |b| {
            b.iter(|| {
                let texture = device.create_texture(&wgpu::TextureDescriptor {
                    label: None,
                    size: wgpu::Extent3d {
                        width: W,
                        height: H,
                        depth_or_array_layers: D,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D3,
                    format,
                    usage: usage | wgpu::TextureUsages::COPY_DST,
                    view_formats: &[],
                });
                queue.write_texture(
                    texture.as_image_copy(),
                    mask.data(),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row_bytes),
                        rows_per_image: Some(H),
                    },
                    texture.size(),
                );
                finish(&device, &queue);
                black_box(texture);
            })
        });
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);

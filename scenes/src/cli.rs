//! The command line shared by the scene binaries: options, and [`run`], which renders scenes
//! with the four noises and writes their tables and strips.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::error::Error;
use std::fs;
use std::path::PathBuf;
use std::time::Instant;

use clap::{Parser, ValueEnum};
use stbn_runtime::Encoding;

use crate::compare::{Backend, Comparison};
use crate::gpu::GpuContext;
use crate::noise::{NoiseKind, NoiseMask, NoiseSpec, generate_all};
use crate::report;
use crate::scene::{Scene, SceneInput};
use crate::strip;

/// Where the frames are rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DeviceArg {
    /// wgpu compute shaders on the first Vulkan adapter (lavapipe without a GPU).
    Vulkan,
    /// wgpu compute shaders on the first GL adapter (Mesa llvmpipe without a GPU).
    Gl,
    /// The CPU renderer.
    Cpu,
}

/// How the masks store their values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EncodingArg {
    /// 8 bits per value.
    Unorm8,
    /// 16 bits per value.
    Unorm16,
    /// 32-bit float.
    F32,
}

impl From<EncodingArg> for Encoding {
    fn from(e: EncodingArg) -> Encoding {
        match e {
            EncodingArg::Unorm8 => Encoding::Unorm8,
            EncodingArg::Unorm16 => Encoding::Unorm16,
            EncodingArg::F32 => Encoding::F32,
        }
    }
}

/// Options of every scene binary.
#[derive(Clone, Debug, Parser)]
pub struct Options {
    /// Output directory; each scene writes `<out>/<scene>/` (rmse.md, rmse.csv, PNG strips).
    #[arg(long, default_value = "out/scenes")]
    pub out: PathBuf,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Mask width and height in pixels (the image tiles the mask).
    #[arg(long, default_value_t = 128)]
    pub mask_size: u32,
    /// Mask frames (the sequence repeats after this many).
    #[arg(long, default_value_t = 64)]
    pub mask_frames: u32,
    /// Frame counts at which RMSE and strips are taken (increasing, from 1); the last is the
    /// number of frames rendered.
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64")]
    pub checkpoints: Vec<u32>,
    /// Seed of every noise source and of the procedural content.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Mask storage.
    #[arg(long, value_enum, default_value_t = EncodingArg::Unorm16)]
    pub encoding: EncodingArg,
    /// Renderer.
    #[arg(long, value_enum, default_value_t = DeviceArg::Vulkan)]
    pub device: DeviceArg,
}

/// Generates the noises the scenes take ([`NoiseKind::for_input`]), renders every scene with
/// each on the chosen device, and writes
/// `<out>/<scene>/rmse.md`, `rmse.csv` and the strips; prints the Markdown to stdout and
/// progress and (noisy, wall-clock) timings to stderr.
pub fn run(options: &Options, scenes: &[&dyn Scene]) -> Result<(), Box<dyn Error>> {
    let spec = NoiseSpec {
        width: options.mask_size,
        height: options.mask_size,
        depth: options.mask_frames,
        seed: options.seed,
        encoding: options.encoding.into(),
    };
    let ctx = match options.device {
        DeviceArg::Vulkan => Some(GpuContext::new(wgpu::Backends::VULKAN)?),
        DeviceArg::Gl => Some(GpuContext::new(wgpu::Backends::GL)?),
        DeviceArg::Cpu => None,
    };
    let (backend, device_name) = match &ctx {
        Some(ctx) => (Backend::Gpu(ctx), ctx.adapter.clone()),
        None => (Backend::Cpu, "CPU renderer".to_owned()),
    };
    let mut masks: HashMap<SceneInput, Vec<NoiseMask>> = HashMap::new();
    for scene in scenes {
        let input = scene.input();
        if let Entry::Vacant(slot) = masks.entry(input) {
            let start = Instant::now();
            let kinds = NoiseKind::for_input(input);
            slot.insert(generate_all(kinds, &spec)?);
            eprintln!(
                "generated {} masks of {}×{}×{} ({:?}) in {:.1} s",
                kinds.len(),
                spec.width,
                spec.height,
                spec.depth,
                spec.encoding,
                start.elapsed().as_secs_f64()
            );
        }
        let start = Instant::now();
        let cmp = Comparison::run(*scene, &masks[&input], &options.checkpoints, backend)?;
        eprintln!(
            "{}: rendered and measured on {device_name} in {:.1} s",
            cmp.scene,
            start.elapsed().as_secs_f64()
        );
        let dir = options.out.join(&cmp.scene);
        fs::create_dir_all(&dir)?;
        let mut md = report::markdown(&cmp);
        md.push_str(&format!(
            "Masks {0}×{0}×{1}, {2:?}, seed {3}; rendered on {device_name}.\n",
            spec.width, spec.depth, spec.encoding, spec.seed
        ));
        fs::write(dir.join("rmse.md"), &md)?;
        fs::write(dir.join("rmse.csv"), report::csv(&cmp))?;
        let strips = strip::write_strips(&dir, &cmp)?;
        println!("{md}");
        eprintln!("wrote {} and {} strips", dir.display(), strips.len());
    }
    Ok(())
}

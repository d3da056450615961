//! The command line shared by the scene binaries: options, and [`run`], which renders scenes
//! with the noises of a [`Study`] and writes their tables and strips.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::error::Error;
use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{CommandFactory, FromArgMatches, Parser, ValueEnum};
use stbn_runtime::Encoding;

use crate::compare::{Backend, Comparison};
use crate::gpu::GpuContext;
use crate::noise::{NoiseKind, NoiseMask, NoiseSpec, generate_all, generate_past_depth};
use crate::render::frames_to_render;
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

impl Options {
    /// Parses the process's arguments with `checkpoints` (comma-separated frame counts) as the
    /// default of `--checkpoints`; exits with clap's message on bad arguments.
    pub fn parse_with_checkpoints(checkpoints: &'static str) -> Options {
        let matches = Options::command()
            .mut_arg("checkpoints", |arg| arg.default_value(checkpoints))
            .get_matches();
        Options::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
    }
}

/// Which noise sources a binary compares, and where it writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Study {
    /// Every source of the scene's input ([`NoiseKind::for_input`]), into `<out>/<scene>/`.
    AllSources,
    /// White noise with a slice per frame, STBN wrapping every `depth` frames and STBN read
    /// progressively ([`generate_past_depth`]), into `<out>/<scene>_past_depth/`: what reading
    /// a mask progressively buys when the frames outnumber its depth. Scalar scenes only.
    PastDepth,
}

impl Study {
    /// The masks compared on scenes that take `input`, over runs of `frames` frames, generated
    /// at `spec`.
    ///
    /// # Errors
    /// The generator's, or a scene input the study has no sources for.
    pub fn masks(
        self,
        input: SceneInput,
        spec: &NoiseSpec,
        frames: u32,
    ) -> Result<Vec<NoiseMask>, Box<dyn Error>> {
        Ok(match (self, input) {
            (Study::AllSources, _) => generate_all(NoiseKind::for_input(input), spec)?,
            (Study::PastDepth, SceneInput::Scalar) => {
                generate_past_depth(spec, frames).map_err(|e| {
                    format!("white noise with a slice for each of {frames} frames, or STBN: {e}")
                })?
            }
            (Study::PastDepth, SceneInput::Direction) => {
                let message = "the past-depth study compares scalar sources, not directions";
                return Err(message.into());
            }
        })
    }

    /// The name of the study's comparison of `scene` (its output directory and table heading).
    pub fn comparison_name(self, scene: &str) -> String {
        match self {
            Study::AllSources => scene.to_owned(),
            Study::PastDepth => format!("{scene}_past_depth"),
        }
    }
}

/// Generates the noises `study` compares on each scene ([`Study::masks`]), renders every
/// scene with each on the chosen device, and writes `<out>/<name>/rmse.md`, `rmse.csv` and the
/// strips (`name` from [`Study::comparison_name`]); prints the Markdown to stdout and progress
/// and (noisy, wall-clock) timings to stderr.
///
/// # Errors
/// Checkpoints that are not strictly increasing frame counts from 1, no device, a mask the
/// generator or the device rejects, a scene the study has no sources for, or a file that cannot
/// be written (named).
pub fn run(options: &Options, study: Study, scenes: &[&dyn Scene]) -> Result<(), Box<dyn Error>> {
    let frames =
        frames_to_render(&options.checkpoints).map_err(|e| format!("--checkpoints: {e}"))?;
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
            let masks = study
                .masks(input, &spec, frames)
                .map_err(|e| format!("{}: {e}", scene.name()))?;
            eprintln!(
                "generated {} masks ({}) in {:.1} s",
                masks.len(),
                mask_sizes(&masks, &spec),
                start.elapsed().as_secs_f64()
            );
            slot.insert(masks);
        }
        let start = Instant::now();
        let mut cmp = Comparison::run(*scene, &masks[&input], &options.checkpoints, backend)?;
        cmp.scene = study.comparison_name(&cmp.scene);
        eprintln!(
            "{}: rendered and measured on {device_name} in {:.1} s",
            cmp.scene,
            start.elapsed().as_secs_f64()
        );
        let dir = options.out.join(&cmp.scene);
        let named = |path: &Path| {
            let path = path.display().to_string();
            move |e: std::io::Error| format!("{path}: {e}")
        };
        fs::create_dir_all(&dir).map_err(named(&dir))?;
        let mut md = report::markdown(&cmp);
        md.push_str(&format!(
            "Masks {}; rendered on {device_name}.\n",
            mask_sizes(&masks[&input], &spec)
        ));
        let (md_path, csv_path) = (dir.join("rmse.md"), dir.join("rmse.csv"));
        fs::write(&md_path, &md).map_err(named(&md_path))?;
        fs::write(&csv_path, report::csv(&cmp)).map_err(named(&csv_path))?;
        let strips = strip::write_strips(&dir, &cmp).map_err(named(&dir))?;
        println!("{md}");
        eprintln!("wrote {} and {} strips", dir.display(), strips.len());
    }
    Ok(())
}

/// `128×128×64, Unorm16, seed 1`: the masks' size (per source where they differ, e.g.
/// `white noise 128×128×1024, STBN 128×128×64, …`), encoding and seed.
fn mask_sizes(masks: &[NoiseMask], spec: &NoiseSpec) -> String {
    let size = |m: &NoiseMask| {
        let view = m.view();
        format!("{}×{}×{}", view.width(), view.height(), view.depth())
    };
    let sizes: Vec<String> = masks.iter().map(size).collect();
    let sizes = if sizes.windows(2).all(|w| w[0] == w[1]) {
        sizes.first().cloned().unwrap_or_default()
    } else {
        let per_source: Vec<String> = masks
            .iter()
            .zip(&sizes)
            .map(|(m, s)| format!("{} {s}", m.kind.label()))
            .collect();
        per_source.join(", ")
    };
    format!("{sizes}, {:?}, seed {}", spec.encoding, spec.seed)
}

//! What to generate: [`MaskSpec`] and its validation.

use core::fmt;

/// Which pixel pairs interact in the void-and-cluster energy.
///
/// All three share one engine, void-and-cluster (Ulichney 1993) over the whole volume as in the
/// paper's §4.1; they differ only in the kernel's footprint.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EnergyTopology {
    /// The STBN paper's energy (eq. 4): pixels interact when they share a slice (same frame, 2D
    /// Gaussian over x, y with `sigma_xy`) or a pixel position (same x, y, 1D Gaussian over frames
    /// with `sigma_z`). Blue in space and in time.
    Spatiotemporal,
    /// Only pixels of the same slice interact: an independent 2D blue-noise mask per frame (white
    /// over time). A baseline.
    Independent2D,
    /// Every pair interacts through an isotropic 3D Gaussian (`sigma_xy` in x and y, `sigma_z` over
    /// frames). 3D blue noise: neither blue within a slice nor over time. A baseline.
    Isotropic3D,
}

impl EnergyTopology {
    /// A short lowercase name, stable for file names and reports.
    pub fn name(self) -> &'static str {
        match self {
            EnergyTopology::Spatiotemporal => "spatiotemporal",
            EnergyTopology::Independent2D => "independent2d",
            EnergyTopology::Isotropic3D => "isotropic3d",
        }
    }
}

/// Everything that determines a scalar STBN mask, bit for bit ([`crate::generate`]).
///
/// Two equal specs produce identical [`crate::Volume`]s on every machine and for every thread
/// count.
#[derive(Clone, Debug, PartialEq)]
pub struct MaskSpec {
    /// Pixels per row, `1..=`[`MaskSpec::MAX_AXIS`].
    pub width: u32,
    /// Rows per slice, `1..=`[`MaskSpec::MAX_AXIS`].
    pub height: u32,
    /// Slices (frames), `1..=`[`MaskSpec::MAX_AXIS`].
    pub depth: u32,
    /// Seed of the initial pattern and of the tie-break order.
    pub seed: u64,
    /// Gaussian σ over x and y, in pixels; finite, at least [`MaskSpec::MIN_SIGMA`]. The paper
    /// uses 1.9.
    pub sigma_xy: f64,
    /// Gaussian σ over frames, in frames; finite, at least [`MaskSpec::MIN_SIGMA`]. The paper
    /// uses 1.9.
    pub sigma_z: f64,
    /// Fraction of pixels turned on in the initial binary pattern, in `(0, 0.5]`. The paper uses 0.1.
    pub initial_density: f64,
    /// Which pixel pairs interact.
    pub topology: EnergyTopology,
    /// Kernel truncation: weights below `kernel_tolerance` (relative to the peak weight 1) are
    /// dropped. In `(0, 1)`. The default 5e-3 keeps offsets up to σ·√(2 ln 200) = 3.26σ (6.2
    /// pixels at σ 1.9, like the reference SDK's radius 6). BENCHMARKS.md measures 1e-3 and 1e-4
    /// taking about a third more time for low-band figures within 1% of these.
    pub kernel_tolerance: f64,
}

impl MaskSpec {
    /// σ the paper uses on every axis.
    pub const DEFAULT_SIGMA: f64 = 1.9;
    /// Initial binary-pattern density the paper uses.
    pub const DEFAULT_DENSITY: f64 = 0.1;
    /// Default kernel truncation tolerance.
    pub const DEFAULT_KERNEL_TOLERANCE: f64 = 5e-3;
    /// Smallest σ accepted on either axis. Below about 7.5e-155, `1/σ²` overflows and the kernel
    /// loses its centre tap, without which void-and-cluster never settles; every σ below about
    /// 0.3 pixels gives the same kernel anyway (the pixel alone, at the default tolerance).
    pub const MIN_SIGMA: f64 = 1e-150;
    /// Largest extent of one axis.
    pub const MAX_AXIS: u32 = 1 << 16;
    /// Largest number of pixels of one slice: ranks within a slice stay exactly representable as
    /// distinct `f32` values `(rank + 0.5) / n`.
    pub const MAX_SLICE_PIXELS: u64 = 1 << 24;
    /// Largest number of pixels of a volume (about 1.25 GiB of generator memory).
    pub const MAX_PIXELS: u64 = 1 << 26;
    /// Generator memory per pixel in bytes, an upper bound: the energy word, its copy for the
    /// concurrent phase 2a, the tie-break priority and the fill / removal order, 4 bytes each, plus
    /// 4 for the per-slice ranks (the global ranks reuse the energy buffer; the extremum trees add
    /// under 1%). Measured peak: 16 bytes per pixel (135 MB for 256×256×128, BENCHMARKS.md).
    pub const BYTES_PER_PIXEL: u64 = 20;

    /// A spatiotemporal spec with the paper's defaults.
    pub fn new(width: u32, height: u32, depth: u32, seed: u64) -> MaskSpec {
        MaskSpec {
            width,
            height,
            depth,
            seed,
            sigma_xy: Self::DEFAULT_SIGMA,
            sigma_z: Self::DEFAULT_SIGMA,
            initial_density: Self::DEFAULT_DENSITY,
            topology: EnergyTopology::Spatiotemporal,
            kernel_tolerance: Self::DEFAULT_KERNEL_TOLERANCE,
        }
    }

    /// The same spec with another topology.
    pub fn with_topology(mut self, topology: EnergyTopology) -> MaskSpec {
        self.topology = topology;
        self
    }

    /// The same spec with σ on every axis.
    pub fn with_sigma(mut self, sigma: f64) -> MaskSpec {
        self.sigma_xy = sigma;
        self.sigma_z = sigma;
        self
    }

    /// Number of pixels of one slice.
    pub fn slice_pixels(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height)
    }

    /// Number of pixels of the volume.
    pub fn pixels(&self) -> u64 {
        self.slice_pixels() * u64::from(self.depth)
    }

    /// Distinct `(Δx, Δy, Δz)` offsets (wrapped, the origin included) with a nonzero weight in
    /// the truncated energy kernel: the footprint every void-and-cluster step updates, so the
    /// generator's cost per pixel. Panics if the spec is invalid ([`MaskSpec::validate`]).
    pub fn kernel_taps(&self) -> usize {
        self.validate().expect("a valid spec");
        crate::kernel::EnergyKernel::new(self).taps()
    }

    /// Checks every field against its documented range.
    ///
    /// Sizes are checked before anything is allocated, and an oversized request reports the memory
    /// it would have taken.
    pub fn validate(&self) -> Result<(), SpecError> {
        for (field, value) in [
            ("width", self.width),
            ("height", self.height),
            ("depth", self.depth),
        ] {
            if value == 0 || value > Self::MAX_AXIS {
                return Err(SpecError::AxisOutOfRange { field, value });
            }
        }
        if self.slice_pixels() > Self::MAX_SLICE_PIXELS || self.pixels() > Self::MAX_PIXELS {
            return Err(SpecError::TooLarge {
                width: self.width,
                height: self.height,
                depth: self.depth,
                bytes_needed: self.pixels() * Self::BYTES_PER_PIXEL,
            });
        }
        for (field, value) in [("sigma_xy", self.sigma_xy), ("sigma_z", self.sigma_z)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(SpecError::InvalidSigma { field, value });
            }
            if value < Self::MIN_SIGMA {
                return Err(SpecError::SigmaTooSmall { field, value });
            }
        }
        if !(self.initial_density > 0.0 && self.initial_density <= 0.5) {
            return Err(SpecError::InvalidDensity(self.initial_density));
        }
        if !(self.kernel_tolerance > 0.0 && self.kernel_tolerance < 1.0) {
            return Err(SpecError::InvalidTolerance(self.kernel_tolerance));
        }
        Ok(())
    }
}

/// A [`MaskSpec`] field outside its range. `Display` names the field and the allowed range.
#[derive(Clone, Debug, PartialEq)]
pub enum SpecError {
    /// `width`, `height` or `depth` is 0 or above [`MaskSpec::MAX_AXIS`].
    AxisOutOfRange {
        /// The field's name.
        field: &'static str,
        /// The value given.
        value: u32,
    },
    /// The slice or the volume has more pixels than the generator accepts.
    TooLarge {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// Requested depth.
        depth: u32,
        /// Generator memory the request would have needed, in bytes.
        bytes_needed: u64,
    },
    /// σ is not finite or not positive.
    InvalidSigma {
        /// The field's name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// σ is positive but below [`MaskSpec::MIN_SIGMA`].
    SigmaTooSmall {
        /// The field's name.
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// The initial density is outside `(0, 0.5]`.
    InvalidDensity(f64),
    /// The kernel tolerance is outside `(0, 1)`.
    InvalidTolerance(f64),
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpecError::AxisOutOfRange { field, value } => write!(
                f,
                "`{field}` is {value}; it must be in 1..={}",
                MaskSpec::MAX_AXIS
            ),
            SpecError::TooLarge {
                width,
                height,
                depth,
                bytes_needed,
            } => write!(
                f,
                "`size` {width}x{height}x{depth} is too large: generating it would take about {:.1} GiB; \
                 the limits are {} pixels per slice and {} pixels per volume (about {:.1} GiB)",
                *bytes_needed as f64 / f64::from(1u32 << 30),
                MaskSpec::MAX_SLICE_PIXELS,
                MaskSpec::MAX_PIXELS,
                (MaskSpec::MAX_PIXELS * MaskSpec::BYTES_PER_PIXEL) as f64 / f64::from(1u32 << 30),
            ),
            SpecError::InvalidSigma { field, value } => {
                write!(f, "`{field}` is {value}; it must be finite and > 0")
            }
            SpecError::SigmaTooSmall { field, value } => write!(
                f,
                "`{field}` is {value:e}; it must be at least {:e} (1/σ² must be finite for the \
                 kernel to keep its centre pixel)",
                MaskSpec::MIN_SIGMA
            ),
            SpecError::InvalidDensity(value) => {
                write!(f, "`density` is {value}; it must be in (0, 0.5]")
            }
            SpecError::InvalidTolerance(value) => {
                write!(f, "`kernel_tolerance` is {value}; it must be in (0, 1)")
            }
        }
    }
}

impl std::error::Error for SpecError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(MaskSpec::new(64, 64, 32, 1).validate(), Ok(()));
        assert_eq!(MaskSpec::new(1, 1, 1, 1).validate(), Ok(()));
    }

    /// Every σ the validation accepts keeps `1/σ²` finite, so the kernel has its centre tap.
    #[test]
    fn the_smallest_sigma_keeps_the_kernel_finite() {
        let spec = MaskSpec::new(8, 8, 4, 0).with_sigma(MaskSpec::MIN_SIGMA);
        assert_eq!(spec.validate(), Ok(()));
        assert!((1.0 / (MaskSpec::MIN_SIGMA * MaskSpec::MIN_SIGMA)).is_finite());
    }

    #[test]
    fn rejects_each_bad_field() {
        let base = MaskSpec::new(8, 8, 8, 0);
        let cases: Vec<(MaskSpec, &str)> = vec![
            (
                MaskSpec {
                    width: 0,
                    ..base.clone()
                },
                "`width`",
            ),
            (
                MaskSpec {
                    depth: 1 << 17,
                    ..base.clone()
                },
                "`depth`",
            ),
            (
                MaskSpec {
                    width: 8192,
                    height: 8192,
                    depth: 2,
                    ..base.clone()
                },
                "GiB",
            ),
            (
                MaskSpec {
                    sigma_xy: f64::NAN,
                    ..base.clone()
                },
                "`sigma_xy`",
            ),
            (
                MaskSpec {
                    sigma_z: -1.0,
                    ..base.clone()
                },
                "`sigma_z`",
            ),
            (
                MaskSpec {
                    sigma_xy: 1e-200,
                    ..base.clone()
                },
                "`sigma_xy` is 1e-200; it must be at least 1e-150",
            ),
            (
                MaskSpec {
                    sigma_z: 5e-324,
                    ..base.clone()
                },
                "`sigma_z`",
            ),
            (
                MaskSpec {
                    initial_density: 0.0,
                    ..base.clone()
                },
                "`density`",
            ),
            (
                MaskSpec {
                    initial_density: 0.51,
                    ..base.clone()
                },
                "`density`",
            ),
            (
                MaskSpec {
                    kernel_tolerance: 1.0,
                    ..base.clone()
                },
                "`kernel_tolerance`",
            ),
        ];
        for (spec, needle) in cases {
            let message = spec.validate().unwrap_err().to_string();
            assert!(message.contains(needle), "{message:?} lacks {needle:?}");
        }
    }
}

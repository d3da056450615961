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
    /// Gaussian σ over x and y, in pixels. The paper uses 1.9. Finite, and where the slice has
    /// more than one pixel along x or y, in [`MaskSpec::sigma_range`]: at least about 0.31 (at
    /// the default tolerance) and at most [`MaskSpec::MAX_SIGMA_PER_LENGTH`] times the larger of
    /// `width` and `height` (but at least 1.9).
    pub sigma_xy: f64,
    /// Gaussian σ over frames, in frames. The paper uses 1.9. Finite, and where it is used
    /// (`depth > 1`, not [`EnergyTopology::Independent2D`]), in [`MaskSpec::sigma_range`]: at
    /// least about 0.31 (at the default tolerance) and at most
    /// [`MaskSpec::MAX_SIGMA_PER_LENGTH`] times `depth` (but at least 1.9).
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
    /// Smallest σ accepted on either axis, even where it is not used (a one-pixel axis, `sigma_z`
    /// of [`EnergyTopology::Independent2D`]). Below about 7.5e-155, `1/σ²` overflows and the
    /// kernel loses its centre tap, without which void-and-cluster never settles. Where σ is
    /// used, [`MaskSpec::sigma_range`] asks for far more.
    pub const MIN_SIGMA: f64 = 1e-150;
    /// Largest σ accepted, in lengths of the axis it acts on (the larger of `width` and `height`
    /// for `sigma_xy`, `depth` for `sigma_z`), but never below the paper's
    /// [`MaskSpec::DEFAULT_SIGMA`], so that axes of 2 and 3 pixels keep it.
    ///
    /// The Gaussian `exp(−d²/(2σ²))` wrapped onto an axis of `n` pixels (summed over its images,
    /// as the kernel folds them) is its mean plus harmonics, the first of relative amplitude
    /// `2·exp(−2π²σ²/n²)`: 1.4% at `σ = n/2`, 2·10⁻⁴ at `0.75 n`, and at `1.1 n` 8.5·10⁻¹¹,
    /// below the resolution 2⁻³¹ of the fixed-point energies (whose full scale, every pixel on, is
    /// below 2³¹), where the energy tells no arrangement from another at all. Well before that
    /// the axis's term only breaks the ties of the other axis's: past half the axis, masks
    /// measured no better than white noise along it (`tests/sigma_range.rs` sweeps every σ), and
    /// the cost is a footprint of the whole axis per pixel (52 s at 128×128×32 with σ 10³⁰⁰,
    /// white noise, against 0.6 s at 1.9).
    pub const MAX_SIGMA_PER_LENGTH: f64 = 0.5;
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

    /// The σ `sigma_xy` (`z == false`) or `sigma_z` (`z == true`) must lie in, where it is used:
    /// `None` where it is not (an axis of one pixel, `sigma_z` of
    /// [`EnergyTopology::Independent2D`]) and where `kernel_tolerance` is not in `(0, 1)` (no σ
    /// qualifies; [`MaskSpec::validate`] refuses it).
    ///
    /// Inside the range the energy tells arrangements apart along the axis. Below `min` the
    /// truncated kernel keeps no neighbour at distance 1 (about `1/√(2 ln(1/kernel_tolerance))`,
    /// 0.3072 at the default 5·10⁻³; the check is the kernel's own arithmetic), so a pixel's
    /// energy is its own state alone; above `max` the kernel is flat along the axis
    /// ([`MaskSpec::MAX_SIGMA_PER_LENGTH`]). Either way void-and-cluster falls back to its
    /// tie-break: white noise along the axis.
    pub fn sigma_range(&self, z: bool) -> Option<SigmaRange> {
        if !(self.kernel_tolerance > 0.0 && self.kernel_tolerance < 1.0) {
            return None;
        }
        let length = if z {
            if self.topology == EnergyTopology::Independent2D {
                return None;
            }
            self.depth
        } else {
            self.width.max(self.height)
        };
        (length >= 2).then(|| SigmaRange {
            min: crate::kernel::smallest_sigma(self.kernel_tolerance),
            // Rounded down to four digits, so that the figure a message shows prints cleanly.
            max: crate::kernel::round_down_4(Self::MAX_SIGMA_PER_LENGTH * f64::from(length))
                .max(Self::DEFAULT_SIGMA),
        })
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
        let xy_length = self.width.max(self.height);
        for (field, value, z, length) in [
            ("sigma_xy", self.sigma_xy, false, xy_length),
            ("sigma_z", self.sigma_z, true, self.depth),
        ] {
            let Some(range) = self.sigma_range(z) else {
                continue;
            };
            let reason = if range.min > range.max && (value < range.min || value > range.max) {
                format!(
                    "`kernel_tolerance` {} keeps a pixel's neighbours only from σ {}, above the \
                     largest σ this axis of {length} allows, so no σ works: lower \
                     `kernel_tolerance`",
                    self.kernel_tolerance, range.min
                )
            } else if !crate::kernel::keeps_unit_offset(value, self.kernel_tolerance) {
                format!(
                    "below {} the kernel, truncated at `kernel_tolerance` {}, keeps no neighbour \
                     of a pixel, so every arrangement has the same energy",
                    range.min, self.kernel_tolerance
                )
            } else if value > range.max {
                format!(
                    "above {} (half the axis's {length} {}, at least 1.9) the Gaussian wrapped \
                     over the axis is within {:.1}% of flat, and farther out flat to the energy's \
                     resolution: the energy no longer orders the mask along it",
                    range.max,
                    if z { "frames" } else { "pixels" },
                    200.0 * (-std::f64::consts::PI.powi(2) / 2.0).exp()
                )
            } else {
                continue;
            };
            return Err(SpecError::SigmaOutOfRange {
                field,
                value,
                range,
                reason,
            });
        }
        Ok(())
    }
}

/// The σ a field accepts for one mask: `min..=max` (`min` 0 meaning any positive σ up to `max`,
/// `max` infinite where nothing bounds it from above). `Display`: `in [0.3072, 35.2]`, `at least
/// 0.4343`, `in (0, 4481]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmaRange {
    /// Smallest σ accepted, or 0 (exclusive).
    pub min: f64,
    /// Largest σ accepted, or infinity.
    pub max: f64,
}

impl SigmaRange {
    /// Whether `value` is inside, by the displayed bounds (the validations test the exact
    /// arithmetic they stand for).
    pub fn contains(&self, value: f64) -> bool {
        (if self.min > 0.0 {
            value >= self.min
        } else {
            value > 0.0
        }) && value <= self.max
    }
}

impl fmt::Display for SigmaRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.min > 0.0, self.max.is_finite()) {
            (true, true) => write!(f, "in [{}, {}]", self.min, self.max),
            (true, false) => write!(f, "at least {}", self.min),
            (false, true) => write!(f, "in (0, {}]", self.max),
            (false, false) => write!(f, "finite and > 0"),
        }
    }
}

/// `value` as stbn's messages write it: plain for everyday magnitudes (`-1`, `0.25`), in exponent
/// notation for tiny and huge ones (`1e-200`, not two hundred digits). The manifest's messages and
/// the generated statics' docs in `stbn-build-support` use it too.
pub fn compact_number(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-4..1e16).contains(&magnitude) {
        value.to_string()
    } else {
        format!("{value:e}")
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
    /// σ is outside the range where the energy tells arrangements apart for this mask
    /// ([`MaskSpec::sigma_range`], [`crate::VectorSpec::sigma_image_range`],
    /// [`crate::VectorSpec::sigma_value_range`]).
    SigmaOutOfRange {
        /// The field's name.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The range the field accepts for this mask.
        range: SigmaRange,
        /// Why the bound it crosses is there.
        reason: String,
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
            SpecError::SigmaOutOfRange {
                field,
                value,
                range,
                reason,
            } => write!(
                f,
                "`{field}` is {}; for this mask it must be {range}: {reason}",
                compact_number(*value)
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

    /// Every σ the validation accepts keeps `1/σ²` finite, so the kernel has its centre tap (on
    /// one-pixel axes, where no range applies, `MIN_SIGMA` itself is accepted).
    #[test]
    fn the_smallest_sigma_keeps_the_kernel_finite() {
        let spec = MaskSpec::new(1, 1, 1, 0).with_sigma(MaskSpec::MIN_SIGMA);
        assert_eq!(spec.validate(), Ok(()));
        assert!((1.0 / (MaskSpec::MIN_SIGMA * MaskSpec::MIN_SIGMA)).is_finite());
    }

    /// The figures the bound on huge σ quotes: the wrapped Gaussian's first harmonic is 1.4% of
    /// its mean at half the axis and below the fixed-point resolution 2⁻³¹ at 1.1 axes; every
    /// accepted σ stays below the latter, the paper's σ on the shortest axes included.
    #[test]
    fn the_largest_sigma_follows_the_wrapped_gaussian() {
        let harmonic = |k: f64| 2.0 * (-2.0 * std::f64::consts::PI.powi(2) * k * k).exp();
        assert!((harmonic(MaskSpec::MAX_SIGMA_PER_LENGTH) - 0.0143).abs() < 1e-4);
        assert!(harmonic(1.1) < 2f64.powi(-31), "{:e}", harmonic(1.1));
        for n in 2..=64u32 {
            let max = MaskSpec::new(n, n, n, 0).sigma_range(false).unwrap().max;
            assert!(max <= 1.1 * f64::from(n), "{n}: {max}");
        }
    }

    #[test]
    fn a_tolerance_that_leaves_no_sigma_says_so() {
        let mut spec = MaskSpec::new(8, 8, 4, 0);
        spec.kernel_tolerance = 0.999;
        let error = spec.validate().unwrap_err().to_string();
        assert!(
            error.contains("so no σ works: lower `kernel_tolerance`"),
            "{error}"
        );
    }

    #[test]
    fn sigma_ranges_follow_the_axes_and_the_tolerance() {
        let spec = MaskSpec::new(32, 16, 8, 0);
        let xy = spec.sigma_range(false).unwrap();
        assert_eq!((xy.min, xy.max), (0.3072, 16.0));
        assert_eq!(spec.sigma_range(true).unwrap().max, 4.0);
        assert_eq!(
            MaskSpec::new(2, 3, 2, 0).sigma_range(true).unwrap().max,
            1.9
        );
        // The shown minimum is accepted, a hair below it is not.
        for (sigma, ok) in [(0.3072, true), (0.3071, false), (4.0, true), (4.01, false)] {
            assert_eq!(
                spec.clone().with_sigma(sigma).validate().is_ok(),
                ok,
                "σ {sigma}"
            );
        }
        // A one-pixel axis and Independent2D's σ_z have no range; the defaults fit every size.
        assert_eq!(MaskSpec::new(1, 1, 1, 0).sigma_range(false), None);
        assert_eq!(MaskSpec::new(8, 8, 1, 0).sigma_range(true), None);
        let flat = MaskSpec::new(8, 8, 8, 0).with_topology(EnergyTopology::Independent2D);
        assert_eq!(flat.sigma_range(true), None);
        for size in 1..=4 {
            assert_eq!(MaskSpec::new(size, size, size, 0).validate(), Ok(()));
        }
        // A looser tolerance needs a wider σ before the neighbour survives.
        let loose = MaskSpec {
            kernel_tolerance: 0.1,
            ..spec
        };
        let min = loose.sigma_range(false).unwrap().min;
        assert!(
            (min - 1.0 / (2.0 * 10f64.ln()).sqrt()).abs() < 1e-3,
            "{min}"
        );
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
                    sigma_xy: 0.2,
                    ..base.clone()
                },
                "`sigma_xy` is 0.2; for this mask it must be in [0.3072, 4]: below 0.3072",
            ),
            (
                MaskSpec {
                    sigma_z: 1e300,
                    ..base.clone()
                },
                "`sigma_z` is 1e300; for this mask it must be in [0.3072, 4]: above 4",
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

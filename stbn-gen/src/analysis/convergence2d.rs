//! Convergence of per-pixel 2D integration over the frames ([`analysis`] docs, "2D
//! convergence").
//!
//! [`analysis`]: crate::analysis#2d-convergence

use super::convergence::{Convergence, ConvergenceOptions, estimator_rmse};
use super::{Field, FieldError};

/// Radius of [`Integrand2D::Disc`].
const DISC_RADIUS: f64 = 0.4;
/// Standard deviation of [`Integrand2D::Gaussian`].
const GAUSSIAN_SIGMA: f64 = 0.2;

/// A 2D integrand on `[0, 1)²` with a known integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Integrand2D {
    /// The indicator of the disc of radius 0.4 centred at `(½, ½)`;
    /// `∫ f = π · 0.4² ≈ 0.5027`. A curved edge, like a soft shadow's penumbra.
    Disc,
    /// `exp(−((x − ½)² + (y − ½)²) / (2σ²))` with σ = 0.2;
    /// `∫ f = (σ √(2π) · erf(1 / (2σ√2)))² ≈ 0.2451`. Smooth.
    Gaussian,
    /// `1` where `x + y < 1`, else `0`; `∫ f = ½`. A straight edge across both axes.
    DiagonalStep,
}

impl Integrand2D {
    /// Every integrand, in report order.
    pub const ALL: [Integrand2D; 3] = [
        Integrand2D::Disc,
        Integrand2D::Gaussian,
        Integrand2D::DiagonalStep,
    ];

    /// `f(x, y)`.
    pub fn eval(self, x: f64, y: f64) -> f64 {
        let (dx, dy) = (x - 0.5, y - 0.5);
        match self {
            Integrand2D::Disc => {
                if dx * dx + dy * dy < DISC_RADIUS * DISC_RADIUS {
                    1.0
                } else {
                    0.0
                }
            }
            Integrand2D::Gaussian => {
                (-(dx * dx + dy * dy) / (2.0 * GAUSSIAN_SIGMA * GAUSSIAN_SIGMA)).exp()
            }
            Integrand2D::DiagonalStep => {
                if x + y < 1.0 {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// The exact integral over `[0, 1)²`.
    pub fn integral(self) -> f64 {
        match self {
            Integrand2D::Disc => std::f64::consts::PI * DISC_RADIUS * DISC_RADIUS,
            Integrand2D::Gaussian => {
                let s = GAUSSIAN_SIGMA;
                let one_axis = s
                    * (2.0 * std::f64::consts::PI).sqrt()
                    * erf(1.0 / (2.0 * s * std::f64::consts::SQRT_2));
                one_axis * one_axis
            }
            Integrand2D::DiagonalStep => 0.5,
        }
    }

    /// A lower-case name: `disc`, `gaussian` or `diagonal_step`.
    pub fn name(self) -> &'static str {
        match self {
            Integrand2D::Disc => "disc",
            Integrand2D::Gaussian => "gaussian",
            Integrand2D::DiagonalStep => "diagonal_step",
        }
    }
}

/// `erf(z)` by its Maclaurin series, for `0 ≤ z ≤ 3` (error below 10⁻¹⁴ there; the series
/// alternates, and 80 terms reach far below `f64` resolution for these arguments).
fn erf(z: f64) -> f64 {
    debug_assert!((0.0..=3.0).contains(&z));
    let mut term = z; // (−1)ⁿ z^(2n+1) / n!
    let mut sum = z;
    for n in 1..80 {
        term *= -z * z / n as f64;
        sum += term / (2 * n + 1) as f64;
    }
    sum * 2.0 / std::f64::consts::PI.sqrt()
}

/// The values of `field` shifted toroidally by `(dx, dy)` pixels: entry `(x, y, z)` holds the
/// field's value at `((x + dx) mod W, (y + dy) mod H, z)`, as a sampler with that offset reads it.
pub fn toroidal_shift(field: &Field, dx: usize, dy: usize) -> Vec<f64> {
    let (w, h) = (field.width(), field.height());
    let mut out = Vec::with_capacity(field.values().len());
    for z in 0..field.depth() {
        let slice = field.slice(z);
        for y in 0..h {
            let row = &slice[((y + dy) % h) * w..][..w];
            out.extend((0..w).map(|x| row[(x + dx) % w]));
        }
    }
    out
}

/// The RMSE over pixels of the Monte Carlo and EMA estimates of `integrand`, with samples
/// `(xs(p, zₖ), ys(p, zₖ))`, after each sample ([module docs](crate::analysis#2d-convergence)).
///
/// Deterministic for any thread count (pixel chunks are summed in order). Errors if the two
/// fields differ in size; panics if `samples == 0` or `alpha ∉ (0, 1]`.
pub fn convergence_2d(
    xs: &Field,
    ys: &Field,
    integrand: Integrand2D,
    options: ConvergenceOptions,
) -> Result<Convergence, FieldError> {
    let size = |f: &Field| (f.width(), f.height(), f.depth());
    if size(xs) != size(ys) {
        return Err(FieldError::Mismatch {
            first: size(xs),
            second: size(ys),
        });
    }
    Ok(estimator_rmse(
        xs.slice_pixels(),
        xs.depth(),
        options,
        integrand.integral(),
        |z, pixels| {
            let (sx, sy) = (&xs.slice(z)[pixels.clone()], &ys.slice(z)[pixels]);
            sx.iter().zip(sy).map(move |(&x, &y)| integrand.eval(x, y))
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrals_match_a_midpoint_rule() {
        let n = 2048;
        for integrand in Integrand2D::ALL {
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let (x, y) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                    sum += integrand.eval(x, y);
                }
            }
            let estimate = sum / (n * n) as f64;
            // Edges cost O(1/n) in a midpoint rule; the Gaussian is smooth.
            let tolerance = if integrand == Integrand2D::Gaussian {
                1e-7
            } else {
                2e-3
            };
            assert!(
                (estimate - integrand.integral()).abs() < tolerance,
                "{}: {estimate} vs {}",
                integrand.name(),
                integrand.integral()
            );
        }
    }

    #[test]
    fn erf_matches_known_values() {
        // erf(0.5), erf(1), erf(2) to 15 digits (Abramowitz & Stegun, table 7.1).
        for (z, expected) in [
            (0.5, 0.520_499_877_813_047),
            (1.0, 0.842_700_792_949_715),
            (2.0, 0.995_322_265_018_953),
        ] {
            assert!((erf(z) - expected).abs() < 1e-14, "erf({z}) = {}", erf(z));
        }
    }

    #[test]
    fn one_exact_sample_has_zero_error_and_a_miss_has_the_integral() {
        // A pixel whose sample is the disc's centre: f = 1, error 1 − I. Outside: error I.
        let inside = Field::new(1, 1, 1, &[0.5]).unwrap();
        let corner = Field::new(1, 1, 1, &[0.0]).unwrap();
        let disc = Integrand2D::Disc;
        let i = disc.integral();
        let curve = convergence_2d(&inside, &inside, disc, ConvergenceOptions::new(1)).unwrap();
        assert!((curve.monte_carlo[0] - (1.0 - i)).abs() < 1e-15);
        let curve = convergence_2d(&corner, &corner, disc, ConvergenceOptions::new(1)).unwrap();
        assert!((curve.ema[0] - i).abs() < 1e-15);
    }

    #[test]
    fn stratified_pairs_integrate_the_diagonal_step_exactly() {
        // Four frames of one pixel: two below x + y = 1 ((¼, ¼), (0.2, 0.7)), two above.
        let xs = Field::new(1, 1, 4, &[0.25, 0.75, 0.2, 0.8]).unwrap();
        let ys = Field::new(1, 1, 4, &[0.25, 0.75, 0.7, 0.3]).unwrap();
        let curve = convergence_2d(
            &xs,
            &ys,
            Integrand2D::DiagonalStep,
            ConvergenceOptions::new(4),
        )
        .unwrap();
        // Running means 1, ½, ⅔, ½: errors ½, 0, ⅙, 0.
        let expected = [0.5, 0.0, 1.0 / 6.0, 0.0];
        for (got, want) in curve.monte_carlo.iter().zip(expected) {
            assert!((got - want).abs() < 1e-15, "{:?}", curve.monte_carlo);
        }
    }

    #[test]
    fn mismatched_fields_are_an_error() {
        let a = Field::new(2, 1, 1, &[0.1, 0.2]).unwrap();
        let b = Field::new(1, 2, 1, &[0.1, 0.2]).unwrap();
        assert!(convergence_2d(&a, &b, Integrand2D::Disc, ConvergenceOptions::new(1)).is_err());
    }

    #[test]
    fn shifts_wrap_on_both_axes() {
        let values: Vec<f64> = (0..12).map(|i| f64::from(i) / 16.0).collect();
        let field = Field::new(3, 2, 2, &values).unwrap();
        let shifted: Vec<f64> = toroidal_shift(&field, 2, 1)
            .iter()
            .map(|v| v * 16.0)
            .collect();
        // (x, y, z) reads ((x + 2) % 3, (y + 1) % 2, z).
        assert_eq!(
            shifted,
            [5.0, 3.0, 4.0, 2.0, 0.0, 1.0, 11.0, 9.0, 10.0, 8.0, 6.0, 7.0]
        );
    }
}

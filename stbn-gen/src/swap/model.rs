//! The second-order model of a pixel's cost that assignment passes choose their permutations
//! with ([module docs](super)).
//!
//! A pixel `p` holding value `v` would have the energy `c(p, v) = Σ_n w f(‖v − Vn‖²)` over its
//! taps, with `f(s) = exp(−x)`, `x = s^(D/6) / σs²`. Around `p`'s own value `u` the model is its
//! Taylor expansion to second order, `c(p, u) + gᵀδ + ½ δᵀHδ` with `δ = v − u`, built from the
//! same per-tap factors as `c(p, u)` itself: with `d = u − Vn`, `s = ‖d‖²` and the derivatives
//! `f'(s) = −(D/6) x f / s`, `f''(s) = (D/6) x f ((D/6) x − D/6 + 1) / s²`,
//!
//! ```text
//! g = 2 Σ w f'(s) d,      H = 2 Σ w f'(s) · I + 4 Σ w f''(s) d dᵀ
//! ```
//!
//! The model only ranks permutations; what a pass keeps is decided on exact energies.

use super::energy::{FACTOR_LANES, squared_distance, value_factors_and_arguments, weighted_sum};
use crate::fastmath::EXP_NEG_F32_CLAMP;

/// Squared distances below this count as this in the model's derivatives, which grow without
/// bound as a neighbour's value approaches the pixel's (the value term has a cusp there).
const MIN_SQUARED_DISTANCE: f32 = 1e-6;

/// The model of one pixel's cost around its own value ([module docs](self)).
#[derive(Clone, Copy, Debug)]
pub(super) struct CostModel<const D: usize> {
    /// The pixel's own value `u`.
    own: [f32; D],
    /// `c(p, u)`, exactly as the energy sums it.
    pub(super) energy: f64,
    /// `g`.
    gradient: [f32; D],
    /// `H` (symmetric).
    hessian: [[f32; D]; D],
}

/// Per-task buffers of [`CostModel::build`], each one padded row of a pixel's taps.
pub(super) struct ModelScratch {
    squared: Vec<f32>,
    argument: Vec<f32>,
    /// `u − Vn`, one row per component.
    difference: Vec<f32>,
    /// `w f'(s)`, then `w f''(s)`.
    first: Vec<f32>,
    second: Vec<f32>,
    /// `w f''(s) d_i`.
    weighted: Vec<f32>,
}

impl ModelScratch {
    /// Buffers for rows of `padded` entries (a multiple of [`FACTOR_LANES`]) of values with
    /// `dims` components.
    pub(super) fn new(padded: usize, dims: usize) -> ModelScratch {
        ModelScratch {
            squared: vec![0.0; padded],
            argument: vec![0.0; padded],
            difference: vec![0.0; padded * dims],
            first: vec![0.0; padded],
            second: vec![0.0; padded],
            weighted: vec![0.0; padded],
        }
    }
}

impl<const D: usize> CostModel<D> {
    /// The model of the pixel holding `own` whose taps hold `neighbours` (the kernel's tap
    /// order) with weights `weight` (padded with zeros to whole [`FACTOR_LANES`]; `weight32`
    /// the same in single precision). Leaves the value factors of `own` against each tap in
    /// `factor` (padded like `weight`): the ones [`weighted_sum`] adds to the energy.
    #[inline(always)]
    pub(super) fn build<const L: usize>(
        own: [f32; D],
        neighbours: &[[f32; D]],
        (weight, weight32): (&[f64], &[f32]),
        inv_sigma_value_sq: f32,
        factor: &mut [f32],
        scratch: &mut ModelScratch,
    ) -> CostModel<D> {
        let padded = weight.len();
        debug_assert!(padded.is_multiple_of(FACTOR_LANES) && neighbours.len() <= padded);
        let taps = neighbours.len();
        if padded == 0 {
            // A kernel with no taps: no energy, whatever the value.
            return CostModel {
                own,
                energy: 0.0,
                gradient: [0.0; D],
                hessian: [[0.0; D]; D],
            };
        }
        let s = &mut scratch.squared;
        for (c, row) in scratch.difference.chunks_exact_mut(padded).enumerate() {
            for (d, n) in row[..taps].iter_mut().zip(neighbours) {
                *d = own[c] - n[c];
            }
            row[taps..].fill(0.0);
        }
        for (t, n) in neighbours.iter().enumerate() {
            s[t] = squared_distance(&own, n);
        }
        s[taps..].fill(0.0);
        let factor = &mut factor[..padded];
        value_factors_and_arguments::<D, L>(s, (factor, &mut scratch.argument), inv_sigma_value_sq);
        let energy = weighted_sum(weight, factor);
        // w f'(s) and w f''(s), from x and f: the padding (x = 0, weight 0) gives 0. Where the
        // factor is clamped (x ≥ 87, or x NaN from 0 · ∞ when 1/σs² overflows single precision)
        // it does not change with the value: no derivatives, so the model stays finite.
        let p = D as f32 / 6.0;
        let (x, f, w) = (
            &scratch.argument[..padded],
            &factor[..padded],
            &weight32[..padded],
        );
        let (first, second) = (&mut scratch.first[..padded], &mut scratch.second[..padded]);
        for t in 0..padded {
            let u = 1.0 / s[t].max(MIN_SQUARED_DISTANCE);
            let wpxf = w[t] * p * x[t] * f[t];
            (first[t], second[t]) = if x[t] < EXP_NEG_F32_CLAMP {
                (-wpxf * u, wpxf * (p * x[t] - p + 1.0) * u * u)
            } else {
                (0.0, 0.0)
            };
        }
        let difference = &scratch.difference;
        let row = |c: usize| &difference[c * padded..(c + 1) * padded];
        // The coefficient of the identity in H.
        let isotropic = 2.0 * lane_sum(&scratch.first);
        let mut model = CostModel {
            own,
            energy,
            gradient: [0.0; D],
            hessian: [[0.0; D]; D],
        };
        for c in 0..D {
            model.gradient[c] = 2.0 * lane_dot(&scratch.first, row(c));
            for (wd, (&b, &d)) in scratch
                .weighted
                .iter_mut()
                .zip(scratch.second.iter().zip(row(c)))
            {
                *wd = b * d;
            }
            for e in c..D {
                let h = 4.0 * lane_dot(&scratch.weighted, row(e));
                model.hessian[c][e] = h;
                model.hessian[e][c] = h;
            }
            model.hessian[c][c] += isotropic;
        }
        model
    }

    /// The model's cost of the pixel holding `value`.
    #[inline(always)]
    pub(super) fn predict(&self, value: &[f32; D]) -> f64 {
        let delta: [f64; D] = std::array::from_fn(|c| f64::from(value[c]) - f64::from(self.own[c]));
        let mut cost = self.energy;
        for ((&d, &g), row) in delta.iter().zip(&self.gradient).zip(&self.hessian) {
            let curvature: f64 = row
                .iter()
                .zip(&delta)
                .map(|(&h, &e)| f64::from(h) * e)
                .sum();
            cost += d * (f64::from(g) + 0.5 * curvature);
        }
        cost
    }
}

/// `Σ a[i]` over whole chunks of [`FACTOR_LANES`], in that many partial sums.
#[inline(always)]
fn lane_sum(a: &[f32]) -> f32 {
    let mut lanes = [0.0f32; FACTOR_LANES];
    for chunk in a.as_chunks::<FACTOR_LANES>().0 {
        for (lane, &x) in lanes.iter_mut().zip(chunk) {
            *lane += x;
        }
    }
    lanes.iter().sum()
}

/// `Σ a[i] b[i]` over whole chunks of [`FACTOR_LANES`], in that many partial sums.
#[inline(always)]
fn lane_dot(a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [0.0f32; FACTOR_LANES];
    let (a, _) = a.as_chunks::<FACTOR_LANES>();
    let (b, _) = b.as_chunks::<FACTOR_LANES>();
    for (x, y) in a.iter().zip(b) {
        for ((lane, &x), &y) in lanes.iter_mut().zip(x).zip(y) {
            *lane += x * y;
        }
    }
    lanes.iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::keyed_rng;
    use crate::swap::energy::value_factor;
    use rand::RngExt;

    /// `c(p, v) = Σ w exp(−‖v − n‖^(D/3))` in double precision: the smooth energy the single
    /// precision factor approximates.
    fn smooth<const D: usize>(v: [f32; D], neighbours: &[[f32; D]], weight: &[f64]) -> f64 {
        neighbours
            .iter()
            .zip(weight)
            .map(|(n, &w)| {
                let s: f64 = (0..D)
                    .map(|c| (f64::from(v[c]) - f64::from(n[c])).powi(2))
                    .sum();
                w * (-s.powf(D as f64 / 6.0)).exp()
            })
            .sum()
    }

    /// The model's energy is [`weighted_sum`] of the value factors (bit for bit), and its
    /// predicted change of the energy is second-order accurate: for random neighbourhoods of 1
    /// to 4 components, the error against the smooth energy's change shrinks more than 6× when
    /// the step halves from 0.02 to 0.01 (8× for an error in `|δ|³`, 4× for a first-order
    /// model; the single-precision factor's own error aside), and at 0.01 it is within 3% of
    /// the change.
    #[test]
    fn predictions_are_second_order() {
        fn check<const D: usize>(rng: &mut rand_chacha::ChaCha8Rng) {
            let taps: usize = 40;
            let padded = taps.div_ceil(FACTOR_LANES) * FACTOR_LANES;
            let mut weight: Vec<f64> = (0..taps).map(|_| rng.random_range(0.05..1.0)).collect();
            weight.resize(padded, 0.0);
            let weight32: Vec<f32> = weight.iter().map(|&w| w as f32).collect();
            let own: [f32; D] = std::array::from_fn(|_| rng.random_range(0.3..0.7));
            // Neighbours 0.15 to 0.45 away in every component, as in a blue-noise neighbourhood.
            let neighbours: Vec<[f32; D]> = (0..taps)
                .map(|_| {
                    std::array::from_fn(|c| {
                        let away = rng.random_range(0.15..0.45f32);
                        if rng.random_range(0..2) == 0 {
                            own[c] + away
                        } else {
                            own[c] - away
                        }
                    })
                })
                .collect();
            let mut factor = vec![0.0f32; padded];
            let mut scratch = ModelScratch::new(padded, D);
            let model = CostModel::build::<1>(
                own,
                &neighbours,
                (&weight, &weight32),
                1.0,
                &mut factor,
                &mut scratch,
            );
            let mut exact = vec![0.0f32; padded];
            for (f, n) in exact.iter_mut().zip(&neighbours) {
                *f = value_factor::<D>(squared_distance(&own, n), 1.0);
            }
            assert_eq!(model.energy, weighted_sum(&weight, &exact));
            let base = smooth(own, &neighbours, &weight);
            for _ in 0..20 {
                let direction: [f32; D] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
                let norm = direction.iter().map(|x| x * x).sum::<f32>().sqrt();
                let error = |step: f32| {
                    let v: [f32; D] = std::array::from_fn(|c| own[c] + step * direction[c] / norm);
                    let change = smooth(v, &neighbours, &weight) - base;
                    (
                        (model.predict(&v) - model.energy - change).abs(),
                        change.abs(),
                    )
                };
                let (e2, _) = error(0.02);
                let (e1, change) = error(0.01);
                assert!(e1 <= e2 / 6.0 + 2e-6, "D {D}: {e2} then {e1}");
                assert!(
                    e1 <= 0.03 * change + 2e-6,
                    "D {D}: {e1} against a change of {change}"
                );
            }
        }
        let mut rng = keyed_rng(5, 0, 0, 0);
        for _ in 0..10 {
            check::<1>(&mut rng);
            check::<2>(&mut rng);
            check::<3>(&mut rng);
            check::<4>(&mut rng);
        }
    }
}

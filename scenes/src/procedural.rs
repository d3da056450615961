//! Seeded procedural noise for the scenes' content: value noise and its fractal sum.

/// Fractal value noise at `p`: `octaves` octaves of [`value_noise`] at frequencies
/// `base_frequency · 2ᵏ` per unit with weights `2⁻ᵏ`, normalised to `[0, 1]`. Octave `k` uses
/// seed `seed + k`.
pub fn fbm(p: [f64; 3], seed: u64, base_frequency: f64, octaves: u32) -> f64 {
    let mut sum = 0.0;
    let mut weight = 1.0;
    let mut total = 0.0;
    for octave in 0..octaves {
        let frequency = base_frequency * f64::from(1u32 << octave);
        sum += weight
            * value_noise(
                p.map(|c| c * frequency),
                seed.wrapping_add(u64::from(octave)),
            );
        total += weight;
        weight *= 0.5;
    }
    sum / total
}

/// Value noise in `[0, 1)`: [`lattice`] values at the integer points around `p`, blended with
/// the smoothstep `3t² − 2t³` on each axis (continuous, with a continuous gradient).
pub fn value_noise(p: [f64; 3], seed: u64) -> f64 {
    let cell = p.map(|c| c.floor());
    let t = [p[0] - cell[0], p[1] - cell[1], p[2] - cell[2]].map(|t| t * t * (3.0 - 2.0 * t));
    let c = cell.map(|c| c as i64);
    let mut result = 0.0;
    for corner in 0..8 {
        let d = [corner & 1, (corner >> 1) & 1, corner >> 2];
        let w: f64 = (0..3)
            .map(|a| if d[a] == 1 { t[a] } else { 1.0 - t[a] })
            .product();
        result += w * lattice(
            [c[0] + d[0] as i64, c[1] + d[1] as i64, c[2] + d[2] as i64],
            seed,
        );
    }
    result
}

/// A value in `[0, 1)` for an integer lattice point: SplitMix64's finaliser over the point and
/// the seed.
pub fn lattice(p: [i64; 3], seed: u64) -> f64 {
    let mut h = seed ^ 0x9E37_79B9_7F4A_7C15;
    for c in p {
        h = (h ^ c as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 31;
        h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
        h ^= h >> 29;
    }
    (h >> 11) as f64 * 2f64.powi(-53)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_noise_is_in_range_and_continuous() {
        for i in 0..100 {
            let p = [i as f64 * 0.173, i as f64 * 0.311, 1.0 - i as f64 * 0.07];
            let v = value_noise(p, 1);
            assert!((0.0..1.0).contains(&v));
            let q = p.map(|c| c + 1e-9);
            assert!((value_noise(q, 1) - v).abs() < 1e-7);
        }
    }

    #[test]
    fn value_noise_hits_lattice_values_at_integers() {
        assert_eq!(value_noise([2.0, -3.0, 5.0], 9), lattice([2, -3, 5], 9));
        assert_ne!(lattice([2, -3, 5], 9), lattice([2, -3, 5], 10));
    }

    #[test]
    fn fbm_is_normalised() {
        for i in 0..50 {
            let v = fbm([i as f64 * 0.01, 0.3, 0.7], 4, 5.0, 3);
            assert!((0.0..1.0).contains(&v));
        }
        // One octave is plain value noise at the base frequency.
        assert_eq!(
            fbm([0.1, 0.2, 0.3], 4, 2.0, 1),
            value_noise([0.2, 0.4, 0.6], 4)
        );
    }
}

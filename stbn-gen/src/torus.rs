//! Offsets on the torus: every mask wraps around in x, y and t, so an offset between two pixels
//! is a class modulo the axis's size.

/// The representative of `offset mod size` in `(−size/2, size/2]`: the offset every kernel
/// stores, so each toroidal offset has one tap.
pub(crate) fn canonical(offset: i64, size: u32) -> i32 {
    let size = i64::from(size);
    let wrapped = offset.rem_euclid(size);
    (if wrapped > size / 2 {
        wrapped - size
    } else {
        wrapped
    }) as i32
}

/// `t` wrapped into `0..size`, for `t` in `−size..2 · size`: a coordinate plus an offset of at
/// most one period.
#[inline(always)]
pub(crate) fn wrap(t: i32, size: u32) -> i32 {
    let size = size as i32;
    if t < 0 {
        t + size
    } else if t >= size {
        t - size
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_offsets_are_the_nearest_representatives() {
        for size in 1..12u32 {
            for offset in -30i64..30 {
                let c = canonical(offset, size);
                assert_eq!((i64::from(c) - offset).rem_euclid(i64::from(size)), 0);
                assert!(2 * i64::from(c) <= i64::from(size) && 2 * i64::from(c) > -i64::from(size));
            }
            for t in -(size as i32)..2 * size as i32 {
                assert_eq!(wrap(t, size), t.rem_euclid(size as i32));
            }
        }
    }
}

//! Weighted sums of short rows of floats held in vector registers for the whole sum: the
//! fits' sums Σ e_k[t] · mean_k of each of a fit's terms ([`super::Filter::fit_sums`]) and a
//! fit read at a member's place, Σ_t p[t] · sums[t] ([`super::blend::read_fit`]). A row is a
//! receiver's coefficients, 9 floats at order 3 in one channel, 27 in three: added one term
//! at a time through memory ([`super::clusters::add_scaled`]), each float was loaded and
//! stored again for every entry and term, which cost more than the products. Every float
//! here gets the same products summed in the same order as there, so the results are the
//! same bits; rows of other widths, and fits of other terms, are still summed through memory.

use glam::Vec4;

use super::clusters::add_scaled;

/// Row `x` of `W` floats in `L` = ⌈W / 4⌉ lanes of four, 0 past its end.
#[inline(always)]
fn load<const W: usize, const L: usize>(x: &[f32]) -> [Vec4; L] {
    let x: &[f32; W] = x[..W].try_into().expect("W floats");
    std::array::from_fn(|l| {
        Vec4::from_array(std::array::from_fn(|i| match 4 * l + i < W {
            true => x[4 * l + i],
            false => 0.0,
        }))
    })
}

/// The `W` floats of `lanes` into `out`.
#[inline(always)]
fn store<const W: usize, const L: usize>(lanes: &[Vec4; L], out: &mut [f32]) {
    let out: &mut [f32; W] = (&mut out[..W]).try_into().expect("W floats");
    for (i, out) in out.iter_mut().enumerate() {
        *out = lanes[i / 4][i % 4];
    }
}

/// Whether [`weighted_sums`] and [`read_sums`] hold `terms` terms of rows of `width` floats
/// in registers (order 3's coefficients in one channel or three); elsewhere they sum them
/// through memory.
fn in_registers(terms: usize, width: usize) -> bool {
    matches!(width, 9 | 27) && matches!(terms, 3 | 4 | 5 | 7 | 8)
}

/// Calls `$f::<T, W, L, _>` for `$terms` terms of `$width` floats ([`in_registers`] holds).
macro_rules! dispatch {
    ($f:ident, $terms:expr, $width:expr, $($arg:expr),*) => {
        match ($terms, $width) {
            (3, 9) => $f::<3, 9, 3, _>($($arg),*),
            (4, 9) => $f::<4, 9, 3, _>($($arg),*),
            (5, 9) => $f::<5, 9, 3, _>($($arg),*),
            (7, 9) => $f::<7, 9, 3, _>($($arg),*),
            (8, 9) => $f::<8, 9, 3, _>($($arg),*),
            (3, 27) => $f::<3, 27, 7, _>($($arg),*),
            (4, 27) => $f::<4, 27, 7, _>($($arg),*),
            (5, 27) => $f::<5, 27, 7, _>($($arg),*),
            (7, 27) => $f::<7, 27, 7, _>($($arg),*),
            (8, 27) => $f::<8, 27, 7, _>($($arg),*),
            _ => unreachable!("in_registers() is checked first"),
        }
    };
}

/// For each of `terms` terms t, Σ_n e_n[t] · x_n over `entries` (e_n, x_n) in order, into
/// `sums`: `terms` rows of `width` floats, which it overwrites (the sums start at 0).
pub(super) fn weighted_sums<'x, const E: usize>(
    entries: impl Iterator<Item = ([f32; E], &'x [f32])>,
    (terms, width): (usize, usize),
    sums: &mut [f32],
) {
    if in_registers(terms, width) {
        return dispatch!(weighted_sums_in, terms, width, entries, sums);
    }
    let sums = &mut sums[..terms * width];
    sums.fill(0.0);
    for (e, x) in entries {
        for (t, sums) in sums.chunks_exact_mut(width.max(1)).enumerate() {
            add_scaled(sums, e[t], x);
        }
    }
}

#[inline(always)]
fn weighted_sums_in<'x, const T: usize, const W: usize, const L: usize, const E: usize>(
    entries: impl Iterator<Item = ([f32; E], &'x [f32])>,
    sums: &mut [f32],
) {
    let mut acc = [[Vec4::ZERO; L]; T];
    for (e, x) in entries {
        let x = load::<W, L>(x);
        for (acc, &e) in acc.iter_mut().zip(&e[..T]) {
            for (acc, x) in acc.iter_mut().zip(&x) {
                *acc += e * *x;
            }
        }
    }
    for (acc, out) in acc.iter().zip(sums.chunks_exact_mut(W)) {
        store::<W, L>(acc, out);
    }
}

/// Σ_t p[t] · sums[t] over the first `terms` rows of `width` floats in `sums`, into `out`
/// (`width` floats).
pub(super) fn read_sums<const E: usize>(
    sums: &[f32],
    (terms, width): (usize, usize),
    p: &[f32; E],
    out: &mut [f32],
) {
    if in_registers(terms, width) {
        return dispatch!(read_sums_in, terms, width, sums, p, out);
    }
    let out = &mut out[..width];
    out.fill(0.0);
    for (t, sums) in sums.chunks_exact(width.max(1)).take(terms).enumerate() {
        add_scaled(out, p[t], sums);
    }
}

#[inline(always)]
fn read_sums_in<const T: usize, const W: usize, const L: usize, const E: usize>(
    sums: &[f32],
    p: &[f32; E],
    out: &mut [f32],
) {
    let sums: &[f32] = &sums[..T * W];
    let mut acc = [Vec4::ZERO; L];
    for (t, &p) in p[..T].iter().enumerate() {
        let sums = load::<W, L>(&sums[t * W..]);
        for (acc, s) in acc.iter_mut().zip(&sums) {
            *acc += p * *s;
        }
    }
    store::<W, L>(&acc, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The most terms a fit has, as the filter's.
    const TERMS: usize = 8;

    fn bits(floats: &[f32]) -> Vec<u32> {
        floats.iter().map(|f| f.to_bits()).collect()
    }

    /// A float of no pattern, from its index.
    fn float(i: usize) -> f32 {
        ((i as f32 * 0.618_034).fract() - 0.5) * (1.0 + i as f32 % 7.0)
    }

    /// Both sums give, bit for bit, what adding one term at a time through memory gives,
    /// for every width and number of terms they take.
    #[test]
    fn sums_in_registers_are_those_through_memory() {
        for width in [9, 27] {
            for terms in [3, 4, 5, 7, 8] {
                assert!(in_registers(terms, width));
                let rows: Vec<f32> = (0..13 * width).map(float).collect();
                let entries = (0..13).map(|n| {
                    let e: [f32; TERMS] = std::array::from_fn(|t| float(1000 + n * TERMS + t));
                    (e, &rows[n * width..][..width])
                });
                let mut want = vec![0.0; terms * width];
                for (e, x) in entries.clone() {
                    for (t, sums) in want.chunks_exact_mut(width).enumerate() {
                        add_scaled(sums, e[t], x);
                    }
                }
                let mut got = vec![f32::NAN; terms * width];
                weighted_sums(entries, (terms, width), &mut got);
                assert_eq!(bits(&got), bits(&want), "{terms} terms of {width}");

                let p: [f32; TERMS] = std::array::from_fn(|t| float(2000 + t));
                let mut want_read = vec![0.0; width];
                for (t, sums) in want.chunks_exact(width).enumerate() {
                    add_scaled(&mut want_read, p[t], sums);
                }
                let mut read = vec![f32::NAN; width];
                read_sums(&want, (terms, width), &p, &mut read);
                assert_eq!(bits(&read), bits(&want_read), "{terms} terms of {width}");
            }
        }
    }
}

//! Exponentials four at a time, for the kernels' weights ([`weigh`]): a vertex kernel weighs
//! each of its 200-odd entries by three exponentials (its Gaussian terms with its range
//! term, its tapers, its robust range term), and the runtime's `expf`, one call per float,
//! took a tenth of a vertex bake's time; on a terrain's texels fitted in the normal, 9 % of
//! the filter's. Cephes' `expf` (Moshier 1989, *Methods and programs for mathematical
//! functions*), in vector registers.

use glam::Vec4;

/// 2ⁿ for whole n in [−126, 127], in the floats' exponent bits (the compiler turns the
/// four lanes' integer steps into vector instructions).
#[inline(always)]
fn pow2(n: Vec4) -> Vec4 {
    Vec4::from_array(
        n.to_array()
            .map(|n| f32::from_bits(((n as i32 + 127) as u32) << 23)),
    )
}

/// eˣ of four floats at once, in vector registers: 2^n for n the nearest integer to
/// x / ln 2 times a degree-6 polynomial of the rest (Cephes' `expf`, within 2 ulp of the
/// runtime's), 0 below −87 (the least normal float's exponent) and for NaN.
#[inline(always)]
pub(super) fn exp4(x: Vec4) -> Vec4 {
    // Rounds to nearest by the floats' own rounding: no call to `round` without SSE4.1.
    let shifter = Vec4::splat(12_582_912.0);
    let n = (x * std::f32::consts::LOG2_E + shifter) - shifter;
    let r = x - n * 0.693_359_4 + n * 2.121_944_4e-4;
    let mut p = Vec4::splat(1.987_569_2e-4);
    for c in [
        1.398_199_9e-3,
        8.333_452e-3,
        4.166_579_6e-2,
        1.666_666_5e-1,
        0.5,
    ] {
        p = p * r + Vec4::splat(c);
    }
    let y = p * (r * r) + r + Vec4::ONE;
    let scale = pow2(n.clamp(Vec4::splat(-126.0), Vec4::splat(127.0)));
    Vec4::select(x.cmpge(Vec4::splat(-87.0)), y * scale, Vec4::ZERO)
}

/// Each weight s · exp(x), four at a time, for x the exponent `exponent` reads from it and
/// (_, s) its `scales`: the kernels' weights, texels' and vertices' alike, and the robust
/// range term's ([`super::normal_fit::reweigh`]).
#[inline(always)]
pub(super) fn scaled<T>(
    weights: &mut [T],
    scales: &[(f32, f32)],
    exponent: impl Fn(&T) -> f32,
    set: impl Fn(&mut T, f32),
) {
    debug_assert_eq!(weights.len(), scales.len());
    let (mut chunks, mut fours) = (weights.chunks_exact_mut(4), scales.chunks_exact(4));
    for (four, s) in (&mut chunks).zip(&mut fours) {
        let x = Vec4::from_array(std::array::from_fn(|l| exponent(&four[l])));
        let s = Vec4::from_array(std::array::from_fn(|l| s[l].1));
        for (w, x) in four.iter_mut().zip((exp4(x) * s).to_array()) {
            set(w, x);
        }
    }
    for (w, &(_, s)) in chunks.into_remainder().iter_mut().zip(fours.remainder()) {
        let x = (exp4(Vec4::splat(exponent(w))) * s).x;
        set(w, x);
    }
}

/// Each kernel entry (k, [x, u, v])'s weight s · exp(x), (_, s) its `scales`.
pub(super) fn weigh(kernel: &mut [(u32, [f32; 3])], scales: &[(f32, f32)]) {
    scaled(
        kernel,
        scales,
        |entry| entry.1[0],
        |entry, w| entry.1[0] = w,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exponentials four at a time are the runtime's but for rounding, from 1 down to
    /// where they give 0 (the kernels' exponents are never positive).
    #[test]
    fn exp4_is_the_runtimes_exp_within_a_few_ulp() {
        let mut x = 0.0f32;
        while x > -90.0 {
            let xs = Vec4::new(x, x - 0.3, x - 0.61, x - 0.97);
            for (x, fast) in xs.to_array().into_iter().zip(exp4(xs).to_array()) {
                let exact = f64::from(x).exp();
                match x >= -87.0 {
                    true => assert!(
                        (f64::from(fast) - exact).abs() <= 3e-7 * exact,
                        "{x}: {fast} against {exact}"
                    ),
                    false => assert_eq!(fast, 0.0),
                }
            }
            x -= 0.001_37;
        }
        let special = exp4(Vec4::new(0.0, f32::NEG_INFINITY, f32::NAN, -1e30)).to_array();
        assert_eq!(special, [1.0, 0.0, 0.0, 0.0]);
    }
}

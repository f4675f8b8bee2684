//! The range term ([`super::Filter`]): how far apart two receivers' signals are against how
//! far apart noise alone would put them.
//! And the guides' layout in vector lanes, which the vertices' range terms and every fit's
//! guide sums read.

use glam::Vec4;

/// The range term's exponent, max(0, d² − 1)/κ² for d² the squared difference of `a` and
/// `b` over `variance`, the difference noise alone would give (so d² ≈ 1 for noise). Summed
/// in order: the clusters' yes-or-no test reads it.
pub(super) fn range_exponent(a: &[f32], b: &[f32], variance: f32, kappa: f32) -> f32 {
    let squared: f32 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
    range_term(squared, variance, kappa)
}

/// Σ (a − b)² in [`LANES`] running sums, added pairwise at the end: one sum in order is a
/// chain of dependent additions (27 of them at order 3, the wide pass's longest), lanes are
/// independent and vectorise. A fixed order still, so the same on any thread; it differs
/// from the sum in order by rounding alone, and feeds the kernels' weights, not a test.
#[inline(always)]
pub(super) fn squared_difference(a: &[f32], b: &[f32]) -> f32 {
    // Lanes 0 to 3 and 4 to 7 in two vector registers, written out: the loop over an
    // array of lanes compiled to scalar arithmetic. The same sums in the same order.
    let (mut low, mut high) = (Vec4::ZERO, Vec4::ZERO);
    let (a_chunks, b_chunks) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (a_rest, b_rest) = (a_chunks.remainder(), b_chunks.remainder());
    for (x, y) in a_chunks.zip(b_chunks) {
        let d = Vec4::from_slice(&x[..4]) - Vec4::from_slice(&y[..4]);
        low += d * d;
        let d = Vec4::from_slice(&x[4..]) - Vec4::from_slice(&y[4..]);
        high += d * d;
    }
    let mut lanes = [0.0f32; LANES];
    low.write_to_slice(&mut lanes[..4]);
    high.write_to_slice(&mut lanes[4..]);
    for (k, (x, y)) in a_rest.iter().zip(b_rest).enumerate() {
        lanes[k] += (x - y) * (x - y);
    }
    // Pairwise: lanes k and k + 4, then k and k + 2, then the two left.
    let four = Vec4::from_slice(&lanes[..4]) + Vec4::from_slice(&lanes[4..]);
    (four.x + four.z) + (four.y + four.w)
}

/// Running sums of [`squared_difference`]: two SSE registers' worth.
const LANES: usize = 8;

/// [`range_exponent`] of a squared difference.
pub(super) fn range_term(squared: f32, variance: f32, kappa: f32) -> f32 {
    let d2 = match variance > 0.0 {
        true => squared / variance,
        false if squared == 0.0 => 0.0,
        false => f32::INFINITY,
    };
    (d2 - 1.0).max(0.0) / (kappa * kappa)
}

/// Vector registers' lanes (four floats) that hold a guide of `sw` floats.
pub(super) fn guide_lanes(sw: usize) -> usize {
    sw.div_ceil(4)
}

/// Guides of `sw` floats each, as [`guide_lanes`] of lanes each, the last zero-padded.
pub(super) fn to_lanes(guides: &[f32], sw: usize) -> Vec<Vec4> {
    let mut lanes = Vec::with_capacity(guides.len().div_ceil(sw.max(1)) * guide_lanes(sw));
    for guide in guides.chunks_exact(sw.max(1)) {
        for four in guide.chunks(4) {
            let mut padded = [0.0f32; 4];
            padded[..four.len()].copy_from_slice(four);
            lanes.push(Vec4::from_array(padded));
        }
    }
    lanes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lanes_sum_is_the_sum_in_order_but_for_rounding() {
        let mut rng = crate::math::sampling::Pcg32::new(5, 6);
        // Every remainder of the lanes, the texels' 27 floats among them.
        for n in 0..40 {
            let a: Vec<f32> = (0..n).map(|_| rng.next_f32() - 0.5).collect();
            let b: Vec<f32> = (0..n).map(|_| rng.next_f32() - 0.5).collect();
            let exact: f64 = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
                .sum();
            let lanes = f64::from(squared_difference(&a, &b));
            assert!(
                (lanes - exact).abs() <= 1e-6 * exact.max(1e-30),
                "{n}: {lanes} {exact}"
            );
        }
    }
}

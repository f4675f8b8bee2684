//! Over a normal map, the shading normal's own effect is taken out of the transfer before the
//! filter and put back after: each texel's transfer less its unoccluded transfer, the clamped
//! cosine lobe about its shading normal, is what the filter smooths, and each texel adds its
//! own back (as SVGF filters illumination demodulated by albedo, Schied et al. 2017).
//!
//! Unoccluded, band l of the transfer about normal n is Â_l/π · y_lm(n), Â_l the clamped
//! cosine's zonal coefficients (Ramamoorthi & Hanrahan 2001, *An efficient representation
//! for irradiance environment maps*): 1, 2/3 and 1/4 for bands 0 to 2. A normal map's bumps
//! change the transfer from texel to texel mostly by that lobe, and what is left, the light
//! the scene blocks or bounces, changes with the normal far less. The fit in the normal
//! ([`super::normal_fit`]) follows the lobe only to second order, and its robust range term
//! cut the neighbours across a bump's edge, where it does not. On the production courtyard's
//! normal-mapped wall, at 256 rays, the wall's part of the error under the sun and sky fell
//! from 0.210 to 0.155 points (raw 2,048 rays: 0.128), and the whole courtyard's from 0.485
//! to 0.464 %, within raw 2,048 rays' 0.475 %.
//!
//! The filter's weights are unchanged in kind: shared by every coefficient, formed once. A
//! texel's answer is U_i + Σ_j w_ij (T_j − U_j): the weights' answer plus a term that
//! depends on the normals alone, the same under every light.

use glam::Vec3;

use super::guides::Guides;
use super::normal_fit::Normals;
use crate::math::glossy::lobe_bands;
use crate::math::sh::{Basis, MAX_ORDER, coeff_count};

/// Each coefficient's factor Â_l/π for an order-`order` bake: the clamped cosine over π is
/// the glossy lobe of exponent 1 ([`lobe_bands`]), band l's factor repeated 2l + 1 times.
pub(super) fn lobe_factors(order: usize) -> Vec<f32> {
    let bands = lobe_bands(1.0, order);
    (0..order)
        .flat_map(|l| std::iter::repeat_n(bands[l], 2 * l + 1))
        .collect()
}

/// The unoccluded transfer about `normal`, `factors` the bake's [`lobe_factors`].
pub(super) fn unoccluded(basis: &Basis, factors: &[f32], normal: Vec3, out: &mut [f32]) {
    basis.eval(normal, out);
    for (y, f) in out.iter_mut().zip(factors) {
        *y *= f;
    }
}

/// Which receivers are filtered demodulated, and how their lobes are formed.
pub(super) struct Demodulation {
    basis: Basis,
    /// Each coefficient's factor ([`lobe_factors`]).
    factors: Vec<f32>,
    /// Per receiver, whether its lobe is taken out.
    demodulated: Vec<bool>,
}

impl Demodulation {
    /// The receivers whose group is fitted over a normal map ([`Normals::Mapped`]) and whose
    /// rays saw some light (their noise is not 0), for transfer of `per_channel` floats per
    /// channel; `None` where there is none, or where `per_channel` is no vector bake's (n²).
    ///
    /// A texel whose rays were all blocked is left as it is: it has neither transfer nor
    /// noise, and its lobe taken out would leave a pattern of bumps the filter reads as
    /// exact, which splits every cluster on a wall's shaded side (on the courtyard's wall,
    /// 11,000 clusters became 30,000, reading 7 × the neighbours). The lobes are formed
    /// when needed, not stored: at order 12 a large lightmap's would take gigabytes.
    pub(super) fn new(guides: &Guides, normals: &[Normals], per_channel: usize) -> Option<Self> {
        let order = (per_channel as f64).sqrt() as usize;
        if !(1..=MAX_ORDER).contains(&order) || coeff_count(order) != per_channel {
            return None;
        }
        let mapped = |g: u32| normals.get(g as usize) == Some(&Normals::Mapped);
        let demodulated: Vec<bool> = (0..guides.points.len())
            .map(|i| mapped(guides.groups[i]) && guides.noise.get(i) != Some(&0.0))
            .collect();
        demodulated.contains(&true).then(|| Demodulation {
            basis: Basis::new(order),
            factors: lobe_factors(order),
            demodulated,
        })
    }

    /// The floats per channel of the transfer it demodulates.
    fn per_channel(&self) -> usize {
        self.factors.len()
    }

    /// Receiver i's lobe into `out` (n² floats), or false where it keeps its transfer.
    fn lobe_of(&self, guides: &Guides, i: usize, out: &mut [f32]) -> bool {
        if !self.demodulated[i] {
            return false;
        }
        unoccluded(&self.basis, &self.factors, guides.normals[i], out);
        true
    }

    /// Adds `sign` × each demodulated receiver's lobe to each of its channels' blocks of
    /// `values`.
    pub(super) fn shift(&self, guides: &Guides, values: &mut [f32], sign: f32) {
        let width = values.len() / self.demodulated.len().max(1);
        let mut lobe = vec![0.0f32; self.per_channel()];
        for (i, v) in values.chunks_exact_mut(width.max(1)).enumerate() {
            self.shift_receiver(guides, i, (v, self.per_channel()), &mut lobe, sign);
        }
    }

    /// Adds `sign` × receiver i's lobe to each block of `block` floats of `values`, its
    /// channels (the lobe's first `block` coefficients: the range term's signal reads bands 0
    /// to 2 alone); `lobe` is room for n² floats.
    pub(super) fn shift_receiver(
        &self,
        guides: &Guides,
        i: usize,
        (values, block): (&mut [f32], usize),
        lobe: &mut [f32],
        sign: f32,
    ) {
        if !self.lobe_of(guides, i, lobe) {
            return;
        }
        for channel in values.chunks_exact_mut(block.max(1)) {
            for (v, u) in channel.iter_mut().zip(&*lobe) {
                *v += sign * u;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relit by the light y(n), the unoccluded transfer about n gives Σ_l Â_l/π Σ_m
    /// y_lm(n)², and Σ_m y_lm(n)² = (2l + 1) / 4π for any n (the addition theorem).
    #[test]
    fn the_unoccluded_transfer_is_the_clamped_cosine_lobe_about_the_normal() {
        let basis = Basis::new(3);
        let (mut u, mut y) = ([0.0f32; 9], [0.0f32; 9]);
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        unoccluded(&basis, &lobe_factors(3), n, &mut u);
        basis.eval(n, &mut y);
        let lit: f32 = u.iter().zip(&y).map(|(u, y)| u * y).sum();
        let expected = (1.0 + 3.0 * 2.0 / 3.0 + 5.0 * 0.25) / (4.0 * std::f32::consts::PI);
        assert!((lit - expected).abs() < 1e-6, "{lit} against {expected}");
    }
}

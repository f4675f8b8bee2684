//! Over a normal map, the shading normal's own effect is taken out of the transfer before the
//! filter and put back after: each texel's transfer less its unoccluded transfer, the clamped
//! cosine lobe about its shading normal over its surface's hemisphere
//! ([`super::clipped_lobe`]), is what the filter smooths, and each texel adds its own back (as
//! SVGF filters illumination demodulated by albedo, Schied et al. 2017).
//!
//! Unoccluded, band l of the transfer about normal n is Â_l/π · y_lm(n), Â_l the clamped
//! cosine's zonal coefficients (Ramamoorthi & Hanrahan 2001, *An efficient representation
//! for irradiance environment maps*): 1, 2/3 and 1/4 for bands 0 to 2, less the part of that
//! lobe below the surface, which the surface itself blocks. A normal map's bumps change the
//! transfer from texel to texel mostly by that lobe, and what is left, the light the scene
//! blocks or bounces, changes with the normal far less. The fit in the normal
//! ([`super::normal_fit`]) follows the lobe only to second order, and its robust range term
//! cut the neighbours across a bump's edge, where it does not. On the production courtyard's
//! normal-mapped wall, at 256 rays, the wall's part of the error under the sun and sky fell
//! from 0.210 to 0.155 points (raw 2,048 rays: 0.128), and the whole courtyard's from 0.485
//! to 0.464 %, with the whole lobe taken out; with the lobe over the surface's hemisphere the
//! wall's fell again to 0.117 points and the courtyard's to 0.452 %
//! (docs/explanation/denoising-record.md).
//!
//! The filter's weights are unchanged in kind: shared by every coefficient, formed once. A
//! texel's answer is U_i + Σ_j w_ij (T_j − U_j): the weights' answer plus a term that
//! depends on the normals alone, the same under every light.

use super::clipped_lobe::{ClippedLobes, LobeScratch};
use super::guides::Guides;
use super::normal_fit::Normals;
use crate::math::sh::{MAX_ORDER, coeff_count};

/// What [`Demodulation::shift_receiver`] forms a lobe in.
#[derive(Default)]
pub(super) struct Scratch {
    lobe: Vec<f32>,
    turn: LobeScratch,
}

/// Which receivers are filtered demodulated, and how their lobes are formed.
pub(super) struct Demodulation {
    lobes: ClippedLobes,
    /// The floats per channel of the transfer it demodulates.
    per_channel: usize,
    /// Per receiver, whether its lobe is taken out.
    demodulated: Vec<bool>,
    /// Where they take no more than [`STORED_FLOATS`], every demodulated receiver's lobe,
    /// `per_channel` floats each in receiver order, and each receiver's first float there.
    stored: Option<(Vec<f32>, Vec<u32>)>,
}

/// The most floats of lobes [`Demodulation`] keeps (64 MiB): each lobe is read twice, once
/// taken out of the filter's signal and once put back, and formed once where they are kept
/// (on the courtyard's wall, 2 % of the filter's instructions). At order 12 a large
/// lightmap's would take gigabytes, so there they are formed each time.
const STORED_FLOATS: usize = 1 << 24;

impl Demodulation {
    /// The receivers whose group is fitted over a normal map ([`Normals::Mapped`]) and whose
    /// rays saw some light (their noise is not 0), for transfer of `per_channel` floats per
    /// channel; `None` where there is none, or where `per_channel` is no vector bake's (n²).
    ///
    /// A texel whose rays were all blocked is left as it is: it has neither transfer nor
    /// noise, and its lobe taken out would leave a pattern of bumps the filter reads as
    /// exact, which splits every cluster on a wall's shaded side (on the courtyard's wall,
    /// 11,000 clusters became 30,000, reading 7 × the neighbours).
    pub(super) fn new(guides: &Guides, normals: &[Normals], per_channel: usize) -> Option<Self> {
        let order = (per_channel as f64).sqrt() as usize;
        if !(1..=MAX_ORDER).contains(&order) || coeff_count(order) != per_channel {
            return None;
        }
        let mapped = |g: u32| normals.get(g as usize) == Some(&Normals::Mapped);
        let demodulated: Vec<bool> = (0..guides.points.len())
            .map(|i| mapped(guides.groups[i]) && guides.noise.get(i) != Some(&0.0))
            .collect();
        let mut demodulation = Demodulation {
            lobes: ClippedLobes::new(order),
            per_channel,
            demodulated,
            stored: None,
        };
        let count = demodulation.demodulated.iter().filter(|&&d| d).count();
        if count == 0 {
            return None;
        }
        if count * per_channel <= STORED_FLOATS {
            let (mut lobes, mut first) = (Vec::with_capacity(count * per_channel), Vec::new());
            let mut scratch = Scratch::default();
            for i in 0..guides.points.len() {
                first.push(lobes.len() as u32);
                if demodulation.lobe_of(guides, i, &mut scratch) {
                    lobes.extend_from_slice(&scratch.lobe);
                }
            }
            demodulation.stored = Some((lobes, first));
        }
        Some(demodulation)
    }

    /// Receiver i's lobe into `scratch.lobe`, or false where it keeps its transfer.
    fn lobe_of(&self, guides: &Guides, i: usize, scratch: &mut Scratch) -> bool {
        if !self.demodulated[i] {
            return false;
        }
        scratch.lobe.resize(self.per_channel, 0.0);
        if let Some((lobes, first)) = &self.stored {
            let first = first[i] as usize;
            scratch
                .lobe
                .copy_from_slice(&lobes[first..][..self.per_channel]);
            return true;
        }
        let (n, h) = (guides.normals[i], guides.surfaces[i]);
        self.lobes.lobe(n, h, &mut scratch.lobe, &mut scratch.turn);
        true
    }

    /// Adds `sign` × each demodulated receiver's lobe to each of its channels' blocks of
    /// `values`.
    pub(super) fn shift(&self, guides: &Guides, values: &mut [f32], sign: f32) {
        let width = values.len() / self.demodulated.len().max(1);
        let mut scratch = Scratch::default();
        for (i, v) in values.chunks_exact_mut(width.max(1)).enumerate() {
            self.shift_receiver(guides, i, (v, self.per_channel), &mut scratch, sign);
        }
    }

    /// Adds `sign` × receiver i's lobe to each block of `block` floats of `values`, its
    /// channels (the lobe's first `block` coefficients: the range term's signal reads bands 0
    /// to 2 alone).
    pub(super) fn shift_receiver(
        &self,
        guides: &Guides,
        i: usize,
        (values, block): (&mut [f32], usize),
        scratch: &mut Scratch,
        sign: f32,
    ) {
        if !self.lobe_of(guides, i, scratch) {
            return;
        }
        for channel in values.chunks_exact_mut(block.max(1)) {
            for (v, u) in channel.iter_mut().zip(&scratch.lobe) {
                *v += sign * u;
            }
        }
    }
}

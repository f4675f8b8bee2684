//! The denoise stage of a bake: its receivers' guides, the noise its rays estimated, and the
//! filter ([`Filter`]) applied in place to the transfer and the accessibility. Whole bakes,
//! merges and checkpoints all come through [`denoise_guided`].

use crate::bake::estimator::Visibility;
use crate::bake::options::BakeOptions;

use super::{Filter, Guides, Settings, vertex_guides};

/// [`denoise_baked`] for a bake of every vertex of `scene`.
pub fn denoise_vertices(
    scene: &crate::Scene,
    options: &BakeOptions,
    coefficients: &mut [f32],
    channels: usize,
    visibility: &mut [Visibility],
) {
    let guides = vertex_guides(scene, Vec::new());
    denoise_baked(
        guides,
        Settings::VERTICES,
        options,
        coefficients,
        channels,
        visibility,
    );
}

/// Denoises a bake's per-receiver transfer (`options` says its layout) in place, with the
/// noise its rays estimated per receiver (`visibility`'s, or none), and each receiver's
/// accessibility with the same weights: the accessibility is the transfer's DC under a
/// white sky, and stays so (but for the clamp to [0, 1]).
pub fn denoise_baked(
    guides: Guides,
    settings: Settings,
    options: &BakeOptions,
    coefficients: &mut [f32],
    channels: usize,
    visibility: &mut [Visibility],
) {
    let guides = Guides {
        noise: visibility.iter().map(|v| v.noise).collect(),
        ..guides
    };
    let mut ao: Vec<f32> = visibility.iter().map(|v| v.accessibility).collect();
    let per_channel = options.transfer.floats_per_channel(options.order);
    denoise_guided(
        &guides,
        settings,
        coefficients,
        channels,
        per_channel,
        Some(ao.as_mut_slice()),
    );
    for (v, a) in visibility.iter_mut().zip(ao) {
        v.accessibility = a;
    }
}

/// [`denoise_baked`] of transfer whose guides carry their noise (a merge's: the parts
/// carry both), `per_channel` floats per channel, and of the accessibility where there is
/// one. Every path that denoises goes through here, so a merged or checkpointed bake is
/// filtered by the very same arithmetic as the whole bake.
pub fn denoise_guided(
    guides: &Guides,
    settings: Settings,
    coefficients: &mut [f32],
    channels: usize,
    per_channel: usize,
    ao: Option<&mut [f32]>,
) {
    if guides.points.is_empty() {
        return;
    }
    let filter = Filter::new(guides, settings, coefficients, channels, per_channel);
    let scalars = ao.unwrap_or_default();
    filter.apply_to_transfer(coefficients, channels * per_channel, scalars);
    // The fit may overshoot a little; accessibility is a fraction.
    for a in scalars.iter_mut() {
        *a = a.clamp(0.0, 1.0);
    }
}

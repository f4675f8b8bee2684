//! Per-texel transfer: SH lightmaps over a lightmap UV atlas (`prt-bake bake --lightmap`).
//!
//! [`atlas`] says where each triangle lies in the lightmap (the scene's own lightmap UVs, or
//! planar charts unwrapped here), [`texels`] turns covered texels into sample points, and the bake runs
//! the same estimator as vertex bakes over those points as [`Receivers`]: same directions,
//! tracing, sums and determinism. `docs/lightmaps.md` describes what exists and what not.

pub mod atlas;
pub mod texels;

use std::time::Instant;

pub use atlas::{Atlas, AtlasSource};
pub use texels::Texels;

use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::trace::{Backend, Tracer};
use crate::transfer::{BakeOptions, Estimator, Mode, Receivers, Transfer, Visibility};

/// A texel bake: the atlas, its sample points, and the transfer of all W×H texels
/// (`transfer.vertex_count` = W·H; invalid texels hold zero transfer, zero accessibility
/// and a +z bent normal).
#[derive(Clone, Debug)]
pub struct LightmapBake {
    pub atlas: Atlas,
    pub texels: Texels,
    pub transfer: Transfer,
}

/// Bakes the transfer of every texel of `atlas` that a triangle covers. Unshadowed and
/// shadowed modes (with `--aux`); interreflected texel bakes are not implemented yet.
pub fn bake(
    scene: &crate::Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    atlas: Atlas,
    progress: &dyn Progress,
) -> Result<LightmapBake> {
    if options.mode == Mode::Interreflected {
        return Err(Error::InvalidOption(
            "--lightmap bakes support --mode unshadowed and shadowed only (interreflected \
             texel bakes are not implemented yet)"
                .into(),
        ));
    }
    let tracer = match (options.mode.casts_rays(), tracer) {
        (false, _) => None,
        (true, Some(t)) => Some(t),
        (true, None) => {
            return Err(Error::InvalidOption(format!(
                "{} transfer needs a ray-tracing backend",
                options.mode.name()
            )));
        }
    };
    let started = Instant::now();
    let texels = Texels::rasterise(scene, &atlas);
    let receivers: Receivers = texels.receivers();
    let count = receivers.len();
    let estimator = Estimator::for_receivers(receivers, options)?;
    let direct = crate::transfer::direct_pass(&estimator, tracer, None, progress);
    let n = crate::sh::coeff_count(options.order);
    let texel_count = texels.valid.len();
    let mut coefficients = vec![0.0f32; texel_count * n];
    let mut visibility = Vec::new();
    if tracer.is_some() {
        visibility = vec![
            Visibility {
                accessibility: 0.0,
                bent_normal: glam::Vec3::Z,
            };
            texel_count
        ];
    }
    let valid_indices = texels
        .valid
        .iter()
        .enumerate()
        .filter(|(_, v)| **v)
        .map(|(i, _)| i);
    for (k, i) in valid_indices.enumerate() {
        coefficients[i * n..(i + 1) * n].copy_from_slice(&direct.coefficients[k * n..(k + 1) * n]);
        if tracer.is_some() {
            visibility[i] = direct.visibility[k];
        }
    }
    Ok(LightmapBake {
        atlas,
        texels,
        transfer: Transfer {
            options: options.clone(),
            channels: 1,
            vertex_count: texel_count,
            coefficients,
            visibility,
            backend: tracer.map_or(Backend::None, |t| t.backend()),
            rays_cast: tracer.map_or(0, |_| u64::from(options.samples) * count as u64),
            seconds: started.elapsed().as_secs_f64(),
            hit_cache_bytes: None,
        },
    })
}

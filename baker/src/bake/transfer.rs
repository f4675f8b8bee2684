//! Diffuse transfer of vertices and lightmap texels: T_j = (1/π) ∫ V(x, s) max(n·s, 0) y_j(s) ds.
//!
//! * `unshadowed`: V = 1 (the thesis's "fast mode"); no rays are cast but the estimator and
//!   the directions are the same as for `shadowed`.
//! * `shadowed`: V is 0 where an occlusion ray from the vertex is blocked.
//! * `interreflected`: shadowed plus light that reaches the vertex after bouncing off other
//!   surfaces, in colour ([`crate::bake::interreflection`]).
//!
//! The rays of the shadowed pass also give the thesis's ambient-occlusion quantities for free
//! ([`Visibility`]): the cosine-weighted accessibility and the bent normal.
//!
//! The stored transfer excludes the receiving surface's own albedo: the renderer multiplies by
//! Kd × texture per pixel, so textures stay sharp between vertices.
//!
//! # How a receiver is baked
//!
//! [`bake_receivers`] is the one place: a vertex bake ([`bake`]) and a texel bake
//! ([`crate::bake::lightmap::bake`]) both build an [`Estimator`] over their receivers and call it,
//! with the way bounce hits read transfer back ([`BounceTargets`]: vertices, or texels).
//! Shard parts ([`crate::distribute::shard`]) run its first half, the direct pass, on a vertex range.
//!
//! The pieces, in the order data flows through them: [`crate::bake::options`] (what is asked),
//! [`crate::bake::receivers`] (what is baked at, and how bounce hits map back to it),
//! [`crate::bake::estimator`] (the per-receiver estimator and the direct pass),
//! [`crate::bake::bounce_rows`] and [`crate::bake::interreflection`] (the bounces), and this module:
//! the [`Transfer`] a bake returns and [`bake`], the entry point that dispatches.

use std::time::Instant;

use crate::scene::Scene;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;
use crate::trace::{Backend, Tracer};

pub(crate) use crate::bake::estimator::direct_pass;
pub use crate::bake::estimator::{Estimator, Scratch, Visibility};
pub use crate::bake::options::{Aux, BakeOptions, DEFAULT_HIT_CACHE_LIMIT, Mode, TransferKind};
pub use crate::bake::receivers::BounceTargets;
pub use crate::bake::receivers::Receivers;

/// The result of a bake: `coefficients[(v · channels + c) · n² + j]`; for a matrix bake
/// (`options.transfer`), `coefficients[((v · channels + c) · n² + i) · n² + j]`.
#[derive(Clone, Debug)]
pub struct Transfer {
    /// The options the bake ran with.
    pub options: BakeOptions,
    pub channels: usize,
    /// Receivers baked: the scene's vertices, or a lightmap's W·H texels.
    pub receiver_count: usize,
    pub coefficients: Vec<f32>,
    /// Per-vertex accessibility and bent normal (all vertices; what is stored is chosen by
    /// `options.aux`). Empty for unshadowed bakes, which cast no rays.
    pub visibility: Vec<Visibility>,
    pub backend: Backend,
    /// Rays actually cast (0 for unshadowed).
    pub rays_cast: u64,
    pub seconds: f64,
    /// Interreflected mode: bytes of cached first hits, or `None` if the bounce passes
    /// re-traced because the cache would have exceeded `options.hit_cache_limit`.
    pub hit_cache_bytes: Option<u64>,
}

/// What baking a set of receivers gave, before it becomes a [`Transfer`] (a texel bake
/// first places it in its lightmap).
#[derive(Clone, Debug, Default)]
pub struct Baked {
    /// `coefficients[(r · channels + c) · n² + j]` for receiver r.
    pub coefficients: Vec<f32>,
    pub channels: usize,
    /// Per receiver; empty when no rays were cast.
    pub visibility: Vec<Visibility>,
    /// Rays cast, re-traced bounce rays included.
    pub rays_cast: u64,
    /// Interreflected mode: bytes of cached bounce rows, `None` if the bounces re-traced.
    pub hit_cache_bytes: Option<u64>,
}

impl Transfer {
    /// The one constructor: `baked` as the transfer of `receiver_count` receivers (vertices,
    /// or a lightmap's W·H texels), baked with `options` on `backend` in `seconds`.
    pub fn from_direct(
        options: &BakeOptions,
        backend: Backend,
        receiver_count: usize,
        baked: Baked,
        seconds: f64,
    ) -> Transfer {
        let n = options.transfer.floats_per_channel(options.order);
        debug_assert!(
            baked.coefficients.is_empty()
                || baked.coefficients.len() == receiver_count * baked.channels * n
        );
        Transfer {
            options: options.clone(),
            channels: baked.channels,
            receiver_count,
            coefficients: baked.coefficients,
            visibility: baked.visibility,
            backend,
            rays_cast: baked.rays_cast,
            seconds,
            hit_cache_bytes: baked.hit_cache_bytes,
        }
    }

    /// Coefficients of vertex `v`, channel `c` (a matrix bake's n⁴, row-major).
    pub fn vertex(&self, v: usize, c: usize) -> &[f32] {
        let n = self.options.transfer.floats_per_channel(self.options.order);
        let start = (v * self.channels + c) * n;
        &self.coefficients[start..start + n]
    }
}

/// The tracer a bake in `options.mode` uses: none for unshadowed bakes, and an error if a
/// mode that casts rays has none.
pub(crate) fn tracer_for<'t>(
    options: &BakeOptions,
    tracer: Option<&'t dyn Tracer>,
) -> Result<Option<&'t dyn Tracer>> {
    match (options.mode.casts_rays(), tracer) {
        (false, _) => Ok(None),
        (true, Some(t)) => Ok(Some(t)),
        (true, None) => Err(Error::InvalidOption(format!(
            "{} transfer needs a ray-tracing backend",
            options.mode.name()
        ))),
    }
}

/// Bakes the transfer of every vertex. `tracer` may be `None` only in unshadowed mode.
pub fn bake(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Transfer> {
    let tracer = tracer_for(options, tracer)?;
    let started = Instant::now();
    let estimator = Estimator::new(scene, options)?;
    let adaptive_denoised = crate::bake::adaptive_denoised::applies(options, tracer);
    let baked = match tracer {
        // Sampled until the denoised estimate is within the target, and denoised.
        Some(tracer) if adaptive_denoised => denoised_adaptive(
            &estimator,
            tracer,
            crate::bake::denoise::vertex_guides(scene, Vec::new()),
            crate::bake::denoise::Settings::VERTICES,
            progress,
        ),
        // The interreflected matrix reads a vector bake's bounces at its hits.
        Some(tracer)
            if options.mode == Mode::Interreflected && options.transfer == TransferKind::Matrix =>
        {
            let m = crate::bake::matrix_bounce::bake_range(
                scene,
                tracer,
                &estimator,
                0..scene.vertex_count(),
                progress,
            )?;
            Baked {
                coefficients: m.coefficients,
                channels: m.channels,
                visibility: m.visibility,
                rays_cast: m.rays_cast,
                hit_cache_bytes: m.hit_cache_bytes,
            }
        }
        _ => bake_receivers(
            scene,
            tracer,
            &estimator,
            &BounceTargets::Vertices,
            progress,
        ),
    };
    let mut baked = baked;
    if options.denoise && tracer.is_some() && !adaptive_denoised {
        crate::bake::denoise::stage::denoise_vertices(
            scene,
            options,
            &mut baked.coefficients,
            baked.channels,
            &mut baked.visibility,
        );
    }
    Ok(Transfer::from_direct(
        options,
        tracer.map_or(Backend::None, |t| t.backend()),
        scene.vertex_count(),
        baked,
        started.elapsed().as_secs_f64(),
    ))
}

/// Bakes the estimator's receivers: the direct pass, and in interreflected mode the bounces,
/// whose hits read the previous bounce through `targets`. `tracer` is `None` exactly in
/// unshadowed mode.
pub fn bake_receivers(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    estimator: &Estimator,
    targets: &BounceTargets,
    progress: &dyn Progress,
) -> Baked {
    let options = &estimator.options;
    debug_assert!(
        !(options.mode == Mode::Interreflected && options.transfer == TransferKind::Matrix),
        "interreflected matrices are baked by bake::matrix_bounce"
    );
    let receivers = estimator.receiver_count();
    let mut baked = match tracer {
        Some(tracer) if options.mode == Mode::Interreflected => {
            let bounced =
                crate::bake::interreflection::bake(scene, tracer, estimator, targets, progress);
            Baked {
                coefficients: bounced.coefficients,
                channels: bounced.channels,
                visibility: bounced.visibility,
                rays_cast: 0,
                hit_cache_bytes: bounced.hit_cache_bytes,
            }
        }
        _ => {
            let direct = match options.transfer {
                TransferKind::Vector => {
                    direct_pass(estimator, tracer, None, 0..receivers, progress)
                }
                TransferKind::Matrix => crate::bake::matrix::matrix_pass(
                    estimator,
                    tracer,
                    None,
                    0..receivers,
                    progress,
                ),
            };
            Baked {
                coefficients: direct.coefficients,
                channels: 1,
                visibility: match tracer {
                    Some(_) => direct.visibility,
                    None => Vec::new(),
                },
                rays_cast: 0,
                hit_cache_bytes: None,
            }
        }
    };
    let rays_per_pass = match (tracer, options.target_error) {
        (None, _) => 0,
        (Some(_), None) => u64::from(options.samples) * receivers as u64,
        (Some(_), Some(_)) => baked.visibility.iter().map(|v| u64::from(v.rays)).sum(),
    };
    // Re-tracing bounce passes cast every receiver's bounce rays again.
    let retraced = match (options.mode, baked.hit_cache_bytes) {
        (Mode::Interreflected, None) => {
            u64::from(options.bounces)
                * u64::from(options.effective_bounce_samples())
                * receivers as u64
        }
        _ => 0,
    };
    baked.rays_cast = rays_per_pass + retraced;
    baked
}

/// An adaptive bake sampled to its denoised error ([`crate::bake::adaptive_denoised`]), as
/// the other bakes return theirs.
pub(crate) fn denoised_adaptive(
    estimator: &Estimator,
    tracer: &dyn Tracer,
    guides: crate::bake::denoise::Guides,
    settings: crate::bake::denoise::Settings,
    progress: &dyn Progress,
) -> Baked {
    let pass = crate::bake::adaptive_denoised::bake(estimator, tracer, guides, settings, progress);
    Baked {
        coefficients: pass.coefficients,
        channels: 1,
        rays_cast: pass.visibility.iter().map(|v| u64::from(v.rays)).sum(),
        visibility: pass.visibility,
        hit_cache_bytes: None,
    }
}

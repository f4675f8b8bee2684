//! Interreflected transfer matrices (`bake --transfer matrix --mode interreflected`, Sloan,
//! Kautz & Snyder 2002, §5 with diffuse interreflection): per receiver and channel c,
//!
//! ```text
//! M^c_ij = ∫ V(s) y_i(s) y_j(s) ds  +  ∫_{blocked s} y_i(s) · ρ_c(h(s)) · T^c_j(h(s)) ds
//! ```
//!
//! the SH coefficients of the incident radiance after bounces: along an unblocked direction
//! the distant light itself, along a blocked one the light the diffuse surface hit there,
//! h(s), reflects, ρ(h)·T(h)·L. T is the *diffuse* interreflected transfer vector with one
//! bounce fewer: a matrix with B bounces reads at its hits the light that arrived there
//! directly or after B − 1 bounces, so that projected through the clamped cosine it is the
//! B-bounce vector bake, T^B = T_0 + (1/π)∫_{blocked} cos·ρ·T^{B−1}(h) ds (the recursion of
//! [`crate::bake::interreflection`]). The hit surfaces are diffuse: what a glossy surface
//! reflects back into the scene is not modelled (as in Sloan 2002's diffuse bounces).
//!
//! # How it is baked
//!
//! 1. The interreflected vector bake with B − 1 bounces (the shadowed bake for B = 1), the
//!    same code, options and seed as `--transfer vector` would run: T^{B−1} at every vertex.
//! 2. One pass of the matrix's uniform-hemisphere rays ([`crate::bake::matrix`]): the
//!    bounce samples (the first M = N/4 points of the sequence, or `--bounce-samples`, as in
//!    the vector bake) are traced for their closest hits, the rest for occlusion. A front hit
//!    reads T^{B−1} exactly as the vector bake's bounce gather does
//!    ([`JobRows::front_hit_slots`]: the corners' barycentric weights, embedded corners left
//!    out, times the albedo at the hit's uv), and adds y(s) ⊗ ρ·T(h) weighted 2π/M. A back
//!    face blocks and reflects nothing.
//!
//! The bounce sums are not symmetric, so they are summed whole (n² rows × channels · n²
//! columns, 4 × 8 tiles kept in registers over a batch's hit rows, as the shadowed part's
//! triangle) in the local frame of y and the world frame of T; the rows are rotated into
//! world space at the end (R·B), and added to the shadowed part, which is summed and rotated
//! exactly as in a shadowed matrix bake. Channels: three unless every albedo is grey, as for
//! vectors. Every sum is in a fixed order: bit-identical for any thread count.

use crate::bake::bounce_rows::{Embedded, JobRows};
use crate::bake::estimator::{Estimator, Visibility, direct_pass};
use crate::bake::interreflection::albedo_is_grey;
use crate::bake::matrix::matrix_pass;
use crate::bake::matrix_hits::{BounceLight, LANES};
use crate::bake::options::{Aux, BakeOptions, Mode, TransferKind};
use crate::bake::receivers::BounceTargets;
use crate::scene::Scene;
use crate::support::error::Result;
use crate::support::progress::Progress;
use crate::trace::Tracer;

/// The options of the vector bake whose result the matrix's hits read: B − 1 bounces (the
/// shadowed bake when B = 1), everything else as asked.
fn vector_options(options: &BakeOptions) -> BakeOptions {
    let bounces = options.bounces.saturating_sub(1);
    BakeOptions {
        transfer: TransferKind::Vector,
        mode: if bounces == 0 {
            Mode::Shadowed
        } else {
            Mode::Interreflected
        },
        bounces,
        bounce_samples: if bounces == 0 {
            None
        } else {
            options.bounce_samples
        },
        aux: Aux::default(),
        ..options.clone()
    }
}

/// What the vector pass gave: T^{B−1}, its channels, the rays it cast and its hit cache.
struct Previous {
    transfer: Vec<f32>,
    channels: usize,
    rays: u64,
    hit_cache_bytes: Option<u64>,
}

/// T^{B−1} at every vertex of `scene`.
fn previous_bounces(
    scene: &Scene,
    tracer: &dyn Tracer,
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Previous> {
    let options = vector_options(options);
    let estimator = Estimator::new(scene, &options)?;
    let vertices = estimator.receiver_count();
    let rays = u64::from(options.samples) * vertices as u64;
    Ok(if options.bounces == 0 {
        let direct = direct_pass(&estimator, Some(tracer), None, 0..vertices, progress);
        Previous {
            transfer: direct.coefficients,
            channels: 1,
            rays,
            // No bounce rows: nothing was cached, and nothing re-traced.
            hit_cache_bytes: Some(0),
        }
    } else {
        let bounced = crate::bake::interreflection::bake(
            scene,
            tracer,
            &estimator,
            &BounceTargets::Vertices,
            progress,
        );
        let retraced = match bounced.hit_cache_bytes {
            Some(_) => 0,
            None => {
                u64::from(options.bounces)
                    * u64::from(options.effective_bounce_samples())
                    * vertices as u64
            }
        };
        Previous {
            transfer: bounced.coefficients,
            channels: bounced.channels,
            rays: rays + retraced,
            hit_cache_bytes: bounced.hit_cache_bytes,
        }
    })
}

/// What an interreflected matrix bake gives.
pub(crate) struct MatrixBounced {
    /// `coefficients[((r · channels + c) · n² + i) · n² + j]`.
    pub coefficients: Vec<f32>,
    pub channels: usize,
    pub visibility: Vec<Visibility>,
    /// Rays cast: the vector pass's (re-traced bounces included) and the matrix pass's.
    pub rays_cast: u64,
    /// The vector pass's hit cache: `None` if its bounces re-traced, 0 bytes if it had none.
    pub hit_cache_bytes: Option<u64>,
}

/// The interreflected matrices of `receivers` (vertices of `scene`; results indexed from
/// its start) by `estimator` (matrix options, interreflected mode), after the vector pass
/// over every vertex: `coefficients[((r · channels + c) · n² + i) · n² + j]`.
pub(crate) fn bake_range(
    scene: &Scene,
    tracer: &dyn Tracer,
    estimator: &Estimator,
    receivers: std::ops::Range<usize>,
    progress: &dyn Progress,
) -> Result<MatrixBounced> {
    let vertices = (estimator, &estimator.options);
    bake_range_of(scene, tracer, vertices, estimator, receivers, progress)
}

/// [`bake_range`] for receivers that are not the scene's vertices (transfer probes:
/// [`crate::bake::probes`]): the vector pass runs over the vertices with `vertex_options`, and
/// `corners` (an estimator over the vertices with them) tests the corners of hit triangles,
/// while `estimator` casts the receivers' own rays.
pub(crate) fn bake_range_of(
    scene: &Scene,
    tracer: &dyn Tracer,
    vertices: (&Estimator, &BakeOptions),
    estimator: &Estimator,
    receivers: std::ops::Range<usize>,
    progress: &dyn Progress,
) -> Result<MatrixBounced> {
    let prepared = prepare_light(scene, tracer, vertices, &estimator.options, progress)?;
    let pass = matrix_pass(
        estimator,
        Some(tracer),
        Some(&prepared.light),
        receivers.clone(),
        progress,
    );
    let rays = u64::from(estimator.options.samples) * receivers.len() as u64;
    Ok(MatrixBounced {
        coefficients: pass.coefficients,
        channels: prepared.light.channels,
        visibility: pass.visibility,
        rays_cast: prepared.rays + rays,
        hit_cache_bytes: prepared.hit_cache_bytes,
    })
}

/// What a matrix bake's bounce rays read (T^{B−1} at every vertex), ready for passes over
/// any receivers: a probe bake in blocks or shards computes it once per run, not per block.
pub(crate) struct PreparedLight<'a> {
    pub light: BounceLight<'a>,
    /// Rays the vector pass cast (re-traced bounces included).
    pub rays: u64,
    pub hit_cache_bytes: Option<u64>,
}

/// The vector pass over the vertices with `vertex_options` and the light its result gives
/// to receivers baked with `options`; `corners` (an estimator over the vertices) tests the
/// corners of hit triangles.
pub(crate) fn prepare_light<'a>(
    scene: &'a Scene,
    tracer: &'a dyn Tracer,
    (corners, vertex_options): (&'a Estimator, &BakeOptions),
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<PreparedLight<'a>> {
    const VERTICES: &BounceTargets<'static> = &BounceTargets::Vertices;
    let previous = previous_bounces(scene, tracer, vertex_options, progress)?;
    let n = crate::math::sh::coeff_count(options.order);
    let channels = if albedo_is_grey(scene) { 1 } else { 3 };
    let bounce_samples = options.effective_bounce_samples() as usize;
    let light = BounceLight {
        rows: JobRows::new(
            scene,
            VERTICES,
            std::sync::Arc::new(Embedded::new(scene, VERTICES)),
        ),
        probe: corners.corner_probe(tracer),
        previous: previous.transfer,
        previous_channels: previous.channels,
        channels,
        n,
        width: (channels * n).div_ceil(LANES) * LANES,
        bounce_samples,
        norm: std::f64::consts::TAU / bounce_samples as f64,
    };
    Ok(PreparedLight {
        light,
        rays: previous.rays,
        hit_cache_bytes: previous.hit_cache_bytes,
    })
}

/// [`bake_range`] of the receivers `receivers` alone, silently (the oracle tests bake one
/// vertex of a large scene): the channel count and the matrices.
pub fn receiver_matrices(
    scene: &Scene,
    tracer: &dyn Tracer,
    options: &BakeOptions,
    receivers: std::ops::Range<usize>,
) -> Result<(usize, Vec<f32>)> {
    let estimator = Estimator::new(scene, options)?;
    let silent = crate::support::progress::Silent;
    let baked = bake_range(scene, tracer, &estimator, receivers, &silent)?;
    Ok((baked.channels, baked.coefficients))
}

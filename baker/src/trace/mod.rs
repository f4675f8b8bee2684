//! Ray casting behind one trait, so the baker does not care which BVH answers.
//!
//! Backends: [`EmbreeTracer`] (the default, needs the `embree` feature and Embree's library)
//! and [`ObvhsTracer`] (pure Rust, always built, so a machine without Embree can still bake).
//! Every backend answers the same two questions for batches of rays, with the same semantics:
//! is the segment blocked, and what does it hit first. Batches let a backend use its fast
//! paths (Embree's ray streams). `tests/agreement.rs` checks that the two agree.
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`].

#[cfg(feature = "embree")]
mod embree;
#[cfg(feature = "embree")]
mod embree_scene;
mod instances;
mod obvhs;
mod offset;
pub mod seams;
mod tracer;
mod twins;

pub use self::obvhs::{ObvhsOptions, ObvhsTracer};
#[cfg(feature = "embree")]
pub use embree::{EmbreeMode, EmbreeOptions, EmbreePoints, EmbreeTracer, HIGH_QUALITY_RAYS};
/// The Embree bindings, for benchmarks that call Embree directly on the same scene.
#[cfg(feature = "embree")]
pub use embree_sys;
pub use offset::{offset_distance, ray_origins};
pub use tracer::{Backend, Hit, Ray, Tracer, TracerOptions};
pub use twins::TwinFacing;

use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// Refuses what [`build`] would refuse without looking at a scene: [`Backend::None`], Embree in
/// a build without the `embree` feature, `robust` with a backend that has no robust mode. The
/// CLI calls it before loading the scene, so a bad command line fails at once.
pub fn check(backend: Backend, options: TracerOptions) -> Result<()> {
    match backend {
        Backend::None => Err(Error::InvalidOption(
            "shadowed transfer needs a ray-tracing backend".into(),
        )),
        Backend::Embree if !cfg!(feature = "embree") => Err(Error::InvalidOption(
            "--backend embree: this prt-bake was built without Embree (the `embree` cargo \
             feature); use --backend obvhs"
                .into(),
        )),
        Backend::Obvhs if options.robust => Err(Error::InvalidOption(
            "--robust is Embree's robust mode; it does not apply to --backend obvhs".into(),
        )),
        Backend::Embree | Backend::Obvhs => Ok(()),
    }
}

/// A tracer of `backend` over `scene` (whose back-face hits on a `doubleSided` surface land
/// on its back sheet, [`TwinFacing`]); fails as [`check`] does, or when Embree cannot build
/// its scene.
pub fn build(backend: Backend, scene: &Scene, options: TracerOptions) -> Result<Box<dyn Tracer>> {
    check(backend, options)?;
    let inner: Box<dyn Tracer> = match backend {
        #[cfg(feature = "embree")]
        Backend::Embree => Box::new(EmbreeTracer::new(
            scene,
            EmbreeOptions {
                threads: options.threads,
                mode: if options.robust {
                    EmbreeMode::Robust
                } else {
                    EmbreeMode::Watertight
                },
                points_only: options.points_only,
                rays_per_receiver: options.rays_per_receiver,
            },
        )?),
        Backend::Obvhs => Box::new(ObvhsTracer::new(scene, ObvhsOptions::default())),
        _ => unreachable!("check() refused {backend:?}"),
    };
    Ok(TwinFacing::wrap(inner, scene))
}

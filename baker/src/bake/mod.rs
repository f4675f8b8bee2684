//! The bake: what is asked ([`options`]), where transfer is baked ([`receivers`]: vertices or
//! lightmap texels), the per-receiver [`estimator`] (its tables: [`sample_sets`]), its [`adaptive`] variant (with [`inference`]) and the [`matrix`] one (with bounces: [`matrix_bounce`]), the bounces
//! ([`bounce_rows`], [`interreflection`]), the entry points ([`transfer`], [`lightmap`]),
//! the memory a bake needs ([`memory`]), the point sets a denoised bake's neighbours share
//! ([`strata`]), the denoiser of its transfer ([`denoise`], guided
//! by each receiver's [`noise`]) and the coefficient file it fills ([`file`]).
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`], [`crate::trace`],
//! [`crate::formats`].

pub mod adaptive;
pub mod adaptive_denoised;
pub mod bounce_rows;
pub mod denoise;
pub mod embedded;
pub mod estimator;
pub mod file;
pub mod hit_cache;
pub mod inference;
pub mod interreflection;
pub mod ldprt;
pub mod lightmap;
pub mod matrix;
pub mod matrix_bounce;
pub mod matrix_hits;
pub mod matrix_layout;
pub mod memory;
pub mod noise;
pub mod occluder_fit;
pub mod options;
pub mod probe_validity;
pub mod probes;
pub mod receiver_names;
pub mod receiver_subset;
pub mod receivers;
pub mod sample_sets;
pub mod strata;
pub mod subsurface;
pub mod transfer;

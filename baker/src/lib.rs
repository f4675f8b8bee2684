//! Precomputed radiance transfer baking, after Sloan, Kautz & Snyder (2002) and the 2008
//! Zagreb thesis this project grew from.
//!
//! A bake turns a [`Scene`] into per-vertex spherical-harmonic transfer coefficients:
//! [`sh`] holds the basis and its conventions, [`sampling`] the directions, [`trace`] the ray
//! casting behind a backend-neutral trait, [`transfer`] the estimators, and
//! [`coefficient_file`] the documented `.prt` format the viewer reads.
//!
//! At run time, [`light`] projects lights (suns, skies, HDR environment maps, TOML rigs of
//! them) to SH, [`sh::rotation`] turns them, and [`relight`] shades a bake with them on the
//! CPU: the reference a viewer must match.

pub mod adaptive;
pub mod atomic;
pub mod bounce_rows;
pub mod checkpoint;
pub mod coefficient_file;
pub mod cpca;
pub mod cpca_block;
pub mod error;
pub mod estimator;
pub mod export;
pub mod gltf_export;
pub mod interreflection;
pub mod light;
pub mod lightmap;
pub mod limits;
pub mod merge;
pub mod npz;
pub mod openexr;
pub mod options;
pub mod output;
pub mod ply;
pub mod progress;
pub mod receivers;
pub mod relight;
pub mod sampling;
pub mod scene;
pub mod sh;
pub mod shard;
pub mod trace;
pub mod transfer;

pub use coefficient_file::CoefficientFile;
pub use error::{Error, Location, Result};
pub use scene::Scene;
pub use transfer::{BakeOptions, Mode, Transfer, bake};

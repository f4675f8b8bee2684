//! Precomputed radiance transfer baking, after Sloan, Kautz & Snyder (2002) and the 2008
//! Zagreb thesis this project grew from.
//!
//! A bake turns a [`Scene`] into per-vertex (or per-texel) spherical-harmonic transfer
//! coefficients. The crate is built in layers; each folder may import only the layers listed
//! before it (its `mod.rs` says which), so the bake can be read from the bottom up:
//!
//! | layer | holds |
//! |---|---|
//! | [`support`] | errors, memory limits and bounded file reads, progress, the output policy |
//! | [`math`] | the SH basis and its rotations, sample directions and random numbers |
//! | [`scene`] | triangle scenes from OBJ/MTL, scene files and glTF, their textures and up axis |
//! | [`trace`] | ray casting behind one trait: Embree, obvhs, ray origins, seams |
//! | [`light`] | lights (suns, skies, environment maps, rigs) projected to SH |
//! | [`formats`] | the files we read and write: the `.prt` coefficient file, npz, OpenEXR, PLY |
//! | [`bake`] | the bake: options, receivers, the estimator, adaptive sampling, bounces, lightmaps |
//! | [`distribute`] | shards, checkpoints and the merge that rejoins them |
//! | [`export`] | a bake for other tools: NumPy arrays, glTF, relighting on the CPU |
//!
//! `prt-bake` itself (`main.rs` and `commands/`) sits on top: one file per subcommand.

pub mod bake;
pub mod distribute;
pub mod export;
pub mod formats;
pub mod light;
pub mod math;
pub mod scene;
pub mod support;
pub mod trace;

pub use bake::lightmap;
pub use bake::transfer::{BakeOptions, Mode, Transfer, bake};
pub use formats::coefficient_file::CoefficientFile;
pub use scene::Scene;
pub use support::error::{Error, Location, Result};

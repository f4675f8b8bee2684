//! A bake for other tools: [`numpy`] arrays for analysis, [`gltf`] files for engines and DCC
//! tools, and [`relight`] (with [`relight_glossy`] for transfer matrices), the CPU reference a
//! viewer must match (coloured PLY meshes or lit lightmap images).
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`], [`crate::light`],
//! [`crate::formats`], [`crate::bake`] (the atlas of a texel bake).

pub mod compress;
pub mod gltf;
pub mod ldprt_gltf;
pub mod numpy;
pub mod probe_field;
pub mod probe_npz;
pub mod relight;
pub mod relight_glossy;
pub mod relight_ldprt;
pub mod relight_ldprt_probes;
pub mod relight_occluded;
pub mod relight_rigid;

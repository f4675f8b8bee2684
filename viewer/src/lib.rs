//! `prt-view`: a real-time viewer of baked precomputed radiance transfer, after the thesis's
//! SHDemo, that compares PRT with classic Blinn-Phong lighting.
//!
//! # PRT on the GPU
//!
//! A vertex's outgoing radiance is albedo × Σ_j T_j·L_j per colour channel (see
//! `docs/reference/lights.md`). The thesis evaluated the dot product on the CPU for every vertex and
//! frame, so its frame rate fell with every light it summed. Here the lights are summed and
//! rotated on the CPU once per frame (n² coefficients per channel, whatever the number of
//! lights), and the vertex shader does the per-vertex dot product, reading the transfer from a
//! storage buffer by vertex index: any order the file holds (up to 45), where vertex
//! attributes would stop at 16 vec4s (order 8 with grey transfer). The fragment shader
//! multiplies the interpolated radiance by Kd × texture per pixel and tone-maps it exactly as
//! `prt-bake relight` does (× 2^exposure, clamp to [0, 1], sRGB encoding by the framebuffer).
//!
//! A lightmap (texel) bake is shaded per pixel instead: its transfer goes to a storage buffer
//! or a texture array ([`texel_transfer`]), a pass dots every texel with the same summed light
//! once per frame into a radiance map ([`texel_radiance`]), and the fragment shader samples
//! it bilinearly at the fragment's lightmap uv (equal, by linearity, to filtering the
//! transfer per pixel and dotting it).
//!
//! A transfer-matrix bake is shown as glossy PRT ([`glossy`]): per vertex and frame, the
//! shadowed incident radiance L′ = M·L (from the matrix, or for a CPCA-compressed file from the
//! light projected per cluster on the CPU), then the diffuse term at the normal and each
//! material's Phong lobe at the reflected view direction.
//!
//! # Structure
//!
//! * [`Bake`] loads a scene through the baker's loader and its coefficient file, refusing a
//!   file baked for another scene.
//! * [`lights`]: the rig's lights as [`prt_baker::light::SteerableLight`]s (unrotated
//!   coefficients and absolute angles, as the thesis keeps them) and their Blinn-Phong
//!   stand-ins.
//! * [`View`]: everything the controls change (camera, lights, mode, toggles), free of any
//!   window, so headless renders, the benchmark and tests drive it directly.
//! * [`Renderer`]: `new` / `resize` / `update` / `render(&TextureView, &Device, &Queue)`, in the
//!   manner of the wgpu examples; it renders into any view, so the window, headless screenshots
//!   and tests share one path. Tests pass their own device ([`Gpu`]).
//! * [`moving`] and [`probe_scene`]: transfer probes (`prt-bake bake --probes`) drawn as
//!   spheres, and a rigid object baked alone moving along a path, lit through them.
//! * [`offscreen`], [`probe`], [`bench`] and [`window`]: screenshots, the per-vertex readback
//!   that tests compare with `relight`, the frame-rate table, and the interactive window.

pub mod bake;
pub mod bench;
pub mod camera;
pub mod controls;
pub mod error;
pub mod font;
pub mod glossy;
pub mod gpu;
pub mod lights;
mod materials;
pub mod moving;
pub mod occluders;
pub mod offscreen;
mod overlay;
pub mod probe;
pub mod probe_scene;
pub mod renderer;
mod resources;
pub mod skinned;
pub mod texel_occluders;
pub mod texel_radiance;
pub mod texel_transfer;
pub mod textures;
pub mod window;

pub use bake::Bake;
pub use camera::Camera;
pub use controls::{Key, Mode, View};
pub use error::{Error, Result};
pub use gpu::Gpu;
pub use renderer::{FrameInputs, Renderer};

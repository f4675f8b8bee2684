//! The mathematics of the bake, free of scenes and rays: the real SH basis (index
//! l(l+1)+m, θ from +z, Condon–Shortley phase) and its rotations, and the sample directions
//! and random numbers that make a bake deterministic.
//!
//! May import: [`crate::support`].

pub mod cpca;
mod cpca_moves;
pub mod eigen;
pub mod glossy;
pub mod light_prior;
pub mod medium;
pub mod occlusion;
pub mod sampling;
pub mod sh;

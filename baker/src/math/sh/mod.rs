//! Real spherical harmonics of any order.
//!
//! # Conventions (fixed for the whole project: bakes, coefficient files, lights, the viewer)
//!
//! * An *order* n projection uses bands l = 0..n−1: n² coefficients (the thesis uses n = 4).
//! * Coefficient (l, m), −l ≤ m ≤ l, is stored at index l(l+1)+m.
//! * θ is measured from +z, φ from +x towards +y: direction (sin θ cos φ, sin θ sin φ, cos θ).
//! * The associated Legendre polynomials carry the Condon–Shortley phase (−1)^m of the thesis's
//!   relation (3), so y_1^{−1} = −0.488603·y, y_1^0 = 0.488603·z, y_1^1 = −0.488603·x, as in
//!   google/spherical-harmonics and DirectXMath.
//! * The basis is orthonormal over the sphere: ∫ y_i y_j ds = δ_ij.
//!
//! Three evaluations, from slow and obviously right to fast:
//! [`eval_slow`] follows the thesis literally (relations (1)–(3), angles, trigonometry);
//! [`Basis`] runs the same recurrences on the Cartesian direction, trading
//! sin^m θ·cos mφ for Re (x+iy)^m so no trigonometry is needed; and for orders ≤ 4 [`Basis`]
//! uses hard-coded polynomials. Tests check each against the one before.
//!
//! Rotations: [`rotation`] builds explicit band matrices (the thesis's ZYZ product, what lights
//! use, and Ivanic–Ruedenberg's recurrence, what the baker uses per receiver), and [`Rotator`]
//! below projects rotated basis functions, the independent method the tests check both with.
//!
//! [`basis`] holds the basis and [`rotation`] its rotations; both are re-exported here, so
//! `sh::coeff_count` and `sh::rotation::ShRotation` read as before.

mod basis;
pub mod rotation;
pub mod triple;

pub use basis::*;
pub use rotation::{RecurrenceRotator, RotationScratch, ZyzRotator};

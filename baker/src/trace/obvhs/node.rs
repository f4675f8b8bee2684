//! The ray–box test on obvhs's compressed 8-wide nodes.
//!
//! A CWBVH node stores its children's boxes as 8-bit plane positions q on a grid of spacing
//! `quantum` (a power of two) from its corner p: a plane lies at p + q·quantum, and a ray
//! from o with direction d meets it at t = q·(quantum/d) + (p − o)/d. Converting the 48 bytes
//! to floats is much of the cost of a test, so [`ChildBoxes`] does it once per node visit for
//! all the rays of a packet. (Decoding every node once, when the tracer is built, measured
//! slower: the float planes take 3.6 times the memory.)
//!
//! obvhs's own test clamps the entry distance to at least 10⁻⁴ (absolute), which skips every
//! box that ends closer than that to the origin — a whole scene a tenth of a millimetre
//! across, or the corner where a floor meets a wall. Ours clamps to the ray's [0, tfar] and
//! widens it by a bound on the rounding error, so no box is missed by rounding (as Embree's
//! robust traversal). And
//! where obvhs replaces direction components below f32::EPSILON by ±EPSILON before inverting
//! (which shrinks slab intervals, so a box crossed at large t can be missed), we substitute
//! ±10⁻¹⁸ as Embree does, which moves the ray by far less than a float.

use glam::{Vec3A, Vec4};
use obvhs::cwbvh::node::{CwBvhNode, extract_byte64};

/// Direction components smaller than this are replaced by ±this before inverting: a ray
/// parallel to a slab then gets a huge finite slope instead of an infinity that would turn
/// `0 · ∞` into NaN.
const MIN_DIRECTION: f32 = 1e-18;

/// A ray prepared for box tests.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoxRay {
    pub(super) origin: Vec3A,
    pub(super) dir: Vec3A,
    inv_dir: Vec3A,
    pub(super) tfar: f32,
}

impl BoxRay {
    pub(super) fn new(origin: Vec3A, dir: Vec3A, tfar: f32) -> BoxRay {
        let inverse = |d: f32| {
            1.0 / if d.abs() < MIN_DIRECTION {
                MIN_DIRECTION.copysign(d)
            } else {
                d
            }
        };
        BoxRay {
            origin,
            dir,
            inv_dir: Vec3A::from_array(dir.to_array().map(inverse)),
            tfar,
        }
    }
}

/// A node's child planes as floats, four children per SSE lane group (glam's `Vec4`).
pub(super) struct ChildBoxes {
    /// `[axis][half]`: the min planes of children 4·half .. 4·half + 3, in quanta.
    min: [[Vec4; 2]; 3],
    max: [[Vec4; 2]; 3],
    p: Vec3A,
    quantum: Vec3A,
}

impl ChildBoxes {
    #[inline(always)]
    pub(super) fn new(node: &CwBvhNode) -> ChildBoxes {
        // One loop over the 48 planes, which LLVM turns into a few vector conversions.
        let mut q = [0.0f32; 48];
        let rows = [
            &node.child_min_x,
            &node.child_max_x,
            &node.child_min_y,
            &node.child_max_y,
            &node.child_min_z,
            &node.child_max_z,
        ];
        for (dst, row) in q.chunks_exact_mut(8).zip(rows) {
            for (d, q) in dst.iter_mut().zip(row) {
                *d = f32::from(*q);
            }
        }
        let lanes = |k: usize| Vec4::from_slice(&q[4 * k..4 * k + 4]);
        ChildBoxes {
            min: [
                [lanes(0), lanes(1)],
                [lanes(4), lanes(5)],
                [lanes(8), lanes(9)],
            ],
            max: [
                [lanes(2), lanes(3)],
                [lanes(6), lanes(7)],
                [lanes(10), lanes(11)],
            ],
            p: node.p.into(),
            quantum: node.compute_extent(),
        }
    }

    /// Bit c is set if the ray enters child c's box within [0, tfar], or comes within
    /// rounding error of it: the test never misses a box the ray enters.
    #[inline(always)]
    pub(super) fn entered_by(&self, ray: &BoxRay) -> u32 {
        let scale = self.quantum * ray.inv_dir;
        let offset = (self.p - ray.origin) * ray.inv_dir;
        // Each distance q·scale + offset is off by at most 4 roundings of its terms' size,
        // ≤ 2⁻²²·(255·|scale| + |offset|); entry and exit each may be, hence 2⁻²¹. The same
        // margin covers obvhs's quantisation, which can round a plane inwards by half an ulp.
        let slack = Vec4::splat(
            (255.0 * scale.abs().max_element() + offset.abs().max_element()) * (1.0 / 2_097_152.0),
        );
        let mut entered = 0;
        for half in 0..2 {
            let planes = |axis: usize| {
                let (lo, hi) = (self.min[axis][half], self.max[axis][half]);
                let (near, far) = if ray.dir[axis] < 0.0 {
                    (hi, lo)
                } else {
                    (lo, hi)
                };
                (
                    near * scale[axis] + offset[axis],
                    far * scale[axis] + offset[axis],
                )
            };
            let ((near_x, far_x), (near_y, far_y), (near_z, far_z)) =
                (planes(0), planes(1), planes(2));
            let entry = near_x.max(near_y).max(near_z).max(Vec4::ZERO);
            let exit = far_x.min(far_y).min(far_z).min(Vec4::splat(ray.tfar)) + slack;
            entered |= entry.cmple(exit).bitmask() << (4 * half);
        }
        entered
    }
}

/// The hit mask obvhs's `traverse!` expects, for the children of `node` in bit mask `entered`
/// (it orders them front to back for the octant `oct_inv4`).
#[inline(always)]
pub(super) fn traversal_mask(node: &CwBvhNode, oct_inv4: u32, entered: u32) -> u32 {
    let (child_bits, bit_index) = node.get_child_and_index_bits(oct_inv4);
    bits(entered).fold(0, |mask, child| {
        mask | extract_byte64(child_bits, child) << extract_byte64(bit_index, child)
    })
}

/// The indices of the set bits of `mask`, lowest first.
#[inline(always)]
pub(super) fn bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let bit = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            bit
        })
    })
}

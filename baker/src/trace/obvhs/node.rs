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

/// Eight rays, one per lane, for [`ChildBoxes::lanes_enter_avx`].
#[derive(Clone, Copy, Debug)]
pub(super) struct RayLanes {
    origin: [[f32; 8]; 3],
    inv_dir: [[f32; 8]; 3],
    tfar: [f32; 8],
}

impl RayLanes {
    /// `rays` (at most eight) in lanes 0, 1, …; missing lanes repeat the first ray.
    pub(super) fn new(rays: &[BoxRay]) -> RayLanes {
        let mut lanes = RayLanes {
            origin: [[0.0; 8]; 3],
            inv_dir: [[0.0; 8]; 3],
            tfar: [0.0; 8],
        };
        for lane in 0..8 {
            let ray = rays.get(lane).unwrap_or(&rays[0]);
            for axis in 0..3 {
                lanes.origin[axis][lane] = ray.origin[axis];
                lanes.inv_dir[axis][lane] = ray.inv_dir[axis];
            }
            lanes.tfar[lane] = ray.tfar;
        }
        lanes
    }
}

/// A node's child planes as floats, all eight children side by side: for eight rays' tests
/// against one child at a time (AVX, [`ChildBoxes::lanes_enter_avx`]), or one ray's against
/// four children at a time (SSE, [`ChildBoxes::entered_by`]).
pub(super) struct ChildBoxes {
    /// `[axis]`: the min planes of children 0..8, in quanta.
    min: [[f32; 8]; 3],
    max: [[f32; 8]; 3],
    p: Vec3A,
    quantum: Vec3A,
}

impl ChildBoxes {
    #[inline(always)]
    pub(super) fn new(node: &CwBvhNode) -> ChildBoxes {
        let planes = |row: &[u8; 8]| row.map(f32::from);
        ChildBoxes {
            min: [
                planes(&node.child_min_x),
                planes(&node.child_min_y),
                planes(&node.child_min_z),
            ],
            max: [
                planes(&node.child_max_x),
                planes(&node.child_max_y),
                planes(&node.child_max_z),
            ],
            p: node.p.into(),
            quantum: node.compute_extent(),
        }
    }

    /// Bit c is set if the ray enters child c's box within [0, tfar], or comes within
    /// rounding error of it: the test never misses a box the ray enters. Four children at a
    /// time (SSE).
    #[inline(always)]
    pub(super) fn entered_by(&self, ray: &BoxRay) -> u32 {
        let (scale, offset, slack) = self.distances(ray);
        let slack = Vec4::splat(slack);
        let mut entered = 0;
        for half in 0..2 {
            let lanes = |planes: &[f32; 8]| Vec4::from_slice(&planes[4 * half..4 * half + 4]);
            let mut entry = Vec4::ZERO;
            let mut exit = Vec4::splat(ray.tfar);
            for axis in 0..3 {
                let (near, far) = self.near_far(ray, axis);
                entry = entry.max(lanes(near) * scale[axis] + offset[axis]);
                exit = exit.min(lanes(far) * scale[axis] + offset[axis]);
            }
            entered |= entry.cmple(exit + slack).bitmask() << (4 * half);
        }
        entered
    }

    /// [`ChildBoxes::entered_by`] for eight rays at once, one per lane (AVX): `[c]` has bit
    /// i set if ray i of `rays` enters child c. Lane by lane the same operations on the same
    /// values as the one-ray tests, so the same answers; the rays' terms are computed once per
    /// node for the eight, and the answers come out by child, as the packet needs them.
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    pub(super) unsafe fn lanes_enter_avx(&self, rays: &RayLanes) -> [u32; 8] {
        use std::arch::x86_64::*;
        // SAFETY (all loads): each array holds the 8 floats an unaligned 256-bit load reads.
        let load = |v: &[f32; 8]| unsafe { _mm256_loadu_ps(v.as_ptr()) };
        let abs = |v: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), v);
        let (p, quantum) = (self.p.to_array(), self.quantum.to_array());
        let mut scale = [_mm256_setzero_ps(); 3];
        let mut offset = [_mm256_setzero_ps(); 3];
        let mut negative = [_mm256_setzero_ps(); 3];
        for axis in 0..3 {
            let inv = load(&rays.inv_dir[axis]);
            scale[axis] = _mm256_mul_ps(_mm256_set1_ps(quantum[axis]), inv);
            offset[axis] = _mm256_mul_ps(
                _mm256_sub_ps(_mm256_set1_ps(p[axis]), load(&rays.origin[axis])),
                inv,
            );
            // By the inverse's sign, as `near_far`.
            negative[axis] = _mm256_cmp_ps::<_CMP_LT_OQ>(inv, _mm256_setzero_ps());
        }
        let largest =
            |v: [__m256; 3]| _mm256_max_ps(_mm256_max_ps(abs(v[0]), abs(v[1])), abs(v[2]));
        let slack = _mm256_mul_ps(
            _mm256_add_ps(
                _mm256_mul_ps(_mm256_set1_ps(255.0), largest(scale)),
                largest(offset),
            ),
            _mm256_set1_ps(1.0 / 2_097_152.0),
        );
        let tfar = load(&rays.tfar);
        let mut entered = [0u32; 8];
        for (c, entered) in entered.iter_mut().enumerate() {
            let mut entry = _mm256_setzero_ps();
            let mut exit = tfar;
            for axis in 0..3 {
                let lo = _mm256_set1_ps(self.min[axis][c]);
                let hi = _mm256_set1_ps(self.max[axis][c]);
                let near = _mm256_blendv_ps(lo, hi, negative[axis]);
                let far = _mm256_blendv_ps(hi, lo, negative[axis]);
                entry = _mm256_max_ps(
                    entry,
                    _mm256_add_ps(_mm256_mul_ps(near, scale[axis]), offset[axis]),
                );
                exit = _mm256_min_ps(
                    exit,
                    _mm256_add_ps(_mm256_mul_ps(far, scale[axis]), offset[axis]),
                );
            }
            let inside = _mm256_cmp_ps::<_CMP_LE_OQ>(entry, _mm256_add_ps(exit, slack));
            *entered = _mm256_movemask_ps(inside) as u32;
        }
        entered
    }

    /// The ray's distance to a plane q quanta from the node's corner is q·scale + offset, per
    /// axis; and the slack that covers the rounding of entry and exit distances.
    #[inline(always)]
    fn distances(&self, ray: &BoxRay) -> (Vec3A, Vec3A, f32) {
        let scale = self.quantum * ray.inv_dir;
        let offset = (self.p - ray.origin) * ray.inv_dir;
        // Each distance q·scale + offset is off by at most 4 roundings of its terms' size,
        // ≤ 2⁻²²·(255·|scale| + |offset|); entry and exit each may be, hence 2⁻²¹. The same
        // margin covers obvhs's quantisation, which can round a plane inwards by half an ulp.
        let slack =
            (255.0 * scale.abs().max_element() + offset.abs().max_element()) * (1.0 / 2_097_152.0);
        (scale, offset, slack)
    }

    /// The planes of `axis` the ray meets first and last. Which is which follows the sign of
    /// the inverse the distances are scaled by: a direction component of −0 has the inverse
    /// −10¹⁸ but does not compare below 0 (a ray straight down, −z, missed every floor).
    #[inline(always)]
    fn near_far(&self, ray: &BoxRay, axis: usize) -> (&[f32; 8], &[f32; 8]) {
        if ray.inv_dir[axis] < 0.0 {
            (&self.max[axis], &self.min[axis])
        } else {
            (&self.min[axis], &self.max[axis])
        }
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

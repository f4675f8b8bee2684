//! Occlusion of consecutive rays in packets.
//!
//! Up to [`PACKET`] rays traverse the BVH together: a node is visited if any ray of the packet
//! that is still unblocked enters it; its child planes are decoded once for all of them
//! ([`ChildBoxes`]) and each ray tests the boxes itself, so the packet visits the union of
//! the nodes its rays would visit alone. At a leaf, each triangle is tested against the
//! unblocked rays four at a time ([`Triangle::hits`], the same arithmetic as the one-ray
//! test). Every ray therefore meets every triangle it would meet alone, and the answers are
//! those of single-ray traversal. The bake's rays leave one vertex in Hilbert order, so
//! neighbours in a batch are close in direction and their node sets overlap.

use glam::UVec2;
use obvhs::traverse;

use super::ObvhsTracer;
use super::node::{BoxRay, ChildBoxes, bits, traversal_mask};
use super::triangle::RayGroup;

/// Rays per packet. On the demo scene at 10,000 rays per vertex, 4, 8 and 16 traced within
/// 5 % of each other and 1.5 times as fast as single rays (docs/performance.md).
pub(super) const PACKET: usize = 16;
const GROUPS: usize = PACKET / 4;

impl ObvhsTracer {
    /// Bit i is set if `rays[i]` (at most [`PACKET`] rays) is blocked.
    ///
    /// With `AVX`, the box tests use AVX instructions: only where the CPU has them.
    #[inline(always)]
    fn blocked_packet<const AVX: bool>(&self, rays: &[BoxRay]) -> u32 {
        debug_assert!((1..=PACKET).contains(&rays.len()));
        let mut groups = [RayGroup::new(&rays[..1]); GROUPS];
        for (group, rays) in groups.iter_mut().zip(rays.chunks(4)) {
            *group = RayGroup::new(rays);
        }
        let all = u32::MAX >> (32 - rays.len());
        let mut blocked = 0u32;
        let mut state = self.bvh.new_traversal(rays[0].dir);
        let mut node;
        'traversal: {
            traverse!(
                self.bvh,
                node,
                state,
                {
                    let boxes = ChildBoxes::new(node);
                    let entered = bits(all & !blocked)
                        .fold(0, |e, i| e | entered_by::<AVX>(&boxes, &rays[i]));
                    traversal_mask(node, state.oct_inv4, entered)
                },
                {
                    let triangle = &self.triangles[state.primitive_id as usize];
                    for (g, group) in groups.iter().enumerate() {
                        let open = (all & !blocked) >> (4 * g) & 0xf;
                        if open != 0 {
                            blocked |= (triangle.hits(group) & open) << (4 * g);
                        }
                    }
                    if blocked == all {
                        break 'traversal;
                    }
                }
            );
        }
        blocked
    }

    /// Occlusion of `rays` in order, [`PACKET`] at a time: compiled for AVX2 where the CPU
    /// has it (the box tests then take one 8-wide instruction per step instead of two 4-wide
    /// ones), and for the build's baseline otherwise. Both compilations evaluate the same
    /// operations in the same order, without fused multiply-adds, so their answers are
    /// identical.
    pub(super) fn blocked_in_packets(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        occluded: &mut [bool],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { self.blocked_in_packets_avx2(rays, occluded) };
        }
        self.blocked_in_packets_baseline(rays, occluded)
    }

    /// [`ObvhsTracer::blocked_in_packets`] compiled for AVX2, with 8-wide box tests.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn blocked_in_packets_avx2(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        occluded: &mut [bool],
    ) {
        self.packets::<true>(rays, occluded)
    }

    /// [`ObvhsTracer::blocked_in_packets`] compiled for the build's baseline (SSE) whatever
    /// the CPU: the portable path, which the tests compare with the AVX2 one.
    pub(super) fn blocked_in_packets_baseline(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        occluded: &mut [bool],
    ) {
        self.packets::<false>(rays, occluded)
    }

    #[inline(always)]
    fn packets<const AVX: bool>(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        occluded: &mut [bool],
    ) {
        assert_eq!(rays.len(), occluded.len());
        let mut rays = rays;
        for occluded in occluded.chunks_mut(PACKET) {
            let mut packet = [BoxRay::new(glam::Vec3A::ZERO, glam::Vec3A::Z, 0.0); PACKET];
            for (p, r) in packet.iter_mut().zip(&mut rays) {
                *p = r;
            }
            let blocked = self.blocked_packet::<AVX>(&packet[..occluded.len()]);
            for (i, o) in occluded.iter_mut().enumerate() {
                *o = blocked & (1 << i) != 0;
            }
        }
    }
}

/// [`ChildBoxes::entered_by`], 8-wide with `AVX`.
#[inline(always)]
fn entered_by<const AVX: bool>(boxes: &ChildBoxes, ray: &BoxRay) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is true only in code the CPU's AVX2 support was checked for.
        return unsafe { boxes.entered_by_avx(ray) };
    }
    boxes.entered_by(ray)
}

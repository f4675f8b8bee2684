//! Occlusion of consecutive rays in packets, each ray culled on its own.
//!
//! Up to [`PACKET`] rays traverse the BVH together, with our own stack rather than obvhs's
//! `traverse!` loop: a stack entry is a node and the mask of the packet's rays that entered
//! its box. At a node, the child planes are decoded once ([`ChildBoxes`]) and each of those
//! rays (still unblocked) tests the eight boxes itself; the per-ray answers, transposed
//! ([`by_child`]), give each child the mask of the rays that entered it. A ray is therefore
//! only tested against the children and triangles of boxes it entered, exactly as if it
//! traversed alone, and its answer is the single-ray answer (every triangle a ray hits lies in
//! boxes it enters: the box test never misses). At a leaf, each triangle is tested against
//! its rays four at a time ([`Triangle::hits`], the same arithmetic as the one-ray test).
//! Children are visited front to back for the first ray's octant (obvhs's order), leaves
//! before inner nodes, and a packet stops once all its rays are blocked. The bake's rays leave
//! one vertex in Hilbert order, so neighbours in a batch are close in direction and their
//! node sets overlap.

use glam::Vec3A;

use super::ObvhsTracer;
use super::node::{BoxRay, ChildBoxes, RayLanes, bits};
use super::triangle::RayGroup;

/// Rays per packet: two AVX box tests of eight rays. (Before per-ray culling, 4, 8 and 16
/// traced within 5 % of each other; not re-measured since.)
pub(super) const PACKET: usize = 16;
const GROUPS: usize = PACKET / 4;

/// A node to visit and the rays (bit i: ray i of the packet) that entered its box.
type Entry = (u32, u32);

impl ObvhsTracer {
    /// Bit i is set if `rays[i]` (at most [`PACKET`] rays) is blocked.
    ///
    /// With `AVX`, the box tests use AVX instructions: only where the CPU has them.
    #[inline(always)]
    fn blocked_packet<const AVX: bool>(
        &self,
        rays: &[BoxRay],
        origin: Option<Vec3A>,
        stack: &mut Vec<Entry>,
    ) -> u32 {
        debug_assert!((1..=PACKET).contains(&rays.len()));
        if self.bvh.nodes.is_empty() {
            return 0;
        }
        let mut groups = [RayGroup::new(&rays[..1]); GROUPS];
        for (group, rays) in groups.iter_mut().zip(rays.chunks(4)) {
            *group = RayGroup::new(rays);
        }
        let lanes: [RayLanes; PACKET / 8] = std::array::from_fn(|h| {
            RayLanes::new(rays.get(8 * h..).filter(|r| !r.is_empty()).unwrap_or(rays))
        });
        let all = u32::MAX >> (32 - rays.len());
        // Children in obvhs's front-to-back order for the first ray's octant: slot k ^ flip
        // for k = 7, 6, …, 0.
        let d = rays[0].dir;
        let flip = (usize::from(d.x >= 0.0) << 2)
            | (usize::from(d.y >= 0.0) << 1)
            | usize::from(d.z >= 0.0);
        let mut blocked = 0u32;
        stack.clear();
        stack.push((0, all));
        while let Some((index, entered_node)) = stack.pop() {
            let open = entered_node & !blocked;
            if open == 0 {
                continue;
            }
            let node = &self.bvh.nodes[index as usize];
            let boxes = ChildBoxes::new(node);
            let children = children_entered::<AVX>(&boxes, &lanes, rays, open);
            // Leaves first, front to back.
            for k in (0..8).rev() {
                let c = k ^ flip;
                let meta = node.child_meta[c];
                if node.imask & (1 << c) != 0 || meta == 0 {
                    continue;
                }
                blocked = self.block_in_leaf(
                    node.primitive_base_idx,
                    meta,
                    children[c],
                    blocked,
                    &groups,
                    origin,
                    rays,
                );
                if blocked == all {
                    return blocked;
                }
            }
            // Inner children, the front one pushed last (popped first). An inner child's
            // index is the number of inner children before it in the node.
            for k in 0..8 {
                let c = k ^ flip;
                if node.imask & (1 << c) != 0 && children[c] != 0 {
                    let before = (u32::from(node.imask) & ((1 << c) - 1)).count_ones();
                    stack.push((node.child_base_idx + before, children[c]));
                }
            }
        }
        blocked
    }

    /// `blocked` with the rays of `entered` that hit a triangle of the leaf `meta` (obvhs's
    /// child metadata: first triangle past `primitive_base` and count) added; stops early
    /// once all of them are blocked. Kept apart from the traversal so each reads alone;
    /// inlined, so the AVX2 compilation still covers it.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the packet's views, each prepared once per packet
    fn block_in_leaf(
        &self,
        primitive_base: u32,
        meta: u8,
        entered: u32,
        mut blocked: u32,
        groups: &[RayGroup; GROUPS],
        origin: Option<Vec3A>,
        rays: &[BoxRay],
    ) -> u32 {
        let first = primitive_base + u32::from(meta & 0b1_1111);
        let count = (meta & 0b1110_0000).count_ones();
        for slot in first..first + count {
            let open = entered & !blocked;
            if open == 0 {
                break;
            }
            let triangle = &self.triangles[slot as usize];
            let mut hit = 0;
            if let Some(o) = origin {
                let shared = triangle.seen_from(o);
                for (g, group) in groups.iter().enumerate() {
                    let lanes = open >> (4 * g) & 0xf;
                    if lanes != 0 {
                        hit |= (triangle.hits_from(&shared, group) & lanes) << (4 * g);
                    }
                }
            } else {
                for (g, group) in groups.iter().enumerate() {
                    let lanes = open >> (4 * g) & 0xf;
                    if lanes != 0 {
                        hit |= (triangle.hits(group) & lanes) << (4 * g);
                    }
                }
            }
            if hit != 0 && self.cutouts.is_some() {
                hit = self.alpha_tested(slot, hit, rays);
            }
            blocked |= hit;
        }
        blocked
    }

    /// Of the rays in `hit` (a mask over `rays`) that hit the triangle in BVH slot `slot`,
    /// those the alpha test stops ([`ObvhsTracer::stops`], on the one-ray hit).
    #[cold]
    fn alpha_tested(&self, slot: u32, hit: u32, rays: &[BoxRay]) -> u32 {
        let triangle = &self.triangles[slot as usize];
        bits(hit)
            .filter(|&i| {
                triangle
                    .intersect(&rays[i])
                    .is_some_and(|h| self.stops(slot, &h, &rays[i]))
            })
            .fold(0, |mask, i| mask | 1 << i)
    }

    /// Occlusion of `rays` in order, [`PACKET`] at a time: compiled for AVX2 where the CPU
    /// has it (the box tests then test eight rays against a child per instruction), and for
    /// the build's baseline otherwise (one ray against four children). Both compilations evaluate the same
    /// operations in the same order, without fused multiply-adds, so their answers are
    /// identical.
    ///
    /// `origin`, where every ray leaves it, lets a leaf compute the triangle's origin-only
    /// terms once for the packet ([`Triangle::seen_from`]).
    pub(super) fn blocked_in_packets(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        origin: Option<Vec3A>,
        occluded: &mut [bool],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { self.blocked_in_packets_avx2(rays, origin, occluded) };
        }
        self.blocked_in_packets_baseline(rays, origin, occluded)
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
        origin: Option<Vec3A>,
        occluded: &mut [bool],
    ) {
        self.packets::<true>(rays, origin, occluded)
    }

    /// [`ObvhsTracer::blocked_in_packets`] compiled for the build's baseline (SSE) whatever
    /// the CPU: the portable path, which the tests compare with the AVX2 one.
    pub(super) fn blocked_in_packets_baseline(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        origin: Option<Vec3A>,
        occluded: &mut [bool],
    ) {
        self.packets::<false>(rays, origin, occluded)
    }

    #[inline(always)]
    fn packets<const AVX: bool>(
        &self,
        rays: impl ExactSizeIterator<Item = BoxRay>,
        origin: Option<Vec3A>,
        occluded: &mut [bool],
    ) {
        assert_eq!(rays.len(), occluded.len());
        let mut rays = rays;
        // Each visited node pushes at most 8 entries; reused by all packets of the batch.
        let mut stack = Vec::with_capacity(256);
        for occluded in occluded.chunks_mut(PACKET) {
            let mut packet = [BoxRay::new(Vec3A::ZERO, Vec3A::Z, 0.0); PACKET];
            for (p, r) in packet.iter_mut().zip(&mut rays) {
                *p = r;
            }
            let blocked = self.blocked_packet::<AVX>(&packet[..occluded.len()], origin, &mut stack);
            for (i, o) in occluded.iter_mut().enumerate() {
                *o = blocked & (1 << i) != 0;
            }
        }
    }
}

/// The rays of `open` that enter each child: eight rays per AVX test with `AVX`, else each
/// ray against the node's boxes and the answers transposed ([`by_child`]).
#[inline(always)]
fn children_entered<const AVX: bool>(
    boxes: &ChildBoxes,
    lanes: &[RayLanes; PACKET / 8],
    rays: &[BoxRay],
    open: u32,
) -> [u32; 8] {
    if AVX {
        children_entered_avx(boxes, lanes, open)
    } else {
        let mut entered = [0u8; PACKET];
        for i in bits(open) {
            entered[i] = boxes.entered_by(&rays[i]) as u8;
        }
        by_child(&entered)
    }
}

/// The rays of `open` that enter each child, eight rays per AVX test
/// ([`ChildBoxes::lanes_enter_avx`]). Only called where `AVX` is true, in code compiled for
/// AVX2 after the CPU's support was checked.
#[inline(always)]
fn children_entered_avx(boxes: &ChildBoxes, lanes: &[RayLanes; PACKET / 8], open: u32) -> [u32; 8] {
    let mut children = [0u32; 8];
    #[cfg(target_arch = "x86_64")]
    for (h, lanes) in lanes.iter().enumerate() {
        if open >> (8 * h) & 0xff != 0 {
            // SAFETY: see above.
            let entered = unsafe { boxes.lanes_enter_avx(lanes) };
            for (children, entered) in children.iter_mut().zip(entered) {
                *children |= entered << (8 * h);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (boxes, lanes);
    children.map(|c| c & open)
}

/// Transposes the packet's box answers: from bit c of `entered[i]` (ray i entered child c)
/// to bit i of the result's `[c]`.
#[inline(always)]
fn by_child(entered: &[u8; PACKET]) -> [u32; 8] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86_64; the load reads the array's 16 bytes.
        unsafe {
            let v = _mm_loadu_si128(entered.as_ptr().cast());
            // Shifting the 64-bit lanes left by 7 − c moves bit c of every byte to the byte's
            // top bit (a lower byte's bits land below it), which movemask collects.
            macro_rules! column {
                ($s:literal) => {
                    _mm_movemask_epi8(_mm_slli_epi64::<$s>(v)) as u32
                };
            }
            [
                column!(7),
                column!(6),
                column!(5),
                column!(4),
                column!(3),
                column!(2),
                column!(1),
                column!(0),
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut children = [0u32; 8];
        for (i, &e) in entered.iter().enumerate() {
            for c in bits(u32::from(e)) {
                children[c] |= 1 << i;
            }
        }
        children
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn by_child_transposes() {
        let mut entered = [0u8; PACKET];
        let mut expected = [0u32; 8];
        let mut x = 0x9e37_79b9u32;
        for (i, e) in entered.iter_mut().enumerate() {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *e = (x >> 24) as u8;
            for (c, children) in expected.iter_mut().enumerate() {
                *children |= u32::from(*e >> c & 1) << i;
            }
        }
        assert_eq!(by_child(&entered), expected);
    }
}

//! A triangle's overlap with a texel's square footprint in the atlas: the clip that
//! rasterisation ([`super::texels`]) measures coverage with, and the edge tests that decide most
//! squares without it.

use glam::Vec2;

/// Where a texel's square lies against a triangle in the atlas ([`Edges::cover`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Cover {
    /// Wholly outside: clipping gives no polygon, so no area.
    Outside,
    /// Wholly inside: clipping gives the square's four corners exactly, so area 1.
    Inside,
    /// Neither for certain: clip it.
    Straddles,
}

/// A triangle's edges in the atlas, to decide most texels of its bounding box without
/// clipping (most of rasterising a mesh of small triangles): a square whose corners all lie
/// beyond [`Edges::margin`] outside one edge, or inside all three, gets the area the clip
/// would give, exactly. The margin is 64 ulps of the largest coordinate and at least 1/64
/// texel, far above the clip's rounding (a few ulps per intersection), so the clip's
/// inside/outside decisions are those of exact arithmetic there; and an inside square's area
/// is exactly 1 in f32 only while its corners' products are exact, hence [`EXACT_AREA`].
pub(super) struct Edges {
    /// Per edge (unit normal pointing inside, offset): inside where n · q + c > 0. Empty
    /// (everything straddles) for a sliver whose orientation rounding could flip.
    lines: Vec<(glam::DVec2, f64)>,
    margin: f64,
}

/// Texel coordinates up to which an inside square's clipped area is exactly 1.0: the
/// shoelace sum's products and partial sums are integers below 2²⁴.
const EXACT_AREA: usize = 2048;

impl Edges {
    pub(super) fn new(uv: [Vec2; 3]) -> Edges {
        let uv = uv.map(|c| c.as_dvec2());
        let twice = (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]);
        let largest = uv.iter().map(|c| c.abs().max_element()).fold(0.0, f64::max);
        let margin = (1.0 / 64.0f64).max(largest * 2f64.powi(-17));
        if !twice.is_finite() || twice.abs() < 1e-3 {
            return Edges {
                lines: Vec::new(),
                margin,
            };
        }
        let lines = (0..3)
            .map(|k| {
                let (a, b) = (uv[k], uv[(k + 1) % 3]);
                let n = (b - a).perp() * twice.signum() / (b - a).length();
                (n, -n.dot(a))
            })
            .collect();
        Edges { lines, margin }
    }

    /// Where the square of texel (x, y) lies.
    pub(super) fn cover(&self, x: usize, y: usize) -> Cover {
        if self.lines.is_empty() {
            return Cover::Straddles;
        }
        let centre = glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        let mut inside = x < EXACT_AREA && y < EXACT_AREA;
        for &(n, c) in &self.lines {
            let (d, half) = (n.dot(centre) + c, 0.5 * (n.x.abs() + n.y.abs()));
            if d + half < -self.margin {
                return Cover::Outside;
            }
            inside &= d - half > self.margin;
        }
        if inside {
            Cover::Inside
        } else {
            Cover::Straddles
        }
    }
}

/// A convex polygon of at most 8 corners: a triangle clipped by four half-planes has at most
/// 7. Held inline: one texel's clip allocated five vectors, most of rasterising a large mesh.
pub(super) struct Polygon {
    points: [Vec2; 8],
    len: usize,
}

impl Polygon {
    fn push(&mut self, p: Vec2) {
        self.points[self.len] = p;
        self.len += 1;
    }
}

impl std::ops::Deref for Polygon {
    type Target = [Vec2];
    fn deref(&self) -> &[Vec2] {
        &self.points[..self.len]
    }
}

/// The triangle clipped to the unit square at `corner` (Sutherland–Hodgman), one half-plane
/// at a time ([`clip_half`]).
pub(super) fn clip_to_square(uv: [Vec2; 3], corner: Vec2) -> Polygon {
    let mut poly = Polygon {
        points: [Vec2::ZERO; 8],
        len: 3,
    };
    poly.points[..3].copy_from_slice(&uv);
    poly = clip_half::<0, false>(&poly, corner.x);
    if !poly.is_empty() {
        poly = clip_half::<0, true>(&poly, corner.x + 1.0);
    }
    if !poly.is_empty() {
        poly = clip_half::<1, false>(&poly, corner.y);
    }
    if !poly.is_empty() {
        poly = clip_half::<1, true>(&poly, corner.y + 1.0);
    }
    poly
}

/// `poly` clipped to the half-plane where coordinate `AXIS` is at most (`BELOW`) or at least
/// `bound`: its edges (corner k to k + 1, the last back to the first) in order, each adding
/// its end if inside and its crossing if it crosses. The axis and side are constants, so the
/// test inlines (the clip is most of rasterising a mesh of small triangles).
#[inline(always)]
fn clip_half<const AXIS: usize, const BELOW: bool>(poly: &Polygon, bound: f32) -> Polygon {
    let inside = |p: Vec2| {
        if BELOW {
            p[AXIS] <= bound
        } else {
            p[AXIS] >= bound
        }
    };
    let mut out = Polygon {
        points: [Vec2::ZERO; 8],
        len: 0,
    };
    let n = poly.len;
    let (mut a, mut a_inside) = (poly.points[0], inside(poly.points[0]));
    for k in 0..n {
        let b = poly.points[if k + 1 == n { 0 } else { k + 1 }];
        let b_inside = inside(b);
        match (a_inside, b_inside) {
            (true, true) => out.push(b),
            (true, false) => out.push(intersect(a, b, AXIS, bound)),
            (false, true) => {
                out.push(intersect(a, b, AXIS, bound));
                out.push(b);
            }
            (false, false) => {}
        }
        (a, a_inside) = (b, b_inside);
    }
    out
}

fn intersect(a: Vec2, b: Vec2, axis: usize, bound: f32) -> Vec2 {
    let t = (bound - a[axis]) / (b[axis] - a[axis]);
    let mut p = a + (b - a) * t;
    p[axis] = bound;
    p
}

/// Unsigned area of a simple polygon.
pub(super) fn polygon_area(poly: &[Vec2]) -> f32 {
    let mut twice = 0.0;
    for k in 0..poly.len() {
        twice += cross(poly[k], poly[(k + 1) % poly.len()]);
    }
    (twice * 0.5).abs()
}

/// Centroid of a convex polygon (its vertex mean is inside it too, which is all we need).
pub(super) fn polygon_centroid(poly: &[Vec2]) -> Vec2 {
    poly.iter().copied().sum::<Vec2>() / poly.len() as f32
}

/// The texels a triangle's bounding box spans in a `w` × `h` lightmap: x0..x1, y0..y1; `None`
/// where it is not in the atlas or degenerate there.
pub(super) fn texel_bounds(
    uv: [Vec2; 3],
    w: usize,
    h: usize,
) -> Option<(usize, usize, usize, usize)> {
    let uv_area = cross(uv[1] - uv[0], uv[2] - uv[0]);
    if !uv_area.is_finite() || uv_area == 0.0 {
        return None;
    }
    let lo = uv[0].min(uv[1]).min(uv[2]).floor().max(Vec2::ZERO);
    let hi = uv[0].max(uv[1]).max(uv[2]).ceil();
    let (x1, y1) = ((hi.x as usize).min(w), (hi.y as usize).min(h));
    Some((lo.x as usize, x1, lo.y as usize, y1))
}

pub(super) fn cross(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clip as it was written before [`clip_half`]: what it must equal, bit for bit.
    fn clip_to_square_before(uv: [Vec2; 3], corner: Vec2) -> Vec<Vec2> {
        let mut poly: Vec<Vec2> = uv.to_vec();
        let planes = [
            (0, corner.x, false),
            (0, corner.x + 1.0, true),
            (1, corner.y, false),
            (1, corner.y + 1.0, true),
        ];
        for (axis, bound, below) in planes {
            if poly.is_empty() {
                break;
            }
            let inside = |p: Vec2| {
                if below {
                    p[axis] <= bound
                } else {
                    p[axis] >= bound
                }
            };
            let mut out = Vec::new();
            for k in 0..poly.len() {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                match (inside(a), inside(b)) {
                    (true, true) => out.push(b),
                    (true, false) => out.push(intersect(a, b, axis, bound)),
                    (false, true) => {
                        out.push(intersect(a, b, axis, bound));
                        out.push(b);
                    }
                    (false, false) => {}
                }
            }
            poly = out;
        }
        poly
    }

    #[test]
    fn the_clip_gives_the_same_polygon_as_before_bit_for_bit() {
        let mut rng = crate::math::sampling::Pcg32::new(5, 9);
        let mut clipped = 0;
        for k in 0..20_000 {
            let size = [0.5f32, 3.0, 30.0][k % 3];
            let at = Vec2::new(rng.next_f32(), rng.next_f32()) * 60.0;
            let uv = [(); 3].map(|_| at + Vec2::new(rng.next_f32(), rng.next_f32()) * size);
            let square = (at + Vec2::splat(size * 0.5)).floor();
            let now = clip_to_square(uv, square);
            let before = clip_to_square_before(uv, square);
            let bits = |p: &[Vec2]| {
                p.iter()
                    .map(|v| v.to_array().map(f32::to_bits))
                    .collect::<Vec<_>>()
            };
            assert_eq!(bits(&now), bits(&before), "{uv:?} at {square}");
            clipped += usize::from(before.len() > 3);
        }
        assert!(clipped > 1000, "{clipped} clips cut corners");
    }

    #[test]
    fn a_triangle_covering_a_square_exactly_half_has_half_the_area() {
        let uv = [Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        assert!((polygon_area(&clip_to_square(uv, Vec2::ZERO)) - 0.5).abs() < 1e-6);
        assert_eq!(polygon_area(&clip_to_square(uv, Vec2::new(1.0, 0.0))), 0.0);
        let big = [
            Vec2::splat(-5.0),
            Vec2::new(10.0, -5.0),
            Vec2::new(-5.0, 10.0),
        ];
        assert!((polygon_area(&clip_to_square(big, Vec2::new(1.0, 1.0))) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn squares_decided_without_clipping_get_the_clips_area() {
        // Triangles of many sizes and shapes, anywhere in a 2048² atlas and beyond it; every
        // texel of their boxes decided without the clip must get the clip's area exactly.
        let mut rng = crate::math::sampling::Pcg32::new(11, 3);
        let (mut decided, mut straddling) = (0, 0);
        for k in 0..3000 {
            let size = [0.3f32, 2.0, 7.0, 40.0][k % 4];
            let at = Vec2::new(rng.next_f32(), rng.next_f32()) * 2100.0 - Vec2::splat(20.0);
            let uv = [(); 3].map(|_| at + Vec2::new(rng.next_f32(), rng.next_f32()) * size);
            let Some((x0, x1, y0, y1)) = texel_bounds(uv, 2048, 2048) else {
                continue;
            };
            let edges = Edges::new(uv);
            for y in y0..y1 {
                for x in x0..x1 {
                    let area = polygon_area(&clip_to_square(uv, Vec2::new(x as f32, y as f32)));
                    match edges.cover(x, y) {
                        Cover::Outside => assert_eq!(area, 0.0, "{uv:?} ({x}, {y})"),
                        Cover::Inside => assert_eq!(area, 1.0, "{uv:?} ({x}, {y})"),
                        Cover::Straddles => straddling += 1,
                    }
                    decided += usize::from(edges.cover(x, y) != Cover::Straddles);
                }
            }
        }
        assert!(
            decided > 2 * straddling,
            "{decided} decided, {straddling} clipped"
        );
    }
}

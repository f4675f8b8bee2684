//! Leak detection: texels whose point lies inside or behind other geometry, moved out where
//! they can be, left out where not.
//!
//! Where a triangle passes under a wall or into a box, the texels there sample the inside of
//! the other object and would show its darkness (or, with light bleeding, its light) beyond
//! the seam. As Bakery and Godot do, a texel whose rays hit **back faces** in more than
//! [`LEAK_FRACTION`] of [`LEAK_RAYS`] directions is taken to be inside. This needs
//! consistently wound geometry: a single-sided wall seen from behind looks like the inside of
//! something.
//!
//! A leaking texel whose footprint straddles the wall (part of the texel lies outside) is
//! **moved out** first: [`SLIDE_RAYS`] rays from its origin along its triangle's plane find
//! the nearest back face, within a texel's width; the point slides just past it
//! ([`slide_margin`]), staying on its triangle's plane. The move is kept only if the new point
//! still lies in the texel's own triangle and in its square footprint in the atlas (so it is
//! still a point of this texel's surface), and if the leak test passes there. Texels that
//! cannot be moved (wholly inside a box or sphere) are left out and dilation fills them from
//! their neighbours. Unlike Godot, which pushes the point to the hit point off the surface,
//! the point never leaves the surface the texel stands for.
//!
//! **Which texels get the test** (the full test everywhere cost half the bake stage's time on a
//! 720,000-triangle heightfield, where nothing leaks). The full test ([`leaks_at`]:
//! [`SCREEN_RAYS`] unbounded closest-hit rays, then [`LEAK_RAYS`] where one finds a back
//! face) runs only on texels that may leak, found three ways:
//! * **near rays**: [`NEAR_RAYS`] closest-hit rays per texel (the full test's first
//!   directions) no longer than [`REACH`] texel widths; one meeting a back face sends the
//!   texel to the full test. A texel's value is seen through bilinear filtering within a
//!   texel of it, so what makes a *visible* texel wrong is a wall within a texel or two:
//!   where a surface passes under a wall, the texels at the wall's foot (centres within a
//!   texel of it) see its back within two texels in a quarter to a half of their
//!   directions. Short rays cost a fraction of unbounded ones (they stop near the surface
//!   instead of crossing the scene), and four per texel are enough because a leaking
//!   region is found from any one of its texels;
//! * **flood**: the 8 neighbours in the atlas of every texel found leaking get the full
//!   test too, and theirs in turn, so a region that leaks is found out to its edge however
//!   far inside the box it reaches (the floor under a crate: its middle sees the crate's
//!   back faces only far away, but is joined to the wall's foot by leaking texels);
//! * **lattice**: every [`LATTICE`]-th texel along each axis gets the full test whatever
//!   its near rays found, so a larger region that no wall comes near (a chart wholly inside
//!   a solid) is found too.
//!
//! A tested texel gets the same answer as before (its own stream, the same rays). What is
//! no longer found: texels that see back faces only farther than [`REACH`] texels away,
//! joined to no leaking texel and off the lattice. These are not texels under a wall but
//! texels looking across open space at the back of a one-sided surface, which the full test
//! calls leaking by chance where about a tenth of their directions meet it (a speckle of
//! left-out texels); they are now baked for what they see. docs/guides/lightmaps.md has the
//! figures.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::atlas::Atlas;
use super::texels::Texels;
use crate::math::sampling::{Frame, Pcg32, cosine_hemisphere, vertex_seed};
use crate::scene::Scene;
use crate::support::error::Result;
use crate::trace::{Hit, Tracer, offset_distance};

/// Closest-hit rays per texel for the test (cosine-weighted over its hemisphere).
pub const LEAK_RAYS: usize = 64;
/// A texel is inside something when more than this fraction of its rays hit back faces.
pub const LEAK_FRACTION: f32 = 0.1;
/// The first rays of the test, traced alone: a texel none of whose first 16 rays hits a back
/// face is taken not to leak without the other 48 (most texels: the test then costs a
/// quarter). A texel inside something sees back faces in most directions; one whose rays
/// see them with probability f passes this screen with probability (1 − f)¹⁶: 19 % at the
/// threshold f = 0.1, 3 % at f = 0.2, 0.3 % at f = 0.3.
pub const SCREEN_RAYS: usize = 16;
/// Short rays per texel that look for a back face near it (module doc).
pub const NEAR_RAYS: usize = 4;
/// How far they reach, in texel widths.
pub const REACH: f32 = 2.0;
/// Every `LATTICE`-th texel along each axis of the atlas gets the full test whatever the near
/// rays find (module doc).
pub const LATTICE: usize = 8;
/// Rays along the surface, evenly spread around the normal, that look for the way out.
pub const SLIDE_RAYS: usize = 16;

/// What [`settle`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Settled {
    /// Leaking texels moved out to a point of their footprint that does not leak.
    pub moved: usize,
    /// Leaking texels that could not be moved: cleared from `valid`.
    pub leaking: usize,
}

/// Tests every valid texel for leaks; moves the leaking ones out where it can (their
/// `positions` and `origins` change) and clears `valid` for the rest. `tracer` should be
/// watertight for the texels' origins ([`Texels::watertight`]). Deterministic from `seed`.
pub fn settle(
    scene: &Scene,
    atlas: &Atlas,
    texels: &mut Texels,
    tracer: &dyn Tracer,
    seed: u64,
) -> Result<Settled> {
    let found = find_leaks(scene, atlas, texels, tracer, seed);
    let leaking: Vec<usize> = (0..found.len()).filter(|&i| found[i]).collect();
    if leaking.is_empty() {
        // Nothing to move (and no seam index to build for the moved points: 0.3 s at 720,000
        // triangles).
        return Ok(Settled::default());
    }
    let around = triangles_around_vertices(scene);
    // Where each leaking texel could go: (position, origin).
    let candidates: Vec<Option<(Vec3, Vec3)>> = leaking
        .par_iter()
        .map(|&i| slide_out(scene, &around, atlas, texels, tracer, i))
        .collect();
    // The candidates' own seam points, so their re-test is watertight too.
    let (origins, own): (Vec<Vec3>, Vec<u32>) = leaking
        .iter()
        .zip(&candidates)
        .filter_map(|(&i, c)| c.map(|(_, o)| (o, texels.triangle[i])))
        .unzip();
    let view = tracer.for_points(scene, &origins, &own)?;
    let retest = view.as_deref().unwrap_or(tracer);
    let outcome: Vec<bool> = leaking
        .par_iter()
        .zip(&candidates)
        .map(|(&i, c)| {
            c.is_some_and(|(_, origin)| {
                let mut rng = Pcg32::new(vertex_seed(seed, i as u64), 0x0017);
                !leaks_at(origin, texels.normals[i], retest, &mut rng)
            })
        })
        .collect();
    let mut settled = Settled::default();
    for ((&i, c), moved) in leaking.iter().zip(&candidates).zip(outcome) {
        match (c, moved) {
            (Some((position, origin)), true) => {
                texels.positions[i] = *position;
                texels.origins[i] = *origin;
                settled.moved += 1;
            }
            _ => {
                texels.valid[i] = false;
                settled.leaking += 1;
            }
        }
    }
    Ok(settled)
}

/// Per texel, whether it leaks (only valid texels are tested). Deterministic from `seed`:
/// which texels get the full test depends only on the answers of texels, each from its own
/// stream, never on the order they were tested in.
pub fn find_leaks(
    scene: &Scene,
    atlas: &Atlas,
    texels: &Texels,
    tracer: &dyn Tracer,
    seed: u64,
) -> Vec<bool> {
    // Its own stream, apart from the transfer's samples; the screen's directions are the
    // full test's first ones.
    let stream = |i: usize| Pcg32::new(vertex_seed(seed, i as u64), 0x1eaf);
    let reach: Vec<f32> = (0..scene.triangles.len())
        .into_par_iter()
        .map(|t| REACH * texel_size(scene, atlas, t))
        .collect();
    let w = texels.width as usize;
    let mut tested: Vec<bool> = (0..texels.valid.len())
        .into_par_iter()
        .map(|i| {
            texels.valid[i]
                && ((i % w) % LATTICE == 0 && (i / w) % LATTICE == 0 || {
                    let reach = reach[texels.triangle[i] as usize];
                    back_face_near(
                        texels.origins[i],
                        texels.normals[i],
                        reach,
                        tracer,
                        stream(i),
                    )
                })
        })
        .collect();
    let mut leaks = vec![false; texels.valid.len()];
    let mut batch: Vec<usize> = (0..tested.len()).filter(|&i| tested[i]).collect();
    while !batch.is_empty() {
        let found: Vec<bool> = batch
            .par_iter()
            .map(|&i| leaks_at(texels.origins[i], texels.normals[i], tracer, &mut stream(i)))
            .collect();
        let mut next = Vec::new();
        for (&i, leaking) in batch.iter().zip(found) {
            leaks[i] = leaking;
            if leaking {
                for j in neighbours(texels, i) {
                    if texels.valid[j] && !tested[j] {
                        tested[j] = true;
                        next.push(j);
                    }
                }
            }
        }
        batch = next;
    }
    leaks
}

/// Whether any of the first [`NEAR_RAYS`] directions of the full test (drawn from `rng` as
/// [`leaks_at`] draws them) meets a back face within `reach` of `origin`.
fn back_face_near(
    origin: Vec3,
    normal: Vec3,
    reach: f32,
    tracer: &dyn Tracer,
    mut rng: Pcg32,
) -> bool {
    let frame = Frame::from_normal(normal);
    let mut dirs = [Vec3::ZERO; NEAR_RAYS];
    for d in dirs.iter_mut() {
        *d = frame.to_world(cosine_hemisphere(rng.next_f32(), rng.next_f32()));
    }
    let mut hits: [Option<Hit>; NEAR_RAYS] = [None; NEAR_RAYS];
    tracer.intersect_within(origin, &dirs, reach, &mut hits);
    hits.iter()
        .zip(&dirs)
        .any(|(hit, dir)| hit.as_ref().is_some_and(|h| h.ng.dot(*dir) > 0.0))
}

/// The texels around texel `i` in the atlas (its 8 neighbours, fewer at the edges).
fn neighbours(texels: &Texels, i: usize) -> impl Iterator<Item = usize> {
    let (w, h) = (texels.width as usize, texels.height as usize);
    let (x, y) = (i % w, i / w);
    (y.saturating_sub(1)..(y + 2).min(h)).flat_map(move |v| {
        (x.saturating_sub(1)..(x + 2).min(w))
            .map(move |u| v * w + u)
            .filter(move |&j| j != i)
    })
}

/// The world-space width of a texel on triangle `t` (the square root of the area a texel
/// covers there); infinite where the triangle has no area in the atlas, so that a screen
/// ray there is unbounded.
fn texel_size(scene: &Scene, atlas: &Atlas, t: usize) -> f32 {
    let p = scene.triangles[t].map(|v| scene.positions[v as usize]);
    let size = Vec2::new(atlas.width as f32, atlas.height as f32);
    let uv = atlas.uv1[t].map(|c| c * size);
    let area = (p[1] - p[0]).cross(p[2] - p[0]).length() * 0.5;
    let uv_area = ((uv[1] - uv[0]).perp_dot(uv[2] - uv[0]) * 0.5).abs();
    let s = (area / uv_area).sqrt();
    if s.is_finite() { s } else { f32::INFINITY }
}

/// Whether more than [`LEAK_FRACTION`] of [`LEAK_RAYS`] cosine-distributed rays from `origin`
/// around `normal` hit back faces. The directions are drawn in order from `rng`, the last
/// [`LEAK_RAYS`] − [`SCREEN_RAYS`] only when the screen finds a back face (most texels stop
/// there, and drawing a direction costs a sine and a cosine).
pub(crate) fn leaks_at(origin: Vec3, normal: Vec3, tracer: &dyn Tracer, rng: &mut Pcg32) -> bool {
    let frame = Frame::from_normal(normal);
    let mut dirs = [Vec3::ZERO; LEAK_RAYS];
    let mut hits: [Option<Hit>; LEAK_RAYS] = [None; LEAK_RAYS];
    let mut back = 0;
    for range in [0..SCREEN_RAYS, SCREEN_RAYS..LEAK_RAYS] {
        let (dirs, hits) = (&mut dirs[range.clone()], &mut hits[range]);
        for d in dirs.iter_mut() {
            *d = frame.to_world(cosine_hemisphere(rng.next_f32(), rng.next_f32()));
        }
        tracer.intersect_from(origin, dirs, hits);
        back += hits
            .iter()
            .zip(dirs.iter())
            .filter(|(hit, dir)| hit.as_ref().is_some_and(|h| h.ng.dot(**dir) > 0.0))
            .count();
        if back == 0 {
            return false;
        }
    }
    back as f32 > LEAK_FRACTION * LEAK_RAYS as f32
}

/// How far past the back face a moved point goes: 1/256 of a texel, and at least 64 times
/// the ray offset δ, so the new origin is clearly on the wall's outer side (the hit distance
/// is accurate to a few ulps) yet still at the wall's foot.
fn slide_margin(texel_size: f32, delta: f32) -> f32 {
    (texel_size / 256.0).max(64.0 * delta)
}

/// Where leaking texel `i` could move: the point and origin just past the nearest back face
/// along its triangle's plane, if that lies within a texel's width, in its triangle and in
/// its footprint.
fn slide_out(
    scene: &Scene,
    around: &[Vec<u32>],
    atlas: &Atlas,
    texels: &Texels,
    tracer: &dyn Tracer,
    i: usize,
) -> Option<(Vec3, Vec3)> {
    let t = texels.triangle[i] as usize;
    let p = scene.triangles[t].map(|v| scene.positions[v as usize]);
    let size = Vec2::new(atlas.width as f32, atlas.height as f32);
    let uv = atlas.uv1[t].map(|c| c * size);
    let normal = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize()?;
    let texel_size = texel_size(scene, atlas, t);
    if !texel_size.is_finite() {
        return None;
    }
    let longest = p[0]
        .distance(p[1])
        .max(p[1].distance(p[2]))
        .max(p[2].distance(p[0]));
    let (position, origin) = (texels.positions[i], texels.origins[i]);
    let frame = Frame::from_normal(normal);
    let dirs: Vec<Vec3> = (0..SLIDE_RAYS)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / SLIDE_RAYS as f32;
            frame.tangent * a.cos() + frame.bitangent * a.sin()
        })
        .collect();
    // Cast a sixteenth of a texel above the surface, so they meet a wall standing on it well
    // away from the wall's bottom edge (a ray δ above the surface would graze that edge,
    // where backends may answer differently); a wall lower than that is not slid past.
    let mut hits: Vec<Option<Hit>> = vec![None; SLIDE_RAYS];
    tracer.intersect_from(origin + normal * (texel_size / 16.0), &dirs, &mut hits);
    let (dir, distance) = hits
        .iter()
        .zip(&dirs)
        .filter_map(|(hit, &dir)| {
            let h = hit.as_ref()?;
            (h.ng.dot(dir) > 0.0 && h.t <= texel_size).then_some((dir, h.t))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let delta = offset_distance(position, longest);
    let step = dir * (distance + slide_margin(texel_size, delta));
    let moved = position + step;
    // Still this texel's: in its square in the atlas (by its triangle's map) ...
    let b = barycentric(p, moved)?;
    let at = uv[0] * b[0] + uv[1] * b[1] + uv[2] * b[2];
    let square = texel_square(texels, i);
    if !(at.cmpge(square).all() && at.cmple(square + Vec2::ONE).all()) {
        return None;
    }
    // ... and on the surface: in its triangle, or in a triangle that touches it and lies in
    // its plane (the next triangle of a flat floor). Decided from the geometry, not by rays,
    // so every backend decides alike.
    if b.iter().any(|&x| x < 0.0) && !on_a_flat_neighbour(scene, around, t, normal, moved) {
        return None;
    }
    Some((moved, origin + step))
}

/// The triangles that use each vertex.
fn triangles_around_vertices(scene: &Scene) -> Vec<Vec<u32>> {
    let mut around = vec![Vec::new(); scene.vertex_count()];
    for (t, tri) in scene.triangles.iter().enumerate() {
        for &v in tri {
            around[v as usize].push(t as u32);
        }
    }
    around
}

/// Whether `q` lies in a triangle that shares a vertex with triangle `t` and lies in its
/// plane (normals within 0.1°, `q` within rounding of it).
fn on_a_flat_neighbour(
    scene: &Scene,
    around: &[Vec<u32>],
    t: usize,
    normal: Vec3,
    q: Vec3,
) -> bool {
    scene.triangles[t].iter().any(|&v| {
        around[v as usize].iter().any(|&u| {
            let p = scene.triangles[u as usize].map(|w| scene.positions[w as usize]);
            let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
                return false;
            };
            let scale = p[0].distance(p[1]).max(p[0].distance(p[2]));
            n.dot(normal) > 0.999_998
                && (q - p[0]).dot(n).abs() <= 1e-5 * scale
                && barycentric(p, q).is_some_and(|b| b.iter().all(|&x| x >= 0.0))
        })
    })
}

/// The lower corner of texel `i`'s square, in texel units.
fn texel_square(texels: &Texels, i: usize) -> Vec2 {
    let w = texels.width as usize;
    Vec2::new((i % w) as f32, (i / w) as f32)
}

/// The barycentric coordinates of `q` (a point of the triangle's plane) in the triangle `p`,
/// negative outside it (`None` for a degenerate triangle).
fn barycentric(p: [Vec3; 3], q: Vec3) -> Option<[f32; 3]> {
    let (e1, e2, d) = (p[1] - p[0], p[2] - p[0], q - p[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det <= 0.0 {
        return None;
    }
    let b1 = (d22 * d1 - d12 * d2) / det;
    let b2 = (d11 * d2 - d12 * d1) / det;
    Some([1.0 - b1 - b2, b1, b2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_are_the_eight_around_within_the_atlas() {
        let texels = Texels::mask(4, 3, vec![true; 12]);
        let around = |i| neighbours(&texels, i).collect::<Vec<_>>();
        assert_eq!(around(5), [0, 1, 2, 4, 6, 8, 9, 10]);
        assert_eq!(around(0), [1, 4, 5]);
        assert_eq!(around(11), [6, 7, 10]);
        assert_eq!(around(3), [2, 6, 7]);
    }

    #[test]
    fn barycentric_coordinates_locate_points_of_the_plane() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = barycentric(p, Vec3::new(0.25, 0.5, 0.0)).expect("inside");
        assert!((b[0] - 0.25).abs() < 1e-6 && (b[1] - 0.25).abs() < 1e-6);
        let b = barycentric(p, Vec3::new(0.75, 0.5, 0.0)).expect("outside");
        assert!(b[0] < 0.0 && (b[1] - 0.75).abs() < 1e-6);
    }
}

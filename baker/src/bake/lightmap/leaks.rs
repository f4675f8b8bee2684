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
    let found = find_leaks(texels, tracer, seed);
    let leaking: Vec<usize> = (0..found.len()).filter(|&i| found[i]).collect();
    let around = match leaking.is_empty() {
        true => Vec::new(),
        false => triangles_around_vertices(scene),
    };
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

/// Per texel, whether it leaks (only valid texels are tested). Deterministic from `seed`.
pub fn find_leaks(texels: &Texels, tracer: &dyn Tracer, seed: u64) -> Vec<bool> {
    (0..texels.valid.len())
        .into_par_iter()
        .map(|i| {
            if !texels.valid[i] {
                return false;
            }
            // Its own stream, apart from the transfer's samples.
            let mut rng = Pcg32::new(vertex_seed(seed, i as u64), 0x1eaf);
            leaks_at(texels.origins[i], texels.normals[i], tracer, &mut rng)
        })
        .collect()
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
    let face = (p[1] - p[0]).cross(p[2] - p[0]);
    let normal = face.try_normalize()?;
    let uv_area = ((uv[1] - uv[0]).perp_dot(uv[2] - uv[0]) * 0.5).abs();
    let texel_size = (face.length() * 0.5 / uv_area).sqrt();
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
    fn barycentric_coordinates_locate_points_of_the_plane() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = barycentric(p, Vec3::new(0.25, 0.5, 0.0)).expect("inside");
        assert!((b[0] - 0.25).abs() < 1e-6 && (b[1] - 0.25).abs() < 1e-6);
        let b = barycentric(p, Vec3::new(0.75, 0.5, 0.0)).expect("outside");
        assert!(b[0] < 0.0 && (b[1] - 0.75).abs() < 1e-6);
    }
}

//! Seam stitching: where one edge in space is two edges in the atlas (a chart seam), a GPU's
//! bilinear filter reads the lightmap from two different sets of texels on the two sides, and
//! they disagree: a visible step along the seam (issue 23 measured stepped patches along
//! Suzanne's seams at 256²).
//!
//! The fix is a least-squares problem over the texels those samples read (after Liu,
//! Ferguson, Jacobson & Gingold 2017, "Seamless: seam erasure and seam-aware decoupling of
//! shape from mesh resolution", and the seam stitching of game lightmappers): points along
//! every seam, each read bilinearly on both sides, should agree, and the texels should stay
//! close to what was baked,
//!
//! ```text
//!     minimise  Σ_s (Σ_a w_sa x_a − Σ_b w_sb x_b)²  +  λ Σ_i (x_i − x̂_i)²
//! ```
//!
//! with x̂ the baked (and dilated) values. Its normal equations (λI + CᵀC) x = λ x̂ are
//! symmetric positive definite and sparse; conjugate gradients solve them, one right-hand
//! side per coefficient, with the same matrix (it depends only on the atlas). Texels no seam
//! sample reads keep their values. Only *smooth* seams are stitched: where the two sides'
//! shading normals differ at the edge's ends (a crease) the transfer differs on purpose.
//! Everything runs in a fixed order, so the result is deterministic. Written here because the
//! problem is small and specific (a few thousand texels, 8 taps a sample): no crate needed.

use std::collections::HashMap;

use glam::Vec2;

use super::atlas::Atlas;
use super::texels::bilinear_taps;
use crate::scene::Scene;

/// Weight of keeping a texel's baked value against making the seams agree: small, so the
/// seams agree to a few per cent of their step, while texels move only as far as they must.
const KEEP: f64 = 0.02;
/// Shading normals at a seam's ends closer than this (cosine) make it smooth.
const SMOOTH: f32 = 0.999;
/// Seam samples per texel of edge length (on the longer side).
const SAMPLES_PER_TEXEL: f32 = 2.0;
/// Conjugate-gradient iterations at most, and the residual (relative) that stops them.
const MAX_ITERATIONS: usize = 200;
const TOLERANCE: f64 = 1e-7;

/// A point of a seam, read on both sides: up to 4 (texel, weight) taps each, weights summing
/// to 1 over the filled texels.
#[derive(Clone, Debug)]
pub struct SeamSample {
    pub a: Vec<(u32, f32)>,
    pub b: Vec<(u32, f32)>,
}

/// An edge by its ends' position bits, lower end first.
type EdgeKey = ([u32; 3], [u32; 3]);

/// No partner: the edge is not a smooth seam.
pub const NO_PARTNER: u32 = u32::MAX;

/// Per triangle and edge k (corners k → k + 1), the edge of another triangle it is in space
/// when the two are apart in the atlas and the surface is smooth across them (a seam to
/// stitch): `(partner_triangle · 3 + partner_edge) · 2 + reversed`, where `reversed` says the
/// partner's edge runs the other way; [`NO_PARTNER`] otherwise. Edges are matched by their
/// ends' positions (welded); an edge of more than two triangles is left alone. Needs the
/// scene; the samples ([`seam_samples`]) need only this and the atlas, so a merge of shard
/// parts, which has no scene, stitches as the whole bake does.
pub fn seam_partners(scene: &Scene, atlas: &Atlas) -> Vec<[u32; 3]> {
    let mut partners = vec![[NO_PARTNER; 3]; scene.triangles.len()];
    if scene.triangles.len() > (u32::MAX as usize - 1) / 6 {
        return partners; // codes would not fit: no stitching
    }
    let corners: Vec<[Vec2; 3]> = atlas.texel_corners().collect();
    let key = |v: u32| scene.positions[v as usize].to_array().map(f32::to_bits);
    let mut edges: HashMap<EdgeKey, Vec<(usize, usize)>> = HashMap::new();
    let mut order = Vec::new();
    for (t, tri) in scene.triangles.iter().enumerate() {
        if corners[t].iter().any(|c| c.x < 0.0) {
            continue; // not in the atlas
        }
        for k in 0..3 {
            let (p, q) = (key(tri[k]), key(tri[(k + 1) % 3]));
            if p == q {
                continue;
            }
            let id = if p < q { (p, q) } else { (q, p) };
            let uses = edges.entry(id).or_default();
            if uses.is_empty() {
                order.push(id);
            }
            uses.push((t, k));
        }
    }
    for id in order {
        let [(t1, k1), (t2, k2)] = edges[&id][..] else {
            continue; // a boundary, or more than two triangles at the edge
        };
        let (tri1, tri2) = (scene.triangles[t1], scene.triangles[t2]);
        let (a0, a1) = (tri1[k1], tri1[(k1 + 1) % 3]);
        let reversed = key(a0) != key(tri2[k2]);
        let (b0, b1) = if reversed {
            (tri2[(k2 + 1) % 3], tri2[k2])
        } else {
            (tri2[k2], tri2[(k2 + 1) % 3])
        };
        let (ua0, ua1) = (corners[t1][k1], corners[t1][(k1 + 1) % 3]);
        let (ub, ub1) = (corners[t2][k2], corners[t2][(k2 + 1) % 3]);
        let (ub0, ub1) = if reversed { (ub1, ub) } else { (ub, ub1) };
        if ua0.distance(ub0) + ua1.distance(ub1) < 1e-3 {
            continue; // the same edge in the atlas too: no seam
        }
        let normal = |v: u32| scene.normals[v as usize];
        if normal(a0).dot(normal(b0)) < SMOOTH || normal(a1).dot(normal(b1)) < SMOOTH {
            continue; // a crease: the two sides differ on purpose
        }
        let code = |t: usize, k: usize| ((t * 3 + k) * 2 + usize::from(reversed)) as u32;
        partners[t1][k1] = code(t2, k2);
        partners[t2][k2] = code(t1, k1);
    }
    partners
}

/// Points along every seam of `partners` at [`SAMPLES_PER_TEXEL`], read on both sides through
/// the atlas `uv1` (per triangle, in [0, 1]) of a `width` × `height` lightmap; `filled[i]`:
/// whether texel i holds a value (baked or dilated). Samples whose footprint on either side is
/// empty are left out.
pub fn seam_samples(
    partners: &[[u32; 3]],
    uv1: &[[Vec2; 3]],
    width: u32,
    height: u32,
    filled: &[bool],
) -> Vec<SeamSample> {
    let size = Vec2::new(width as f32, height as f32);
    let mut samples = Vec::new();
    for (t, edges) in partners.iter().enumerate() {
        for (k, &code) in edges.iter().enumerate() {
            if code == NO_PARTNER {
                continue;
            }
            let (other, reversed) = ((code / 2) as usize, code % 2 == 1);
            if other < t * 3 + k {
                continue; // each seam once, from its lower edge
            }
            let (t2, k2) = (other / 3, other % 3);
            let (Some(a), Some(b)) = (uv1.get(t), uv1.get(t2)) else {
                continue;
            };
            let (ua0, ua1) = (a[k] * size, a[(k + 1) % 3] * size);
            let (mut ub0, mut ub1) = (b[k2] * size, b[(k2 + 1) % 3] * size);
            if reversed {
                std::mem::swap(&mut ub0, &mut ub1);
            }
            let length = ua0.distance(ua1).max(ub0.distance(ub1));
            if !length.is_finite() {
                continue;
            }
            let count = ((length * SAMPLES_PER_TEXEL).ceil() as usize).clamp(1, 1 << 16);
            for s in 0..count {
                let f = (s as f32 + 0.5) / count as f32;
                let a = taps(ua0.lerp(ua1, f), width, height, filled);
                let b = taps(ub0.lerp(ub1, f), width, height, filled);
                if !a.is_empty() && !b.is_empty() {
                    samples.push(SeamSample { a, b });
                }
            }
        }
    }
    samples
}

/// [`bilinear_taps`] as a list.
fn taps(p: Vec2, width: u32, height: u32, filled: &[bool]) -> Vec<(u32, f32)> {
    let mut out = [(0, 0.0); 4];
    let count = bilinear_taps(p, width, height, filled, &mut out);
    out[..count].to_vec()
}

/// The step across the seams, column `column` of `values` (`width` floats a texel): the
/// root mean square and the largest |side a − side b| over the samples.
pub fn seam_step(
    samples: &[SeamSample],
    values: &[f32],
    width: usize,
    column: usize,
) -> (f64, f64) {
    let read = |taps: &[(u32, f32)]| -> f64 {
        taps.iter()
            .map(|&(i, w)| f64::from(w) * f64::from(values[i as usize * width + column]))
            .sum()
    };
    let (mut sum, mut max) = (0.0, 0.0f64);
    for s in samples {
        let d = read(&s.a) - read(&s.b);
        sum += d * d;
        max = max.max(d.abs());
    }
    ((sum / samples.len().max(1) as f64).sqrt(), max)
}

/// Stitches `values` (`width` floats per texel, W×H texels) along `samples`: every column
/// is solved with the same system.
pub fn stitch(samples: &[SeamSample], values: &mut [f32], width: usize) {
    if samples.is_empty() || width == 0 {
        return;
    }
    // The texels the samples read, in first-read order, as unknowns 0..n.
    let mut index: HashMap<u32, usize> = HashMap::new();
    let mut texels = Vec::new();
    let rows: Vec<Vec<(usize, f64)>> = samples
        .iter()
        .map(|s| {
            let mut row: Vec<(usize, f64)> = Vec::with_capacity(8);
            let sides =
                s.a.iter()
                    .map(|&t| (t, 1.0))
                    .chain(s.b.iter().map(|&t| (t, -1.0)));
            for ((texel, w), sign) in sides {
                let k = *index.entry(texel).or_insert_with(|| {
                    texels.push(texel as usize);
                    texels.len() - 1
                });
                match row.iter_mut().find(|(j, _)| *j == k) {
                    Some(entry) => entry.1 += sign * f64::from(w),
                    None => row.push((k, sign * f64::from(w))),
                }
            }
            row
        })
        .collect();
    let n = texels.len();
    // y = (λI + CᵀC) x
    let apply = |x: &[f64], y: &mut [f64]| {
        for (yi, xi) in y.iter_mut().zip(x) {
            *yi = KEEP * xi;
        }
        for row in &rows {
            let c: f64 = row.iter().map(|&(k, w)| w * x[k]).sum();
            for &(k, w) in row {
                y[k] += w * c;
            }
        }
    };
    for column in 0..width {
        let baked: Vec<f64> = texels
            .iter()
            .map(|&i| f64::from(values[i * width + column]))
            .collect();
        let rhs: Vec<f64> = baked.iter().map(|v| KEEP * v).collect();
        let x = conjugate_gradients(&apply, &rhs, baked, n);
        for (&i, v) in texels.iter().zip(&x) {
            values[i * width + column] = *v as f32;
        }
    }
}

/// Solves A x = b for symmetric positive definite A (given as `apply`), from `x`.
fn conjugate_gradients(
    apply: &dyn Fn(&[f64], &mut [f64]),
    b: &[f64],
    mut x: Vec<f64>,
    n: usize,
) -> Vec<f64> {
    let dot = |u: &[f64], v: &[f64]| -> f64 { u.iter().zip(v).map(|(a, b)| a * b).sum() };
    let mut ax = vec![0.0; n];
    apply(&x, &mut ax);
    let mut r: Vec<f64> = b.iter().zip(&ax).map(|(b, a)| b - a).collect();
    let mut p = r.clone();
    let mut rr = dot(&r, &r);
    let stop = TOLERANCE * TOLERANCE * dot(b, b).max(f64::MIN_POSITIVE);
    let mut ap = vec![0.0; n];
    for _ in 0..MAX_ITERATIONS {
        if rr <= stop {
            break;
        }
        apply(&p, &mut ap);
        let alpha = rr / dot(&p, &ap);
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        let next = dot(&r, &r);
        let beta = next / rr;
        rr = next;
        for i in 0..n {
            p[i] = r[i] + beta * p[i];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_texels_read_across_a_seam_meet_in_the_middle() {
        // One sample reads texel 0 on one side and texel 1 on the other.
        let samples = vec![SeamSample {
            a: vec![(0, 1.0)],
            b: vec![(1, 1.0)],
        }];
        let mut values = vec![1.0f32, 0.0, 5.0];
        stitch(&samples, &mut values, 1);
        // (λ + 1) x0 − x1 = λ·1, −x0 + (λ + 1) x1 = 0: x0 − x1 = λ/(λ + 2).
        let step = f64::from(values[0] - values[1]);
        assert!((step - KEEP / (KEEP + 2.0)).abs() < 1e-5, "step {step}");
        assert!((f64::from(values[0] + values[1]) - 1.0).abs() < 1e-5);
        assert_eq!(values[2], 5.0, "a texel no seam reads is left alone");
        assert!(seam_step(&samples, &values, 1, 0).0 < 0.011);
    }
}

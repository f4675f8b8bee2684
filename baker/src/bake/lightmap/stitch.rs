//! Seam stitching: where one edge in space is two edges in the atlas (a chart seam), a GPU's
//! bilinear filter reads the lightmap from two different sets of texels on the two sides, and
//! they disagree: a visible step along the seam (unstitched bakes showed stepped patches along
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
//! symmetric positive definite and sparse; one sparse Cholesky factorisation of the matrix
//! (it depends only on the atlas) solves them for every coefficient ([`stitch`]). Texels no
//! seam sample reads keep their values. Only *smooth* seams are stitched: where the two sides'
//! shading normals differ at the edge's ends (a crease) the transfer differs on purpose.
//! Everything runs in a fixed order, so the result is deterministic. The seams are found
//! and sampled here; the factorisation is `faer`'s, because a planar atlas of a large mesh
//! links hundreds of thousands of texels into one system, which iterative solvers took most
//! of the bake to solve (docs/guides/lightmaps.md, "Seam stitching at scale").

use glam::Vec2;
use rayon::prelude::*;

use super::atlas::Atlas;
use super::stitch_factor::Factor;
use super::texels::bilinear_taps;
use crate::scene::Scene;

#[cfg(test)]
use super::stitch_factor::KEEP;
/// Shading normals at a seam's ends closer than this (cosine) make it smooth.
const SMOOTH: f32 = 0.999;
/// Seam samples per texel of edge length (on the longer side).
const SAMPLES_PER_TEXEL: f32 = 2.0;

/// A point of a seam, read on both sides: up to 4 (texel, weight) taps each, weights summing
/// to 1 over the filled texels.
#[derive(Clone, Debug)]
pub struct SeamSample {
    pub a: Vec<(u32, f32)>,
    pub b: Vec<(u32, f32)>,
}

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
    // Vertices welded by position bits: equal ids for equal positions, so an edge is a pair
    // of ids and sorts as one u64 (sorting the positions' bits themselves cost most of the
    // stage on a large mesh).
    let welded = weld(scene);
    // Every edge of a triangle in the atlas by its welded ends, sorted (in parallel) so that
    // the uses of one edge lie together; triangle · 3 + edge makes the order total.
    let mut uses: Vec<(u64, u32)> = scene
        .triangles
        .par_iter()
        .enumerate()
        .filter(|(t, _)| !corners[*t].iter().any(|c| c.x < 0.0)) // in the atlas
        .flat_map_iter(|(t, tri)| {
            let welded = &welded;
            (0..3).filter_map(move |k| {
                let (p, q) = (welded[tri[k] as usize], welded[tri[(k + 1) % 3] as usize]);
                let id = (u64::from(p.min(q)) << 32) | u64::from(p.max(q));
                (p != q).then_some((id, (t * 3 + k) as u32))
            })
        })
        .collect();
    uses.par_sort_unstable();
    let pairs: Vec<((usize, usize), (usize, usize))> = uses
        .chunk_by(|a, b| a.0 == b.0)
        .filter_map(|edge| match edge {
            // a boundary, or more than two triangles at the edge, is left alone
            [(_, e1), (_, e2)] => {
                let (e1, e2) = (*e1 as usize, *e2 as usize);
                Some(((e1 / 3, e1 % 3), (e2 / 3, e2 % 3)))
            }
            _ => None,
        })
        .collect();
    drop(uses);
    for ((t1, k1), (t2, k2)) in pairs {
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

/// Per vertex, an id shared by exactly the vertices at the same position (bit for bit):
/// its position's rank among the distinct positions.
fn weld(scene: &Scene) -> Vec<u32> {
    let bits = |v: u32| scene.positions[v as usize].to_array().map(f32::to_bits);
    let mut order: Vec<u32> = (0..scene.positions.len() as u32).collect();
    order.par_sort_unstable_by_key(|&v| (bits(v), v));
    let mut welded = vec![0u32; order.len()];
    let mut id = 0u32;
    for (n, &v) in order.iter().enumerate() {
        if n > 0 && bits(order[n - 1]) != bits(v) {
            id += 1;
        }
        welded[v as usize] = id;
    }
    welded
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
    // Per triangle in parallel, collected in triangle order (the same list for any thread
    // count).
    partners
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, edges)| {
            let mut samples = Vec::new();
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
            samples
        })
        .collect()
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
/// is solved with the same system, factored once.
///
/// The normal equations are solved directly: a sparse Cholesky factorisation L Lᵀ of
/// λI + CᵀC (`faer`'s supernodal factorisation after an approximate-minimum-degree
/// ordering), then two triangular solves over all columns at once ([`Factor::solve`]). A
/// planar atlas of a 720,000-triangle heightfield has 592,060 seam points linking 898,707
/// baked and dilated texels into one system, where Jacobi-preconditioned conjugate gradients
/// needed 125 iterations of two passes over C per column to a relative residual of 10⁻⁴
/// (19 CPU-s); the factorisation and the solves take about 2 CPU-s there, and are exact but
/// for rounding. The ordering and factorisation run sequentially (`Par::Seq`: faer's
/// parallel factorisation is not promised to add in the same order for any thread count),
/// and the solves add in a fixed order, so the result is the same for any thread count. A
/// factorisation that fails (it cannot for finite weights, as λ > 0 makes the matrix
/// positive definite, unless an index would overflow) leaves the values as baked.
///
/// Returns the factor's nonzeros (0: nothing was stitched).
pub fn stitch(samples: &[SeamSample], values: &mut [f32], width: usize) -> usize {
    stitch_fields(samples, &mut [(values, width)])
}

/// [`stitch`] for several fields of the same texels (the coefficients and the
/// accessibility), each `(values, width)`: the system is built and factored once, and
/// solved once for all their columns.
pub fn stitch_fields(samples: &[SeamSample], fields: &mut [(&mut [f32], usize)]) -> usize {
    if samples.is_empty() || fields.iter().all(|(_, width)| *width == 0) {
        return 0;
    }
    stitch_factored(&factor(samples), fields)
}

/// The least squares of `samples`, factored before the values it stitches exist: the system
/// depends only on where the seams read, not on what they read there, so a texel bake
/// factors it beside its rays ([`super::bake_translucent`]), and a sharded one once for all
/// its stitch shards (`prt-bake factor-seams`).
pub struct Factored(Option<Factor>);

impl Factored {
    /// The factor (`None`: nothing to stitch), to store.
    pub fn factor(&self) -> Option<&Factor> {
        self.0.as_ref()
    }

    /// A factor read back (`None`: nothing to stitch).
    pub fn from_factor(factor: Option<Factor>) -> Factored {
        Factored(factor)
    }
}

/// Builds and factors the system of `samples` ([`stitch`]); `None` inside where there is
/// nothing to stitch or the factorisation failed.
pub fn factor(samples: &[SeamSample]) -> Factored {
    if samples.is_empty() {
        return Factored(None);
    }
    Factored(Factor::new(samples.len(), |s| {
        (&samples[s].a, &samples[s].b)
    }))
}

/// [`stitch_fields`] with the system of its samples factored already ([`factor`]): the same
/// bits as factoring it here.
pub fn stitch_factored(factored: &Factored, fields: &mut [(&mut [f32], usize)]) -> usize {
    let Some(system) = &factored.0 else {
        return 0;
    };
    if fields.iter().all(|(_, width)| *width == 0) {
        return 0;
    }
    system.solve(fields);
    system.len()
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

    /// Seam samples over a `side`² lightmap: runs of texels read on both sides of short
    /// seams (bilinear-like taps), deterministic from a fixed LCG.
    fn synthetic(side: u32, count: usize) -> (Vec<SeamSample>, Vec<f32>) {
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as u32
        };
        let texels = side * side;
        let samples = (0..count)
            .map(|_| {
                let side_taps = |base: u32, w: [u32; 2]| -> Vec<(u32, f32)> {
                    let total = (w[0] + w[1]) as f32;
                    vec![
                        (base, w[0] as f32 / total),
                        ((base + 1) % texels, w[1] as f32 / total),
                    ]
                };
                // Seams link texels within a few rows, so components stay local.
                let a = next() % texels;
                let b = (a + side * (1 + next() % 3)) % texels;
                let weights = [
                    1 + next() % 7,
                    1 + next() % 7,
                    1 + next() % 7,
                    1 + next() % 7,
                ];
                SeamSample {
                    a: side_taps(a, [weights[0], weights[1]]),
                    b: side_taps(b, [weights[2], weights[3]]),
                }
            })
            .collect();
        let values = (0..texels * 3)
            .map(|_| (next() % 1000) as f32 / 1000.0)
            .collect();
        (samples, values)
    }

    /// The normal equations of all samples at once, solved densely (Gaussian elimination).
    fn dense_solution(
        samples: &[SeamSample],
        values: &[f32],
        width: usize,
        column: usize,
    ) -> Vec<f64> {
        let n = values.len() / width;
        let mut a = vec![vec![0.0f64; n + 1]; n];
        for (i, row) in a.iter_mut().enumerate() {
            row[i] = KEEP;
            row[n] = KEEP * f64::from(values[i * width + column]);
        }
        for s in samples {
            let mut row = vec![0.0f64; n];
            for &(t, w) in &s.a {
                row[t as usize] += f64::from(w);
            }
            for &(t, w) in &s.b {
                row[t as usize] -= f64::from(w);
            }
            for i in 0..n {
                for j in 0..n {
                    a[i][j] += row[i] * row[j];
                }
            }
        }
        for k in 0..n {
            let (above, below) = a.split_at_mut(k + 1);
            let pivot = &above[k];
            for row in below.iter_mut() {
                let f = row[k] / pivot[k];
                for (x, p) in row[k..].iter_mut().zip(&pivot[k..]) {
                    *x -= f * p;
                }
            }
        }
        let mut x = vec![0.0; n];
        for i in (0..n).rev() {
            let sum: f64 = (i + 1..n).map(|j| a[i][j] * x[j]).sum();
            x[i] = (a[i][n] - sum) / a[i][i];
        }
        x
    }

    #[test]
    fn stitching_solves_the_least_squares_problem() {
        let (samples, mut values) = synthetic(16, 24);
        let baked = values.clone();
        stitch(&samples, &mut values, 3);
        for column in 0..3 {
            let exact = dense_solution(&samples, &baked, 3, column);
            // The direct solution is exact but for rounding: f32's, about 6·10⁻⁸ relative.
            let (mut error, mut norm) = (0.0, 0.0);
            for (i, x) in exact.iter().enumerate() {
                error += (f64::from(values[i * 3 + column]) - x).powi(2);
                norm += f64::from(baked[i * 3 + column]).powi(2);
            }
            let (error, bound) = (error.sqrt(), 1e-6 * norm.sqrt());
            assert!(
                error <= bound,
                "column {column}: error {error:e} over {bound:e}"
            );
        }
        assert!(seam_step(&samples, &values, 3, 0).0 < 0.2 * seam_step(&samples, &baked, 3, 0).0);
    }

    #[test]
    fn a_column_is_stitched_the_same_whatever_columns_share_its_solve() {
        // `prt-bake stitch --columns` stitches shards of columns: each must get the bits
        // the whole bake's solve of all columns (and the accessibility) gives it.
        let (samples, values) = synthetic(64, 400);
        let ao: Vec<f32> = (0..values.len() / 3).map(|i| values[i * 3]).collect();
        let (mut all, mut all_ao) = (values.clone(), ao.clone());
        stitch_fields(&samples, &mut [(&mut all[..], 3), (&mut all_ao[..], 1)]);
        for column in 0..3 {
            let mut alone: Vec<f32> = values.iter().skip(column).step_by(3).copied().collect();
            stitch(&samples, &mut alone, 1);
            let together: Vec<f32> = all.iter().skip(column).step_by(3).copied().collect();
            assert!(
                alone == together,
                "column {column} differs when stitched alone"
            );
        }
        let mut alone = ao;
        stitch(&samples, &mut alone, 1);
        assert!(
            alone == all_ao,
            "the accessibility differs when stitched alone"
        );
    }

    #[test]
    fn stitching_is_the_same_for_any_thread_count() {
        let (samples, values) = synthetic(64, 400);
        let run = |threads: usize| {
            let mut v = values.clone();
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| stitch(&samples, &mut v, 3));
            v
        };
        let one = run(1);
        assert!(one != values, "stitching moved nothing");
        for threads in [2, 3] {
            assert!(run(threads) == one, "{threads} threads differ from 1");
        }
    }
}

//! Transfer matrices (`bake --transfer matrix`, Sloan, Kautz & Snyder 2002, §5): per receiver
//! the n²×n² matrix
//!
//! ```text
//! M_ij = ∫ V(x, s) y_i(s) y_j(s) ds        (V = 0 below the receiver's tangent plane)
//! ```
//!
//! that maps a distant light's SH coefficients L to those of the receiver's shadowed incident
//! radiance, L′ = M·L. A glossy (or any view-dependent) BRDF is then convolved with L′ at
//! render time; the diffuse transfer vector is the special case T = (1/π) M·ĉ, ĉ the clamped
//! cosine's coefficients about the normal.
//!
//! # Why uniform hemisphere sampling
//!
//! The vector estimator draws cosine-weighted directions because its integrand carries the
//! cosine. M has no cosine: with cosine-weighted samples every ray would be weighted by
//! π / cos θ, unbounded at grazing angles (the estimator's variance, ∫ (y_i y_j)² / cos θ ds,
//! diverges logarithmically). With uniform directions over the hemisphere (density 1/2π) each
//! unblocked ray adds (2π/N)·y(s)·y(s)ᵀ, a bounded integrand, so the error falls as for the
//! vector bake. The directions are the vector bake's: the same Owen-scrambled Sobol points of
//! the same seed, in the same Hilbert order ([`set_points`]), the same per-receiver turn about
//! the normal, the same ray origins and batches — only the map from the unit square to the
//! hemisphere differs (z = 1 − u₁ instead of √(1 − u₁)). A denoised bake's receivers take
//! the vector bake's joint sets, unturned, as [`Estimator::set`] picks them
//! ([`crate::bake::strata`]): the tables hold every set, one after another, and a receiver
//! reads its own set's rows and batch totals. That took the glossy torus's denoised error
//! at 64 rays from 2.25 to 1.95 % (docs/explanation/denoising-record.md).
//!
//! # How it is organised
//!
//! As in [`crate::bake::estimator`]: y(s) is tabled once per bake in the local frame (z along
//! the normal), each receiver sums the outer products of its unblocked rows in f32 per batch
//! of [`BATCH`] rays and in f64 across batches, and rotates the local matrix into world space
//! once: M_world = R · M_local · Rᵀ, with R the SH rotation of the receiver's frame (exact).
//! Only the upper triangle is summed, cut into 4×8 tiles ([`TileLayout`]) whose 32 sums stay
//! in registers while the batch's rows stream past: 192 multiply-adds per ray at order 4 (the
//! triangle is n²(n²+1)/2 = 136, the square 256), all in full vectors, and the lower triangle
//! mirrored at the end. In isolation that is 3–4 times faster than adding each ray's outer
//! product into memory (docs/explanation/performance.md, "Transfer matrices"). A batch in which most rays are
//! unblocked is summed as its precomputed total minus its blocked rays (on an open surface,
//! most are unblocked). Every quantity is a pure function of (seed, receiver, sample
//! index) summed in a fixed order: bit-identical for any thread count.
//!
//! The same rays give the denoiser its noise estimate ([`crate::bake::noise`]): the first row
//! of the local matrix is M_0j = 2π y₀ · (the mean of y_j over the unblocked points), so the
//! spread of the sequence's runs' sums of y_j over bands 0 to 2 (whole bands, the same spread
//! in world space) gives the variance of the range term's signal, the first 9 entries of
//! the n⁴. 9 additions per unblocked ray: about 1 % of a 64-ray bake's instructions.

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::bake::estimator::{DirectPass, Estimator, Visibility};
use crate::bake::matrix_hits::{BounceLight, BounceScratch};
use crate::bake::matrix_layout::{EXTRA, TOTALS_BUDGET};
pub use crate::bake::matrix_layout::{TileLayout, add_outer, packed_len, table_bytes};
use crate::bake::noise::{NOISE_BLOCKS, NoiseBlocks};
use crate::bake::receivers::RECEIVERS_PER_JOB;
use crate::bake::sample_sets::{batch_ranges, set_points};
use crate::math::sh::RecurrenceRotator;
use crate::math::sh::rotation::ShRotation;
use crate::support::progress::Progress;
use crate::trace::Tracer;

/// Rays per tracer call, as in the vector estimator.
const BATCH: usize = 256;
/// Maps [0, 1)² to the uniform hemisphere around +z (density 1/2π): z = 1 − u₁, the
/// counterpart of [`crate::math::sampling::cosine_hemisphere`]'s √(1 − u₁).
#[inline]
pub fn uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - u1;
    let r = (u1 * (2.0 - u1)).max(0.0).sqrt();
    let (s, c) = (std::f32::consts::TAU * u2).sin_cos();
    Vec3::new(r * c, r * s, z)
}

/// The directions every receiver traces, in its local frame (z along the normal), in the
/// order they are traced: the vector bake's point set of the seed, in its Hilbert order
/// ([`Estimator::for_receivers`]), mapped to the uniform hemisphere. In interreflected mode
/// the bounce samples (the sequence's first M points, a stratified set of their own) come
/// first, in their own Hilbert order, as in the vector bake: its first set ([`set_points`]).
pub fn local_directions(options: &crate::bake::options::BakeOptions) -> Vec<Vec3> {
    set_points(options, 0)
        .iter()
        .map(|&(_, u1, u2)| uniform_hemisphere(u1, u2))
        .collect()
}

/// The bake's tables: the local directions, y at each, the extra columns, and per batch the
/// sum of its outer products and extras; for each of the estimator's sets
/// ([`Estimator::set_count`]: one, or a denoised bake's joint sets), one after another.
pub(crate) struct MatrixTables {
    n: usize,
    /// Points per set (`--samples`).
    samples: usize,
    local_dirs: Vec<Vec3>,
    /// The batches of sample indices traced together ([`batch_ranges`]: 256 rays, split at
    /// the end of the bounce samples).
    batches: Vec<std::ops::Range<usize>>,
    pub(crate) layout: TileLayout,
    /// Row r (padded to `layout.width`): y_j(local_dirs[r]), then zeros.
    pub(crate) rows: Vec<f32>,
    /// Row r: cos θ, then the local direction times cos θ.
    extras: Vec<[f32; EXTRA]>,
    /// Row r: the run of the sequence its point belongs to (its index × [`NOISE_BLOCKS`] /
    /// samples), as in the vector bake.
    row_blocks: Vec<u8>,
    /// Whether the range term's signal (the first 9 entries of a channel's n⁴) is the first
    /// row's bands 0 to 2, whose noise the runs' spread estimates: at orders 1 and 3 up, not
    /// at order 2, where it takes in 2 rows and a bit (the denoiser then estimates the noise
    /// from the neighbours).
    row_noise: bool,
    /// Per set and batch: the tiled sum of its rows' outer products, then its extras' sum;
    /// empty where one set's would take more than [`TOTALS_BUDGET`] bytes (very high
    /// orders), and then every batch sums its unblocked rays.
    batch_totals: Vec<f32>,
}

impl MatrixTables {
    pub(crate) fn new(estimator: &Estimator) -> MatrixTables {
        let options = &estimator.options;
        let basis = &estimator.basis;
        let n = basis.coeff_count();
        let points: Vec<(u32, f32, f32)> = (0..estimator.set_count())
            .flat_map(|set| set_points(options, set))
            .collect();
        let local_dirs: Vec<Vec3> = points
            .iter()
            .map(|&(_, u1, u2)| uniform_hemisphere(u1, u2))
            .collect();
        let row_blocks = points
            .iter()
            .map(|&(i, _, _)| {
                (u64::from(i) * NOISE_BLOCKS as u64 / u64::from(options.samples)) as u8
            })
            .collect();
        let layout = TileLayout::new(n);
        let mut rows = vec![0.0f32; local_dirs.len() * layout.width];
        for (row, d) in rows.chunks_mut(layout.width).zip(&local_dirs) {
            basis.eval(*d, &mut row[..n]);
        }
        let extras: Vec<[f32; EXTRA]> = local_dirs
            .iter()
            .map(|d| [d.z, d.x * d.z, d.y * d.z, d.z * d.z])
            .collect();
        let width = layout.floats() + EXTRA;
        let batches: Vec<_> = batch_ranges(options).collect();
        let samples = options.samples as usize;
        let mut batch_totals = Vec::new();
        if batches.len() * width * 4 <= TOTALS_BUDGET {
            for first in (0..local_dirs.len()).step_by(samples) {
                for &std::ops::Range { start, end } in &batches {
                    let (start, end) = (first + start, first + end);
                    let mut total = vec![0.0f32; width];
                    let all: Vec<u32> = (start as u32..end as u32).collect();
                    layout.accumulate(&rows, &all, &mut total[..width - EXTRA]);
                    for e in &extras[start..end] {
                        add_extras(&mut total[width - EXTRA..], e, 1.0);
                    }
                    batch_totals.extend(total);
                }
            }
        }
        MatrixTables {
            n,
            samples,
            layout,
            batches,
            local_dirs,
            rows,
            extras,
            row_blocks,
            row_noise: n == 1 || n >= 9,
            batch_totals,
        }
    }
}

#[inline]
fn add_extras(acc: &mut [f32], e: &[f32; EXTRA], sign: f32) {
    for (a, x) in acc.iter_mut().zip(e) {
        *a += sign * x;
    }
}

/// Per-thread buffers, reused across receivers.
struct MatrixScratch {
    dirs: Vec<Vec3>,
    occluded: Vec<bool>,
    selected: Vec<u32>,
    batch_sum: Vec<f32>,
    total: Vec<f64>,
    local: Vec<f64>,
    column: Vec<f64>,
    rotated: Vec<f64>,
    /// Interreflected mode: the bounce rays' hits and sums.
    bounce: Option<BounceScratch>,
    /// The current receiver's sums per run of its sequence (its noise estimate).
    noise: NoiseBlocks,
}

impl MatrixScratch {
    fn new(n: usize, layout: &TileLayout, bounce: Option<&BounceLight>) -> MatrixScratch {
        MatrixScratch {
            bounce: bounce.map(|b| BounceScratch::new(b, BATCH)),
            dirs: Vec::with_capacity(BATCH),
            occluded: vec![false; BATCH],
            selected: Vec::with_capacity(BATCH),
            batch_sum: vec![0.0; layout.floats() + EXTRA],
            total: vec![0.0; layout.floats() + EXTRA],
            local: vec![0.0; n * n],
            column: vec![0.0; n],
            rotated: vec![0.0; n],
            noise: NoiseBlocks::bands_0_to_2(n),
        }
    }
}

/// The transfer matrices of the receivers `receivers` (results indexed from its start):
/// `coefficients[((r · channels + c) · n² + i) · n² + j]`, one channel unless `bounce`
/// (interreflected mode: [`crate::bake::matrix_bounce`]) has three. `tracer` is `None` in
/// unshadowed mode (V = 1 over the hemisphere).
pub(crate) fn matrix_pass(
    estimator: &Estimator,
    tracer: Option<&dyn Tracer>,
    bounce: Option<&BounceLight>,
    receivers: std::ops::Range<usize>,
    progress: &dyn Progress,
) -> DirectPass {
    let tables = MatrixTables::new(estimator);
    let n = tables.n;
    let width = bounce.map_or(1, |b| b.channels) * n * n;
    let rotator = RecurrenceRotator::new(estimator.options.order);
    let rays_per_receiver = match tracer {
        Some(_) => u64::from(estimator.options.samples),
        None => 0,
    };
    progress.begin("matrix", receivers.len() as u64, rays_per_receiver);
    let mut coefficients = vec![0.0f32; receivers.len() * width];
    let mut visibility = vec![Visibility::default(); receivers.len()];
    coefficients
        .par_chunks_mut(RECEIVERS_PER_JOB * width)
        .zip(visibility.par_chunks_mut(RECEIVERS_PER_JOB))
        .enumerate()
        .for_each_init(
            || MatrixScratch::new(n, &tables.layout, bounce),
            |scratch, (job, (out, vis))| {
                let first = receivers.start + job * RECEIVERS_PER_JOB;
                for (k, (out, vis)) in out.chunks_mut(width).zip(vis.iter_mut()).enumerate() {
                    *vis = receiver_matrix(
                        estimator,
                        &tables,
                        &rotator,
                        first + k,
                        (tracer, bounce),
                        scratch,
                        out,
                    );
                }
                progress.advance(vis.len() as u64);
            },
        );
    progress.finish();
    DirectPass {
        coefficients,
        visibility,
    }
}

/// The matrices of the receivers `receivers` alone, n⁴ floats each, row-major (the oracle
/// tests bake one vertex of a large scene): [`matrix_pass`] without progress.
pub fn receiver_matrices(
    estimator: &Estimator,
    tracer: Option<&dyn Tracer>,
    receivers: std::ops::Range<usize>,
) -> Vec<f32> {
    let silent = crate::support::progress::Silent;
    matrix_pass(estimator, tracer, None, receivers, &silent).coefficients
}

/// Receiver `v`'s matrix into `out` (n⁴ floats per channel, row-major), and its visibility
/// quantities. With a [`BounceLight`], the bounce samples are traced for their closest hits
/// and the light the hit surfaces reflect is added ([`crate::bake::matrix_bounce`]).
fn receiver_matrix(
    estimator: &Estimator,
    tables: &MatrixTables,
    rotator: &RecurrenceRotator,
    v: usize,
    (tracer, bounce): (Option<&dyn Tracer>, Option<&BounceLight>),
    s: &mut MatrixScratch,
    out: &mut [f32],
) -> Visibility {
    let n = tables.n;
    let packed = tables.layout.floats();
    // The receiver's set (unturned frame) where the bake samples jointly: its rows follow
    // `first`, its batches' totals `set` sets' in.
    let frame: Mat3 = estimator.vertex_frame(v);
    let (set, first) = (estimator.set(v), estimator.first_row(v));
    let origin = estimator.origin(v);
    s.total.fill(0.0);
    s.noise.clear();
    if let Some(bs) = &mut s.bounce {
        bs.begin();
    }
    let samples = tables.samples;
    for (b, batch) in tables.batches.iter().enumerate() {
        let b = set * tables.batches.len() + b;
        // Rows of the tables; the bounce samples are the set's first.
        let (start, end) = (first + batch.start, first + batch.end);
        let len = end - start;
        let occluded = &mut s.occluded[..len];
        match tracer {
            Some(tracer) => {
                s.dirs.clear();
                s.dirs
                    .extend(tables.local_dirs[start..end].iter().map(|d| frame * *d));
                let bounce_batch = bounce.is_some_and(|b| batch.start < b.bounce_samples);
                match (bounce, &mut s.bounce) {
                    (Some(light), Some(bs)) if bounce_batch => bs.trace_batch(
                        light,
                        (&tables.rows, tables.layout.width),
                        tracer,
                        origin,
                        start,
                        &s.dirs,
                        occluded,
                    ),
                    _ => tracer.occluded_from(origin, &s.dirs, occluded),
                }
            }
            None => occluded.fill(false),
        }
        if tracer.is_some() && tables.row_noise {
            let w = tables.layout.width;
            let rows = tables.rows[start * w..end * w].chunks_exact(w);
            s.noise
                .add_unblocked(rows, &tables.row_blocks[start..end], occluded);
        }
        let blocked = occluded.iter().filter(|&&b| b).count();
        // The total minus the blocked rays, or the sum of the unblocked ones: the fewer terms.
        let subtract = !tables.batch_totals.is_empty() && 2 * blocked <= len;
        s.selected.clear();
        s.selected.extend(
            (start as u32..end as u32)
                .zip(occluded.iter())
                .filter(|(_, b)| **b == subtract)
                .map(|(r, _)| r),
        );
        s.batch_sum.fill(0.0);
        let (outer, extra) = s.batch_sum.split_at_mut(packed);
        tables.layout.accumulate(&tables.rows, &s.selected, outer);
        for &r in &s.selected {
            add_extras(extra, &tables.extras[r as usize], 1.0);
        }
        if subtract {
            let total = &tables.batch_totals[b * (packed + EXTRA)..(b + 1) * (packed + EXTRA)];
            for (t, (all, selected)) in s.total.iter_mut().zip(total.iter().zip(&s.batch_sum)) {
                *t += f64::from(all - selected);
            }
        } else {
            for (t, selected) in s.total.iter_mut().zip(&s.batch_sum) {
                *t += f64::from(*selected);
            }
        }
    }
    // Uniform over the hemisphere: each ray stands for 2π/N steradians.
    let norm = std::f64::consts::TAU / samples as f64;
    tables.layout.unpack(&s.total[..packed], norm, &mut s.local);
    let rotation = rotator.rotation(frame.as_dmat3());
    rotate_symmetric(&rotation, n, s);
    match (bounce, &mut s.bounce) {
        (Some(light), Some(bs)) => bs.finish(
            light,
            &rotation,
            &s.local,
            out,
            &mut s.column,
            &mut s.rotated,
        ),
        _ => {
            for (o, w) in out.iter_mut().zip(&s.local) {
                *o = *w as f32;
            }
        }
    }
    let extra = &s.total[packed..];
    // (1/π) ∫ V cos θ ds and the cosine-weighted mean unblocked direction, from the same rays.
    let local_bent = glam::DVec3::new(extra[1], extra[2], extra[3]).as_vec3();
    Visibility {
        accessibility: ((extra[0] * norm / std::f64::consts::PI) as f32).clamp(0.0, 1.0),
        bent_normal: (frame * local_bent)
            .try_normalize()
            .unwrap_or(estimator.normals[v]),
        rays: if tracer.is_some() { samples as u32 } else { 0 },
        points: samples as u32,
        error_estimate: 0.0,
        // Row 0 is M_0j = 2π y₀ · (the mean of y_j over the points, 0 where blocked), and
        // (2π y₀)² = π: the runs give the variance of that mean.
        noise: match tracer {
            Some(_) if tables.row_noise => s.noise.variance(samples as u32) * std::f32::consts::PI,
            _ => 0.0,
        },
    }
}

/// `s.local` ← R · `s.local` · Rᵀ (symmetric in, symmetric out: the result's two halves are
/// averaged, so it is exactly symmetric).
fn rotate_symmetric(rotation: &ShRotation, n: usize, s: &mut MatrixScratch) {
    let m = &mut s.local;
    // Rows: B = M·Rᵀ, row i of B being R applied to row i of M.
    for i in 0..n {
        rotation.apply(&m[i * n..(i + 1) * n], &mut s.rotated);
        m[i * n..(i + 1) * n].copy_from_slice(&s.rotated);
    }
    // Columns: R·B, column j being R applied to column j of B.
    for j in 0..n {
        for i in 0..n {
            s.column[i] = m[i * n + j];
        }
        rotation.apply(&s.column, &mut s.rotated);
        for i in 0..n {
            m[i * n + j] = s.rotated[i];
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            let mean = 0.5 * (m[i * n + j] + m[j * n + i]);
            m[i * n + j] = mean;
            m[j * n + i] = mean;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiled_outer_products_match_the_full_ones() {
        for n in [1, 4, 9, 16, 25] {
            let layout = TileLayout::new(n);
            let mut rng = crate::math::sampling::Pcg32::new(3, n as u64);
            let rows: Vec<f32> = (0..3 * layout.width)
                .map(|k| {
                    if k % layout.width < n {
                        rng.next_f32() - 0.5
                    } else {
                        0.0
                    }
                })
                .collect();
            let mut tiled = vec![0.0f32; layout.floats()];
            layout.accumulate(&rows, &[0, 2], &mut tiled);
            let tiled: Vec<f64> = tiled.iter().map(|&x| f64::from(x)).collect();
            let mut full = vec![f64::NAN; n * n];
            layout.unpack(&tiled, 2.0, &mut full);
            let y = |k: usize, i: usize| f64::from(rows[k * layout.width + i]);
            for i in 0..n {
                for j in 0..n {
                    let expected = 2.0 * (y(0, i) * y(0, j) + y(2, i) * y(2, j));
                    assert!(
                        (full[i * n + j] - expected).abs() < 1e-6,
                        "n {n} ({i}, {j})"
                    );
                }
            }
        }
    }

    #[test]
    fn a_denoised_bakes_tile_takes_consecutive_joint_sets_of_the_matrix_tables() {
        let receivers = |strata| crate::bake::receivers::Receivers {
            origins: vec![Vec3::ZERO; 32],
            normals: vec![Vec3::Z; 32],
            strata,
            ..Default::default()
        };
        let options = crate::bake::options::BakeOptions {
            transfer: crate::bake::options::TransferKind::Matrix,
            order: 3,
            samples: 64,
            denoise: true,
            ..Default::default()
        };
        let strata = Some((0..32).collect());
        let estimator = Estimator::for_receivers(receivers(strata), &options).unwrap();
        let tables = MatrixTables::new(&estimator);
        let sets = estimator.set_count() as usize;
        assert_eq!(sets, 256);
        assert_eq!(tables.local_dirs.len(), sets * 64);
        assert_eq!(
            tables.batch_totals.len(),
            sets * (tables.layout.floats() + EXTRA)
        );
        assert!(table_bytes(&options).unwrap() * sets as u64 <= 64 << 20);
        // Each tile of 16 strata takes the 16 consecutive blocks of one group's sequence,
        // whose points are the tables' rows from the set's first, unturned.
        for tile in [0..16, 16..32] {
            let mut taken: Vec<usize> = tile.map(|v| estimator.set(v)).collect();
            let group = taken[0] / 16;
            taken.sort_unstable();
            assert_eq!(taken, (group * 16..group * 16 + 16).collect::<Vec<_>>());
        }
        let v = 5;
        let first = estimator.first_row(v);
        let points = set_points(&options, estimator.set(v) as u32);
        assert_eq!(
            tables.local_dirs[first],
            uniform_hemisphere(points[0].1, points[0].2)
        );
        assert_eq!(estimator.vertex_frame(v), estimator.vertex_frame(v + 16));
        // Not denoised: one set, turned by each receiver.
        let raw = crate::bake::options::BakeOptions {
            denoise: false,
            ..options
        };
        let estimator = Estimator::for_receivers(receivers(None), &raw).unwrap();
        assert_eq!(estimator.set_count(), 1);
        assert_eq!(
            MatrixTables::new(&estimator).local_dirs,
            local_directions(&raw)
        );
    }

    #[test]
    fn uniform_hemisphere_points_are_unit_and_above_the_horizon() {
        for (u1, u2) in [(0.0, 0.0), (0.999_999, 0.5), (0.5, 0.25), (1e-7, 0.9)] {
            let d = uniform_hemisphere(u1, u2);
            assert!((d.length() - 1.0).abs() < 1e-6 && d.z > 0.0, "{d}");
        }
    }
}

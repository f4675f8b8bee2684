//! The estimator's sample tables ([`crate::bake::estimator`]): per set of `--samples`
//! Owen-scrambled Sobol points, their cosine-weighted directions in the local frame, a row of
//! SH values and the direction per point, each batch's sum of rows and each point's noise
//! block. One set, or a denoised bake's joint sets ([`crate::bake::strata`]), one after
//! another; [`set_points`] gives a set's points to the transfer matrices' tables too
//! ([`crate::bake::matrix`]).

use glam::Vec3;

use crate::bake::noise::NOISE_BLOCKS;
use crate::bake::options::BakeOptions;
use crate::bake::strata::SETS_PER_GROUP;
use crate::math::sampling::{OwenSobol, cosine_hemisphere, hilbert_index, vertex_seed};
use crate::math::sh::Basis;

/// Rays per tracer call: the batch over which the SH sums are first formed in f32.
pub(crate) const BATCH: usize = 256;
/// The columns after the n² coefficients in the estimator's rows: the local direction.
pub(crate) const DIR_COLUMNS: usize = 3;

/// `sets` × `samples` points' tables, set after set.
#[derive(Default)]
pub(crate) struct SampleSets {
    /// Cosine-weighted directions in the local frame.
    pub dirs: Vec<Vec3>,
    /// Row i (width n² + 3): y_j(dirs[i]) for j < n², then dirs[i] itself, whose sum over
    /// the unblocked rays gives the bent normal with the same additions.
    pub rows: Vec<f32>,
    /// Per set and batch of [`batch_ranges`], the sum of its rows.
    pub batch_totals: Vec<f32>,
    /// Per row, the block of its set's sequence the point belongs to (its index in the set
    /// × [`NOISE_BLOCKS`] / samples): the rows are sorted for tracing, the blocks are runs.
    pub row_blocks: Vec<u8>,
}

impl SampleSets {
    /// The tables of `sets` sets: set s is block s mod [`SETS_PER_GROUP`] of sequence
    /// s / [`SETS_PER_GROUP`] (one set: the first sequence's first block).
    pub fn new(options: &BakeOptions, basis: &Basis, sets: u32) -> SampleSets {
        let n = basis.coeff_count();
        let width = n + DIR_COLUMNS;
        let mut tables = SampleSets::default();
        for set in 0..sets {
            let uv = set_points(options, set);
            let start = tables.dirs.len();
            let dirs = uv.iter().map(|&(_, u1, u2)| cosine_hemisphere(u1, u2));
            tables.dirs.extend(dirs);
            tables.row_blocks.extend(uv.iter().map(|&(i, _, _)| {
                (u64::from(i) * NOISE_BLOCKS as u64 / u64::from(options.samples)) as u8
            }));
            tables.rows.resize(tables.dirs.len() * width, 0.0);
            let rows = &mut tables.rows[start * width..];
            for (row, d) in rows.chunks_mut(width).zip(&tables.dirs[start..]) {
                basis.eval(*d, &mut row[..n]);
                row[n..].copy_from_slice(&d.to_array());
            }
            for batch in batch_ranges(options) {
                let mut total = vec![0.0f32; width];
                for row in rows[batch.start * width..batch.end * width].chunks_exact(width) {
                    for (t, y) in total.iter_mut().zip(row) {
                        *t += y;
                    }
                }
                tables.batch_totals.extend(total);
            }
        }
        tables
    }
}

/// Set `set`'s `samples` points (index in the set, u₁, u₂) in the order they are traced:
/// block `set` mod [`SETS_PER_GROUP`] of sequence `set` / [`SETS_PER_GROUP`] (a group's sets
/// are consecutive blocks of one sequence; set 0 is the one set of a bake that samples its
/// receivers independently). The vector and the matrix estimators' tables both start here.
pub(crate) fn set_points(options: &BakeOptions, set: u32) -> Vec<(u32, f32, f32)> {
    let (sequence, block) = (set / SETS_PER_GROUP, set % SETS_PER_GROUP);
    let points = OwenSobol::new(vertex_seed(options.seed, u64::MAX - u64::from(sequence)));
    let first = block * options.samples;
    let mut uv: Vec<(u32, f32, f32)> = (0..options.samples)
        .map(|i| {
            let (u1, u2) = points.point(first + i);
            (i, u1, u2)
        })
        .collect();
    // The bounce samples (the set's first M points) come first, so a batch is all
    // closest-hit rays or all occlusion rays; within each part, consecutive rays with close
    // directions trace much faster (Embree forms coherent packets). The set, and so the
    // estimate, does not depend on the order. Each key computed once (a stable sort, as
    // `sort_by_key`: the same order).
    let bounce_samples = options.effective_bounce_samples();
    uv.sort_by_cached_key(|&(i, u1, u2)| (i >= bounce_samples, hilbert_index(u1, u2)));
    uv
}

/// The batches of sample indices a vertex traces: at most [`BATCH`] long, and split at the
/// bounce samples' end, so each batch is all bounce samples or none.
pub(crate) fn batch_ranges(
    options: &BakeOptions,
) -> impl Iterator<Item = std::ops::Range<usize>> + use<> {
    let samples = options.samples as usize;
    let bounce = options.effective_bounce_samples() as usize;
    let mut start = 0;
    std::iter::from_fn(move || {
        (start < samples).then(|| {
            let limit = if start < bounce { bounce } else { samples };
            let range = start..(start + BATCH).min(limit);
            start = range.end;
            range
        })
    })
}

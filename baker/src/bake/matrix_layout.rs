//! How a transfer-matrix bake lays out its sums ([`crate::bake::matrix`]): the upper
//! triangle of each n²×n² matrix cut into register-sized tiles, and what one sample set's
//! tables take in bytes. Apart from the bake itself so that the memory estimate
//! ([`crate::bake::memory`]), which the estimator asks to size its joint sets, does not
//! depend on the bake that depends on the estimator.

use crate::bake::options::BakeOptions;
use crate::bake::sample_sets::batch_ranges;

/// The most bytes the per-batch totals may take (64 MiB: order 16 at a million rays).
pub(crate) const TOTALS_BUDGET: usize = 64 << 20;
/// Columns summed beside the outer products: cos θ (for the accessibility) and the local
/// direction times cos θ (for the bent normal).
pub(crate) const EXTRA: usize = 4;

/// Length of the packed upper triangle of an n×n symmetric matrix.
#[inline]
pub fn packed_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// `acc += sign · y yᵀ` over the packed upper triangle (row i holds columns i..n), ray by ray:
/// the straightforward accumulation, which `benches/matrix.rs` times against
/// [`TileLayout::accumulate`] (the bake's). Each row is one contiguous multiply-add of
/// `y[i..]` scaled by `y[i]`, but every sum is loaded and stored once per ray.
#[inline]
pub fn add_outer(acc: &mut [f32], y: &[f32], sign: f32) {
    let mut rest = acc;
    for (i, &yi) in y.iter().enumerate() {
        let (row, tail) = rest.split_at_mut(y.len() - i);
        let s = sign * yi;
        for (a, &yj) in row.iter_mut().zip(&y[i..]) {
            *a += s * yj;
        }
        rest = tail;
    }
}

/// Rows of a tile: the y_i broadcast against one column chunk.
const TILE_ROWS: usize = 4;
/// Columns of a tile (two SSE or one AVX register of f32).
const TILE_LANES: usize = 8;
/// Floats in one tile.
const TILE: usize = TILE_ROWS * TILE_LANES;

/// The upper triangle of an n×n symmetric matrix cut into 4×8 tiles (rows i0..i0+4, columns
/// j0..j0+8) that cover every (i, j ≥ i) exactly once: row block i0 takes the column chunks
/// from the one holding its diagonal on. Rows of y are padded with zeros to `width`, a
/// multiple of 8, so every tile is full: at order 4, 6 tiles, 192 multiply-adds per ray (the
/// triangle itself is 136), all in full vectors.
pub struct TileLayout {
    pub n: usize,
    /// n rounded up to a multiple of [`TILE_LANES`]: the stride of a padded row.
    pub width: usize,
    /// Each tile's (first row, first column).
    pub tiles: Vec<(usize, usize)>,
}

impl TileLayout {
    pub fn new(n: usize) -> TileLayout {
        let width = n.div_ceil(TILE_LANES) * TILE_LANES;
        let tiles = (0..n)
            .step_by(TILE_ROWS)
            .flat_map(|i0| {
                let first = i0 / TILE_LANES * TILE_LANES;
                (first..width).step_by(TILE_LANES).map(move |j0| (i0, j0))
            })
            .collect();
        TileLayout { n, width, tiles }
    }

    /// Floats in the tiled triangle.
    pub fn floats(&self) -> usize {
        self.tiles.len() * TILE
    }

    /// `out += Σ_{k ∈ selected} y_k y_kᵀ` over the tiles, y_k being row k of `rows` (padded
    /// rows of [`TileLayout::width`]). Per tile the 32 sums stay in registers while the rows
    /// stream past (a batch's rows fit in L1): 4 broadcasts and 32 multiply-adds per row
    /// and tile, where summing ray by ray into memory loads and stores every sum per ray.
    pub fn accumulate(&self, rows: &[f32], selected: &[u32], out: &mut [f32]) {
        let w = self.width;
        for (&(i0, j0), out) in self.tiles.iter().zip(out.chunks_exact_mut(TILE)) {
            let mut acc = [[0.0f32; TILE_LANES]; TILE_ROWS];
            for &k in selected {
                let row = &rows[k as usize * w..(k as usize + 1) * w];
                let yj: &[f32; TILE_LANES] = row[j0..j0 + TILE_LANES].try_into().expect("8");
                let yi: &[f32; TILE_ROWS] = row[i0..i0 + TILE_ROWS].try_into().expect("4");
                for (a, &y) in acc.iter_mut().zip(yi) {
                    for (a, &x) in a.iter_mut().zip(yj) {
                        *a += y * x;
                    }
                }
            }
            for (o, a) in out.iter_mut().zip(acc.iter().flatten()) {
                *o += a;
            }
        }
    }

    /// The full n×n matrix, times `scale`, from tiled sums.
    pub(crate) fn unpack(&self, tiled: &[f64], scale: f64, out: &mut [f64]) {
        let n = self.n;
        for (&(i0, j0), tile) in self.tiles.iter().zip(tiled.chunks_exact(TILE)) {
            for ii in 0..TILE_ROWS {
                for jj in 0..TILE_LANES {
                    let (i, j) = (i0 + ii, j0 + jj);
                    if i < n && j < n && j >= i {
                        let x = tile[ii * TILE_LANES + jj] * scale;
                        out[i * n + j] = x;
                        out[j * n + i] = x;
                    }
                }
            }
        }
    }
}

/// One set's tables' bytes with `options` (what [`crate::bake::memory`] and the joint sets'
/// budget count): per sample its local direction, padded row, extras, run and sort key,
/// and per batch its totals where they are kept. None if it overflows.
pub fn table_bytes(options: &BakeOptions) -> Option<u64> {
    let layout = TileLayout::new(crate::math::sh::coeff_count(options.order));
    let per_sample = 12 + 4 * layout.width as u64 + 4 * EXTRA as u64 + 1 + 12;
    let batches = batch_ranges(options).count();
    let totals = batches.checked_mul((layout.floats() + EXTRA) * 4)?;
    let totals = if totals <= TOTALS_BUDGET { totals } else { 0 };
    u64::from(options.samples)
        .checked_mul(per_sample)?
        .checked_add(totals as u64)
}

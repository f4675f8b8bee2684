//! The seam stitch's least-squares system ([`super::stitch`]), factored and solved: the
//! normal equations (λI + CᵀC) x = λx̂ of the seam samples C, assembled in parallel, ordered
//! and factored by `faer` (sparse supernodal Cholesky), and solved here for all columns at
//! once, in an order that makes every column's bits independent of the others and of the
//! thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{
    SupernodalLltRef, SymbolicSupernodalCholesky, factorize_supernodal_numeric_llt,
    factorize_supernodal_numeric_llt_scratch,
};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::utils::{permute_self_adjoint_scratch, permute_self_adjoint_to_unsorted};
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{MatRef, Par, Side};
use rayon::prelude::*;

/// Weight of keeping a texel's baked value against making the seams agree: small, so the
/// seams agree to a few per cent of their step, while texels move only as far as they must.
pub(super) const KEEP: f64 = 0.02;

/// A seam sample's (texel, weight) taps on its two sides.
pub(super) type Taps<'s> = (&'s [(u32, f32)], &'s [(u32, f32)]);

/// The least-squares system of [`super::stitch::stitch`], factored.
pub(super) struct System {
    /// The lightmap texel of each unknown, in the factor's (permuted) order.
    texels: Vec<usize>,
    /// The ordering and supernodes (faer's symbolic factorisation, forced supernodal) and
    /// the factor's values.
    symbolic: SymbolicCholesky<u32>,
    factor: Vec<f64>,
}

impl System {
    /// The factor's nonzeros.
    pub(super) fn factor_len(&self) -> usize {
        self.factor.len()
    }

    /// C (one row per sample over the texels it reads) and its transpose, then the lower
    /// triangle of λI + CᵀC, factored. `sample(s)`: seam sample s's (texel, weight) taps on
    /// its two sides, for s in 0..`count` (a function, so that this module needs not know
    /// [`super::stitch::SeamSample`]). Indices are u32 (an unknown is a texel, and a texel
    /// index is u32 in the samples), which halves the ordering's workspace.
    pub(super) fn new<'s>(count: usize, sample: impl Fn(usize) -> Taps<'s>) -> Option<System> {
        let samples = || (0..count).map(&sample);
        let texel_count = samples()
            .flat_map(|(a, b)| a.iter().chain(b))
            .map(|&(t, _)| t as usize + 1)
            .max()
            .unwrap_or(0);
        let mut index = vec![u32::MAX; texel_count];
        let mut texels: Vec<usize> = Vec::new();
        // Per sample, its (unknown, ± weight) entries (side a positive, side b negative, a
        // texel read on both sides once), delimited by `starts`.
        let mut entries: Vec<(u32, f32)> = Vec::with_capacity(count * 8);
        let mut starts = Vec::with_capacity(count + 1);
        for (a, b) in samples() {
            let row = entries.len();
            starts.push(row);
            let sides = a
                .iter()
                .map(|&t| (t, 1.0))
                .chain(b.iter().map(|&t| (t, -1.0)));
            for ((texel, w), sign) in sides {
                let slot = &mut index[texel as usize];
                if *slot == u32::MAX {
                    *slot = texels.len() as u32;
                    texels.push(texel as usize);
                }
                let k = *slot;
                match entries[row..].iter_mut().find(|(j, _)| *j == k) {
                    Some(entry) => entry.1 += sign * w,
                    None => entries.push((k, sign * w)),
                }
            }
        }
        starts.push(entries.len());
        drop(index);
        // The transpose, by counting: each unknown's readers (samples) in sample order.
        let n = texels.len();
        let mut reads = vec![0usize; n + 1];
        for &(k, _) in &entries {
            reads[k as usize + 1] += 1;
        }
        for k in 0..n {
            reads[k + 1] += reads[k];
        }
        let mut fill = reads.clone();
        let mut readers = vec![(0u32, 0.0f32); entries.len()];
        for (s, row) in starts.windows(2).enumerate() {
            for &(k, w) in &entries[row[0]..row[1]] {
                readers[fill[k as usize]] = (s as u32, w);
                fill[k as usize] += 1;
            }
        }
        drop(fill);
        // Column j of the lower triangle: λ on the diagonal plus, for every sample reading
        // j, w_j·w_k at each unknown k ≥ j it reads; equal rows add in sample order (the
        // same bits for any thread count), each row found by `slot` (its place in the
        // column, u32::MAX where absent) rather than by sorting all the products: half the
        // time of sorting them (0.18 against 0.37 CPU-s on the heightfield). Rows sorted
        // once merged. In parallel over fixed blocks of columns, each block's rows and
        // values flat.
        let blocks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..n)
            .into_par_iter()
            .step_by(COLUMN_BLOCK)
            // At least 8 blocks a task: the slots (3.6 MB on the heightfield) are set up per
            // task, and rayon makes more tasks the more threads it has.
            .with_min_len(8)
            .map_init(
                || vec![u32::MAX; n],
                |slot, first| {
                    let (mut lengths, mut rows, mut values) = (Vec::new(), Vec::new(), Vec::new());
                    let mut column: Vec<(u32, f64)> = Vec::new();
                    for j in first..(first + COLUMN_BLOCK).min(n) {
                        column.clear();
                        column.push((j as u32, KEEP));
                        slot[j] = 0;
                        for &(s, wj) in &readers[reads[j]..reads[j + 1]] {
                            let s = s as usize;
                            for &(k, wk) in &entries[starts[s]..starts[s + 1]] {
                                if k as usize >= j {
                                    let v = f64::from(wj) * f64::from(wk);
                                    match slot[k as usize] {
                                        u32::MAX => {
                                            slot[k as usize] = column.len() as u32;
                                            column.push((k, v));
                                        }
                                        at => column[at as usize].1 += v,
                                    }
                                }
                            }
                        }
                        for &(k, _) in &column {
                            slot[k as usize] = u32::MAX;
                        }
                        column.sort_unstable_by_key(|&(k, _)| k);
                        rows.extend(column.iter().map(|&(k, _)| k));
                        values.extend(column.iter().map(|&(_, v)| v));
                        lengths.push(column.len());
                    }
                    (lengths, rows, values)
                },
            )
            .collect();
        drop((entries, starts, readers, reads));
        let nonzeros: usize = blocks.iter().map(|b| b.1.len()).sum();
        u32::try_from(nonzeros).ok()?;
        let mut col_ptr: Vec<u32> = Vec::with_capacity(n + 1);
        let (mut rows, mut values) = (Vec::with_capacity(nonzeros), Vec::with_capacity(nonzeros));
        col_ptr.push(0);
        for (lengths, block_rows, block_values) in blocks {
            for length in lengths {
                col_ptr.push(col_ptr.last().expect("starts with 0") + length as u32);
            }
            rows.extend(block_rows);
            values.extend(block_values);
        }
        let structure = SymbolicSparseColMat::<u32>::new_checked(n, n, col_ptr, None, rows);
        let matrix = SparseColMat::<u32, f64>::new(structure, values);
        let symbolic = factorize_symbolic_cholesky(
            matrix.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                // The solves below walk supernodes.
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
        )
        .ok()?;
        let SymbolicCholeskyRaw::Supernodal(supernodes) = symbolic.raw() else {
            return None; // forced supernodal above
        };
        let order = symbolic.perm()?;
        // The matrix in the factor's order, as faer's numeric factorisation would permute it
        // into its scratch, but made here so that the original goes before the factor is
        // allocated: one copy of the matrix (98 MB on the heightfield) at the stitch's peak
        // instead of two.
        let nonzeros = matrix.compute_nnz();
        let (mut permuted_values, mut permuted_rows) =
            (vec![0.0f64; nonzeros], vec![0u32; nonzeros]);
        let mut permuted_col_ptr = vec![0u32; n + 1];
        let mut scratch = MemBuffer::new(permute_self_adjoint_scratch::<u32>(n));
        let permuted = permute_self_adjoint_to_unsorted(
            &mut permuted_values,
            &mut permuted_col_ptr,
            &mut permuted_rows,
            matrix.as_ref(),
            order,
            Side::Lower,
            Side::Lower,
            MemStack::new(&mut scratch),
        );
        drop(matrix);
        let permuted = SparseColMatRef::new(permuted.symbolic(), permuted.val());
        let mut factor = vec![0.0; symbolic.len_val()];
        let mut scratch = MemBuffer::new(factorize_supernodal_numeric_llt_scratch::<u32, f64>(
            supernodes,
            Par::Seq,
            Default::default(),
        ));
        factorize_supernodal_numeric_llt(
            &mut factor,
            permuted,
            Default::default(),
            supernodes,
            Par::Seq,
            MemStack::new(&mut scratch),
            Default::default(),
        )
        .ok()?;
        drop((scratch, permuted_values, permuted_rows, permuted_col_ptr));
        let texels = order
            .arrays()
            .0
            .iter()
            .map(|&u| texels[u as usize])
            .collect();
        Some(System {
            texels,
            symbolic,
            factor,
        })
    }

    /// Solves (λI + CᵀC) x = λx̂ for every column of every field (`(values, width)`,
    /// `width` floats per texel) and writes x into the stitched texels.
    ///
    /// The solve is memory-bound (373 MB of factor on the heightfield), so the columns go
    /// through the factor together, one pass forward and one back, rather than one column
    /// at a time (the solve took 1.7 of the stitch's 4.4 CPU-s that way). The columns are
    /// split into one group per thread; every column's arithmetic is the same whichever
    /// columns share its group and however many threads run, so a column's values do not
    /// depend on which columns are stitched with it (`prt-bake stitch --columns` stitches
    /// shards of columns: `distribute::stitch_columns`).
    pub(super) fn solve(&self, fields: &mut [(&mut [f32], usize)]) {
        let SymbolicCholeskyRaw::Supernodal(supernodes) = self.symbolic.raw() else {
            return; // System::new made sure it is
        };
        let n = self.texels.len();
        let columns: Vec<(usize, usize)> = fields
            .iter()
            .enumerate()
            .flat_map(|(f, (_, width))| (0..*width).map(move |c| (f, c)))
            .collect();
        let group = columns.len().div_ceil(rayon::current_num_threads().max(1));
        let baked: Vec<(&[f32], usize)> = fields.iter().map(|(v, w)| (&**v, *w)).collect();
        let solutions: Vec<Vec<f64>> = columns
            .par_chunks(group.max(1))
            .map(|group| {
                let k = group.len();
                let mut x = vec![0.0f64; n * k];
                for (row, &texel) in x.chunks_exact_mut(k).zip(&self.texels) {
                    for (x, &(f, c)) in row.iter_mut().zip(group) {
                        let (values, width) = baked[f];
                        *x = KEEP * f64::from(values[texel * width + c]);
                    }
                }
                solve_in_place(supernodes, &self.factor, &mut x, k);
                x
            })
            .collect();
        for (group, x) in columns.chunks(group.max(1)).zip(&solutions) {
            let k = group.len();
            for (row, &texel) in x.chunks_exact(k).zip(&self.texels) {
                for (&x, &(f, c)) in row.iter().zip(group) {
                    let (values, width) = &mut fields[f];
                    values[texel * *width + c] = x as f32;
                }
            }
        }
    }
}

/// L Lᵀ x = b for `k` right-hand sides at once, `x` row-major (n × k, in the factor's
/// order), supernode by supernode: each right-hand side sees the same operations in the
/// same order whatever `k` is (the loops over it only repeat them side by side).
fn solve_in_place(
    symbolic: &SymbolicSupernodalCholesky<u32>,
    values: &[f64],
    x: &mut [f64],
    k: usize,
) {
    let factor = SupernodalLltRef::new(symbolic, values);
    let count = symbolic.n_supernodes();
    let (mut top, mut below, mut sum) = (Vec::new(), Vec::new(), vec![0.0f64; k]);
    // Forward: L y = b.
    for s in 0..count {
        let node = factor.supernode(s);
        let (l, pattern, start) = (node.val(), node.pattern(), node.start());
        let size = l.ncols();
        top.clear();
        top.extend_from_slice(&x[start * k..(start + size) * k]);
        below.clear();
        below.resize(pattern.len() * k, 0.0);
        for c in 0..size {
            let column = column_slice(l, c);
            let (done, rest) = top.split_at_mut((c + 1) * k);
            let xc = &mut done[c * k..];
            for v in xc.iter_mut() {
                *v /= column[c];
            }
            for (&w, xr) in column[c + 1..size].iter().zip(rest.chunks_exact_mut(k)) {
                for (r, &v) in xr.iter_mut().zip(&*xc) {
                    *r -= w * v;
                }
            }
            for (&w, xr) in column[size..].iter().zip(below.chunks_exact_mut(k)) {
                for (r, &v) in xr.iter_mut().zip(&*xc) {
                    *r += w * v;
                }
            }
        }
        x[start * k..(start + size) * k].copy_from_slice(&top);
        for (&i, update) in pattern.iter().zip(below.chunks_exact(k)) {
            let i = i as usize;
            for (r, &v) in x[i * k..(i + 1) * k].iter_mut().zip(update) {
                *r -= v;
            }
        }
    }
    // Backward: Lᵀ x = y.
    for s in (0..count).rev() {
        let node = factor.supernode(s);
        let (l, pattern, start) = (node.val(), node.pattern(), node.start());
        let size = l.ncols();
        below.clear();
        for &i in pattern {
            let i = i as usize;
            below.extend_from_slice(&x[i * k..(i + 1) * k]);
        }
        top.clear();
        top.extend_from_slice(&x[start * k..(start + size) * k]);
        for c in (0..size).rev() {
            let column = column_slice(l, c);
            sum.fill(0.0);
            for (&w, xr) in column[size..].iter().zip(below.chunks_exact(k)) {
                for (a, &v) in sum.iter_mut().zip(xr) {
                    *a += w * v;
                }
            }
            let (head, solved) = top.split_at_mut((c + 1) * k);
            for (&w, xr) in column[c + 1..size].iter().zip(solved.chunks_exact(k)) {
                for (a, &v) in sum.iter_mut().zip(xr) {
                    *a += w * v;
                }
            }
            for (v, &a) in head[c * k..].iter_mut().zip(&sum) {
                *v = (*v - a) / column[c];
            }
        }
        x[start * k..(start + size) * k].copy_from_slice(&top);
    }
}

/// Column `c` of a supernode's values (faer stores them column-major, contiguous).
fn column_slice(l: MatRef<'_, f64>, c: usize) -> &[f64] {
    l.col(c)
        .try_as_col_major()
        .expect("faer's supernodes are column-major")
        .as_slice()
}

/// Columns of the stitching matrix assembled per parallel task.
const COLUMN_BLOCK: usize = 4096;

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit for bit, in f64: the stitched f32 values hide a last-bit difference, which is
    /// enough to make `stitch --columns` differ from the whole bake somewhere in a large
    /// lightmap.
    #[test]
    fn a_column_gets_the_same_bits_whatever_columns_share_its_pass() {
        // Texel i against a blend of two texels further on: one connected system.
        type Sample = ([(u32, f32); 2], [(u32, f32); 2]);
        let taps: Vec<Sample> = (0..1500u32)
            .map(|i| {
                let w = 0.1 + (i % 9) as f32 * 0.1;
                let (p, q) = ((i * 7) % 2000, (i * 13 + 5) % 2000);
                ([(i, w), (i + 1, 1.0 - w)], [(p, 0.5), (q, 0.5)])
            })
            .collect();
        let system =
            System::new(taps.len(), |s| (&taps[s].0[..], &taps[s].1[..])).expect("factored");
        let SymbolicCholeskyRaw::Supernodal(supernodes) = system.symbolic.raw() else {
            panic!("forced supernodal");
        };
        let n = system.texels.len();
        let rhs = |i: usize, c: usize| ((i * 31 + c * 17) % 101) as f64 / 101.0;
        let k = 3;
        let mut together: Vec<f64> = (0..n * k).map(|e| rhs(e / k, e % k)).collect();
        solve_in_place(supernodes, &system.factor, &mut together, k);
        for c in 0..k {
            let mut alone: Vec<f64> = (0..n).map(|i| rhs(i, c)).collect();
            solve_in_place(supernodes, &system.factor, &mut alone, 1);
            for (i, x) in alone.iter().enumerate() {
                assert_eq!(
                    x.to_bits(),
                    together[i * k + c].to_bits(),
                    "column {c}, unknown {i}"
                );
            }
        }
    }
}

//! The seam stitch's least-squares system ([`super::stitch`]), factored: the normal
//! equations (λI + CᵀC) x = λx̂ of the seam samples C, assembled in parallel, ordered and
//! factored by `faer` (sparse supernodal Cholesky), the factor then taken into our own form
//! ([`Factor`], which solves it).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::{
    factorize_supernodal_numeric_llt, factorize_supernodal_numeric_llt_scratch,
};
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::utils::{permute_self_adjoint_scratch, permute_self_adjoint_to_unsorted};
use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{Par, Side};
use rayon::prelude::*;

pub(super) use super::stitch_factor::{Factor, KEEP};

/// A seam sample's (texel, weight) taps on its two sides.
pub(super) type Taps<'s> = (&'s [(u32, f32)], &'s [(u32, f32)]);

impl Factor {
    /// C (one row per sample over the texels it reads) and its transpose, then the lower
    /// triangle of λI + CᵀC, factored. `sample(s)`: seam sample s's (texel, weight) taps on
    /// its two sides, for s in 0..`count` (a function, so that this module needs not know
    /// [`super::stitch::SeamSample`]). Indices are u32 (an unknown is a texel, and a texel
    /// index is u32 in the samples), which halves the ordering's workspace.
    pub(super) fn new<'s>(count: usize, sample: impl Fn(usize) -> Taps<'s>) -> Option<Factor> {
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
        // faer's factor in our own form ([`Factor`]): its values as they are (each supernode's
        // block column-major, one after another), its supernodes' starts and row patterns.
        let texels = order
            .arrays()
            .0
            .iter()
            .map(|&u| texels[u as usize] as u32)
            .collect();
        let count = supernodes.n_supernodes();
        let (mut starts, mut row_starts, mut rows) = (
            Vec::with_capacity(count + 1),
            Vec::with_capacity(count + 1),
            Vec::new(),
        );
        row_starts.push(0u64);
        for s in 0..count {
            let node = supernodes.supernode(s);
            starts.push(node.start() as u32);
            rows.extend_from_slice(node.pattern());
            row_starts.push(rows.len() as u64);
        }
        starts.push(n as u32);
        let offsets = supernodes.col_ptr_for_val();
        if offsets[0] != 0 {
            return None; // faer's blocks start at 0, one after another
        }
        let used = offsets[count] as usize;
        factor.truncate(used);
        Factor::from_parts(texels, starts, row_starts, rows, factor).ok()
    }
}

/// Columns of the stitching matrix assembled per parallel task.
const COLUMN_BLOCK: usize = 4096;

//! The seam stitch's Cholesky factor in a form of our own ([`Factor`]), taken from `faer`'s
//! after factoring ([`super::stitch_system`]) and solved here: so that it can be stored
//! (`prt-bake factor-seams`, `distribute::factor_file`) and read back by every stitch shard
//! instead of each factoring it again, and solved with the same arithmetic, the same bits.

use rayon::prelude::*;

/// Weight of keeping a texel's baked value against making the seams agree: small, so the
/// seams agree to a few per cent of their step, while texels move only as far as they must.
pub(super) const KEEP: f64 = 0.02;

/// L of L Lᵀ = λI + CᵀC, supernode by supernode, in the factor's (permuted) order.
#[derive(Clone, Debug, PartialEq)]
pub struct Factor {
    /// The lightmap texel of each unknown, in the factor's order.
    texels: Vec<u32>,
    /// Supernode s holds unknowns `starts[s]..starts[s + 1]`.
    starts: Vec<u32>,
    /// Supernode s's rows below its diagonal block: `rows[row_starts[s]..row_starts[s + 1]]`.
    row_starts: Vec<u64>,
    rows: Vec<u32>,
    /// Supernode s's values: its (size + rows) × size block, column-major, from
    /// `value_starts[s]` (derived from the sizes, not stored).
    values: Vec<f64>,
    value_starts: Vec<usize>,
}

impl Factor {
    /// The factor of these parts, refused (a message) where they do not fit together: a solve
    /// of a factor read from a file must not index out of bounds.
    pub fn from_parts(
        texels: Vec<u32>,
        starts: Vec<u32>,
        row_starts: Vec<u64>,
        rows: Vec<u32>,
        values: Vec<f64>,
    ) -> Result<Factor, String> {
        let n = texels.len();
        let count = starts.len().checked_sub(1).ok_or("no supernode starts")?;
        if row_starts.len() != count + 1 {
            return Err(format!(
                "{} row starts for {count} supernodes",
                row_starts.len()
            ));
        }
        if starts[0] != 0 || starts[count] as usize != n || row_starts[0] != 0 {
            return Err(format!(
                "supernodes cover unknowns {}..{}, not the {n} unknowns",
                starts[0], starts[count]
            ));
        }
        if row_starts[count] != rows.len() as u64 {
            return Err(format!(
                "{} rows below the supernodes, {} announced",
                rows.len(),
                row_starts[count]
            ));
        }
        let mut value_starts = Vec::with_capacity(count + 1);
        let mut total = 0usize;
        for s in 0..count {
            value_starts.push(total);
            let (start, end) = (starts[s] as usize, starts[s + 1] as usize);
            let (first, last) = (row_starts[s], row_starts[s + 1]);
            if end <= start || last < first {
                return Err(format!("supernode {s} is empty or runs backwards"));
            }
            let below = &rows[first as usize..last as usize];
            // Rows below the block, ascending, within the unknowns.
            let mut previous = end - 1;
            for &row in below {
                let row = row as usize;
                if row <= previous || row >= n {
                    return Err(format!(
                        "supernode {s}'s row {row} is out of order or range"
                    ));
                }
                previous = row;
            }
            let size = end - start;
            total = (size + below.len())
                .checked_mul(size)
                .and_then(|v| v.checked_add(total))
                .ok_or("sizes overflow")?;
        }
        value_starts.push(total);
        if values.len() != total {
            return Err(format!(
                "{} factor values, the supernodes hold {total}",
                values.len()
            ));
        }
        Ok(Factor {
            texels,
            starts,
            row_starts,
            rows,
            values,
            value_starts,
        })
    }

    /// The unknowns' texels, in the factor's order.
    pub fn texels(&self) -> &[u32] {
        &self.texels
    }
    pub fn starts(&self) -> &[u32] {
        &self.starts
    }
    pub fn row_starts(&self) -> &[u64] {
        &self.row_starts
    }
    pub fn rows(&self) -> &[u32] {
        &self.rows
    }
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The factor's nonzeros (as `faer` stores them: each supernode's block whole).
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are no unknowns.
    pub fn is_empty(&self) -> bool {
        self.texels.is_empty()
    }

    /// Supernode s: its first unknown, its rows below the block and its values.
    fn supernode(&self, s: usize) -> (usize, usize, &[u32], &[f64]) {
        let (start, end) = (self.starts[s] as usize, self.starts[s + 1] as usize);
        let rows = &self.rows[self.row_starts[s] as usize..self.row_starts[s + 1] as usize];
        let values = &self.values[self.value_starts[s]..self.value_starts[s + 1]];
        (start, end - start, rows, values)
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
    pub fn solve(&self, fields: &mut [(&mut [f32], usize)]) {
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
                        *x = KEEP * f64::from(values[texel as usize * width + c]);
                    }
                }
                self.solve_in_place(&mut x, k);
                x
            })
            .collect();
        for (group, x) in columns.chunks(group.max(1)).zip(&solutions) {
            let k = group.len();
            for (row, &texel) in x.chunks_exact(k).zip(&self.texels) {
                for (&x, &(f, c)) in row.iter().zip(group) {
                    let (values, width) = &mut fields[f];
                    values[texel as usize * *width + c] = x as f32;
                }
            }
        }
    }

    /// L Lᵀ x = b for `k` right-hand sides at once, `x` row-major (n × k, in the factor's
    /// order), supernode by supernode: each right-hand side sees the same operations in the
    /// same order whatever `k` is (the loops over it only repeat them side by side).
    pub(super) fn solve_in_place(&self, x: &mut [f64], k: usize) {
        let count = self.starts.len() - 1;
        let (mut top, mut below, mut sum) = (Vec::new(), Vec::new(), vec![0.0f64; k]);
        // Forward: L y = b.
        for s in 0..count {
            let (start, size, pattern, l) = self.supernode(s);
            let height = size + pattern.len();
            top.clear();
            top.extend_from_slice(&x[start * k..(start + size) * k]);
            below.clear();
            below.resize(pattern.len() * k, 0.0);
            for c in 0..size {
                let column = &l[c * height..(c + 1) * height];
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
            let (start, size, pattern, l) = self.supernode(s);
            let height = size + pattern.len();
            below.clear();
            for &i in pattern {
                let i = i as usize;
                below.extend_from_slice(&x[i * k..(i + 1) * k]);
            }
            top.clear();
            top.extend_from_slice(&x[start * k..(start + size) * k]);
            for c in (0..size).rev() {
                let column = &l[c * height..(c + 1) * height];
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
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A factor of `faer`'s ([`super::super::stitch_system`]) of a connected system.
    fn factored() -> Factor {
        // Texel i against a blend of two texels further on: one connected system.
        type Sample = ([(u32, f32); 2], [(u32, f32); 2]);
        let taps: Vec<Sample> = (0..1500u32)
            .map(|i| {
                let w = 0.1 + (i % 9) as f32 * 0.1;
                let (p, q) = ((i * 7) % 2000, (i * 13 + 5) % 2000);
                ([(i, w), (i + 1, 1.0 - w)], [(p, 0.5), (q, 0.5)])
            })
            .collect();
        Factor::new(taps.len(), |s| (&taps[s].0[..], &taps[s].1[..])).expect("factored")
    }

    /// Bit for bit, in f64: the stitched f32 values hide a last-bit difference, which is
    /// enough to make `stitch --columns` differ from the whole bake somewhere in a large
    /// lightmap.
    #[test]
    fn a_column_gets_the_same_bits_whatever_columns_share_its_pass() {
        let factor = factored();
        let n = factor.texels.len();
        let rhs = |i: usize, c: usize| ((i * 31 + c * 17) % 101) as f64 / 101.0;
        let k = 3;
        let mut together: Vec<f64> = (0..n * k).map(|e| rhs(e / k, e % k)).collect();
        factor.solve_in_place(&mut together, k);
        for c in 0..k {
            let mut alone: Vec<f64> = (0..n).map(|i| rhs(i, c)).collect();
            factor.solve_in_place(&mut alone, 1);
            for (i, x) in alone.iter().enumerate() {
                assert_eq!(
                    x.to_bits(),
                    together[i * k + c].to_bits(),
                    "column {c}, unknown {i}"
                );
            }
        }
    }

    #[test]
    fn parts_that_do_not_fit_are_refused() {
        let f = factored();
        let parts = || {
            (
                f.texels.clone(),
                f.starts.clone(),
                f.row_starts.clone(),
                f.rows.clone(),
                f.values.clone(),
            )
        };
        let (t, s, rs, r, v) = parts();
        assert_eq!(Factor::from_parts(t, s, rs, r, v).as_ref(), Ok(&f));
        let (t, s, rs, r, mut v) = parts();
        v.pop();
        assert!(Factor::from_parts(t, s, rs, r, v).is_err(), "a value short");
        let (mut t, s, rs, r, v) = parts();
        t.pop();
        assert!(
            Factor::from_parts(t, s, rs, r, v).is_err(),
            "an unknown short"
        );
        let (t, s, rs, mut r, v) = parts();
        let last = r.len() - 1;
        r[last] = f.texels.len() as u32;
        assert!(
            Factor::from_parts(t, s, rs, r, v).is_err(),
            "a row out of range"
        );
        let (t, mut s, rs, r, v) = parts();
        s[1] = s[0];
        assert!(
            Factor::from_parts(t, s, rs, r, v).is_err(),
            "an empty supernode"
        );
    }
}

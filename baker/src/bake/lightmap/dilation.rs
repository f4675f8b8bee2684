//! Dilation: baked texels spread into the empty texels around them, so bilinear filtering
//! (the renderer's, and a bounce hit's lookup) never reads an empty texel at a chart's edge.
//!
//! Which texels are filled, and from which neighbours, depends only on which texels are
//! baked; [`dilate_with`] walks those fills in a fixed order and the callers average whatever
//! they hold (coefficients, visibility) over the sources.

use rayon::prelude::*;

use super::texels::Texels;

/// Padding texels around each chart that dilation fills: bilinear filtering at a chart's
/// edge reads one texel beyond it, mipmapping further.
pub const DILATION: usize = 2;

/// Walks [`DILATION`] rings: each ring gives every empty texel that touches (8-neighbourhood)
/// a texel filled before the ring the mean of those neighbours. Calls `fill(texel, sources)`
/// for each texel it fills, row by row within a ring, with the sources in a fixed neighbour
/// order; a texel filled in a ring is never a source in that ring. Charts are packed at least
/// `atlas::PADDING` = 2 texels apart, so the first ring of one chart never mixes in its
/// neighbour. Returns which texels were filled.
pub fn dilate_with(texels: &Texels, mut fill: impl FnMut(usize, &[usize])) -> Vec<bool> {
    let w = texels.width as usize;
    dilate_rings(texels, |ring| {
        for f in ring {
            let (sources, count) = f.sources(w);
            fill(f.texel as usize, &sources[..count]);
        }
    })
}

/// A texel one ring fills: its index and which of its [`NEIGHBOURS`] are its sources (bit k:
/// neighbour k). Eight bytes, where a list of sources took 72: a large atlas's first ring
/// fills millions of texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fill {
    pub texel: u32,
    sources: u8,
}

impl Fill {
    /// The sources' texel indices in neighbour order (a `w`-wide lightmap), and how many.
    pub fn sources(&self, w: usize) -> ([usize; 8], usize) {
        let (mut out, mut count) = ([0usize; 8], 0);
        let i = self.texel as usize;
        for (k, (dx, dy)) in NEIGHBOURS.iter().enumerate() {
            if self.sources & (1 << k) != 0 {
                out[count] = (i as isize + dy * w as isize + dx) as usize;
                count += 1;
            }
        }
        (out, count)
    }
}

/// [`dilate_with`] a ring at a time: `fill_ring` gets each ring's fills in row order, all
/// of whose sources were filled before the ring, so a ring's means may be computed in any
/// order. Finding the fills runs in parallel over blocks of rows, gathered in row order.
pub fn dilate_rings(texels: &Texels, mut fill_ring: impl FnMut(&[Fill])) -> Vec<bool> {
    let (w, h) = (texels.width as usize, texels.height as usize);
    let mut filled = texels.valid.clone();
    let mut dilated = vec![false; w * h];
    for _ in 0..DILATION {
        let ring: Vec<Fill> = (0..h.div_ceil(ROW_BLOCK))
            .into_par_iter()
            .flat_map_iter(|b| {
                let mut fills = Vec::new();
                for y in b * ROW_BLOCK..h.min((b + 1) * ROW_BLOCK) {
                    row_fills(&filled, w, h, y, &mut fills);
                }
                fills
            })
            .collect();
        fill_ring(&ring);
        for f in &ring {
            filled[f.texel as usize] = true;
            dilated[f.texel as usize] = true;
        }
    }
    dilated
}

/// Rows per parallel task of [`dilate_rings`]: a row is too little work for a task.
const ROW_BLOCK: usize = 64;

/// Appends the fills of row `y` of a `w` × `h` lightmap whose texels `before` hold a value to
/// `fills`, in order. The rows above and below are read as three-texel windows, without a
/// bounds test per neighbour (a missing row or column reads as empty).
fn row_fills(before: &[bool], w: usize, h: usize, y: usize, fills: &mut Vec<Fill>) {
    let row = |r: Option<usize>| r.filter(|&r| r < h).map(|r| &before[r * w..(r + 1) * w]);
    let (up, mid, down) = (
        row(y.checked_sub(1)),
        row(Some(y)).expect("a row"),
        row(Some(y + 1)),
    );
    // Bit k of a window: neighbour k of NEIGHBOURS in that row (left, centre, right).
    let at = |r: &[bool], x: usize| -> u8 {
        let left = x.checked_sub(1).is_some_and(|l| r[l]);
        let right = r.get(x + 1).copied().unwrap_or(false);
        u8::from(left) | u8::from(r[x]) << 1 | u8::from(right) << 2
    };
    for x in 0..w {
        if mid[x] {
            continue;
        }
        let above = up.map_or(0, |r| at(r, x));
        let beside = at(mid, x);
        let below = down.map_or(0, |r| at(r, x));
        // NEIGHBOURS: three above (bits 0..3), left and right (3, 4), three below (5..8).
        let sources = above | (beside & 1) << 3 | (beside >> 2) << 4 | below << 5;
        if sources != 0 {
            fills.push(Fill {
                texel: (y * w + x) as u32,
                sources,
            });
        }
    }
}

/// Dilates `values` (`n` floats per texel, W·H texels) in place; returns which texels were
/// filled.
pub fn dilate_values(texels: &Texels, n: usize, values: &mut [f32]) -> Vec<bool> {
    let w = texels.width as usize;
    dilate_rings(texels, |ring| mean_ring(ring, w, n, values))
}

/// Each fill's `n` values become the mean of its sources' (summed in their order), in
/// place, one fill after another: a ring's sources are never its targets, so the order does
/// not matter, and a mean of a few short rows is too little work to share out (the parallel
/// version, which computed blocks of means apart and copied them in, cost more CPU).
pub fn mean_ring(ring: &[Fill], w: usize, n: usize, values: &mut [f32]) {
    if n == 0 {
        return;
    }
    let mut mean = vec![0.0f32; n];
    let offsets = NEIGHBOURS.map(|(dx, dy)| dy * w as isize + dx);
    for f in ring {
        let i = f.texel as usize;
        mean.fill(0.0);
        // The sources in neighbour order: the set bits, lowest first.
        let (mut bits, count) = (f.sources, f.sources.count_ones());
        while bits != 0 {
            let j = i.wrapping_add_signed(offsets[bits.trailing_zeros() as usize]);
            bits &= bits - 1;
            for (s, c) in mean.iter_mut().zip(&values[j * n..(j + 1) * n]) {
                *s += c;
            }
        }
        for (v, s) in values[i * n..(i + 1) * n].iter_mut().zip(&mean) {
            *v = s / count as f32;
        }
    }
}

/// Fills per block of [`mean_ring`].
pub const RING_BLOCK: usize = 1 << 15;

/// Texel `i`'s `n` values become the mean of the `sources`' (summed in their order).
pub fn mean_into(values: &mut [f32], n: usize, i: usize, sources: &[usize]) {
    let mut sum = vec![0.0f32; n];
    for &j in sources {
        for (s, c) in sum.iter_mut().zip(&values[j * n..(j + 1) * n]) {
            *s += c;
        }
    }
    for (c, s) in values[i * n..(i + 1) * n].iter_mut().zip(&sum) {
        *c = s / sources.len() as f32;
    }
}

const NEIGHBOURS: [(isize, isize); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Dilation as it was first written: a ring at a time, every neighbour tested against
    /// the lightmap's bounds, each mean summed in neighbour order.
    fn reference(valid: &[bool], w: usize, h: usize, n: usize, values: &mut [f32]) -> Vec<bool> {
        let mut filled = valid.to_vec();
        let mut dilated = vec![false; w * h];
        for _ in 0..DILATION {
            let before = filled.clone();
            for y in 0..h {
                for x in 0..w {
                    let i = y * w + x;
                    if before[i] {
                        continue;
                    }
                    let mut sources = Vec::new();
                    for (dx, dy) in NEIGHBOURS {
                        let (nx, ny) = (x as isize + dx, y as isize + dy);
                        if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                            continue;
                        }
                        let j = ny as usize * w + nx as usize;
                        if before[j] {
                            sources.push(j);
                        }
                    }
                    if !sources.is_empty() {
                        mean_into(values, n, i, &sources);
                        filled[i] = true;
                        dilated[i] = true;
                    }
                }
            }
        }
        dilated
    }

    #[test]
    fn dilation_equals_a_neighbour_by_neighbour_search_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        // Edges, single rows and columns, and more rows than a parallel block.
        let sizes = [
            (1, 1),
            (1, 9),
            (9, 1),
            (3, 5),
            (17, 2),
            (67, 150),
            (130, 70),
        ];
        for (w, h) in sizes {
            for density in [2, 10, 40] {
                let valid: Vec<bool> = (0..w * h).map(|_| next() % 100 < density).collect();
                let n = 3;
                let mut values: Vec<f32> = (0..w * h * n)
                    .map(|k| {
                        if valid[k / n] {
                            (next() % 1000) as f32 / 7.0
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let mut expected = values.clone();
                let texels = Texels::mask(w as u32, h as u32, valid.clone());
                let dilated = dilate_values(&texels, n, &mut values);
                let expected_dilated = reference(&valid, w, h, n, &mut expected);
                assert_eq!(dilated, expected_dilated, "{w}×{h}, {density}% baked");
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&values), bits(&expected), "{w}×{h}, {density}% baked");
            }
        }
    }
}

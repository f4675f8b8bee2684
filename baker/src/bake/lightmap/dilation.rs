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
/// order (in parallel). Finding the fills runs in parallel over rows, gathered in row order.
pub fn dilate_rings(texels: &Texels, mut fill_ring: impl FnMut(&[Fill])) -> Vec<bool> {
    let (w, h) = (texels.width as usize, texels.height as usize);
    let mut filled = texels.valid.clone();
    let mut dilated = vec![false; w * h];
    for _ in 0..DILATION {
        let ring: Vec<Fill> = (0..h)
            .into_par_iter()
            .flat_map_iter(|y| row_fills(&filled, w, h, y))
            .collect();
        fill_ring(&ring);
        for f in &ring {
            filled[f.texel as usize] = true;
            dilated[f.texel as usize] = true;
        }
    }
    dilated
}

/// The fills of row `y` of a `w` × `h` lightmap whose texels `before` hold a value.
fn row_fills(before: &[bool], w: usize, h: usize, y: usize) -> Vec<Fill> {
    let mut fills = Vec::new();
    for x in 0..w {
        let i = y * w + x;
        if before[i] {
            continue;
        }
        let mut sources = 0u8;
        for (k, (dx, dy)) in NEIGHBOURS.iter().enumerate() {
            let (nx, ny) = (x as isize + dx, y as isize + dy);
            if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                continue;
            }
            if before[ny as usize * w + nx as usize] {
                sources |= 1 << k;
            }
        }
        if sources != 0 {
            fills.push(Fill {
                texel: i as u32,
                sources,
            });
        }
    }
    fills
}

/// Dilates `values` (`n` floats per texel, W·H texels) in place; returns which texels were
/// filled.
pub fn dilate_values(texels: &Texels, n: usize, values: &mut [f32]) -> Vec<bool> {
    let w = texels.width as usize;
    dilate_rings(texels, |ring| mean_ring(ring, w, n, values))
}

/// Each fill's `n` values become the mean of its sources' (summed in their order): a block
/// of fills at a time, computed in parallel, then written (a ring's sources are never its
/// targets, so the order does not matter; blocks keep the buffer small).
pub fn mean_ring(ring: &[Fill], w: usize, n: usize, values: &mut [f32]) {
    if n == 0 {
        return;
    }
    let mut means = vec![0.0f32; RING_BLOCK.min(ring.len()) * n];
    for block in ring.chunks(RING_BLOCK) {
        let means = &mut means[..block.len() * n];
        let source = &*values;
        means
            .par_chunks_mut(n)
            .zip(block.par_iter())
            .for_each(|(mean, f)| {
                let (sources, count) = f.sources(w);
                mean.fill(0.0);
                for &j in &sources[..count] {
                    for (s, c) in mean.iter_mut().zip(&source[j * n..(j + 1) * n]) {
                        *s += c;
                    }
                }
                for s in mean.iter_mut() {
                    *s /= count as f32;
                }
            });
        for (f, mean) in block.iter().zip(means.chunks_exact(n)) {
            let i = f.texel as usize;
            values[i * n..(i + 1) * n].copy_from_slice(mean);
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

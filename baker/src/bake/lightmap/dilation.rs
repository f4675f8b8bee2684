//! Dilation: baked texels spread into the empty texels around them, so bilinear filtering
//! (the renderer's, and a bounce hit's lookup) never reads an empty texel at a chart's edge.
//!
//! Which texels are filled, and from which neighbours, depends only on which texels are
//! baked; [`dilate_with`] walks those fills in a fixed order and the callers average whatever
//! they hold (coefficients, visibility) over the sources.

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
    let (w, h) = (texels.width as usize, texels.height as usize);
    let mut filled = texels.valid.clone();
    let mut dilated = vec![false; w * h];
    for _ in 0..DILATION {
        let before = filled.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if before[i] {
                    continue;
                }
                let (mut sources, mut count) = ([0usize; 8], 0);
                for (dx, dy) in NEIGHBOURS {
                    let (nx, ny) = (x as isize + dx, y as isize + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if before[j] {
                        sources[count] = j;
                        count += 1;
                    }
                }
                if count == 0 {
                    continue;
                }
                fill(i, &sources[..count]);
                filled[i] = true;
                dilated[i] = true;
            }
        }
    }
    dilated
}

/// Dilates `values` (`n` floats per texel, W·H texels) in place; returns which texels were
/// filled.
pub fn dilate_values(texels: &Texels, n: usize, values: &mut [f32]) -> Vec<bool> {
    dilate_with(texels, |i, sources| mean_into(values, n, i, sources))
}

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

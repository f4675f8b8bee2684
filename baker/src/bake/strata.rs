//! Jointly stratified point sets for denoised bakes: neighbouring receivers sample
//! complementary parts of one Owen-scrambled Sobol sequence, so that the denoiser's average
//! over them integrates like a point set many times larger.
//!
//! A bake that is not denoised samples every receiver with one scrambled (0, m, 2)-net,
//! turned about the normal by an angle of its own, so that its errors are independent of
//! its neighbours'. That is what a raw bake wants, and it wastes what a filter could gain:
//! the filter's average over 100 texels of independent 64-point estimates has the error of
//! 64 points, divided by √100. Given the 16 texels of a 4 × 4 tile the 16 consecutive
//! blocks of 64 points of one sequence instead (each block is itself a scrambled net, so a
//! texel alone estimates exactly as well as before), the tile's texels together hold a
//! 1,024-point net, whose error on the visibility's edges falls faster than √N; their
//! errors are complementary, high in spatial frequency, and a filter removes them better
//! (blue-noise sampling: Georgiev & Fajardo 2016, *Blue-noise dithered sampling*; Heitz &
//! Belcour 2019, *Distributing Monte Carlo errors as a blue noise in screen space*; the nets
//! and their scrambling: Owen 1997). The tiles' texels share their frame (no turn), as the
//! blocks are complementary in one frame only. Tiles draw one of [`MAX_GROUPS`] sequences
//! (each its own scramble) at random: tiles with one sequence would repeat one another's
//! errors every 4 texels, a pattern wider than the tile that the filter would not average.
//! A mesh has no tiles: its vertices take 16 consecutive ranks of a Morton order in space
//! for one ([`vertex_strata`]). Transfer matrices sample the same sets, set for set, from
//! tables of their own ([`crate::bake::matrix`]), whose size sets their groups
//! ([`crate::bake::memory::set_bytes`]); [`crate::bake::estimator::Estimator::set`] says
//! which set a receiver takes, for both.
//!
//! Measured on the Cornell room at 256², 64 rays, denoised, under a sun and sky / a low sun
//! / a sky (docs/explanation/denoising-record.md): 1.27 / 1.03 / 0.86 % with independent texels,
//! 0.99 / 0.84 / 0.70 % with joint strata; 16 sets in a single sequence for every tile
//! gave 1.12 / 0.96 / 0.76 %, 16 independently scrambled sets 1.21 / 0.97 / 0.82 %.
//! The raw error of each texel is unchanged (8.8 against 8.6 %, one seed). The torus's
//! vertices, `--denoise on`: 1.46 / 3.98 / 0.88 % -> 1.29 / 3.51 / 0.80 %; the glossy
//! torus's transfer matrices (RMS of the entries, seeds 1 / 2): 2.25 / 2.25 % -> 1.95 /
//! 1.98 %, unfiltered 9.46 / 9.38 % -> 9.64 / 9.70 %.

use glam::Vec3;

use crate::bake::options::BakeOptions;
use crate::math::sampling::vertex_seed;

/// Texels a tile spans each way.
const TILE: u32 = 4;
/// The sets of one group: one per texel of a tile, consecutive blocks of one sequence.
pub const SETS_PER_GROUP: u32 = TILE * TILE;
/// At most this many groups (independently scrambled sequences) for the tiles to draw from.
const MAX_GROUPS: u32 = 16;
/// The most the sample tables of the joint sets may take beyond the one set of a bake that
/// is not denoised: fewer groups where larger tables (many samples, a high order) need it.
const BUDGET: u64 = 64 << 20;

/// The groups of sets a bake with `options` and tables of `set_bytes` per set (vector or
/// matrix tables: [`crate::bake::memory::set_bytes`]) samples from: 0 where its receivers
/// sample independently (no denoising, or not even one group fits).
pub fn groups(options: &BakeOptions, set_bytes: u64) -> u32 {
    if !samples_jointly(options) {
        return 0;
    }
    let group = set_bytes.saturating_mul(u64::from(SETS_PER_GROUP)).max(1);
    (BUDGET / group).min(u64::from(MAX_GROUPS)) as u32
}

/// The sample sets a bake samples from with `groups` groups: every group's sets, or the one
/// set of a bake whose receivers sample independently (0 groups).
pub fn set_count(groups: u32) -> u32 {
    (groups * SETS_PER_GROUP).max(1)
}

/// Whether a bake with `options` may sample its receivers jointly: a denoised bake, of
/// transfer vectors or matrices.
pub fn samples_jointly(options: &BakeOptions) -> bool {
    options.denoise
}

/// Each of `valid` texels' (indices y · `width` + x) stratum: its tile's index times
/// [`SETS_PER_GROUP`] plus its place in the tile, in Morton order (the tile's 2 × 2 quads
/// take four consecutive blocks, a net of their own). A function of the texel alone, so a
/// shard or a subset samples a texel as the whole bake does.
pub fn texel_strata(valid: &[usize], width: u32) -> Vec<u32> {
    let tiles_across = width.div_ceil(TILE) as usize;
    valid
        .iter()
        .map(|&i| {
            let (x, y) = (i % width as usize, i / width as usize);
            let tile = (y / TILE as usize) * tiles_across + x / TILE as usize;
            let (x, y) = (x as u32 % TILE, y as u32 % TILE);
            let morton = (x & 1) | ((y & 1) << 1) | ((x & 2) << 1) | ((y & 2) << 2);
            tile as u32 * SETS_PER_GROUP + morton
        })
        .collect()
}

/// Each vertex's stratum: its rank in a Morton order of the points (a 1,024³ grid over
/// their bounds, ties in index order), so that 16 consecutive ranks, mostly neighbours,
/// share a group as a texel tile does. Computed over the whole mesh: a subset of the
/// vertices picks its own.
pub fn vertex_strata(points: &[Vec3]) -> Vec<u32> {
    let (low, high) = points.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(low, high), p| (low.min(*p), high.max(*p)),
    );
    let scale = 1023.0 / (high - low).max_element().max(1e-30);
    // The bits of a 10-bit coordinate spread three apart.
    let spread = |x: u32| {
        let mut x = u64::from(x & 0x3ff);
        x = (x | (x << 16)) & 0x0300_00ff;
        x = (x | (x << 8)) & 0x0300_f00f;
        x = (x | (x << 4)) & 0x030c_30c3;
        (x | (x << 2)) & 0x0924_9249
    };
    let mut keys: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let q = ((*p - low) * scale).as_uvec3();
            (spread(q.x) | spread(q.y) << 1 | spread(q.z) << 2, i as u32)
        })
        .collect();
    keys.sort_unstable();
    let mut strata = vec![0; points.len()];
    for (rank, &(_, i)) in keys.iter().enumerate() {
        strata[i as usize] = rank as u32;
    }
    strata
}

/// The set a receiver of `stratum` samples, among `groups` × [`SETS_PER_GROUP`]: its
/// tile's group, drawn from (seed, tile), and its place in the tile.
pub fn set_of(seed: u64, stratum: u32, groups: u32) -> usize {
    let (tile, place) = (stratum / SETS_PER_GROUP, stratum % SETS_PER_GROUP);
    let group = vertex_seed(seed ^ 0x7374_7261_7461, u64::from(tile)) % u64::from(groups.max(1));
    (group as u32 * SETS_PER_GROUP + place) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiles_texels_take_every_set_of_its_group_once() {
        let width = 10;
        let valid: Vec<usize> = (0..width as usize * 8).collect();
        let strata = texel_strata(&valid, width);
        for (tile_x, tile_y) in [(0, 0), (1, 1)] {
            let mut sets: Vec<usize> = (0..16)
                .map(|k| (tile_y * 4 + k / 4) * width as usize + tile_x * 4 + k % 4)
                .map(|i| set_of(7, strata[i], 16))
                .collect();
            let group = sets[0] / 16;
            sets.sort_unstable();
            assert_eq!(sets, (group * 16..group * 16 + 16).collect::<Vec<_>>());
        }
        // A 2 × 2 quad at a tile's corner takes four consecutive blocks.
        let quad: Vec<u32> = [0, 1, 10, 11].map(|i| strata[i] % 16).to_vec();
        assert_eq!(quad, vec![0, 1, 2, 3]);
    }

    #[test]
    fn vertices_close_in_space_take_close_ranks() {
        // Two clusters of 16 points far apart: each takes 16 consecutive ranks.
        let points: Vec<Vec3> = (0..32)
            .map(|i| {
                let base = if i % 2 == 0 {
                    Vec3::ZERO
                } else {
                    Vec3::splat(10.0)
                };
                base + Vec3::new((i / 2 % 4) as f32, (i / 8) as f32, 0.0) * 0.01
            })
            .collect();
        let strata = vertex_strata(&points);
        let tiles: Vec<u32> = strata.iter().map(|s| s / SETS_PER_GROUP).collect();
        assert!(tiles.iter().step_by(2).all(|&t| t == tiles[0]));
        assert!(tiles.iter().skip(1).step_by(2).all(|&t| t == tiles[1]));
        assert_ne!(tiles[0], tiles[1]);
    }

    #[test]
    fn only_denoised_bakes_sample_jointly_matrices_too_and_large_tables_take_fewer_groups() {
        let mut options = BakeOptions::default();
        assert_eq!(groups(&options, 1000), 0);
        options.denoise = true;
        assert_eq!(groups(&options, 1000), MAX_GROUPS);
        let matrices = BakeOptions {
            transfer: crate::bake::options::TransferKind::Matrix,
            ..options.clone()
        };
        assert_eq!(groups(&matrices, 1000), MAX_GROUPS);
        assert_eq!(groups(&options, BUDGET / 32), 2);
        assert_eq!(groups(&options, BUDGET), 0);
    }
}

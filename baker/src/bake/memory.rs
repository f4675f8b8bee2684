//! What a bake will need in memory, estimated from its options before anything is
//! allocated, so that `--max-memory` refuses a bake that cannot fit instead of letting the
//! system kill it halfway ([`crate::support::limits`] holds the limit itself).

use crate::bake::bounce_rows::BYTES_PER_ENTRY;
use crate::bake::options::{BakeOptions, Mode, TransferKind};
use crate::math::sh;
use crate::support::error::{Error, Result};
use crate::support::limits::check;

/// An upper bound of a bake's memory: the scene, the tracer's acceleration structure, the
/// sample tables, the coefficients (computed, packed and written) and, interreflected, the
/// bounce buffers, each thread's row accumulator and the hit cache at most at its limit.
/// `vertices` counts receivers and slots: a texel bake passes its W·H texels plus the
/// scene's vertices. None if it overflows.
pub fn bake_bytes(options: &BakeOptions, vertices: u64, triangles: u64) -> Option<u64> {
    let n = sh::coeff_count(options.order) as u64;
    // A denoised bake's joint sets: up to 256 tables ([`crate::bake::strata`]), or one; a
    // matrix bake's are matrix tables, beside the vector estimator's one set.
    let one = set_bytes(options)?;
    let sets = crate::bake::strata::set_count(crate::bake::strata::groups(options, one));
    let tables = one.checked_mul(u64::from(sets))?;
    let tables = match options.transfer {
        TransferKind::Vector => tables,
        TransferKind::Matrix => tables.checked_add(table_bytes(options)?)?,
    };
    // Positions, normals, uvs, material, ray origins; triangles and a BVH of ~3 nodes each.
    let scene = vertices
        .checked_mul(64)?
        .checked_add(triangles.checked_mul(12 + 3 * 64)?)?;
    let channels = if options.mode == Mode::Interreflected {
        3
    } else {
        1
    };
    // The coefficients three times over: the bake's, the file's copy and its bytes.
    // A matrix bake stores n² × n² floats per channel.
    let per_channel = options.transfer.floats_per_channel(options.order) as u64;
    let coefficients = vertices
        .checked_mul(channels * per_channel * 4)?
        .checked_mul(3)?;
    let bounce = match options.mode {
        Mode::Interreflected => {
            // Hit cache: up to three (slot, weight) entries of 16 bytes per bounce ray for a
            // vertex, one hit of at most 16 bytes for a texel, dropped beyond the cache's limit.
            let rows = vertices
                .checked_mul(u64::from(options.effective_bounce_samples()))?
                .checked_mul(3 * BYTES_PER_ENTRY)?;
            // Each thread accumulates one row at a time, sparsely: a slot, an RGB weight and
            // a hash-map entry (≤ 32 bytes) for each of up to four entries per bounce ray.
            let builders = u64::from(options.effective_bounce_samples())
                .checked_mul(4 * 32 * rayon::current_num_threads() as u64)?;
            // Previous bounce, next bounce, total; a texel bake's previous bounce is also
            // spread over its lightmap, and its total placed there.
            vertices
                .checked_mul(3 * n * 4 * 5)?
                .checked_add(builders)?
                .checked_add(rows.min(options.hit_cache_limit))?
        }
        _ => 0,
    };
    tables
        .checked_add(scene)?
        .checked_add(coefficients)?
        .checked_add(bounce)
}

/// The estimator's sample tables: per sample its local direction (12 bytes), its row of n² SH
/// values and the direction again (4 n² + 12 bytes), and the sort key while they are built
/// (12 bytes). None if it overflows.
pub(crate) fn table_bytes(options: &BakeOptions) -> Option<u64> {
    let n = sh::coeff_count(options.order) as u64;
    u64::from(options.samples).checked_mul(36 + 4 * n)
}

/// One sample set's tables, the unit of a denoised bake's joint sets: the vector
/// estimator's ([`table_bytes`]) or a matrix bake's ([`crate::bake::matrix_layout`]).
pub(crate) fn set_bytes(options: &BakeOptions) -> Option<u64> {
    match options.transfer {
        TransferKind::Vector => table_bytes(options),
        TransferKind::Matrix => crate::bake::matrix_layout::table_bytes(options),
    }
}

/// Refuses `--samples` and `--order` whose sample tables alone cannot fit, before the scene
/// is even read (a bad command line: [`Error::InvalidOption`]).
pub fn check_bake_options(options: &BakeOptions) -> Result<()> {
    let n = sh::coeff_count(options.order) as u64;
    check(
        "--samples",
        &format!(
            "{} samples at order {} ({n} SH values per sample)",
            options.samples, options.order
        ),
        table_bytes(options),
    )
    .map_err(|err| Error::InvalidOption(err.to_string()))
}

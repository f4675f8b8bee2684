//! Bakes that outgrow one run: [`shard`] parts baked on many machines ([`part_baker`]),
//! [`checkpoint`] blocks that survive a kill, and the [`merge`] that joins parts into the very
//! file one machine would have written; vertex, texel and probe bakes alike
//! ([`lightmap_parts`], [`probe_parts`]).
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`], [`crate::trace`],
//! [`crate::formats`], [`crate::bake`].

pub mod big_reads;
pub mod bounce_stages;
pub mod checkpoint;
pub mod column_join;
pub mod factor_file;
pub mod lightmap_parts;
pub mod merge;
pub mod part_baker;
pub mod part_encoding;
pub mod part_guides;
pub mod prepared_file;
pub mod probe_parts;
pub mod probe_shards;
pub mod row_encoding;
pub mod shard;
pub mod stitch_columns;

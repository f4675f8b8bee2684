//! Bakes that outgrow one run: [`shard`] parts baked on many machines, [`checkpoint`] blocks
//! that survive a kill, and the [`merge`] that joins parts into the very file one machine
//! would have written.
//!
//! May import: [`crate::support`], [`crate::math`], [`crate::scene`], [`crate::trace`],
//! [`crate::formats`], [`crate::bake`].

pub mod checkpoint;
pub mod merge;
pub mod shard;

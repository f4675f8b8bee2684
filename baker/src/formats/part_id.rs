//! The shard identity in header bytes 88..108: which shard of a bake a part file holds and
//! which of its vertices (or texels). All zero in a whole bake, so the coefficient-file
//! reader can refuse parts without knowing how they are baked ([`crate::distribute::shard`]).

use std::fmt;
use std::ops::Range;

use serde::Serialize;

/// Which of how many shards: `index` in 0..`count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ShardId {
    pub index: u32,
    pub count: u32,
}

impl fmt::Display for ShardId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "shard {} of {}", self.index, self.count)
    }
}

/// What header bytes 88..108 say: which shard a part belongs to and which vertices it holds
/// (a shard's range, or a checkpoint block of it). All zero in a whole bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PartId {
    pub shard: ShardId,
    /// First vertex held.
    pub first_vertex: u64,
    /// Vertices held.
    pub vertices: u32,
}

impl fmt::Display for PartId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let range = self.range();
        write!(f, "{}, vertices {}..{}", self.shard, range.start, range.end)
    }
}

/// Offset of the shard identity in the header.
const ID_OFFSET: usize = 88;

impl PartId {
    pub fn range(&self) -> Range<usize> {
        let first = self.first_vertex as usize;
        first..first + self.vertices as usize
    }

    /// The 20 header bytes: u32 shard count (never 0), u32 shard index, u64 first vertex,
    /// u32 vertex count.
    pub fn to_bytes(self) -> [u8; 20] {
        let mut bytes = [0; 20];
        bytes[0..4].copy_from_slice(&self.shard.count.to_le_bytes());
        bytes[4..8].copy_from_slice(&self.shard.index.to_le_bytes());
        bytes[8..16].copy_from_slice(&self.first_vertex.to_le_bytes());
        bytes[16..20].copy_from_slice(&self.vertices.to_le_bytes());
        bytes
    }

    /// The identity in a file's header (at least 128 bytes): `None` for a whole bake.
    pub fn from_header_bytes(bytes: &[u8]) -> std::result::Result<Option<PartId>, String> {
        let id = &bytes[ID_OFFSET..ID_OFFSET + 20];
        if id.iter().all(|&b| b == 0) {
            return Ok(None);
        }
        let u32_at = |o: usize| u32::from_le_bytes(id[o..o + 4].try_into().expect("4 bytes"));
        let (count, index) = (u32_at(0), u32_at(4));
        if index >= count {
            return Err(format!(
                "shard identity {index} of {count}: the index must be below the count"
            ));
        }
        Ok(Some(PartId {
            shard: ShardId { index, count },
            first_vertex: u64::from_le_bytes(id[8..16].try_into().expect("8 bytes")),
            vertices: u32_at(16),
        }))
    }
}

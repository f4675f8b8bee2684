//! A part file's bytes in pieces ([`Encoded`]): its arrays borrowed, its bounce rows encoded
//! once. A texel shard's part is 145 MB at 2048² (rows, mostly); building it as one payload,
//! copying that behind the header and then again to insert the texel block, and summing it
//! twice cost every shard several copies of the file in fresh memory.

use glam::Vec3;

use crate::distribute::lightmap_parts::BLOCK_BYTES;
use crate::distribute::part_guides::guide_bytes;
#[cfg(doc)]
use crate::distribute::row_encoding::encode_jobs;
use crate::distribute::row_encoding::{EncodedRows, row_bytes};
use crate::distribute::shard::Part;
use crate::formats::coefficient_file;
use crate::formats::encoded::Encoded;
use crate::formats::header::HEADER_SIZE;

impl Part {
    /// The part file's bytes in pieces, the checksum set: the bytes of
    /// [`Part::to_bytes`].
    pub fn encode(&self) -> Encoded<'_> {
        self.encode_with(self.rows.as_ref().map(row_bytes))
    }

    /// [`Part::encode`] with its bounce rows already encoded (`rows`, the part's own `rows`
    /// unused): a shard encodes them straight from its direct pass ([`encode_jobs`]).
    pub fn encode_with(&self, rows: Option<EncodedRows>) -> Encoded<'_> {
        let tail = self.lightmap.as_ref().map_or(Ok(0), |l| {
            l.tail_len()
                .ok_or("a lightmap's arrays of more bytes than fit")
        });
        let tail = tail.expect("the arrays of a lightmap in memory fit") as usize;
        let ao = self.ao.as_deref().unwrap_or_default();
        let bent = self.bent_normal.as_deref().unwrap_or_default();
        let guides = self.guides.as_ref().map_or(Vec::new(), guide_bytes);
        let arrays = 4 * (self.coefficients.len() + ao.len() + 3 * bent.len()) + guides.len();
        let row_len = rows.as_ref().map_or(0, EncodedRows::byte_len);
        let payload = (arrays + row_len + tail) as u64;
        // The header as for an empty payload (and whatever follows it there), its payload
        // length then set; a texel part's block goes right after the 128 header bytes.
        let mut head = coefficient_file::bytes_with_payload(&self.header, &self.id.to_bytes(), &[]);
        head[72..80].copy_from_slice(&payload.to_le_bytes());
        if let Some(l) = &self.lightmap {
            let size = (HEADER_SIZE + BLOCK_BYTES) as u32;
            head[12..16].copy_from_slice(&size.to_le_bytes());
            head.splice(HEADER_SIZE..HEADER_SIZE, l.block_bytes());
        }
        let mut e = Encoded::from(head);
        e.put(&self.coefficients, f32::to_le_bytes);
        e.put(ao, f32::to_le_bytes);
        e.put(bent, |n: Vec3| {
            let mut b = [0u8; 12];
            for (o, f) in b.chunks_exact_mut(4).zip(n.to_array()) {
                o.copy_from_slice(&f.to_le_bytes());
            }
            b
        });
        e.push(guides);
        if let Some(rows) = rows {
            e.push(rows.lengths);
            for entries in rows.entries {
                e.push(entries);
            }
        }
        if let Some(l) = &self.lightmap {
            l.put_tail(&mut e);
        }
        e.seal();
        e
    }
}

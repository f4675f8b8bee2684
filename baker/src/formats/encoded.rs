//! A file's bytes as pieces in order: large arrays of plain numbers are their own bytes on a
//! little-endian machine, so they are borrowed, not copied into one buffer. A texel bake's
//! file is 172 MB; building it whole touched that much fresh memory (42,000 page faults)
//! before writing it.

use std::borrow::Cow;

use rayon::prelude::*;

use crate::formats::header::{CHECKSUM_OFFSET, HEADER_SIZE};

/// The pieces of a file's bytes; the first holds at least the 128-byte header.
#[derive(Debug, Default)]
pub struct Encoded<'a> {
    parts: Vec<Cow<'a, [u8]>>,
}

impl<'a> Encoded<'a> {
    /// The pieces, to write one after the other.
    pub fn parts(&self) -> Vec<&[u8]> {
        self.parts.iter().map(|p| &**p).collect()
    }

    pub fn len(&self) -> usize {
        self.parts.iter().map(|p| p.len()).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// All the bytes in one buffer.
    pub fn into_vec(self) -> Vec<u8> {
        match <[Cow<'_, [u8]>; 1]>::try_from(self.parts) {
            Ok([only]) => only.into_owned(),
            Err(parts) => parts.concat(),
        }
    }

    /// Appends bytes of its own.
    pub fn push(&mut self, bytes: Vec<u8>) {
        if !bytes.is_empty() {
            self.parts.push(Cow::Owned(bytes));
        }
    }

    /// Appends `other`'s pieces, as they are (borrowed ones stay borrowed).
    pub fn append(&mut self, other: Encoded<'a>) {
        self.parts.extend(other.parts);
    }

    /// Overwrites bytes `offset..` of the first piece (a header's checksum, once the rest is
    /// known).
    pub fn patch(&mut self, offset: usize, bytes: &[u8]) {
        if let Some(first) = self.parts.first_mut() {
            first.to_mut()[offset..offset + bytes.len()].copy_from_slice(bytes);
        }
    }

    /// Appends each of `values` as its `N` little-endian bytes (`le`): borrowed where those are
    /// its bytes in memory (a little-endian machine), else encoded in parallel.
    pub fn put<T: bytemuck::NoUninit + Sync, const N: usize>(
        &mut self,
        values: &'a [T],
        le: impl Fn(T) -> [u8; N] + Sync,
    ) {
        debug_assert_eq!(size_of::<T>(), N);
        if values.is_empty() {
            return;
        }
        if cfg!(target_endian = "little") {
            self.parts.push(Cow::Borrowed(bytemuck::cast_slice(values)));
            return;
        }
        const CHUNK: usize = 1 << 14;
        let mut bytes = vec![0u8; values.len() * N];
        bytes
            .par_chunks_mut(CHUNK * N)
            .zip(values.par_chunks(CHUNK))
            .for_each(|(out, values)| {
                for (out, &v) in out.chunks_exact_mut(N).zip(values) {
                    out.copy_from_slice(&le(v));
                }
            });
        self.parts.push(Cow::Owned(bytes));
    }

    /// Computes the file's checksum (CRC-32 of all bytes, the checksum field as zeros:
    /// [`crate::formats::header::checksum`]), stores it in the header and returns it.
    pub fn seal(&mut self) -> u32 {
        let mut hasher = crc32fast::Hasher::new();
        let Some(first) = self.parts.first_mut() else {
            return 0;
        };
        let first = first.to_mut();
        debug_assert!(first.len() >= HEADER_SIZE);
        hasher.update(&first[..CHECKSUM_OFFSET]);
        hasher.update(&[0; 4]);
        hasher.update(&first[HEADER_SIZE..]);
        for part in &self.parts[1..] {
            hasher.update(part);
        }
        let checksum = hasher.finalize();
        if let Some(first) = self.parts.first_mut() {
            first.to_mut()[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&checksum.to_le_bytes());
        }
        checksum
    }
}

impl From<Vec<u8>> for Encoded<'_> {
    fn from(bytes: Vec<u8>) -> Self {
        let mut encoded = Encoded::default();
        encoded.push(bytes);
        encoded
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::header::checksum;

    #[test]
    fn pieces_seal_and_join_as_one_buffer_would() {
        let head: Vec<u8> = (0..HEADER_SIZE as u32 + 40)
            .map(|i| (i * 7) as u8)
            .collect();
        let floats: Vec<f32> = (0..1000).map(|i| i as f32 * 0.37 - 5.0).collect();
        let counts: Vec<u32> = (0..333).map(|i| i * 12_345).collect();
        let mut encoded = Encoded::from(head.clone());
        encoded.put(&floats, f32::to_le_bytes);
        encoded.push(vec![1, 2, 3]);
        encoded.put(&counts, u32::to_le_bytes);
        let sealed = encoded.seal();
        // What one buffer holds, built byte by byte.
        let mut whole = head;
        whole.extend(floats.iter().flat_map(|f| f.to_le_bytes()));
        whole.extend([1, 2, 3]);
        whole.extend(counts.iter().flat_map(|c| c.to_le_bytes()));
        let expected = checksum(&whole);
        whole[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&expected.to_le_bytes());
        assert_eq!(sealed, expected);
        assert_eq!(encoded.len(), whole.len());
        assert_eq!(encoded.parts().concat(), whole);
        assert_eq!(encoded.into_vec(), whole);
    }
}

//! [`Digest`]: an xxh3 of bytes fed a few at a time, equal to `xxh3_64` of all of them in one
//! buffer, without that buffer (tens of megabytes for a lightmap's fingerprint).

use xxhash_rust::xxh3::Xxh3;

/// Bytes gathered before they are hashed: per-call overhead of the streaming hash is paid
/// once per chunk, not once per float.
const CHUNK: usize = 1 << 16;

/// A streaming xxh3 (64 bits, seed 0) with a chunk buffer.
pub struct Digest {
    hasher: Xxh3,
    chunk: Vec<u8>,
}

impl Default for Digest {
    fn default() -> Digest {
        Digest {
            hasher: Xxh3::new(),
            chunk: Vec::with_capacity(CHUNK + 64),
        }
    }
}

impl Digest {
    /// Appends `bytes`.
    pub fn bytes(&mut self, bytes: &[u8]) {
        self.chunk.extend_from_slice(bytes);
        if self.chunk.len() >= CHUNK {
            self.hasher.update(&self.chunk);
            self.chunk.clear();
        }
    }

    /// Appends the little-endian bytes of `floats`.
    pub fn floats(&mut self, floats: &[f32]) {
        for f in floats {
            self.bytes(&f.to_le_bytes());
        }
    }

    /// The hash of every byte appended: `xxh3_64` of their concatenation.
    pub fn finish(mut self) -> u64 {
        self.hasher.update(&self.chunk);
        self.hasher.digest()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_the_one_shot_hash() {
        let bytes: Vec<u8> = (0..300_000u32).map(|i| (i * 7919 % 251) as u8).collect();
        let mut digest = Digest::default();
        for piece in bytes.chunks(13) {
            digest.bytes(piece);
        }
        assert_eq!(digest.finish(), xxhash_rust::xxh3::xxh3_64(&bytes));
        assert_eq!(Digest::default().finish(), xxhash_rust::xxh3::xxh3_64(&[]));
    }
}

//! A texel bake's seam stitch, factored once (`prt-bake factor-seams`) and stored, so that the
//! stitch shards (`prt-bake stitch --columns K/N --factor FILE`) solve without each factoring
//! the system again (2.1 CPU-s each on a 720,000-triangle heightfield): the system depends
//! only on where the seams read (the prepared lightmap's atlas, baked texels, their dilation
//! and seam partners), never on the values.
//!
//! The file records the prepared lightmap it was made from (its key and checksum) and a
//! *fingerprint* of what a texel file carries of it: the lightmap's size, UVs, baked and
//! dilated texels. A stitch shard computes the fingerprint of the file it stitches and refuses
//! a factor whose fingerprint differs (a stale factor of another preparation).
//!
//! Layout (little-endian): magic `PRTFAC\0\x01`, the prepared lightmap's key and checksum
//! (u64 each), the fingerprint (u64), xxh3 of the rest (u64); then unknowns, supernodes, rows
//! below the supernodes and values (u64 each; no supernodes: nothing to stitch); per unknown
//! its texel (u32); per supernode its first unknown and after the last the unknown count
//! (u32); per supernode its first row and after the last the row count (u64); the rows (u32);
//! the values (f64): [`Factor`].

use std::path::Path;

use glam::Vec2;

use crate::bake::lightmap::stitch::{self, Factored};
use crate::bake::lightmap::stitch_factor::Factor;
use crate::bake::lightmap::{self, Prepared, Stitching, dilation};
use crate::distribute::merge::refuse;
use crate::formats::coefficient_file::LightmapBlock;
use crate::formats::encoded::Encoded;
use crate::support::error::{Error, Result};

const MAGIC: &[u8; 8] = b"PRTFAC\0\x01";
/// Magic, prepared key and checksum, fingerprint, checksum.
const HEAD: usize = 40;

/// A stored seam factor and what it was made from.
pub struct FactorFile {
    /// The prepared lightmap's key and the checksum of its bytes.
    pub prepared_key: u64,
    pub prepared_sum: u64,
    /// [`fingerprint`] of the lightmap the factor stitches.
    pub fingerprint: u64,
    pub factored: Factored,
}

/// What a stitch reads of a lightmap, hashed: its size, the atlas's UVs and which texels are
/// baked and dilated (the seam samples are a function of these and the seam partners).
pub fn fingerprint(
    width: u32,
    height: u32,
    uv1: &[[Vec2; 3]],
    valid: &[bool],
    dilated: &[bool],
) -> u64 {
    let mut bytes = Vec::with_capacity(16 + uv1.len() * 24 + valid.len());
    bytes.extend(width.to_le_bytes());
    bytes.extend(height.to_le_bytes());
    bytes.extend((uv1.len() as u64).to_le_bytes());
    for uv in uv1.iter().flatten() {
        bytes.extend(uv.x.to_bits().to_le_bytes());
        bytes.extend(uv.y.to_bits().to_le_bytes());
    }
    bytes.extend(
        valid
            .iter()
            .zip(dilated)
            .map(|(&v, &d)| u8::from(v) | (u8::from(d) << 1)),
    );
    bytes.extend((dilated.len() as u64).to_le_bytes());
    xxhash_rust::xxh3::xxh3_64(&bytes)
}

/// The seam stitch of `prepared` (key `prepared_key`, bytes' checksum `prepared_sum`),
/// factored as the whole bake factors it: the same seam samples, the same factor.
pub fn factor_prepared(prepared: &Prepared, prepared_key: u64, prepared_sum: u64) -> FactorFile {
    let texels = &prepared.texels;
    let dilated = dilation::dilate_rings(texels, |_| {});
    let stitching = Stitching {
        partners: &prepared.seams,
        uv1: &prepared.atlas.uv1,
    };
    let samples = lightmap::seam_samples(texels, &dilated, &stitching);
    FactorFile {
        prepared_key,
        prepared_sum,
        fingerprint: fingerprint(
            texels.width,
            texels.height,
            &prepared.atlas.uv1,
            &texels.valid,
            &dilated,
        ),
        factored: stitch::factor(&samples),
    }
}

impl FactorFile {
    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.encode().into_vec()
    }

    /// [`FactorFile::to_bytes`] in pieces, the factor's arrays borrowed ([`Encoded`]): the
    /// values are hundreds of MB, and building the bytes whole cost the seam factor job about
    /// half a CPU-second of copying and page faults on the heightfield, and as much memory.
    pub fn encode(&self) -> Encoded<'_> {
        let mut e = Encoded::default();
        let mut head = Vec::with_capacity(HEAD);
        head.extend(MAGIC);
        for x in [self.prepared_key, self.prepared_sum, self.fingerprint, 0] {
            head.extend(x.to_le_bytes());
        }
        e.push(head);
        match self.factored.factor() {
            // No supernodes: nothing to stitch.
            None => e.push(vec![0u8; 32]),
            Some(f) => {
                let supernodes = f.starts().len() - 1;
                let (texels, rows, values) = (f.texels().len(), f.rows().len(), f.len());
                let counts = [texels, supernodes, rows, values];
                e.push(
                    counts
                        .iter()
                        .flat_map(|&x| (x as u64).to_le_bytes())
                        .collect(),
                );
                e.put(f.texels(), u32::to_le_bytes);
                e.put(f.starts(), u32::to_le_bytes);
                e.put(f.row_starts(), u64::to_le_bytes);
                e.put(f.rows(), u32::to_le_bytes);
                e.put(f.values(), f64::to_le_bytes);
            }
        }
        let mut hasher = xxhash_rust::xxh3::Xxh3::new();
        for part in &e.parts()[1..] {
            hasher.update(part);
        }
        e.patch(HEAD - 8, &hasher.digest().to_le_bytes());
        e
    }

    /// Reads the bytes of a factor file.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<FactorFile, String> {
        read_from(bytes, bytes.len() as u64).map_err(|err| match err {
            ReadError::Io(err) => err.to_string(),
            ReadError::Bad(message) => message,
        })
    }

    /// Reads the factor file at `path`, straight into the factor's arrays through a small
    /// buffer (the values are hundreds of MB: a whole-file buffer beside them would double the
    /// stitch shard's memory and page faults).
    pub fn read(path: &Path) -> Result<FactorFile> {
        let file = std::fs::File::open(path).map_err(|err| Error::io(path, err))?;
        let length = file.metadata().map_err(|err| Error::io(path, err))?.len();
        let reader = std::io::BufReader::with_capacity(CHUNK, file);
        read_from(reader, length).map_err(|err| match err {
            ReadError::Io(err) => Error::io(path, err),
            ReadError::Bad(message) => Error::coefficient_file(path, message),
        })
    }

    /// Refuses (exit 3) a factor not made for the lightmap `l` of the texel file at `file`.
    pub fn check(&self, path: &Path, file: &Path, l: &LightmapBlock) -> Result<()> {
        let found = fingerprint(l.width, l.height, &l.uv1, &l.valid, &l.dilated);
        if found != self.fingerprint {
            return Err(refuse(format!(
                "{}: the seam factor of another prepared lightmap than {}'s (fingerprint {:016x}, \
                 the file's {found:016x}): make it again with prt-bake factor-seams from this \
                 bake's prepared lightmap",
                path.display(),
                file.display(),
                self.fingerprint
            )));
        }
        // The fingerprint matched; a factor whose unknowns lie outside the lightmap all the
        // same (a file forged or broken under its checksum) is refused, not solved.
        let texels = self.factored.factor().map_or(&[][..], |f| f.texels());
        if let Some(&t) = texels.iter().find(|&&t| t as usize >= l.valid.len()) {
            return Err(refuse(format!(
                "{}: texel {t} of the seam factor is outside {}'s {}×{} lightmap",
                path.display(),
                file.display(),
                l.width,
                l.height
            )));
        }
        Ok(())
    }

    /// Refuses (exit 3) a factor not made from the prepared lightmap of key `key` and
    /// checksum `sum` (at `prepared`).
    pub fn check_prepared(&self, path: &Path, prepared: &Path, key: u64, sum: u64) -> Result<()> {
        if (key, sum) != (self.prepared_key, self.prepared_sum) {
            return Err(refuse(format!(
                "{}: the seam factor of another prepared lightmap than {} (made from key \
                 {:016x}, checksum {:016x}; that one has {key:016x}, {sum:016x}): make it again \
                 with prt-bake factor-seams",
                path.display(),
                prepared.display(),
                self.prepared_key,
                self.prepared_sum
            )));
        }
        Ok(())
    }
}

/// A factor file from `reader` (`length` bytes), read in order into the factor's arrays.
fn read_from(
    reader: impl std::io::Read,
    length: u64,
) -> std::result::Result<FactorFile, ReadError> {
    let reader = &mut Chunks {
        file: reader,
        hasher: xxhash_rust::xxh3::Xxh3::new(),
        length,
    };
    let mut head = [0u8; HEAD];
    if length < HEAD as u64 {
        return Err("not a seam factor (prt-bake factor-seams)".into());
    }
    reader.exact(&mut head, false)?;
    if &head[..8] != MAGIC {
        return Err("not a seam factor (prt-bake factor-seams)".into());
    }
    let u64_at = |o: usize| u64::from_le_bytes(head[o..o + 8].try_into().expect("8"));
    let counts: Vec<u64> = reader.array(4, u64::from_le_bytes)?;
    let (unknowns, supernodes, rows, values) = (counts[0], counts[1], counts[2], counts[3]);
    // The sizes must add up to the file's length before anything is allocated.
    let supernodes = supernodes.min(u64::MAX - 1);
    let announced = [
        (unknowns, 4),
        (supernodes + 1, 4),
        (supernodes + 1, 8),
        (rows, 4),
    ]
    .iter()
    .chain(&[(values, 8)])
    .try_fold((HEAD + 32) as u64, |sum, &(n, each): &(u64, u64)| {
        n.checked_mul(each).and_then(|b| b.checked_add(sum))
    });
    let expected = if supernodes == 0 {
        Some((HEAD + 32) as u64)
    } else {
        announced
    };
    if expected != Some(length) {
        return Err("the file is shorter than its sizes announce, or longer".into());
    }
    let parts = match supernodes {
        0 => None,
        _ => Some((
            reader.array(unknowns, u32::from_le_bytes)?,
            reader.array(supernodes + 1, u32::from_le_bytes)?,
            reader.array(supernodes + 1, u64::from_le_bytes)?,
            reader.array(rows, u32::from_le_bytes)?,
            reader.array(values, f64::from_le_bytes)?,
        )),
    };
    if reader.hasher.digest() != u64_at(HEAD - 8) {
        return Err("checksum mismatch: the file is truncated or corrupted".into());
    }
    let factor = match parts {
        None => None,
        Some((texels, starts, row_starts, rows, values)) => Some(Factor::from_parts(
            texels, starts, row_starts, rows, values,
        )?),
    };
    let factored = Factored::from_factor(factor);
    Ok(FactorFile {
        prepared_key: u64_at(8),
        prepared_sum: u64_at(16),
        fingerprint: u64_at(24),
        factored,
    })
}

/// Bytes read at a time.
const CHUNK: usize = 1 << 20;

enum ReadError {
    Io(std::io::Error),
    Bad(String),
}

impl From<String> for ReadError {
    fn from(message: String) -> ReadError {
        ReadError::Bad(message)
    }
}

impl From<&str> for ReadError {
    fn from(message: &str) -> ReadError {
        ReadError::Bad(message.into())
    }
}

/// A factor file read in order, hashing its body as it goes.
struct Chunks<R> {
    file: R,
    hasher: xxhash_rust::xxh3::Xxh3,
    length: u64,
}

impl<R: std::io::Read> Chunks<R> {
    fn exact(&mut self, into: &mut [u8], hash: bool) -> std::result::Result<(), ReadError> {
        self.file.read_exact(into).map_err(|err| match err.kind() {
            std::io::ErrorKind::UnexpectedEof => {
                ReadError::Bad(format!("the file ends early ({} bytes)", self.length))
            }
            _ => ReadError::Io(err),
        })?;
        if hash {
            self.hasher.update(into);
        }
        Ok(())
    }

    /// `n` values of `N` bytes each, little-endian.
    fn array<T, const N: usize>(
        &mut self,
        n: u64,
        from: impl Fn([u8; N]) -> T,
    ) -> std::result::Result<Vec<T>, ReadError> {
        let n = usize::try_from(n).map_err(|_| "sizes overflow")?;
        let mut out = Vec::with_capacity(n);
        let mut buffer = vec![0u8; (CHUNK / N).max(1) * N];
        let mut left = n;
        while left > 0 {
            let take = left.min(buffer.len() / N);
            let bytes = &mut buffer[..take * N];
            self.exact(bytes, true)?;
            out.extend(
                bytes
                    .chunks_exact(N)
                    .map(|c| from(c.try_into().expect("N bytes"))),
            );
            left -= take;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::lightmap::stitch::SeamSample;

    fn file() -> FactorFile {
        // A chain of texels read across seams: one connected system of a few supernodes.
        let samples: Vec<SeamSample> = (0..40u32)
            .map(|i| SeamSample {
                a: vec![(i, 0.7), (i + 1, 0.3)],
                b: vec![((i * 7 + 3) % 45, 1.0)],
            })
            .collect();
        FactorFile {
            prepared_key: 1,
            prepared_sum: 2,
            fingerprint: 3,
            factored: stitch::factor(&samples),
        }
    }

    #[test]
    fn a_factor_reads_back_as_written_and_solves_the_same() {
        let f = file();
        let bytes = f.to_bytes();
        let back = FactorFile::from_bytes(&bytes).expect("reads");
        assert_eq!(
            (back.prepared_key, back.prepared_sum, back.fingerprint),
            (1, 2, 3)
        );
        assert!(back.factored.factor().is_some());
        assert_eq!(back.factored.factor(), f.factored.factor());
        let values: Vec<f32> = (0..50).map(|i| (i % 7) as f32 * 0.25).collect();
        let (mut a, mut b) = (values.clone(), values.clone());
        stitch::stitch_factored(&f.factored, &mut [(&mut a[..], 1)]);
        stitch::stitch_factored(&back.factored, &mut [(&mut b[..], 1)]);
        assert!(a != values, "the stitch moved nothing");
        assert!(a == b, "the factor read back solves differently");
        // Nothing to stitch: no supernodes.
        let none = FactorFile {
            factored: stitch::factor(&[]),
            ..file()
        };
        let back = FactorFile::from_bytes(&none.to_bytes()).expect("reads");
        assert!(back.factored.factor().is_none());
    }

    #[test]
    fn damaged_factors_are_refused() {
        let bytes = file().to_bytes();
        let refused = |b: &[u8]| FactorFile::from_bytes(b).err().unwrap_or_default();
        assert!(refused(&bytes[..bytes.len() - 8]).contains("shorter than its sizes"));
        assert!(refused(&bytes[..20]).contains("not a seam factor"));
        let mut flipped = bytes.clone();
        flipped[HEAD + 40] ^= 1;
        assert!(refused(&flipped).contains("checksum"));
        // Sizes that lie, under a checksum made to match: refused, not a panic.
        let mut lying = bytes.clone();
        lying[HEAD..HEAD + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        let sum = xxhash_rust::xxh3::xxh3_64(&lying[HEAD..]);
        lying[HEAD - 8..HEAD].copy_from_slice(&sum.to_le_bytes());
        assert!(refused(&lying).contains("shorter than its sizes"));
        let mut inconsistent = bytes;
        let unknowns = u64::from_le_bytes(inconsistent[HEAD..HEAD + 8].try_into().unwrap());
        // Two unknowns fewer and one value more: the sizes add up, the factor does not.
        let values = u64::from_le_bytes(inconsistent[HEAD + 24..HEAD + 32].try_into().unwrap());
        inconsistent[HEAD..HEAD + 8].copy_from_slice(&(unknowns - 2).to_le_bytes());
        inconsistent[HEAD + 24..HEAD + 32].copy_from_slice(&(values + 1).to_le_bytes());
        let sum = xxhash_rust::xxh3::xxh3_64(&inconsistent[HEAD..]);
        inconsistent[HEAD - 8..HEAD].copy_from_slice(&sum.to_le_bytes());
        assert!(
            refused(&inconsistent).contains("supernodes cover unknowns"),
            "{}",
            refused(&inconsistent)
        );
    }
}

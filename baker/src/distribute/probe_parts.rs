//! Shard parts and checkpoint blocks of probe bakes (`bake --probes … --shard K/N`,
//! `--checkpoint`, docs/guides/probes.md): a range of consecutive probes, merged by concatenation.
//!
//! A probe's matrix depends only on its index (its random streams and classification
//! rotation), its position, the scene and the options, never on the other probes, so the
//! final matrices of a range are baked where the range is: a part holds final transfer, not
//! the direct transfer and bounce rows a vertex part holds. In interreflected mode every run
//! first bakes the vertices' bounce solution (T^{B−1}) its hits read: each shard repeats that
//! vertex bake (docs/guides/probes.md measures it); a checkpointed run does it once for all its
//! blocks.
//!
//! The file: the whole bake's 176-byte header and probe block (every option, the seed, the
//! scene fingerprint, the backend, the channel count, the probe count and grid), the shard
//! identity in bytes 88..108, and the range's payload laid out as the whole file's: its
//! matrices, then its positions, then its back-face fractions.

use std::path::Path;

use glam::Vec3;

use crate::formats::coefficient_file::{self, CoefficientFile};
use crate::formats::header::{
    self, CHECKSUM_OFFSET, HEADER_SIZE, Header, PROBE_HEADER_SIZE, checksum,
};
use crate::formats::part_id::PartId;
use crate::formats::probe_block::{self, PROBE_BYTES, ProbeBlock, ProbeGrid};
use crate::support::error::{Error, Result};

/// A probe bake's shard part (or checkpoint block) in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbePart {
    /// The whole bake's header: `vertex_count` is every probe of the bake.
    pub header: Header,
    /// The whole bake's grid, if it is one.
    pub grid: Option<ProbeGrid>,
    /// Which shard, and which probes (its "vertices").
    pub id: PartId,
    /// The range's matrices, as the whole file stores them.
    pub coefficients: Vec<f32>,
    pub positions: Vec<Vec3>,
    pub backfaces: Vec<f32>,
}

impl ProbePart {
    /// The part file's bytes (checksummed).
    pub fn to_bytes(&self) -> Vec<u8> {
        let floats = self.coefficients.iter().copied();
        let positions = self.positions.iter().flat_map(|p| p.to_array());
        let payload: Vec<u8> = floats
            .chain(positions)
            .chain(self.backfaces.iter().copied())
            .flat_map(f32::to_le_bytes)
            .collect();
        let mut bytes =
            coefficient_file::bytes_with_payload(&self.header, &self.id.to_bytes(), &payload);
        bytes[12..16].copy_from_slice(&(PROBE_HEADER_SIZE as u32).to_le_bytes());
        let block = probe_block::encode_block(self.header.vertex_count, self.grid.as_ref());
        bytes.splice(HEADER_SIZE..HEADER_SIZE, block);
        let sum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    /// Whether `bytes` are a probe bake's part (a 176-byte header and a shard identity),
    /// as far as their framing says; [`ProbePart::from_bytes`] checks the rest.
    pub fn is_probe_part(bytes: &[u8]) -> bool {
        bytes.len() >= PROBE_HEADER_SIZE
            && bytes[12..16] == (PROBE_HEADER_SIZE as u32).to_le_bytes()
            && bytes[88..108].iter().any(|&b| b != 0)
    }

    /// Parses and validates a part file's bytes; the error is a sentence for the user.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<ProbePart, String> {
        let (header, payload, header_size) = header::parse_header(bytes)?;
        let id = PartId::from_header_bytes(bytes)?
            .ok_or("a whole bake, not a shard part (nothing to merge)")?;
        if header_size != PROBE_HEADER_SIZE {
            return Err("a vertex or texel bake's part, not a probe bake's".into());
        }
        let grid =
            probe_block::decode_block(&bytes[HEADER_SIZE..PROBE_HEADER_SIZE], header.vertex_count)?;
        let range = id.range();
        if range.end as u64 > header.vertex_count {
            return Err(format!(
                "{}: probes {}..{}, beyond the bake's {} probes",
                id.shard, range.start, range.end, header.vertex_count
            ));
        }
        let width = header.coefficients_per_vertex();
        let count = range.len();
        let needed = count as u64 * (width as u64 * 4 + PROBE_BYTES);
        if payload != needed {
            return Err(format!(
                "{}: payload of {payload} bytes, but probes {}..{} need {needed}",
                id.shard, range.start, range.end
            ));
        }
        let floats: Vec<f32> = bytes[PROBE_HEADER_SIZE..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        let (coefficients, rest) = floats.split_at(count * width);
        let (positions, backfaces) = rest.split_at(3 * count);
        if let Some(i) = positions.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "position of probe {} is not finite",
                range.start + i / 3
            ));
        }
        if let Some(p) = backfaces.iter().position(|x| !(0.0..=1.0).contains(x)) {
            let p = range.start + p;
            return Err(format!("back-face fraction of probe {p} is outside [0, 1]"));
        }
        Ok(ProbePart {
            header,
            grid,
            id,
            coefficients: coefficients.to_vec(),
            positions: positions.chunks_exact(3).map(Vec3::from_slice).collect(),
            backfaces: backfaces.to_vec(),
        })
    }

    pub fn read(path: &Path) -> Result<ProbePart> {
        let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
        ProbePart::from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))
    }

    /// Writes the part atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        crate::support::atomic::write(path, &self.to_bytes())
    }

    /// What differs between the bakes of `self` and `other` (header or grid), if anything.
    pub fn bake_difference(&self, other: &ProbePart) -> Option<String> {
        crate::distribute::shard::header_difference(&self.header, &other.header).or_else(|| {
            (self.grid != other.grid).then(|| {
                let grid = |g: &Option<ProbeGrid>| match g {
                    Some(g) => format!("grid {:?} over [{}, {}]", g.counts, g.lo, g.hi),
                    None => "a list of points".into(),
                };
                format!("{} instead of {}", grid(&other.grid), grid(&self.grid))
            })
        })
    }

    /// Joins parts of one bake that hold consecutive ranges, in order, into one part with
    /// identity `id` (the caller has checked that they tile its range).
    pub fn join(parts: Vec<ProbePart>, id: PartId) -> ProbePart {
        let mut parts = parts.into_iter();
        let mut joined = parts.next().expect("at least one part");
        joined.id = id;
        for part in parts {
            joined.coefficients.extend(part.coefficients);
            joined.positions.extend(part.positions);
            joined.backfaces.extend(part.backfaces);
        }
        joined
    }

    /// The whole probe file from a part that holds every probe.
    pub fn into_file(self) -> CoefficientFile {
        debug_assert_eq!(self.positions.len() as u64, self.header.vertex_count);
        CoefficientFile {
            header: self.header,
            coefficients: self.coefficients,
            ao: None,
            bent_normal: None,
            rays: None,
            error_estimate: None,
            lightmap: None,
            probes: Some(ProbeBlock {
                positions: self.positions,
                grid: self.grid,
                backfaces: self.backfaces,
            }),
        }
    }
}

//! The probe block of a probe bake's coefficient file (`bake --probes`,
//! `docs/reference/coefficient-format.md`, "Transfer probes"): a 176-byte header (the 128 bytes, then
//! the probe count, the grid and 4 reserved bytes), the probes' transfer matrices as a matrix
//! file's coefficients, and after them the probes' positions and back-face fractions. The
//! "vertices" of such a file are its probes. Old readers refuse the header size, so a probe file is never read as a
//! vertex bake.

use glam::Vec3;

use crate::formats::header::{HEADER_SIZE, Header, PROBE_HEADER_SIZE, TransferKind};

/// Bytes of the probe block (header bytes 128..176).
pub const BLOCK_BYTES: usize = PROBE_HEADER_SIZE - HEADER_SIZE;
/// Bytes per probe after the coefficients: its position and back-face fraction.
pub(crate) const PROBE_BYTES: u64 = 16;

/// What a probe file holds beyond a matrix file.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeBlock {
    /// Per probe, its position in the scene's frame.
    pub positions: Vec<Vec3>,
    /// `grid:` bakes: the grid the probes fill, in its order.
    pub grid: Option<ProbeGrid>,
    /// Per probe, the fraction of its classification rays that hit a back face, in [0, 1]
    /// (`crate::bake::probe_validity`): above [`INSIDE_FRACTION`], the probe is inside
    /// geometry and readers leave it out.
    pub backfaces: Vec<f32>,
}

/// The back-face fraction above which a probe is taken to be inside geometry: a probe
/// beside a wall sees none; just under a large floor, about half; inside a closed box, all
/// (DDGI's probe classification uses the same bound).
pub const INSIDE_FRACTION: f32 = 0.25;

/// NX × NY × NZ probes at the centres of the cells of the box [lo, hi]: probe (i, j, k), at
/// index i + NX·(j + NY·k), sits at lo + (hi − lo)·((i, j, k) + ½)/(NX, NY, NZ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeGrid {
    pub counts: [u32; 3],
    pub lo: Vec3,
    pub hi: Vec3,
}

impl ProbeGrid {
    /// The probes' positions, x fastest, then y, then z.
    pub fn positions(&self) -> Vec<Vec3> {
        let [nx, ny, nz] = self.counts;
        let size = Vec3::new(nx as f32, ny as f32, nz as f32);
        let mut out = Vec::with_capacity(self.len());
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let cell = Vec3::new(i as f32, j as f32, k as f32) + 0.5;
                    out.push(self.lo + (self.hi - self.lo) * cell / size);
                }
            }
        }
        out
    }

    pub fn len(&self) -> usize {
        self.counts.iter().map(|&c| c as usize).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The index of probe (i, j, k).
    pub fn index(&self, [i, j, k]: [u32; 3]) -> usize {
        let [nx, ny, _] = self.counts;
        (i + nx * (j + ny * k)) as usize
    }
}

impl ProbeBlock {
    /// The block's 48 bytes ([`encode_block`]).
    pub(crate) fn encode_block(&self) -> Vec<u8> {
        encode_block(self.positions.len() as u64, self.grid.as_ref())
    }

    /// Whether probe `p` is outside geometry (its back-face fraction at most
    /// [`INSIDE_FRACTION`]).
    pub fn valid(&self, p: usize) -> bool {
        self.backfaces[p] <= INSIDE_FRACTION
    }

    /// The arrays after the coefficients: the positions (3 little-endian f32 per probe),
    /// then the back-face fractions (one f32 per probe).
    pub(crate) fn encode_arrays(&self) -> impl Iterator<Item = u8> + '_ {
        let floats = self.positions.iter().flat_map(|p| p.to_array());
        floats
            .chain(self.backfaces.iter().copied())
            .flat_map(f32::to_le_bytes)
    }

    /// Bytes of the arrays after the coefficients.
    pub(crate) fn arrays_bytes(&self) -> u64 {
        self.positions.len() as u64 * PROBE_BYTES
    }
}

impl ProbeBlock {
    /// The block of a probe file's `bytes`, whose `header` and payload length were read:
    /// checked against both, with the positions from the payload's end.
    pub(crate) fn read(
        bytes: &[u8],
        header: &Header,
        payload: u64,
    ) -> std::result::Result<ProbeBlock, String> {
        let grid = check_block(bytes, header, payload)?;
        let count = header.vertex_count as usize;
        let tail = &bytes[bytes.len() - count * PROBE_BYTES as usize..];
        let floats: Vec<f32> = tail
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        let (positions, backfaces) = floats.split_at(3 * count);
        if let Some(i) = positions.iter().position(|x| !x.is_finite()) {
            return Err(format!("position of probe {} is not finite", i / 3));
        }
        if let Some(p) = backfaces.iter().position(|x| !(0.0..=1.0).contains(x)) {
            return Err(format!("back-face fraction of probe {p} is outside [0, 1]"));
        }
        Ok(ProbeBlock {
            positions: positions.chunks_exact(3).map(Vec3::from_slice).collect(),
            grid,
            backfaces: backfaces.to_vec(),
        })
    }
}

/// A probe block's 48 bytes: the probe count (u64), the grid's counts (3 × u32) and box
/// (6 × f32), all zero for a list of points, and 4 reserved zero bytes. Shard parts carry
/// the whole bake's block (`crate::distribute::probe_parts`).
pub(crate) fn encode_block(count: u64, grid: Option<&ProbeGrid>) -> Vec<u8> {
    let mut bytes = count.to_le_bytes().to_vec();
    let (counts, lo, hi) = match grid {
        Some(g) => (g.counts, g.lo, g.hi),
        None => ([0; 3], Vec3::ZERO, Vec3::ZERO),
    };
    bytes.extend(counts.iter().flat_map(|c| c.to_le_bytes()));
    let corners = lo.to_array().into_iter().chain(hi.to_array());
    bytes.extend(corners.flat_map(f32::to_le_bytes));
    bytes.resize(BLOCK_BYTES, 0);
    bytes
}

/// The grid of a block's 48 bytes, checked against its probe count, which must be the
/// header's `header_count`.
pub(crate) fn decode_block(
    block: &[u8],
    header_count: u64,
) -> std::result::Result<Option<ProbeGrid>, String> {
    let u32_at = |o: usize| u32::from_le_bytes(block[o..o + 4].try_into().expect("4 bytes"));
    let f32_at = |o: usize| f32::from_le_bytes(block[o..o + 4].try_into().expect("4 bytes"));
    let count = u64::from_le_bytes(block[..8].try_into().expect("8 bytes"));
    if count != header_count {
        return Err(format!(
            "the probe block counts {count} probes, the header {header_count}"
        ));
    }
    if block[44..].iter().any(|&b| b != 0) {
        return Err("reserved bytes 172..176 of the probe block are not zero".into());
    }
    let counts = [u32_at(8), u32_at(12), u32_at(16)];
    let lo = Vec3::new(f32_at(20), f32_at(24), f32_at(28));
    let hi = Vec3::new(f32_at(32), f32_at(36), f32_at(40));
    let grid = match counts {
        [0, 0, 0] if lo == Vec3::ZERO && hi == Vec3::ZERO => None,
        _ => {
            let product = counts.iter().map(|&c| u64::from(c)).product::<u64>();
            if product != count || !(lo.is_finite() && hi.is_finite()) || lo.cmpgt(hi).any() {
                return Err(format!(
                    "a probe grid of {}×{}×{} over [{lo}, {hi}] for {count} probes",
                    counts[0], counts[1], counts[2]
                ));
            }
            Some(ProbeGrid { counts, lo, hi })
        }
    };
    Ok(grid)
}

/// Checks a probe file's header and block (bytes 128..176) against each other and the
/// payload's length; returns the grid, if any.
fn check_block(
    bytes: &[u8],
    header: &Header,
    payload: u64,
) -> std::result::Result<Option<ProbeGrid>, String> {
    let grid = decode_block(&bytes[HEADER_SIZE..PROBE_HEADER_SIZE], header.vertex_count)?;
    let count = header.vertex_count;
    if header.transfer != TransferKind::Matrix {
        return Err("a probe bake whose transfer kind is not matrix".into());
    }
    if header.aux.any() || header.adaptive.is_some() {
        return Err("a probe bake with per-receiver aux arrays or a target error".into());
    }
    let needed = count
        .checked_mul(header.coefficients_per_vertex() as u64 * 4)
        .zip(count.checked_mul(PROBE_BYTES))
        .and_then(|(c, p)| c.checked_add(p));
    if needed != Some(payload) {
        return Err(format!(
            "payload of {payload} bytes, but {count} probes of {} channels at order {} need {}",
            header.channels,
            header.order,
            needed.map_or("more than 2^64".into(), |n| n.to_string())
        ));
    }
    Ok(grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::coefficient_file::{CoefficientFile, fixture};
    use crate::formats::header::{CHECKSUM_OFFSET, checksum};

    /// Two order-1 probes of a 2×1×1 grid, one channel.
    fn probe_file() -> CoefficientFile {
        let mut file = fixture(1, 1, 2, vec![0.75, 1.0]);
        file.header.transfer = TransferKind::Matrix;
        let grid = ProbeGrid {
            counts: [2, 1, 1],
            lo: Vec3::ZERO,
            hi: Vec3::new(4.0, 2.0, 2.0),
        };
        assert_eq!(
            grid.positions(),
            [Vec3::new(1.0, 1.0, 1.0), Vec3::new(3.0, 1.0, 1.0)]
        );
        file.probes = Some(ProbeBlock {
            positions: grid.positions(),
            grid: Some(grid),
            backfaces: vec![0.0, 0.5],
        });
        file
    }

    /// A change to a file's bytes.
    type Corruption = Box<dyn Fn(&mut Vec<u8>)>;

    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let sum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn probe_files_round_trip() {
        for grid in [true, false] {
            let mut file = probe_file();
            if !grid {
                file.probes.as_mut().unwrap().grid = None;
            }
            let (bytes, sum) = file.to_bytes();
            assert_eq!(bytes.len(), 176 + 2 * 4 + 2 * 16);
            assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 176);
            let mut read = CoefficientFile::from_bytes(&bytes).unwrap();
            assert_eq!(read.header.checksum, sum);
            read.header.checksum = 0;
            assert_eq!(read, file);
        }
    }

    #[test]
    fn inconsistent_probe_files_are_refused() {
        let (good, _) = probe_file().to_bytes();
        let cases: [(&str, Corruption); 6] = [
            ("counts 3 probes", Box::new(|b| b[128] = 3)),
            ("reserved bytes 172..176", Box::new(|b| b[174] = 1)),
            ("a probe grid of 2×2×1", Box::new(|b| b[140] = 2)),
            ("not matrix", Box::new(|b| b[38] = 0)),
            (
                "position of probe 1",
                Box::new(|b| {
                    let at = b.len() - 12;
                    b[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes())
                }),
            ),
            (
                "back-face fraction of probe 1",
                Box::new(|b| {
                    let at = b.len() - 4;
                    b[at..].copy_from_slice(&1.5f32.to_le_bytes())
                }),
            ),
        ];
        for (message, corrupt) in cases {
            let mut bytes = good.clone();
            corrupt(&mut bytes);
            match CoefficientFile::from_bytes(&resealed(bytes)) {
                Err(m) => assert!(m.contains(message), "{message}: {m}"),
                Ok(_) => panic!("{message}: accepted"),
            }
        }
    }
}

//! The probe block of a probe bake's coefficient file (`bake --probes`,
//! `docs/coefficient-format.md`, "Transfer probes"): a 144-byte header (the 128 bytes, then
//! the probe count and 8 reserved bytes), the probes' transfer matrices as a matrix file's
//! coefficients, and after them the probes' positions. The "vertices" of such a file are its
//! probes. Old readers refuse the header size, so a probe file is never read as a vertex bake.

use glam::Vec3;

use crate::formats::header::{Header, PROBE_HEADER_SIZE, TransferKind};

/// Bytes of the probe block (header bytes 128..144).
pub const BLOCK_BYTES: usize = PROBE_HEADER_SIZE - crate::formats::header::HEADER_SIZE;

/// The probe block: the probe count (u64, equal to the header's vertex count), then 8
/// reserved zero bytes.
pub(crate) fn encode_block(probes: &[Vec3]) -> Vec<u8> {
    let mut bytes = (probes.len() as u64).to_le_bytes().to_vec();
    bytes.resize(BLOCK_BYTES, 0);
    bytes
}

/// The positions after the arrays: 3 little-endian f32 per probe.
pub(crate) fn encode_positions(probes: &[Vec3]) -> impl Iterator<Item = u8> + '_ {
    probes
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
}

/// Bytes of the positions.
pub(crate) fn positions_bytes(probes: &[Vec3]) -> u64 {
    probes.len() as u64 * 12
}

/// Checks a probe file's header and block (bytes 128..144) against each other and returns
/// the bytes its positions take at the payload's end.
pub(crate) fn check_block(
    bytes: &[u8],
    header: &Header,
    payload: u64,
) -> std::result::Result<u64, String> {
    let block = &bytes[crate::formats::header::HEADER_SIZE..PROBE_HEADER_SIZE];
    let count = u64::from_le_bytes(block[..8].try_into().expect("8 bytes"));
    if count != header.vertex_count {
        return Err(format!(
            "the probe block counts {count} probes, the header {}",
            header.vertex_count
        ));
    }
    if block[8..].iter().any(|&b| b != 0) {
        return Err("reserved bytes 136..144 of the probe block are not zero".into());
    }
    if header.transfer != TransferKind::Matrix {
        return Err("a probe bake whose transfer kind is not matrix".into());
    }
    if header.aux.any() || header.adaptive.is_some() {
        return Err("a probe bake with per-receiver aux arrays or a target error".into());
    }
    let positions = count.checked_mul(12);
    let needed = count
        .checked_mul(header.coefficients_per_vertex() as u64 * 4)
        .zip(positions)
        .and_then(|(c, p)| c.checked_add(p));
    if needed != Some(payload) {
        return Err(format!(
            "payload of {payload} bytes, but {count} probes of {} channels at order {} need {}",
            header.channels,
            header.order,
            needed.map_or("more than 2^64".into(), |n| n.to_string())
        ));
    }
    Ok(count * 12)
}

/// The positions from the last bytes of a probe file, every one finite.
pub(crate) fn decode_positions(tail: &[u8]) -> std::result::Result<Vec<Vec3>, String> {
    let floats: Vec<f32> = tail
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    if let Some(i) = floats.iter().position(|x| !x.is_finite()) {
        return Err(format!("position of probe {} is not finite", i / 3));
    }
    Ok(floats.chunks_exact(3).map(Vec3::from_slice).collect())
}

#[cfg(test)]
mod tests {
    use crate::formats::coefficient_file::{CoefficientFile, fixture};
    use crate::formats::header::{CHECKSUM_OFFSET, HEADER_SIZE, TransferKind, checksum};
    use glam::Vec3;

    /// Two order-1 probes, one channel.
    fn probe_file() -> CoefficientFile {
        let mut file = fixture(1, 1, 2, vec![0.75, 1.0]);
        file.header.transfer = TransferKind::Matrix;
        file.probes = Some(vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.5, 0.0)]);
        file
    }

    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let sum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn probe_files_round_trip() {
        let file = probe_file();
        let (bytes, sum) = file.to_bytes();
        assert_eq!(bytes.len(), 144 + 2 * 4 + 2 * 12);
        assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 144);
        let mut read = CoefficientFile::from_bytes(&bytes).unwrap();
        assert_eq!(read.header.checksum, sum);
        read.header.checksum = 0;
        assert_eq!(read, file);
    }

    #[test]
    fn inconsistent_probe_files_are_refused() {
        let (good, _) = probe_file().to_bytes();
        let cases: [(&str, Box<dyn Fn(&mut Vec<u8>)>); 4] = [
            ("counts 3 probes", Box::new(|b| b[128] = 3)),
            ("reserved bytes 136..144", Box::new(|b| b[140] = 1)),
            ("not matrix", Box::new(|b| b[38] = 0)),
            (
                "position of probe 1",
                Box::new(|b| {
                    let at = b.len() - 4;
                    b[at..].copy_from_slice(&f32::NAN.to_le_bytes())
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

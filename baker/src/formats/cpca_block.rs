//! Version 2 of the coefficient file: a CPCA-compressed bake ([`crate::cpca`]); specified in
//! docs/reference/coefficient-format.md, "Compressed files (version 2)".
//!
//! A version-2 file is a version-1 file whose coefficients are replaced by the cluster means,
//! bases, per-receiver cluster indices and weights, with a 32-byte CPCA block after the
//! header (and after a texel bake's texel block). Everything else — header fields, aux
//! arrays, lightmap UVs and states, the checksum — is as in version 1, and both are built
//! from version 1's code: the writer cuts the coefficients out of a version-1 file's bytes,
//! and the reader validates the compressed arrays, reconstructs the coefficients and hands
//! the rebuilt version-1 bytes to the version-1 reader, so a compressed file is checked as
//! strictly as any other and no field is parsed twice. Version-1 files are untouched.

use serde_json::json;

use crate::formats::coefficient_file::{
    CoefficientFile, HEADER_SIZE, LIGHTMAP_HEADER_SIZE, MAGIC, PROBE_HEADER_SIZE,
};
use crate::math::cpca::Cpca;
use crate::math::sh;

/// The format version of a compressed file.
pub const VERSION: u32 = 2;
/// Bytes of the CPCA block after the (texel) header.
pub const BLOCK_SIZE: usize = 32;
/// The block's layout code: one vector of channels × n² floats per receiver (all channels
/// concatenated, as [`crate::cpca`] fits them). Other codes are reserved.
const LAYOUT_CONCATENATED: u32 = 0;
const CHECKSUM_OFFSET: usize = 124;

/// What the CPCA block and arrays of a file hold.
#[derive(Clone, Debug, PartialEq)]
pub struct CompressedFile {
    /// The reconstructed file, as version 1 would store it (its header is a version-1 header
    /// and its checksum the one writing it would give).
    pub file: CoefficientFile,
    pub cpca: Cpca,
    /// The reconstruction's RMS coefficient error, as recorded by the writer.
    pub rms_error: f32,
    /// The seed the fit's k-means++ seeding started from.
    pub seed: u64,
    /// The compressed file's own checksum.
    pub checksum: u32,
}

/// Whether `bytes` start like a version-2 coefficient file (the full check is
/// [`from_bytes`]).
pub fn is_compressed(bytes: &[u8]) -> bool {
    bytes.len() >= 12 && bytes[..8] == MAGIC && u32_at(bytes, 8) == VERSION
}

fn u32_at(bytes: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"))
}

fn u64_at(bytes: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"))
}

fn checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..CHECKSUM_OFFSET]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[HEADER_SIZE..]);
    hasher.finalize()
}

fn seal(bytes: &mut [u8]) {
    let sum = checksum(bytes);
    bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
}

/// The version-2 bytes of `file` compressed as `cpca` (fitted to `file.coefficients`).
pub fn to_bytes(file: &CoefficientFile, cpca: &Cpca, rms_error: f32) -> Vec<u8> {
    let (v1, _) = file.to_bytes();
    let header_size = u32_at(&v1, 12) as usize;
    let coefficients_end = header_size + file.coefficients.len() * 4;
    let tail = &v1[coefficients_end..];
    let arrays =
        (cpca.means.len() + cpca.bases.len() + cpca.cluster.len() + cpca.weights.len()) as u64 * 4;
    let mut bytes = Vec::with_capacity(header_size + BLOCK_SIZE + arrays as usize + tail.len());
    bytes.extend_from_slice(&v1[..header_size]);
    bytes[8..12].copy_from_slice(&VERSION.to_le_bytes());
    bytes[12..16].copy_from_slice(&((header_size + BLOCK_SIZE) as u32).to_le_bytes());
    bytes[72..80].copy_from_slice(&(arrays + tail.len() as u64).to_le_bytes());
    bytes.extend((cpca.clusters() as u32).to_le_bytes());
    bytes.extend((cpca.pcs as u32).to_le_bytes());
    bytes.extend(LAYOUT_CONCATENATED.to_le_bytes());
    bytes.extend(cpca.iterations.to_le_bytes());
    bytes.extend(cpca.seed.to_le_bytes());
    bytes.extend(rms_error.to_le_bytes());
    bytes.extend(0u32.to_le_bytes());
    let floats = cpca.means.iter().chain(&cpca.bases);
    bytes.extend(floats.flat_map(|x| x.to_le_bytes()));
    bytes.extend(cpca.cluster.iter().flat_map(|k| k.to_le_bytes()));
    bytes.extend(cpca.weights.iter().flat_map(|x| x.to_le_bytes()));
    bytes.extend_from_slice(tail);
    seal(&mut bytes);
    bytes
}

/// Parses and validates a version-2 file; the error is a sentence for the user. Sizes are
/// checked (overflow included) before anything is allocated, every stored float must be
/// finite and every cluster index in range; the rebuilt version-1 file then passes the
/// version-1 reader's checks (header fields, reconstructed coefficients finite, aux arrays,
/// lightmap block).
pub fn from_bytes(bytes: &[u8]) -> Result<CompressedFile, String> {
    if !is_compressed(bytes) {
        return Err("not a compressed (version 2) coefficient file".into());
    }
    if bytes.len() < HEADER_SIZE {
        return Err(format!(
            "truncated: {} bytes, but the header alone is {HEADER_SIZE} bytes",
            bytes.len()
        ));
    }
    let header_size = u32_at(bytes, 12) as usize;
    let base = header_size.wrapping_sub(BLOCK_SIZE);
    if ![HEADER_SIZE, LIGHTMAP_HEADER_SIZE, PROBE_HEADER_SIZE].contains(&base) {
        return Err(format!(
            "header size {header_size} (version 2 headers are {} bytes, {} for lightmap bakes, \
             {} for probe bakes)",
            HEADER_SIZE + BLOCK_SIZE,
            LIGHTMAP_HEADER_SIZE + BLOCK_SIZE,
            PROBE_HEADER_SIZE + BLOCK_SIZE
        ));
    }
    if bytes.len() < header_size {
        return Err(format!(
            "truncated: {} bytes, but the header alone is {header_size} bytes",
            bytes.len()
        ));
    }
    let payload = u64_at(bytes, 72);
    let found = (bytes.len() - header_size) as u64;
    if found < payload {
        return Err(format!(
            "truncated: the header announces {payload} bytes of compressed coefficients, the file holds {found}"
        ));
    }
    if found > payload {
        return Err(format!(
            "{} unexpected bytes after the {payload} bytes of compressed coefficients",
            found - payload
        ));
    }
    let stored = u32_at(bytes, CHECKSUM_OFFSET);
    let computed = checksum(bytes);
    if stored != computed {
        return Err(format!(
            "checksum mismatch (stored {stored:08x}, computed {computed:08x}): the file is corrupted"
        ));
    }
    // The fields the array sizes depend on; the version-1 reader checks the rest.
    let order = u32_at(bytes, 16);
    if !(1..=sh::MAX_ORDER as u32).contains(&order) {
        return Err(format!("SH order {order} is outside 1..={}", sh::MAX_ORDER));
    }
    let channels = u32_at(bytes, 20);
    if channels != 1 && channels != 3 {
        return Err(format!("{channels} channels (1 or 3 are defined)"));
    }
    // A matrix bake (transfer kind 1 at bytes 38..40) compresses its n⁴ floats per channel.
    let per_channel = match u16::from_le_bytes([bytes[38], bytes[39]]) {
        1 => sh::coeff_count(order as usize).pow(2),
        _ => sh::coeff_count(order as usize),
    };
    let dim = channels as u64 * per_channel as u64;
    let vertices = u64_at(bytes, 24);
    let clusters = u64::from(u32_at(bytes, base));
    let pcs = u64::from(u32_at(bytes, base + 4));
    let layout = u32_at(bytes, base + 8);
    let iterations = u32_at(bytes, base + 12);
    let seed = u64_at(bytes, base + 16);
    let rms_error = f32::from_le_bytes(bytes[base + 24..base + 28].try_into().expect("4 bytes"));
    if layout != LAYOUT_CONCATENATED {
        return Err(format!("unknown CPCA layout {layout}"));
    }
    if u32_at(bytes, base + 28) != 0 {
        return Err("reserved CPCA bytes are not zero".into());
    }
    if !(rms_error.is_finite() && rms_error >= 0.0) {
        return Err(format!(
            "CPCA error {rms_error} is not a non-negative number"
        ));
    }
    if clusters == 0 || clusters > vertices {
        return Err(format!(
            "{clusters} clusters for {vertices} receivers (1 to one per receiver)"
        ));
    }
    if pcs > dim {
        return Err(format!(
            "{pcs} principal components of {dim}-float transfer vectors (at most {dim})"
        ));
    }
    // Checked: a corrupted count must not wrap around to the payload's size.
    let arrays = clusters
        .checked_mul(dim)
        .and_then(|n| n.checked_mul(pcs + 1))
        .and_then(|n| n.checked_add(vertices.checked_mul(pcs + 1)?))
        .and_then(|n| n.checked_mul(4));
    let Some(arrays) = arrays.filter(|&n| n <= payload) else {
        return Err(format!(
            "{clusters} clusters of {pcs} components for {vertices} receivers need more than \
             the {payload} bytes the header announces"
        ));
    };
    // The reconstruction is larger than the file: checked against the memory limit first.
    let tail = (payload - arrays) as usize;
    let rebuilt = vertices
        .checked_mul(dim * 4)
        .and_then(|n| n.checked_add(base as u64 + tail as u64));
    let limit = crate::support::limits::max_memory();
    match rebuilt {
        Some(n) if n <= limit => {}
        _ => {
            return Err(format!(
                "its reconstruction needs {} of memory, over the limit of {} (--max-memory)",
                rebuilt.map_or_else(
                    || "more than 2^64 bytes".into(),
                    crate::support::limits::human
                ),
                crate::support::limits::human(limit)
            ));
        }
    }
    let (k, m, d, v) = (
        clusters as usize,
        pcs as usize,
        dim as usize,
        vertices as usize,
    );
    let floats = |start: usize, count: usize| -> Vec<f32> {
        bytes[start..start + 4 * count]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect()
    };
    let mut at = header_size;
    let means = floats(at, k * d);
    at += 4 * k * d;
    let bases = floats(at, k * m * d);
    at += 4 * k * m * d;
    let cluster: Vec<u32> = (0..v).map(|i| u32_at(bytes, at + 4 * i)).collect();
    at += 4 * v;
    let weights = floats(at, v * m);
    at += 4 * v * m;
    if let Some(i) = means.iter().position(|x| !x.is_finite()) {
        return Err(format!("mean {} of cluster {} is not finite", i % d, i / d));
    }
    if let Some(i) = bases.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "component {} of cluster {} is not finite",
            (i / d) % m,
            i / (d * m)
        ));
    }
    if let Some(i) = cluster.iter().position(|&c| u64::from(c) >= clusters) {
        return Err(format!(
            "receiver {i} is in cluster {}, of {clusters}",
            cluster[i]
        ));
    }
    if let Some(i) = weights.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "weight {} of receiver {} is not finite",
            i % m,
            i / m
        ));
    }
    let cpca = Cpca {
        dim: d,
        pcs: m,
        means,
        bases,
        cluster,
        weights,
        iterations,
        seed,
    };
    // The version-1 file these arrays stand for, checked by the version-1 reader.
    let coefficients = cpca.reconstruct();
    let mut v1 = Vec::with_capacity(rebuilt.unwrap_or(0) as usize);
    v1.extend_from_slice(&bytes[..base]);
    v1[8..12].copy_from_slice(&crate::formats::coefficient_file::VERSION.to_le_bytes());
    v1[12..16].copy_from_slice(&(base as u32).to_le_bytes());
    let v1_payload = vertices * dim * 4 + tail as u64;
    v1[72..80].copy_from_slice(&v1_payload.to_le_bytes());
    v1.extend(coefficients.iter().flat_map(|x| x.to_le_bytes()));
    v1.extend_from_slice(&bytes[at..]);
    seal(&mut v1);
    let file = CoefficientFile::from_version1_bytes(&v1)?;
    Ok(CompressedFile {
        file,
        cpca,
        rms_error,
        seed,
        checksum: stored,
    })
}

/// `prt-bake inspect` of a compressed file: the version, the file's own checksum and a
/// `compression` object added to the header's JSON. Nothing for other files.
pub fn annotate_inspect(bytes: &[u8], json: &mut serde_json::Value) {
    if !is_compressed(bytes) {
        return;
    }
    // The caller has read the file successfully, so it parses.
    let Ok(c) = from_bytes(bytes) else { return };
    json["version"] = json!(VERSION);
    json["checksum"] = json!(format!("{:08x}", c.checksum));
    json["compression"] = json!({
        "method": "cpca",
        "layout": "concatenated-channels",
        "clusters": c.cpca.clusters(),
        "pcs": c.cpca.pcs,
        "floats_per_vertex": c.cpca.floats_per_vertex(),
        "uncompressed_floats_per_vertex": c.cpca.dim,
        "rms_error": c.rms_error,
        "iterations": c.cpca.iterations,
        "seed": format!("{:016x}", c.seed),
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::transfer::{Aux, Mode};
    use crate::formats::coefficient_file::{Header, VERSION as V1};
    use crate::math::sampling::Sampling;
    use crate::trace::Backend;

    /// A grey order-2 file of `v` vertices with AO.
    fn file(v: usize) -> CoefficientFile {
        CoefficientFile {
            header: Header {
                version: V1,
                order: 2,
                channels: 1,
                vertex_count: v as u64,
                samples_per_vertex: 64,
                mode: Mode::Shadowed,
                transfer: Default::default(),
                bounces: 0,
                bounce_samples: 0,
                backend: Backend::Embree,
                sampling: Sampling::OwenSobol,
                seed: 1,
                scene_fingerprint: 0xabc,
                aux: Aux {
                    ao: true,
                    bent_normal: false,
                },
                up: crate::scene::Up::Z,
                checksum: 0,
                adaptive: None,
                receivers: None,
                denoised: false,
            },
            coefficients: (0..v * 4).map(|i| ((i * 37) % 11) as f32 / 11.0).collect(),
            ao: Some((0..v).map(|i| (i % 3) as f32 / 2.0).collect()),
            bent_normal: None,
            rays: None,
            error_estimate: None,
            lightmap: None,
            probes: None,
        }
    }

    fn compressed(v: usize, k: usize, m: usize) -> (CoefficientFile, Cpca, Vec<u8>) {
        let f = file(v);
        let cpca = crate::math::cpca::compress(&f.coefficients, 4, k, m).unwrap();
        let bytes = to_bytes(&f, &cpca, 0.0);
        (f, cpca, bytes)
    }

    #[test]
    fn round_trip() {
        let (f, cpca, bytes) = compressed(40, 5, 2);
        assert_eq!(bytes.len(), 160 + 4 * (5 * 4 * 3 + 40 * 3) + 40 * 4);
        let read = from_bytes(&bytes).unwrap();
        assert_eq!(read.cpca, cpca);
        assert_eq!(read.file.coefficients, cpca.reconstruct());
        assert_eq!(read.file.ao, f.ao);
        assert_eq!(read.file.header.version, V1);
        // Through the version-1 reader's hook too.
        assert_eq!(CoefficientFile::from_bytes(&bytes).unwrap(), read.file);
        // Lossless with one cluster per vertex: the original file's bytes come back.
        let (f, _, bytes) = compressed(40, 40, 1);
        let read = from_bytes(&bytes).unwrap();
        assert_eq!(read.file.to_bytes().0, f.to_bytes().0);
    }

    #[test]
    fn corrupted_files_are_refused() {
        let (_, _, good) = compressed(40, 5, 2);
        let means = 160;
        let clusters_at = means + 4 * (5 * 4 * 3);
        let weights_at = clusters_at + 4 * 40;
        type Corruption = Box<dyn Fn(&mut Vec<u8>)>;
        let set = |o: usize, x: u32| -> Corruption {
            Box::new(move |b: &mut Vec<u8>| b[o..o + 4].copy_from_slice(&x.to_le_bytes()))
        };
        let cases: Vec<(&str, Corruption, bool)> = vec![
            (
                "checksum mismatch",
                Box::new(|b: &mut Vec<u8>| b[200] ^= 1),
                false,
            ),
            (
                "truncated",
                Box::new(|b: &mut Vec<u8>| b.truncate(300)),
                false,
            ),
            (
                "unexpected bytes",
                Box::new(|b: &mut Vec<u8>| b.push(0)),
                false,
            ),
            ("header size 128", set(12, 128), true),
            ("0 clusters", set(128, 0), true),
            ("41 clusters for 40", set(128, 41), true),
            ("need more than", set(24, 1_000_000_000), true),
            ("5 principal components", set(132, 5), true),
            ("unknown CPCA layout", set(136, 1), true),
            ("reserved CPCA bytes", set(156, 1), true),
            ("CPCA error", set(152, f32::NAN.to_bits()), true),
            (
                "mean 1 of cluster 0",
                set(means + 4, f32::INFINITY.to_bits()),
                true,
            ),
            ("receiver 3 is in cluster 5", set(clusters_at + 12, 5), true),
            (
                "weight 1 of receiver 2",
                set(weights_at + 20, f32::NAN.to_bits()),
                true,
            ),
            // Finite arrays whose reconstruction is not: the version-1 checks still run.
            (
                "coefficient 0 of vertex 0 is not finite",
                Box::new(move |b: &mut Vec<u8>| {
                    let max = f32::MAX.to_le_bytes();
                    b[clusters_at..clusters_at + 4].fill(0);
                    b[weights_at..weights_at + 4].copy_from_slice(&max);
                    b[means + 4 * 4 * 5..means + 4 * 4 * 5 + 4].copy_from_slice(&max);
                }),
                true,
            ),
            ("SH order 0", set(16, 0), true),
            ("unknown transfer mode", set(36, 9), true),
            (
                "ambient accessibility of vertex 0",
                set(weights_at + 320, 2.0f32.to_bits()),
                true,
            ),
            ("unexpected bytes", set(72, 7), true),
        ];
        for (message, corrupt, reseal) in cases {
            let mut bytes = good.clone();
            corrupt(&mut bytes);
            if reseal {
                seal(&mut bytes);
            }
            match CoefficientFile::from_bytes(&bytes) {
                Err(m) => assert!(m.contains(message), "{message}: {m}"),
                Ok(_) => panic!("{message}: accepted"),
            }
        }
    }

    #[test]
    fn version_1_files_are_untouched() {
        let f = file(10);
        let (bytes, _) = f.to_bytes();
        assert!(!is_compressed(&bytes));
        let read = CoefficientFile::from_bytes(&bytes).unwrap();
        assert_eq!(read.to_bytes().0, bytes);
    }
}

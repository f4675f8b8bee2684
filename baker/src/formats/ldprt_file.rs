//! The LDPRT file (`bake --transfer ldprt`, docs/reference/ldprt-format.md): per vertex, K
//! zonal-harmonic lobes, each an axis in the vertex's frame and `order` zonal coefficients
//! per channel, and the fit's relative error. Little-endian; a 96-byte header, three arrays,
//! then a CRC-32 of everything before it.

use crate::formats::header::Mode;
use crate::scene::Up;

/// First 8 bytes (the coefficient file's pattern: non-ASCII byte, CR LF, ^Z).
pub const MAGIC: [u8; 8] = *b"\x89LDP\r\n\x1a\n";
pub const VERSION: u32 = 1;
pub const HEADER_SIZE: usize = 96;
/// Most lobes per vertex a reader accepts.
pub const MAX_LOBES: u32 = 8;
/// Longest pose text (bytes) a reader accepts.
pub const MAX_POSE_BYTES: u32 = 4096;

/// The fit's relative L2 error over the vertices: what LDPRT loses against the SH bake
/// before any deformation.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FitError {
    pub mean: f32,
    pub p99: f32,
    pub max: f32,
}

impl FitError {
    /// Mean, 99th percentile (nearest rank) and largest of per-vertex errors.
    pub fn of(errors: &[f32]) -> FitError {
        if errors.is_empty() {
            return FitError::default();
        }
        let mut sorted = errors.to_vec();
        sorted.sort_by(f32::total_cmp);
        let rank = ((0.99 * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
        FitError {
            mean: (errors.iter().map(|&e| f64::from(e)).sum::<f64>() / errors.len() as f64) as f32,
            p99: sorted[rank - 1],
            max: sorted[sorted.len() - 1],
        }
    }
}

/// An LDPRT file in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct LdprtFile {
    /// SH order n of the bake fitted (bands 0..n−1): n zonal coefficients per lobe.
    pub order: u32,
    /// Lobes per vertex, K.
    pub lobes: u32,
    /// 1 (shadowed, grey) or 3 (interreflected, RGB).
    pub channels: u32,
    pub vertex_count: u64,
    pub samples_per_vertex: u32,
    pub mode: Mode,
    pub bounces: u32,
    pub up: Up,
    pub seed: u64,
    /// The baked (rest-pose) scene's fingerprint.
    pub scene_fingerprint: u64,
    /// [`topology_fingerprint`] of the mesh: a posed mesh must have the same.
    pub topology: u64,
    pub error: FitError,
    /// Per vertex and lobe, the unit axis in the vertex's (tangent, bitangent, normal) frame.
    pub axes: Vec<[f32; 3]>,
    /// Per vertex, lobe, channel and band: index `((v·K + k)·channels + c)·order + l`.
    pub zh: Vec<f32>,
    /// Per vertex, the fit's relative L2 error.
    pub vertex_error: Vec<f32>,
    /// For a bake of a skinned glTF, the pose it was baked in (`rest`, `ANIM@SECONDS`,
    /// `ANIM#KEYFRAME`): relit on a pose of that skin, the lobes' axes follow the skin
    /// from it. `None` for other meshes: the axes follow each vertex's rebuilt frame.
    pub pose: Option<String>,
}

/// FNV-1a over the vertex count and the triangles' indices: equal for meshes of the same
/// topology whatever their pose.
pub fn topology_fingerprint(vertex_count: usize, triangles: &[[u32; 3]]) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            hash = (hash ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(&(vertex_count as u64).to_le_bytes());
    for t in triangles {
        for i in t {
            eat(&i.to_le_bytes());
        }
    }
    hash
}

/// Whether `bytes` start as an LDPRT file does.
pub fn is_ldprt(bytes: &[u8]) -> bool {
    bytes.len() >= MAGIC.len() && bytes[..MAGIC.len()] == MAGIC
}

fn mode_code(mode: Mode) -> u16 {
    match mode {
        Mode::Unshadowed => 0,
        Mode::Shadowed => 1,
        Mode::Interreflected => 2,
    }
}

impl LdprtFile {
    /// Floats of the three arrays per vertex: 3K + K·channels·order + 1.
    fn floats_per_vertex(order: u32, lobes: u32, channels: u32) -> u64 {
        u64::from(3 * lobes + lobes * channels * order + 1)
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER_SIZE + 4 * (self.axes.len() * 3 + self.zh.len()));
        b.extend(MAGIC);
        b.extend(VERSION.to_le_bytes());
        b.extend(self.order.to_le_bytes());
        b.extend(self.lobes.to_le_bytes());
        b.extend(self.channels.to_le_bytes());
        b.extend(self.vertex_count.to_le_bytes());
        b.extend(self.samples_per_vertex.to_le_bytes());
        b.extend(mode_code(self.mode).to_le_bytes());
        b.extend(0u16.to_le_bytes());
        b.extend(self.bounces.to_le_bytes());
        b.extend(self.up.code().to_le_bytes());
        b.extend(self.seed.to_le_bytes());
        b.extend(self.scene_fingerprint.to_le_bytes());
        b.extend(self.topology.to_le_bytes());
        for e in [self.error.mean, self.error.p99, self.error.max] {
            b.extend(e.to_le_bytes());
        }
        let pose = self.pose.as_deref().unwrap_or("");
        b.extend((pose.len() as u32).to_le_bytes());
        b.resize(HEADER_SIZE, 0);
        b.extend(pose.as_bytes());
        for a in &self.axes {
            for x in a {
                b.extend(x.to_le_bytes());
            }
        }
        for x in self.zh.iter().chain(&self.vertex_error) {
            b.extend(x.to_le_bytes());
        }
        let crc = crc32fast::hash(&b);
        b.extend(crc.to_le_bytes());
        b
    }

    /// Reads and checks a file: magic, version, sizes, checksum, finite values, unit axes.
    pub fn from_bytes(bytes: &[u8]) -> Result<LdprtFile, String> {
        if !is_ldprt(bytes) {
            return Err("not an LDPRT file (bad magic)".into());
        }
        if bytes.len() < HEADER_SIZE + 4 {
            return Err(format!(
                "truncated: {} bytes, the header alone is {HEADER_SIZE}",
                bytes.len()
            ));
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let version = u32_at(8);
        if version != VERSION {
            return Err(format!(
                "LDPRT version {version} is not supported (this build reads {VERSION})"
            ));
        }
        let (order, lobes, channels) = (u32_at(12), u32_at(16), u32_at(20));
        if !(1..=crate::math::sh::MAX_ORDER as u32).contains(&order) {
            return Err(format!(
                "order {order} is outside 1..={}",
                crate::math::sh::MAX_ORDER
            ));
        }
        if !(1..=MAX_LOBES).contains(&lobes) {
            return Err(format!(
                "{lobes} lobes per vertex is outside 1..={MAX_LOBES}"
            ));
        }
        if channels != 1 && channels != 3 {
            return Err(format!("{channels} channels (1 or 3 expected)"));
        }
        let vertex_count = u64_at(24);
        let pose_bytes = u32_at(84);
        if pose_bytes > MAX_POSE_BYTES {
            return Err(format!(
                "a pose of {pose_bytes} bytes (at most {MAX_POSE_BYTES})"
            ));
        }
        let arrays = HEADER_SIZE + pose_bytes as usize;
        let per_vertex = LdprtFile::floats_per_vertex(order, lobes, channels);
        let expected = vertex_count
            .checked_mul(per_vertex * 4)
            .and_then(|p| p.checked_add(arrays as u64 + 4));
        if expected != Some(bytes.len() as u64) {
            return Err(format!(
                "{} bytes, but {vertex_count} vertices of {lobes} lobes at order {order} with \
                 {channels} channel(s) and a pose of {pose_bytes} bytes need {}",
                bytes.len(),
                expected.map_or("more than 2^64".into(), |e| e.to_string())
            ));
        }
        let body = bytes.len() - 4;
        let stored = u32_at(body);
        let computed = crc32fast::hash(&bytes[..body]);
        if stored != computed {
            return Err(format!(
                "checksum {stored:#010x} does not match the content ({computed:#010x})"
            ));
        }
        let mode = match u16::from_le_bytes([bytes[36], bytes[37]]) {
            0 => Mode::Unshadowed,
            1 => Mode::Shadowed,
            2 => Mode::Interreflected,
            other => return Err(format!("unknown mode code {other}")),
        };
        let up = Up::from_code(u32_at(44))
            .ok_or_else(|| format!("unknown up axis code {}", u32_at(44)))?;
        let pose = match pose_bytes {
            0 => None,
            _ => Some(
                std::str::from_utf8(&bytes[HEADER_SIZE..arrays])
                    .map_err(|_| "the pose is not UTF-8 text".to_string())?
                    .to_owned(),
            ),
        };
        let floats: Vec<f32> = bytes[arrays..body]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect();
        if let Some(i) = floats.iter().position(|x| !x.is_finite()) {
            return Err(format!("a non-finite value at byte {}", arrays + 4 * i));
        }
        let v = vertex_count as usize;
        let (k, c, n) = (lobes as usize, channels as usize, order as usize);
        let axes: Vec<[f32; 3]> = floats[..v * k * 3]
            .chunks_exact(3)
            .map(|a| [a[0], a[1], a[2]])
            .collect();
        if let Some(i) = axes
            .iter()
            .position(|a| (glam::Vec3::from_array(*a).length() - 1.0).abs() > 1e-3)
        {
            return Err(format!(
                "lobe axis {} (vertex {}) is not unit length",
                i % k,
                i / k
            ));
        }
        let zh_end = v * k * 3 + v * k * c * n;
        Ok(LdprtFile {
            order,
            lobes,
            channels,
            vertex_count,
            samples_per_vertex: u32_at(32),
            mode,
            bounces: u32_at(40),
            up,
            seed: u64_at(48),
            scene_fingerprint: u64_at(56),
            topology: u64_at(64),
            error: FitError {
                mean: f32_at(72),
                p99: f32_at(76),
                max: f32_at(80),
            },
            axes,
            zh: floats[v * k * 3..zh_end].to_vec(),
            vertex_error: floats[zh_end..].to_vec(),
            pose,
        })
    }

    /// Reads `path`; errors name it.
    pub fn read(path: &std::path::Path) -> crate::support::error::Result<LdprtFile> {
        let bytes = crate::support::limits::read_file(path)?;
        LdprtFile::from_bytes(&bytes).map_err(|m| crate::Error::coefficient_file(path, m))
    }

    /// The zonal coefficients of vertex `v`, lobe `k`, channel `c` (`order` of them).
    pub fn zh(&self, v: usize, k: usize, c: usize) -> &[f32] {
        let n = self.order as usize;
        let start = ((v * self.lobes as usize + k) * self.channels as usize + c) * n;
        &self.zh[start..start + n]
    }

    /// The header as `prt-bake inspect` prints it.
    pub fn inspect_json(&self) -> serde_json::Value {
        serde_json::json!({
            "format": "ldprt",
            "version": VERSION,
            "order": self.order,
            "lobes": self.lobes,
            "channels": self.channels,
            "vertex_count": self.vertex_count,
            "samples_per_vertex": self.samples_per_vertex,
            "mode": self.mode.name(),
            "bounces": self.bounces,
            "up": self.up.name(),
            "seed": self.seed,
            "scene_fingerprint": format!("{:016x}", self.scene_fingerprint),
            "topology_fingerprint": format!("{:016x}", self.topology),
            "fit_error": self.error,
            "pose": self.pose,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> LdprtFile {
        LdprtFile {
            order: 2,
            lobes: 2,
            channels: 1,
            vertex_count: 1,
            samples_per_vertex: 64,
            mode: Mode::Shadowed,
            bounces: 0,
            up: Up::Z,
            seed: 7,
            scene_fingerprint: 1,
            topology: 2,
            error: FitError {
                mean: 0.1,
                p99: 0.1,
                max: 0.1,
            },
            axes: vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            zh: vec![1.0, 0.5, 0.25, 0.125],
            vertex_error: vec![0.1],
            pose: None,
        }
    }

    #[test]
    fn round_trips_and_refuses_damage() {
        let posed = LdprtFile {
            pose: Some("bend@0.5".into()),
            ..sample()
        };
        assert_eq!(LdprtFile::from_bytes(&posed.to_bytes()).unwrap(), posed);
        let file = sample();
        let bytes = file.to_bytes();
        assert_eq!(LdprtFile::from_bytes(&bytes).unwrap(), file);
        let mut bad = bytes.clone();
        bad[HEADER_SIZE] ^= 1;
        assert!(
            LdprtFile::from_bytes(&bad)
                .unwrap_err()
                .contains("checksum")
        );
        assert!(
            LdprtFile::from_bytes(&bytes[..bytes.len() - 1])
                .unwrap_err()
                .contains("bytes")
        );
    }

    #[test]
    fn fit_error_percentile() {
        let errors: Vec<f32> = (1..=200).map(|i| i as f32).collect();
        let e = FitError::of(&errors);
        assert_eq!((e.p99, e.max), (198.0, 200.0));
    }
}

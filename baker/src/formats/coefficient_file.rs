//! The coefficient file (`.prt`): a 128-byte little-endian header, then f32 transfer
//! coefficients, vertex-major. `docs/reference/coefficient-format.md` is the specification; this module
//! is its reference implementation.
//!
//! Files are written atomically (temporary file in the same folder, then rename), so a failed
//! or interrupted bake never leaves a partial file under the output name. The reader checks
//! everything — size, magic, version, checksum, every field, every float — before it returns.

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::formats::encoded::Encoded;
use crate::formats::header::{
    AtlasSource, CHECKSUM_OFFSET, OBJECT_PLACEMENT_BYTES, ObjectPlacement, checksum, parse_header,
};
use crate::formats::object_placements;
use crate::formats::part_id::PartId;
use crate::formats::probe_block::ProbeBlock;
use crate::formats::receiver_section::ReceiverObjects;
use crate::support::error::Result;

/// The header is the file's own part: its fields and sizes are named here too.
pub use crate::formats::header::{
    Adaptive, HEADER_SIZE, Header, LIGHTMAP_HEADER_SIZE, LIGHTMAP_PART_HEADER_SIZE, MAGIC,
    PROBE_HEADER_SIZE, VERSION,
};

/// A coefficient file in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct CoefficientFile {
    pub header: Header,
    /// `coefficients[(v · channels + c) · n² + j]`.
    pub coefficients: Vec<f32>,
    /// Per-vertex ambient accessibility, if `header.aux.ao`.
    pub ao: Option<Vec<f32>>,
    /// Per-vertex bent normals, if `header.aux.bent_normal`.
    pub bent_normal: Option<Vec<Vec3>>,
    /// Adaptive bakes (`header.adaptive`): rays each vertex cast.
    pub rays: Option<Vec<u32>>,
    /// Adaptive bakes: each vertex's estimated RMS coefficient error.
    pub error_estimate: Option<Vec<f32>>,
    /// Texel bakes only: the lightmap's size, validity mask and UVs. The "vertices" of such
    /// a file are the W×H texels, row-major.
    pub lightmap: Option<LightmapBlock>,
    /// Probe bakes only: the probes' positions and grid; the "vertices" are the probes.
    pub probes: Option<ProbeBlock>,
}

/// What a texel bake stores beyond a vertex bake (docs/reference/coefficient-format.md, "Lightmap
/// (texel) bakes").
#[derive(Clone, Debug, PartialEq)]
pub struct LightmapBlock {
    pub width: u32,
    pub height: u32,
    /// The scene's vertex and triangle counts (the file's own vertex count is W·H).
    pub scene_vertex_count: u64,
    pub scene_triangle_count: u64,
    /// `--texel-size`, or 0 where the charts were scaled to fill the atlas.
    pub texel_size: f32,
    pub source: AtlasSource,
    /// Per texel (row-major), whether a triangle covers it (its transfer was baked).
    pub valid: Vec<bool>,
    /// Per texel, whether it is padding filled from baked neighbours (dilation).
    pub dilated: Vec<bool>,
    /// Per scene triangle, its corners' lightmap UVs in [0, 1] ((−1, −1) for a triangle left
    /// out of the atlas).
    pub uv1: Vec<[Vec2; 3]>,
    /// [`AtlasSource::PerObject`] atlases only: per scene object, where its own UVs went.
    pub objects: Vec<ObjectPlacement>,
}

impl LightmapBlock {
    /// Bytes after the aux arrays: the UVs (f32), the mask (u8), and for a per-object atlas
    /// the object count (u32) and placements.
    fn payload_bytes(&self) -> u64 {
        let objects = match self.source {
            AtlasSource::PerObject => 4 + (OBJECT_PLACEMENT_BYTES * self.objects.len()) as u64,
            _ => 0,
        };
        self.scene_triangle_count * 6 * 4 + u64::from(self.width) * u64::from(self.height) + objects
    }

    /// [`LightmapBlock::payload_bytes`] of a block read from a file: `None` where a corrupted
    /// count overflows.
    fn checked_payload_bytes(&self) -> Option<u64> {
        self.scene_triangle_count
            .checked_mul(6 * 4)?
            .checked_add(u64::from(self.width) * u64::from(self.height))
    }
}

/// `M` floats' little-endian bytes, in order (`N` = 4·`M`).
fn le_floats<const M: usize, const N: usize>(floats: [f32; M]) -> [u8; N] {
    let mut out = [0u8; N];
    for (o, f) in out.chunks_exact_mut(4).zip(floats) {
        o.copy_from_slice(&f.to_le_bytes());
    }
    out
}

impl CoefficientFile {
    /// Bytes after the header.
    fn payload_bytes(&self) -> u64 {
        let probes = self.probes.as_ref().map_or(0, ProbeBlock::arrays_bytes);
        self.header.payload_bytes()
            + self.lightmap.as_ref().map_or(0, |l| l.payload_bytes())
            + probes
    }

    fn header_size(&self) -> usize {
        match (&self.lightmap, &self.probes) {
            (Some(_), _) => LIGHTMAP_HEADER_SIZE,
            (None, Some(_)) => PROBE_HEADER_SIZE,
            (None, None) => HEADER_SIZE,
        }
    }

    /// Coefficients of vertex `v`, channel `c` (a matrix bake's n⁴, row-major).
    pub fn vertex(&self, v: usize, c: usize) -> &[f32] {
        let n = self
            .header
            .transfer
            .floats_per_channel(self.header.order as usize);
        let start = (v * self.header.channels as usize + c) * n;
        &self.coefficients[start..start + n]
    }

    /// The file's bytes; the checksum field is computed (and stored in the returned header).
    pub fn to_bytes(&self) -> (Vec<u8>, u32) {
        let (encoded, checksum) = self.encode();
        (encoded.into_vec(), checksum)
    }

    /// [`CoefficientFile::to_bytes`] in pieces, its arrays borrowed where it can
    /// ([`Encoded`]): what a bake writes.
    pub fn encode(&self) -> (Encoded<'_>, u32) {
        let h = &self.header;
        let mut head = Vec::with_capacity(self.header_size());
        head.extend(h.encode(self.header_size(), self.payload_bytes()));
        if let Some(l) = &self.lightmap {
            head.extend(l.width.to_le_bytes());
            head.extend(l.height.to_le_bytes());
            head.extend(l.scene_vertex_count.to_le_bytes());
            head.extend(l.scene_triangle_count.to_le_bytes());
            head.extend(l.texel_size.to_le_bytes());
            head.extend(l.source.code().to_le_bytes());
        }
        head.extend(
            self.probes
                .as_ref()
                .map(ProbeBlock::encode_block)
                .unwrap_or_default(),
        );
        let mut bytes = Encoded::from(head);
        bytes.put(&self.coefficients, f32::to_le_bytes);
        bytes.put(self.ao.as_deref().unwrap_or_default(), f32::to_le_bytes);
        let bent = self.bent_normal.as_deref().unwrap_or_default();
        bytes.put(bent, |n| le_floats::<3, 12>(n.to_array()));
        bytes.put(self.rays.as_deref().unwrap_or_default(), u32::to_le_bytes);
        let errors = self.error_estimate.as_deref().unwrap_or_default();
        bytes.put(errors, f32::to_le_bytes);
        if let Some(l) = &self.lightmap {
            bytes.put(&l.uv1, |c| {
                le_floats::<6, 24>([c[0].x, c[0].y, c[1].x, c[1].y, c[2].x, c[2].y])
            });
            let state = |(&valid, &dilated): (&bool, &bool)| match (valid, dilated) {
                (true, _) => 1u8,
                (false, true) => 2,
                (false, false) => 0,
            };
            bytes.push(l.valid.par_iter().zip(&l.dilated).map(state).collect());
            if l.source == AtlasSource::PerObject {
                bytes.push(object_placements::encode(&l.objects));
            }
        }
        bytes.push(
            self.probes
                .iter()
                .flat_map(ProbeBlock::encode_arrays)
                .collect(),
        );
        if let Some(r) = &h.receivers {
            bytes.push(r.encode());
        }
        debug_assert_eq!(
            bytes.len() as u64,
            self.header_size() as u64 + self.payload_bytes()
        );
        let checksum = bytes.seal();
        (bytes, checksum)
    }

    /// Writes the file atomically: nothing appears under `path` unless all of it was written.
    pub fn write(&mut self, path: &Path) -> Result<()> {
        let (bytes, checksum) = self.to_bytes();
        crate::support::atomic::write(path, &bytes)?;
        self.header.checksum = checksum;
        Ok(())
    }

    /// Parses and validates a version-1 file's bytes; the error is a sentence for the user.
    /// [`CoefficientFile::from_bytes`] reads every version.
    pub fn from_version1_bytes(bytes: &[u8]) -> std::result::Result<CoefficientFile, String> {
        let (header, payload, header_size) = parse_header(bytes)?;
        if let Some(shard) = PartId::from_header_bytes(bytes)? {
            return Err(format!(
                "a shard part ({shard}) of a bake, not a whole bake: combine the parts with `prt-bake merge`"
            ));
        }
        if header_size == LIGHTMAP_PART_HEADER_SIZE {
            return Err(format!(
                "header size {header_size} without a shard identity (only lightmap shard parts \
                 have {header_size}-byte headers)"
            ));
        }
        let mut lightmap = match header_size == LIGHTMAP_HEADER_SIZE {
            true => Some(LightmapBlock::from_header_bytes(bytes, &header)?),
            false => None,
        };
        let probes = match header_size == PROBE_HEADER_SIZE {
            true => Some(ProbeBlock::read(bytes, &header, payload)?),
            false => None,
        };
        let section = match probes {
            Some(_) => 0,
            None => check_payload_size(&header, lightmap.as_ref(), payload)? as usize,
        };
        let mut header = header;
        if header.receivers.is_some() {
            header.receivers = Some(ReceiverObjects::decode(&bytes[bytes.len() - section..])?);
        }
        let mut floats = bytes[header_size..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")));
        let arrays = Arrays::read(&header, &mut floats, lightmap.is_some())?;
        if let Some(l) = lightmap.as_mut() {
            let end = bytes.len() - section;
            let mask = &bytes[end - header.vertex_count as usize..end];
            l.read_payload(&mut floats, mask)?;
            l.read_objects(&bytes[end..])?;
            // Adaptive texel bakes: the baked texels cast rays, the others none.
            if let Some(t) = arrays
                .rays
                .as_ref()
                .and_then(|rays| (0..rays.len()).find(|&t| (rays[t] > 0) != l.valid[t]))
            {
                return Err(format!(
                    "texel {t} cast {} rays but is {}baked",
                    arrays.rays.as_ref().expect("rays")[t],
                    if l.valid[t] { "" } else { "not " }
                ));
            }
        }
        Ok(CoefficientFile {
            header,
            coefficients: arrays.coefficients,
            ao: arrays.ao,
            bent_normal: arrays.bent_normal,
            rays: arrays.rays,
            error_estimate: arrays.error_estimate,
            lightmap,
            probes,
        })
    }
}

/// Refuses a payload whose length is not what the header's counts need. Checked: a
/// corrupted count must not wrap around to the payload's size. Returns the length of a
/// per-object atlas's trailing section (the rest of the payload: a count and whole
/// placements), 0 for other files.
fn check_payload_size(
    header: &Header,
    lightmap: Option<&LightmapBlock>,
    payload: u64,
) -> std::result::Result<u64, String> {
    let needed = header
        .vertex_count
        .checked_mul((header.coefficients_per_vertex() + header.aux_floats_per_vertex()) as u64 * 4)
        .and_then(|n| match lightmap {
            Some(l) => l.checked_payload_bytes().and_then(|m| n.checked_add(m)),
            None => Some(n),
        });
    if header.receivers.is_some() {
        // A receiver section ends a vertex file; texel bakes cover every object.
        return match (lightmap, needed) {
            (Some(_), _) => Err("a texel bake with a receiver section (aux bit 4)".into()),
            (None, Some(n)) if n.checked_add(8).is_some_and(|m| payload >= m) => Ok(payload - n),
            _ => Err(format!(
                "{} vertices × {} coefficients and a receiver section need more than the {payload} bytes the header announces",
                header.vertex_count,
                header.coefficients_per_vertex()
            )),
        };
    }
    let per_object = lightmap.is_some_and(|l| l.source == AtlasSource::PerObject);
    object_placements::section_bytes(header, needed, payload, per_object)
}

/// A file's per-vertex arrays, in the order they are stored.
struct Arrays {
    coefficients: Vec<f32>,
    ao: Option<Vec<f32>>,
    bent_normal: Option<Vec<Vec3>>,
    rays: Option<Vec<u32>>,
    error_estimate: Option<Vec<f32>>,
}

impl Arrays {
    /// Reads and checks the arrays `header` announces from `floats`.
    fn read(
        header: &Header,
        floats: &mut impl Iterator<Item = f32>,
        texels: bool,
    ) -> std::result::Result<Arrays, String> {
        let vertices = header.vertex_count as usize;
        let coefficients: Vec<f32> = floats
            .by_ref()
            .take(vertices * header.coefficients_per_vertex())
            .collect();
        let ao: Option<Vec<f32>> = header
            .aux
            .ao
            .then(|| floats.by_ref().take(vertices).collect());
        let bent_normal: Option<Vec<Vec3>> = header.aux.bent_normal.then(|| {
            let flat: Vec<f32> = floats.by_ref().take(3 * vertices).collect();
            flat.chunks_exact(3).map(Vec3::from_slice).collect()
        });
        let rays: Option<Vec<u32>> = header.adaptive.map(|_| {
            // u32s: the same 4 little-endian bytes, reinterpreted.
            let bits = floats.by_ref().take(vertices).map(f32::to_bits);
            bits.collect()
        });
        let error_estimate: Option<Vec<f32>> = header
            .adaptive
            .map(|_| floats.by_ref().take(vertices).collect());
        check_adaptive_arrays(header, rays.as_deref(), error_estimate.as_deref(), texels)?;
        check_floats(header, &coefficients, ao.as_deref(), bent_normal.as_deref())?;
        Ok(Arrays {
            coefficients,
            ao,
            bent_normal,
            rays,
            error_estimate,
        })
    }
}

/// An adaptive bake's per-vertex rays (within the samples, adding up to the header's total)
/// and estimated errors (non-negative). In a texel bake (`texels`) the texels no triangle
/// covers cast none.
fn check_adaptive_arrays(
    header: &Header,
    rays: Option<&[u32]>,
    error_estimate: Option<&[f32]>,
    texels: bool,
) -> std::result::Result<(), String> {
    if let (Some(adaptive), Some(rays)) = (header.adaptive, rays) {
        let least = u32::from(!texels);
        if let Some(v) = rays
            .iter()
            .position(|r| !(least..=header.samples_per_vertex).contains(r))
        {
            return Err(format!(
                "{} {v} cast {} rays, outside {least}..={} (the samples per {0})",
                if texels { "texel" } else { "vertex" },
                rays[v],
                header.samples_per_vertex
            ));
        }
        let total: u64 = rays.iter().map(|&r| u64::from(r)).sum();
        if total != adaptive.rays_cast {
            return Err(format!(
                "the per-vertex rays add up to {total}, the header says {} were cast",
                adaptive.rays_cast
            ));
        }
    }
    if let Some(v) = error_estimate
        .iter()
        .copied()
        .flatten()
        .position(|e| !(e.is_finite() && *e >= 0.0))
    {
        return Err(format!(
            "estimated error of vertex {v} is not a non-negative number"
        ));
    }
    Ok(())
}

impl LightmapBlock {
    /// The texel block of a lightmap header (bytes 128..160), its arrays still empty.
    fn from_header_bytes(
        bytes: &[u8],
        header: &Header,
    ) -> std::result::Result<LightmapBlock, String> {
        LightmapBlock::from_block_bytes(&bytes[128..160], header, "a file")
    }

    /// The 32 bytes of a texel block, where a whole texel file (at 128) and a texel part
    /// (at 128, followed by its atlas block) keep them; `holder` names which, for the error.
    pub(crate) fn from_block_bytes(
        block: &[u8],
        header: &Header,
        holder: &str,
    ) -> std::result::Result<LightmapBlock, String> {
        let u32_at = |o: usize| u32::from_le_bytes(block[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(block[o..o + 8].try_into().expect("8 bytes"));
        let (width, height) = (u32_at(0), u32_at(4));
        if u64::from(width) * u64::from(height) != header.vertex_count {
            return Err(format!(
                "a {width}×{height} lightmap in {holder} of {} texels",
                header.vertex_count
            ));
        }
        let source = AtlasSource::from_code(u32_at(28))
            .ok_or_else(|| format!("unknown atlas source {}", u32_at(28)))?;
        let texel_size = f32::from_le_bytes(block[24..28].try_into().expect("4 bytes"));
        if !(texel_size.is_finite() && texel_size >= 0.0) {
            return Err(format!("texel size {texel_size} is not a size"));
        }
        Ok(LightmapBlock {
            width,
            height,
            scene_vertex_count: u64_at(8),
            scene_triangle_count: u64_at(16),
            texel_size,
            source,
            valid: Vec::new(),
            dilated: Vec::new(),
            uv1: Vec::new(),
            objects: Vec::new(),
        })
    }

    /// A per-object atlas's placements (empty section: none).
    fn read_objects(&mut self, section: &[u8]) -> std::result::Result<(), String> {
        self.objects = object_placements::decode(section)?;
        Ok(())
    }

    /// The block's arrays after the aux arrays: the triangles' UVs, then the texel states.
    fn read_payload(
        &mut self,
        floats: &mut impl Iterator<Item = f32>,
        mask: &[u8],
    ) -> std::result::Result<(), String> {
        let uv: Vec<f32> = floats
            .by_ref()
            .take(self.scene_triangle_count as usize * 6)
            .collect();
        self.uv1 = triangle_uvs(&uv)?;
        if let Some(i) = mask.iter().position(|&b| b > 2) {
            return Err(format!("state of texel {i} is {} (0, 1 or 2)", mask[i]));
        }
        self.valid = mask.iter().map(|&b| b == 1).collect();
        self.dilated = mask.iter().map(|&b| b == 2).collect();
        Ok(())
    }
}

/// Checks every float of a file's (or a part's) arrays; `coefficients` holds whole vertices
/// of `coefficients.len() / vertices` floats each.
pub(crate) fn check_floats(
    header: &Header,
    coefficients: &[f32],
    ao: Option<&[f32]>,
    bent_normal: Option<&[Vec3]>,
) -> std::result::Result<(), String> {
    if let Some(v) = ao
        .iter()
        .copied()
        .flatten()
        .position(|a| !(0.0..=1.0).contains(a))
    {
        return Err(format!(
            "ambient accessibility of vertex {v} is outside [0, 1]"
        ));
    }
    if let Some(v) = bent_normal
        .iter()
        .copied()
        .flatten()
        .position(|n| !n.is_finite() || (n.length() - 1.0).abs() > 1e-3)
    {
        return Err(format!("bent normal of vertex {v} is not a unit vector"));
    }
    if let Some(i) = coefficients.iter().position(|c| !c.is_finite()) {
        let per_vertex = header.coefficients_per_vertex();
        return Err(format!(
            "coefficient {} of vertex {} is not finite",
            i % per_vertex,
            i / per_vertex
        ));
    }
    Ok(())
}

/// Per triangle its 3 corners' lightmap UVs, from 6 floats a triangle (a texel file's or a
/// texel part's UV array), every one finite.
pub(crate) fn triangle_uvs(floats: &[f32]) -> std::result::Result<Vec<[Vec2; 3]>, String> {
    if let Some(i) = floats.iter().position(|x| !x.is_finite()) {
        return Err(format!("lightmap UV of triangle {} is not finite", i / 6));
    }
    Ok(floats
        .chunks_exact(6)
        .map(|c| {
            [
                Vec2::new(c[0], c[1]),
                Vec2::new(c[2], c[3]),
                Vec2::new(c[4], c[5]),
            ]
        })
        .collect())
}

/// The bytes of a file with `header`'s fields but another payload (a shard part's): the
/// header exactly as [`CoefficientFile::to_bytes`] writes it, with the payload length, the
/// shard identity `shard` (bytes 88..108) and the checksum set for `payload`.
pub(crate) fn bytes_with_payload(header: &Header, shard: &[u8; 20], payload: &[u8]) -> Vec<u8> {
    let empty = CoefficientFile {
        header: Header {
            vertex_count: 0,
            ..header.clone()
        },
        coefficients: Vec::new(),
        ao: header.aux.ao.then(Vec::new),
        bent_normal: header.aux.bent_normal.then(Vec::new),
        rays: header.adaptive.map(|_| Vec::new()),
        error_estimate: header.adaptive.map(|_| Vec::new()),
        lightmap: None,
        probes: None,
    };
    let (mut bytes, _) = empty.to_bytes();
    bytes[24..32].copy_from_slice(&header.vertex_count.to_le_bytes());
    bytes[72..80].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes[88..108].copy_from_slice(shard);
    bytes.extend_from_slice(payload);
    let checksum = checksum(&bytes);
    bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&checksum.to_le_bytes());
    bytes
}

/// A test fixture: an unshadowed vector file of `order` and `channels` whose `coefficients`
/// are `vertex_count` receivers' worth, no aux arrays, z-up, every other field zero; tests set
/// what they care about with struct update syntax.
#[cfg(test)]
pub(crate) fn fixture(
    order: u32,
    channels: u32,
    vertex_count: u64,
    coefficients: Vec<f32>,
) -> CoefficientFile {
    CoefficientFile {
        header: Header {
            version: VERSION,
            order,
            channels,
            vertex_count,
            samples_per_vertex: 1,
            mode: crate::formats::header::Mode::Unshadowed,
            transfer: Default::default(),
            bounces: 0,
            bounce_samples: 0,
            backend: crate::trace::Backend::None,
            sampling: crate::math::sampling::Sampling::OwenSobol,
            seed: 0,
            scene_fingerprint: 0,
            aux: Default::default(),
            up: crate::scene::Up::Z,
            checksum: 0,
            adaptive: None,
            receivers: None,
            denoised: false,
        },
        coefficients,
        ao: None,
        bent_normal: None,
        rays: None,
        error_estimate: None,
        lightmap: None,
        probes: None,
    }
}

#[cfg(test)]
mod tests;

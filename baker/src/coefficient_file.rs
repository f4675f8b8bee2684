//! The coefficient file (`.prt`): a 128-byte little-endian header, then f32 transfer
//! coefficients, vertex-major. `docs/coefficient-format.md` is the specification; this module
//! is its reference implementation.
//!
//! Files are written atomically (temporary file in the same folder, then rename), so a failed
//! or interrupted bake never leaves a partial file under the output name. The reader checks
//! everything — size, magic, version, checksum, every field, every float — before it returns.

use std::path::Path;

use glam::{Vec2, Vec3};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::lightmap::{AtlasSource, LightmapBake};
use crate::sampling::Sampling;
use crate::scene::{Scene, Up};
use crate::sh;
use crate::trace::Backend;
use crate::transfer::{Aux, Mode, Transfer};

/// First 8 bytes. Like PNG's: a non-ASCII byte, CR LF and ^Z catch text-mode mangling.
pub const MAGIC: [u8; 8] = *b"\x89PRT\r\n\x1a\n";
pub const VERSION: u32 = 1;
pub const HEADER_SIZE: usize = 128;
/// The header size of a lightmap (texel) bake: the 128 bytes, then the texel block.
pub const LIGHTMAP_HEADER_SIZE: usize = 160;
/// Offset of the CRC-32 (the last 4 bytes of the header).
const CHECKSUM_OFFSET: usize = 124;

/// The header, as `prt-bake inspect` prints it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Header {
    pub version: u32,
    pub order: u32,
    pub channels: u32,
    pub vertex_count: u64,
    pub samples_per_vertex: u32,
    #[serde(serialize_with = "as_name::mode")]
    pub mode: Mode,
    pub bounces: u32,
    /// Rays per vertex whose hits fed the bounces (interreflected mode; 0 otherwise).
    pub bounce_samples: u32,
    #[serde(serialize_with = "as_name::backend")]
    pub backend: Backend,
    #[serde(serialize_with = "as_name::sampling")]
    pub sampling: Sampling,
    pub seed: u64,
    #[serde(serialize_with = "as_name::hex64")]
    pub scene_fingerprint: u64,
    /// Optional per-vertex arrays stored after the coefficients (header bit flags: 1 = AO,
    /// 2 = bent normal).
    #[serde(serialize_with = "as_name::aux")]
    pub aux: Aux,
    /// The scene's up axis (bytes 84..88: 0 = +z, 1 = +y): how rigs and skies are turned
    /// to light it.
    #[serde(serialize_with = "as_name::up")]
    pub up: Up,
    #[serde(serialize_with = "as_name::hex32")]
    pub checksum: u32,
    /// Adaptive sampling (`--target-error`, bytes 108..124); `None` for fixed-sample bakes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<Adaptive>,
}

/// How an adaptive bake sampled (header bytes 108..124; all zero for fixed sampling). Its
/// files carry two per-vertex arrays, rays cast and estimated error (aux bits 2 and 3).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Adaptive {
    /// The RMS coefficient error each vertex was sampled to (f32 at 108; > 0).
    pub target_error: f32,
    /// Independently scrambled point sets the error was estimated from (u32 at 112).
    pub replicates: u32,
    /// Rays cast by all vertices together (u64 at 116).
    pub rays_cast: u64,
}

mod as_name {
    use serde::Serializer;

    pub fn mode<S: Serializer>(m: &crate::transfer::Mode, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }
    pub fn backend<S: Serializer>(b: &crate::trace::Backend, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(b.name())
    }
    pub fn aux<S: Serializer>(a: &crate::transfer::Aux, s: S) -> Result<S::Ok, S::Error> {
        let names = [(a.ao, "ao"), (a.bent_normal, "bent-normal")];
        s.collect_seq(names.iter().filter(|(on, _)| *on).map(|(_, name)| name))
    }
    pub fn sampling<S: Serializer>(m: &crate::sampling::Sampling, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }
    pub fn hex64<S: Serializer>(x: &u64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{x:016x}"))
    }
    pub fn up<S: Serializer>(u: &crate::scene::Up, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(u.name())
    }
    pub fn hex32<S: Serializer>(x: &u32, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{x:08x}"))
    }
}

/// Aux flag bits in the header.
const AUX_AO: u32 = 1;
const AUX_BENT_NORMAL: u32 = 2;
/// Adaptive bakes: per-vertex rays cast (u32) and estimated error (f32), both always.
const AUX_RAYS: u32 = 4;
const AUX_ERROR_ESTIMATE: u32 = 8;
const AUX_ADAPTIVE: u32 = AUX_RAYS | AUX_ERROR_ESTIMATE;

fn aux_flags(aux: Aux) -> u32 {
    (if aux.ao { AUX_AO } else { 0 }) | (if aux.bent_normal { AUX_BENT_NORMAL } else { 0 })
}

impl Header {
    pub fn coefficients_per_vertex(&self) -> usize {
        self.channels as usize * sh::coeff_count(self.order as usize)
    }

    /// Floats per vertex in the aux arrays.
    fn aux_floats_per_vertex(&self) -> usize {
        usize::from(self.aux.ao)
            + 3 * usize::from(self.aux.bent_normal)
            + 2 * usize::from(self.adaptive.is_some())
    }

    fn aux_flags(&self) -> u32 {
        aux_flags(self.aux)
            | if self.adaptive.is_some() {
                AUX_ADAPTIVE
            } else {
                0
            }
    }

    fn payload_bytes(&self) -> u64 {
        self.vertex_count
            * (self.coefficients_per_vertex() + self.aux_floats_per_vertex()) as u64
            * 4
    }
}

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
}

/// What a texel bake stores beyond a vertex bake (docs/coefficient-format.md, "Lightmap
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
}

impl LightmapBlock {
    /// Bytes after the aux arrays: the UVs (f32) then the mask (u8).
    fn payload_bytes(&self) -> u64 {
        self.scene_triangle_count * 6 * 4 + u64::from(self.width) * u64::from(self.height)
    }

    /// [`LightmapBlock::payload_bytes`] of a block read from a file: `None` where a corrupted
    /// count overflows.
    fn checked_payload_bytes(&self) -> Option<u64> {
        self.scene_triangle_count
            .checked_mul(6 * 4)?
            .checked_add(u64::from(self.width) * u64::from(self.height))
    }
}

fn mode_code(mode: Mode) -> u32 {
    match mode {
        Mode::Unshadowed => 0,
        Mode::Shadowed => 1,
        Mode::Interreflected => 2,
    }
}

fn backend_code(backend: Backend) -> u32 {
    match backend {
        Backend::None => 0,
        Backend::Embree => 1,
        Backend::Obvhs => 2,
    }
}

fn sampling_code(sampling: Sampling) -> u32 {
    match sampling {
        Sampling::OwenSobol => 0,
        Sampling::ThesisRandom => 1,
    }
}

impl CoefficientFile {
    /// Packages a bake of `scene` with the settings it was made with; the up axis is the
    /// scene's (set [`Header::up`] afterwards to override it).
    pub fn from_bake(scene: &Scene, transfer: &Transfer) -> CoefficientFile {
        let options = &transfer.options;
        CoefficientFile {
            header: Header {
                version: VERSION,
                order: options.order as u32,
                channels: transfer.channels as u32,
                vertex_count: transfer.vertex_count as u64,
                samples_per_vertex: options.samples,
                mode: options.mode,
                bounces: options.bounces,
                bounce_samples: options.effective_bounce_samples(),
                backend: transfer.backend,
                sampling: options.sampling,
                seed: options.seed,
                scene_fingerprint: scene.fingerprint(),
                aux: options.aux,
                up: scene.up,
                checksum: 0,
                adaptive: options.target_error.map(|target_error| Adaptive {
                    target_error,
                    replicates: crate::adaptive::REPLICATES as u32,
                    rays_cast: transfer.rays_cast,
                }),
            },
            coefficients: transfer.coefficients.clone(),
            ao: options.aux.ao.then(|| {
                transfer
                    .visibility
                    .iter()
                    .map(|v| v.accessibility)
                    .collect()
            }),
            bent_normal: options
                .aux
                .bent_normal
                .then(|| transfer.visibility.iter().map(|v| v.bent_normal).collect()),
            rays: options
                .target_error
                .map(|_| transfer.visibility.iter().map(|v| v.rays).collect()),
            error_estimate: options.target_error.map(|_| {
                transfer
                    .visibility
                    .iter()
                    .map(|v| v.error_estimate)
                    .collect()
            }),
            lightmap: None,
        }
    }

    /// Packages a texel bake of `scene`.
    pub fn from_lightmap_bake(scene: &Scene, bake: &LightmapBake) -> CoefficientFile {
        let mut file = CoefficientFile::from_bake(scene, &bake.transfer);
        file.lightmap = Some(LightmapBlock {
            width: bake.atlas.width,
            height: bake.atlas.height,
            scene_vertex_count: scene.vertex_count() as u64,
            scene_triangle_count: scene.triangles.len() as u64,
            texel_size: bake.atlas.texel_size.unwrap_or(0.0),
            source: bake.atlas.source,
            valid: bake.texels.valid.clone(),
            dilated: bake.dilated.clone(),
            uv1: bake.atlas.uv1.clone(),
        });
        file
    }

    /// Bytes after the header.
    fn payload_bytes(&self) -> u64 {
        self.header.payload_bytes() + self.lightmap.as_ref().map_or(0, |l| l.payload_bytes())
    }

    fn header_size(&self) -> usize {
        match self.lightmap {
            Some(_) => LIGHTMAP_HEADER_SIZE,
            None => HEADER_SIZE,
        }
    }

    /// Coefficients of vertex `v`, channel `c`.
    pub fn vertex(&self, v: usize, c: usize) -> &[f32] {
        let n = sh::coeff_count(self.header.order as usize);
        let start = (v * self.header.channels as usize + c) * n;
        &self.coefficients[start..start + n]
    }

    /// The file's bytes; the checksum field is computed (and stored in the returned header).
    pub fn to_bytes(&self) -> (Vec<u8>, u32) {
        let h = &self.header;
        let mut bytes = Vec::with_capacity(HEADER_SIZE + self.coefficients.len() * 4);
        bytes.extend(MAGIC);
        bytes.extend(h.version.to_le_bytes());
        bytes.extend((self.header_size() as u32).to_le_bytes());
        bytes.extend(h.order.to_le_bytes());
        bytes.extend(h.channels.to_le_bytes());
        bytes.extend(h.vertex_count.to_le_bytes());
        bytes.extend(h.samples_per_vertex.to_le_bytes());
        bytes.extend(mode_code(h.mode).to_le_bytes());
        bytes.extend(h.bounces.to_le_bytes());
        bytes.extend(backend_code(h.backend).to_le_bytes());
        bytes.extend(h.seed.to_le_bytes());
        bytes.extend(h.scene_fingerprint.to_le_bytes());
        bytes.extend(sampling_code(h.sampling).to_le_bytes());
        bytes.extend(h.aux_flags().to_le_bytes());
        bytes.extend(self.payload_bytes().to_le_bytes());
        bytes.extend(h.bounce_samples.to_le_bytes());
        bytes.extend(h.up.code().to_le_bytes());
        bytes.resize(108, 0); // the shard identity 88..108: zero in a whole file
        let adaptive = h.adaptive.unwrap_or(Adaptive {
            target_error: 0.0,
            replicates: 0,
            rays_cast: 0,
        });
        bytes.extend(adaptive.target_error.to_le_bytes());
        bytes.extend(adaptive.replicates.to_le_bytes());
        bytes.extend(adaptive.rays_cast.to_le_bytes());
        bytes.resize(HEADER_SIZE, 0); // the checksum slot
        if let Some(l) = &self.lightmap {
            bytes.extend(l.width.to_le_bytes());
            bytes.extend(l.height.to_le_bytes());
            bytes.extend(l.scene_vertex_count.to_le_bytes());
            bytes.extend(l.scene_triangle_count.to_le_bytes());
            bytes.extend(l.texel_size.to_le_bytes());
            bytes.extend(l.source.code().to_le_bytes());
        }
        bytes.extend(self.coefficients.iter().flat_map(|c| c.to_le_bytes()));
        let ao = self.ao.iter().flatten().copied();
        let bent = self.bent_normal.iter().flatten().flat_map(|n| n.to_array());
        bytes.extend(ao.chain(bent).flat_map(f32::to_le_bytes));
        bytes.extend(self.rays.iter().flatten().flat_map(|r| r.to_le_bytes()));
        let errors = self.error_estimate.iter().flatten();
        bytes.extend(errors.flat_map(|e| e.to_le_bytes()));
        if let Some(l) = &self.lightmap {
            let uv = l.uv1.iter().flatten().flat_map(|p| p.to_array());
            bytes.extend(uv.flat_map(f32::to_le_bytes));
            let state = |(&valid, &dilated): (&bool, &bool)| match (valid, dilated) {
                (true, _) => 1u8,
                (false, true) => 2,
                (false, false) => 0,
            };
            bytes.extend(l.valid.iter().zip(&l.dilated).map(state));
        }
        debug_assert_eq!(
            bytes.len() as u64,
            self.header_size() as u64 + self.payload_bytes()
        );
        let checksum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&checksum.to_le_bytes());
        (bytes, checksum)
    }

    /// Writes the file atomically: nothing appears under `path` unless all of it was written.
    pub fn write(&mut self, path: &Path) -> Result<()> {
        let (bytes, checksum) = self.to_bytes();
        crate::atomic::write(path, &bytes)?;
        self.header.checksum = checksum;
        Ok(())
    }

    pub fn read(path: &Path) -> Result<CoefficientFile> {
        let bytes = crate::limits::read_file(path)?;
        CoefficientFile::from_bytes(&bytes)
            .map_err(|message| Error::coefficient_file(path, message))
    }

    /// Parses and validates a file's bytes; the error is a sentence for the user.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<CoefficientFile, String> {
        // Version 2 (CPCA-compressed): read as the version-1 file it reconstructs.
        if crate::cpca_block::is_compressed(bytes) {
            return crate::cpca_block::from_bytes(bytes).map(|c| c.file);
        }
        let (header, payload, header_size) = parse_header(bytes)?;
        if let Some(shard) = crate::shard::PartId::from_header_bytes(bytes)? {
            return Err(format!(
                "a shard part ({shard}) of a bake, not a whole bake: combine the parts with `prt-bake merge`"
            ));
        }
        let mut lightmap = None;
        if header_size == LIGHTMAP_HEADER_SIZE {
            let u32_at =
                |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
            let u64_at =
                |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
            let (width, height) = (u32_at(128), u32_at(132));
            if u64::from(width) * u64::from(height) != header.vertex_count {
                return Err(format!(
                    "a {width}×{height} lightmap in a file of {} texels",
                    header.vertex_count
                ));
            }
            let source = AtlasSource::from_code(u32_at(156))
                .ok_or_else(|| format!("unknown atlas source {}", u32_at(156)))?;
            let texel_size = f32::from_le_bytes(bytes[152..156].try_into().expect("4 bytes"));
            if !(texel_size.is_finite() && texel_size >= 0.0) {
                return Err(format!("texel size {texel_size} is not a size"));
            }
            lightmap = Some(LightmapBlock {
                width,
                height,
                scene_vertex_count: u64_at(136),
                scene_triangle_count: u64_at(144),
                texel_size,
                source,
                valid: Vec::new(),
                dilated: Vec::new(),
                uv1: Vec::new(),
            });
        }
        // Checked: a corrupted count must not wrap around to the payload's size.
        let needed = header
            .vertex_count
            .checked_mul(
                (header.coefficients_per_vertex() + header.aux_floats_per_vertex()) as u64 * 4,
            )
            .and_then(|n| match &lightmap {
                Some(l) => l.checked_payload_bytes().and_then(|m| n.checked_add(m)),
                None => Some(n),
            });
        if needed != Some(payload) {
            return Err(format!(
                "{} vertices × {} coefficients need {} bytes, the header announces {payload}",
                header.vertex_count,
                header.coefficients_per_vertex(),
                needed.map_or_else(|| "more than 2^64".into(), |n| n.to_string())
            ));
        }
        let aux = header.aux;
        let mut floats = bytes[header_size..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")));
        let vertices = header.vertex_count as usize;
        let coefficients: Vec<f32> = floats
            .by_ref()
            .take(vertices * header.coefficients_per_vertex())
            .collect();
        let ao: Option<Vec<f32>> = aux.ao.then(|| floats.by_ref().take(vertices).collect());
        let bent_normal: Option<Vec<Vec3>> = aux.bent_normal.then(|| {
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
        if let (Some(adaptive), Some(rays)) = (header.adaptive, &rays) {
            if let Some(v) = rays
                .iter()
                .position(|r| !(1..=header.samples_per_vertex).contains(r))
            {
                return Err(format!(
                    "vertex {v} cast {} rays, outside 1..={} (the samples per vertex)",
                    rays[v], header.samples_per_vertex
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
            .flatten()
            .position(|e| !(e.is_finite() && *e >= 0.0))
        {
            return Err(format!(
                "estimated error of vertex {v} is not a non-negative number"
            ));
        }
        check_floats(
            &header,
            &coefficients,
            ao.as_deref(),
            bent_normal.as_deref(),
        )?;
        if let Some(l) = lightmap.as_mut() {
            let uv: Vec<f32> = floats
                .by_ref()
                .take(l.scene_triangle_count as usize * 6)
                .collect();
            if let Some(i) = uv.iter().position(|x| !x.is_finite()) {
                return Err(format!("lightmap UV of triangle {} is not finite", i / 6));
            }
            l.uv1 = uv
                .chunks_exact(6)
                .map(|c| {
                    [
                        Vec2::new(c[0], c[1]),
                        Vec2::new(c[2], c[3]),
                        Vec2::new(c[4], c[5]),
                    ]
                })
                .collect();
            let mask = &bytes[bytes.len() - header.vertex_count as usize..];
            if let Some(i) = mask.iter().position(|&b| b > 2) {
                return Err(format!("state of texel {i} is {} (0, 1 or 2)", mask[i]));
            }
            l.valid = mask.iter().map(|&b| b == 1).collect();
            l.dilated = mask.iter().map(|&b| b == 2).collect();
        }
        Ok(CoefficientFile {
            header,
            coefficients,
            ao,
            bent_normal,
            rays,
            error_estimate,
            lightmap,
        })
    }
}

/// Checks the header of a whole file or a shard part (everything but the payload's layout):
/// size, magic, version, checksum and every field. Returns the header and the payload length
/// it announces.
pub(crate) fn parse_header(bytes: &[u8]) -> std::result::Result<(Header, u64, usize), String> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err("not a PRT coefficient file (wrong magic bytes)".into());
    }
    if bytes.len() < HEADER_SIZE {
        return Err(format!(
            "truncated: {} bytes, but the header alone is {HEADER_SIZE} bytes",
            bytes.len()
        ));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let version = u32_at(8);
    if version != VERSION {
        return Err(format!(
            "unsupported format version {version} (this build reads version {VERSION})"
        ));
    }
    let header_size = u32_at(12) as usize;
    if header_size != HEADER_SIZE && header_size != LIGHTMAP_HEADER_SIZE {
        return Err(format!(
            "header size {header_size} (version {VERSION} headers are {HEADER_SIZE} bytes, \
             {LIGHTMAP_HEADER_SIZE} for lightmap bakes)"
        ));
    }
    if bytes.len() < header_size {
        return Err(format!(
            "truncated: {} bytes, but the header alone is {header_size} bytes",
            bytes.len()
        ));
    }
    let payload = u64_at(72);
    let found = (bytes.len() - header_size) as u64;
    if found < payload {
        return Err(format!(
            "truncated: the header announces {payload} bytes of coefficients, the file holds {found}"
        ));
    }
    if found > payload {
        return Err(format!(
            "{} unexpected bytes after the {payload} bytes of coefficients",
            found - payload
        ));
    }
    let stored = u32_at(CHECKSUM_OFFSET);
    let computed = checksum(bytes);
    if stored != computed {
        return Err(format!(
            "checksum mismatch (stored {stored:08x}, computed {computed:08x}): the file is corrupted"
        ));
    }

    let order = u32_at(16);
    if !(1..=sh::MAX_ORDER as u32).contains(&order) {
        return Err(format!("SH order {order} is outside 1..={}", sh::MAX_ORDER));
    }
    let channels = u32_at(20);
    if channels != 1 && channels != 3 {
        return Err(format!("{channels} channels (1 or 3 are defined)"));
    }
    let mode = match u32_at(36) {
        0 => Mode::Unshadowed,
        1 => Mode::Shadowed,
        2 => Mode::Interreflected,
        other => return Err(format!("unknown transfer mode {other}")),
    };
    let bounces = u32_at(40);
    if (mode == Mode::Interreflected) != (bounces > 0) {
        return Err(format!("{bounces} bounces in a {} file", mode.name()));
    }
    let backend = match u32_at(44) {
        0 => Backend::None,
        1 => Backend::Embree,
        2 => Backend::Obvhs,
        other => return Err(format!("unknown backend {other}")),
    };
    let sampling = match u32_at(64) {
        0 => Sampling::OwenSobol,
        1 => Sampling::ThesisRandom,
        other => return Err(format!("unknown sampling method {other}")),
    };
    let aux_flags = u32_at(68);
    if aux_flags & !(AUX_AO | AUX_BENT_NORMAL | AUX_ADAPTIVE) != 0 {
        return Err(format!("unknown auxiliary-array flags {aux_flags:#x}"));
    }
    let aux = Aux {
        ao: aux_flags & AUX_AO != 0,
        bent_normal: aux_flags & AUX_BENT_NORMAL != 0,
    };
    let bounce_samples = u32_at(80);
    let samples_per_vertex = u32_at(32);
    let bounce_samples_valid = match mode {
        Mode::Interreflected => (1..=samples_per_vertex).contains(&bounce_samples),
        _ => bounce_samples == 0,
    };
    if !bounce_samples_valid {
        return Err(format!(
            "{bounce_samples} bounce samples in a {} file of {samples_per_vertex} samples",
            mode.name()
        ));
    }
    let up = match Up::from_code(u32_at(84)) {
        Some(up) => up,
        None => return Err(format!("unknown up axis {} (0 = +z, 1 = +y)", u32_at(84))),
    };
    // 88..108 is the shard identity (crate::shard::PartId).
    // 88..108 is the shard identity (crate::shard::PartId); 108..124 the adaptive fields.
    let adaptive = read_adaptive(bytes, aux_flags, mode, sampling)?;
    let header = Header {
        version,
        order,
        channels,
        vertex_count: u64_at(24),
        samples_per_vertex,
        mode,
        bounces,
        bounce_samples,
        backend,
        sampling,
        seed: u64_at(48),
        scene_fingerprint: u64_at(56),
        aux,
        up,
        checksum: stored,
        adaptive,
    };
    Ok((header, payload, header_size))
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

impl CoefficientFile {
    /// Refuses a file baked for a different scene (or a changed version of this one).
    pub fn check_scene(&self, path: &Path, scene: &Scene) -> Result<()> {
        let mismatch = |message: String| {
            Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message,
            })
        };
        if let Some(l) = &self.lightmap {
            return mismatch(format!(
                "a lightmap bake ({}×{} texels), which this reader does not read (only \
                 `export` reads lightmap bakes so far)",
                l.width, l.height
            ));
        }
        self.check_fingerprint(path, scene, self.header.vertex_count)
    }

    /// Refuses a lightmap bake made for a different scene, or a vertex bake.
    pub fn check_lightmap_scene(&self, path: &Path, scene: &Scene) -> Result<&LightmapBlock> {
        let Some(l) = &self.lightmap else {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: "a per-vertex bake, not a lightmap bake".into(),
            });
        };
        if l.scene_triangle_count != scene.triangles.len() as u64 {
            return Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message: format!(
                    "baked for a scene with {} triangles, but {} has {}",
                    l.scene_triangle_count,
                    scene.path.display(),
                    scene.triangles.len()
                ),
            });
        }
        self.check_fingerprint(path, scene, l.scene_vertex_count)?;
        Ok(l)
    }

    fn check_fingerprint(&self, path: &Path, scene: &Scene, vertex_count: u64) -> Result<()> {
        let mismatch = |message: String| {
            Err(Error::SceneMismatch {
                path: path.to_path_buf(),
                message,
            })
        };
        if vertex_count != scene.vertex_count() as u64 {
            return mismatch(format!(
                "baked for a scene with {} vertices, but {} has {}",
                vertex_count,
                scene.path.display(),
                scene.vertex_count()
            ));
        }
        let fingerprint = scene.fingerprint();
        if self.header.scene_fingerprint != fingerprint {
            return mismatch(format!(
                "baked for another scene: fingerprint {:016x}, but {} has {fingerprint:016x}",
                self.header.scene_fingerprint,
                scene.path.display()
            ));
        }
        Ok(())
    }
}

/// Header bytes 108..124 and aux bits 2–3: all zero, or a consistent adaptive bake.
fn read_adaptive(
    bytes: &[u8],
    aux_flags: u32,
    mode: Mode,
    sampling: Sampling,
) -> std::result::Result<Option<Adaptive>, String> {
    let target_error = f32::from_le_bytes(bytes[108..112].try_into().expect("4 bytes"));
    let replicates = u32::from_le_bytes(bytes[112..116].try_into().expect("4 bytes"));
    let rays_cast = u64::from_le_bytes(bytes[116..124].try_into().expect("8 bytes"));
    let flags = aux_flags & AUX_ADAPTIVE;
    if target_error.to_bits() == 0 {
        if replicates != 0 || rays_cast != 0 || flags != 0 {
            return Err(
                "adaptive-sampling fields (bytes 112..124, aux bits 2-3) set without a target error"
                    .into(),
            );
        }
        return Ok(None);
    }
    if !(target_error.is_finite() && target_error > 0.0) {
        return Err(format!(
            "target error {target_error} is not a positive number"
        ));
    }
    if replicates < 2 {
        return Err(format!(
            "{replicates} replicates cannot estimate an error (at least 2)"
        ));
    }
    if flags != AUX_ADAPTIVE {
        return Err(
            "an adaptive bake without its per-vertex rays and errors (aux bits 2 and 3)".into(),
        );
    }
    if mode != Mode::Shadowed || sampling != Sampling::OwenSobol {
        return Err(format!(
            "a target error in a file of mode {}, sampling {} (adaptive bakes are shadowed, \
             owen-sobol)",
            mode.name(),
            sampling.name()
        ));
    }
    Ok(Some(Adaptive {
        target_error,
        replicates,
        rays_cast,
    }))
}

/// CRC-32 (IEEE, as zlib's `crc32`) of the whole file with the checksum field read as zero.
fn checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..CHECKSUM_OFFSET]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[HEADER_SIZE..]);
    hasher.finalize()
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

#[cfg(test)]
mod tests {
    use super::*;

    /// An adaptive file of two vertices at order 1.
    fn adaptive_file() -> CoefficientFile {
        CoefficientFile {
            header: Header {
                version: VERSION,
                order: 1,
                channels: 1,
                vertex_count: 2,
                samples_per_vertex: 4096,
                mode: Mode::Shadowed,
                bounces: 0,
                bounce_samples: 0,
                backend: Backend::Embree,
                sampling: Sampling::OwenSobol,
                seed: 3,
                scene_fingerprint: 0x1234,
                up: crate::scene::Up::Z,
                aux: Aux {
                    ao: true,
                    bent_normal: false,
                },
                checksum: 0,
                adaptive: Some(Adaptive {
                    target_error: 1e-3,
                    replicates: 16,
                    rays_cast: 256 + 4096,
                }),
            },
            coefficients: vec![0.25, 0.5],
            ao: Some(vec![0.75, 1.0]),
            bent_normal: None,
            rays: Some(vec![256, 4096]),
            error_estimate: Some(vec![5e-4, 2e-3]),
            lightmap: None,
        }
    }

    /// `bytes` with a new checksum, so only the change under test is wrong.
    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let sum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn adaptive_files_round_trip_and_fixed_ones_keep_their_bytes() {
        let file = adaptive_file();
        let (bytes, sum) = file.to_bytes();
        // Header, 2 coefficients, 2 accessibilities, 2 ray counts, 2 errors.
        assert_eq!(bytes.len(), HEADER_SIZE + 8 * 4);
        assert_eq!(
            u32::from_le_bytes(bytes[68..72].try_into().unwrap()),
            1 | 4 | 8
        );
        let read = CoefficientFile::from_bytes(&bytes).unwrap();
        assert_eq!(read.header.checksum, sum);
        assert_eq!(
            read,
            CoefficientFile {
                header: Header {
                    checksum: sum,
                    ..file.header.clone()
                },
                ..file.clone()
            }
        );

        // Zero means "not adaptive": a fixed-sample file has zeros in 108..124 and no bits 2–3.
        let fixed = CoefficientFile {
            header: Header {
                adaptive: None,
                ..file.header.clone()
            },
            rays: None,
            error_estimate: None,
            ..file
        };
        let (bytes, _) = fixed.to_bytes();
        assert!(bytes[84..CHECKSUM_OFFSET].iter().all(|&b| b == 0));
        assert_eq!(u32::from_le_bytes(bytes[68..72].try_into().unwrap()), 1);
        let read = CoefficientFile::from_bytes(&bytes).unwrap();
        assert_eq!((read.header.adaptive, read.rays), (None, None));
    }

    /// A change to a file's bytes.
    type Corruption = Box<dyn Fn(&mut Vec<u8>)>;

    #[test]
    fn inconsistent_adaptive_fields_are_refused() {
        let (good, _) = adaptive_file().to_bytes();
        let rays_at = HEADER_SIZE + 4 * 4;
        let errors_at = rays_at + 2 * 4;
        let cases: [(&str, Corruption); 7] = [
            (
                "without a target error",
                Box::new(|b: &mut Vec<u8>| b[108..112].fill(0)),
            ),
            (
                "is not a positive number",
                Box::new(|b: &mut Vec<u8>| b[108..112].copy_from_slice(&(-1e-3f32).to_le_bytes())),
            ),
            (
                "replicates cannot estimate",
                Box::new(|b: &mut Vec<u8>| b[112..116].copy_from_slice(&1u32.to_le_bytes())),
            ),
            (
                "without its per-vertex rays and errors",
                Box::new(|b: &mut Vec<u8>| b[68] = 1 | 4),
            ),
            (
                "the header says 4352 were cast",
                Box::new(move |b: &mut Vec<u8>| {
                    b[rays_at..rays_at + 4].copy_from_slice(&512u32.to_le_bytes())
                }),
            ),
            (
                "vertex 1 cast 5000 rays, outside 1..=4096",
                Box::new(move |b: &mut Vec<u8>| {
                    b[rays_at + 4..rays_at + 8].copy_from_slice(&5000u32.to_le_bytes())
                }),
            ),
            (
                "estimated error of vertex 0",
                Box::new(move |b: &mut Vec<u8>| {
                    b[errors_at..errors_at + 4].copy_from_slice(&f32::NAN.to_le_bytes())
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
        // A target error in an interreflected file.
        let mut bytes = good.clone();
        bytes[36..40].copy_from_slice(&2u32.to_le_bytes());
        bytes[40..44].copy_from_slice(&1u32.to_le_bytes());
        bytes[80..84].copy_from_slice(&1u32.to_le_bytes());
        let m = CoefficientFile::from_bytes(&resealed(bytes)).unwrap_err();
        assert!(
            m.contains("a target error in a file of mode interreflected"),
            "{m}"
        );
    }
}

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
use crate::scene::Scene;
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
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
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
    #[serde(serialize_with = "as_name::hex32")]
    pub checksum: u32,
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
    pub fn hex32<S: Serializer>(x: &u32, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&format!("{x:08x}"))
    }
}

/// Aux flag bits in the header.
const AUX_AO: u32 = 1;
const AUX_BENT_NORMAL: u32 = 2;

fn aux_flags(aux: Aux) -> u32 {
    (if aux.ao { AUX_AO } else { 0 }) | (if aux.bent_normal { AUX_BENT_NORMAL } else { 0 })
}

impl Header {
    pub fn coefficients_per_vertex(&self) -> usize {
        self.channels as usize * sh::coeff_count(self.order as usize)
    }

    /// Floats per vertex in the aux arrays.
    fn aux_floats_per_vertex(&self) -> usize {
        usize::from(self.aux.ao) + 3 * usize::from(self.aux.bent_normal)
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
    /// Packages a bake of `scene` with the settings it was made with.
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
                checksum: 0,
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
        bytes.extend(aux_flags(h.aux).to_le_bytes());
        bytes.extend(self.payload_bytes().to_le_bytes());
        bytes.extend(h.bounce_samples.to_le_bytes());
        bytes.resize(HEADER_SIZE, 0); // reserved bytes 84..124, then the checksum slot
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
        let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
        CoefficientFile::from_bytes(&bytes)
            .map_err(|message| Error::coefficient_file(path, message))
    }

    /// Parses and validates a file's bytes; the error is a sentence for the user.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<CoefficientFile, String> {
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
        if aux_flags & !(AUX_AO | AUX_BENT_NORMAL) != 0 {
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
        if bytes[84..CHECKSUM_OFFSET].iter().any(|&b| b != 0) {
            return Err("reserved header bytes are not zero".into());
        }
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
            checksum: stored,
        };
        let mut lightmap = None;
        if header_size == LIGHTMAP_HEADER_SIZE {
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
        let expected = header.payload_bytes() + lightmap.as_ref().map_or(0, |l| l.payload_bytes());
        if expected != payload {
            return Err(format!(
                "{} vertices × {} coefficients need {expected} bytes, the header announces {payload}",
                header.vertex_count,
                header.coefficients_per_vertex(),
            ));
        }
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
        if let Some(v) = ao.iter().flatten().position(|a| !(0.0..=1.0).contains(a)) {
            return Err(format!(
                "ambient accessibility of vertex {v} is outside [0, 1]"
            ));
        }
        if let Some(v) = bent_normal
            .iter()
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
            lightmap,
        })
    }

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

/// CRC-32 (IEEE, as zlib's `crc32`) of the whole file with the checksum field read as zero.
fn checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..CHECKSUM_OFFSET]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[HEADER_SIZE..]);
    hasher.finalize()
}

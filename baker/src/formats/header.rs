//! The coefficient file's header: the fields `prt-bake inspect` prints, their binary layout
//! (bytes 0..128, `docs/reference/coefficient-format.md`) and the checks a reader makes of them. The
//! header describes a bake (mode, order, samples, seed, backend…) without knowing how one is
//! made: the bake fills it ([`Header::for_bake`]).

use serde::Serialize;

use crate::formats::receiver_section::ReceiverObjects;
use crate::math::sampling::Sampling;
use crate::math::sh;
use crate::scene::Up;
use crate::trace::Backend;

/// First 8 bytes. Like PNG's: a non-ASCII byte, CR LF and ^Z catch text-mode mangling.
pub const MAGIC: [u8; 8] = *b"\x89PRT\r\n\x1a\n";
pub const VERSION: u32 = 1;
pub const HEADER_SIZE: usize = 128;
/// The header size of a lightmap (texel) bake: the 128 bytes, then the texel block.
pub const LIGHTMAP_HEADER_SIZE: usize = 160;
/// The header size of a lightmap bake's shard part: the texel block, then the part's atlas
/// block (`docs/reference/coefficient-format.md`, "Shard parts"); never a whole file's.
pub const LIGHTMAP_PART_HEADER_SIZE: usize = 192;
/// The header size of a probe bake (`bake --probes`): the 128 bytes, then the probe block
/// (`docs/reference/coefficient-format.md`, "Transfer probes").
pub const PROBE_HEADER_SIZE: usize = 176;
/// Offset of the CRC-32 (the last 4 bytes of the header).
pub(crate) const CHECKSUM_OFFSET: usize = 124;

/// What the transfer function includes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    Unshadowed,
    #[default]
    Shadowed,
    Interreflected,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Unshadowed => "unshadowed",
            Mode::Shadowed => "shadowed",
            Mode::Interreflected => "interreflected",
        }
    }

    /// Whether the mode casts rays (and so needs a tracer).
    pub fn casts_rays(self) -> bool {
        self != Mode::Unshadowed
    }
}

/// What each receiver stores per channel (`bake --transfer`; header bytes 38..40).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransferKind {
    /// The diffuse transfer vector: n² coefficients (every file before matrix bakes).
    #[default]
    Vector,
    /// The transfer matrix M_ij = ∫ V(s) y_i(s) y_j(s) ds over the receiver's hemisphere
    /// (Sloan, Kautz & Snyder 2002): n² × n² floats, row-major; symmetric unless
    /// interreflected (which adds the light bounced off the surfaces the rays hit).
    Matrix,
}

impl TransferKind {
    fn is_vector(&self) -> bool {
        *self == TransferKind::Vector
    }

    pub fn name(self) -> &'static str {
        match self {
            TransferKind::Vector => "vector",
            TransferKind::Matrix => "matrix",
        }
    }

    /// Floats per channel at SH order `order`: n², or n⁴ for a matrix.
    pub fn floats_per_channel(self, order: usize) -> usize {
        let n = sh::coeff_count(order);
        match self {
            TransferKind::Vector => n,
            TransferKind::Matrix => n * n,
        }
    }

    fn code(self) -> u16 {
        match self {
            TransferKind::Vector => 0,
            TransferKind::Matrix => 1,
        }
    }
}

/// Optional per-vertex arrays stored beside the coefficients (`--aux`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Aux {
    /// Ambient accessibility, `Visibility::accessibility` of the bake's estimator.
    pub ao: bool,
    /// The bent normal, `Visibility::bent_normal` of the bake's estimator.
    pub bent_normal: bool,
}

impl Aux {
    pub fn any(self) -> bool {
        self.ao || self.bent_normal
    }
}

/// Where the atlas came from (stored in texel files).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtlasSource {
    /// Unwrapped here (the bake's `Atlas::generate`).
    Generated,
    /// The scene's own lightmap UVs (glTF TEXCOORD_1), used as the atlas.
    SceneUvs,
    /// Each object's own lightmap UVs (or, where they overlap themselves or are missing, a
    /// chart set unwrapped for that object alone), packed into the atlas with a scale and an
    /// offset per object ([`ObjectPlacement`]): the scene's TEXCOORD_1 charts of different
    /// objects overlapped, as when every object has its own [0, 1] lightmap UVs.
    PerObject,
}

impl AtlasSource {
    pub fn code(self) -> u32 {
        match self {
            AtlasSource::Generated => 0,
            AtlasSource::SceneUvs => 1,
            AtlasSource::PerObject => 2,
        }
    }

    pub fn from_code(code: u32) -> Option<AtlasSource> {
        match code {
            0 => Some(AtlasSource::Generated),
            1 => Some(AtlasSource::SceneUvs),
            2 => Some(AtlasSource::PerObject),
            _ => None,
        }
    }

    /// The name `inspect` prints.
    pub fn name(self) -> &'static str {
        match self {
            AtlasSource::Generated => "generated",
            AtlasSource::SceneUvs => "scene-uvs",
            AtlasSource::PerObject => "per-object",
        }
    }
}

/// Where one object's own lightmap UVs went in a [`AtlasSource::PerObject`] atlas, as
/// Unity's `lightmapScaleOffset`: atlas uv = own uv × `scale` + `offset` (the file's
/// convention, v up from the bottom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectPlacement {
    pub scale: [f32; 2],
    pub offset: [f32; 2],
    pub uvs: ObjectUvs,
}

/// Which UVs of an object a placement maps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectUvs {
    /// The scene's own (TEXCOORD_1).
    Own,
    /// Unwrapped by prt-bake for this object alone: its own overlapped themselves.
    GeneratedOverlapping,
    /// Unwrapped by prt-bake for this object alone: it had no lightmap UVs.
    GeneratedMissing,
}

impl ObjectUvs {
    pub fn code(self) -> u32 {
        match self {
            ObjectUvs::Own => 0,
            ObjectUvs::GeneratedOverlapping => 1,
            ObjectUvs::GeneratedMissing => 2,
        }
    }

    pub fn from_code(code: u32) -> Option<ObjectUvs> {
        match code {
            0 => Some(ObjectUvs::Own),
            1 => Some(ObjectUvs::GeneratedOverlapping),
            2 => Some(ObjectUvs::GeneratedMissing),
            _ => None,
        }
    }

    /// The name `inspect` prints.
    pub fn name(self) -> &'static str {
        match self {
            ObjectUvs::Own => "own",
            ObjectUvs::GeneratedOverlapping => "generated (own UVs overlap themselves)",
            ObjectUvs::GeneratedMissing => "generated (no lightmap UVs)",
        }
    }
}

/// Bytes per object of the per-object section (scale, offset: 4 × f32; uvs: u32).
pub const OBJECT_PLACEMENT_BYTES: usize = 20;

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
    /// Transfer vectors or matrices (bytes 38..40; 0 = vector in every older file). `inspect`
    /// shows it for matrix files only, as it shows `adaptive` for adaptive bakes only, so the
    /// output for every vector file is what it was.
    #[serde(
        serialize_with = "as_name::transfer",
        skip_serializing_if = "TransferKind::is_vector"
    )]
    pub transfer: TransferKind,
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
    /// A bake of some objects only (`bake --receivers`, aux bit 4; `None`: every object). The
    /// reader fills it from the payload's end ([`parse_header`] leaves an empty placeholder).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub receivers: Option<ReceiverObjects>,
    /// The transfer was denoised (`bake --denoise`, aux bit 5): filtered with weights that
    /// every coefficient shares, so it relights as the raw one does. `inspect` shows it for
    /// denoised files only.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub denoised: bool,
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
    /// The error estimates and the target are of the denoised transfer: read from the
    /// denoised bit (aux bit 5) of an adaptive file, which every reader knows.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub after_denoise: bool,
}

mod as_name;

/// Aux flag bits in the header.
const AUX_AO: u32 = 1;
const AUX_BENT_NORMAL: u32 = 2;
/// Adaptive bakes: per-vertex rays cast (u32) and estimated error (f32), both always.
const AUX_RAYS: u32 = 4;
const AUX_ERROR_ESTIMATE: u32 = 8;
const AUX_ADAPTIVE: u32 = AUX_RAYS | AUX_ERROR_ESTIMATE;
/// A bake of some objects only: a receiver section ends the payload.
const AUX_RECEIVERS: u32 = 16;
/// The transfer was denoised; no array goes with it.
const AUX_DENOISED: u32 = 32;

fn aux_flags(aux: Aux) -> u32 {
    (if aux.ao { AUX_AO } else { 0 }) | (if aux.bent_normal { AUX_BENT_NORMAL } else { 0 })
}

impl Header {
    /// Floats per vertex (or texel) in the coefficient array: channels × n², or channels × n⁴
    /// for a matrix bake.
    pub fn coefficients_per_vertex(&self) -> usize {
        self.channels as usize * self.transfer.floats_per_channel(self.order as usize)
    }

    /// Floats per vertex in the aux arrays.
    pub(crate) fn aux_floats_per_vertex(&self) -> usize {
        usize::from(self.aux.ao)
            + 3 * usize::from(self.aux.bent_normal)
            + 2 * usize::from(self.adaptive.is_some())
    }

    pub(crate) fn aux_flags(&self) -> u32 {
        aux_flags(self.aux)
            | if self.adaptive.is_some() {
                AUX_ADAPTIVE
            } else {
                0
            }
            | (u32::from(self.receivers.is_some()) * AUX_RECEIVERS)
            | (u32::from(self.denoised) * AUX_DENOISED)
    }

    pub(crate) fn payload_bytes(&self) -> u64 {
        self.vertex_count
            * (self.coefficients_per_vertex() + self.aux_floats_per_vertex()) as u64
            * 4
            + self
                .receivers
                .as_ref()
                .map_or(0, ReceiverObjects::section_bytes)
    }
}

impl Header {
    /// The first 128 header bytes as a file of `header_size` header bytes and `payload_bytes`
    /// after them stores them, with the shard identity and the checksum zero.
    pub(crate) fn encode(&self, header_size: usize, payload_bytes: u64) -> Vec<u8> {
        let h = self;
        let mut bytes = Vec::with_capacity(HEADER_SIZE);
        bytes.extend(MAGIC);
        bytes.extend(h.version.to_le_bytes());
        bytes.extend((header_size as u32).to_le_bytes());
        bytes.extend(h.order.to_le_bytes());
        bytes.extend(h.channels.to_le_bytes());
        bytes.extend(h.vertex_count.to_le_bytes());
        bytes.extend(h.samples_per_vertex.to_le_bytes());
        // Bytes 36..40: the mode (u16), then the transfer kind (u16, 0 for vectors), so a
        // vector file's bytes are those of a file written before matrix bakes existed.
        bytes.extend(mode_code(h.mode).to_le_bytes());
        bytes.extend(h.transfer.code().to_le_bytes());
        bytes.extend(h.bounces.to_le_bytes());
        bytes.extend(backend_code(h.backend).to_le_bytes());
        bytes.extend(h.seed.to_le_bytes());
        bytes.extend(h.scene_fingerprint.to_le_bytes());
        bytes.extend(sampling_code(h.sampling).to_le_bytes());
        bytes.extend(h.aux_flags().to_le_bytes());
        bytes.extend(payload_bytes.to_le_bytes());
        bytes.extend(h.bounce_samples.to_le_bytes());
        bytes.extend(h.up.code().to_le_bytes());
        bytes.resize(108, 0); // the shard identity 88..108: zero in a whole file
        let adaptive = h.adaptive.unwrap_or(Adaptive {
            target_error: 0.0,
            replicates: 0,
            rays_cast: 0,
            after_denoise: false,
        });
        bytes.extend(adaptive.target_error.to_le_bytes());
        bytes.extend(adaptive.replicates.to_le_bytes());
        bytes.extend(adaptive.rays_cast.to_le_bytes());
        bytes.resize(HEADER_SIZE, 0); // the checksum slot
        bytes
    }
}

fn mode_code(mode: Mode) -> u16 {
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

/// Checks the header of a whole file or a shard part (everything but the payload's layout):
/// size, magic, version, checksum and every field. Returns the header and the payload length
/// it announces.
pub(crate) fn parse_header(bytes: &[u8]) -> std::result::Result<(Header, u64, usize), String> {
    let (version, header_size, payload) = check_framing(bytes)?;
    let header = parse_fields(bytes, version)?;
    Ok((header, payload, header_size))
}

/// The checks that need no field: magic, version, sizes and checksum. Returns the version,
/// the header size and the payload length.
fn check_framing(bytes: &[u8]) -> std::result::Result<(u32, usize, u64), String> {
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
    let sizes = [
        HEADER_SIZE,
        LIGHTMAP_HEADER_SIZE,
        LIGHTMAP_PART_HEADER_SIZE,
        PROBE_HEADER_SIZE,
    ];
    if !sizes.contains(&header_size) {
        return Err(format!(
            "header size {header_size} (version {VERSION} headers are {HEADER_SIZE} bytes, \
             {LIGHTMAP_HEADER_SIZE} for lightmap bakes, {LIGHTMAP_PART_HEADER_SIZE} for their shard parts, \
             {PROBE_HEADER_SIZE} for probe bakes)"
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
    Ok((version, header_size, payload))
}

/// Every field of a header whose framing [`check_framing`] accepted.
fn parse_fields(bytes: &[u8], version: u32) -> std::result::Result<Header, String> {
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let order = u32_at(16);
    if !(1..=sh::MAX_ORDER as u32).contains(&order) {
        return Err(format!("SH order {order} is outside 1..={}", sh::MAX_ORDER));
    }
    let channels = u32_at(20);
    if channels != 1 && channels != 3 {
        return Err(format!("{channels} channels (1 or 3 are defined)"));
    }
    let u16_at = |o: usize| u16::from_le_bytes(bytes[o..o + 2].try_into().expect("2 bytes"));
    let mode = match u16_at(36) {
        0 => Mode::Unshadowed,
        1 => Mode::Shadowed,
        2 => Mode::Interreflected,
        other => return Err(format!("unknown transfer mode {other}")),
    };
    let transfer = match u16_at(38) {
        0 => TransferKind::Vector,
        1 => TransferKind::Matrix,
        other => {
            return Err(format!(
                "unknown transfer kind {other} (0 = vector, 1 = matrix)"
            ));
        }
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
    if aux_flags & !(AUX_AO | AUX_BENT_NORMAL | AUX_ADAPTIVE | AUX_RECEIVERS | AUX_DENOISED) != 0 {
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
    // 88..108 is the shard identity ([`crate::formats::part_id::PartId`]); 108..124 the adaptive fields.
    let adaptive = read_adaptive(bytes, aux_flags, mode, sampling)?;
    if adaptive.is_some() && transfer == TransferKind::Matrix {
        return Err(
            "a target error in a transfer-matrix file (matrix bakes are not adaptive)".into(),
        );
    }
    let header = Header {
        version,
        order,
        channels,
        vertex_count: u64_at(24),
        samples_per_vertex,
        mode,
        transfer,
        bounces,
        bounce_samples,
        backend,
        sampling,
        seed: u64_at(48),
        scene_fingerprint: u64_at(56),
        aux,
        up,
        checksum: u32_at(CHECKSUM_OFFSET),
        adaptive,
        receivers: (aux_flags & AUX_RECEIVERS != 0).then(ReceiverObjects::default),
        denoised: aux_flags & AUX_DENOISED != 0,
    };
    Ok(header)
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
    let after_denoise = aux_flags & AUX_DENOISED != 0;
    Ok(Some(Adaptive {
        target_error,
        replicates,
        rays_cast,
        after_denoise,
    }))
}

/// CRC-32 (IEEE, as zlib's `crc32`) of the whole file with the checksum field read as zero.
pub(crate) fn checksum(bytes: &[u8]) -> u32 {
    let mut hasher = crc32fast::Hasher::new();
    hasher.update(&bytes[..CHECKSUM_OFFSET]);
    hasher.update(&[0; 4]);
    hasher.update(&bytes[HEADER_SIZE..]);
    hasher.finalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::coefficient_file::CoefficientFile;

    /// `bytes` with a new checksum, so only the change under test is wrong.
    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let sum = checksum(&bytes);
        bytes[CHECKSUM_OFFSET..HEADER_SIZE].copy_from_slice(&sum.to_le_bytes());
        bytes
    }

    #[test]
    fn matrix_files_record_their_kind_and_size() {
        let vector = CoefficientFile {
            header: Header {
                version: VERSION,
                order: 1,
                channels: 1,
                vertex_count: 2,
                samples_per_vertex: 64,
                mode: Mode::Shadowed,
                transfer: TransferKind::Vector,
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
                adaptive: None,
                receivers: None,
                denoised: false,
            },
            coefficients: vec![0.25, 0.5],
            ao: Some(vec![0.75, 1.0]),
            bent_normal: None,
            rays: None,
            error_estimate: None,
            lightmap: None,
            probes: None,
        };
        let (vector_bytes, _) = vector.to_bytes();
        // Mode 1 (shadowed) as the u32 every older reader reads: the kind's bytes are zero.
        assert_eq!(vector_bytes[36..40], [1, 0, 0, 0]);
        // Order 2: a 4×4 matrix, 16 floats per vertex.
        let matrix = CoefficientFile {
            header: Header {
                order: 2,
                transfer: TransferKind::Matrix,
                ..vector.header.clone()
            },
            coefficients: (0..32).map(|i| i as f32).collect(),
            ..vector.clone()
        };
        let (bytes, sum) = matrix.to_bytes();
        assert_eq!(bytes[36..40], [1, 0, 1, 0]);
        assert_eq!(bytes.len(), HEADER_SIZE + (2 * 16 + 2) * 4);
        let read = CoefficientFile::from_bytes(&bytes).unwrap();
        assert_eq!(read.header.transfer, TransferKind::Matrix);
        assert_eq!(read.vertex(1, 0), &matrix.coefficients[16..32]);
        assert_eq!(read.header.checksum, sum);
        // An unknown kind is refused; an interreflected matrix reads.
        let mut unknown = bytes.clone();
        unknown[38] = 2;
        let m = CoefficientFile::from_bytes(&resealed(unknown)).unwrap_err();
        assert!(m.contains("unknown transfer kind 2"), "{m}");
        let mut bounced = bytes;
        bounced[36] = 2;
        bounced[40] = 1;
        bounced[80] = 1;
        let read = CoefficientFile::from_bytes(&resealed(bounced)).unwrap();
        assert_eq!(read.header.mode, Mode::Interreflected);
        assert_eq!(read.header.transfer, TransferKind::Matrix);
    }
}

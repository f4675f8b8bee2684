//! Texel (lightmap) bakes in shard parts and checkpoint blocks.
//!
//! A texel bake's receivers are the lightmap's *baked* texels (covered, not leaking) in
//! row-major order; a part holds a range of them, so shards of equal length cast equal rays
//! (every baked texel casts `--samples` rays, `--bounce-samples` of them closest-hit) while
//! empty texels cost nothing. Which texels are baked, and where, is computed by every shard
//! from the scene (the atlas, then the leak test, [`crate::bake::lightmap::prepare`]), so
//! every part records a fingerprint of it, and the merge refuses parts that disagree.
//!
//! Shard 0's part also carries the atlas (the triangles' lightmap UVs) and the baked-texel
//! mask; the other shards' parts carry the lightmap's block only, tied to shard 0's by the
//! fingerprint (the arrays are a quarter of a part at 720,000 triangles, and the merge needs
//! one copy). The merge has no scene, and needs them to place the texels' values in the W×H lightmap,
//! dilate it, and read the previous bounce at the texels the bounce rows name (the same
//! [`crate::bake::lightmap::place`] and [`BounceTargets::slot_values`] a whole bake uses, so
//! the merged file is the whole bake's byte for byte). A per-object atlas's parts also carry
//! its placements (each object's scale and offset), which the merged file stores as the
//! whole bake's does.

use glam::{Vec2, Vec3};

use crate::bake::lightmap::dilation;
use crate::bake::lightmap::stitch::NO_PARTNER;
use crate::bake::lightmap::{
    Atlas, AtlasSource, Prepared, Stitching, Texels, place, place_unstitched,
};
use crate::bake::transfer::{BounceTargets, Visibility};
use crate::formats::coefficient_file::{CoefficientFile, LightmapBlock};
use crate::formats::encoded::Encoded;
use crate::formats::header::{HEADER_SIZE, Header, OBJECT_PLACEMENT_BYTES, ObjectPlacement};
use crate::formats::object_placements;
use crate::math::sh;
use crate::scene::Scene;
use crate::support::digest::Digest;

/// Bytes 128..192 of a texel part: the texel block of a whole texel file (128..160), then
/// the part's atlas block (160..192).
pub const BLOCK_BYTES: usize = 64;

/// What a texel part holds besides a vertex part's arrays: the lightmap's size and atlas,
/// which texels are baked, and the fingerprint that ties all shards of one bake together.
#[derive(Clone, Debug, PartialEq)]
pub struct PartLightmap {
    pub width: u32,
    pub height: u32,
    pub scene_vertex_count: u64,
    pub scene_triangle_count: u64,
    /// `--texel-size`, or 0 where the charts were scaled to fill the atlas.
    pub texel_size: f32,
    pub source: AtlasSource,
    /// Baked texels in the whole lightmap: the receivers that the shards split.
    pub receivers: u64,
    /// xxh3 of the atlas (UVs, size, texel size, source, per-object placements) and of the
    /// baked texels (mask, points, normals, ray origins, triangles: [`Texels::fingerprint`]).
    pub fingerprint: u64,
    /// Per scene triangle, its corners' lightmap UVs.
    pub uv1: Vec<[Vec2; 3]>,
    /// Per texel (row-major): baked.
    pub valid: Vec<bool>,
    /// Per scene triangle and edge, its seam partner
    /// ([`crate::bake::lightmap::stitch::seam_partners`]): the merge stitches with them.
    pub seams: Vec<[u32; 3]>,
    /// A per-object atlas's placements, in object order (empty for other atlases).
    pub objects: Vec<ObjectPlacement>,
    /// How many placements the block announces: what [`PartLightmap::tail_len`] counts
    /// before [`PartLightmap::read_tail`] has read them.
    announced_objects: u32,
    /// Whether the file carries the arrays above (UVs, mask, seam partners, placements). A
    /// checkpoint block does not ([`PartLightmap::without_arrays`]): the bake that resumes
    /// it computes them anyway and checks them by fingerprint, so a block is its texels'
    /// values only, not 30 MB of atlas each at 720,000 triangles.
    pub carried: bool,
    /// A shard part that leaves its arrays to shard 0's part ([`PartLightmap::in_shard_zero`]),
    /// not a checkpoint block.
    pub in_shard_zero: bool,
}

/// Atlas block flag (bytes 180..184): the part leaves its lightmap's arrays out.
const NOT_CARRIED: u32 = 1;
/// Atlas block flag: the arrays left out are in shard 0's part of the same bake (with
/// [`NOT_CARRIED`]; an older merge refuses the flag rather than take the part for a block).
const IN_SHARD_ZERO: u32 = 2;

impl PartLightmap {
    /// The lightmap of a texel bake of `scene` over `prepared`, with its arrays.
    pub fn new(scene: &Scene, prepared: &Prepared) -> PartLightmap {
        PartLightmap::block_of(scene, prepared).with_arrays(prepared)
    }

    /// [`PartLightmap::new`]'s block only (size, counts, fingerprint), the arrays not copied:
    /// a shard other than 0 carries no arrays, and shard 0 copies them once, into its part.
    pub fn block_of(scene: &Scene, prepared: &Prepared) -> PartLightmap {
        let atlas = &prepared.atlas;
        let texel_size = atlas.texel_size.unwrap_or(0.0);
        let mut digest = Digest::default();
        digest.bytes(&prepared.texels.fingerprint().to_le_bytes());
        digest.bytes(&texel_size.to_le_bytes());
        digest.bytes(&atlas.source.code().to_le_bytes());
        for corners in &atlas.uv1 {
            for p in corners {
                digest.floats(&p.to_array());
            }
        }
        for partners in &prepared.seams {
            for c in partners {
                digest.bytes(&c.to_le_bytes());
            }
        }
        digest.bytes(&objects_section(atlas.source, &atlas.objects));
        PartLightmap {
            width: atlas.width,
            height: atlas.height,
            scene_vertex_count: scene.vertex_count() as u64,
            scene_triangle_count: scene.triangles.len() as u64,
            texel_size,
            source: atlas.source,
            receivers: prepared.texels.valid_count() as u64,
            fingerprint: digest.finish(),
            uv1: Vec::new(),
            valid: Vec::new(),
            seams: Vec::new(),
            objects: Vec::new(),
            announced_objects: atlas.objects.len() as u32,
            carried: false,
            in_shard_zero: false,
        }
    }

    /// [`PartLightmap::block_of`] with its arrays, copied from `prepared`: what shard 0's part
    /// carries.
    pub fn with_arrays(self, prepared: &Prepared) -> PartLightmap {
        PartLightmap {
            uv1: prepared.atlas.uv1.clone(),
            valid: prepared.texels.valid.clone(),
            seams: prepared.seams.clone(),
            objects: prepared.atlas.objects.clone(),
            carried: true,
            ..self
        }
    }

    /// The lightmap with its block only (size, counts, fingerprint), as a checkpoint block
    /// carries it.
    pub fn without_arrays(&self) -> PartLightmap {
        PartLightmap {
            uv1: Vec::new(),
            valid: Vec::new(),
            seams: Vec::new(),
            objects: Vec::new(),
            carried: false,
            in_shard_zero: false,
            ..*self
        }
    }

    /// The lightmap as the part of a shard other than 0 carries it: its block only, the
    /// arrays being in shard 0's part.
    pub fn in_shard_zero(&self) -> PartLightmap {
        PartLightmap {
            in_shard_zero: true,
            ..self.without_arrays()
        }
    }

    /// Header bytes 128..192.
    pub(crate) fn block_bytes(&self) -> [u8; BLOCK_BYTES] {
        let mut b = Vec::with_capacity(BLOCK_BYTES);
        b.extend(self.width.to_le_bytes());
        b.extend(self.height.to_le_bytes());
        b.extend(self.scene_vertex_count.to_le_bytes());
        b.extend(self.scene_triangle_count.to_le_bytes());
        b.extend(self.texel_size.to_le_bytes());
        b.extend(self.source.code().to_le_bytes());
        b.extend(self.fingerprint.to_le_bytes());
        b.extend(self.receivers.to_le_bytes());
        b.extend(self.announced_objects.to_le_bytes());
        let flags = match (self.carried, self.in_shard_zero) {
            (true, _) => 0,
            (false, false) => NOT_CARRIED,
            (false, true) => NOT_CARRIED | IN_SHARD_ZERO,
        };
        b.extend(flags.to_le_bytes());
        b.resize(BLOCK_BYTES, 0); // reserved
        b.try_into().expect("64 bytes")
    }

    /// The bytes after a part's other arrays: the UVs (f32), the mask (u8, 1 = baked), per
    /// triangle and edge its seam partner (u32), then for a per-object atlas the placements
    /// (the texel file's per-object section, [`object_placements`]).
    /// They are appended to `e` borrowed (shard 0's part and the merged bounce files carry
    /// them: 26 MB at 720,000 triangles).
    pub(crate) fn put_tail<'a>(&'a self, e: &mut Encoded<'a>) {
        if !self.carried {
            return;
        }
        e.put(&self.uv1, |t: [Vec2; 3]| {
            let mut b = [0u8; 24];
            for (o, f) in b
                .chunks_exact_mut(4)
                .zip(t.iter().flat_map(|p| p.to_array()))
            {
                o.copy_from_slice(&f.to_le_bytes());
            }
            b
        });
        e.put(&self.valid, |v: bool| [u8::from(v)]);
        e.put(&self.seams, |c: [u32; 3]| {
            let mut b = [0u8; 12];
            for (o, c) in b.chunks_exact_mut(4).zip(c) {
                o.copy_from_slice(&c.to_le_bytes());
            }
            b
        });
        e.push(objects_section(self.source, &self.objects));
    }

    /// Length of [`PartLightmap::put_tail`]; `None` where a corrupted count overflows.
    pub(crate) fn tail_len(&self) -> Option<u64> {
        if !self.carried {
            return Some(0);
        }
        let objects = match self.source {
            AtlasSource::PerObject => {
                4 + OBJECT_PLACEMENT_BYTES as u64 * u64::from(self.announced_objects)
            }
            _ => 0,
        };
        self.scene_triangle_count
            .checked_mul(24 + 12)?
            .checked_add(u64::from(self.width) * u64::from(self.height))?
            .checked_add(objects)
    }

    /// The block of a part's header bytes (at least 192), its arrays still empty.
    pub(crate) fn from_block(
        bytes: &[u8],
        header: &Header,
    ) -> std::result::Result<PartLightmap, String> {
        let b = &bytes[HEADER_SIZE..HEADER_SIZE + BLOCK_BYTES];
        let block = LightmapBlock::from_block_bytes(&b[..32], header, "a part of a bake")?;
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"));
        let texels = header.vertex_count;
        let receivers = u64_at(40);
        if receivers > texels {
            return Err(format!(
                "{receivers} baked texels in a lightmap of {texels}"
            ));
        }
        let objects = u32_at(48);
        if objects > 0 && block.source != AtlasSource::PerObject {
            let source = block.source;
            return Err(format!("{objects} object placements in a {source:?} atlas"));
        }
        let flags = u32_at(52);
        if ![0, NOT_CARRIED, NOT_CARRIED | IN_SHARD_ZERO].contains(&flags) {
            return Err(format!("atlas block flags {flags:#x} (0, 1 or 3)"));
        }
        if b[56..].iter().any(|&x| x != 0) {
            return Err("reserved bytes 184..192 are not zero".into());
        }
        Ok(PartLightmap {
            width: block.width,
            height: block.height,
            scene_vertex_count: block.scene_vertex_count,
            scene_triangle_count: block.scene_triangle_count,
            texel_size: block.texel_size,
            source: block.source,
            receivers,
            fingerprint: u64_at(32),
            uv1: Vec::new(),
            valid: Vec::new(),
            seams: Vec::new(),
            objects: Vec::new(),
            announced_objects: objects,
            carried: flags & NOT_CARRIED == 0,
            in_shard_zero: flags & IN_SHARD_ZERO != 0,
        })
    }

    /// Reads [`PartLightmap::put_tail`] (exactly [`PartLightmap::tail_len`] bytes); without
    /// `arrays` only the mask (and placements), the UVs and seam partners left empty.
    pub(crate) fn read_tail(
        &mut self,
        tail: &[u8],
        arrays: bool,
    ) -> std::result::Result<(), String> {
        if !self.carried {
            return Ok(());
        }
        let uv_bytes = self.scene_triangle_count as usize * 24;
        let mask_bytes = self.width as usize * self.height as usize;
        let seam_bytes = self.scene_triangle_count as usize * 12;
        let (uv, rest) = tail.split_at(uv_bytes);
        let (mask, rest) = rest.split_at(mask_bytes);
        let (seams, objects) = rest.split_at(seam_bytes);
        if self.source == AtlasSource::PerObject {
            self.objects = object_placements::decode(objects)?;
        }
        // Decoded straight into place (every merge and gather reads a lightmap: intermediate
        // arrays were 26 MB of fresh memory each at 720,000 triangles).
        let (seams, uv) = match arrays {
            true => (seams, uv),
            false => (&[][..], &[][..]),
        };
        let code_at =
            |c: &[u8], k: usize| u32::from_le_bytes(c[4 * k..4 * k + 4].try_into().expect("4"));
        self.seams = seams
            .chunks_exact(12)
            .map(|c| [code_at(c, 0), code_at(c, 1), code_at(c, 2)])
            .collect();
        let edges = 3 * self.scene_triangle_count as usize;
        if let Some(i) = self
            .seams
            .iter()
            .flatten()
            .position(|&c| c != NO_PARTNER && c as usize / 2 >= edges)
        {
            let code = self.seams[i / 3][i % 3];
            return Err(format!("seam partner {code} of edge {i} is not an edge"));
        }
        let float_at = |c: &[u8], k: usize| f32::from_bits(code_at(c, k));
        self.uv1 = uv
            .chunks_exact(24)
            .map(|c| [0, 2, 4].map(|k| Vec2::new(float_at(c, k), float_at(c, k + 1))))
            .collect();
        if let Some(i) = self.uv1.iter().flatten().position(|p| !p.is_finite()) {
            return Err(format!("lightmap UV of triangle {} is not finite", i / 3));
        }
        if let Some(i) = mask.iter().position(|&b| b > 1) {
            return Err(format!("texel {i}'s mask byte is {} (0 or 1)", mask[i]));
        }
        self.valid = mask.iter().map(|&b| b == 1).collect();
        let baked = self.valid.iter().filter(|&&v| v).count() as u64;
        if baked != self.receivers {
            return Err(format!(
                "the mask holds {baked} baked texels, the header says {}",
                self.receivers
            ));
        }
        Ok(())
    }

    /// How the lightmaps of two parts differ (another atlas, resolution, leak test, scene),
    /// or `None` where they are one bake's.
    pub fn difference(&self, other: &PartLightmap) -> Option<String> {
        let fields = [
            ("width", self.width.to_string(), other.width.to_string()),
            ("height", self.height.to_string(), other.height.to_string()),
            (
                "scene vertices",
                self.scene_vertex_count.to_string(),
                other.scene_vertex_count.to_string(),
            ),
            (
                "scene triangles",
                self.scene_triangle_count.to_string(),
                other.scene_triangle_count.to_string(),
            ),
            (
                "texel size",
                self.texel_size.to_string(),
                other.texel_size.to_string(),
            ),
            (
                "atlas source",
                format!("{:?}", self.source),
                format!("{:?}", other.source),
            ),
            (
                "baked texels",
                self.receivers.to_string(),
                other.receivers.to_string(),
            ),
            (
                "atlas fingerprint",
                format!("{:016x}", self.fingerprint),
                format!("{:016x}", other.fingerprint),
            ),
        ];
        let differences: Vec<String> = fields
            .iter()
            .filter(|(_, a, b)| a != b)
            .map(|(name, a, b)| format!("{name} {b} instead of {a}"))
            .collect();
        (!differences.is_empty()).then(|| {
            format!(
                "another lightmap atlas or set of baked texels: {}",
                differences.join(", ")
            )
        })
    }

    /// The baked texels, by mask only (no points): enough to place, dilate and look up.
    pub fn texels(&self) -> Texels {
        Texels::mask(self.width, self.height, self.valid.clone())
    }

    /// Bounce values at the baked texels (`width` floats each, in their row-major order, as
    /// little-endian bytes: read from a bounce file, not decoded first) placed in the W×H
    /// lightmap and dilated: what [`BounceTargets::slot_values`] makes of them, without the
    /// lookup's other arrays (a gather reads no hit, only its rows).
    pub(crate) fn placed_and_dilated(&self, values: &[u8], width: usize) -> Vec<f32> {
        let texels = self.texels();
        let mut map = vec![0.0f32; texels.valid.len() * width];
        let valid = texels.valid.iter().enumerate().filter(|(_, v)| **v);
        for ((i, _), value) in valid.zip(values.chunks_exact(4 * width)) {
            let words = value.chunks_exact(4);
            for (m, w) in map[i * width..(i + 1) * width].iter_mut().zip(words) {
                *m = f32::from_le_bytes(w.try_into().expect("4 bytes"));
            }
        }
        crate::bake::lightmap::dilation::dilate_values(&texels, width, &mut map);
        map
    }

    /// The atlas the UVs describe.
    pub fn atlas(&self) -> Atlas {
        Atlas {
            width: self.width,
            height: self.height,
            uv1: self.uv1.clone(),
            source: self.source,
            texel_size: (self.texel_size > 0.0).then_some(self.texel_size),
            objects: self.objects.clone(),
        }
    }

    /// The whole texel file of a bake with `header` (the texel count as its vertex count) from
    /// every receiver's final transfer (`header.channels` × n² floats each) and aux arrays:
    /// placed in the lightmap, dilated and (with `stitch`) stitched, as
    /// [`crate::bake::lightmap::bake`] does.
    pub(crate) fn into_file(
        self,
        header: Header,
        receivers: &[f32],
        ao: Option<Vec<f32>>,
        bent_normal: Option<Vec<Vec3>>,
        stitch: bool,
    ) -> CoefficientFile {
        let width = header.coefficients_per_vertex();
        debug_assert_eq!(
            receivers.len(),
            self.receivers as usize
                * header.channels as usize
                * sh::coeff_count(header.order as usize)
        );
        let aux = header.aux;
        if !stitch && !aux.bent_normal && (header.mode.casts_rays() || !aux.ao) {
            let (coefficients, ao, dilated) = self.placed_unstitched(width, receivers, ao);
            return self.file_of(header, coefficients, ao, None, dilated);
        }
        // A whole bake dilates the visibility of every bake that casts rays.
        let visibility: Option<Vec<Visibility>> = header.mode.casts_rays().then(|| {
            (0..self.receivers as usize)
                .map(|k| Visibility {
                    accessibility: ao.as_ref().map_or(0.0, |a| a[k]),
                    bent_normal: bent_normal.as_ref().map_or(Vec3::Z, |b| b[k]),
                    ..Default::default()
                })
                .collect()
        });
        let texels = self.texels();
        let stitching = Stitching {
            partners: &self.seams,
            uv1: &self.uv1,
        };
        let placed = match stitch {
            true => place(
                &texels,
                width,
                receivers,
                visibility.as_deref(),
                &stitching,
                &mut Default::default(),
            ),
            false => place_unstitched(
                &texels,
                width,
                receivers,
                visibility.as_deref(),
                &mut Default::default(),
            ),
        };
        let ao = aux
            .ao
            .then(|| placed.visibility.iter().map(|v| v.accessibility).collect());
        let bent_normal = aux
            .bent_normal
            .then(|| placed.visibility.iter().map(|v| v.bent_normal).collect());
        self.file_of(header, placed.coefficients, ao, bent_normal, placed.dilated)
    }

    /// [`place_unstitched`] of the coefficients and the accessibility alone (`ao`, where the
    /// file has it), the same means in the same order: a whole texel's [`Visibility`] (28
    /// bytes, 117 MB at 2048²) spread only for its accessibility to be kept.
    fn placed_unstitched(
        &self,
        width: usize,
        receivers: &[f32],
        ao: Option<Vec<f32>>,
    ) -> (Vec<f32>, Option<Vec<f32>>, Vec<bool>) {
        let texels = self.texels();
        let count = texels.valid.len();
        let mut coefficients = vec![0.0f32; count * width];
        let mut map_ao = ao.as_ref().map(|_| vec![0.0f32; count]);
        let valid = texels.valid.iter().enumerate().filter(|(_, v)| **v);
        for (k, (i, _)) in valid.enumerate() {
            coefficients[i * width..(i + 1) * width]
                .copy_from_slice(&receivers[k * width..(k + 1) * width]);
            if let (Some(map), Some(ao)) = (map_ao.as_mut(), ao.as_ref()) {
                map[i] = ao[k];
            }
        }
        let w = texels.width as usize;
        let dilated = dilation::dilate_rings(&texels, |ring| {
            dilation::mean_ring(ring, w, width, &mut coefficients);
            if let Some(map) = map_ao.as_mut() {
                dilation::mean_ring(ring, w, 1, map);
            }
        });
        (coefficients, map_ao, dilated)
    }

    /// The texel file of `header` with the lightmap's arrays and the placed ones.
    fn file_of(
        self,
        header: Header,
        coefficients: Vec<f32>,
        ao: Option<Vec<f32>>,
        bent_normal: Option<Vec<Vec3>>,
        dilated: Vec<bool>,
    ) -> CoefficientFile {
        CoefficientFile {
            header: Header {
                checksum: 0,
                ..header
            },
            coefficients,
            ao,
            bent_normal,
            rays: None,
            error_estimate: None,
            lightmap: Some(LightmapBlock {
                width: self.width,
                height: self.height,
                scene_vertex_count: self.scene_vertex_count,
                scene_triangle_count: self.scene_triangle_count,
                texel_size: self.texel_size,
                source: self.source,
                valid: self.valid,
                dilated,
                uv1: self.uv1,
                objects: self.objects,
            }),
            probes: None,
        }
    }
}

/// The lookup of a texel bake's bounces from a part's lightmap (the merge's, with no scene):
/// only [`BounceTargets::slot_values`] is used there, which needs the mask alone.
pub(crate) struct Lookup {
    atlas: Atlas,
    texels: Texels,
}

impl Lookup {
    pub(crate) fn new(lightmap: &PartLightmap) -> Lookup {
        Lookup {
            atlas: lightmap.atlas(),
            texels: lightmap.texels(),
        }
    }

    pub(crate) fn targets(&self) -> BounceTargets<'_> {
        BounceTargets::texels(&self.atlas, &self.texels)
    }
}

/// The per-object section of an atlas's placements, or nothing for other atlases (whose
/// parts are what they were before per-object atlases could be sharded).
fn objects_section(source: AtlasSource, objects: &[ObjectPlacement]) -> Vec<u8> {
    match source {
        AtlasSource::PerObject => object_placements::encode(objects),
        _ => Vec::new(),
    }
}

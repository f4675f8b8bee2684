//! A prepared lightmap on disk (`prt-bake prepare-lightmap`): the atlas, the rasterised texels
//! after the leak test and the seam partners ([`Prepared`]), computed once and read by every
//! shard of a texel bake (`bake --shard K/N --prepared FILE`) and by the stitch shards, so no
//! shard repeats the atlas, the rasterisation or the leak test.
//!
//! The file records a *key*: an xxh3 of everything the preparation depends on (the scene's
//! fingerprint, the lightmap options, the seed, the backend, whether rays are cast). A reader
//! computes the key from its own scene and options and refuses a file whose key differs.
//!
//! Layout (little-endian): magic `PRTLMP\0\x01`, key u64, xxh3 of the rest u64; then width,
//! height (u32), triangles (u64), atlas source (u32), texel size (f32, 0: none), moved and
//! leaking (u64), per-object placements (u32 count + records, [`object_placements`]); per
//! triangle its UVs (6 f32) and seam partners (3 u32); per texel a flag byte (1 baked, 2 has a
//! point) and its triangle (u32); per texel with a point: position, normal, mapped normal and
//! ray origin (12 f32).

use std::path::Path;

use glam::{Vec2, Vec3};

use crate::bake::lightmap::stitch::NO_PARTNER;
use crate::bake::lightmap::{Atlas, Prepared, Stages, Texels, leaks};
use crate::formats::header::AtlasSource;
use crate::formats::object_placements;
use crate::support::error::{Error, Result};

const MAGIC: &[u8; 8] = b"PRTLMP\0\x01";
/// Magic, key, checksum.
const HEAD: usize = 24;

/// The key of a preparation: what it depends on, hashed. `options` are the lightmap options
/// as the command line gave them (resolution, texel size, atlas method, strict UVs, up axis),
/// in a fixed text form.
pub fn key(scene_fingerprint: u64, options: &str, seed: u64, backend: &str, rays: bool) -> u64 {
    let text = format!("{scene_fingerprint:016x}|{options}|{seed}|{backend}|{rays}");
    xxhash_rust::xxh3::xxh3_64(text.as_bytes())
}

/// The file's bytes.
pub fn to_bytes(key: u64, prepared: &Prepared) -> Vec<u8> {
    let (atlas, texels) = (&prepared.atlas, &prepared.texels);
    let mut b: Vec<u8> = Vec::new();
    b.extend(atlas.width.to_le_bytes());
    b.extend(atlas.height.to_le_bytes());
    b.extend((atlas.uv1.len() as u64).to_le_bytes());
    b.extend(atlas.source.code().to_le_bytes());
    b.extend(atlas.texel_size.unwrap_or(0.0).to_le_bytes());
    b.extend((prepared.settled.moved as u64).to_le_bytes());
    b.extend((prepared.settled.leaking as u64).to_le_bytes());
    b.extend(object_placements::encode(&atlas.objects));
    for uv in atlas.uv1.iter().flatten() {
        b.extend(uv.x.to_le_bytes());
        b.extend(uv.y.to_le_bytes());
    }
    b.extend(
        prepared
            .seams
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes()),
    );
    let has_point = |i: usize| {
        texels.triangle[i] != u32::MAX
            || [
                texels.positions[i],
                texels.normals[i],
                texels.mapped[i],
                texels.origins[i],
            ]
            .iter()
            .any(|v| *v != Vec3::ZERO)
    };
    for i in 0..texels.valid.len() {
        b.push(u8::from(texels.valid[i]) | (u8::from(has_point(i)) << 1));
    }
    b.extend(texels.triangle.iter().flat_map(|t| t.to_le_bytes()));
    for i in (0..texels.valid.len()).filter(|&i| has_point(i)) {
        for v in [
            texels.positions[i],
            texels.normals[i],
            texels.mapped[i],
            texels.origins[i],
        ] {
            b.extend(v.to_array().iter().flat_map(|x| x.to_le_bytes()));
        }
    }
    let mut bytes = Vec::with_capacity(HEAD + b.len());
    bytes.extend(MAGIC);
    bytes.extend(key.to_le_bytes());
    bytes.extend(xxhash_rust::xxh3::xxh3_64(&b).to_le_bytes());
    bytes.extend(b);
    bytes
}

/// Reads the bytes of a prepared lightmap: its key and the preparation (stage times empty).
pub fn from_bytes(bytes: &[u8]) -> std::result::Result<(u64, Prepared), String> {
    if bytes.len() < HEAD || &bytes[..8] != MAGIC {
        return Err("not a prepared lightmap (prt-bake prepare-lightmap)".into());
    }
    let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
    let (key, sum) = (u64_at(8), u64_at(16));
    let body = &bytes[HEAD..];
    if xxhash_rust::xxh3::xxh3_64(body) != sum {
        return Err("checksum mismatch: the file is truncated or corrupted".into());
    }
    let mut r = Reader { bytes: body, at: 0 };
    let width = r.u32()?;
    let height = r.u32()?;
    let triangles = r.u64()? as usize;
    let source = AtlasSource::from_code(r.u32()?).ok_or("unknown atlas source")?;
    let texel_size = r.f32()?;
    let moved = r.u64()? as usize;
    let leaking = r.u64()? as usize;
    let placements = r.u32()? as usize;
    let section = r.take(
        placements
            .checked_mul(OBJECT_BYTES)
            .ok_or("too many objects")?,
    )?;
    let mut encoded = (placements as u32).to_le_bytes().to_vec();
    encoded.extend(section);
    let objects = match placements {
        0 => Vec::new(),
        _ => object_placements::decode(&encoded)?,
    };
    let count = |n: usize, each: usize| n.checked_mul(each).ok_or("sizes overflow");
    let uv = r.floats(count(triangles, 6)?)?;
    let uv1 = uv
        .chunks_exact(6)
        .map(|c| {
            [
                Vec2::new(c[0], c[1]),
                Vec2::new(c[2], c[3]),
                Vec2::new(c[4], c[5]),
            ]
        })
        .collect();
    let codes = r.u32s(count(triangles, 3)?)?;
    let edges = 3 * triangles;
    if let Some(i) = codes
        .iter()
        .position(|&c| c != NO_PARTNER && c as usize / 2 >= edges)
    {
        return Err(format!(
            "seam partner {} of edge {i} is not an edge",
            codes[i]
        ));
    }
    let seams = codes.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let texel_count = count(width as usize, height as usize)?;
    let flags = r.take(texel_count)?.to_vec();
    let triangle = r.u32s(texel_count)?;
    if let Some(i) = (0..texel_count).find(|&i| {
        let t = triangle[i];
        (t != u32::MAX && t as usize >= triangles) || (flags[i] & 1 != 0 && t == u32::MAX)
    }) {
        return Err(format!(
            "texel {i}'s triangle {} is not one of the {triangles}",
            triangle[i]
        ));
    }
    let with_point = flags.iter().filter(|&&f| f & 2 != 0).count();
    let points = r.floats(count(with_point, 12)?)?;
    if r.at != body.len() {
        return Err(format!("{} bytes after the texels", body.len() - r.at));
    }
    let mut texels = Texels {
        width,
        height,
        valid: flags.iter().map(|&f| f & 1 != 0).collect(),
        positions: vec![Vec3::ZERO; texel_count],
        normals: vec![Vec3::ZERO; texel_count],
        mapped: vec![Vec3::ZERO; texel_count],
        origins: vec![Vec3::ZERO; texel_count],
        triangle,
    };
    let mut point = points.chunks_exact(3).map(Vec3::from_slice);
    for i in (0..texel_count).filter(|&i| flags[i] & 2 != 0) {
        texels.positions[i] = point.next().expect("counted");
        texels.normals[i] = point.next().expect("counted");
        texels.mapped[i] = point.next().expect("counted");
        texels.origins[i] = point.next().expect("counted");
    }
    let prepared = Prepared {
        atlas: Atlas {
            width,
            height,
            uv1,
            source,
            texel_size: (texel_size > 0.0).then_some(texel_size),
            objects,
        },
        texels,
        settled: leaks::Settled { moved, leaking },
        seams,
        stages: Stages::default(),
    };
    Ok((key, prepared))
}

/// Writes a prepared lightmap atomically.
pub fn write(path: &Path, key: u64, prepared: &Prepared) -> Result<()> {
    crate::support::atomic::write(path, &to_bytes(key, prepared))
}

/// Reads the prepared lightmap at `path` whatever its key (`prt-bake stitch` has no scene: it
/// checks the atlas and texels against the file it stitches instead).
pub fn read_any(path: &Path) -> Result<Prepared> {
    Ok(read_identified(path)?.2)
}

/// [`read_any`], with the file's key and the checksum of its bytes: what identifies this
/// very preparation (a seam factor records them, `distribute::factor_file`).
pub fn read_identified(path: &Path) -> Result<(u64, u64, Prepared)> {
    let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
    let (key, prepared) =
        from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))?;
    let sum = u64::from_le_bytes(bytes[16..24].try_into().expect("from_bytes checked"));
    Ok((key, sum, prepared))
}

/// Reads the prepared lightmap at `path`, refusing (exit 3, [`Error::Shards`]) one whose key
/// is not `key`: another scene, other lightmap options, seed or backend.
pub fn read(path: &Path, key: u64) -> Result<Prepared> {
    let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
    let (found, prepared) =
        from_bytes(&bytes).map_err(|message| Error::coefficient_file(path, message))?;
    if found != key {
        return Err(Error::Shards(format!(
            "{}: a prepared lightmap of another scene or other options (key {found:016x}, this \
             bake's {key:016x}): prepare it again with this bake's scene, --lightmap, \
             --texel-size, --atlas, --strict-uvs, --up, --seed, --backend and --mode",
            path.display()
        )));
    }
    Ok(prepared)
}

/// Bytes of one per-object placement record.
const OBJECT_BYTES: usize = crate::formats::header::OBJECT_PLACEMENT_BYTES;

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let end = end.ok_or("the file is shorter than its sizes announce")?;
        let out = &self.bytes[self.at..end];
        self.at = end;
        Ok(out)
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().expect("4")))
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8")))
    }
    fn f32(&mut self) -> std::result::Result<f32, String> {
        Ok(f32::from_le_bytes(self.take(4)?.try_into().expect("4")))
    }
    fn u32s(&mut self, n: usize) -> std::result::Result<Vec<u32>, String> {
        let bytes = self.take(n.checked_mul(4).ok_or("sizes overflow")?)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().expect("4")))
            .collect())
    }
    fn floats(&mut self, n: usize) -> std::result::Result<Vec<f32>, String> {
        let bytes = self.take(n.checked_mul(4).ok_or("sizes overflow")?)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
            .collect())
    }
}

//! A prepared lightmap on disk (`prt-bake prepare-lightmap`): the atlas, the rasterised texels
//! after the leak test and the seam partners ([`Prepared`]), computed once and read by every
//! shard of a texel bake (`bake --shard K/N --prepared FILE`) and by the stitch shards, so no
//! shard repeats the atlas, the rasterisation or the leak test.
//!
//! The file records a *key*: an xxh3 of everything the preparation depends on (the scene's
//! fingerprint, the lightmap options, the seed, the backend, whether rays are cast). A reader
//! computes the key from its own scene and options and refuses a file whose key differs.
//!
//! Layout (little-endian): magic `PRTLMP\0\x02`, key u64, xxh3 of the rest u64; then width,
//! height (u32), triangles (u64), atlas source (u32), texel size (f32, 0: none), moved and
//! leaking (u64), whether the seam points are known (u32, 0 or 1), per-object placements (u32
//! count + records, [`object_placements`]); per triangle its UVs (6 f32) and seam partners (3
//! u32); per texel a flag byte (1 baked, 2 has a point, 4 its ray origin is a seam point) and
//! its triangle (u32); per texel with a point: position, normal, mapped normal and ray origin
//! (12 f32). Version 1 files (without the seam points) are refused: prepare again.

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::bake::lightmap::stitch::NO_PARTNER;
use crate::bake::lightmap::{Atlas, Prepared, Stages, Texels, leaks};
use crate::formats::header::AtlasSource;
use crate::formats::object_placements;
use crate::support::error::{Error, Result};
use crate::support::output::Output;

const MAGIC: &[u8; 8] = b"PRTLMP\0\x02";
/// The first version's magic, refused with a message.
const MAGIC_1: &[u8; 8] = b"PRTLMP\0\x01";
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
    let body = body_bytes(prepared);
    let mut bytes = head_bytes(key, &body);
    bytes.extend(body);
    bytes
}

/// Magic, key and the body's checksum.
fn head_bytes(key: u64, body: &[u8]) -> Vec<u8> {
    let mut head = Vec::with_capacity(HEAD);
    head.extend(MAGIC);
    head.extend(key.to_le_bytes());
    head.extend(xxhash_rust::xxh3::xxh3_64(body).to_le_bytes());
    head
}

/// Everything after the head.
fn body_bytes(prepared: &Prepared) -> Vec<u8> {
    let (atlas, texels) = (&prepared.atlas, &prepared.texels);
    let mut b: Vec<u8> = Vec::new();
    b.extend(atlas.width.to_le_bytes());
    b.extend(atlas.height.to_le_bytes());
    b.extend((atlas.uv1.len() as u64).to_le_bytes());
    b.extend(atlas.source.code().to_le_bytes());
    b.extend(atlas.texel_size.unwrap_or(0.0).to_le_bytes());
    b.extend((prepared.settled.moved as u64).to_le_bytes());
    b.extend((prepared.settled.leaking as u64).to_le_bytes());
    b.extend(u32::from(prepared.seam_points.is_some()).to_le_bytes());
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
    let mut seam = vec![false; texels.valid.len()];
    if let Some(points) = &prepared.seam_points {
        for (i, &s) in texels.valid_indices().zip(points) {
            seam[i] = s;
        }
    }
    for (i, &seam) in seam.iter().enumerate() {
        b.push(u8::from(texels.valid[i]) | (u8::from(has_point(i)) << 1) | (u8::from(seam) << 2));
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
    b
}

/// Reads the bytes of a prepared lightmap: its key and the preparation (stage times empty).
pub fn from_bytes(bytes: &[u8]) -> std::result::Result<(u64, Prepared), String> {
    parse(bytes, Points::Read)
}

/// Whether a reading decodes the texels' points (a shard's receivers) or leaves them out (the
/// seam stitch needs only which texels are baked: [`Texels::mask`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Points {
    Read,
    Skip,
}

fn parse(bytes: &[u8], points_read: Points) -> std::result::Result<(u64, Prepared), String> {
    if bytes.len() >= HEAD && &bytes[..8] == MAGIC_1 {
        return Err(
            "a prepared lightmap of an older prt-bake (without its seam points): prepare it again"
                .into(),
        );
    }
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
    let seams_known = match r.u32()? {
        0 => false,
        1 => true,
        other => return Err(format!("seam points flag {other}, not 0 or 1")),
    };
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
    // Each array is decoded straight from the file's bytes into its place (a shard reads
    // this file before its rays: copies of its 100 MB were a second of CPU in each shard).
    let uv1 = r
        .take(count(triangles, 24)?)?
        .chunks_exact(24)
        .map(|c| {
            let f = |k: usize| f32_at(c, 4 * k);
            [
                Vec2::new(f(0), f(1)),
                Vec2::new(f(2), f(3)),
                Vec2::new(f(4), f(5)),
            ]
        })
        .collect();
    let edges = 3 * triangles;
    let seams: Vec<[u32; 3]> = r
        .take(count(triangles, 12)?)?
        .chunks_exact(12)
        .map(|c| [0, 4, 8].map(|o| u32_at(c, o)))
        .collect();
    if let Some(i) = seams
        .iter()
        .flatten()
        .position(|&c| c != NO_PARTNER && c as usize / 2 >= edges)
    {
        let code = seams[i / 3][i % 3];
        return Err(format!("seam partner {code} of edge {i} is not an edge"));
    }
    let texel_count = count(width as usize, height as usize)?;
    let flags = r.take(texel_count)?;
    let triangle: Vec<u32> = r
        .take(count(texel_count, 4)?)?
        .par_chunks_exact(4)
        .map(|c| u32_at(c, 0))
        .collect();
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
    let points = r.take(count(with_point, 48)?)?;
    if r.at != body.len() {
        return Err(format!("{} bytes after the texels", body.len() - r.at));
    }
    if let Some(i) = (0..texel_count).find(|&i| flags[i] & !7 != 0 || (flags[i] & 5 == 4)) {
        return Err(format!("texel {i}'s flags {} are not a texel's", flags[i]));
    }
    let seam_points = seams_known.then(|| {
        flags
            .iter()
            .filter(|&&f| f & 1 != 0)
            .map(|&f| f & 4 != 0)
            .collect()
    });
    let valid = flags.iter().map(|&f| f & 1 != 0).collect();
    let texels = match points_read {
        Points::Read => {
            let [positions, normals, mapped, origins] = point_arrays(flags, points);
            Texels {
                width,
                height,
                valid,
                positions,
                normals,
                mapped,
                origins,
                triangle,
            }
        }
        Points::Skip => Texels::mask(width, height, valid),
    };
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
        seam_points,
        stages: Stages::default(),
    };
    Ok((key, prepared))
}

/// Writes a prepared lightmap atomically, its head and body apart (not copied into one buffer
/// first: 107 MB at 2048² planar).
pub fn write(path: &Path, key: u64, prepared: &Prepared) -> Result<()> {
    let body = body_bytes(prepared);
    let head = head_bytes(key, &body);
    Output::new(path, &[])?.write_parts(&[&head, &body])
}

/// Reads the prepared lightmap at `path` whatever its key (`prt-bake stitch` has no scene: it
/// checks the atlas and texels against the file it stitches instead), for its seams: the
/// texels are a mask ([`Texels::mask`]), without their points (two thirds of the file).
pub fn read_any(path: &Path) -> Result<Prepared> {
    Ok(read_identified(path)?.2)
}

/// [`read_any`], with the file's key and the checksum of its bytes: what identifies this
/// very preparation (a seam factor records them, `distribute::factor_file`).
pub fn read_identified(path: &Path) -> Result<(u64, u64, Prepared)> {
    let bytes = crate::distribute::big_reads::map(path)?;
    let (key, prepared) =
        parse(&bytes, Points::Skip).map_err(|message| Error::coefficient_file(path, message))?;
    let sum = u64::from_le_bytes(bytes[16..24].try_into().expect("from_bytes checked"));
    Ok((key, sum, prepared))
}

/// Reads the prepared lightmap at `path`, refusing (exit 3, [`Error::Shards`]) one whose key
/// is not `key`: another scene, other lightmap options, seed or backend.
pub fn read(path: &Path, key: u64) -> Result<Prepared> {
    let bytes = crate::distribute::big_reads::map(path)?;
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

/// Every texel's position, normal, mapped normal and ray origin (zero where its flag byte
/// says it has no point), from the file's points: the n-th is the point of the n-th texel
/// that has one.
fn point_arrays(flags: &[u8], points: &[u8]) -> [Vec<Vec3>; 4] {
    let mut first_point = Vec::with_capacity(flags.len());
    let mut n = 0u32;
    for &f in flags {
        first_point.push(n);
        n += u32::from(f & 2 != 0);
    }
    let point = |i: usize, which: usize| match flags[i] & 2 != 0 {
        true => {
            let at = 48 * first_point[i] as usize + 12 * which;
            Vec3::new(
                f32_at(points, at),
                f32_at(points, at + 4),
                f32_at(points, at + 8),
            )
        }
        false => Vec3::ZERO,
    };
    std::array::from_fn(|which| {
        (0..flags.len())
            .into_par_iter()
            .map(|i| point(i, which))
            .collect()
    })
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

fn f32_at(bytes: &[u8], at: usize) -> f32 {
    f32::from_bits(u32_at(bytes, at))
}

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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::lightmap::texels::cornell_lightmap;
    use crate::trace::{Backend, TracerOptions};

    /// The Cornell room's floor meets its walls edge to edge: some of its texels' ray origins
    /// are seam points, which the file must carry so a shard need not find them again.
    #[test]
    fn seam_points_round_trip_and_old_or_damaged_files_are_refused() {
        let (scene, atlas, _) = cornell_lightmap(64);
        let tracer =
            crate::trace::build(Backend::Embree, &scene, TracerOptions::default()).unwrap();
        let prepared = crate::bake::lightmap::prepare(&scene, Some(&*tracer), 7, atlas).unwrap();
        let seam = prepared
            .seam_points
            .clone()
            .expect("Embree routes by origin");
        assert_eq!(seam.len(), prepared.texels.valid_count());
        assert!(seam.iter().any(|&s| s) && seam.iter().any(|&s| !s));
        let bytes = to_bytes(42, &prepared);
        let (key, read) = from_bytes(&bytes).unwrap();
        assert_eq!((key, read.seam_points.as_ref()), (42, Some(&seam)));
        assert_eq!(read.texels.valid, prepared.texels.valid);
        assert_eq!(read.texels.origins, prepared.texels.origins);
        assert_eq!(read.atlas.uv1, prepared.atlas.uv1);
        assert_eq!(read.seams, prepared.seams);

        // Without a tracer there are no seam points to carry.
        let unknown = Prepared {
            seam_points: None,
            ..prepared.clone()
        };
        assert_eq!(
            from_bytes(&to_bytes(1, &unknown)).unwrap().1.seam_points,
            None
        );

        let mut old = bytes.clone();
        old[..8].copy_from_slice(MAGIC_1);
        assert!(from_bytes(&old).unwrap_err().contains("older prt-bake"));
        // A seam flag on a texel that is not baked, with a checksum that matches.
        let flags_at = bytes.len()
            - 4 * 4096
            - 48 * prepared
                .texels
                .positions
                .iter()
                .filter(|p| **p != Vec3::ZERO)
                .count()
            - 4096;
        let blank = (0..4096).find(|&i| !prepared.texels.valid[i]).unwrap();
        let mut damaged = bytes.clone();
        damaged[flags_at + blank] |= 4;
        let sum = xxhash_rust::xxh3::xxh3_64(&damaged[HEAD..]);
        damaged[16..24].copy_from_slice(&sum.to_le_bytes());
        assert!(
            from_bytes(&damaged).unwrap_err().contains("flags"),
            "{:?}",
            from_bytes(&damaged).err()
        );
    }
}

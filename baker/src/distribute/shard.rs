//! Shards: one bake split into parts that bake on different machines (a Slurm job array, a
//! Kubernetes Indexed Job) and are merged into the file one machine would have written
//! ([`crate::distribute::merge`]). A checkpoint block ([`crate::distribute::checkpoint`]) is the same kind of part.
//!
//! A part is a range of consecutive vertices. Every vertex casts `--samples` rays in every mode
//! (the interreflected mode's bounce samples are among them), so ranges of equal length are
//! balanced by expected rays: shard K of N is vertices ⌊K·V/N⌋..⌊(K+1)·V/N⌋.
//!
//! A part file is a `.prt` whose header is the whole bake's (every option, the seed, the scene
//! fingerprint, the backend, the final channel count), with its identity in bytes 88..108 and
//! a payload of its own: its vertices' coefficients and aux arrays, and in interreflected mode
//! its direct (shadowed) transfer and bounce rows instead of the final transfer, because a
//! bounce gathers from every vertex of the scene. `docs/reference/coefficient-format.md` specifies it.

use std::ops::Range;
use std::path::Path;

use glam::Vec3;

use crate::bake::denoise::{self, Guides, Settings};
use crate::bake::interreflection::{self, PackedRows, RowSource, Rows};
use crate::bake::transfer::{BakeOptions, BounceTargets, Mode};
use crate::distribute::lightmap_parts::{Lookup, PartLightmap};
use crate::distribute::part_guides::{GUIDE_WORDS, parse_guides};
use crate::distribute::row_encoding::{EncodedRows, parse_rows, row_starts};
use crate::formats::coefficient_file::{self, CoefficientFile};
use crate::formats::header::{self, HEADER_SIZE, Header, LIGHTMAP_PART_HEADER_SIZE};
pub use crate::formats::part_id::{PartId, ShardId};
use crate::math::sh;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;

/// The environment variable that gives the shard count to `--shard auto` in a Kubernetes
/// Indexed Job (which sets only the index, `JOB_COMPLETION_INDEX`).
pub const SHARD_COUNT_VARIABLE: &str = "PRT_SHARD_COUNT";

impl ShardId {
    /// Parses `--shard`: `K/N`, or `auto` / `auto/N`, which read the index (and the count)
    /// from the environment through `env`:
    /// * a Slurm array task: `SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN` (0 if unset) and
    ///   `SLURM_ARRAY_TASK_COUNT` (`--array=0-(N-1)`);
    /// * a Kubernetes Indexed Job: `JOB_COMPLETION_INDEX`, the count from `auto/N` or
    ///   [`SHARD_COUNT_VARIABLE`].
    pub fn parse(spec: &str, env: &dyn Fn(&str) -> Option<String>) -> Result<ShardId> {
        let bad = |why: String| Error::InvalidOption(format!("--shard {spec}: {why}"));
        let number = |text: &str, what: &str| {
            text.trim()
                .parse::<u32>()
                .map_err(|_| bad(format!("{what} {text:?} is not a whole number")))
        };
        let (index, count) = match spec.split_once('/') {
            _ if spec == "auto" => auto(None, env).map_err(bad)?,
            Some(("auto", count)) => auto(Some(number(count, "the count")?), env).map_err(bad)?,
            Some((index, count)) => (number(index, "the index")?, number(count, "the count")?),
            None => return Err(bad("expected K/N, auto or auto/N".into())),
        };
        if count == 0 {
            return Err(bad("the shard count must be at least 1".into()));
        }
        if index >= count {
            return Err(bad(format!(
                "shard index {index} is not below the count {count}"
            )));
        }
        Ok(ShardId { index, count })
    }
}

/// `--shard auto`: (index, count) from a Slurm array task or a Kubernetes Indexed Job.
fn auto(
    count: Option<u32>,
    env: &dyn Fn(&str) -> Option<String>,
) -> std::result::Result<(u32, u32), String> {
    let number = |name: &str| -> std::result::Result<Option<u32>, String> {
        env(name)
            .map(|value| {
                value
                    .trim()
                    .parse::<u32>()
                    .map_err(|_| format!("{name}={value:?} is not a whole number"))
            })
            .transpose()
    };
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        let slurm_count = number("SLURM_ARRAY_TASK_COUNT")?
            .ok_or("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not")?;
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        if let Some(count) = count.filter(|&c| c != slurm_count) {
            return Err(format!(
                "the count {count} differs from the Slurm array's SLURM_ARRAY_TASK_COUNT={slurm_count}"
            ));
        }
        let index = id
            .checked_sub(min)
            .ok_or("SLURM_ARRAY_TASK_ID is below SLURM_ARRAY_TASK_MIN")?;
        return Ok((index, slurm_count));
    }
    if let Some(index) = number("JOB_COMPLETION_INDEX")? {
        let count = match count {
            Some(count) => count,
            None => number(SHARD_COUNT_VARIABLE)?.ok_or(format!(
                "JOB_COMPLETION_INDEX is set, but not the count: use --shard auto/N or set {SHARD_COUNT_VARIABLE}"
            ))?,
        };
        return Ok((index, count));
    }
    Err(
        "neither a Slurm array task (SLURM_ARRAY_TASK_ID) nor a Kubernetes Indexed Job \
         (JOB_COMPLETION_INDEX) is in the environment"
            .into(),
    )
}

/// The vertices of shard `shard` of a scene of `vertex_count` vertices: equal shares (±1),
/// hence equal expected rays.
pub fn shard_range(vertex_count: usize, shard: ShardId) -> Range<usize> {
    let at = |k: u32| (vertex_count as u128 * u128::from(k) / u128::from(shard.count)) as usize;
    at(shard.index)..at(shard.index + 1)
}

/// A shard part (or checkpoint block) in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// The whole bake's header: `vertex_count` is the scene's, `channels` the final file's.
    pub header: Header,
    pub id: PartId,
    /// Per vertex of the part, `width` floats ([`Part::coefficient_width`]): the final
    /// transfer, or in interreflected mode the direct (shadowed, one-channel) transfer.
    pub coefficients: Vec<f32>,
    pub ao: Option<Vec<f32>>,
    pub bent_normal: Option<Vec<Vec3>>,
    /// Interreflected mode: the part's bounce rows.
    pub rows: Option<Rows>,
    /// Texel bakes: the lightmap (atlas, baked texels, fingerprint). The part's "vertices"
    /// are then the baked texels, in row-major order.
    pub lightmap: Option<PartLightmap>,
    /// Denoised bakes ([`Header::denoised`]): each receiver's noise and the denoiser's
    /// guides, for the merge to denoise with ([`crate::distribute::part_guides`]).
    pub guides: Option<Guides>,
}

impl Part {
    /// Floats per vertex in a part's coefficient array.
    pub fn coefficient_width(header: &Header) -> usize {
        match header.mode {
            Mode::Interreflected => sh::coeff_count(header.order as usize),
            _ => header.coefficients_per_vertex(),
        }
    }

    pub fn range(&self) -> Range<usize> {
        self.id.range()
    }

    /// Where the denoiser's guides lie in the part's file (denoised bakes): after the
    /// transfer and the aux arrays, 12 words a receiver.
    pub fn guide_words_at(&self) -> Option<Range<usize>> {
        let header_size = match self.lightmap {
            Some(_) => LIGHTMAP_PART_HEADER_SIZE,
            None => HEADER_SIZE,
        };
        let aux = usize::from(self.header.aux.ao) + 3 * usize::from(self.header.aux.bent_normal);
        let count = self.id.vertices as usize;
        let at = header_size + count * (Part::coefficient_width(&self.header) + aux) * 4;
        self.header
            .denoised
            .then_some(at..at + count * GUIDE_WORDS * 4)
    }

    /// The part file's bytes (checksummed): [`Part::encode`]'s pieces in one buffer.
    pub fn to_bytes(&self) -> Vec<u8> {
        self.encode().into_vec()
    }

    /// The receivers of the whole bake the part is of: the scene's vertices, or the baked
    /// texels of a texel bake.
    pub fn receiver_count(&self) -> usize {
        match &self.lightmap {
            Some(l) => l.receivers as usize,
            None => self.header.vertex_count as usize,
        }
    }

    /// Parses and validates a part file's bytes; the error is a sentence for the user. A
    /// texel checkpoint block, which leaves its lightmap's arrays out, is refused: only
    /// [`Part::read_block`] reads one.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Part, String> {
        Part::checked(Part::parse(bytes, Reading::Whole)?.0)
    }

    /// Refuses a texel checkpoint block, which leaves its lightmap's arrays out, and a part
    /// of shard 0 that leaves them out too (the other shards' parts leave them to it).
    fn checked(part: Part) -> std::result::Result<Part, String> {
        let Some(l) = part.lightmap.as_ref().filter(|l| !l.carried) else {
            return Ok(part);
        };
        match (l.in_shard_zero, part.id.shard.index) {
            (false, _) => Err(format!(
                "{}: a checkpoint block (without its lightmap's atlas), not a part",
                part.id
            )),
            (true, 0) => Err(format!(
                "{}: shard 0's part without its lightmap's atlas (it is the one that carries it)",
                part.id
            )),
            (true, _) => Ok(part),
        }
    }

    /// [`Part::from_bytes`], a texel checkpoint block too, reading what `reading` says;
    /// with [`Reading::Packed`] also where the rows' entries start and each row's.
    fn parse(
        bytes: &[u8],
        reading: Reading,
    ) -> std::result::Result<(Part, Option<RowsAt>), String> {
        let (header, payload_bytes, header_size) = header::parse_header(bytes)?;
        let id = PartId::from_header_bytes(bytes)?
            .ok_or("a whole bake, not a shard part (nothing to merge)")?;
        let mut lightmap = match header_size {
            HEADER_SIZE => None,
            LIGHTMAP_PART_HEADER_SIZE => Some(PartLightmap::from_block(bytes, &header)?),
            header::PROBE_HEADER_SIZE => {
                return Err("a probe bake's part, not a vertex or texel bake's".into());
            }
            _ => return Err(format!("header size {header_size} in a shard part")),
        };
        let limit = lightmap
            .as_ref()
            .map_or(header.vertex_count, |l| l.receivers);
        if id.first_vertex + u64::from(id.vertices) > limit {
            let what = match lightmap {
                Some(_) => "baked texels",
                None => "vertices",
            };
            return Err(format!("{id}: beyond the scene's {limit} {what}"));
        }
        let tail = match &lightmap {
            Some(l) => l
                .tail_len()
                .filter(|&t| t <= payload_bytes)
                .ok_or(format!(
                    "{id}: the payload is {payload_bytes} bytes, too few for the lightmap's UVs and mask"
                ))?,
            None => 0,
        };
        let payload_bytes = payload_bytes - tail;
        let count = id.vertices as usize;
        let width = Part::coefficient_width(&header);
        let aux_floats = usize::from(header.aux.ao)
            + 3 * usize::from(header.aux.bent_normal)
            + GUIDE_WORDS * usize::from(header.denoised);
        let interreflected = header.mode == Mode::Interreflected;
        let fixed = (count * (width + aux_floats) * 4
            + if interreflected { 4 + count * 4 } else { 0 }) as u64;
        if payload_bytes < fixed {
            return Err(format!(
                "{id}: the payload is {payload_bytes} bytes, its arrays need at least {fixed}"
            ));
        }
        let payload = &bytes[header_size..bytes.len() - tail as usize];
        let rows_at = (count * (width + aux_floats) * 4) as u64;
        if let Reading::Packed { aux } = reading {
            if !interreflected {
                return Err(format!("{id}: a part without bounce rows"));
            }
            let (starts, grey) = row_starts(&payload[rows_at as usize..], &id)?;
            let at = header_size + rows_at as usize + 4 + 4 * count;
            // The guides stay in the bytes ([`Part::guide_words_at`]): a gather copies them.
            let (ao, bent_normal, _) = match aux {
                true => aux_arrays(&payload[count * width * 4..], &header, count, false)
                    .map_err(|m| format!("{id}: {m}"))?,
                false => (None, None, None),
            };
            let part = Part {
                header,
                id,
                coefficients: Vec::new(),
                ao,
                bent_normal,
                rows: None,
                lightmap,
                guides: None,
            };
            return Ok((part, Some((at, starts, grey))));
        }
        if let Some(l) = lightmap.as_mut() {
            l.read_tail(
                &bytes[bytes.len() - tail as usize..],
                reading != Reading::Mask,
            )
            .map_err(|message| format!("{id}: {message}"))?;
        }
        let mut words = payload.chunks_exact(4);
        let mut f32s = |n: usize| -> Vec<f32> {
            words
                .by_ref()
                .take(n)
                .map(|w| f32::from_le_bytes(w.try_into().expect("4 bytes")))
                .collect()
        };
        let coefficients = f32s(count * width);
        let (ao, bent_normal, guides) = match reading {
            Reading::WithoutRows { aux: false } => (None, None, None),
            _ => aux_arrays(&payload[count * width * 4..], &header, count, true)
                .map_err(|m| format!("{id}: {m}"))?,
        };
        let rows = if interreflected && matches!(reading, Reading::WithoutRows { .. }) {
            row_starts(&payload[rows_at as usize..], &id)?;
            None
        } else if interreflected {
            Some(parse_rows(&payload[rows_at as usize..], &id, &header)?)
        } else {
            if payload_bytes != fixed {
                return Err(format!(
                    "{id}: {} unexpected bytes after the arrays",
                    payload_bytes - fixed
                ));
            }
            None
        };
        let check = Header {
            channels: 1,
            ..header.clone()
        };
        let check = if interreflected { &check } else { &header };
        coefficient_file::check_floats(check, &coefficients, ao.as_deref(), bent_normal.as_deref())
            .map_err(|message| {
                format!("{id}: {message} (counting from the part's first vertex)")
            })?;
        let part = Part {
            header,
            id,
            coefficients,
            ao,
            bent_normal,
            rows,
            lightmap,
            guides,
        };
        Ok((part, None))
    }

    pub fn read(path: &Path) -> Result<Part> {
        Part::read_with(path, Reading::Whole)
    }

    /// [`Part::read`] without the bounce rows (their lengths checked): `merge --direct` and
    /// the merge's first reading need only the direct transfer and the lightmap. Without
    /// `aux`, the aux arrays and guides are left out too (`merge --direct` of a bake with
    /// bounces: the last gathers carry them on).
    pub fn read_without_rows(path: &Path, aux: bool) -> Result<Part> {
        Part::read_with(path, Reading::WithoutRows { aux })
    }

    /// [`Part::from_bytes`] of a part of no receivers (a bounce file's stub) whose
    /// lightmap's mask is read but not its UVs nor seam partners: a gather places and dilates
    /// the previous bounce with the mask alone.
    pub fn stub_mask_from_bytes(bytes: &[u8]) -> std::result::Result<Part, String> {
        Part::checked(Part::parse(bytes, Reading::Mask)?.0)
    }

    fn read_with(path: &Path, reading: Reading) -> Result<Part> {
        let bytes = crate::distribute::big_reads::map(path)?;
        Part::parse(&bytes, reading)
            .and_then(|(part, _)| Part::checked(part))
            .map_err(|message| Error::coefficient_file(path, message))
    }

    /// What a gather reads of a part: its header, identity and lightmap block (not its
    /// arrays, nor its transfer), and its bounce rows where they lie in the file's bytes,
    /// each entry checked as [`Part::read`] checks it.
    /// With `aux`, also its aux arrays (the last bounce's gather passes them on, and the guides
    /// from the file's bytes: [`Part::guide_words_at`]).
    pub fn read_packed_rows(path: &Path, aux: bool) -> Result<(Part, PackedRows)> {
        let bytes = crate::distribute::big_reads::map(path)?;
        Part::packed_rows_from_bytes(bytes, aux).map_err(|m| Error::coefficient_file(path, m))
    }

    /// [`Part::read_packed_rows`] of a file's bytes.
    pub fn packed_rows_from_bytes(
        bytes: impl std::ops::Deref<Target = [u8]> + Send + Sync + 'static,
        aux: bool,
    ) -> std::result::Result<(Part, PackedRows), String> {
        let (part, rows) = Part::parse(&bytes, Reading::Packed { aux })?;
        let part = Part::checked(part)?;
        let (at, starts, grey) = rows.expect("a packed reading returns the rows");
        let rows = PackedRows::new(bytes, at, starts, grey);
        if let Some((e, vertex, weight)) = rows.first_invalid(part.header.vertex_count) {
            return Err(format!(
                "{}: bounce-row entry {e} (vertex {vertex}, weight {weight:?}) is invalid",
                part.id
            ));
        }
        Ok((part, rows))
    }

    /// Reads a checkpoint block: a part whose lightmap (texel bakes) may be its block only.
    pub fn read_block(path: &Path) -> Result<Part> {
        let bytes = std::fs::read(path).map_err(|err| Error::io(path, err))?;
        Part::parse(&bytes, Reading::Whole)
            .map(|(part, _)| part)
            .map_err(|message| Error::coefficient_file(path, message))
    }

    /// Writes the part atomically, in pieces ([`Part::encode`]).
    pub fn write(&self, path: &Path) -> Result<()> {
        let output = crate::support::output::Output::new(path, &[])?;
        output.write_parts(&self.encode().parts())
    }

    /// [`Part::write`] with the bounce rows already encoded ([`Part::encode_with`]).
    pub fn write_with(&self, path: &Path, rows: Option<EncodedRows>) -> Result<()> {
        let output = crate::support::output::Output::new(path, &[])?;
        output.write_parts(&self.encode_with(rows).parts())
    }

    /// Drops a texel part's lightmap arrays, which a checkpoint block leaves out
    /// ([`crate::distribute::lightmap_parts::PartLightmap::without_arrays`]).
    pub fn into_block(mut self) -> Part {
        self.lightmap = self.lightmap.map(|l| l.without_arrays());
        self
    }

    /// Joins parts of one bake that hold consecutive ranges, in order, into one part with
    /// identity `id` (the caller has checked that they tile its range).
    pub fn join(parts: Vec<Part>, id: PartId) -> Part {
        let mut parts = parts.into_iter();
        let mut joined = parts.next().expect("at least one part");
        joined.id = id;
        for part in parts {
            joined.coefficients.extend(part.coefficients);
            if let (Some(ao), Some(more)) = (&mut joined.ao, part.ao) {
                ao.extend(more);
            }
            if let (Some(bent), Some(more)) = (&mut joined.bent_normal, part.bent_normal) {
                bent.extend(more);
            }
            if let (Some(rows), Some(more)) = (&mut joined.rows, part.rows) {
                rows.append(&more);
            }
            if let (Some(guides), Some(more)) = (&mut joined.guides, part.guides) {
                guides.append(more);
            }
        }
        joined
    }

    /// The whole bake from a part that holds every vertex: in interreflected mode the
    /// bounces are gathered here (no rays), exactly as a single-machine bake gathers them.
    pub fn finish(mut self, progress: &dyn Progress) -> CoefficientFile {
        let lookup = self.lightmap.as_ref().map(Lookup::new);
        let targets = lookup
            .as_ref()
            .map_or(BounceTargets::Vertices, Lookup::targets);
        let coefficients = match self.rows.take() {
            Some(rows) => interreflection::add_bounces(
                std::mem::take(&mut self.coefficients),
                self.header.channels as usize,
                &options_of(&self.header),
                &RowSource::Flat(&rows),
                &targets,
                progress,
            ),
            None => std::mem::take(&mut self.coefficients),
        };
        self.into_file(coefficients)
    }

    /// The whole file of a part that holds every vertex, with the final `coefficients`.
    /// Texel bakes: `coefficients` are the baked texels', placed in the lightmap and dilated
    /// here.
    pub(crate) fn into_file(self, coefficients: Vec<f32>) -> CoefficientFile {
        self.into_file_with(coefficients, true)
    }

    /// [`Part::into_file`]; a texel bake's lightmap stitched only with `stitch`. A denoised
    /// bake's transfer (and accessibility) is denoised here, every receiver in, with the
    /// guides its parts carried: before the lightmap is placed, as the whole bake does.
    pub(crate) fn into_file_with(
        mut self,
        mut coefficients: Vec<f32>,
        stitch: bool,
    ) -> CoefficientFile {
        assert_eq!(
            self.id.range(),
            0..self.receiver_count(),
            "a whole file needs every vertex"
        );
        if self.header.denoised {
            let guides = self
                .guides
                .take()
                .expect("a denoised part carries its guides");
            let settings = match self.lightmap {
                Some(_) => {
                    Settings::texels(self.header.samples_per_vertex, self.header.order as usize)
                }
                None => Settings::VERTICES,
            };
            let per_channel = self
                .header
                .transfer
                .floats_per_channel(self.header.order as usize);
            let channels = self.header.channels as usize;
            denoise::stage::denoise_guided(
                &guides,
                settings,
                &mut coefficients,
                channels,
                per_channel,
                self.ao.as_deref_mut(),
            );
        }
        if let Some(lightmap) = self.lightmap {
            let (ao, bent) = (self.ao, self.bent_normal);
            return lightmap.into_file(self.header, &coefficients, ao, bent, stitch);
        }
        CoefficientFile {
            header: Header {
                checksum: 0,
                ..self.header
            },
            coefficients,
            ao: self.ao,
            bent_normal: self.bent_normal,
            // Parts of adaptive bakes are refused before baking (prt-bake's `bake`).
            rays: None,
            error_estimate: None,
            lightmap: None,
            probes: None,
        }
    }
}

/// Where a part's bounce rows lie in its file: the byte their first entry starts at, and
/// where each row starts ([`Rows::starts`]), and whether the entries are grey.
type RowsAt = (usize, Vec<u64>, bool);

/// Which of a part's arrays a reading parses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reading {
    Whole,
    /// [`Reading::Whole`] but a lightmap's UVs and seam partners (its mask is read).
    Mask,
    /// Everything but the bounce rows' entries (their lengths are checked); without `aux`
    /// also without the aux arrays and guides.
    WithoutRows {
        aux: bool,
    },
    /// The header, identity and lightmap block, and where the rows lie ([`PackedRows`]);
    /// with `aux` also the aux arrays (the last bounce's gather carries them, and the
    /// denoiser's guides as they lie in the file, to the last merge).
    Packed {
        aux: bool,
    },
}

/// A part's aux arrays and guides, from `bytes` that start after its transfer.
type AuxArrays = (Option<Vec<f32>>, Option<Vec<Vec3>>, Option<Guides>);

/// The aux arrays (AO, bent normals) and, with `guides`, the denoiser's guides of `count`
/// receivers, from the bytes that follow their transfer (the lengths are checked by the
/// caller).
fn aux_arrays(
    bytes: &[u8],
    header: &Header,
    count: usize,
    guides: bool,
) -> Result<AuxArrays, String> {
    let mut words = bytes
        .chunks_exact(4)
        .map(|w| f32::from_le_bytes(w.try_into().expect("4 bytes")));
    let mut f32s = |n: usize| -> Vec<f32> { words.by_ref().take(n).collect() };
    let ao = header.aux.ao.then(|| f32s(count));
    let bent_normal = header.aux.bent_normal.then(|| {
        f32s(3 * count)
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect::<Vec<_>>()
    });
    let guides = match header.denoised && guides {
        true => {
            let at =
                count * (usize::from(header.aux.ao) + 3 * usize::from(header.aux.bent_normal)) * 4;
            Some(parse_guides(
                &bytes[at..at + count * GUIDE_WORDS * 4],
                count,
            )?)
        }
        false => None,
    };
    Ok((ao, bent_normal, guides))
}

/// The options a header records (what the merge needs to gather the bounces).
pub(crate) fn options_of(header: &Header) -> BakeOptions {
    BakeOptions {
        order: header.order as usize,
        samples: header.samples_per_vertex,
        mode: header.mode,
        seed: header.seed,
        sampling: header.sampling,
        bounces: header.bounces,
        bounce_samples: (header.mode == Mode::Interreflected).then_some(header.bounce_samples),
        aux: header.aux,
        transfer: header.transfer,
        ..BakeOptions::default()
    }
}

/// How two headers of parts differ (fields by name), or `None` if they belong to one bake.
pub fn header_difference(a: &Header, b: &Header) -> Option<String> {
    let fields = |h: &Header| match serde_json::to_value(Header {
        checksum: 0,
        ..h.clone()
    }) {
        Ok(serde_json::Value::Object(map)) => map,
        _ => unreachable!("a header serialises to an object"),
    };
    let (a, b) = (fields(a), fields(b));
    // The keys of both: a field left out when unset (`denoised`, `adaptive`) differs too.
    let only_b = b.keys().filter(|key| !a.contains_key(*key));
    let differences: Vec<String> = a
        .keys()
        .chain(only_b)
        .filter(|key| a.get(*key) != b.get(*key))
        .map(|key| {
            let value = a.get(key).map_or("none".into(), |v| v.to_string());
            let other = b.get(key).map_or("none".into(), |v| v.to_string());
            let name = match key.as_str() {
                "scene_fingerprint" => "scene fingerprint (another scene)",
                key => key,
            };
            format!("{name} {other} instead of {value}")
        })
        .collect();
    (!differences.is_empty()).then(|| differences.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| {
            vars.iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn shard_ranges_tile_the_vertices_in_equal_shares() {
        for (vertices, count) in [(0, 1), (7, 3), (10, 4), (13_500, 7), (5, 8)] {
            let mut next = 0;
            for index in 0..count {
                let range = shard_range(vertices, ShardId { index, count });
                assert_eq!(range.start, next);
                assert!(range.len().abs_diff(vertices / count as usize) <= 1);
                next = range.end;
            }
            assert_eq!(next, vertices);
        }
    }

    #[test]
    fn shard_specs_parse_from_the_command_line_slurm_and_kubernetes() {
        let none = env(&[]);
        assert_eq!(
            ShardId::parse("2/5", &none).unwrap(),
            ShardId { index: 2, count: 5 }
        );
        for bad in ["5/5", "1/0", "x/3", "3", "auto"] {
            assert!(ShardId::parse(bad, &none).is_err(), "{bad}");
        }
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "13"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(
            ShardId::parse("auto", &slurm).unwrap(),
            ShardId { index: 3, count: 4 }
        );
        assert!(ShardId::parse("auto/5", &slurm).is_err());
        let kubernetes = env(&[("JOB_COMPLETION_INDEX", "6")]);
        assert_eq!(
            ShardId::parse("auto/8", &kubernetes).unwrap(),
            ShardId { index: 6, count: 8 }
        );
        assert!(ShardId::parse("auto", &kubernetes).is_err());
        let counted = env(&[("JOB_COMPLETION_INDEX", "6"), (SHARD_COUNT_VARIABLE, "7")]);
        assert_eq!(
            ShardId::parse("auto", &counted).unwrap(),
            ShardId { index: 6, count: 7 }
        );
    }
}

//! Baking a part: the direct pass over a range of a bake's receivers (the scene's vertices,
//! or a lightmap's baked texels), with its bounce rows in interreflected mode. A shard part
//! and a checkpoint block are both baked here, by one [`PartBaker`] built once per run.

use std::ops::Range;

use crate::bake::bounce_rows::{HitCache, HitRecorder};
use crate::bake::denoise::{self, Guides};
use crate::bake::interreflection::{self, Rows};
use crate::bake::lightmap::Prepared;
use crate::bake::transfer::{
    BakeOptions, BounceTargets, Estimator, Mode, Receivers, direct_pass, tracer_for,
};
use crate::distribute::lightmap_parts::PartLightmap;
use crate::distribute::row_encoding::{EncodedRows, encode_jobs};
use crate::distribute::shard::{Part, PartId, ShardId};
use crate::formats::header::Header;
use crate::scene::Scene;
use crate::support::error::{Error, Result};
use crate::support::progress::Progress;
use crate::trace::{Backend, Tracer};

/// The header a bake of `scene` with `options` writes (the same code as a whole bake's).
pub fn bake_header(scene: &Scene, backend: Backend, options: &BakeOptions) -> Header {
    let channels = match options.mode {
        Mode::Interreflected if !interreflection::albedo_is_grey(scene) => 3,
        _ => 1,
    };
    Header::for_bake(scene, options, backend, channels, scene.vertex_count(), 0)
}

/// What every part of one run shares: the estimator over all the bake's receivers, the way
/// bounce hits map back to them, and the header the parts carry.
pub struct PartBaker<'a> {
    scene: &'a Scene,
    tracer: Option<&'a dyn Tracer>,
    estimator: Estimator,
    targets: BounceTargets<'a>,
    header: Header,
    /// Texel bakes: the lightmap's block ([`PartLightmap::block_of`]) and the preparation its
    /// arrays are copied from, into shard 0's part only.
    lightmap: Option<(PartLightmap, &'a Prepared)>,
    /// Denoised bakes: the guides of the receivers from `guides_from` on (every receiver,
    /// or a shard's), whose range each part carries with its receivers' noise.
    guides: Option<Guides>,
    guides_from: usize,
}

impl<'a> PartBaker<'a> {
    /// Parts of a vertex bake.
    pub fn vertices(
        scene: &'a Scene,
        tracer: Option<&'a dyn Tracer>,
        options: &BakeOptions,
    ) -> Result<PartBaker<'a>> {
        let tracer = tracer_for(options, tracer)?;
        if options.transfer == crate::bake::options::TransferKind::Matrix {
            return Err(Error::InvalidOption(
                "--transfer matrix with --shard or --checkpoint is not supported yet".into(),
            ));
        }
        let backend = tracer.map_or(Backend::None, |t| t.backend());
        Ok(PartBaker {
            scene,
            tracer,
            estimator: Estimator::new(scene, options)?,
            targets: BounceTargets::Vertices,
            header: bake_header(scene, backend, options),
            lightmap: None,
            guides: (options.denoise && tracer.is_some())
                .then(|| denoise::vertex_guides(scene, Vec::new())),
            guides_from: 0,
        })
    }

    /// Parts of a texel bake over `prepared` (its atlas and settled texels). `tracer` must be
    /// watertight for the texels' ray origins, as a whole texel bake's is
    /// ([`crate::bake::lightmap::Texels::watertight`]).
    pub fn texels(
        scene: &'a Scene,
        tracer: Option<&'a dyn Tracer>,
        options: &BakeOptions,
        prepared: &'a Prepared,
    ) -> Result<PartBaker<'a>> {
        let all = 0..prepared.texels.valid_count();
        PartBaker::texels_in(scene, tracer, options, prepared, all)
    }

    /// [`PartBaker::texels`] that bakes only the baked texels `receivers` (a shard's): a
    /// denoised bake's guides are computed for them alone, not the whole lightmap.
    pub fn texels_in(
        scene: &'a Scene,
        tracer: Option<&'a dyn Tracer>,
        options: &BakeOptions,
        prepared: &'a Prepared,
        receivers: Range<usize>,
    ) -> Result<PartBaker<'a>> {
        let tracer = tracer_for(options, tracer)?;
        let backend = tracer.map_or(Backend::None, |t| t.backend());
        let texels = &prepared.texels;
        let estimator = Estimator::for_receivers(Receivers::texels(texels), options)?;
        let mut header = bake_header(scene, backend, options);
        header.vertex_count = texels.valid.len() as u64;
        Ok(PartBaker {
            scene,
            tracer,
            estimator,
            targets: BounceTargets::texels(&prepared.atlas, texels),
            header,
            lightmap: Some((PartLightmap::block_of(scene, prepared), prepared)),
            guides: (options.denoise && tracer.is_some()).then(|| {
                denoise::guides::texel_guides_of(scene, &prepared.atlas, texels, receivers.clone())
            }),
            guides_from: receivers.start,
        })
    }

    /// The receivers the parts split: the scene's vertices, or the baked texels.
    pub fn receivers(&self) -> usize {
        self.estimator.receiver_count()
    }

    /// The header every part of this bake carries.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Texel bakes: the lightmap's block (size, counts, fingerprint), without its arrays.
    pub fn lightmap(&self) -> Option<&PartLightmap> {
        self.lightmap.as_ref().map(|(block, _)| block)
    }

    /// Texel bakes: the lightmap with its arrays, as shard 0's part carries it.
    pub fn lightmap_with_arrays(&self) -> Option<PartLightmap> {
        let (block, prepared) = self.lightmap.as_ref()?;
        Some(block.clone().with_arrays(prepared))
    }

    /// Bakes `receivers` into a part of `shard`. In interreflected mode the part carries its
    /// bounce rows, so they must fit in `options.hit_cache_limit`; otherwise the bake stops
    /// with an error (a part cannot fall back to re-tracing: the merge casts no rays). Also
    /// returns the rays cast.
    pub fn bake(
        &self,
        shard: ShardId,
        receivers: Range<usize>,
        progress: &dyn Progress,
    ) -> Result<(Part, u64)> {
        let (mut part, jobs, rays) = self.bake_direct(shard, receivers.clone(), None, progress)?;
        if let Some(jobs) = jobs {
            let rows = Rows::from_jobs(jobs);
            self.check_rows(rows.bytes(), &receivers)?;
            part.rows = Some(rows);
        }
        Ok((part, rays))
    }

    /// [`PartBaker::bake`] with the bounce rows encoded as the part's file stores them (the
    /// part's own `rows` left empty: [`Part::encode_with`]), never held as [`Rows`]. Where
    /// `receivers` are all the baker's guides cover (a shard's), the part takes those guides
    /// rather than a copy: a later part of this baker would have none.
    pub fn bake_encoded(
        &mut self,
        shard: ShardId,
        receivers: Range<usize>,
        progress: &dyn Progress,
    ) -> Result<(Part, Option<EncodedRows>, u64)> {
        let covers =
            |g: &Guides| self.guides_from == receivers.start && g.points.len() == receivers.len();
        let own = match self.guides.as_ref().is_some_and(covers) {
            true => self.guides.take(),
            false => None,
        };
        let (part, jobs, rays) = self.bake_direct(shard, receivers.clone(), own, progress)?;
        let rows = jobs.map(encode_jobs);
        if let Some(rows) = &rows {
            self.check_rows(rows.rows_bytes(), &receivers)?;
        }
        Ok((part, rows, rays))
    }

    /// The direct pass: the part without rows, its jobs' rows (interreflected mode) and the
    /// rays cast. The part's guides are `own` where given (exactly its receivers'), else
    /// copied from the baker's.
    #[allow(clippy::type_complexity)]
    fn bake_direct(
        &self,
        shard: ShardId,
        receivers: Range<usize>,
        own: Option<Guides>,
        progress: &dyn Progress,
    ) -> Result<(Part, Option<HitCache<'_>>, u64)> {
        let options = &self.estimator.options;
        let recorder = (options.mode == Mode::Interreflected).then(|| {
            HitRecorder::new(
                self.scene,
                &self.targets,
                receivers.len(),
                options.hit_cache_limit,
            )
        });
        let direct = direct_pass(
            &self.estimator,
            self.tracer,
            recorder.as_ref(),
            receivers.clone(),
            progress,
        );
        let jobs = match recorder {
            Some(recorder) => match recorder.into_cache() {
                Some((jobs, _)) => Some(jobs),
                None => return Err(self.rows_too_large(&receivers)),
            },
            None => None,
        };
        let rays = self
            .tracer
            .map_or(0, |_| u64::from(options.samples) * receivers.len() as u64);
        let aux = self.header.aux;
        let part = Part {
            id: PartId {
                shard,
                first_vertex: receivers.start as u64,
                vertices: receivers.len() as u32,
            },
            coefficients: direct.coefficients,
            ao: aux
                .ao
                .then(|| direct.visibility.iter().map(|v| v.accessibility).collect()),
            bent_normal: aux
                .bent_normal
                .then(|| direct.visibility.iter().map(|v| v.bent_normal).collect()),
            rows: None,
            header: self.header.clone(),
            // Shard 0's part carries the lightmap's arrays for every part of the bake.
            lightmap: self
                .lightmap
                .as_ref()
                .map(|(block, prepared)| match shard.index {
                    0 => block.clone().with_arrays(prepared),
                    _ => block.in_shard_zero(),
                }),
            guides: own
                .or_else(|| {
                    let from = self.guides_from;
                    let g = self.guides.as_ref()?;
                    Some(g.range(receivers.start - from..receivers.end - from))
                })
                .map(|g| Guides {
                    noise: direct.visibility.iter().map(|v| v.noise).collect(),
                    ..g
                }),
        };
        Ok((part, jobs, rays))
    }

    /// The recorder keeps compact hits; the part carries them folded into rows, which can be
    /// several times larger, so the limit applies to the rows (`bytes` in memory) too.
    fn check_rows(&self, bytes: u64, receivers: &Range<usize>) -> Result<()> {
        match bytes <= self.estimator.options.hit_cache_limit {
            true => Ok(()),
            false => Err(self.rows_too_large(receivers)),
        }
    }

    fn rows_too_large(&self, receivers: &Range<usize>) -> Error {
        let what = match self.lightmap {
            Some(_) => "baked texels",
            None => "vertices",
        };
        Error::InvalidOption(format!(
            "the bounce rows of {what} {}..{} exceed --hit-cache-mb {}; a part carries its rows \
             (the merge casts no rays): use more shards or a larger --hit-cache-mb",
            receivers.start,
            receivers.end,
            self.estimator.options.hit_cache_limit >> 20
        ))
    }
}

/// Bakes the vertices `vertices` into a part of `shard` ([`PartBaker::bake`] of a vertex
/// bake). Also returns the rays cast.
pub fn bake_part(
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    options: &BakeOptions,
    shard: ShardId,
    vertices: Range<usize>,
    progress: &dyn Progress,
) -> Result<(Part, u64)> {
    PartBaker::vertices(scene, tracer, options)?.bake(shard, vertices, progress)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::coefficient_file::CoefficientFile;
    use std::path::Path;

    /// An interreflected part of the Cornell room's vertices 100..140 (shard 1 of 3 in name).
    fn cornell_part() -> Part {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/cornell/cornell.scene"
        );
        let scene = Scene::load(Path::new(path)).unwrap();
        let tracer = crate::trace::build(Backend::DEFAULT, &scene, Default::default()).unwrap();
        let options = BakeOptions {
            samples: 32,
            mode: Mode::Interreflected,
            bounces: 1,
            aux: crate::bake::transfer::Aux {
                ao: true,
                bent_normal: true,
            },
            ..BakeOptions::default()
        };
        let shard = ShardId { index: 1, count: 3 };
        let silent = crate::support::progress::Silent;
        bake_part(&scene, Some(&*tracer), &options, shard, 100..140, &silent)
            .unwrap()
            .0
    }

    #[test]
    fn parts_round_trip_and_bad_rows_or_sizes_are_refused() {
        let part = cornell_part();
        let rows = part.rows.as_ref().unwrap();
        assert_eq!(rows.vertex_count(), 40);
        assert!(!rows.vertices.is_empty());
        let bytes = part.to_bytes();
        let mut read = Part::from_bytes(&bytes).unwrap();
        assert_ne!(read.header.checksum, 0);
        read.header.checksum = 0; // the bake's header has none until written
        assert!(
            read == part,
            "a part read back differs from the one written"
        );
        // A whole-file reader refuses it, naming what it is.
        let err = CoefficientFile::from_bytes(&bytes).unwrap_err();
        assert!(
            err.contains("a shard part (shard 1 of 3, vertices 100..140)"),
            "{err}"
        );

        // A gather's reading: the same rows, read where they lie in the file.
        let (header_only, packed) = Part::packed_rows_from_bytes(bytes.clone(), false).unwrap();
        assert_eq!((header_only.id, packed.receiver_count()), (part.id, 40));
        for k in 0..40 {
            let range = rows.vertex(k);
            let expected = rows.vertices[range.clone()].iter().copied();
            let expected: Vec<_> = expected.zip(rows.weights[range].iter().copied()).collect();
            assert_eq!(packed.row(k).collect::<Vec<_>>(), expected, "row {k}");
        }

        // A row entry naming a vertex beyond the scene (checksum recomputed).
        let mut bad = part.clone();
        bad.rows.as_mut().unwrap().vertices[0] = part.header.vertex_count as u32;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("bounce-row entry 0"), "{err}");
        let err = Part::packed_rows_from_bytes(bad.to_bytes(), false)
            .err()
            .unwrap();
        assert!(err.contains("bounce-row entry 0"), "{err}");
        // A weight that is not finite, which the gather would spread.
        let mut bad = part.clone();
        let last = bad.rows.as_ref().unwrap().vertices.len() - 1;
        bad.rows.as_mut().unwrap().weights[last][2] = f32::NAN;
        let err = Part::packed_rows_from_bytes(bad.to_bytes(), false)
            .err()
            .unwrap();
        assert!(err.contains(&format!("bounce-row entry {last}")), "{err}");
        // Row lengths that do not add up to the entries.
        let mut bad = part.clone();
        bad.rows.as_mut().unwrap().starts[40] -= 1;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("the bounce rows announce"), "{err}");
        // A range beyond the scene.
        let mut bad = part.clone();
        bad.id.first_vertex = part.header.vertex_count - 10;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("beyond the scene"), "{err}");
        // A non-finite coefficient.
        let mut bad = part;
        bad.coefficients[17] = f32::NAN;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(
            err.contains("coefficient 1 of vertex 1 is not finite"),
            "{err}"
        );
    }

    #[test]
    fn denoised_parts_carry_their_guides_and_bad_guides_are_refused() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/cornell/cornell.scene"
        );
        let scene = Scene::load(Path::new(path)).unwrap();
        let tracer = crate::trace::build(Backend::DEFAULT, &scene, Default::default()).unwrap();
        let mut options = BakeOptions {
            samples: 32,
            ..BakeOptions::default()
        };
        let shard = ShardId { index: 1, count: 3 };
        let silent = crate::support::progress::Silent;
        let raw = bake_part(&scene, Some(&*tracer), &options, shard, 100..140, &silent);
        options.denoise = true;
        let part = bake_part(&scene, Some(&*tracer), &options, shard, 100..140, &silent);
        let (raw, part) = (raw.unwrap().0, part.unwrap().0);
        // A raw part is as before: no guides. A denoised one: 48 bytes a vertex more, the
        // whole scene's guides of its vertices, and each vertex's noise.
        assert!(raw.guides.is_none());
        assert_eq!(part.to_bytes().len(), raw.to_bytes().len() + 48 * 40);
        let guides = part.guides.as_ref().unwrap();
        let all = crate::bake::denoise::vertex_guides(&scene, Vec::new());
        assert_eq!(guides.points, all.points[100..140]);
        assert_eq!(guides.spacing, all.spacing[100..140]);
        assert!(guides.noise.iter().all(|&v| v >= 0.0) && guides.noise.iter().any(|&v| v > 0.0));
        let mut read = Part::from_bytes(&part.to_bytes()).unwrap();
        read.header.checksum = 0;
        assert!(read == part, "a denoised part read back differs");
        // A guide no denoiser can use (a spacing of 0), checksum recomputed: refused.
        let mut bad = part;
        bad.guides.as_mut().unwrap().spacing[3] = 0.0;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(
            err.contains("the denoiser's guides of receiver 3: its spacing is not positive"),
            "{err}"
        );
    }

    #[test]
    fn grey_rows_take_half_the_bytes_and_old_parts_are_refused() {
        let part = cornell_part();
        let entries = part.rows.as_ref().unwrap().vertices.len();
        let rgb = part.to_bytes();
        // The Cornell room's walls are coloured: RGB entries, every weight kept.
        let mut grey = part.clone();
        for w in &mut grey.rows.as_mut().unwrap().weights {
            *w = [w[1]; 3];
        }
        let bytes = grey.to_bytes();
        assert_eq!(rgb.len() - bytes.len(), 8 * entries);
        let mut read = Part::from_bytes(&bytes).unwrap();
        read.header.checksum = 0;
        assert!(read == grey, "a grey part read back differs");
        let (_, packed) = Part::packed_rows_from_bytes(bytes.clone(), false).unwrap();
        let rows = grey.rows.as_ref().unwrap();
        for k in 0..40 {
            let range = rows.vertex(k);
            let expected = rows.vertices[range.clone()].iter().copied();
            let expected: Vec<_> = expected.zip(rows.weights[range].iter().copied()).collect();
            assert_eq!(packed.row(k).collect::<Vec<_>>(), expected, "row {k}");
        }
        // One weight that is not grey: the part keeps all three.
        let mut almost = grey.clone();
        almost.rows.as_mut().unwrap().weights[entries - 1][2] += 1.0;
        assert_eq!(almost.to_bytes().len(), rgb.len());

        // A part as an older prt-bake wrote it: no encoding word before the row lengths.
        let mut old = Vec::from(&rgb[..]);
        let payload = u64::from_le_bytes(old[72..80].try_into().unwrap()) - 4;
        old[72..80].copy_from_slice(&payload.to_le_bytes());
        let at = 128 + 4 * part.coefficients.len() + 4 * part.ao.as_ref().unwrap().len() + 12 * 40;
        old.drain(at..at + 4);
        let checksum = crate::formats::header::checksum(&old);
        old[124..128].copy_from_slice(&checksum.to_le_bytes());
        for err in [
            Part::from_bytes(&old).unwrap_err(),
            Part::packed_rows_from_bytes(old.clone(), false)
                .err()
                .unwrap(),
        ] {
            assert!(err.contains("a part of an older prt-bake"), "{err}");
        }
    }

    #[test]
    fn texel_parts_round_trip_and_bad_masks_or_blocks_are_refused() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/cornell/cornell.scene"
        );
        let scene = Scene::load(Path::new(path)).unwrap();
        let tracer = crate::trace::build(Backend::DEFAULT, &scene, Default::default()).unwrap();
        let options = BakeOptions {
            samples: 16,
            mode: Mode::Interreflected,
            bounces: 1,
            aux: crate::bake::transfer::Aux {
                ao: true,
                bent_normal: false,
            },
            ..BakeOptions::default()
        };
        let atlas = crate::bake::lightmap::Atlas::generate(&scene, 24, None).unwrap();
        let prepared =
            crate::bake::lightmap::prepare(&scene, Some(&*tracer), options.seed, atlas).unwrap();
        let mut baker = PartBaker::texels(&scene, Some(&*tracer), &options, &prepared).unwrap();
        let baked = baker.receivers();
        assert_eq!(baked, prepared.texels.valid_count());
        let shard = ShardId { index: 1, count: 2 };
        let silent = crate::support::progress::Silent;
        let (part, _) = baker.bake(shard, 10..30, &silent).unwrap();
        let bytes = part.to_bytes();
        // A shard's way: the rows encoded from the direct pass, the same bytes.
        let (bare, rows, _) = baker.bake_encoded(shard, 10..30, &silent).unwrap();
        assert!(bare.rows.is_none());
        assert!(bare.encode_with(rows).into_vec() == bytes);
        assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 192);
        let mut read = Part::from_bytes(&bytes).unwrap();
        read.header.checksum = 0;
        assert!(read == part, "a texel part read back differs");
        assert_eq!(read.receiver_count(), baked);
        // Shard 0's part carries the lightmap's arrays; the others leave them to it.
        let zero = ShardId { index: 0, count: 2 };
        let (first, _) = baker.bake(zero, 0..10, &silent).unwrap();
        assert!(first.lightmap.as_ref().unwrap().carried);
        assert!(part.lightmap.as_ref().unwrap().in_shard_zero);
        assert_eq!(part.lightmap.as_ref().unwrap().uv1.len(), 0);

        // A denoised shard computes the guides of its own texels only, equal to the whole
        // lightmap's (group ids first met before its range included).
        let denoised = BakeOptions {
            denoise: true,
            ..options.clone()
        };
        let all = crate::bake::denoise::texel_guides(
            &scene,
            &prepared.atlas,
            &prepared.texels,
            Vec::new(),
        );
        for range in [0..baked, 10..30, baked - 7..baked] {
            let own =
                PartBaker::texels_in(&scene, Some(&*tracer), &denoised, &prepared, range.clone())
                    .unwrap();
            let (p, _) = own.bake(shard, range.clone(), &silent).unwrap();
            let mut guides = p.guides.unwrap();
            assert!(guides.noise.iter().all(|&v| v >= 0.0));
            guides.noise = Vec::new();
            assert_eq!(guides, all.range(range.clone()), "guides of {range:?}");
        }
        // Readers of whole files refuse it.
        let err = CoefficientFile::from_bytes(&bytes).unwrap_err();
        assert!(err.contains("a shard part (shard 1 of 2"), "{err}");

        // A mask that does not hold the announced baked texels (shard 0's part, which carries
        // the arrays).
        let mut bad = first.clone();
        let l = bad.lightmap.as_mut().unwrap();
        let first_empty = l.valid.iter().position(|v| !v).unwrap();
        l.valid[first_empty] = true;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("the mask holds"), "{err}");
        // Baked texels beyond the lightmap, and a range beyond the baked texels.
        let mut bad = first.clone();
        bad.lightmap.as_mut().unwrap().receivers = 24 * 24 + 1;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("baked texels in a lightmap of 576"), "{err}");
        let mut bad = first.clone();
        bad.id.first_vertex = baked as u64 - 5;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("beyond the scene's"), "{err}");
        // A truncated tail: the file's payload no longer matches.
        let mut short = first.to_bytes();
        short.truncate(short.len() - 1);
        assert!(Part::from_bytes(&short).is_err());
        // A row entry naming a texel beyond the lightmap.
        let mut bad = first;
        let rows = bad.rows.as_mut().unwrap();
        assert!(!rows.vertices.is_empty(), "no bounce hits recorded");
        rows.vertices[0] = 24 * 24;
        let err = Part::from_bytes(&bad.to_bytes()).unwrap_err();
        assert!(err.contains("bounce-row entry 0"), "{err}");
    }
}

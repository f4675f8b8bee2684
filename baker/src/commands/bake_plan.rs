//! What one `prt-bake bake` (or `prepare-lightmap`) is to do: which receivers, the library's
//! options, the tracer, the outputs and the compression. `commands::bake` lowers the command
//! line into a [`BakePlan`] in one place; `commands::bake_run` runs it, stage by stage.

use std::path::PathBuf;

use prt_baker::bake::lightmap::atlas::AtlasMethod;
use prt_baker::distribute::prepared_file;
use prt_baker::distribute::shard::ShardId;
use prt_baker::export::compress::FitOptions;
use prt_baker::scene::Up;
use prt_baker::trace::{Backend, TracerOptions};
use prt_baker::{BakeOptions, Error, Scene};

use super::scene_load::{DoubleSidedArg, InstancesArg};

/// A bake, lowered from its command line and checked (options, memory of the sample tables,
/// compression, lightmap resolution, shard, backend) before anything is read.
pub struct BakePlan {
    /// The scene file and what its loading is told.
    pub scene: PathBuf,
    pub load: LoadPlan,
    /// `--materials`: subsurface media per material.
    pub materials: Option<PathBuf>,
    /// `-o`: the coefficient file, part file or prepared lightmap.
    pub output: PathBuf,
    pub what: What,
    /// Whether the scene's receivers are chosen here (`--receivers`, glTF marks): neither
    /// split into parts nor a lightmap's preparation (whole bakes, and unsplit probes).
    pub whole_scene: bool,
    pub split: Split,
    pub lightmap: LightmapPlan,
    pub options: BakeOptions,
    /// `--transfer ldprt`: lobes per vertex fitted to the vector bake (`commands::bake_ldprt`).
    pub ldprt: Option<usize>,
    pub backend: Backend,
    pub tracer: TracerOptions,
    /// `--threads`: the process's thread pool.
    pub threads: Option<usize>,
    /// `--clusters`/`--pcs`: the clustered PCA the whole bake's file is written through.
    pub fit: Option<FitOptions>,
    pub report: Report,
}

/// What is baked, in the order the command line decides it: probes, then a lightmap's
/// preparation, then a bake in parts, else a whole bake.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum What {
    /// Per vertex, or with `--lightmap` per texel; all receivers or `--receivers`' objects.
    Whole,
    /// `prepare-lightmap`: the atlas, the baked texels and the seam partners, for the shards.
    Prepare,
    /// `--shard` or `--checkpoint`: a part file, or the whole file from checkpoint blocks.
    Parts,
    /// `--probes`: transfer matrices at points.
    Probes(String),
}

/// How the scene is read.
pub struct LoadPlan {
    /// `--up`: overrides the format's axis.
    pub up: Option<Up>,
    /// `--receivers`' globs.
    pub receivers: Vec<String>,
    pub instances: InstancesArg,
    pub double_sided: DoubleSidedArg,
    /// `--pose`: a glTF file's skins and animations.
    pub pose: prt_baker::scene::Pose,
}

/// `--shard` and `--checkpoint`: the bake's share of the receivers, and where its blocks go.
pub struct Split {
    pub shard: Option<ShardId>,
    pub checkpoint: Option<PathBuf>,
    pub checkpoint_vertices: Option<usize>,
}

impl Split {
    /// Whether this process bakes part of the receivers, or in checkpoint blocks.
    pub fn any(&self) -> bool {
        self.shard.is_some() || self.checkpoint.is_some()
    }
}

/// `--lightmap` and the options that shape its atlas (none without it: clap requires it).
pub struct LightmapPlan {
    /// The atlas's resolution; None bakes per vertex.
    pub resolution: Option<u32>,
    pub texel_size: Option<f32>,
    /// `--atlas`: unwrap here with this method, even where the scene has lightmap UVs.
    pub atlas: Option<AtlasMethod>,
    pub strict_uvs: bool,
    /// `--prepared`: the preparation read instead of computed.
    pub prepared: Option<PathBuf>,
}

/// What is printed besides the summary line.
pub struct Report {
    pub quiet: bool,
    pub verbose: bool,
    /// `--hit-cache-mb`, as given (the summary names it when the bounces re-trace).
    pub hit_cache_mb: u64,
}

impl BakePlan {
    /// The files the output must not overwrite, before the scene names its own.
    pub fn inputs(&self) -> Vec<PathBuf> {
        let mut inputs = vec![self.scene.clone()];
        inputs.extend(self.materials.clone());
        inputs.extend(self.lightmap.prepared.clone());
        inputs
    }

    /// What a prepared lightmap depends on, hashed ([`prepared_file::key`]): the scene, the
    /// lightmap options, the seed, the backend, and whether rays are cast (the leak test).
    pub fn prepared_key(&self, scene: &Scene) -> u64 {
        let lightmap = &self.lightmap;
        let lightmap = format!(
            "{:?} {:?} {:?} {} {} {:?}",
            lightmap.resolution,
            lightmap.texel_size.map(f32::to_bits),
            lightmap.atlas,
            lightmap.strict_uvs,
            self.tracer.robust,
            scene.up,
        );
        let options = &self.options;
        let (backend, rays) = (self.backend.name(), options.mode.casts_rays());
        prepared_file::key(scene.fingerprint(), &lightmap, options.seed, backend, rays)
    }
}

/// Refuses `--denoise on` for probes: a filter over a probe grid's neighbours biases them
/// more than it removes noise (docs/explanation/denoising.md#probes-are-not-denoised).
/// Bakes in shards or checkpoints are denoised where every receiver is in (the merge, or the
/// checkpointed bake's join), with the guides their parts carry; `prepare-lightmap` takes the
/// bake's options, and its preparation serves denoised and raw shards alike.
pub fn check_denoise(options: &BakeOptions, what: &What) -> Result<(), Error> {
    match options.denoise && matches!(what, What::Probes(_)) {
        true => Err(Error::InvalidOption(
            "--denoise on is for vertex and texel bakes (whole, in shards or checkpointed): \
             probes are not denoised (a filter over their neighbours costs more bias than it \
             removes noise); raise --samples instead"
                .into(),
        )),
        false => Ok(()),
    }
}

/// The tracer's settings for `--threads` and `--robust`, a texel bake (`texels`) or not, and
/// the rays each receiver casts.
pub fn tracer_options(
    threads: Option<usize>,
    robust: bool,
    texels: bool,
    options: &BakeOptions,
) -> TracerOptions {
    TracerOptions {
        threads,
        robust,
        // A texel bake casts no ray from a vertex: its texels' seam points are found apart.
        points_only: texels,
        // Picks Embree's BVH quality; from the command line alone, so every process of a
        // staged or sharded bake picks the same.
        rays_per_receiver: options
            .samples
            .saturating_add(options.effective_bounce_samples()),
    }
}

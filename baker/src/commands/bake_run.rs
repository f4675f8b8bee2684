//! `prt-bake bake`, run: a [`BakePlan`]'s stages in order. Every bake starts the same way
//! ([`start`], [`load`], [`receivers`], [`check_memory`], [`tracer`]); [`probes`] and bakes
//! in parts ([`bake_in_parts`]) then go to `commands::bake_probes` and `commands::bake_parts`,
//! and a whole bake ([`bake_whole`]) bakes its receiving objects ([`bake_objects`]), its
//! vertices ([`bake_vertices`], with [`add_subsurface`]) or its texels ([`bake_texels`], whose
//! atlas is [`atlas`]), then [`write`]s its file, compressed or not, and prints its
//! [`summary`]. The estimator, the bounces, the denoiser and the lightmap's seam stitch run
//! inside the library's bake.

use prt_baker::bake::denoise;
use prt_baker::bake::lightmap;
use prt_baker::bake::memory;
use prt_baker::bake::receiver_names::receiver_objects;
use prt_baker::bake::receiver_subset::bake_objects_translucent;
use prt_baker::bake::subsurface;
use prt_baker::export::compress;
use prt_baker::math::medium::Medium;
use prt_baker::support::limits;
use prt_baker::support::output::Output;
use prt_baker::support::progress::Progress;
use prt_baker::trace::{self, Tracer};
use prt_baker::{BakeOptions, CoefficientFile, Error, Mode, Scene, Transfer};

use super::bake_plan::{BakePlan, LightmapPlan, What};
use super::{bake_media, bake_parts, bake_probes, scene_load};

/// A whole bake's result: its transfer, its file, and what the summary says was baked.
type Baked = (Transfer, CoefficientFile, String);

/// What the scene's receivers are: `--receivers`' objects (None: all), and each material's
/// subsurface medium.
struct Receivers {
    objects: Option<Vec<u32>>,
    media: Vec<Option<Medium>>,
}

/// Runs `plan`: the shared stages, then probes, parts, or a whole bake and its file.
pub fn run(plan: &BakePlan) -> Result<(), Error> {
    super::bake_ldprt::check(plan)?;
    start(plan)?;
    let of_probes = matches!(plan.what, What::Probes(_));
    if let Some(note) = plan.options.samples_note().filter(|_| !of_probes) {
        eprintln!("prt-bake: {note}");
    }
    // What every process of a bake pays before its own work (`--verbose`).
    let mut setup = lightmap::Stages::default();
    let (scene, output) = load(plan, &mut setup)?;
    let receivers = receivers(plan, &scene)?;
    check_memory(plan, &scene)?;
    let tracer = tracer(plan, &scene, &mut setup)?;
    if plan.report.verbose {
        eprintln!("prt-bake: stages: {}", setup.line());
    }
    let progress = super::progress(plan.report.quiet);
    let (tracer, progress) = (tracer.as_deref(), progress.as_ref());
    match &plan.what {
        What::Probes(spec) => probes(plan, spec, &scene, tracer, progress),
        What::Prepare | What::Parts => bake_in_parts(plan, &scene, tracer, progress),
        What::Whole => {
            let baked = bake_whole(plan, &scene, &receivers, tracer, progress)?;
            match plan.ldprt {
                Some(lobes) => super::bake_ldprt::write(plan, &scene, &output, &baked.0, lobes),
                None => write(plan, &output, baked),
            }
        }
    }
}

/// Checks the output's path against the inputs the command line names, and starts the
/// thread pool, before the scene is read.
fn start(plan: &BakePlan) -> Result<(), Error> {
    Output::new(&plan.output, &plan.inputs())?;
    match plan.threads {
        Some(threads) => start_threads(threads),
        None => Ok(()),
    }
}

/// `--threads`: the process's one pool. (A pool of our own entered with `install` measured
/// 14 % slower on the demo bake, for no benefit in a single-bake process.)
fn start_threads(threads: usize) -> Result<(), Error> {
    if threads == 0 {
        return Err(Error::InvalidOption("--threads must be at least 1".into()));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .map_err(|err| Error::InvalidOption(format!("cannot start {threads} threads: {err}")))
}

/// The scene, turned to `--up`, and the output checked against every file it reads.
fn load(plan: &BakePlan, setup: &mut lightmap::Stages) -> Result<(Scene, Output), Error> {
    // Whole bakes, per vertex or texel: the non-receivers only occlude.
    let instancing = plan.what == What::Whole && plan.materials.is_none();
    let instancing = instancing && plan.options.mode != Mode::Interreflected;
    let load = &plan.load;
    let mut scene = setup.time("scene", || {
        let (instances, sides) = (load.instances, load.double_sided);
        let how = (instances, sides, &load.pose);
        scene_load::load(&plan.scene, how, &load.receivers, instancing)
    })?;
    // --up overrides the format's axis; whole files, parts and checkpoints all record it.
    if let Some(up) = load.up {
        scene.up = up;
    }
    let mut inputs = scene.input_files();
    inputs.extend(plan.materials.clone());
    inputs.extend(plan.lightmap.prepared.clone());
    let output = Output::new(&plan.output, &inputs)?;
    Ok((scene, output))
}

/// The receiving objects and the subsurface media.
fn receivers(plan: &BakePlan, scene: &Scene) -> Result<Receivers, Error> {
    // Whole bakes only (clap refuses --receivers with the others; glTF marks are not
    // applied to them).
    let objects = match plan.whole_scene {
        true => receiver_objects(scene, &plan.load.receivers)?,
        false => None,
    };
    let materials = plan.materials.as_deref();
    let media = bake_media::media(scene, materials, &plan.options, plan.split.any())?;
    Ok(Receivers { objects, media })
}

/// Refuses a bake whose memory estimate exceeds `--max-memory`, and says so when it is large.
fn check_memory(plan: &BakePlan, scene: &Scene) -> Result<(), Error> {
    let options = &plan.options;
    // A texel bake's receivers are the atlas's texels, besides the scene's own vertices.
    let (receivers, what) = match plan.lightmap.resolution {
        Some(res) => {
            let texels = u64::from(res) * u64::from(res);
            (
                texels + scene.vertex_count() as u64,
                format!("{texels} texels"),
            )
        }
        None => (
            scene.vertex_count() as u64,
            format!("{} vertices", scene.vertex_count()),
        ),
    };
    let needed = memory::bake_bytes(options, receivers, scene.triangles.len() as u64);
    limits::check(
        plan.scene.display().to_string(),
        &format!(
            "baking {what} at order {} with {} samples",
            options.order, options.samples
        ),
        needed,
    )?;
    if !plan.report.quiet && needed.is_some_and(|n| n >= 1 << 30) {
        eprintln!(
            "prt-bake: this bake needs up to {} of memory (limit {})",
            limits::human(needed.unwrap_or(0)),
            limits::human(limits::max_memory())
        );
    }
    Ok(())
}

/// The tracer, where the mode casts rays.
fn tracer(
    plan: &BakePlan,
    scene: &Scene,
    setup: &mut lightmap::Stages,
) -> Result<Option<Box<dyn Tracer>>, Error> {
    Ok(match plan.options.mode.casts_rays() {
        false => None,
        true => Some(setup.time("tracer", || trace::build(plan.backend, scene, plan.tracer))?),
    })
}

/// `--probes`: transfer matrices at points, whole or in parts.
fn probes(
    plan: &BakePlan,
    spec: &str,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    progress: &dyn Progress,
) -> Result<(), Error> {
    let split = &plan.split;
    let parts = (
        split.shard,
        split.checkpoint.as_deref(),
        split.checkpoint_vertices,
    );
    let (output, options) = (&plan.output, &plan.options);
    bake_probes::bake(spec, output, scene, tracer, options, parts, progress)
}

/// `--shard`, `--checkpoint` and `prepare-lightmap`.
fn bake_in_parts(
    plan: &BakePlan,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    progress: &dyn Progress,
) -> Result<(), Error> {
    let atlas = |resolution| atlas(&plan.lightmap, scene, resolution, progress);
    let parts = bake_parts::PartsArgs {
        lightmap: plan.lightmap.resolution,
        checkpoint: plan.split.checkpoint.as_deref(),
        checkpoint_vertices: plan.split.checkpoint_vertices,
        output: &plan.output,
        prepared: plan.lightmap.prepared.as_deref(),
        prepared_key: plan.prepared_key(scene),
        verbose: plan.report.verbose,
        atlas: &atlas,
    };
    let options = &plan.options;
    match plan.what {
        What::Prepare => bake_parts::prepare_lightmap(&parts, scene, tracer, options),
        _ => bake_parts::bake_in_parts(&parts, scene, tracer, options, plan.split.shard, progress),
    }
}

/// A whole bake: `--receivers`' objects' vertices, every vertex, or the lightmap's texels.
fn bake_whole(
    plan: &BakePlan,
    scene: &Scene,
    receivers: &Receivers,
    tracer: Option<&dyn Tracer>,
    progress: &dyn Progress,
) -> Result<Baked, Error> {
    let media = &receivers.media;
    match (plan.lightmap.resolution, receivers.objects.as_deref()) {
        (None, Some(objects)) => bake_objects(plan, scene, tracer, objects, media, progress),
        (None, None) => bake_vertices(plan, scene, tracer, media, progress),
        (Some(resolution), objects) => {
            bake_texels(plan, (scene, objects), tracer, media, resolution, progress)
        }
    }
}

/// `--receivers` per vertex: the receiving objects' vertices only.
fn bake_objects(
    plan: &BakePlan,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    objects: &[u32],
    media: &[Option<Medium>],
    progress: &dyn Progress,
) -> Result<Baked, Error> {
    let options = &plan.options;
    if options.denoise {
        // Its receivers are some of the scene's vertices, which the vertex guides do not
        // single out: refused rather than recorded as denoised.
        return Err(Error::InvalidOption(
            "--denoise on with receiving objects is for lightmaps (--lightmap): a vertex bake \
             of some objects is not denoised"
                .into(),
        ));
    }
    let transfer = bake_objects_translucent(scene, tracer, options, objects, media, progress)?;
    let file = CoefficientFile::from_object_bake(scene, &transfer, objects);
    let what = format!(
        "{} vertices of {} receiving objects (of {})",
        transfer.receiver_count,
        objects.len(),
        scene.objects.len()
    );
    Ok((transfer, file, what))
}

/// Every vertex: the bake, then subsurface transfer where a material has a medium.
fn bake_vertices(
    plan: &BakePlan,
    scene: &Scene,
    tracer: Option<&dyn Tracer>,
    media: &[Option<Medium>],
    progress: &dyn Progress,
) -> Result<Baked, Error> {
    let options = &plan.options;
    let subsurface = media.iter().any(Option::is_some);
    // Subsurface transfer is added after the bake: denoised after it, with it.
    let direct = BakeOptions {
        denoise: options.denoise && !subsurface,
        ..options.clone()
    };
    let mut transfer = prt_baker::bake(scene, tracer, &direct, progress)?;
    if let (true, Some(tracer)) = (subsurface, tracer) {
        add_subsurface(options, scene, tracer, media, &mut transfer, progress)?;
    }
    let file = CoefficientFile::from_bake(scene, &transfer);
    let what = format!("{} vertices", transfer.receiver_count);
    Ok((transfer, file, what))
}

/// Adds the random walks' subsurface transfer to a vertex bake's, then denoises the sum.
fn add_subsurface(
    options: &BakeOptions,
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    transfer: &mut Transfer,
    progress: &dyn Progress,
) -> Result<(), Error> {
    let started = std::time::Instant::now();
    subsurface::apply_to_vertices(scene, tracer, media, transfer, progress)?;
    if options.denoise {
        denoise::stage::denoise_vertices(
            scene,
            options,
            &mut transfer.coefficients,
            transfer.channels,
            &mut transfer.visibility,
        );
        transfer.options.denoise = true;
    }
    transfer.seconds += started.elapsed().as_secs_f64();
    Ok(())
}

/// `--lightmap RES`: the atlas (the scene's lightmap UVs, or generated), then the texel bake.
fn bake_texels(
    plan: &BakePlan,
    (scene, receivers): (&Scene, Option<&[u32]>),
    tracer: Option<&dyn Tracer>,
    media: &[Option<Medium>],
    resolution: u32,
    progress: &dyn Progress,
) -> Result<Baked, Error> {
    let options = &plan.options;
    let mut stages = lightmap::Stages::default();
    let atlas = stages.time("atlas", || match receivers {
        None => atlas(&plan.lightmap, scene, resolution, progress),
        Some(objects) => {
            lightmap::receiving::check_mode(options.mode)?;
            let alone = lightmap::receiving::receiver_scene(scene, objects);
            let atlas = atlas(&plan.lightmap, &alone, resolution, progress)?;
            Ok(lightmap::receiving::widen(scene, objects, atlas))
        }
    })?;
    let points = lightmap::TexelPoints::Released;
    let bake = lightmap::bake_texels(scene, tracer, options, atlas, media, points, progress)?;
    if plan.report.verbose {
        eprintln!(
            "prt-bake: stages: {}, {}; stitching factor {} nonzeros",
            stages.line(),
            bake.stages.line(),
            bake.seams.factor_nonzeros
        );
    }
    let seams = match bake.seams.samples {
        0 => String::new(),
        n => format!(
            "; seams stitched at {n} points, step {:.1e} -> {:.1e}",
            bake.seams.step_before, bake.seams.step_after
        ),
    };
    let what = format!(
        "{} of {}×{} texels ({} moved out, {} left out as leaking{seams})",
        bake.texels.valid_count(),
        bake.texels.width,
        bake.texels.height,
        bake.moved,
        bake.leaking
    );
    let (file, transfer) = CoefficientFile::from_lightmap_bake_owned(scene, bake);
    Ok((transfer, file, what))
}

/// `--lightmap RES`'s atlas: the scene's lightmap UVs, or generated.
fn atlas(
    plan: &LightmapPlan,
    scene: &Scene,
    resolution: u32,
    progress: &dyn Progress,
) -> Result<lightmap::Atlas, Error> {
    Ok(match (&scene.lightmap_uvs, plan.texel_size, plan.atlas) {
        (Some(uvs), None, None) => {
            let (atlas, _, notes) =
                lightmap::objects::from_scene_uvs(scene, uvs, resolution, plan.strict_uvs)?;
            notes.iter().for_each(|n| eprintln!("prt-bake: {n}"));
            atlas
        }
        (_, texel_size, method) => {
            let method = method.unwrap_or_default();
            // The unwrap reports no progress of its own (seconds on the demo): a bar
            // with its elapsed time shows that it runs.
            progress.begin("atlas", 0, 0);
            let generated = lightmap::atlas::generate(scene, resolution, texel_size, method);
            progress.finish();
            let generated = generated?;
            if let Some(note) = generated.fragmentation_note(method, scene.triangles.len()) {
                eprintln!("prt-bake: {note}");
            }
            generated.atlas
        }
    })
}

/// The whole bake's file, compressed by `--clusters`/`--pcs` or not, through the output
/// policy; then the summary lines.
fn write(plan: &BakePlan, output: &Output, (transfer, file, what): Baked) -> Result<(), Error> {
    let mut stages = lightmap::Stages::default();
    let compressed = stages.time("writing", || -> Result<_, Error> {
        let (bytes, compressed) = compress::bake_output(&file, plan.fit.as_ref())?;
        output.write_parts(&bytes.parts())?;
        Ok(compressed)
    })?;
    if plan.report.verbose {
        eprintln!("prt-bake: stages: {}", stages.line());
    }
    println!("{}", summary(plan, &transfer, &what));
    if let Some(c) = compressed {
        println!(
            "compressed to {} clusters × {} components: {:.2} floats per vertex (from {}), rms error {:.3e}",
            c.clusters, c.pcs, c.floats_per_vertex, c.uncompressed_floats_per_vertex, c.rms_error
        );
    }
    Ok(())
}

/// The line printed after a whole bake: what, how many rays, how fast, how.
fn summary(plan: &BakePlan, transfer: &Transfer, what: &str) -> String {
    let options = &plan.options;
    let rays = match transfer.rays_cast {
        0 => String::from("no rays"),
        rays => format!(
            "{rays} rays, {:.2} Mrays/s",
            rays as f64 / transfer.seconds.max(1e-9) / 1e6
        ),
    };
    let mode = match (options.mode, transfer.hit_cache_bytes) {
        // A one-bounce matrix bake: its vector pass has no bounces, so no rows to cache.
        (Mode::Interreflected, Some(0)) => format!(
            "interreflected, {} from {} rays, {} channels",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
        ),
        (Mode::Interreflected, Some(bytes)) => format!(
            "interreflected, {} from {} rays, {} channels, hit cache {:.0} MiB",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
            bytes as f64 / f64::from(1 << 20)
        ),
        (Mode::Interreflected, None) => format!(
            "interreflected, {} from {} rays, {} channels, re-traced (hit cache over {} MiB)",
            bounces(options.bounces),
            options.effective_bounce_samples(),
            transfer.channels,
            plan.report.hit_cache_mb
        ),
        (mode, _) => mode.name().to_string(),
    };
    let mode = match options.target_error {
        Some(target) => {
            // Texel bakes: the baked texels only (the others cast no rays).
            let baked = transfer.visibility.iter().filter(|v| v.rays > 0).count();
            format!(
                "{mode}, adaptive to {target:e}{}: {:.0} rays per {} on average",
                if options.denoise {
                    " after denoising"
                } else {
                    ""
                },
                transfer.rays_cast as f64 / baked.max(1) as f64,
                if plan.lightmap.resolution.is_some() {
                    "texel"
                } else {
                    "vertex"
                }
            )
        }
        None => mode,
    };
    format!(
        "baked {what}, {rays}, {:.2} s (order {}, {mode}, {} samples, {}) -> {}",
        transfer.seconds,
        options.order,
        options.samples,
        transfer.backend.name(),
        plan.output.display()
    )
}

/// "1 bounce", "2 bounces".
fn bounces(count: u32) -> String {
    match count {
        1 => String::from("1 bounce"),
        n => format!("{n} bounces"),
    }
}

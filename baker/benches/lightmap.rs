//! `make bench`, texel bakes: the demo scene with a generated 512×512 atlas at 1,024 rays per
//! texel (order 4, shadowed), timed end to end from the atlas (rasterisation, seam texels, leak
//! test, bake, dilation), against the raw Embree rate of the very same rays (same origins and directions,
//! occlusion streams straight into Embree's default-mode scene, as `benches/bake.rs` measures
//! vertices). The goal: "a texel is a ray origin like a vertex", the bake at
//! ≥ 0.8 × the raw rate. Also the default (watertight) bake against Embree's fast mode
//! everywhere, and the stages on their own.
//!
//! The atlas is made once, before the timed bakes, and timed as a stage of its own: like
//! loading the scene, it is not work per ray, and a scene with its own lightmap UVs
//! (TEXCOORD_1) does not pay it. (uvunwrap takes about 5 s on the torus, as long as the bake.)
//!
//! Times are CPU time (user + system, all threads) divided by the thread count, best of
//! [`REPEATS`], the bakes alternated, as in `benches/bake.rs`: wall time on a shared machine
//! also counts other tenants.
//!
//! Usage: `cargo bench -p prt-baker --bench lightmap [-- RESOLUTION [SAMPLES]]`.

mod timing;

use glam::Vec3;
use prt_baker::bake::lightmap::{self, Atlas, LightmapBake, Texels, leaks};
use prt_baker::bake::transfer::{Estimator, Receivers};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeMode, EmbreeOptions, EmbreeTracer, Tracer, embree_sys};
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;
use timing::{REPEATS, best_of, cpu_time};

/// The goal: the texel bake's rate over the raw Embree rate of its rays.
const GOAL: f64 = 0.8;

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| !a.starts_with("--"));
    let resolution: u32 = args.next().map_or(512, |s| s.parse().expect("RESOLUTION"));
    let samples: u32 = args.next().map_or(1024, |s| s.parse().expect("SAMPLES"));
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene = Scene::load(&root.join("scenes/torus/torus.scene")).expect("the demo scene");
    let options = BakeOptions {
        order: 4,
        samples,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let threads = rayon::current_num_threads();
    let tracer = |mode| {
        EmbreeTracer::new(
            &scene,
            EmbreeOptions {
                mode,
                ..EmbreeOptions::default()
            },
        )
        .expect("embree scene")
    };
    let (watertight, fast) = (tracer(EmbreeMode::Watertight), tracer(EmbreeMode::Fast));
    let generated = Atlas::generate(&scene, resolution, None).expect("atlas");
    let bake = |tracer: &dyn Tracer| -> LightmapBake {
        let atlas = generated.clone();
        lightmap::bake(&scene, Some(tracer), &options, atlas, &Silent).expect("texel bake")
    };
    let mut last = None;
    let (mut default_s, mut fast_s) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..REPEATS {
        default_s = default_s.min(cpu_time(|| last = Some(bake(&watertight))));
        fast_s = fast_s.min(cpu_time(|| {
            bake(&fast);
        }));
    }
    let baked = last.expect("a bake");
    let texels = baked.texels.valid_count();
    println!(
        "texel bake: demo scene, {resolution}×{resolution} generated atlas, {texels} texels \
         ({} moved out, {} left out as leaking), order {}, {samples} rays per texel, \
         {threads} threads",
        baked.moved, baked.leaking, options.order
    );

    // The stages on their own (watertight tracer).
    let atlas_s = best_of(|| {
        cpu_time(|| {
            Atlas::generate(&scene, resolution, None).expect("atlas");
        })
    });
    let atlas = Atlas::generate(&scene, resolution, None).expect("atlas");
    let raster_s = best_of(|| {
        cpu_time(|| {
            Texels::rasterise(&scene, &atlas);
        })
    });
    let fresh = Texels::rasterise(&scene, &atlas);
    let seams_s = best_of(|| {
        cpu_time(|| {
            fresh.watertight(&scene, &watertight).expect("seams");
        })
    });
    let leaks_s = best_of(|| {
        cpu_time(|| {
            let mut texels = fresh.clone();
            leaks::settle(&scene, &atlas, &mut texels, &watertight, options.seed).expect("leaks");
        })
    });

    // The raw Embree rate of the bake's own rays: the final texels as receivers.
    let estimator = Estimator::for_receivers(Receivers::texels(&baked.texels), &options)
        .expect("valid options");
    let raw_s = raw_embree(&estimator, texels, samples as usize, &fast);
    let rays = texels as f64 * f64::from(samples);
    let rate = |s: f64| rays / s / 1e6;
    println!(
        "  raw Embree (default mode, occlusion streams): {:.2} Mrays/s ({raw_s:.3} s)",
        rate(raw_s)
    );
    println!(
        "  bake, default (watertight):  {:.2} Mrays/s ({default_s:.3} s from the atlas) = {:.2} × raw",
        rate(default_s),
        raw_s / default_s
    );
    println!(
        "  bake, Embree fast mode:      {:.2} Mrays/s ({fast_s:.3} s) = {:.2} × raw; watertight \
         costs {:+.1} %",
        rate(fast_s),
        raw_s / fast_s,
        100.0 * (default_s / fast_s - 1.0)
    );
    println!(
        "  stages: atlas {atlas_s:.3} s, rasterisation {raster_s:.3} s, seam texels {seams_s:.3} s, \
         leak test {leaks_s:.3} s"
    );
    let ratio = raw_s / default_s;
    println!(
        "goal: texel bake ≥ {GOAL} × raw Embree: {ratio:.2} × ({})",
        if ratio >= GOAL { "met" } else { "NOT met" }
    );
}

/// Best-of CPU seconds that Embree alone takes for every receiver's rays (default-mode scene,
/// occlusion streams): a run that traces them minus a run that only generates them.
fn raw_embree(estimator: &Estimator, count: usize, samples: usize, tracer: &EmbreeTracer) -> f64 {
    let embree = tracer.embree_scene();
    let run = |trace: bool| {
        (0..count).into_par_iter().for_each_init(
            || (Vec::new(), Vec::new(), Vec::<embree_sys::Ray>::new()),
            |(dirs, weights, stream), v| {
                let frame = estimator.vertex_frame(v);
                estimator.directions(v, &frame, 0..samples, dirs, weights);
                if trace {
                    let origin: Vec3 = estimator.origin(v);
                    stream.clear();
                    stream.extend(dirs.iter().map(|d| {
                        embree_sys::Ray::new(origin.to_array(), d.to_array(), 0.0, f32::INFINITY)
                    }));
                    embree.occluded_stream(stream);
                }
            },
        );
    };
    let generate = best_of(|| cpu_time(|| run(false)));
    best_of(|| cpu_time(|| run(true))) - generate
}

//! `scripts/bench-large.sh`'s raw Embree rate (not part of `make bench`): the rays of a texel
//! bake of a scene with its own lightmap UVs (TEXCOORD_1), straight into Embree's default-mode
//! scene — the bounce samples as closest-hit streams, the others as occlusion streams, as the
//! interreflected bake traces them — so the bake's rate can be divided by it. Also times the
//! texel preparation (rasterisation, seam texels, leak test), which every shard repeats.
//!
//! Times are CPU time (user + system, all threads) divided by the thread count, one run each
//! (a million-triangle 2048² bake is minutes; `benches/lightmap.rs` takes the best of three).
//!
//! Usage: `cargo bench -p prt-baker --bench large -- SCENE RES SAMPLES [BOUNCE_SAMPLES]`;
//! BOUNCE_SAMPLES 0 traces a shadowed bake's rays (occlusion streams only), for
//! `scripts/bench/lightmap_scale.sh`'s shadowed rate.

#[allow(dead_code)] // best_of: one run each here
mod timing;

use glam::Vec3;
use prt_baker::bake::lightmap::{self, Atlas};
use prt_baker::bake::transfer::{Estimator, Receivers};
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, embree_sys};
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;
use timing::cpu_time;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let [scene, res, samples, rest @ ..] = args.as_slice() else {
        panic!("usage: large SCENE RES SAMPLES [BOUNCE_SAMPLES]");
    };
    let resolution: u32 = res.parse().expect("RES");
    let samples: u32 = samples.parse().expect("SAMPLES");
    let bounce_samples: Option<u32> = rest.first().map(|s| s.parse().expect("BOUNCE_SAMPLES"));
    let scene = Scene::load(std::path::Path::new(scene)).expect("the scene");
    let uvs = scene
        .lightmap_uvs
        .as_ref()
        .expect("a scene with TEXCOORD_1");
    let atlas = Atlas::from_vertex_uvs(&scene, uvs, resolution, resolution).expect("atlas");
    // A shadowed bake casts only occlusion rays: BOUNCE_SAMPLES 0 asks for its rays.
    let shadowed = bounce_samples == Some(0);
    let options = BakeOptions {
        order: 3,
        samples,
        mode: if shadowed {
            Mode::Shadowed
        } else {
            Mode::Interreflected
        },
        bounces: if shadowed { 0 } else { 2 },
        bounce_samples: bounce_samples.filter(|_| !shadowed),
        ..BakeOptions::default()
    };
    let threads = rayon::current_num_threads();
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("embree scene");
    let mut prepared = None;
    let prepare_s = cpu_time(|| {
        prepared =
            Some(lightmap::prepare(&scene, Some(&tracer), options.seed, atlas).expect("texels"));
    });
    let prepared = prepared.expect("prepared");
    let texels = prepared.texels.valid_count();
    let estimator = Estimator::for_receivers(Receivers::texels(&prepared.texels), &options)
        .expect("valid options");
    let bounce = options.effective_bounce_samples() as usize;
    let embree = tracer.embree_scene();
    let run = |trace: bool| {
        (0..texels).into_par_iter().for_each_init(
            || {
                (
                    Vec::new(),
                    Vec::new(),
                    Vec::<embree_sys::Ray>::new(),
                    Vec::new(),
                )
            },
            |(dirs, weights, stream, hits), v| {
                let frame = estimator.vertex_frame(v);
                estimator.directions(v, &frame, 0..samples as usize, dirs, weights);
                if trace {
                    let origin: Vec3 = estimator.origin(v);
                    stream.clear();
                    stream.extend(dirs.iter().map(|d| {
                        embree_sys::Ray::new(origin.to_array(), d.to_array(), 0.0, f32::INFINITY)
                    }));
                    hits.clear();
                    hits.extend(stream[..bounce].iter().map(|r| embree_sys::RayHit::new(*r)));
                    embree.intersect_stream(hits);
                    embree.occluded_stream(&mut stream[bounce..]);
                }
            },
        );
    };
    let generate_s = cpu_time(|| run(false));
    let raw_s = cpu_time(|| run(true)) - generate_s;
    let rays = texels as f64 * f64::from(samples);
    println!(
        "raw Embree: {texels} texels × {samples} rays ({bounce} closest-hit), {threads} threads: \
         {raw_s:.3} s CPU per thread, {:.2} Mrays/s; texel preparation (leak test) {prepare_s:.3} s",
        rays / raw_s / 1e6
    );
}

//! `make bench`: the demo scene baked at 10,000 rays per vertex (order 4, shadowed), and, in the
//! same run, the raw Embree occlusion rate for the very same rays with no sampling or SH work.
//! Rates are reported as ratios within the run, because these machines are shared and noisy.
//!
//! Usage: `cargo bench -p prt-baker --bench bake [-- SCENE [SAMPLES]]`.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::Vec3;
use prt_baker::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, Tracer};
use prt_baker::transfer::Estimator;
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;

/// Each measurement is repeated and the best kept: noise from other tenants only slows runs down.
const REPEATS: usize = 3;

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| !a.starts_with("--"));
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene_path = args
        .next()
        .map(Into::into)
        .unwrap_or_else(|| root.join("scenes/torus/torus.scene"));
    let samples: u32 = args
        .next()
        .map(|s| s.parse().expect("SAMPLES is a number"))
        .unwrap_or(10_000);

    let scene = Scene::load(&scene_path).unwrap_or_else(|err| panic!("{err}"));
    let options = BakeOptions {
        order: 4,
        samples,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let threads = rayon::current_num_threads();
    println!(
        "scene {} ({} vertices, {} triangles), order {}, {} rays per vertex, {threads} threads",
        scene_path.display(),
        scene.vertex_count(),
        scene.triangles.len(),
        options.order,
        samples
    );

    let started = Instant::now();
    let tracer =
        EmbreeTracer::new(&scene, EmbreeOptions::default()).unwrap_or_else(|err| panic!("{err}"));
    println!("embree BVH build: {:.3} s", started.elapsed().as_secs_f64());
    let total_rays = scene.vertex_count() as f64 * samples as f64;

    let bake_seconds = best_of(|| {
        let transfer = prt_baker::bake(&scene, Some(&tracer), &options, &Silent).expect("bake");
        transfer.seconds
    });
    let estimator = Estimator::new(&scene, &options).expect("options are valid");
    let stream_seconds =
        best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::Stream));
    let packet_seconds =
        best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::Packet16));
    let trait_seconds = best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::Trait));
    let shuffled_seconds =
        best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::Shuffled));
    let closest_seconds =
        best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::ClosestHit));
    let closest16_seconds =
        best_of(|| raw_embree(&scene, &estimator, &tracer, samples, Query::ClosestHit16));
    let robust = EmbreeTracer::new(
        &scene,
        EmbreeOptions {
            robust: true,
            ..EmbreeOptions::default()
        },
    )
    .unwrap_or_else(|err| panic!("{err}"));
    let robust_seconds = best_of(|| {
        let transfer = prt_baker::bake(&scene, Some(&robust), &options, &Silent).expect("bake");
        transfer.seconds
    });

    let rate = |seconds: f64| total_rays / seconds / 1e6;
    let ceiling = rate(stream_seconds).max(rate(packet_seconds));
    println!();
    println!(
        "{:<44} {:>10} {:>12} {:>9}",
        "", "seconds", "Mrays/s", "ratio"
    );
    let row = |name: &str, seconds: f64| {
        println!(
            "{name:<44} {seconds:>10.3} {:>12.2} {:>9.3}",
            rate(seconds),
            rate(seconds) / ceiling
        );
    };
    row("raw embree, rtcOccluded1M (same rays)", stream_seconds);
    row("raw embree, rtcOccluded16 (same rays)", packet_seconds);
    row("raw through the Tracer trait (same rays)", trait_seconds);
    row(
        "raw embree, same rays shuffled (incoherent)",
        shuffled_seconds,
    );
    row("full bake (sampling + tracing + SH)", bake_seconds);
    row("full bake, Embree robust mode", robust_seconds);
    row(
        "raw embree closest hit, rtcIntersect1M (same rays)",
        closest_seconds,
    );
    row(
        "raw embree closest hit, rtcIntersect16 (same rays)",
        closest16_seconds,
    );
    println!();
    println!(
        "bake: {:.2} s for {:.0} M rays, {:.1} Mrays/s = {:.3} x the raw Embree rate (target: <= 4 s, >= 0.8 x)",
        bake_seconds,
        total_rays / 1e6,
        rate(bake_seconds),
        rate(bake_seconds) / ceiling
    );

    // Interreflection (issue 4): the same scene and rays, 1–3 bounces, against the shadowed
    // bake just measured.
    println!();
    println!(
        "{:<44} {:>10} {:>12} {:>12}",
        "", "seconds", "x shadowed", "cache MiB"
    );
    let mut previous = bake_seconds;
    for bounces in 1..=3 {
        let options = BakeOptions {
            mode: Mode::Interreflected,
            bounces,
            ..options.clone()
        };
        let mut cache = 0;
        let seconds = best_of(|| {
            let transfer = prt_baker::bake(&scene, Some(&tracer), &options, &Silent).expect("bake");
            cache = transfer.hit_cache_bytes.unwrap_or(0);
            transfer.seconds
        });
        println!(
            "{:<44} {seconds:>10.3} {:>12.3} {:>12.0}   (+{:.3} x for this bounce)",
            format!(
                "interreflected, {bounces} bounce(s), {} bounce rays",
                options.effective_bounce_samples()
            ),
            seconds / bake_seconds,
            cache as f64 / f64::from(1 << 20),
            (seconds - previous) / bake_seconds,
        );
        previous = seconds;
    }
    println!(
        "peak resident memory of this benchmark process: {:.0} MiB",
        peak_rss_mib()
    );
}

/// The process's peak resident set (VmHWM), in MiB; 0 where /proc is unavailable.
fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
            line.split_whitespace().nth(1)?.parse::<f64>().ok()
        })
        .map_or(0.0, |kib| kib / 1024.0)
}

fn best_of(mut run: impl FnMut() -> f64) -> f64 {
    (0..REPEATS).map(|_| run()).fold(f64::INFINITY, f64::min)
}

#[derive(Clone, Copy, PartialEq)]
enum Query {
    Stream,
    Packet16,
    Trait,
    /// The stream in a fixed random order: what the rays cost without the Hilbert ordering.
    Shuffled,
    /// Closest hits instead of occlusion (what the interreflected mode's direct pass traces).
    ClosestHit,
    ClosestHit16,
}

/// Seconds that the bake's rays take in Embree alone. Rays are generated outside the timed
/// sections; the time inside them, summed over threads and divided by the thread count, is
/// the wall time a pure tracing run would take.
fn raw_embree(
    scene: &Scene,
    estimator: &Estimator,
    tracer: &EmbreeTracer,
    samples: u32,
    query: Query,
) -> f64 {
    let embree = tracer.embree_scene();
    let traced_nanos = AtomicU64::new(0);
    let samples = samples as usize;
    (0..scene.vertex_count()).into_par_iter().for_each_init(
        || {
            (
                Vec::new(),
                Vec::new(),
                Vec::new(),
                vec![false; samples],
                embree_sys::Ray16::default(),
            )
        },
        |(dirs, weights, stream, occluded, packet): &mut (
            Vec<Vec3>,
            Vec<f32>,
            Vec<embree_sys::Ray>,
            Vec<bool>,
            _,
        ),
         v| {
            let origin = estimator.origin(v);
            estimator.directions(v, &estimator.vertex_frame(v), 0..samples, dirs, weights);
            if query == Query::Shuffled {
                shuffle(dirs, v as u64);
            }
            stream.clear();
            stream.extend(dirs.iter().map(|d| {
                embree_sys::Ray::new(origin.to_array(), d.to_array(), 0.0, f32::INFINITY)
            }));
            let mut rayhits: Vec<embree_sys::RayHit> = match query {
                Query::ClosestHit => stream.iter().map(|r| embree_sys::RayHit::new(*r)).collect(),
                _ => Vec::new(),
            };
            let started = Instant::now();
            match query {
                Query::Stream | Query::Shuffled => embree.occluded_stream(stream),
                Query::Packet16 => {
                    for chunk in stream.chunks(embree_sys::PACKET_WIDTH) {
                        packet.clear();
                        for (i, r) in chunk.iter().enumerate() {
                            packet.set(i, r.origin(), r.dir(), 0.0, r.tfar());
                        }
                        embree.occluded16(packet);
                    }
                }
                Query::Trait => tracer.occluded_from(origin, dirs, occluded),
                Query::ClosestHit => embree.intersect_stream(&mut rayhits),
                Query::ClosestHit16 => {
                    let mut packet = embree_sys::RayHit16::default();
                    for chunk in stream.chunks(embree_sys::PACKET_WIDTH) {
                        packet.clear();
                        for (i, r) in chunk.iter().enumerate() {
                            packet.set(i, r.origin(), r.dir(), 0.0, r.tfar());
                        }
                        embree.intersect16(&mut packet);
                    }
                }
            }
            traced_nanos.fetch_add(started.elapsed().as_nanos() as u64, Ordering::Relaxed);
        },
    );
    traced_nanos.into_inner() as f64 / 1e9 / rayon::current_num_threads() as f64
}

/// A deterministic Fisher–Yates shuffle.
fn shuffle(values: &mut [Vec3], seed: u64) {
    let mut rng = prt_baker::sampling::Pcg32::new(seed, 99);
    for i in (1..values.len()).rev() {
        let j = (rng.next_u32() as usize) % (i + 1);
        values.swap(i, j);
    }
}

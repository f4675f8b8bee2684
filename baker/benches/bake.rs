//! `make bench`: the demo scene baked at 10,000 rays per vertex (order 4, shadowed) with each
//! backend, and, in the same run, the raw occlusion rate of each backend for the very same
//! rays with no sampling or SH work; then interreflected bakes at 1–3 bounces against the
//! shadowed one, with their hit-cache size and the process's peak memory. Rates are reported as ratios within the run, because these
//! machines are shared and noisy.
//!
//! Times are **CPU time** (user + system, all threads, from `/proc/self/stat`) divided by the
//! thread count: the wall time the work would take on otherwise idle cores. On a shared machine
//! wall time also counts the time other tenants hold our cores, which swung ratios between
//! backends by 2× from one run to the next; CPU time moved by a few per cent. Raw rows subtract
//! the CPU time of generating the same rays without tracing them.
//!
//! Usage: `cargo bench -p prt-baker --bench bake [-- SCENE [SAMPLES]] [-- --presets] [-- --quick]`;
//! `--presets` also times every obvhs build preset; `--quick` times only the bakes and the raw
//! rates they are compared with (no shuffled, closest-hit or interreflection rows);
//! `--adaptive-only` runs only the last section, the time to the thesis's accuracy (adaptive
//! against fixed sampling).

mod timing;

use std::time::{Duration, Instant};

use glam::Vec3;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::rt_triangle::RtTriangle;
use prt_baker::bake::transfer::Estimator;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{
    EmbreeMode, EmbreeOptions, EmbreeTracer, ObvhsOptions, ObvhsTracer, Tracer, embree_sys,
};
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;
use timing::{REPEATS, best_of, cpu_time};

fn main() {
    let all_args: Vec<String> = std::env::args().skip(1).collect();
    let presets = all_args.iter().any(|a| a == "--presets");
    let quick = all_args.iter().any(|a| a == "--quick");
    let adaptive_only = all_args.iter().any(|a| a == "--adaptive-only");
    let mut args = all_args.iter().filter(|a| !a.starts_with("--"));
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
    let embree =
        // The BVH quality `prt-bake` picks for this many rays per vertex.
        EmbreeTracer::new(
            &scene,
            EmbreeOptions {
                rays_per_receiver: samples,
                ..EmbreeOptions::default()
            },
        )
        .unwrap_or_else(|err| panic!("{err}"));
    println!(
        "embree BVH build: {:.3} s (two scenes: robust mode for the rays of {} seam vertices \
         of {})",
        started.elapsed().as_secs_f64(),
        embree.seam_origin_count(),
        scene.vertex_count()
    );
    if adaptive_only {
        time_to_thesis_accuracy(&scene, &embree, options.order);
        return;
    }
    let started = Instant::now();
    let obvhs = ObvhsTracer::new(&scene, ObvhsOptions::default());
    println!("obvhs BVH build:  {:.3} s", started.elapsed().as_secs_f64());
    let total_rays = scene.vertex_count() as f64 * samples as f64;
    let estimator = Estimator::new(&scene, &options).expect("options are valid");
    let rays = SameRays {
        scene: &scene,
        estimator: &estimator,
        samples: samples as usize,
    };
    let mut bake_wall = f64::INFINITY;
    // One timed bake; the Embree bakes are repeated below, the obvhs bake is best of
    // [`REPEATS`].
    let mut bake_once = |tracer: &dyn Tracer, default: bool| {
        cpu_time(|| {
            let transfer = prt_baker::bake(&scene, Some(tracer), &options, &Silent).expect("bake");
            if default {
                bake_wall = bake_wall.min(transfer.seconds);
            }
        })
    };

    let embree_mode = |mode| {
        EmbreeTracer::new(
            &scene,
            EmbreeOptions {
                mode,
                rays_per_receiver: samples,
                ..EmbreeOptions::default()
            },
        )
        .unwrap_or_else(|err| panic!("{err}"))
    };
    let (fast, robust) = (
        embree_mode(EmbreeMode::Fast),
        embree_mode(EmbreeMode::Robust),
    );
    // The three Embree modes' bakes one after another, three times, so slow phases of the
    // shared machine hit all of them alike.
    let (mut bake_seconds, mut fast_seconds, mut robust_seconds) =
        (f64::INFINITY, f64::INFINITY, f64::INFINITY);
    for _ in 0..REPEATS {
        bake_seconds = bake_seconds.min(bake_once(&embree, true));
        fast_seconds = fast_seconds.min(bake_once(&fast, false));
        robust_seconds = robust_seconds.min(bake_once(&robust, false));
    }
    let stream_seconds = raw_embree(&rays, &embree, Query::Stream);
    let packet_seconds = raw_embree(&rays, &embree, Query::Packet16);
    let skip = |query| {
        if quick {
            f64::NAN
        } else {
            raw_embree(&rays, &embree, query)
        }
    };
    let trait_seconds = if quick {
        f64::NAN
    } else {
        rays.time(Order::Hilbert, &embree)
    };
    let shuffled_seconds = skip(Query::Shuffled);
    let closest_seconds = skip(Query::ClosestHit);
    let closest16_seconds = skip(Query::ClosestHit16);
    let obvhs_seconds = rays.time(Order::Hilbert, &obvhs);
    let obvhs_shuffled_seconds = if quick {
        f64::NAN
    } else {
        rays.time(Order::Shuffled, &obvhs)
    };
    let stock = StockObvhs::new(&scene, ObvhsOptions::default().build);
    let stock_seconds = if quick {
        f64::NAN
    } else {
        rays.time_with(
            Order::Hilbert,
            || vec![false; samples as usize],
            |occluded, origin, dirs| stock.occluded_from(origin, dirs, occluded),
        )
    };
    let obvhs_bake_seconds = best_of(|| bake_once(&obvhs, false));

    let rate = |seconds: f64| total_rays / seconds / 1e6;
    let ceiling = rate(stream_seconds).max(rate(packet_seconds));
    println!();
    println!(
        "{:<52} {:>10} {:>12} {:>9}",
        "", "seconds", "Mrays/s", "ratio"
    );
    let row = |name: &str, seconds: f64| {
        if seconds.is_nan() {
            return; // not measured with --quick
        }
        println!(
            "{name:<52} {seconds:>10.3} {:>12.2} {:>9.3}",
            rate(seconds),
            rate(seconds) / ceiling
        );
    };
    row("raw embree, rtcOccluded1M (same rays)", stream_seconds);
    row("raw embree, rtcOccluded16 (same rays)", packet_seconds);
    row(
        "raw embree through the Tracer trait (same rays)",
        trait_seconds,
    );
    row(
        "raw embree, same rays shuffled (incoherent)",
        shuffled_seconds,
    );
    row("full bake (sampling + tracing + SH), embree", bake_seconds);
    row(
        "full bake, Embree default mode everywhere (leaks)",
        fast_seconds,
    );
    row("full bake, Embree robust mode everywhere", robust_seconds);
    row(
        "raw embree closest hit, rtcIntersect1M (same rays)",
        closest_seconds,
    );
    row(
        "raw embree closest hit, rtcIntersect16 (same rays)",
        closest16_seconds,
    );
    row(
        "raw obvhs through the Tracer trait (same rays)",
        obvhs_seconds,
    );
    row("raw obvhs, same rays shuffled", obvhs_shuffled_seconds);
    row(
        "raw obvhs stock (ray_traverse_miss, RtTriangle)",
        stock_seconds,
    );
    row("full bake, obvhs", obvhs_bake_seconds);
    println!();
    println!(
        "load average {}",
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    );
    println!(
        "bake: {:.2} s wall ({:.2} s CPU per thread) for {:.0} M rays, {:.1} Mrays/s = {:.3} x the raw Embree rate (target: <= 4 s, >= 0.8 x)",
        bake_wall,
        bake_seconds,
        total_rays / 1e6,
        rate(bake_seconds),
        rate(bake_seconds) / ceiling
    );
    println!(
        "embree modes (bake speed / the default mode everywhere, the default before the watertight one): \
         watertight default {:.3} (target >= 0.93), robust everywhere {:.3}",
        fast_seconds / bake_seconds,
        fast_seconds / robust_seconds
    );
    println!(
        "obvhs/embree on the same rays: raw {:.3} (obvhs {:.1} / embree {:.1} Mrays/s), bake {:.3} ({:.2} s / {:.2} s) (target: > 0.35)",
        rate(obvhs_seconds) / ceiling,
        rate(obvhs_seconds),
        ceiling,
        bake_seconds / obvhs_bake_seconds,
        obvhs_bake_seconds,
        bake_seconds
    );

    if quick {
        return;
    }
    // Interreflection: the same scene and rays, 1–3 bounces, against the shadowed
    // Embree bake just measured.
    println!();
    println!(
        "{:<52} {:>10} {:>12} {:>12}",
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
            cpu_time(|| {
                let transfer =
                    prt_baker::bake(&scene, Some(&embree), &options, &Silent).expect("bake");
                cache = transfer.hit_cache_bytes.unwrap_or(0);
            })
        });
        println!(
            "{:<52} {seconds:>10.3} {:>12.3} {:>12.0}   (+{:.3} x for this bounce)",
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

    time_to_thesis_accuracy(&scene, &embree, options.order);

    if presets {
        println!();
        println!(
            "{:<24} {:>9} {:>8} {:>12} {:>9}",
            "obvhs preset", "build s", "nodes", "Mrays/s", "ratio"
        );
        for (name, build) in [
            ("fastest_build", BvhBuildParams::fastest_build()),
            ("very_fast_build", BvhBuildParams::very_fast_build()),
            ("fast_build", BvhBuildParams::fast_build()),
            ("medium_build", BvhBuildParams::medium_build()),
            ("slow_build", BvhBuildParams::slow_build()),
            ("very_slow_build", BvhBuildParams::very_slow_build()),
        ] {
            for leaf in [1, 3] {
                let build = BvhBuildParams {
                    max_prims_per_leaf: leaf,
                    ..build
                };
                let started = Instant::now();
                let tracer = ObvhsTracer::new(&scene, ObvhsOptions { build });
                let build_seconds = started.elapsed().as_secs_f64();
                let seconds = rays.time(Order::Hilbert, &tracer);
                println!(
                    "{:<24} {build_seconds:>9.3} {:>8} {:>12.2} {:>9.3}",
                    format!("{name}, leaf {leaf}"),
                    tracer.node_count(),
                    rate(seconds),
                    rate(seconds) / ceiling
                );
            }
        }
    }
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

/// The rays of the bake, regenerated per vertex.
struct SameRays<'a> {
    scene: &'a Scene,
    estimator: &'a Estimator,
    samples: usize,
}

#[derive(Clone, Copy, PartialEq)]
enum Order {
    /// As the bake casts them.
    Hilbert,
    /// In a fixed random order: what the rays cost without the Hilbert ordering.
    Shuffled,
}

impl SameRays<'_> {
    /// Generates every vertex's rays in `order` and hands them to `trace`, on all threads.
    fn run<S>(
        &self,
        order: Order,
        init: impl Fn() -> S + Sync + Send,
        trace: impl Fn(&mut S, Vec3, &[Vec3]) + Sync + Send,
    ) {
        (0..self.scene.vertex_count())
            .into_par_iter()
            .for_each_init(
                || (Vec::new(), Vec::new(), init()),
                |(dirs, weights, state), v| {
                    let estimator = self.estimator;
                    let frame = estimator.vertex_frame(v);
                    estimator.directions(v, &frame, 0..self.samples, dirs, weights);
                    if order == Order::Shuffled {
                        shuffle(dirs, v as u64);
                    }
                    trace(state, estimator.origin(v), dirs);
                },
            );
    }

    /// Best-of CPU seconds (per thread) that tracing the rays with `trace` takes: the run
    /// minus a run that only generates the rays.
    fn time_with<S>(
        &self,
        order: Order,
        init: impl Fn() -> S + Sync + Send,
        trace: impl Fn(&mut S, Vec3, &[Vec3]) + Sync + Send,
    ) -> f64 {
        let generate = best_of(|| cpu_time(|| self.run(order, || (), |_, _, _| ())));
        best_of(|| cpu_time(|| self.run(order, &init, &trace))) - generate
    }

    /// [`SameRays::time_with`] through a [`Tracer`]'s `occluded_from`, as the bake calls it.
    fn time(&self, order: Order, tracer: &dyn Tracer) -> f64 {
        self.time_with(
            order,
            || vec![false; self.samples],
            |occluded, origin, dirs| tracer.occluded_from(origin, dirs, occluded),
        )
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Query {
    Stream,
    Packet16,
    /// The stream in a fixed random order.
    Shuffled,
    /// Closest hits instead of occlusion (what the interreflected mode's bounce rays trace).
    ClosestHit,
    ClosestHit16,
}

/// CPU seconds that the bake's rays take in Embree alone, called directly.
fn raw_embree(rays: &SameRays, tracer: &EmbreeTracer, query: Query) -> f64 {
    let embree = tracer.embree_scene();
    let order = match query {
        Query::Shuffled => Order::Shuffled,
        _ => Order::Hilbert,
    };
    rays.time_with(
        order,
        || {
            (
                Vec::new(),
                Vec::new(),
                embree_sys::Ray16::default(),
                embree_sys::RayHit16::default(),
            )
        },
        |(stream, rayhits, packet, hit_packet): &mut (
            Vec<embree_sys::Ray>,
            Vec<embree_sys::RayHit>,
            _,
            _,
        ),
         origin,
         dirs| {
            stream.clear();
            stream.extend(dirs.iter().map(|d| {
                embree_sys::Ray::new(origin.to_array(), d.to_array(), 0.0, f32::INFINITY)
            }));
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
                Query::ClosestHit => {
                    rayhits.clear();
                    rayhits.extend(stream.iter().map(|r| embree_sys::RayHit::new(*r)));
                    embree.intersect_stream(rayhits);
                }
                Query::ClosestHit16 => {
                    for chunk in stream.chunks(embree_sys::PACKET_WIDTH) {
                        hit_packet.clear();
                        for (i, r) in chunk.iter().enumerate() {
                            hit_packet.set(i, r.origin(), r.dir(), 0.0, r.tfar());
                        }
                        embree.intersect16(hit_packet);
                    }
                }
            }
        },
    )
}

/// obvhs as its examples use it: `ray_traverse_miss` with its own box and triangle tests
/// (which differ from Embree's at edges and within 10⁻⁴ of the origin; see
/// `baker/src/trace/obvhs/node.rs`). The row shows what our own tests cost or gain.
struct StockObvhs {
    bvh: CwBvh,
    triangles: Vec<RtTriangle>,
}

impl StockObvhs {
    fn new(scene: &Scene, build: BvhBuildParams) -> StockObvhs {
        let soup: Vec<obvhs::triangle::Triangle> = scene
            .triangles
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.map(|i| scene.positions[i as usize].into());
                obvhs::triangle::Triangle { v0, v1, v2 }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&soup, build, &mut Duration::default());
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| RtTriangle::from(&soup[i as usize]))
            .collect();
        StockObvhs { bvh, triangles }
    }

    /// Occlusion only, one ray at a time: all the benchmark times.
    fn occluded_from(&self, origin: Vec3, dirs: &[Vec3], occluded: &mut [bool]) {
        for (o, d) in occluded.iter_mut().zip(dirs) {
            let ray = obvhs::ray::Ray::new(origin.into(), (*d).into(), 0.0, f32::INFINITY);
            *o = !self
                .bvh
                .ray_traverse_miss(ray, |ray, id| self.triangles[id].intersect(ray));
        }
    }
}

/// A deterministic Fisher–Yates shuffle.
fn shuffle(values: &mut [Vec3], seed: u64) {
    let mut rng = prt_baker::math::sampling::Pcg32::new(seed, 99);
    for i in (1..values.len()).rev() {
        let j = (rng.next_u32() as usize) % (i + 1);
        values.swap(i, j);
    }
}

/// Adaptive sampling (`--target-error`): the time to reach the thesis's accuracy. The thesis cast
/// 10,000 independent uniform rays per vertex (`--sampling thesis-random --samples 10000`);
/// its RMS coefficient error E is measured against a 2^16-ray Owen–Sobol reference of another
/// seed. Then, each timed as the bake above: the thesis's bake; fixed Owen–Sobol at 10,000
/// rays and at the fewest rays (a power of two) whose RMS error is at most E; and the adaptive
/// bake with `--target-error E` (capped at 2^16 rays per vertex).
fn time_to_thesis_accuracy(scene: &Scene, tracer: &dyn Tracer, order: usize) {
    use prt_baker::math::sampling::Sampling;
    let base = BakeOptions {
        order,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let bake = |options: &BakeOptions| {
        prt_baker::bake(scene, Some(tracer), options, &Silent).expect("bake")
    };
    let timed = |options: &BakeOptions| {
        let mut transfer = None;
        let seconds = best_of(|| cpu_time(|| transfer = Some(bake(options))));
        (seconds, transfer.expect("a bake"))
    };
    let reference = bake(&BakeOptions {
        samples: 1 << 16,
        seed: 12_345,
        ..base.clone()
    });
    // Per-vertex RMS coefficient errors against the reference.
    let errors = |t: &prt_baker::Transfer| -> Vec<f64> {
        let n = prt_baker::math::sh::coeff_count(order);
        t.coefficients
            .chunks(n)
            .zip(reference.coefficients.chunks(n))
            .map(|(a, r)| {
                let squares: f64 = a.iter().zip(r).map(|(a, r)| f64::from(a - r).powi(2)).sum();
                (squares / n as f64).sqrt()
            })
            .collect()
    };
    let rms = |e: &[f64]| (e.iter().map(|e| e * e).sum::<f64>() / e.len() as f64).sqrt();
    let p95 = |e: &[f64]| {
        let mut sorted = e.to_vec();
        sorted.sort_by(f64::total_cmp);
        sorted[(0.95 * sorted.len() as f64).ceil() as usize - 1]
    };

    let thesis_options = BakeOptions {
        samples: 10_000,
        sampling: Sampling::ThesisRandom,
        ..base.clone()
    };
    let (thesis_seconds, thesis) = timed(&thesis_options);
    let target = rms(&errors(&thesis));
    let mut fewest = 64;
    while fewest < 10_000 {
        let options = BakeOptions {
            samples: fewest,
            ..base.clone()
        };
        if rms(&errors(&bake(&options))) <= target {
            break;
        }
        fewest *= 2;
    }
    let rows = [
        (
            "fixed, thesis-random, 10,000 rays".to_string(),
            thesis_options,
        ),
        (
            "fixed, owen-sobol, 10,000 rays".to_string(),
            BakeOptions {
                samples: 10_000,
                ..base.clone()
            },
        ),
        (
            format!("fixed, owen-sobol, {fewest} rays (fewest reaching E)"),
            BakeOptions {
                samples: fewest,
                ..base.clone()
            },
        ),
        (
            format!("adaptive, --target-error {target:.2e}"),
            BakeOptions {
                samples: 1 << 16,
                target_error: Some(target as f32),
                ..base.clone()
            },
        ),
    ];
    println!();
    println!(
        "time to the thesis's accuracy: E = {target:.3e} (RMS coefficient error of thesis-random \
         at 10,000 rays against an owen-sobol reference at 65,536)"
    );
    println!(
        "{:<52} {:>10} {:>9} {:>10} {:>10} {:>10} {:>10} {:>9}",
        "", "rays/vtx", "seconds", "x faster", "RMS err", "p95 err", "max err", "> 1.5 E"
    );
    for (name, options) in rows {
        let (seconds, transfer) = if options == thesis.options {
            (thesis_seconds, thesis.clone())
        } else {
            timed(&options)
        };
        let e = errors(&transfer);
        println!(
            "{name:<52} {:>10.0} {seconds:>9.3} {:>10.2} {:>10.2e} {:>10.2e} {:>10.2e} {:>8.2}%",
            transfer.rays_cast as f64 / transfer.receiver_count as f64,
            thesis_seconds / seconds,
            rms(&e),
            p95(&e),
            e.iter().copied().fold(0.0, f64::max),
            100.0 * e.iter().filter(|&&e| e > 1.5 * target).count() as f64 / e.len() as f64,
        );
        if options.target_error.is_some() {
            let above = transfer
                .visibility
                .iter()
                .filter(|v| f64::from(v.error_estimate) > target)
                .count();
            println!("  adaptive: {above} vertices stopped at the cap above E");
        }
    }
}

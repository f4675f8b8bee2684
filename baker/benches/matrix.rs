//! `cargo bench -p prt-baker --bench matrix [SCENE] [SAMPLES]`: the transfer-matrix bake
//! (`--transfer matrix`) against the vector bake and against Embree alone tracing the matrix
//! bake's very rays (same origins, same directions, same batches of 256, through the
//! `Tracer` trait as the bake calls it); and the outer-product accumulation alone, packed
//! upper triangle (what the bake does) against the full n²×n² square. Then the interreflected
//! matrix (`--mode interreflected --bounces 2`: the vector bake with one bounce, then the
//! matrix pass whose first quarter of rays are closest-hit rays) against the interreflected
//! vector bakes and against Embree alone tracing both passes' rays. CPU time per thread,
//! best of three (`timing`), so other tenants of a shared machine count less.

mod timing;

use prt_baker::bake::matrix::{TileLayout, add_outer, local_directions, packed_len};
use prt_baker::bake::options::TransferKind;
use prt_baker::bake::transfer::Estimator;
use prt_baker::math::sampling::Pcg32;
use prt_baker::support::progress::Silent;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, Tracer};
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;
use timing::{best_of, cpu_time};

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
    let vector = BakeOptions {
        order: 4,
        samples,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let matrix = BakeOptions {
        transfer: TransferKind::Matrix,
        ..vector.clone()
    };
    let threads = rayon::current_num_threads();
    println!(
        "scene {} ({} vertices), order 4, {samples} rays per vertex, {threads} threads",
        scene_path.display(),
        scene.vertex_count()
    );
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("embree");
    let rays = scene.vertex_count() as f64 * f64::from(samples);
    let bake = |options: &BakeOptions| {
        best_of(|| {
            cpu_time(|| {
                prt_baker::bake(&scene, Some(&tracer), options, &Silent).expect("bake");
            })
        })
    };
    let vector_seconds = bake(&vector);
    let matrix_seconds = bake(&matrix);
    let raw_seconds = raw_matrix_rays(&scene, &tracer, &matrix);
    let row = |what: &str, seconds: f64| {
        println!(
            "{what:<52} {seconds:>8.3} s {:>8.2} Mrays/s {:>6.3} x raw",
            rays / seconds / 1e6,
            raw_seconds / seconds
        );
    };
    row(
        "raw embree, the matrix bake's rays (Tracer trait)",
        raw_seconds,
    );
    row("vector bake (cosine-weighted)", vector_seconds);
    row("matrix bake (uniform hemisphere)", matrix_seconds);
    interreflected(&scene, &tracer, &vector);
    outer_products();
}

/// The interreflected matrix with 2 bounces against the vector bakes with 1 and 2 bounces and
/// Embree alone on the rays of its two passes (the vector bake's with 1 bounce, the matrix
/// pass's); rates count both passes' rays.
fn interreflected(scene: &Scene, tracer: &EmbreeTracer, shadowed: &BakeOptions) {
    let vector = |bounces| BakeOptions {
        mode: Mode::Interreflected,
        bounces,
        ..shadowed.clone()
    };
    let matrix = BakeOptions {
        transfer: TransferKind::Matrix,
        ..vector(2)
    };
    let bake = |options: &BakeOptions| {
        best_of(|| {
            cpu_time(|| {
                prt_baker::bake(scene, Some(tracer), options, &Silent).expect("bake");
            })
        })
    };
    let vector1 = bake(&vector(1));
    let vector2 = bake(&vector(2));
    let matrix2 = bake(&matrix);
    let vector_estimator = Estimator::new(scene, &vector(1)).expect("options");
    let raw_vector = raw_rays(scene, tracer, &vector(1), |v, frame, range, dirs| {
        let mut weights = Vec::new();
        vector_estimator.directions(v, frame, range, dirs, &mut weights);
    });
    let local = local_directions(&matrix);
    let raw_matrix = raw_rays(scene, tracer, &matrix, |_, frame, range, dirs| {
        dirs.clear();
        dirs.extend(local[range].iter().map(|d| *frame * *d));
    });
    let raw = raw_vector + raw_matrix;
    let rays = 2.0 * scene.vertex_count() as f64 * f64::from(shadowed.samples);
    println!("interreflected (rates count both passes' rays, the vector's and the matrix's):");
    let row = |what: &str, seconds: f64| {
        println!(
            "{what:<52} {seconds:>8.3} s {:>8.2} Mrays/s {:>6.3} x raw",
            rays / seconds / 1e6,
            raw / seconds
        );
    };
    row("raw embree, both passes' rays (1/4 closest-hit)", raw);
    println!("{:<52} {raw_vector:>8.3} s", "  of which the vector pass's");
    println!(
        "{:<52} {vector1:>8.3} s",
        "vector bake, interreflected, 1 bounce"
    );
    println!(
        "{:<52} {vector2:>8.3} s",
        "vector bake, interreflected, 2 bounces"
    );
    row(
        "matrix bake, interreflected, 2 bounces (both passes)",
        matrix2,
    );
    println!(
        "{:<52} {:>8.3} s {:>15} {:>6.3} x raw",
        "  of which the matrix pass",
        matrix2 - vector1,
        "",
        raw_matrix / (matrix2 - vector1)
    );
}

/// CPU seconds per thread Embree takes for the rays of a pass: per vertex, batches split at
/// the bounce samples' end as the bake splits them, the bounce samples traced for their
/// closest hits and the rest for occlusion; the run that traces them minus the run that only
/// generates them. `directions(v, frame, range, dirs)` gives vertex v's world directions.
fn raw_rays(
    scene: &Scene,
    tracer: &EmbreeTracer,
    options: &BakeOptions,
    directions: impl Fn(usize, &glam::Mat3, std::ops::Range<usize>, &mut Vec<glam::Vec3>) + Sync,
) -> f64 {
    let estimator = Estimator::new(scene, options).expect("options");
    let (samples, bounce) = (
        options.samples as usize,
        options.effective_bounce_samples() as usize,
    );
    let run = |trace: bool| {
        (0..scene.vertex_count()).into_par_iter().for_each_init(
            || (Vec::with_capacity(256), vec![false; 256], vec![None; 256]),
            |(dirs, occluded, hits), v| {
                let frame = estimator.vertex_frame(v);
                let mut start = 0;
                while start < samples {
                    let limit = if start < bounce { bounce } else { samples };
                    let end = (start + 256).min(limit);
                    directions(v, &frame, start..end, dirs);
                    if trace && start < bounce {
                        tracer.intersect_from(estimator.origin(v), dirs, &mut hits[..end - start]);
                    } else if trace {
                        tracer.occluded_from(
                            estimator.origin(v),
                            dirs,
                            &mut occluded[..end - start],
                        );
                    }
                    start = end;
                }
            },
        )
    };
    let generate = best_of(|| cpu_time(|| run(false)));
    best_of(|| cpu_time(|| run(true))) - generate
}

/// CPU seconds per thread that Embree takes for the matrix bake's rays: the run that traces
/// them minus the run that only generates them.
fn raw_matrix_rays(scene: &Scene, tracer: &EmbreeTracer, options: &BakeOptions) -> f64 {
    let estimator = Estimator::new(scene, options).expect("options");
    let local = local_directions(options);
    let run = |trace: bool| {
        (0..scene.vertex_count()).into_par_iter().for_each_init(
            || (Vec::with_capacity(256), vec![false; 256]),
            |(dirs, occluded), v| {
                let frame = estimator.vertex_frame(v);
                for batch in local.chunks(256) {
                    dirs.clear();
                    dirs.extend(batch.iter().map(|d| frame * *d));
                    if trace {
                        tracer.occluded_from(
                            estimator.origin(v),
                            dirs,
                            &mut occluded[..batch.len()],
                        );
                    }
                }
            },
        )
    };
    let generate = best_of(|| cpu_time(|| run(false)));
    best_of(|| cpu_time(|| run(true))) - generate
}

/// The accumulation alone, one thread: 2^22 outer products of order-4 rows into register
/// tiles (the bake's, 192 multiply-adds each), ray by ray into the packed upper triangle
/// (136) and into the full square (256).
fn outer_products() {
    let n = 16;
    let count = 1 << 22;
    let mut rng = Pcg32::new(1, 2);
    let rows: Vec<f32> = (0..256 * n).map(|_| rng.next_f32() - 0.5).collect();
    let time = |f: &mut dyn FnMut()| {
        let started = std::time::Instant::now();
        f();
        started.elapsed().as_secs_f64()
    };
    let mut packed = vec![0.0f32; packed_len(n)];
    let packed_seconds = time(&mut || {
        for k in 0..count {
            let row = &rows[(k % 256) * n..(k % 256 + 1) * n];
            add_outer(std::hint::black_box(&mut packed), row, 1.0);
        }
    });
    let mut full = vec![0.0f32; n * n];
    let full_seconds = time(&mut || {
        for k in 0..count {
            let row = &rows[(k % 256) * n..(k % 256 + 1) * n];
            let acc = std::hint::black_box(&mut full);
            for (i, &yi) in row.iter().enumerate() {
                for (a, &yj) in acc[i * n..(i + 1) * n].iter_mut().zip(row) {
                    *a += yi * yj;
                }
            }
        }
    });
    let layout = TileLayout::new(n);
    let mut tiled = vec![0.0f32; layout.floats()];
    let all: Vec<u32> = (0..256).collect();
    let tiled_seconds = time(&mut || {
        for _ in 0..count / 256 {
            layout.accumulate(&rows, &all, std::hint::black_box(&mut tiled));
        }
    });
    let per = |s: f64| s / count as f64 * 1e9;
    println!(
        "outer products, order 4, one thread: 4x8 register tiles (the bake's) {:.1} ns each \
         ({:.2} G useful multiply-adds/s of the 136)",
        per(tiled_seconds),
        136.0 * count as f64 / tiled_seconds / 1e9
    );
    println!(
        "outer products, order 4, one thread: packed triangle {:.1} ns each ({:.2} G multiply-adds/s), \
         full square {:.1} ns each ({:.2} G/s)",
        per(packed_seconds),
        136.0 * count as f64 / packed_seconds / 1e9,
        per(full_seconds),
        256.0 * count as f64 / full_seconds / 1e9
    );
    // Keep the sums observable.
    assert!(packed[0].is_finite() && full[0].is_finite() && tiled[0].is_finite());
}

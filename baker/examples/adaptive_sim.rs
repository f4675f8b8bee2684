//! What per-vertex allocation can gain on a scene (docs/explanation/performance.md, "Adaptive sampling"):
//! allocation rules simulated from fixed bakes, and a clairvoyant bound.
//!
//! An adaptive vertex that stops at N rays holds exactly the fixed N-ray bake's value for it
//! (same sequence, same frame: `tests/adaptive.rs`), so one fixed bake per size of the
//! adaptive grid (256, 320, 384, … 16,384) gives every vertex's true error at every size it
//! could stop at, and any rule that picks a size per vertex can be scored without baking it:
//! - **bake**: the bake's own rule ([`Tables::net_points`] on the pilot's block spread);
//! - **pooled**: the same with the spread's square averaged over the vertex and its mesh
//!   neighbours (a second pass the bake does not have);
//! - **clairvoyant**: each vertex's error curve fitted log-log to its *true* errors at every
//!   size, the smallest size whose fitted error × 1.2 is ≤ E. It knows the reference, so it
//!   bounds what any honest estimate of a vertex's difficulty could reach.
//!
//! Each rule is scored as the adaptive example scores a bake: mean points per vertex over the
//! rays of the fixed bake with the same p99 error (the fixed curve interpolated log-log). It
//! counts points, not rays: what the bake saves by inferring answers
//! ([`prt_baker::bake::inference`]) comes on top.
//!
//! cargo run --release -p prt-baker --example adaptive_sim -- [SCENE]

#[path = "common/reference.rs"]
mod reference;

use std::path::{Path, PathBuf};

use prt_baker::bake::adaptive::{PILOT_BLOCKS, Tables, block_spread};
use prt_baker::bake::transfer::{Estimator, Scratch};
use prt_baker::math::sh::Basis;
use prt_baker::trace::{EmbreeOptions, EmbreeTracer, Tracer};
use prt_baker::{BakeOptions, Mode, Scene};
use rayon::prelude::*;

const ORDER: usize = 4;
const N: usize = ORDER * ORDER;
const CAP: u32 = 16_384;
const TARGETS: [f64; 5] = [4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4];

fn bake(scene: &Scene, tracer: &dyn Tracer, options: &BakeOptions) -> Vec<f32> {
    let estimator = Estimator::new(scene, options).expect("valid options");
    let per_vertex: Vec<Vec<f32>> = (0..scene.vertex_count())
        .into_par_iter()
        .map_init(
            || Scratch::new(N),
            |scratch, v| {
                let mut out = vec![0.0f32; N];
                estimator.receiver_transfer(v, Some(tracer), scratch, &mut out, None);
                out
            },
        )
        .collect();
    per_vertex.concat()
}

/// Per-vertex RMS coefficient error against the reference.
fn errors(bake: &[f32], reference: &[f32]) -> Vec<f64> {
    bake.chunks(N)
        .zip(reference.chunks(N))
        .map(|(a, r)| {
            let squares: f64 = a.iter().zip(r).map(|(a, r)| f64::from(a - r).powi(2)).sum();
            (squares / N as f64).sqrt()
        })
        .collect()
}

fn p99(mut e: Vec<f64>) -> f64 {
    e.sort_by(f64::total_cmp);
    e[((0.99 * e.len() as f64).ceil() as usize).clamp(1, e.len()) - 1]
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene_path = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("scenes/torus/torus.scene"));
    let scene = Scene::load(&scene_path).unwrap_or_else(|err| panic!("{err}"));
    let tracer = EmbreeTracer::new(&scene, EmbreeOptions::default()).expect("embree");
    let base = BakeOptions {
        order: ORDER,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    // The reference of adaptive_vs_fixed (the same cache file).
    let reference = reference::cached(&root, &scene, 1, 1 << 16, || {
        let options = BakeOptions {
            samples: 1 << 16,
            seed: 12_345,
            ..base.clone()
        };
        bake(&scene, &tracer, &options)
    });
    let vertices = scene.vertex_count();

    // The pilot's blocks (64, 128, 192 points) and every size a vertex may stop at.
    let grid_of = |target: f64| {
        let options = BakeOptions {
            samples: CAP,
            target_error: Some(target as f32),
            ..base.clone()
        };
        Tables::new(&options, &Basis::new(ORDER))
    };
    let tables: Vec<Tables> = TARGETS.iter().map(|&e| grid_of(e)).collect();
    let pilot = tables[0].pilot;
    let mut sizes: Vec<u32> = (1..PILOT_BLOCKS as u32).map(|k| k * pilot).collect();
    sizes.extend(&tables[0].rounds);
    let bakes: Vec<Vec<f32>> = sizes
        .iter()
        .map(|&samples| {
            let options = BakeOptions {
                samples,
                ..base.clone()
            };
            bake(&scene, &tracer, &options)
        })
        .collect();
    let err: Vec<Vec<f64>> = bakes.iter().map(|b| errors(b, &reference)).collect();
    let first_round = PILOT_BLOCKS - 1;
    let fixed: Vec<(f64, f64)> = (first_round..sizes.len())
        .map(|i| (f64::from(sizes[i]), p99(err[i].clone())))
        .collect();

    // Each vertex's pilot spread, from the block sums S(k·m) − S((k−1)·m), S(N) = N·T(N).
    let spread: Vec<f64> = (0..vertices)
        .map(|v| {
            let sum = |i: usize, j: usize| f64::from(sizes[i]) * f64::from(bakes[i][v * N + j]);
            let mut totals = vec![0.0; PILOT_BLOCKS * N];
            for k in 0..PILOT_BLOCKS {
                for j in 0..N {
                    let before = if k == 0 { 0.0 } else { sum(k - 1, j) };
                    totals[k * N + j] = sum(k, j) - before;
                }
            }
            block_spread(&totals, N, pilot)
        })
        .collect();
    let mut ring: Vec<Vec<usize>> = vec![Vec::new(); vertices];
    for t in &scene.triangles {
        for a in t {
            ring[*a as usize].extend(
                t.iter()
                    .map(|&b| b as usize)
                    .filter(|b| b != &(*a as usize)),
            );
        }
    }
    let pooled: Vec<f64> = (0..vertices)
        .map(|v| {
            ring[v].sort_unstable();
            ring[v].dedup();
            let squares: f64 = ring[v].iter().map(|&u| spread[u].powi(2)).sum();
            ((squares + spread[v].powi(2)) / (ring[v].len() + 1) as f64).sqrt()
        })
        .collect();
    // The clairvoyant fit: log error = a + b·log N over every size of the grid.
    let fits: Vec<(f64, f64)> = (0..vertices)
        .map(|v| {
            let points: Vec<(f64, f64)> = (first_round..sizes.len())
                .map(|i| (f64::from(sizes[i]).ln(), err[i][v].max(1e-12).ln()))
                .collect();
            let count = points.len() as f64;
            let (mx, my) = points
                .iter()
                .fold((0.0, 0.0), |(x, y), p| (x + p.0 / count, y + p.1 / count));
            let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
            let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
            let b = sxy / sxx;
            (my - b * mx, b)
        })
        .collect();

    let equivalent = |p: f64| -> f64 {
        fixed
            .windows(2)
            .find_map(|w| {
                (w[0].1 >= p && w[1].1 <= p).then(|| {
                    let t = (w[0].1 / p).ln() / (w[0].1 / w[1].1).ln();
                    w[0].0 * (w[1].0 / w[0].0).powf(t)
                })
            })
            .unwrap_or(f64::NAN)
    };
    println!(
        "{} ({vertices} vertices), order {ORDER}, shadowed; the fixed bakes' p99: {}",
        scene_path.display(),
        fixed
            .iter()
            .map(|(n, p)| format!("{n}: {p:.2e}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    type Rule<'a> = Box<dyn Fn(usize, &Tables) -> u32 + 'a>;
    let rules: [(&str, Rule); 3] = [
        ("bake", Box::new(|v, t: &Tables| t.net_points(spread[v]))),
        ("pooled", Box::new(|v, t: &Tables| t.net_points(pooled[v]))),
        (
            "clairvoyant",
            Box::new(|v, t: &Tables| {
                let (a, b) = fits[v];
                let fitted = |n: u32| 1.2 * (a + b * f64::from(n).ln()).exp();
                t.rounds
                    .iter()
                    .copied()
                    .find(|&n| n >= t.feature_net && fitted(n) <= f64::from(t.target))
                    .unwrap_or(CAP)
            }),
        ),
    ];
    println!("| rule | E | rays per vertex | p99 | fixed rays at that p99 | ratio |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (name, rule) in &rules {
        for (target, t) in TARGETS.iter().zip(&tables) {
            let stops: Vec<(u32, f64)> = (0..vertices)
                .map(|v| {
                    let n = rule(v, t);
                    let i = sizes.iter().position(|&s| s == n).expect("a grid size");
                    (n, err[i][v])
                })
                .collect();
            let total: f64 = stops.iter().map(|&(n, _)| f64::from(n)).sum();
            let realised: Vec<f64> = stops.iter().map(|&(_, e)| e).collect();
            let mean = total / vertices as f64;
            let p = p99(realised);
            let fixed_rays = equivalent(p);
            println!(
                "| {name} | {target:.1e} | {mean:.0} | {p:.2e} | {fixed_rays:.0} | {:.2} |",
                mean / fixed_rays
            );
        }
    }
}

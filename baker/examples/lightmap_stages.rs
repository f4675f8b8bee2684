//! Times the texel bake's preparation and output stages on a scene (on large meshes they,
//! not the rays, set a texel bake's speed): the planar atlas, rasterising, seam texels, seam partners, dilation, seam points and the file's
//! bytes, each `REPEAT` times; prints the fastest wall time of each and a fingerprint of its
//! result, so a change can be checked for both speed and identical output.
//!
//! cargo run --release -p prt-baker --example lightmap_stages -- SCENE [RESOLUTION [REPEAT [FILE.prt]]]

use std::time::Instant;

use prt_baker::lightmap::{self, Texels, atlas::AtlasMethod, stitch};
use prt_baker::support::cpu_time::process_cpu_seconds;
use prt_baker::trace::{self, Backend, TracerOptions};
use prt_baker::{CoefficientFile, Scene};

fn best<T>(repeat: usize, name: &str, mut f: impl FnMut() -> T, print: impl Fn(&T) -> String) -> T {
    let (mut fastest, mut least_cpu) = (f64::INFINITY, f64::INFINITY);
    let mut out = None;
    for _ in 0..repeat {
        let (t, cpu) = (Instant::now(), process_cpu_seconds().unwrap_or(0.0));
        let r = f();
        fastest = fastest.min(t.elapsed().as_secs_f64());
        least_cpu = least_cpu.min(process_cpu_seconds().unwrap_or(0.0) - cpu);
        out = Some(r);
    }
    let out = out.expect("repeat >= 1");
    println!(
        "{name:>14} {fastest:7.3} s (CPU {least_cpu:6.3} s)  {}",
        print(&out)
    );
    out
}

fn hash<T: std::fmt::Debug>(v: &T) -> u64 {
    xxhash_rust::xxh3::xxh3_64(format!("{v:?}").as_bytes())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene = Scene::load(std::path::Path::new(&args[1])).expect("scene");
    let resolution: u32 = args.get(2).map_or(2048, |a| a.parse().expect("resolution"));
    let repeat: usize = args.get(3).map_or(3, |a| a.parse().expect("repeat"));
    let atlas = best(
        repeat,
        "atlas",
        || lightmap::atlas::generate(&scene, resolution, None, AtlasMethod::Planar).unwrap(),
        |g| format!("{} charts, uv {:016x}", g.chart_count, hash(&g.atlas.uv1)),
    )
    .atlas;
    let texels = best(
        repeat,
        "rasterise",
        || Texels::rasterise(&scene, &atlas),
        |t| format!("{} texels, {:016x}", t.valid_count(), t.fingerprint()),
    );
    let tracer = trace::build(Backend::Embree, &scene, TracerOptions::default()).unwrap();
    best(
        repeat,
        "seam texels",
        || {
            texels
                .watertight(&scene, tracer.as_ref())
                .unwrap()
                .is_some()
        },
        |w| format!("watertight view: {w}"),
    );
    let partners = best(
        repeat,
        "seam partners",
        || stitch::seam_partners(&scene, &atlas),
        |p| format!("{:016x}", hash(p)),
    );
    let width = 16;
    let valid = texels.valid_count();
    let receivers: Vec<f32> = (0..valid * width)
        .map(|i| (i % 977) as f32 * 0.01)
        .collect();
    let vis: Vec<prt_baker::bake::transfer::Visibility> = (0..valid)
        .map(|i| prt_baker::bake::transfer::Visibility {
            accessibility: (i % 13) as f32 / 13.0,
            bent_normal: glam::Vec3::new(0.1, (i % 7) as f32, 1.0).normalize(),
            ..Default::default()
        })
        .collect();
    let mut stages = lightmap::Stages::default();
    let placed = best(
        repeat,
        "place+dilate",
        || lightmap::place_unstitched(&texels, width, &receivers, Some(&vis), &mut stages),
        |p| {
            let bytes: Vec<u8> = p
                .coefficients
                .iter()
                .flat_map(|c| c.to_le_bytes())
                .collect();
            format!(
                "{} dilated, {:016x} {:016x}",
                p.dilated.iter().filter(|d| **d).count(),
                xxhash_rust::xxh3::xxh3_64(&bytes),
                hash(&p.visibility)
            )
        },
    );
    println!(
        "   (dilate alone {:.3} s)",
        stages.0.iter().map(|s| s.1).fold(f64::INFINITY, f64::min)
    );
    let stitching = lightmap::Stitching {
        partners: &partners,
        uv1: &atlas.uv1,
    };
    best(
        repeat,
        "seam points",
        || lightmap::seam_samples(&texels, &placed.dilated, &stitching),
        |s| format!("{} samples, {:016x}", s.len(), hash(s)),
    );
    let Some(prt) = args.get(4) else { return };
    let original = std::fs::read(prt).expect("FILE.prt");
    let file = CoefficientFile::from_bytes(&original).expect("a coefficient file");
    best(
        repeat,
        "to_bytes",
        || file.to_bytes(),
        |(b, c)| {
            format!(
                "{} bytes, crc {c:08x}, same as FILE: {}",
                b.len(),
                *b == original
            )
        },
    );
}

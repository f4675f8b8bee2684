//! What the LDPRT oracles (`ldprt.rs`, `skinned.rs`) share: the tube's SH bake, a sun-and-sky
//! rig, and the relit radiance and error they compare.

use std::path::Path;

use prt_baker::light::{LightCoefficients, Rig};
use prt_baker::support::progress::Silent;
use prt_baker::trace::{self, Backend, TracerOptions};
use prt_baker::{BakeOptions, Mode, Scene, Transfer};

/// The SH order every LDPRT oracle bakes and lights at.
pub const ORDER: usize = 4;

pub fn bake(scene: &Scene) -> Transfer {
    let options = BakeOptions {
        order: ORDER,
        samples: 512,
        mode: Mode::Shadowed,
        ..BakeOptions::default()
    };
    let tracer = trace::build(Backend::Obvhs, scene, TracerOptions::default()).unwrap();
    prt_baker::bake(scene, Some(tracer.as_ref()), &options, &Silent).unwrap()
}

/// A warm sun and a sky over a dark ground, as prt-view's default rig; `theta`, `phi` in degrees.
pub fn light(theta: f64, phi: f64) -> LightCoefficients {
    let text = format!(
        "[[light]]\nkind = \"sun\"\ntheta = {theta}\nphi = {phi}\ncolor = [1.0, 0.92, 0.8]\nintensity = 3.0\n\n\
         [[light]]\nkind = \"hemisphere\"\ncolor = [0.15, 0.19, 0.27]\nground_color = [0.05, 0.045, 0.04]\n"
    );
    Rig::parse(&text, Path::new("rig.toml"))
        .unwrap()
        .project(ORDER)
}

/// Relit radiance of a vector bake: albedo · T · L per channel (grey transfer).
pub fn sh_radiance(transfer: &Transfer, scene: &Scene, light: &LightCoefficients) -> Vec<[f32; 3]> {
    let albedo = scene.vertex_albedo();
    (0..scene.vertex_count())
        .map(|v| {
            let t = transfer.vertex(v, 0);
            [0, 1, 2].map(|c| {
                let dot: f64 = t
                    .iter()
                    .zip(&light.rgb[c])
                    .map(|(t, l)| f64::from(*t) * l)
                    .sum();
                (f64::from(albedo[v][c]) * dot) as f32
            })
        })
        .collect()
}

pub fn rms(a: &[[f32; 3]], b: &[[f32; 3]], pick: &[usize]) -> f64 {
    let sum: f64 = pick
        .iter()
        .flat_map(|&v| (0..3).map(move |c| f64::from(a[v][c] - b[v][c]).powi(2)))
        .sum();
    (sum / (3 * pick.len()) as f64).sqrt()
}

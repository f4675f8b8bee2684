//! Local, deformable PRT (LDPRT; Sloan, Luna & Snyder 2005): a vertex bake's SH transfer
//! refitted as zonal-harmonic lobes whose axes live in the vertex's frame ([`frame`]), so
//! the transfer turns with the surface when the mesh is posed or skinned ([`fit`]).
//!
//! What it keeps: the transfer as baked, turned with each vertex's frame: local
//! self-shadowing and interreflection (bumps, ribs, folds, the crease of a joint as far as
//! the baked pose had it). What it cannot keep: occlusion by parts that move relative to the
//! vertex (an arm over the torso, the far side of a bent joint closing in): that stays as
//! the baked pose had it, turned with the vertex.

pub mod fit;
pub mod frame;

use glam::DVec3;
use rayon::prelude::*;

use crate::bake::transfer::Transfer;
use crate::formats::header::TransferKind;
use crate::formats::ldprt_file::{FitError, LdprtFile, topology_fingerprint};
use crate::math::sh::Basis;
use crate::scene::Scene;
use crate::support::error::{Error, Result};

/// Fits `lobes` lobes per vertex to a whole vector bake of `scene` (every vertex a
/// receiver) and packages them with the bake's settings. Deterministic: each vertex's fit
/// depends on its own transfer and frame only.
pub fn fit_bake(scene: &Scene, transfer: &Transfer, lobes: usize) -> Result<LdprtFile> {
    let options = &transfer.options;
    if options.transfer != TransferKind::Vector {
        return Err(Error::InvalidOption(
            "LDPRT fits a vector bake, not transfer matrices".into(),
        ));
    }
    if !(1..=fit::MAX_LOBES).contains(&lobes) {
        return Err(Error::InvalidOption(format!(
            "--lobes {lobes} is outside 1..={}",
            fit::MAX_LOBES
        )));
    }
    let vertices = scene.vertex_count();
    let n = crate::math::sh::coeff_count(options.order);
    if transfer.coefficients.len() != vertices * transfer.channels * n {
        return Err(Error::InvalidOption(
            "LDPRT needs transfer at every vertex of the scene (a whole bake, no --receivers)"
                .into(),
        ));
    }
    let frames = frame::vertex_frames(&scene.positions, &scene.normals, &scene.triangles);
    let fitted = fit_all(
        &transfer.coefficients,
        transfer.channels,
        options.order,
        &frames,
        lobes,
    );
    let mut file = package(&fitted, transfer.channels, options.order, lobes, &frames);
    file.vertex_count = vertices as u64;
    file.samples_per_vertex = options.samples;
    file.mode = options.mode;
    file.bounces = options.bounces;
    file.up = scene.up;
    file.seed = options.seed;
    file.scene_fingerprint = scene.fingerprint();
    file.topology = topology_fingerprint(vertices, &scene.triangles);
    Ok(file)
}

/// The lobes of every vertex of `coefficients` (vertex-major, `channels` × n² each).
pub fn fit_all(
    coefficients: &[f32],
    channels: usize,
    order: usize,
    frames: &[[DVec3; 3]],
    lobes: usize,
) -> Vec<fit::Lobes> {
    let n = crate::math::sh::coeff_count(order);
    let basis = Basis::new(order);
    frames
        .par_iter()
        .enumerate()
        .map(|(v, frame)| {
            let t: Vec<f64> = coefficients[v * channels * n..(v + 1) * channels * n]
                .iter()
                .map(|&x| f64::from(x))
                .collect();
            fit::fit_vertex(&basis, &t, channels, *frame, lobes)
        })
        .collect()
}

/// The file's arrays (axes turned into each vertex's frame) and error summary; the bake's
/// settings are left for the caller.
pub fn package(
    fitted: &[fit::Lobes],
    channels: usize,
    order: usize,
    lobes: usize,
    frames: &[[DVec3; 3]],
) -> LdprtFile {
    let mut axes = Vec::with_capacity(fitted.len() * lobes);
    let mut zh = Vec::with_capacity(fitted.len() * lobes * channels * order);
    for (l, f) in fitted.iter().zip(frames) {
        for a in &l.axes {
            axes.push(frame::to_local(f, *a).normalize().as_vec3().to_array());
        }
        zh.extend(l.g.iter().map(|&g| g as f32));
    }
    let vertex_error: Vec<f32> = fitted.iter().map(|l| l.relative_error as f32).collect();
    LdprtFile {
        order: order as u32,
        lobes: lobes as u32,
        channels: channels as u32,
        vertex_count: fitted.len() as u64,
        samples_per_vertex: 0,
        mode: crate::formats::header::Mode::Shadowed,
        bounces: 0,
        up: crate::scene::Up::Z,
        seed: 0,
        scene_fingerprint: 0,
        topology: 0,
        error: FitError::of(&vertex_error),
        axes,
        zh,
        vertex_error,
        pose: None,
    }
}

/// Per vertex and lobe, the world axis of the file's lobes on the vertex frames `frames`
/// (a pose of the mesh; the frame rule).
pub fn frame_axes(file: &LdprtFile, frames: &[[DVec3; 3]]) -> Vec<DVec3> {
    let k_count = file.lobes as usize;
    (0..file.axes.len())
        .map(|i| {
            let local = DVec3::from_array(file.axes[i].map(f64::from));
            frame::to_world(&frames[i / k_count], local).normalize()
        })
        .collect()
}

/// Per vertex, the (tangent, normal) of its frame in the skinned mesh's bind (object)
/// space: the baked pose's frame (`frames`, `linear` that pose's per-vertex skinning) taken
/// back through the inverse of the vertex's skinning, N_B⁻¹ t and N_B⁻¹ n.
pub fn bind_frames(frames: &[[DVec3; 3]], linear: &[glam::Mat3]) -> Vec<[DVec3; 2]> {
    frames
        .iter()
        .zip(linear)
        .map(|(f, n)| {
            let inverse = n.as_dmat3().inverse();
            [inverse * f[0], inverse * f[2]]
        })
        .collect()
}

/// The frames of a pose from bind-space ones: normal and tangent skinned by each vertex's
/// linear part N_P (as runtimes skin NORMAL and TANGENT), the tangent made orthogonal to the
/// normal, the bitangent n × t. A vertex's lobes turn rigidly with it, so a blend's shear
/// cannot change the angles between them (skinning the axes themselves like normals would,
/// and lobes fitted to cancel each other then no longer do).
pub fn skinned_frames(bind: &[[DVec3; 2]], linear: &[glam::Mat3]) -> Vec<[DVec3; 3]> {
    bind.iter()
        .zip(linear)
        .map(|([t, n], m)| {
            let m = m.as_dmat3();
            let n = (m * *n).normalize_or(DVec3::Z);
            let t = m * *t;
            let t = (t - n * t.dot(n))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            [t, n.cross(t), n]
        })
        .collect()
}

/// Per vertex and channel, the n² SH transfer of the file's lobes in the world frames
/// `frames` (a pose of the mesh): c_l g_l y_l^m(R a) per lobe, summed.
pub fn world_transfer(file: &LdprtFile, frames: &[[DVec3; 3]]) -> Vec<f64> {
    world_transfer_axes(file, &frame_axes(file, frames))
}

/// [`world_transfer`] with every lobe's world axis given (vertex-major, K per vertex).
pub fn world_transfer_axes(file: &LdprtFile, axes: &[DVec3]) -> Vec<f64> {
    let order = file.order as usize;
    let n = crate::math::sh::coeff_count(order);
    let (k_count, channels) = (file.lobes as usize, file.channels as usize);
    let basis = Basis::new(order);
    let per_vertex: Vec<Vec<f64>> = axes
        .par_chunks(k_count)
        .enumerate()
        .map(|(v, vertex_axes)| {
            let mut out = vec![0.0; channels * n];
            let mut y = vec![0.0; n];
            for (k, &axis) in vertex_axes.iter().enumerate() {
                for c in 0..channels {
                    let g: Vec<f64> = file.zh(v, k, c).iter().map(|&x| f64::from(x)).collect();
                    fit::add_lobe(&basis, axis, &g, &mut y, &mut out[c * n..(c + 1) * n]);
                }
            }
            out
        })
        .collect();
    per_vertex.concat()
}

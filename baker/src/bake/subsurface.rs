//! Subsurface transfer: for receivers on a translucent object (a material with a medium, from
//! `bake --materials`), the transfer from the distant light to the radiance that leaves the
//! surface along its normal after scattering inside (`docs/guides/subsurface.md`).
//!
//! # Method: random walks inside the closed mesh
//!
//! Each estimate is a path traced backwards from the receiver, as a volumetric path tracer
//! traces it, with the bake's own tracer finding the boundary:
//!
//! 1. the viewing ray along −n crosses the boundary into the medium with weight 1 − F(0°)
//!    (the specular reflection F is not subsurface light: a glossy matrix can carry it);
//! 2. free flights of length −ln(1 − ξ)/σt; a flight shorter than the distance to the
//!    boundary scatters, isotropically, multiplying the weight by the albedo σs′/σt;
//! 3. at the boundary the path reflects with the Fresnel probability F (1 past the critical
//!    angle) or refracts out along ω by Snell's law;
//! 4. a path that leaves having scattered at least once adds weight × y(ω) to the transfer if ω is unoccluded (shadowed); in
//!    interreflected mode a path whose ω hits an opaque front face adds weight × albedo ×
//!    that point's transfer (light bounced off the rest of the scene).
//!
//! For a homogeneous medium with an isotropic phase function this is exact, up to Monte Carlo
//! noise: single and multiple scattering, thin parts lit from behind, corners and total
//! internal reflection all come out of the walk with no diffusion kernel. The radiance factors
//! η² of entering and leaving cancel, since every counted path enters once and leaves once.
//! Russian roulette ends faint walks without bias. Paths that leave without scattering (light
//! straight through a thin part, or specularly reflected inside) are view-dependent and left
//! out.
//!
//! Channels whose σt is equal share their walks (each weighted by its own albedo); the others
//! walk on their own. Every receiver draws from its own PCG stream seeded by the bake seed and
//! the receiver's index, so a bake does not depend on the thread count.
//!
//! The stored transfer is divided by the material's Kd: the renderer multiplies a receiver's
//! transfer by Kd × texture, so a subsurface receiver renders its walk's radiance times its
//! texture (a tint; white or no texture renders it as baked).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::bake::options::{Mode, TransferKind};
use crate::bake::receivers::BounceTargets;
use crate::bake::transfer::Transfer;
use crate::math::medium::{Medium, fresnel, reflect, refract};
use crate::math::sampling::{Pcg32, uniform_sphere, vertex_seed};
use crate::math::sh::Basis;
use crate::scene::Scene;
use crate::support::error::{Error, Location, Result};
use crate::support::progress::Progress;
use crate::trace::{Hit, Ray, Tracer, offset_distance, ray_origins};

/// Receivers per parallel job.
const RECEIVERS_PER_JOB: usize = 16;
/// Scattering events after which a walk is ended (it would carry a weight of albedo^this).
const MAX_EVENTS: u32 = 100_000;
/// Weights below this face Russian roulette.
const ROULETTE_BELOW: f32 = 0.25;

/// Where subsurface transfer is baked: points on the surface of a translucent material.
#[derive(Clone, Debug, Default)]
pub struct Points {
    /// Receiver index in the bake's output (a vertex, or a lightmap texel's slot).
    pub receiver: Vec<usize>,
    pub position: Vec<Vec3>,
    /// Unit shading normal: the direction the radiance is baked for.
    pub normal: Vec<Vec3>,
    /// A point just inside the surface, where walks start.
    pub inside: Vec<Vec3>,
    /// Index into `Scene::materials` (a material with a medium).
    pub material: Vec<u32>,
}

/// What an exiting path sees when it hits the scene (interreflected mode): the bake's final
/// transfer at every slot of `targets` (the vertices, or the W×H texels of a lightmap, put in
/// place and dilated), `slots[(s · channels + c) · n² + j]`, read as the bounce passes read it.
pub struct Bounced<'a> {
    pub slots: &'a [f32],
    pub channels: usize,
    pub targets: &'a BounceTargets<'a>,
}

/// A subsurface bake's settings.
pub struct Walks<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a dyn Tracer,
    /// Per scene material, its medium (`None`: opaque).
    pub media: &'a [Option<Medium>],
    pub order: usize,
    /// Walks per receiver (per group of channels with equal σt).
    pub samples: u32,
    pub seed: u64,
    /// `None`: shadowed (a leaving path that hits anything sees no light).
    pub bounced: Option<Bounced<'a>>,
}

/// The vertices of `scene` whose material has a medium, as subsurface receivers.
pub fn vertex_points(scene: &Scene, media: &[Option<Medium>]) -> Points {
    let outside = ray_origins(scene);
    let mut points = Points::default();
    for (v, &origin) in outside.iter().enumerate() {
        let material = scene.vertex_material[v];
        if media[material as usize].is_none() {
            continue;
        }
        let p = scene.positions[v];
        points.receiver.push(v);
        points.position.push(p);
        points.normal.push(scene.normals[v]);
        // The outside origin mirrored through the tangent plane: as far below the surface as
        // it is above, and nudged, as it is, into the vertex's own triangles (at a box's
        // corner that keeps it inside the other faces' planes).
        let (n, d) = (scene.normals[v], origin - p);
        points.inside.push(origin - 2.0 * d.dot(n) * n);
        points.material.push(material);
    }
    points
}

/// Checks that the materials with a medium can be rendered from a transfer divided by Kd.
pub fn check_media(scene: &Scene, media: &[Option<Medium>]) -> Result<()> {
    for (material, medium) in scene.materials.iter().zip(media) {
        if medium.is_some() && material.kd.min_element() <= 0.0 {
            return Err(Error::scene(
                Location::file(&scene.path),
                format!(
                    "material `{}` has a medium but a Kd of {}: subsurface transfer is stored \
                     divided by Kd, so every channel must be positive",
                    material.name, material.kd
                ),
            ));
        }
    }
    Ok(())
}

/// Replaces the transfer of `transfer`'s translucent vertices (a vertex bake of `scene`) by
/// their subsurface transfer, making the bake RGB (a grey bake's channel is copied to all
/// three). Interreflected bakes' leaving paths read the bake's own transfer where they hit the
/// rest of the scene. Returns the rays cast.
pub fn apply_to_vertices(
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    transfer: &mut Transfer,
    progress: &dyn Progress,
) -> Result<u64> {
    apply_to_rows(scene, tracer, media, transfer, None, progress)
}

/// [`apply_to_vertices`] for a transfer that holds the vertices `rows` only, in that order
/// (a `--receivers` bake; `None`: every vertex): only those vertices walk. Only a whole
/// transfer can feed interreflected walks the rest of the scene's light.
pub fn apply_to_rows(
    scene: &Scene,
    tracer: &dyn Tracer,
    media: &[Option<Medium>],
    transfer: &mut Transfer,
    rows: Option<&[u32]>,
    progress: &dyn Progress,
) -> Result<u64> {
    check_media(scene, media)?;
    let options = &transfer.options;
    if options.transfer != TransferKind::Vector {
        return Err(Error::InvalidOption(
            "--materials with a subsurface medium needs --transfer vector".into(),
        ));
    }
    if rows.is_some() && options.mode == Mode::Interreflected {
        return Err(Error::InvalidOption(
            "interreflected subsurface walks need the whole bake's transfer".into(),
        ));
    }
    let n = options.order * options.order;
    let mut points = vertex_points(scene, media);
    // Each point's row in the transfer.
    let slots: Vec<usize> = match rows {
        None => points.receiver.clone(),
        Some(rows) => {
            let mut rank = vec![usize::MAX; scene.vertex_count()];
            for (r, &v) in rows.iter().enumerate() {
                rank[v as usize] = r;
            }
            points = points.keep(|v| rank[v] != usize::MAX);
            points.receiver.iter().map(|&v| rank[v]).collect()
        }
    };
    let walks = Walks {
        scene,
        tracer,
        media,
        order: options.order,
        samples: options.samples,
        seed: options.seed,
        bounced: (options.mode == Mode::Interreflected).then_some(Bounced {
            slots: &transfer.coefficients,
            channels: transfer.channels,
            targets: &BounceTargets::Vertices,
        }),
    };
    let (baked, rays) = bake_points(&walks, &points, progress);
    let mut rgb = to_rgb(&transfer.coefficients, transfer.channels, n);
    for (i, &r) in slots.iter().enumerate() {
        rgb[r * 3 * n..(r + 1) * 3 * n].copy_from_slice(&baked[i * 3 * n..(i + 1) * 3 * n]);
        // The walks' transfer replaced the opaque pass's, whose rays' noise estimate no
        // longer holds: the denoiser estimates a walked vertex's from its neighbours.
        if let Some(v) = transfer.visibility.get_mut(r) {
            v.noise = 0.0;
        }
    }
    transfer.coefficients = rgb;
    transfer.channels = 3;
    transfer.rays_cast += rays;
    Ok(rays)
}

impl Points {
    /// The points whose receiver passes `keep`, in order.
    pub fn keep(self, keep: impl Fn(usize) -> bool) -> Points {
        let mut out = Points::default();
        for i in (0..self.receiver.len()).filter(|&i| keep(self.receiver[i])) {
            out.receiver.push(self.receiver[i]);
            out.position.push(self.position[i]);
            out.normal.push(self.normal[i]);
            out.inside.push(self.inside[i]);
            out.material.push(self.material[i]);
        }
        out
    }
}

/// `coefficients` (`channels` of n per receiver) as three channels: grey copied to each.
pub fn to_rgb(coefficients: &[f32], channels: usize, n: usize) -> Vec<f32> {
    match channels {
        3 => coefficients.to_vec(),
        _ => coefficients
            .chunks(n)
            .flat_map(|row| row.iter().chain(row).chain(row).copied())
            .collect(),
    }
}

/// The subsurface transfer of every point: `out[(i · 3 + c) · n² + j]`, divided by the
/// material's Kd; also returns the rays cast.
pub fn bake_points(walks: &Walks, points: &Points, progress: &dyn Progress) -> (Vec<f32>, u64) {
    let basis = Basis::new(walks.order);
    let n = basis.coeff_count();
    let count = points.position.len();
    let mut out = vec![0.0f32; count * 3 * n];
    progress.begin("subsurface", count as u64, u64::from(walks.samples));
    let rays: u64 = out
        .par_chunks_mut(RECEIVERS_PER_JOB * 3 * n)
        .enumerate()
        .map(|(job, out)| {
            let mut sh = vec![0.0f32; n];
            let mut rays = 0u64;
            for (k, out) in out.chunks_mut(3 * n).enumerate() {
                let i = job * RECEIVERS_PER_JOB + k;
                rays += point_transfer(walks, &basis, points, i, &mut sh, out);
            }
            progress.advance((out.len() / (3 * n)) as u64);
            rays
        })
        .sum();
    progress.finish();
    (out, rays)
}

/// One point's transfer into `out` (3 · n²), returning the rays it cast.
fn point_transfer(
    walks: &Walks,
    basis: &Basis,
    points: &Points,
    i: usize,
    sh: &mut [f32],
    out: &mut [f32],
) -> u64 {
    let n = basis.coeff_count();
    let material = points.material[i];
    let medium = walks.media[material as usize].expect("subsurface points have a medium");
    let seed = vertex_seed(walks.seed, points.receiver[i] as u64);
    let mut rng = Pcg32::new(seed, 0x5355_4253_5552_4641);
    let sigma_t = medium.extinction().to_array();
    let albedo = medium.albedo().to_array();
    let normal = points.normal[i];
    // Entering along the normal: the viewing ray is not bent, and loses the reflected F(0°).
    let entry = 1.0 - fresnel(1.0, 1.0 / medium.ior);
    let mut rays = 0u64;
    let mut done = [false; 3];
    for c in 0..3 {
        if done[c] {
            continue;
        }
        // The channels that walk with channel c: those with the same σt.
        let group: [bool; 3] = std::array::from_fn(|k| !done[k] && sigma_t[k] == sigma_t[c]);
        let group_albedo: [f32; 3] =
            std::array::from_fn(|k| if group[k] { albedo[k] } else { 0.0 });
        let mut sums = vec![0.0f64; 3 * n];
        for _ in 0..walks.samples {
            let start = Step {
                position: points.inside[i],
                direction: -normal,
                weight: [entry; 3],
                scattered: false,
            };
            let (exit, cast) = walk(walks, &medium, sigma_t[c], group_albedo, start, &mut rng);
            rays += cast;
            if let Some(exit) = exit {
                rays += gather(walks, basis, &exit, group, sh, &mut sums);
            }
        }
        let kd = walks.scene.materials[material as usize].kd.to_array();
        for k in (0..3).filter(|&k| group[k]) {
            for j in 0..n {
                out[k * n + j] =
                    (sums[k * n + j] / f64::from(walks.samples) / f64::from(kd[k])) as f32;
            }
            done[k] = true;
        }
    }
    rays
}

/// A walk's state: where it is, where it goes, and its weight per channel.
struct Step {
    position: Vec3,
    direction: Vec3,
    weight: [f32; 3],
    /// Whether it has scattered yet.
    scattered: bool,
}

/// Where a walk left the medium: light arriving at `origin` from `direction`, times `weight`,
/// is what the path carries to the receiver.
struct Exit {
    origin: Vec3,
    direction: Vec3,
    weight: [f32; 3],
}

/// One random walk with extinction `sigma_t` from `step`; channels outside the group have
/// albedo 0 and are ignored by the caller. Returns where the path left, if it did, and the
/// rays cast.
fn walk(
    walks: &Walks,
    medium: &Medium,
    sigma_t: f32,
    albedo: [f32; 3],
    mut step: Step,
    rng: &mut Pcg32,
) -> (Option<Exit>, u64) {
    let mut rays = 0u64;
    let mut hit = [None];
    for _ in 0..MAX_EVENTS {
        walks.tracer.intersect(
            &[Ray {
                origin: step.position,
                dir: step.direction,
                tfar: f32::INFINITY,
            }],
            &mut hit,
        );
        rays += 1;
        // An open mesh lets the walk out without a boundary: it carries nothing.
        let Some(h) = hit[0] else {
            return (None, rays);
        };
        let flight = -(1.0 - rng.next_f32()).ln() / sigma_t;
        if flight < h.t {
            step.position += step.direction * flight;
            step.direction = uniform_sphere(rng.next_f32(), rng.next_f32());
            step.scattered = true;
            for (w, a) in step.weight.iter_mut().zip(albedo) {
                *w *= a;
            }
            let strongest = step.weight.iter().copied().fold(0.0f32, f32::max);
            if strongest < ROULETTE_BELOW {
                let survive = strongest / ROULETTE_BELOW;
                if rng.next_f32() >= survive {
                    return (None, rays);
                }
                step.weight = step.weight.map(|w| w / survive);
            }
            continue;
        }
        // Another object inside this one absorbs the walk. (Meshes with equal media, such as
        // an OBJ's groups of one material, bound one medium.)
        let hit_material =
            walks.scene.vertex_material[walks.scene.triangles[h.triangle as usize][0] as usize];
        if walks.media[hit_material as usize] != Some(*medium) {
            return (None, rays);
        }
        let point = step.position + step.direction * h.t;
        let geometric = h.ng.normalize();
        let outward = if geometric.dot(step.direction) > 0.0 {
            geometric
        } else {
            -geometric
        };
        let delta = offset_distance(point, triangle_size(walks.scene, h.triangle));
        let cos_i = step.direction.dot(outward);
        let reflected = rng.next_f32() < fresnel(cos_i, medium.ior);
        let left = match reflected {
            true => None,
            false => refract(step.direction, -outward, medium.ior),
        };
        match left {
            None => {
                step.direction = reflect(step.direction, outward);
                step.position = point - outward * delta;
            }
            // Unscattered light straight through is view-dependent: not subsurface transfer.
            Some(_) if !step.scattered => return (None, rays),
            Some(direction) => {
                let exit = Exit {
                    origin: point + outward * delta,
                    direction,
                    weight: step.weight,
                };
                return (Some(exit), rays);
            }
        }
    }
    (None, rays)
}

/// The longest edge of triangle `t`: the size that scales its ray offsets.
fn triangle_size(scene: &Scene, t: u32) -> f32 {
    let p = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
    p[0].distance(p[1])
        .max(p[1].distance(p[2]))
        .max(p[2].distance(p[0]))
}

/// Adds what a path that left at `exit` carries to `sums` (3 · n², the channels in `group`):
/// the distant light from its direction if that is unoccluded; in interreflected mode, where it
/// hits an opaque front face instead, that point's albedo times its transfer (the light the
/// rest of the scene bounces in). Returns the rays cast.
fn gather(
    walks: &Walks,
    basis: &Basis,
    exit: &Exit,
    group: [bool; 3],
    sh: &mut [f32],
    sums: &mut [f64],
) -> u64 {
    let n = basis.coeff_count();
    let ray = Ray {
        origin: exit.origin,
        dir: exit.direction,
        tfar: f32::INFINITY,
    };
    let channels = (0..3).filter(|&k| group[k]);
    let Some(bounced) = &walks.bounced else {
        let mut occluded = [false];
        walks.tracer.occluded(&[ray], &mut occluded);
        if !occluded[0] {
            basis.eval(exit.direction, sh);
            for k in channels {
                for j in 0..n {
                    sums[k * n + j] += f64::from(exit.weight[k] * sh[j]);
                }
            }
        }
        return 1;
    };
    let mut hit = [None];
    walks.tracer.intersect(&[ray], &mut hit);
    match hit[0] {
        None => {
            basis.eval(exit.direction, sh);
            for k in channels {
                for j in 0..n {
                    sums[k * n + j] += f64::from(exit.weight[k] * sh[j]);
                }
            }
        }
        Some(h) => {
            let scene = walks.scene;
            let tri = scene.triangles[h.triangle as usize];
            let material = scene.vertex_material[tri[0] as usize] as usize;
            // Back faces and translucent surfaces (whose transfer here is not yet their
            // subsurface one) send nothing back.
            if h.ng.dot(exit.direction) >= 0.0 || walks.media[material].is_some() {
                return 1;
            }
            add_bounce(scene, bounced, &h, &exit.weight, group, n, sums);
        }
    }
    1
}

/// Adds weight × albedo × transfer at hit `h` to `sums`: the albedo (Kd × texture) at the
/// hit's uv, the transfer read from the hit's slots as a bounce pass reads it (barycentric
/// over a triangle's vertices, bilinear around a lightmap UV).
fn add_bounce(
    scene: &Scene,
    bounced: &Bounced,
    h: &Hit,
    weight: &[f32; 3],
    group: [bool; 3],
    n: usize,
    sums: &mut [f64],
) {
    let tri = scene.triangles[h.triangle as usize];
    let bary = [1.0 - h.u - h.v, h.u, h.v];
    let uv: Vec2 = (0..3).map(|k| scene.uvs[tri[k] as usize] * bary[k]).sum();
    let albedo = scene.albedo(scene.triangle_material(h.triangle as usize), uv);
    let mut taps = [(0u32, 0.0f32); 4];
    let count = bounced.targets.lookup(scene, h.triangle, bary, &mut taps);
    for k in (0..3).filter(|&k| group[k]) {
        // A grey bake's one channel serves all three.
        let c = k.min(bounced.channels - 1);
        for &(slot, b) in &taps[..count] {
            let factor = weight[k] * b * albedo[k];
            let start = (slot as usize * bounced.channels + c) * n;
            for j in 0..n {
                sums[k * n + j] += f64::from(factor * bounced.slots[start + j]);
            }
        }
    }
}

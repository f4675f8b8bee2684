//! `prt-bake relight` of a transfer-matrix bake: the CPU reference for glossy PRT
//! (docs/guides/glossy.md, "Glossy rendering").
//!
//! Per vertex and colour channel c, with L′ = M·L_c the receiver's shadowed incident radiance
//! (M: channel c's matrix, or the grey one; L_c the rig in the scene's frame):
//!
//! ```text
//!     radiance_c = albedo_c · w · Σ_lm ĝ_l(1) L′_lm y_lm(n)  +  ks_c · Σ_lm ĝ_l(s) L′_lm y_lm(r)
//! ```
//!
//! ([`crate::math::glossy`]: ĝ the normalised Phong lobe's band factors, r the mirror
//! direction of the unit vector from the vertex to the eye). Without a view only the first
//! term is rendered, with w = 1: the diffuse render, which is what a vector bake of the same
//! scene gives up to the band limit. With a view, a material's glossy layer adds the second
//! term and sets w to its diffuse weight; materials without one stay diffuse.
//!
//! A compressed (CPCA) matrix file is rendered the way a GPU renderer does it: the light is
//! projected once through each cluster's mean and components, so a vertex only sums M + 1
//! vectors of n² instead of multiplying an n² × n² matrix; the result is the reconstructed
//! file's up to rounding (tested below).

use glam::Vec3;
use rayon::prelude::*;

use crate::formats::coefficient_file::CoefficientFile;
use crate::light::LightCoefficients;
use crate::math::cpca::Cpca;
use crate::math::glossy::{convolve_at, lobe_bands, reflect};
use crate::math::sh::{self, Basis};
use crate::scene::{Glossy, Scene};

/// What a renderer needs to know of each vertex of the scene.
pub struct Receivers<'a> {
    pub positions: &'a [Vec3],
    pub normals: &'a [Vec3],
    /// Linear diffuse albedo (Kd × texture).
    pub albedo: &'a [Vec3],
    /// Per vertex, an index into `layers`.
    pub material: &'a [u32],
    /// Per material, its glossy layer if it has one.
    pub layers: Vec<Option<Glossy>>,
}

impl<'a> Receivers<'a> {
    pub fn of_scene(scene: &'a Scene, albedo: &'a [Vec3]) -> Receivers<'a> {
        Receivers {
            positions: &scene.positions,
            normals: &scene.normals,
            albedo,
            material: &scene.vertex_material,
            layers: scene.materials.iter().map(|m| m.glossy).collect(),
        }
    }
}

/// Per-vertex linear RGB radiance of a matrix bake lit by `light` (of the file's order, in
/// the scene's frame), seen from `eye` (scene coordinates) if given. With `cpca` (the file's
/// compressed form, `file` its reconstruction) the light is projected per cluster instead.
pub fn matrix_vertex_radiance(
    file: &CoefficientFile,
    cpca: Option<&Cpca>,
    receivers: &Receivers,
    light: &LightCoefficients,
    eye: Option<Vec3>,
) -> Vec<[f32; 3]> {
    let order = file.header.order as usize;
    assert_eq!(light.order(), order, "light and transfer orders differ");
    let channels = file.header.channels as usize;
    let shader = Shader::new(order, receivers, eye);
    match cpca {
        None => shader.shade_all(|v, c, out| {
            let m = file.vertex(v, if channels == 3 { c } else { 0 });
            project(m, &light.rgb[c], out);
        }),
        Some(cpca) => {
            let projected = ClusterProjections::new(cpca, channels, light);
            shader.shade_all(|v, c, out| projected.incident(cpca, v, c, out))
        }
    }
}

/// out = M·l for a row-major n² × n² matrix M.
fn project(m: &[f32], l: &[f64], out: &mut [f64]) {
    let n = l.len();
    for (i, o) in out.iter_mut().enumerate() {
        let row = &m[i * n..(i + 1) * n];
        *o = row.iter().zip(l).map(|(&a, &b)| f64::from(a) * b).sum();
    }
}

/// The light projected through every cluster's mean and components of a compressed matrix
/// bake, per colour channel: `vectors[((k·(M + 1) + i)·3 + c)·n² ..]`, i = 0 the mean,
/// i = 1 + p component p. A GPU renderer does this once per frame (prt-view uploads it); a
/// grey matrix serves every colour channel.
pub struct ClusterProjections {
    n2: usize,
    vectors: Vec<f64>,
}

impl ClusterProjections {
    pub fn new(cpca: &Cpca, channels: usize, light: &LightCoefficients) -> ClusterProjections {
        let n2 = light.rgb[0].len();
        let n4 = n2 * n2;
        assert_eq!(cpca.dim, channels * n4, "CPCA vectors of another size");
        let per_cluster = cpca.pcs + 1;
        let mut vectors = vec![0.0; cpca.clusters() * per_cluster * 3 * n2];
        vectors
            .par_chunks_mut(3 * n2)
            .enumerate()
            .for_each(|(slot, out)| {
                let (k, i) = (slot / per_cluster, slot % per_cluster);
                let x = match i {
                    0 => &cpca.means[k * cpca.dim..(k + 1) * cpca.dim],
                    _ => {
                        let at = (k * cpca.pcs + i - 1) * cpca.dim;
                        &cpca.bases[at..at + cpca.dim]
                    }
                };
                for (c, out) in out.chunks_exact_mut(n2).enumerate() {
                    let mc = if channels == 3 { c } else { 0 };
                    project(&x[mc * n4..(mc + 1) * n4], &light.rgb[c], out);
                }
            });
        ClusterProjections { n2, vectors }
    }

    /// Cluster k's vector i (0 the mean, 1 + p component p) times colour c's light: n² values.
    pub fn vector(&self, k: usize, i: usize, c: usize, pcs: usize) -> &[f64] {
        let at = ((k * (pcs + 1) + i) * 3 + c) * self.n2;
        &self.vectors[at..at + self.n2]
    }

    /// Vertex v's L′ for colour c: its cluster's projected mean plus its weights times the
    /// projected components.
    fn incident(&self, cpca: &Cpca, v: usize, c: usize, out: &mut [f64]) {
        let n2 = self.n2;
        let k = cpca.cluster[v] as usize;
        let per_cluster = cpca.pcs + 1;
        let at = |i: usize| ((k * per_cluster + i) * 3 + c) * n2;
        out.copy_from_slice(&self.vectors[at(0)..at(0) + n2]);
        for p in 0..cpca.pcs {
            let w = f64::from(cpca.weights[v * cpca.pcs + p]);
            let b = &self.vectors[at(p + 1)..at(p + 1) + n2];
            for (o, &x) in out.iter_mut().zip(b) {
                *o += w * x;
            }
        }
    }
}

/// The per-vertex half of the formula: everything but L′.
struct Shader<'a> {
    order: usize,
    receivers: &'a Receivers<'a>,
    eye: Option<Vec3>,
    /// ĝ(1): the clamped cosine over π.
    diffuse_bands: Vec<f64>,
    /// Per material, its glossy layer and the layer's ĝ(s).
    lobes: Vec<Option<(Glossy, Vec<f64>)>>,
}

impl<'a> Shader<'a> {
    fn new(order: usize, receivers: &'a Receivers<'a>, eye: Option<Vec3>) -> Shader<'a> {
        Shader {
            order,
            receivers,
            eye,
            diffuse_bands: bands(1.0, order),
            lobes: receivers
                .layers
                .iter()
                .map(|layer| layer.map(|g| (g, bands(g.exponent, order))))
                .collect(),
        }
    }

    fn shade_all(&self, incident: impl Fn(usize, usize, &mut [f64]) + Sync) -> Vec<[f32; 3]> {
        let n2 = sh::coeff_count(self.order);
        let basis = Basis::new(self.order);
        (0..self.receivers.albedo.len())
            .into_par_iter()
            .map_init(
                || (vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]),
                |(l, y_n, y_r), v| {
                    let n = self.receivers.normals[v].as_dvec3().normalize_or_zero();
                    basis.eval_recurrence(n, y_n);
                    let glossy = self.eye.and_then(|eye| {
                        let lobe = self.lobes[self.receivers.material[v] as usize].as_ref()?;
                        let to_eye = (eye - self.receivers.positions[v]).normalize_or_zero();
                        // The eye at the vertex itself: look along the normal.
                        let to_eye = if to_eye == Vec3::ZERO {
                            n.as_vec3()
                        } else {
                            to_eye
                        };
                        let r = reflect(to_eye, n.as_vec3()).as_dvec3().normalize_or_zero();
                        basis.eval_recurrence(r, y_r);
                        Some(lobe)
                    });
                    let albedo = self.receivers.albedo[v];
                    std::array::from_fn(|c| {
                        incident(v, c, l);
                        let diffuse = convolve_at(l, &self.diffuse_bands, y_n);
                        let value = match glossy {
                            None => f64::from(albedo[c]) * diffuse,
                            Some((layer, g)) => {
                                f64::from(albedo[c] * layer.diffuse_weight) * diffuse
                                    + f64::from(layer.ks[c]) * convolve_at(l, g, y_r)
                            }
                        };
                        value as f32
                    })
                },
            )
            .collect()
    }
}

/// [`lobe_bands`] in f64.
fn bands(exponent: f32, order: usize) -> Vec<f64> {
    lobe_bands(exponent, order)
        .into_iter()
        .map(f64::from)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::coefficient_file::Header;
    use crate::formats::header::TransferKind;
    use crate::math::sampling::Pcg32;
    use glam::DVec3;

    /// A matrix file of `vertices` random symmetric matrices at `order`.
    fn matrix_file(order: u32, channels: u32, vertices: usize) -> CoefficientFile {
        let n2 = sh::coeff_count(order as usize);
        let mut rng = Pcg32::new(7, 11);
        let mut coefficients = Vec::new();
        for _ in 0..vertices * channels as usize {
            let mut m = vec![0.0f32; n2 * n2];
            for i in 0..n2 {
                for j in 0..=i {
                    let x = rng.next_f32() - 0.5;
                    m[i * n2 + j] = x;
                    m[j * n2 + i] = x;
                }
            }
            coefficients.extend(m);
        }
        let file = crate::formats::coefficient_file::fixture(
            order,
            channels,
            vertices as u64,
            coefficients,
        );
        CoefficientFile {
            header: Header {
                mode: crate::Mode::Shadowed,
                transfer: TransferKind::Matrix,
                ..file.header.clone()
            },
            ..file
        }
    }

    fn receivers<'a>(
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        albedo: &'a [Vec3],
    ) -> Receivers<'a> {
        Receivers {
            positions,
            normals,
            albedo,
            material: &[],
            layers: vec![Some(Glossy {
                ks: Vec3::new(0.5, 0.25, 0.125),
                exponent: 12.0,
                diffuse_weight: 0.5,
            })],
        }
    }

    /// Projecting the light through each cluster's mean and components gives what the
    /// reconstructed matrices give, grey and RGB, diffuse and glossy.
    #[test]
    fn cluster_projections_match_the_reconstruction() {
        let vertices = 60;
        let positions: Vec<Vec3> = (0..vertices)
            .map(|v| Vec3::new(v as f32, 0.0, 0.0))
            .collect();
        let normals: Vec<Vec3> = (0..vertices)
            .map(|v| Vec3::new((v as f32).sin(), (v as f32).cos(), 1.0).normalize())
            .collect();
        let albedo = vec![Vec3::new(0.8, 0.6, 0.4); vertices];
        let material = vec![0u32; vertices];
        let mut r = receivers(&positions, &normals, &albedo);
        r.material = &material;
        let mut light = LightCoefficients::tinted(3, &[0.0; 9], glam::DVec3::ONE);
        for (c, channel) in light.rgb.iter_mut().enumerate() {
            for (j, x) in channel.iter_mut().enumerate() {
                *x = ((c * 9 + j) as f64 * 0.37).sin();
            }
        }
        for channels in [1, 3] {
            let original = matrix_file(3, channels, vertices);
            let dim = channels as usize * 81;
            let cpca = crate::math::cpca::compress(&original.coefficients, dim, 5, 4).unwrap();
            let reconstructed = CoefficientFile {
                coefficients: cpca.reconstruct(),
                ..original
            };
            for eye in [None, Some(Vec3::new(3.0, -2.0, 5.0))] {
                let a = matrix_vertex_radiance(&reconstructed, None, &r, &light, eye);
                let b = matrix_vertex_radiance(&reconstructed, Some(&cpca), &r, &light, eye);
                let worst = a
                    .iter()
                    .flatten()
                    .zip(b.iter().flatten())
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0f32, f32::max);
                let scale = a.iter().flatten().fold(0.0f32, |m, x| m.max(x.abs()));
                assert!(scale > 0.1, "{scale}");
                assert!(
                    worst <= 1e-5 * scale,
                    "channels {channels}, eye {eye:?}: {worst}"
                );
            }
        }
    }

    /// An identity matrix passes the whole sphere's light: a directional light E·y(d) then
    /// gives the diffuse term E·Σ_l ĝ_l(1) (2l+1)/(4π) P_l(n·d) and the glossy term the same
    /// with ĝ(s) at r·d (the addition theorem), which the shader must reproduce term by term.
    #[test]
    fn an_identity_matrix_renders_the_convolved_light() {
        let order = 4;
        let n2 = sh::coeff_count(order);
        let mut file = matrix_file(order as u32, 1, 1);
        file.coefficients = (0..n2 * n2)
            .map(|k| f32::from(u8::from(k / n2 == k % n2)))
            .collect();
        let d = DVec3::new(0.3, 0.2, 0.9).normalize();
        let mut y = vec![0.0; n2];
        Basis::new(order).eval_recurrence(d, &mut y);
        let light = LightCoefficients::tinted(order, &y, glam::DVec3::ONE);
        let positions = [Vec3::ZERO];
        let normals = [Vec3::Z];
        let albedo = [Vec3::ONE];
        let material = [0u32];
        let mut r = receivers(&positions, &normals, &albedo);
        r.material = &material;
        let eye = Vec3::new(-1.0, 0.5, 2.0);
        let zonal = |g: &[f32], t: f64| -> f64 {
            g.iter()
                .enumerate()
                .map(|(l, &gl)| {
                    f64::from(gl) * (2 * l + 1) as f64 / (4.0 * std::f64::consts::PI)
                        * sh::legendre(l, 0, t)
                })
                .sum()
        };
        let diffuse = zonal(&lobe_bands(1.0, order), d.z);
        let got = matrix_vertex_radiance(&file, None, &r, &light, None)[0];
        assert!(
            (f64::from(got[0]) - diffuse).abs() < 1e-6,
            "{got:?} {diffuse}"
        );
        let refl = reflect(eye.normalize(), Vec3::Z).as_dvec3();
        let glossy = zonal(&lobe_bands(12.0, order), refl.dot(d));
        let got = matrix_vertex_radiance(&file, None, &r, &light, Some(eye))[0];
        for (c, ks) in [0.5, 0.25, 0.125].into_iter().enumerate() {
            let want = 0.5 * diffuse + ks * glossy;
            assert!(
                (f64::from(got[c]) - want).abs() < 1e-6,
                "{c}: {} vs {want}",
                got[c]
            );
        }
        // An RGB file: channel c's own matrix, (c + 1)·I, lights channel c.
        let mut rgb = matrix_file(order as u32, 3, 1);
        rgb.coefficients = (0..3 * n2 * n2)
            .map(|k| ((k / (n2 * n2)) as f32 + 1.0) * f32::from(u8::from(k / n2 % n2 == k % n2)))
            .collect();
        let coloured = matrix_vertex_radiance(&rgb, None, &r, &light, Some(eye))[0];
        for c in 0..3 {
            let want = (c as f32 + 1.0) * got[c];
            assert!(
                (coloured[c] - want).abs() < 1e-5,
                "{c}: {coloured:?} {got:?}"
            );
        }
    }
}

//! Moving occluders over a lightmap (texel) bake, on the device: the radiance pass
//! ([`crate::texel_radiance`]) evaluates each texel's Σ_jk T_j M_jk V_k itself, with the
//! occluders' spheres in a uniform and each texel's surface point in a buffer.
//!
//! **Why a shader pass, not the CPU.** The per-vertex path (`crate::occluders`) rewrites
//! the transfer on the CPU, T′ = Γ(T, V), and uploads it. For a lightmap that does not keep
//! the frame rate: a sphere reaches 10 radii, so four balls of radius 0.2 reach nearly every
//! texel of the Cornell room, and the 512² lightmap's 262,144 texels × about 2,000
//! multiply-adds each (the spheres' visibilities multiplied, then the RGB triple product)
//! is about 0.5 G multiply-adds a frame; the CPU's scalar loop over a sparse Γ takes 0.5 µs
//! a vertex for one ball (RGB; the Cornell room's 2,944 vertices in 1.5 ms), and four balls'
//! products about as much again, so an estimated 0.25 s a frame on one core, and the
//! rewritten transfer is 50 MB to upload. The same arithmetic in the radiance pass, which already visits each texel
//! once a frame, runs on every lane of the rasteriser (eight texels per instruction on
//! lavapipe) with nothing uploaded but the spheres, because every index in it is a constant:
//! the code is generated per order, Γ's non-zero entries written out as sums (353 at order
//! 4), the SH basis and the cap's zonal coefficients as the baker's recurrences unrolled. The
//! frame-rate cost is in docs/explanation/performance.md.
//!
//! The arithmetic is `prt-bake relight --occluder`'s (`OccludedLight`), in f32: per texel the
//! product of the visibilities of the spheres within reach and above its plane (the baker's
//! [`REACH`] and test), L′ = Γ(L, V) per channel, and Σ_j T_j·L′_j, which equals
//! Σ_jk T_j M_jk V_k (Γ is symmetric). A texel no sphere reaches keeps Σ_j T_j·L_j.

use std::fmt::Write;

use prt_baker::math::occlusion::{REACH, Sphere};
use prt_baker::math::sh::triple::Gaunt;
use prt_baker::math::sh::{coeff_count, index, normalization};
use wgpu::util::DeviceExt;

use crate::bake::Bake;
use crate::error::{Error, Result};

/// The most spheres (all occluders together) the uniform holds.
pub const MAX_SPHERES: usize = 64;
/// The highest order the generated pass is built for (order 6: 2,000-odd Γ entries a product).
pub const MAX_ORDER: usize = 6;

/// The spheres as the shader reads them.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct OccluderUniform {
    count: u32,
    pad: [u32; 3],
    /// Centre xyz, radius w.
    spheres: [[f32; 4]; MAX_SPHERES],
}

/// The occluded radiance pass's resources: its bind group (group 1: the spheres, the texels'
/// points) and the shader source it is built from.
#[derive(Debug)]
pub struct TexelOccluders {
    uniform: wgpu::Buffer,
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    /// Spheres placed this frame (0: the plain pass runs).
    pub count: usize,
}

impl TexelOccluders {
    /// For a lightmap bake of order ≤ [`MAX_ORDER`]: uploads each texel's point and normal
    /// (where `prt-bake relight` puts it, padding texels at their nearest covered texel's).
    pub fn new(device: &wgpu::Device, bake: &Bake) -> Result<TexelOccluders> {
        let Some(block) = bake.lightmap() else {
            return Err(Error::InvalidOption(
                "texel occluders need a lightmap bake".into(),
            ));
        };
        if bake.order() > MAX_ORDER {
            return Err(Error::InvalidOption(format!(
                "{}: --mover-occluder shadows lightmaps of order up to {MAX_ORDER} (this one is order {}); `prt-bake relight --occluder` relights any order",
                bake.file_path.display(),
                bake.order()
            )));
        }
        let (points, normals) =
            prt_baker::export::relight_occluded::texel_points(&bake.scene, block);
        let packed: Vec<[f32; 4]> = points
            .iter()
            .zip(&normals)
            // w = 0 marks a texel no triangle covers (no normal; its transfer is zero).
            .flat_map(|(p, n)| {
                let covered = f32::from(u8::from(*n != glam::Vec3::ZERO));
                [p.extend(covered).to_array(), n.extend(0.0).to_array()]
            })
            .collect();
        let points = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("texel points"),
            contents: bytemuck::cast_slice(&packed),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("occluder spheres"),
            contents: bytemuck::bytes_of(&OccluderUniform::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty,
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("texel occluders"),
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                entry(
                    1,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("texel occluders"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: points.as_entire_binding(),
                },
            ],
        });
        Ok(TexelOccluders {
            uniform,
            layout,
            bind_group,
            count: 0,
        })
    }

    /// This frame's spheres (all occluders', placed in the scene); an error past
    /// [`MAX_SPHERES`].
    pub fn set_spheres(&mut self, queue: &wgpu::Queue, spheres: &[Sphere]) -> Result<()> {
        if spheres.len() > MAX_SPHERES {
            return Err(Error::InvalidOption(format!(
                "{} occluder spheres in all; a lightmap is shadowed by at most {MAX_SPHERES}",
                spheres.len()
            )));
        }
        let mut uniform = OccluderUniform::zeroed();
        uniform.count = spheres.len() as u32;
        for (u, s) in uniform.spheres.iter_mut().zip(spheres) {
            *u = s.centre.as_vec3().extend(s.radius as f32).to_array();
        }
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        self.count = spheres.len();
        Ok(())
    }
}

use bytemuck::Zeroable;

/// A float as a WGSL literal.
fn lit(x: f64) -> String {
    format!("({:.9e})", x as f32)
}

/// The WGSL of the occluded radiance pass at `order` for `channels` channels, reading the
/// transfer from the buffer (`in_buffer`) or the texture array; appended to common.wgsl and
/// texel_radiance.wgsl. Entry point `fs_texel_radiance_occluded`.
pub fn shader_source(order: usize, channels: usize, in_buffer: bool) -> String {
    let n2 = coeff_count(order);
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "struct Occluders {{ count: u32, pad0: u32, pad1: u32, pad2: u32, spheres: array<vec4<f32>, {MAX_SPHERES}> }}\n\
         @group(1) @binding(0) var<uniform> occluders: Occluders;\n\
         // Texel p's surface point at 2p (w = 1; 0 where no triangle covers it), its normal at 2p + 1.\n\
         @group(1) @binding(1) var<storage, read> texel_points: array<vec4<f32>>;\n"
    );
    // The real SH basis by the baker's recurrence (basis.rs), unrolled.
    let _ = writeln!(
        w,
        "fn occ_basis(d: vec3<f32>) -> array<f32, {n2}> {{\n    var y: array<f32, {n2}>;\n    let c0 = 1.0;\n    let s0 = 0.0;"
    );
    for m in 0..order {
        if m > 0 {
            let _ = writeln!(
                w,
                "    let c{m} = c{p} * d.x - s{p} * d.y;\n    let s{m} = c{p} * d.y + s{p} * d.x;",
                p = m - 1
            );
        }
        let qmm: f64 = (1..=m).map(|k| -((2 * k - 1) as f64)).product();
        for l in m..order {
            let q = if l == m {
                lit(qmm)
            } else if l == m + 1 {
                format!("d.z * {}", lit((2 * m + 1) as f64 * qmm))
            } else {
                format!(
                    "(d.z * {} * q{}_{m} - {} * q{}_{m})",
                    lit((2 * l - 1) as f64 / (l - m) as f64),
                    l - 1,
                    lit((l + m - 1) as f64 / (l - m) as f64),
                    l - 2
                )
            };
            let _ = writeln!(w, "    let q{l}_{m} = {q};");
            let k = normalization(l, m as i32);
            if m == 0 {
                let _ = writeln!(w, "    y[{}] = {} * q{l}_0;", index(l, 0), lit(k));
            } else {
                let k = lit(std::f64::consts::SQRT_2 * k);
                let (mi, ni) = (index(l, m as i32), index(l, -(m as i32)));
                let _ = writeln!(
                    w,
                    "    y[{mi}] = {k} * q{l}_{m} * c{m};\n    y[{ni}] = {k} * q{l}_{m} * s{m};"
                );
            }
        }
    }
    let _ = writeln!(w, "    return y;\n}}\n");
    // One sphere's visibility (occlusion.rs): 1 − the cap it blocks, zero inside it.
    let _ = writeln!(
        w,
        "fn occ_sphere(p: vec3<f32>, sphere: vec4<f32>) -> array<f32, {n2}> {{\n    var y: array<f32, {n2}>;\n    let to_centre = sphere.xyz - p;\n    let d = length(to_centre);\n    if d <= sphere.w {{ return y; }}\n    let sin_a = sphere.w / d;\n    let t = sqrt(1.0 - sin_a * sin_a);\n    y = occ_basis(to_centre / d);\n    let p0 = 1.0;\n    let p1 = t;"
    );
    for l in 1..order {
        let _ = writeln!(
            w,
            "    let p{} = ({} * t * p{l} - {} * p{});",
            l + 1,
            lit((2 * l + 1) as f64 / (l + 1) as f64),
            lit(l as f64 / (l + 1) as f64),
            l - 1
        );
    }
    let four_pi = 4.0 * std::f64::consts::PI;
    for l in 0..order {
        let base =
            -(four_pi / (2 * l + 1) as f64).sqrt() * std::f64::consts::TAU * normalization(l, 0);
        let scale = if l == 0 {
            format!("{} * (1.0 - t)", lit(base))
        } else {
            format!(
                "{} * (p{} - p{})",
                lit(base / (2 * l + 1) as f64),
                l - 1,
                l + 1
            )
        };
        let _ = writeln!(w, "    let a{l} = {scale};");
        for m in -(l as i32)..=l as i32 {
            let _ = writeln!(w, "    y[{i}] = y[{i}] * a{l};", i = index(l, m));
        }
    }
    let _ = writeln!(
        w,
        "    y[0] = y[0] + {};\n    return y;\n}}\n",
        lit(four_pi.sqrt())
    );
    // Γ written out: out_i = Σ_jk Γ_ijk a_j b_k, for scalars and for RGB light times scalars.
    let gaunt = Gaunt::new(order);
    let mut terms: Vec<Vec<String>> = vec![Vec::new(); n2];
    for &(i, j, k, g) in gaunt.entries() {
        terms[i as usize].push(format!("{} * a[{j}] * b[{k}]", lit(g)));
    }
    for (name, ty) in [("occ_product", "f32"), ("occ_light", "vec3<f32>")] {
        let _ = writeln!(
            w,
            "fn {name}(a: array<{ty}, {n2}>, b: array<f32, {n2}>) -> array<{ty}, {n2}> {{\n    var o: array<{ty}, {n2}>;"
        );
        for (i, t) in terms.iter().enumerate() {
            let _ = writeln!(w, "    o[{i}] = {};", t.join(" + "));
        }
        let _ = writeln!(w, "    return o;\n}}\n");
    }
    // The pass: visibilities of the spheres in reach, then Σ_j T_j·Γ(L, V)_j.
    let m4 = n2.div_ceil(4);
    let fetch = |c: usize, q: usize| {
        if in_buffer {
            format!("transfer_texel_vec4s[base + {}u]", c * m4 + q)
        } else {
            format!("textureLoad(transfer_texels, texel, {}, 0)", c * m4 + q)
        }
    };
    let plain = if in_buffer {
        "prt_radiance_texel_buffer"
    } else {
        "prt_radiance_texel_array"
    };
    let _ = writeln!(
        w,
        "@fragment\nfn fs_texel_radiance_occluded(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {{\n    let texel = vec2<u32>(frag.xy);\n    let p_index = texel.y * frame.lightmap_width + texel.x;\n    let at = texel_points[2u * p_index];\n    if at.w == 0.0 {{ return vec4<f32>({plain}(texel), 1.0); }}\n    let point = at.xyz;\n    let normal = texel_points[2u * p_index + 1u].xyz;\n    var v: array<f32, {n2}>;\n    var any = false;\n    for (var s = 0u; s < occluders.count; s++) {{\n        let sphere = occluders.spheres[s];\n        let offset = sphere.xyz - point;\n        if length(offset) > {reach} * sphere.w || dot(offset, normal) < -sphere.w {{ continue; }}\n        let one = occ_sphere(point, sphere);\n        if any {{ v = occ_product(v, one); }} else {{ v = one; any = true; }}\n    }}\n    if !any {{ return vec4<f32>({plain}(texel), 1.0); }}\n    var l: array<vec3<f32>, {n2}>;",
        reach = lit(REACH)
    );
    for j in 0..n2 {
        let _ = writeln!(w, "    l[{j}] = light[{j}].rgb;");
    }
    let _ = writeln!(
        w,
        "    let lv = occ_light(l, v);\n    let base = p_index * {}u;\n    var radiance = vec3<f32>(0.0);",
        channels * m4
    );
    for q in 0..m4 {
        let (r, g, b) = if channels == 3 {
            (fetch(0, q), fetch(1, q), fetch(2, q))
        } else {
            (fetch(0, q), format!("r{q}"), format!("r{q}"))
        };
        let _ = writeln!(
            w,
            "    let r{q} = {r};\n    let g{q} = {g};\n    let b{q} = {b};"
        );
        for (e, comp) in ["x", "y", "z", "w"].iter().enumerate() {
            let j = 4 * q + e;
            if j < n2 {
                let _ = writeln!(
                    w,
                    "    radiance += vec3<f32>(r{q}.{comp}, g{q}.{comp}, b{q}.{comp}) * lv[{j}];"
                );
            }
        }
    }
    let _ = writeln!(w, "    return vec4<f32>(radiance, 1.0);\n}}");
    s
}

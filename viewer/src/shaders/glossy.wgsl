// Glossy PRT from a transfer-matrix bake (after common.wgsl; glossy.rs is the Rust side).
//
// Per vertex: the shadowed incident radiance L′ = M·L (n² coefficients, RGB), then
//     diffuse = Σ_lm ĝ_l(1) L′_lm y_lm(n)      (times Kd × texture × the diffuse weight)
//     glossy  = Σ_lm ĝ_l(s) L′_lm y_lm(r)      (times Ks), r = reflect(to_eye, n)
// as prt_baker::math::glossy states it. L′ comes either from the matrix itself (an
// uncompressed bake: n⁴ products per vertex) or, for a CPCA-compressed bake, from the light
// projected through the vertex's cluster mean and components once per frame on the CPU: the
// vertex then only weights M + 1 vectors of n².

// The largest order a matrix bake is shown at (MAX_GLOSSY_ORDER in glossy.rs): n² ≤ 64.
const MAX_N2: u32 = 64u;

struct GlossyParams {
    // Rows of the rotation from the viewer's z-up frame into the bake's frame (y-up bakes
    // are turned on loading; the transfer and the light stay in the bake's frame).
    to_bake: mat3x3<f32>,
    // ĝ_l(1): the clamped cosine over π, band l at [l / 4][l % 4].
    diffuse_bands: array<vec4<f32>, 2>,
    // The SH order n.
    order: u32,
    // 1: L′ from `projected`; 0: from the matrix (`transfer`, group 0).
    compressed: u32,
    // M: principal components per cluster.
    pcs: u32,
    pad: u32,
    // The basis's normalisation per coefficient index (√2·K_l^|m| for m ≠ 0, K_l^0).
    sh_scale: array<vec4<f32>, 16>,
}

// Material (common.wgsl) carries the per-material lobe: ks, the diffuse weight and ĝ_l(s).
@group(2) @binding(0) var<uniform> glossy: GlossyParams;
// Compressed bakes: each vertex's cluster, its M weights, and per cluster k and vector p
// (0 the mean, 1 + i component i) the light's projection, coefficient i at
// (k·(M + 1) + p)·n² + i.
@group(2) @binding(1) var<storage, read> cluster_of: array<u32>;
@group(2) @binding(2) var<storage, read> pca_weights: array<f32>;
@group(2) @binding(3) var<storage, read> projected: array<vec4<f32>>;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) uv1: vec2<f32>,
}

fn band_of(bands: array<vec4<f32>, 2>, l: u32) -> f32 {
    return bands[l / 4u][l % 4u];
}

fn scale_of(i: u32) -> f32 {
    return glossy.sh_scale[i / 4u][i % 4u];
}

// y_i(d) for i < n², by the baker's recurrence (math/sh/basis.rs): Q_l^m = P_l^m/(1−z²)^{m/2}
// times Re/Im (x + iy)^m, with the Condon–Shortley phase in Q_m^m.
fn sh_eval(d: vec3<f32>) -> array<f32, MAX_N2> {
    var out: array<f32, MAX_N2>;
    let n = glossy.order;
    var c = 1.0;
    var s = 0.0;
    var qmm = 1.0;
    for (var m = 0u; m < n; m++) {
        if m > 0u {
            let c_next = c * d.x - s * d.y;
            s = c * d.y + s * d.x;
            c = c_next;
            qmm *= -f32(2u * m - 1u);
        }
        var q2 = 0.0;
        var q1 = qmm;
        for (var l = m; l < n; l++) {
            var q = qmm;
            if l == m + 1u {
                q = d.z * f32(2u * m + 1u) * qmm;
            } else if l > m + 1u {
                q = (d.z * f32(2u * l - 1u) * q1 - f32(l + m - 1u) * q2) / f32(l - m);
            }
            if l > m {
                q2 = q1;
                q1 = q;
            }
            let centre = l * l + l;
            let k = scale_of(centre + m) * q;
            if m == 0u {
                out[centre] = k;
            } else {
                out[centre + m] = k * c;
                out[centre - m] = k * s;
            }
        }
    }
    return out;
}

// L′_i, RGB, for vertex v.
fn incident(v: u32, i: u32) -> vec3<f32> {
    let n2 = frame.coefficient_count;
    if glossy.compressed != 0u {
        let vectors = glossy.pcs + 1u;
        let first = cluster_of[v] * vectors;
        var t = projected[first * n2 + i].rgb;
        for (var p = 0u; p < glossy.pcs; p++) {
            t += pca_weights[v * glossy.pcs + p] * projected[(first + 1u + p) * n2 + i].rgb;
        }
        return t;
    }
    var t = vec3<f32>(0.0);
    if frame.channels == 3u {
        let row = (3u * v * n2 + i) * n2;
        let step = n2 * n2;
        for (var j = 0u; j < n2; j++) {
            let m = vec3<f32>(transfer[row + j], transfer[row + step + j], transfer[row + 2u * step + j]);
            t += m * light[j].rgb;
        }
    } else {
        let row = (v * n2 + i) * n2;
        for (var j = 0u; j < n2; j++) {
            t += transfer[row + j] * light[j].rgb;
        }
    }
    return t;
}

struct GlossyTerms {
    // Σ ĝ_l(1) L′ y(n): times Kd × texture × the diffuse weight.
    diffuse: vec3<f32>,
    // Σ ĝ_l(s) L′ y(r): times Ks.
    glossy: vec3<f32>,
}

// The two sums for vertex v at `position` with `normal` (the viewer's z-up frame), seen
// from the camera. This is the one place they are computed; the probe reads them back.
fn glossy_terms(v: u32, position: vec3<f32>, normal: vec3<f32>) -> GlossyTerms {
    let n = normalize(normal);
    let to_eye = normalize(frame.camera_position.xyz - position);
    let r = 2.0 * dot(n, to_eye) * n - to_eye;
    let yn = sh_eval(normalize(glossy.to_bake * n));
    let yr = sh_eval(normalize(glossy.to_bake * r));
    var out: GlossyTerms;
    out.diffuse = vec3<f32>(0.0);
    out.glossy = vec3<f32>(0.0);
    for (var l = 0u; l < glossy.order; l++) {
        let gd = band_of(glossy.diffuse_bands, l);
        let gs = band_of(material.glossy_bands, l);
        for (var i = l * l; i < (l + 1u) * (l + 1u); i++) {
            let t = incident(v, i);
            out.diffuse += gd * yn[i] * t;
            out.glossy += gs * yr[i] * t;
        }
    }
    return out;
}

struct GlossyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) diffuse: vec3<f32>,
    @location(1) glossy: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

// Per vertex, as the diffuse PRT path: both sums, interpolated.
@vertex
fn vs_glossy(in: VertexIn, @builtin(vertex_index) v: u32) -> GlossyOut {
    var out: GlossyOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    let terms = glossy_terms(v, in.position, in.normal);
    out.diffuse = terms.diffuse;
    out.glossy = terms.glossy;
    out.uv = in.uv;
    return out;
}

@fragment
fn fs_glossy(in: GlossyOut) -> @location(0) vec4<f32> {
    if !covered(in.uv, in.clip.xy) {
        discard;
    }
    let diffuse = in.diffuse * albedo(in.uv) * material.ks.w;
    return tone_map(diffuse + material.ks.rgb * in.glossy);
}

// The probe (glossy.rs): vertex v as one point at pixel (v mod PROBE_WIDTH, v div
// PROBE_WIDTH) of two float targets, the diffuse and the glossy sum, nothing interpolated.
const PROBE_WIDTH: u32 = 256u;
override PROBE_ROWS: f32 = 1.0;

struct ProbeOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) diffuse: vec4<f32>,
    @location(1) @interpolate(flat) glossy: vec4<f32>,
}

struct ProbeTargets {
    @location(0) diffuse: vec4<f32>,
    @location(1) glossy: vec4<f32>,
}

@vertex
fn vs_glossy_probe(in: VertexIn, @builtin(vertex_index) v: u32) -> ProbeOut {
    let x = f32(v % PROBE_WIDTH) + 0.5;
    let y = f32(v / PROBE_WIDTH) + 0.5;
    var out: ProbeOut;
    out.clip = vec4<f32>(2.0 * x / f32(PROBE_WIDTH) - 1.0, 1.0 - 2.0 * y / PROBE_ROWS, 0.0, 1.0);
    let terms = glossy_terms(v, in.position, in.normal);
    out.diffuse = vec4<f32>(terms.diffuse, 1.0);
    out.glossy = vec4<f32>(terms.glossy, 1.0);
    return out;
}

@fragment
fn fs_glossy_probe(in: ProbeOut) -> ProbeTargets {
    var out: ProbeTargets;
    out.diffuse = in.diffuse;
    out.glossy = in.glossy;
    return out;
}

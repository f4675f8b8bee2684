// Shared by the scene, line and probe shaders (prepended to each): the per-frame uniform,
// the transfer and light buffers, the material, and the tone map of `prt-bake relight`.
// The Rust mirror of these structs is in renderer.rs.

const PI: f32 = 3.14159265358979;

struct PhongLight {
    // xyz: unit vector toward the light (directional) or the sky's zenith (hemisphere);
    // w: 0 directional, 1 hemisphere.
    direction: vec4<f32>,
    // Directional: irradiance E on a facing surface; hemisphere: the sky's radiance.
    colour: vec4<f32>,
    // Hemisphere: the ground's radiance.
    ground: vec4<f32>,
}

struct Frame {
    view_projection: mat4x4<f32>,
    camera_position: vec4<f32>,
    // n² of the transfer and of the light.
    coefficient_count: u32,
    // 1: grey transfer serves every colour channel; 3: R, G, B transfer.
    channels: u32,
    use_textures: u32,
    // 2^exposure.
    exposure_scale: f32,
    light_count: u32,
    // A texel bake's lightmap width W.
    lightmap_width: u32,
    pad1: u32,
    pad2: u32,
    // Blinn-Phong: radiance from every direction (constant skies, environment means).
    ambient: vec4<f32>,
    lights: array<PhongLight, 8>,
}

struct Material {
    // rgb Kd, w the base colour factor's alpha.
    kd: vec4<f32>,
    has_texture: u32,
    // 0 opaque, 1 MASK (discard below the cutoff), 2 hashed (glTF BLEND, OBJ map_d).
    alpha_mode: u32,
    // The coverage texture's channel: 3 alpha, 0 red (grey map_d images), 4 none.
    alpha_channel: u32,
    alpha_cutoff: f32,
    // Glossy PRT (matrix bakes, glossy.wgsl): rgb Ks, w the diffuse term's weight (1 for a
    // material without a glossy layer, whose Ks is 0).
    ks: vec4<f32>,
    // ĝ_l(s) of the material's Phong lobe, band l at [l / 4][l % 4] (orders up to 8).
    glossy_bands: array<vec4<f32>, 2>,
    // The base colour texture's KHR_texture_transform: rows (a, b, c) of a·u + b·v + c in
    // glTF's texture coordinates (v down from the image's top).
    uv_transform: array<vec4<f32>, 2>,
    // The coverage texture's.
    alpha_uv_transform: array<vec4<f32>, 2>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
// The coefficient file's payload as is: vertex v, channel c, coefficient j at
// (v·channels + c)·n² + j.
@group(0) @binding(1) var<storage, read> transfer: array<f32>;
// The summed, rotated light: coefficient j's (R, G, B) at j.
@group(0) @binding(2) var<storage, read> light: array<vec4<f32>>;
// A lightmap (texel) bake's transfer (texel_transfer.rs), in one of two layouts (the other
// binding, and both for vertex bakes, a placeholder). With m = ⌈n²/4⌉, channel c's
// coefficients 4l..4l + 3 of texel (x, y) (p = y·W + x) are at: layer c·m + l, texel (x, y)
// of the array; vec4 (p·C + c)·m + l of the buffer.
@group(0) @binding(3) var transfer_texels: texture_2d_array<f32>;
@group(0) @binding(4) var<storage, read> transfer_texel_vec4s: array<vec4<f32>>;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var albedo_texture: texture_2d<f32>;
@group(1) @binding(2) var albedo_sampler: sampler;
// The coverage texture (alpha): the base colour texture for glTF, an OBJ map_d's own image.
@group(1) @binding(3) var alpha_texture: texture_2d<f32>;

// Σ_j T_j·L_j per channel for vertex v: the light a vertex sends out per unit albedo. This
// is the one place the PRT dot product is computed; the probe reads it back for the tests.
fn prt_radiance(v: u32) -> vec3<f32> {
    let n2 = frame.coefficient_count;
    var radiance = vec3<f32>(0.0);
    if frame.channels == 3u {
        let base = 3u * v * n2;
        for (var j = 0u; j < n2; j++) {
            let t = vec3<f32>(transfer[base + j], transfer[base + n2 + j], transfer[base + 2u * n2 + j]);
            radiance += t * light[j].rgb;
        }
    } else {
        let base = v * n2;
        for (var j = 0u; j < n2; j++) {
            radiance += transfer[base + j] * light[j].rgb;
        }
    }
    return radiance;
}

// Σ_j T_j·L_j per channel of lightmap texel (x, y): prt_radiance for a texel bake, computed
// once per texel and frame into the radiance map (texel_radiance.wgsl) that the PRT
// fragment shader samples. Layer c·⌈n²/4⌉ + l holds channel c's coefficients 4l..4l + 3
// (texel_transfer.rs; the light buffer is padded with zeros to a multiple of four), so every
// vector is indexed by constants: CPU rasterisers run a vector indexed by a variable as
// scalar code.
// Σ_j T_j·L_j per channel of lightmap texel (x, y): prt_radiance for a texel bake, computed
// once per texel and frame into the radiance map (texel_radiance.wgsl) that the PRT
// fragment shader samples. Each vec4 holds four coefficients of one channel (the light
// buffer is padded with zeros to a multiple of four), so no vector is indexed by a variable:
// CPU rasterisers run that as scalar code. Grey transfer: one vec4 serves all three channels.
fn texel_dot(r: vec4<f32>, g: vec4<f32>, b: vec4<f32>, j: u32) -> vec3<f32> {
    return vec3<f32>(r.x, g.x, b.x) * light[j].rgb + vec3<f32>(r.y, g.y, b.y) * light[j + 1u].rgb
        + vec3<f32>(r.z, g.z, b.z) * light[j + 2u].rgb + vec3<f32>(r.w, g.w, b.w) * light[j + 3u].rgb;
}

// From the buffer (texel_transfer.rs: texel-major, contiguous per texel).
fn prt_radiance_texel_buffer(texel: vec2<u32>) -> vec3<f32> {
    let m = (frame.coefficient_count + 3u) / 4u;
    let base = (texel.y * frame.lightmap_width + texel.x) * frame.channels * m;
    let step = select(0u, m, frame.channels == 3u);
    var radiance = vec3<f32>(0.0);
    for (var l = 0u; l < m; l++) {
        let r = transfer_texel_vec4s[base + l];
        var g = r;
        var b = r;
        if step != 0u {
            g = transfer_texel_vec4s[base + step + l];
            b = transfer_texel_vec4s[base + 2u * step + l];
        }
        radiance += texel_dot(r, g, b, 4u * l);
    }
    return radiance;
}

// From the texture array (where the buffer would exceed the device's limit).
fn prt_radiance_texel_array(texel: vec2<u32>) -> vec3<f32> {
    let m = (frame.coefficient_count + 3u) / 4u;
    let step = select(0u, m, frame.channels == 3u);
    var radiance = vec3<f32>(0.0);
    for (var l = 0u; l < m; l++) {
        let r = textureLoad(transfer_texels, texel, l, 0);
        var g = r;
        var b = r;
        if step != 0u {
            g = textureLoad(transfer_texels, texel, step + l, 0);
            b = textureLoad(transfer_texels, texel, 2u * step + l, 0);
        }
        radiance += texel_dot(r, g, b, 4u * l);
    }
    return radiance;
}

// A scene uv (OBJ's convention, v up from the image's bottom; textures are stored top row
// first) in glTF's convention, through a material's texture transform.
fn texture_uv(uv: vec2<f32>, transform: array<vec4<f32>, 2>) -> vec2<f32> {
    let g = vec3<f32>(uv.x, 1.0 - uv.y, 1.0);
    return vec2<f32>(dot(transform[0].xyz, g), dot(transform[1].xyz, g));
}

// Linear albedo Kd × texture (the texture is sRGB, so sampling returns linear values).
fn albedo(uv: vec2<f32>) -> vec3<f32> {
    let texel = textureSample(albedo_texture, albedo_sampler, texture_uv(uv, material.uv_transform)).rgb;
    let textured = material.has_texture != 0u && frame.use_textures != 0u;
    return material.kd.rgb * select(vec3<f32>(1.0), texel, textured);
}

// Whether the fragment at `pixel` (its framebuffer position) is drawn: the material's
// coverage (Kd's alpha × the coverage texture's channel) against the cutoff (MASK), or against
// a hash of the pixel (hashed transparency: kept with probability = coverage, as the baker's
// rays are stopped). Opaque materials draw everything. Fragment entry points discard where
// this is false.
fn covered(uv: vec2<f32>, pixel: vec2<f32>) -> bool {
    let texel = textureSample(alpha_texture, albedo_sampler, texture_uv(uv, material.alpha_uv_transform));
    var coverage = material.kd.w;
    if material.alpha_channel == 3u {
        coverage *= texel.a;
    } else if material.alpha_channel == 0u {
        coverage *= texel.r;
    }
    if material.alpha_mode == 1u {
        return coverage >= material.alpha_cutoff;
    }
    if material.alpha_mode == 2u {
        return pixel_hash(vec2<u32>(pixel)) < coverage;
    }
    return true;
}

// A number in [0, 1) per pixel (a 2D integer hash), the threshold of hashed transparency.
fn pixel_hash(p: vec2<u32>) -> f32 {
    var h = p.x * 0x8da6b343u ^ p.y * 0xd8163841u;
    h = (h ^ (h >> 16u)) * 0x7feb352du;
    h = (h ^ (h >> 15u)) * 0x846ca68bu;
    h = h ^ (h >> 16u);
    return f32(h >> 8u) / 16777216.0;
}

// `prt-bake relight`'s display colour: × 2^exposure, clamped to [0, 1]; the sRGB framebuffer
// encodes it.
fn tone_map(radiance: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(clamp(radiance * frame.exposure_scale, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

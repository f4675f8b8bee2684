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
    pad0: u32,
    pad1: u32,
    pad2: u32,
    // Blinn-Phong: radiance from every direction (constant skies, environment means).
    ambient: vec4<f32>,
    lights: array<PhongLight, 8>,
}

struct Material {
    kd: vec4<f32>,
    has_texture: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> frame: Frame;
// The coefficient file's payload as is: vertex v, channel c, coefficient j at
// (v·channels + c)·n² + j.
@group(0) @binding(1) var<storage, read> transfer: array<f32>;
// The summed, rotated light: coefficient j's (R, G, B) at j.
@group(0) @binding(2) var<storage, read> light: array<vec4<f32>>;
// A lightmap (texel) bake's transfer (texel_transfer.rs): coefficient i = c·n² + j of texel
// (x, y) at layer i / 4, component i mod 4. Vertex bakes bind a 1×1 placeholder.
@group(0) @binding(3) var transfer_texels: texture_2d_array<f32>;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var albedo_texture: texture_2d<f32>;
@group(1) @binding(2) var albedo_sampler: sampler;

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

// Where the bilinear filter of the lightmap reads, and with what weights. Texel (x, y) covers
// uv·(W, H) ∈ [x, x+1] × [y, y+1], so its value sits at its centre; outside the outermost
// centres the edge texels are held (clamp to edge). Charts are dilated 2 texels deep, so the
// four texels read at a chart's edge all hold the chart's values. Computed once per pixel,
// then read for every layer.
struct Bilinear {
    lo: vec2<i32>,
    hi: vec2<i32>,
    f: vec2<f32>,
}

fn bilinear(uv1: vec2<f32>) -> Bilinear {
    let size = vec2<i32>(textureDimensions(transfer_texels));
    let p = uv1 * vec2<f32>(size) - vec2<f32>(0.5);
    let corner = floor(p);
    let last = size - vec2<i32>(1);
    var b: Bilinear;
    b.lo = clamp(vec2<i32>(corner), vec2<i32>(0), last);
    b.hi = clamp(vec2<i32>(corner) + vec2<i32>(1), vec2<i32>(0), last);
    b.f = p - corner;
    return b;
}

// The lightmap's packed coefficients of `layer`, filtered bilinearly by hand (Rgba32Float is
// not filterable everywhere).
fn texel_coefficients(b: Bilinear, layer: u32) -> vec4<f32> {
    let t00 = textureLoad(transfer_texels, vec2<i32>(b.lo.x, b.lo.y), layer, 0);
    let t10 = textureLoad(transfer_texels, vec2<i32>(b.hi.x, b.lo.y), layer, 0);
    let t01 = textureLoad(transfer_texels, vec2<i32>(b.lo.x, b.hi.y), layer, 0);
    let t11 = textureLoad(transfer_texels, vec2<i32>(b.hi.x, b.hi.y), layer, 0);
    return mix(mix(t00, t10, b.f.x), mix(t01, t11, b.f.x), b.f.y);
}

// Σ_j T_j·L_j per channel at lightmap coordinate uv1: prt_radiance for a texel bake, with the
// transfer filtered per pixel. A triangle left out of the atlas (uv1 = (−1, −1)) has no
// transfer and is black. Grey transfer takes four coefficients per layer at once (the light
// buffer is padded with zeros to a multiple of four); RGB walks (c, j) along the packing,
// without a division per coefficient (slow on CPU rasterisers).
fn prt_radiance_texel(uv1: vec2<f32>) -> vec3<f32> {
    if any(uv1 < vec2<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let b = bilinear(uv1);
    let n2 = frame.coefficient_count;
    var radiance = vec3<f32>(0.0);
    if frame.channels != 3u {
        for (var layer = 0u; 4u * layer < n2; layer++) {
            let t = texel_coefficients(b, layer);
            let j = 4u * layer;
            radiance += t.x * light[j].rgb + t.y * light[j + 1u].rgb + t.z * light[j + 2u].rgb
                + t.w * light[j + 3u].rgb;
        }
        return radiance;
    }
    var c = 0u;
    var j = 0u;
    for (var layer = 0u; 4u * layer < 3u * n2; layer++) {
        let t = texel_coefficients(b, layer);
        for (var k = 0u; k < 4u && c < 3u; k++) {
            radiance[c] += t[k] * light[j][c];
            j++;
            if j == n2 {
                j = 0u;
                c++;
            }
        }
    }
    return radiance;
}

// Linear albedo Kd × texture (the texture is sRGB, so sampling returns linear values).
fn albedo(uv: vec2<f32>) -> vec3<f32> {
    // OBJ's v runs up from the bottom of the image; textures are stored top row first.
    let texel = textureSample(albedo_texture, albedo_sampler, vec2<f32>(uv.x, 1.0 - uv.y)).rgb;
    let textured = material.has_texture != 0u && frame.use_textures != 0u;
    return material.kd.rgb * select(vec3<f32>(1.0), texel, textured);
}

// `prt-bake relight`'s display colour: × 2^exposure, clamped to [0, 1]; the sRGB framebuffer
// encodes it.
fn tone_map(radiance: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(clamp(radiance * frame.exposure_scale, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

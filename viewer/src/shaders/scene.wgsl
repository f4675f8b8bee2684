// The scene in either shading model (after common.wgsl).

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    // Lightmap uv (texel bakes).
    @location(3) uv1: vec2<f32>,
}

struct PrtOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) radiance: vec3<f32>,
    @location(1) uv: vec2<f32>,
}

// PRT: the dot product per vertex, interpolated, times the albedo per pixel.
@vertex
fn vs_prt(in: VertexIn, @builtin(vertex_index) v: u32) -> PrtOut {
    var out: PrtOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    out.radiance = prt_radiance(v);
    out.uv = in.uv;
    return out;
}

@fragment
fn fs_prt(in: PrtOut) -> @location(0) vec4<f32> {
    if !covered(in.uv, in.clip.xy) {
        discard;
    }
    return tone_map(in.radiance * albedo(in.uv));
}

struct PrtTexelOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) uv1: vec2<f32>,
}

// A texel bake's radiance map (texel_radiance.rs): Σ_j T_j·L_j per texel for this frame's
// light, sampled bilinearly (texel centres at (x + ½, y + ½)/(W, H), held at the edges).
@group(2) @binding(0) var texel_radiance: texture_2d<f32>;
@group(2) @binding(1) var texel_radiance_sampler: sampler;

// PRT from a lightmap (texel) bake: the radiance map filtered at the pixel's lightmap uv
// (equal, by linearity, to the filtered transfer dotted with the light), times the albedo. A
// triangle left out of the atlas (uv1 = (−1, −1)) has no transfer and is black.
@vertex
fn vs_prt_texel(in: VertexIn) -> PrtTexelOut {
    var out: PrtTexelOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    out.uv = in.uv;
    out.uv1 = in.uv1;
    return out;
}

@fragment
fn fs_prt_texel(in: PrtTexelOut) -> @location(0) vec4<f32> {
    if !covered(in.uv, in.clip.xy) {
        discard;
    }
    var radiance = vec3<f32>(0.0);
    if all(in.uv1 >= vec2<f32>(0.0)) {
        radiance = textureSampleLevel(texel_radiance, texel_radiance_sampler, in.uv1, 0.0).rgb;
    }
    return tone_map(radiance * albedo(in.uv));
}

struct PhongOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

// Specular reflectance at normal incidence (a dielectric's 4 %) and the Blinn-Phong exponent:
// the scenes carry only a diffuse Kd, so the specular part is the viewer's choice.
const SPECULAR: f32 = 0.04;
const SHININESS: f32 = 32.0;

@vertex
fn vs_phong(in: VertexIn) -> PhongOut {
    var out: PhongOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    out.world = in.position;
    out.normal = in.normal;
    out.uv = in.uv;
    return out;
}

// Per pixel: diffuse E·max(n·l, 0)/π per directional light (a facing white surface gets E/π,
// as under PRT), hemisphere skies, ambient, and an energy-normalised Blinn-Phong highlight.
@fragment
fn fs_phong(in: PhongOut) -> @location(0) vec4<f32> {
    if !covered(in.uv, in.clip.xy) {
        discard;
    }
    let n = normalize(in.normal);
    let to_eye = normalize(frame.camera_position.xyz - in.world);
    var diffuse = frame.ambient.rgb;
    var specular = vec3<f32>(0.0);
    for (var i = 0u; i < frame.light_count; i++) {
        let l = frame.lights[i];
        let cos_theta = dot(n, l.direction.xyz);
        if l.direction.w > 0.5 {
            diffuse += mix(l.ground.rgb, l.colour.rgb, 0.5 + 0.5 * cos_theta);
        } else if cos_theta > 0.0 {
            let h = normalize(l.direction.xyz + to_eye);
            let lobe = SPECULAR * (SHININESS + 8.0) / (8.0 * PI) * pow(max(dot(n, h), 0.0), SHININESS);
            diffuse += l.colour.rgb * cos_theta / PI;
            specular += l.colour.rgb * lobe * cos_theta;
        }
    }
    return tone_map(albedo(in.uv) * diffuse + specular);
}

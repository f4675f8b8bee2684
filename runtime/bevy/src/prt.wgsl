// PrtMaterial's shaders: StandardMaterial with its diffuse lighting replaced by PRT, radiance =
// albedo · (1 − metallic) · clamp(Σ_j T_j·L_j) per channel (docs/reference/gltf.md), plus,
// with PRT_SPECULAR, Bevy's own specular from the scene's Bevy lights.
//
// Per vertex, the vertex stage dots the transfer attributes (PRT_T0…) into the light and
// hands the result on as the vertex colour; the fragment stage takes it back out of the
// StandardMaterial's inputs (so that a metal's F0 is its base colour, not T·L) and
// multiplies it in. Per texel, the fragment stage samples the transfer array on TEXCOORD_1.
#import bevy_pbr::{
    mesh_functions,
    forward_io::{VertexOutput, FragmentOutput},
    view_transformations::position_world_to_clip,
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::{alpha_discard, apply_pbr_lighting, main_pass_post_lighting_processing},
}

struct PrtUniform {
    // Per colour channel c and group k, light[c * groups + k]: coefficients 4k..4k+3.
    light: array<vec4<f32>, 36>,
    groups: u32,
    rgb: u32,
    clamp_shading: u32,
    exposure: f32,
}

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> prt: PrtUniform;
@group(#{MATERIAL_BIND_GROUP}) @binding(101) var prt_transfer: texture_2d_array<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(102) var prt_sampler: sampler;

// The transfer's VEC4 a of channel c, group k: grey files share one set.
fn attribute_index(c: u32, k: u32) -> u32 {
    return select(k, c * prt.groups + k, prt.rgb != 0u);
}

fn finish(s: vec3<f32>) -> vec3<f32> {
    var shading = s;
    if prt.clamp_shading != 0u {
        shading = clamp(shading, vec3(0.0), vec3(1.0));
    }
    return shading * prt.exposure;
}

struct Vertex {
    @builtin(instance_index) instance_index: u32,
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
#ifdef PRT_TEXEL
    @location(3) uv_b: vec2<f32>,
#else
    @location(3) t0: vec4<f32>,
#ifdef PRT_T1
    @location(4) t1: vec4<f32>,
#endif
#ifdef PRT_T2
    @location(5) t2: vec4<f32>,
#endif
#ifdef PRT_T3
    @location(6) t3: vec4<f32>,
#endif
#ifdef PRT_T4
    @location(7) t4: vec4<f32>,
#endif
#ifdef PRT_T5
    @location(8) t5: vec4<f32>,
#endif
#ifdef PRT_T6
    @location(9) t6: vec4<f32>,
#endif
#ifdef PRT_T7
    @location(10) t7: vec4<f32>,
#endif
#ifdef PRT_T8
    @location(11) t8: vec4<f32>,
#endif
#ifdef PRT_T9
    @location(12) t9: vec4<f32>,
#endif
#ifdef PRT_T10
    @location(13) t10: vec4<f32>,
#endif
#ifdef PRT_T11
    @location(14) t11: vec4<f32>,
#endif
#endif
}

#ifndef PRT_TEXEL
fn vertex_shading(v: Vertex) -> vec3<f32> {
    var t: array<vec4<f32>, 12>;
    t[0] = v.t0;
#ifdef PRT_T1
    t[1] = v.t1;
#endif
#ifdef PRT_T2
    t[2] = v.t2;
#endif
#ifdef PRT_T3
    t[3] = v.t3;
#endif
#ifdef PRT_T4
    t[4] = v.t4;
#endif
#ifdef PRT_T5
    t[5] = v.t5;
#endif
#ifdef PRT_T6
    t[6] = v.t6;
#endif
#ifdef PRT_T7
    t[7] = v.t7;
#endif
#ifdef PRT_T8
    t[8] = v.t8;
#endif
#ifdef PRT_T9
    t[9] = v.t9;
#endif
#ifdef PRT_T10
    t[10] = v.t10;
#endif
#ifdef PRT_T11
    t[11] = v.t11;
#endif
    var s = vec3(0.0);
    for (var c = 0u; c < 3u; c++) {
        for (var k = 0u; k < prt.groups; k++) {
            s[c] += dot(t[attribute_index(c, k)], prt.light[c * prt.groups + k]);
        }
    }
    return finish(s);
}
#endif

@vertex
fn vertex(v: Vertex) -> VertexOutput {
    var out: VertexOutput;
    let world_from_local = mesh_functions::get_world_from_local(v.instance_index);
    out.world_normal = mesh_functions::mesh_normal_local_to_world(v.normal, v.instance_index);
    out.world_position = mesh_functions::mesh_position_local_to_world(world_from_local, vec4<f32>(v.position, 1.0));
    out.position = position_world_to_clip(out.world_position.xyz);
#ifdef VERTEX_UVS_A
    out.uv = v.uv;
#endif
#ifdef PRT_TEXEL
    out.uv_b = v.uv_b;
#else
    out.color = vec4(vertex_shading(v), 1.0);
#endif
#ifdef VERTEX_OUTPUT_INSTANCE_INDEX
    out.instance_index = v.instance_index;
#endif
#ifdef VISIBILITY_RANGE_DITHER
    out.visibility_range_dither = mesh_functions::get_visibility_range_dither_level(v.instance_index, world_from_local[3]);
#endif
    return out;
}

#ifdef PRT_TEXEL
fn texel_shading(uv: vec2<f32>) -> vec3<f32> {
    var s = vec3(0.0);
    for (var c = 0u; c < 3u; c++) {
        for (var k = 0u; k < prt.groups; k++) {
            let t = textureSampleLevel(prt_transfer, prt_sampler, uv, attribute_index(c, k), 0.0);
            s[c] += dot(t, prt.light[c * prt.groups + k]);
        }
    }
    return finish(s);
}
#endif

@fragment
fn fragment(in: VertexOutput, @builtin(front_facing) is_front: bool) -> FragmentOutput {
    var material_in = in;
#ifdef PRT_TEXEL
    let shading = texel_shading(in.uv_b);
#else
    let shading = in.color.rgb;
    material_in.color = vec4(1.0);
#endif
    var pbr_input = pbr_input_from_standard_material(material_in, is_front);
    let base = pbr_input.material.base_color;
    var color = vec4(base.rgb * (1.0 - pbr_input.material.metallic) * shading, base.a);
#ifdef PRT_SPECULAR
    // Bevy's own lighting with its diffuse made zero: calculate_diffuse_color multiplies by
    // (1 − diffuse_transmission), and F0 does not depend on it; the transmitted lobe is drawn
    // only under STANDARD_MATERIAL_DIFFUSE_TRANSMISSION, which a PrtMaterial never sets.
    var specular_input = pbr_input;
    specular_input.material.diffuse_transmission = 1.0;
    specular_input.material.emissive = vec4(0.0);
    color = vec4(color.rgb + apply_pbr_lighting(specular_input).rgb, color.a);
#endif
    color = alpha_discard(pbr_input.material, color);
    var out: FragmentOutput;
    out.color = main_pass_post_lighting_processing(pbr_input, color);
    return out;
}

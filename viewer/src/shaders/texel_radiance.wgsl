// The radiance map of a texel bake (texel_radiance.rs, after common.wgsl): one full-screen
// triangle over the W×H map, whose fragment at pixel (x, y) is texel (x, y)'s Σ_j T_j·L_j.
// Pixel centres are at (x + ½, y + ½), and framebuffer row y is texture row y, the texel row
// the scene's sampler reads at v = (y + ½)/H.

@vertex
fn vs_texel_radiance(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (−1, −1), (3, −1), (−1, 3): covers the whole target.
    let corner = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(2.0 * corner - vec2<f32>(1.0), 0.0, 1.0);
}

@fragment
fn fs_texel_radiance_buffer(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(prt_radiance_texel_buffer(vec2<u32>(p.xy)), 1.0);
}

@fragment
fn fs_texel_radiance_array(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(prt_radiance_texel_array(vec2<u32>(p.xy)), 1.0);
}

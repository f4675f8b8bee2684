// The on-screen readout: one quad per character from the 5×7 font atlas (font.rs), in pixels
// from the top-left corner.

struct Overlay {
    screen: vec2<f32>,
    pad: vec2<f32>,
}

@group(0) @binding(0) var<uniform> overlay: Overlay;
// One row of 5×7 glyphs, R8: 1 where a glyph has a pixel.
@group(0) @binding(1) var atlas: texture_2d<f32>;

const CELL: vec2<f32> = vec2<f32>(5.0, 7.0);

struct GlyphIn {
    @location(0) origin: vec2<f32>,
    @location(1) size: vec2<f32>,
    @location(2) glyph: u32,
    @location(3) colour: vec4<f32>,
}

struct GlyphOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) texel: vec2<f32>,
    @location(1) @interpolate(flat) glyph: u32,
    @location(2) colour: vec4<f32>,
}

@vertex
fn vs_glyph(@builtin(vertex_index) corner: u32, in: GlyphIn) -> GlyphOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(0.0, 1.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0),
    );
    let c = corners[corner];
    let pixel = in.origin + c * in.size;
    var out: GlyphOut;
    out.clip = vec4<f32>(2.0 * pixel.x / overlay.screen.x - 1.0, 1.0 - 2.0 * pixel.y / overlay.screen.y, 0.0, 1.0);
    out.texel = c * CELL;
    out.glyph = in.glyph;
    out.colour = in.colour;
    return out;
}

@fragment
fn fs_glyph(in: GlyphOut) -> @location(0) vec4<f32> {
    let t = vec2<u32>(clamp(in.texel, vec2<f32>(0.0), CELL - vec2<f32>(0.5)));
    let on = textureLoad(atlas, vec2<u32>(in.glyph * 5u + t.x, t.y), 0).r;
    if on < 0.5 {
        discard;
    }
    return in.colour;
}

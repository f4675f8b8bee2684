// Normals and light vectors as coloured lines (after common.wgsl).

struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) colour: vec4<f32>,
}

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) colour: vec4<f32>,
}

@vertex
fn vs_line(in: LineIn) -> LineOut {
    var out: LineOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    out.colour = in.colour;
    return out;
}

@fragment
fn fs_line(in: LineOut) -> @location(0) vec4<f32> {
    return in.colour;
}

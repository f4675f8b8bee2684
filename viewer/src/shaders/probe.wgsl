// The per-vertex check (after common.wgsl): vertex v is drawn as one point at pixel
// (v mod PROBE_WIDTH, v div PROBE_WIDTH) of a float target, coloured with prt_radiance(v),
// the very function the PRT vertex shader calls.

const PROBE_WIDTH: u32 = 256u;
override PROBE_ROWS: f32 = 1.0;

struct ProbeOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) radiance: vec4<f32>,
}

@vertex
fn vs_probe(@builtin(vertex_index) v: u32) -> ProbeOut {
    let x = f32(v % PROBE_WIDTH) + 0.5;
    let y = f32(v / PROBE_WIDTH) + 0.5;
    var out: ProbeOut;
    out.clip = vec4<f32>(2.0 * x / f32(PROBE_WIDTH) - 1.0, 1.0 - 2.0 * y / PROBE_ROWS, 0.0, 1.0);
    out.radiance = vec4<f32>(prt_radiance(v), 1.0);
    return out;
}

@fragment
fn fs_probe(in: ProbeOut) -> @location(0) vec4<f32> {
    return in.radiance;
}

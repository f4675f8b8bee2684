// The moving object and the transfer probes (after common.wgsl; probe_scene.rs).

// The moving object: its vertices placed and coloured on the CPU (linear radiance, albedo
// included), tone-mapped as the scene is.
struct MoverIn {
    @location(0) position: vec3<f32>,
    @location(1) colour: vec4<f32>,
}

struct MoverOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) colour: vec4<f32>,
}

@vertex
fn vs_mover(in: MoverIn) -> MoverOut {
    var out: MoverOut;
    out.clip = frame.view_projection * vec4<f32>(in.position, 1.0);
    out.colour = in.colour;
    return out;
}

@fragment
fn fs_mover(in: MoverOut) -> @location(0) vec4<f32> {
    return vec4<f32>(clamp(in.colour.rgb * frame.exposure_scale, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

// Each valid probe's incident radiance L_in = M·L with band l scaled by A_l/π (the clamped
// cosine): probe i's coefficient j (R, G, B) at i·n² + j, n² = frame.coefficient_count.
@group(1) @binding(0) var<storage, read> incident: array<vec4<f32>>;

struct SphereOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) @interpolate(flat) probe: u32,
}

// A unit sphere's vertex (position = normal), per instance the probe's centre and radius.
@vertex
fn vs_probe_sphere(
    @location(0) unit: vec3<f32>,
    @location(1) centre: vec4<f32>,
    @builtin(instance_index) probe: u32,
) -> SphereOut {
    var out: SphereOut;
    out.clip = frame.view_projection * vec4<f32>(centre.xyz + centre.w * unit, 1.0);
    out.normal = unit;
    out.probe = probe;
    return out;
}

// Σ_j c_j y_j(d) of probe `probe`'s coefficients: here E(d)/π, a white diffuse ball's
// radiance where its normal is d, evaluated per pixel
// (real SH, Condon–Shortley phase, index l(l+1)+m, θ from +z: the baker's basis.rs).
fn incident_radiance(probe: u32, d: vec3<f32>) -> vec3<f32> {
    let count = frame.coefficient_count;
    let order = u32(round(sqrt(f32(count))));
    let base = probe * count;
    let x = clamp(d.z, -1.0, 1.0);
    let s = sqrt(max(0.0, 1.0 - x * x));
    let phi = atan2(d.y, d.x);
    var sum = vec3<f32>(0.0);
    var pmm = 1.0;
    for (var m = 0u; m < order; m++) {
        if m > 0u {
            pmm = -pmm * f32(2u * m - 1u) * s;
        }
        var p_prev = 0.0;
        var p = pmm;
        for (var l = m; l < order; l++) {
            if l == m + 1u {
                p_prev = p;
                p = x * f32(2u * m + 1u) * pmm;
            } else if l > m + 1u {
                let next = (x * f32(2u * l - 1u) * p - f32(l + m - 1u) * p_prev) / f32(l - m);
                p_prev = p;
                p = next;
            }
            // K_l^m = sqrt((2l+1)/(4π) · (l−m)!/(l+m)!).
            var ratio = 1.0;
            for (var k = l - m + 1u; k <= l + m; k++) {
                ratio = ratio / f32(k);
            }
            let kp = sqrt(f32(2u * l + 1u) / (4.0 * PI) * ratio) * p;
            let centre = base + l * (l + 1u);
            if m == 0u {
                sum += kp * incident[centre].rgb;
            } else {
                let a = f32(m) * phi;
                sum += 1.41421356 * kp * (cos(a) * incident[centre + m].rgb + sin(a) * incident[centre - m].rgb);
            }
        }
    }
    return sum;
}

@fragment
fn fs_probe_sphere(in: SphereOut) -> @location(0) vec4<f32> {
    let radiance = incident_radiance(in.probe, normalize(in.normal));
    return vec4<f32>(clamp(radiance * frame.exposure_scale, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}

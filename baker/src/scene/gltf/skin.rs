//! Skins and animations: the nodes' local transforms in a [`Pose`], and linear-blend skinning
//! of a skinned mesh's vertices on the CPU (glTF 2.0 §3.7.3):
//!
//! ```text
//! p' = Σ_k w_k · J_k · IBM_k · p
//! ```
//!
//! with J_k the joint node's world matrix in the pose and IBM_k its inverse bind matrix
//! (identity where the skin gives none, as the specification says). Normals take the same
//! blend of the matrices' linear parts, normalised after, as three.js and most runtimes skin
//! them. The skinned mesh node's own transform is ignored (the specification's rule).

use glam::{Mat3, Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};

use super::accessors::check;
use super::pose::Pose;

/// Each node's local matrix (by index in the file) in `pose`.
pub fn node_locals(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    pose: &Pose,
) -> Result<Vec<Mat4>, String> {
    let mut trs: Vec<(Vec3, Quat, Vec3)> = document
        .nodes()
        .map(|node| {
            let (t, r, s) = node.transform().decomposed();
            (Vec3::from(t), Quat::from_array(r), Vec3::from(s))
        })
        .collect();
    let matrices = |trs: &[(Vec3, Quat, Vec3)]| {
        trs.iter()
            .map(|(t, r, s)| Mat4::from_scale_rotation_translation(*s, *r, *t))
            .collect()
    };
    let (animation, time) = match pose {
        // The file's matrices as written (a decomposition would round them).
        Pose::Rest => {
            return Ok(document
                .nodes()
                .map(|n| Mat4::from_cols_array_2d(&n.transform().matrix()))
                .collect());
        }
        Pose::Time { animation, seconds } => (find(document, animation)?, *seconds),
        Pose::Keyframe { animation, index } => {
            let found = find(document, animation)?;
            let mut times = Vec::new();
            for channel in found.channels() {
                times.extend(read_channel(document, buffers, &channel)?.0);
            }
            times.sort_by(f32::total_cmp);
            times.dedup();
            let time = *times.get(*index).ok_or_else(|| {
                format!(
                    "pose '{pose}': animation '{animation}' has {} keyframes (0..{})",
                    times.len(),
                    times.len()
                )
            })?;
            (found, time)
        }
    };
    for channel in animation.channels() {
        let (inputs, outputs) = read_channel(document, buffers, &channel)?;
        let node = channel.target().node().index();
        let cubic = channel.sampler().interpolation() == Interpolation::CubicSpline;
        let per_key = if cubic { 3 } else { 1 };
        if inputs.is_empty() || outputs.len() != inputs.len() * per_key {
            return Err(format!(
                "animation {}: channel {} has {} keyframe times and {} values ({} expected)",
                animation.index(),
                channel.index(),
                inputs.len(),
                outputs.len(),
                inputs.len() * per_key
            ));
        }
        let rotation = channel.target().property() == Property::Rotation;
        let interpolation = channel.sampler().interpolation();
        let value = sample(&inputs, &outputs, interpolation, rotation, time);
        match channel.target().property() {
            Property::Translation => trs[node].0 = value.truncate(),
            Property::Rotation => trs[node].1 = Quat::from_vec4(value).normalize(),
            Property::Scale => trs[node].2 = value.truncate(),
            Property::MorphTargetWeights => {}
        }
    }
    Ok(matrices(&trs))
}

/// The animation named `name`, or else the one at index `name`.
fn find<'a>(document: &'a gltf::Document, name: &str) -> Result<gltf::Animation<'a>, String> {
    let by_name = document.animations().find(|a| a.name() == Some(name));
    let by_index = || name.parse().ok().and_then(|i| document.animations().nth(i));
    by_name.or_else(by_index).ok_or_else(|| {
        let names: Vec<String> = document
            .animations()
            .map(|a| {
                a.name()
                    .map_or_else(|| a.index().to_string(), str::to_owned)
            })
            .collect();
        format!(
            "no animation '{name}' (the file has {}: {})",
            names.len(),
            if names.is_empty() {
                "none".into()
            } else {
                names.join(", ")
            }
        )
    })
}

/// A channel's keyframe times and values (xyz0 for translations and scales, xyzw for
/// rotations; morph weights are not read: an empty list), accessors checked first.
fn read_channel(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    channel: &gltf::animation::Channel,
) -> Result<(Vec<f32>, Vec<Vec4>), String> {
    let at = format!(
        "animation {} channel {}",
        channel.animation().index(),
        channel.index()
    );
    let sampler = channel.sampler();
    check(
        document,
        &format!("{at} input"),
        &sampler.input(),
        Dimensions::Scalar,
        &[DataType::F32],
    )?;
    let rotation_types = [
        DataType::F32,
        DataType::I8,
        DataType::U8,
        DataType::I16,
        DataType::U16,
    ];
    let (dimensions, types): (Dimensions, &[DataType]) = match channel.target().property() {
        Property::Rotation => (Dimensions::Vec4, &rotation_types),
        Property::MorphTargetWeights => return Ok((Vec::new(), Vec::new())),
        _ => (Dimensions::Vec3, &[DataType::F32]),
    };
    check(
        document,
        &format!("{at} output"),
        &sampler.output(),
        dimensions,
        types,
    )?;
    let reader = channel.reader(|b| Some(&buffers[b.index()]));
    let inputs: Vec<f32> = reader
        .read_inputs()
        .map(Iterator::collect)
        .unwrap_or_default();
    if let Some(i) = inputs
        .windows(2)
        .position(|w| w[0].partial_cmp(&w[1]) != Some(std::cmp::Ordering::Less))
    {
        return Err(format!(
            "{at}: keyframe times must increase (time {i} and {})",
            i + 1
        ));
    }
    let outputs = match reader.read_outputs() {
        Some(ReadOutputs::Translations(t)) => t.map(|v| Vec3::from(v).extend(0.0)).collect(),
        Some(ReadOutputs::Scales(s)) => s.map(|v| Vec3::from(v).extend(0.0)).collect(),
        Some(ReadOutputs::Rotations(r)) => r.into_f32().map(Vec4::from).collect(),
        _ => Vec::new(),
    };
    Ok((inputs, outputs))
}

/// The channel's value at `time`: held at the first and last keyframes, stepped, linear
/// (rotations by slerp) or a cubic Hermite spline (values stored as in-tangent, value,
/// out-tangent), as glTF 2.0 Appendix C defines them; `rotation`: slerp for linear.
fn sample(
    inputs: &[f32],
    outputs: &[Vec4],
    interpolation: Interpolation,
    rotation: bool,
    time: f32,
) -> Vec4 {
    let cubic = interpolation == Interpolation::CubicSpline;
    let value = |k: usize| {
        if cubic {
            outputs[3 * k + 1]
        } else {
            outputs[k]
        }
    };
    let last = inputs.len() - 1;
    if time <= inputs[0] {
        return value(0);
    }
    if time >= inputs[last] {
        return value(last);
    }
    let k = inputs.partition_point(|&t| t <= time) - 1;
    let dt = inputs[k + 1] - inputs[k];
    let u = (time - inputs[k]) / dt;
    match interpolation {
        Interpolation::Step => value(k),
        Interpolation::Linear if rotation => {
            let a = Quat::from_vec4(value(k)).normalize();
            let b = Quat::from_vec4(value(k + 1)).normalize();
            Vec4::from(a.slerp(b, u))
        }
        Interpolation::Linear => value(k).lerp(value(k + 1), u),
        Interpolation::CubicSpline => {
            let (u2, u3) = (u * u, u * u * u);
            let out_tangent = outputs[3 * k + 2];
            let in_tangent = outputs[3 * (k + 1)];
            (2.0 * u3 - 3.0 * u2 + 1.0) * value(k)
                + (u3 - 2.0 * u2 + u) * dt * out_tangent
                + (-2.0 * u3 + 3.0 * u2) * value(k + 1)
                + (u3 - u2) * dt * in_tangent
        }
    }
}

/// J_k · IBM_k for each joint of `skin`, from the nodes' world matrices in the pose (`None`
/// for nodes outside the scene, which a skin may not use).
pub fn joint_matrices(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    skin: &gltf::Skin,
    worlds: &[Option<Mat4>],
) -> Result<Vec<Mat4>, String> {
    let joints: Vec<gltf::Node> = skin.joints().collect();
    let inverse_binds: Vec<Mat4> = match skin.inverse_bind_matrices() {
        None => vec![Mat4::IDENTITY; joints.len()],
        Some(accessor) => {
            let what = format!("skin {} inverseBindMatrices", skin.index());
            check(
                document,
                &what,
                &accessor,
                Dimensions::Mat4,
                &[DataType::F32],
            )?;
            let reader = skin.reader(|b| Some(&buffers[b.index()]));
            let matrices: Vec<Mat4> = reader
                .read_inverse_bind_matrices()
                .map(|m| m.map(|m| Mat4::from_cols_array_2d(&m)).collect())
                .unwrap_or_default();
            if matrices.len() < joints.len() {
                return Err(format!(
                    "{what} has {} matrices for {} joints",
                    matrices.len(),
                    joints.len()
                ));
            }
            matrices
        }
    };
    joints
        .iter()
        .zip(inverse_binds)
        .map(|(joint, inverse_bind)| {
            let world = worlds[joint.index()].ok_or_else(|| {
                format!(
                    "skin {}: joint node {} is not in the scene",
                    skin.index(),
                    joint.index()
                )
            })?;
            Ok(world * inverse_bind)
        })
        .collect()
}

/// How far the weights of a vertex may sum from 1: a little more than four 8-bit weights
/// rounded each by half a step.
pub const WEIGHT_SUM_TOLERANCE: f32 = 0.01;

/// Per vertex, Σ_k w_k · J_k · IBM_k from every JOINTS_n / WEIGHTS_n set of the primitive.
pub fn vertex_matrices(
    primitive: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    joints: &[Mat4],
    vertex_count: usize,
) -> Result<Vec<Mat4>, String> {
    let reader = primitive.reader(|b| Some(&buffers[b.index()]));
    let mut blended = vec![Mat4::ZERO; vertex_count];
    let mut sums = vec![0.0f32; vertex_count];
    let mut set = 0;
    while let (Some(indices), Some(weights)) = (reader.read_joints(set), reader.read_weights(set)) {
        let indices: Vec<[u16; 4]> = indices.into_u16().collect();
        let weights: Vec<[f32; 4]> = weights.into_f32().collect();
        if indices.len() != vertex_count || weights.len() != vertex_count {
            return Err(format!(
                "JOINTS_{set} and WEIGHTS_{set} have {} and {} elements for {vertex_count} vertices",
                indices.len(),
                weights.len()
            ));
        }
        for (v, (js, ws)) in indices.iter().zip(&weights).enumerate() {
            for (&j, &w) in js.iter().zip(ws) {
                let Some(joint) = joints.get(usize::from(j)) else {
                    return Err(format!(
                        "JOINTS_{set} of vertex {v} names joint {j}, but the skin has {} joints",
                        joints.len()
                    ));
                };
                if w.is_nan() || w < 0.0 {
                    return Err(format!(
                        "WEIGHTS_{set} of vertex {v} has a weight {w} below 0"
                    ));
                }
                blended[v] += *joint * w;
                sums[v] += w;
            }
        }
        set += 1;
    }
    if set == 0 {
        return Err("the node has a skin but the primitive no JOINTS_0 and WEIGHTS_0".into());
    }
    if let Some(v) = sums
        .iter()
        .position(|s| (s - 1.0).abs() > WEIGHT_SUM_TOLERANCE)
    {
        return Err(format!(
            "the weights of vertex {v} sum to {} (glTF requires 1)",
            sums[v]
        ));
    }
    Ok(blended)
}

/// Positions by each vertex's blended matrix, normals by its linear part (normalised).
pub fn skin(matrices: &[Mat4], positions: &mut [Vec3], normals: Option<&mut Vec<Vec3>>) {
    for (p, m) in positions.iter_mut().zip(matrices) {
        *p = m.transform_point3(*p);
    }
    if let Some(normals) = normals {
        for (n, m) in normals.iter_mut().zip(matrices) {
            *n = (Mat3::from_mat4(*m) * *n).normalize_or_zero();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samplers_hold_step_lerp_and_slerp() {
        let inputs = [0.0, 1.0];
        let values = [Vec4::new(0.0, 0.0, 0.0, 0.0), Vec4::new(2.0, 0.0, 0.0, 0.0)];
        let at = |i, t| sample(&inputs, &values, i, false, t);
        assert_eq!(at(Interpolation::Linear, 0.25).x, 0.5);
        assert_eq!(at(Interpolation::Step, 0.75).x, 0.0);
        assert_eq!(at(Interpolation::Linear, 5.0).x, 2.0);
        assert_eq!(at(Interpolation::Linear, -1.0).x, 0.0);
        let turn = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let rotations = [Vec4::from(Quat::IDENTITY), Vec4::from(turn)];
        let half = Quat::from_vec4(sample(
            &inputs,
            &rotations,
            Interpolation::Linear,
            true,
            0.5,
        ));
        let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(half.angle_between(expected) < 1e-5);
        // A cubic spline with zero tangents is smoothstep between the values.
        let cubic = [
            Vec4::ZERO,
            values[0],
            Vec4::ZERO,
            Vec4::ZERO,
            values[1],
            Vec4::ZERO,
        ];
        let mid = sample(&inputs, &cubic, Interpolation::CubicSpline, false, 0.25).x;
        assert!((mid - 2.0 * (3.0 * 0.0625 - 2.0 * 0.015625)).abs() < 1e-6);
    }
}

//! Checks on accessors before `gltf`'s typed readers see them: those readers panic on what
//! the specification does not allow.

/// Guards panics of `gltf` 1.4's typed readers (found by `baker/tests/fuzz.rs`): they reach
/// `unreachable!` on a component type the specification does not allow for the attribute
/// (indices of floats), and slice out of bounds when a view's stride is shorter than an
/// element or a sparse accessor is empty.
pub fn readable_accessors(
    document: &gltf::Document,
    primitive: &gltf::Primitive,
    uv_set: u32,
    tangents: bool,
) -> std::result::Result<(), String> {
    use gltf::Semantic;
    use gltf::accessor::{DataType, Dimensions};
    let float = &[DataType::F32][..];
    let uv = &[DataType::F32, DataType::U8, DataType::U16][..];
    let mut used: Vec<(String, gltf::Accessor, Dimensions, &[DataType])> = Vec::new();
    for (semantic, dimensions, types) in [
        (Semantic::Positions, Dimensions::Vec3, float),
        (Semantic::Normals, Dimensions::Vec3, float),
        (Semantic::TexCoords(uv_set), Dimensions::Vec2, uv),
        (Semantic::TexCoords(1), Dimensions::Vec2, uv),
        (Semantic::Tangents, Dimensions::Vec4, float),
    ] {
        // TANGENT is read only for a normal map.
        let read = tangents || semantic != Semantic::Tangents;
        if let Some(accessor) = primitive.get(&semantic).filter(|_| read) {
            used.push((semantic.to_string(), accessor, dimensions, types));
        }
    }
    // Skins: every set of JOINTS_n and WEIGHTS_n (read where the node has a skin).
    let joints = &[DataType::U8, DataType::U16][..];
    let weights = &[DataType::F32, DataType::U8, DataType::U16][..];
    for (semantic, accessor) in primitive.attributes() {
        let types = match semantic {
            Semantic::Joints(_) => joints,
            Semantic::Weights(_) => weights,
            _ => continue,
        };
        used.push((semantic.to_string(), accessor, Dimensions::Vec4, types));
    }
    if let Some(accessor) = primitive.indices() {
        let types = &[DataType::U8, DataType::U16, DataType::U32][..];
        used.push(("indices".into(), accessor, Dimensions::Scalar, types));
    }
    for (what, accessor, dimensions, types) in used {
        check(document, &what, &accessor, dimensions, types)?;
    }
    Ok(())
}

/// Refuses an accessor of other dimensions or component types than `types` (which would
/// reach an `unreachable!` of the typed readers), or whose view's stride or sparse storage
/// would make them slice out of bounds. `what` names it in the message.
pub fn check(
    document: &gltf::Document,
    what: &str,
    accessor: &gltf::Accessor,
    dimensions: gltf::accessor::Dimensions,
    types: &[gltf::accessor::DataType],
) -> std::result::Result<(), String> {
    use gltf::json::accessor::{ComponentType, IndexComponentType};
    use gltf::json::validation::Checked;
    let views = &document.as_json().buffer_views;
    let short_stride = |view: usize, size: usize| {
        let stride = views[view].byte_stride.map_or(0, |s| s.0);
        stride != 0 && stride < size
    };
    let at = format!("{what} (accessor {})", accessor.index());
    if accessor.dimensions() != dimensions || !types.contains(&accessor.data_type()) {
        return Err(format!(
            "{at} is {:?} of {:?}, which glTF does not allow there",
            accessor.dimensions(),
            accessor.data_type()
        ));
    }
    let size = accessor.size();
    let json = &document.as_json().accessors[accessor.index()];
    let mut strides = vec![(json.buffer_view.map(|v| v.value()), size)];
    if let Some(sparse) = &json.sparse {
        let index_size = match sparse.indices.component_type {
            Checked::Valid(IndexComponentType(ComponentType::U8)) => 1,
            Checked::Valid(IndexComponentType(ComponentType::U16)) => 2,
            Checked::Valid(IndexComponentType(ComponentType::U32)) => 4,
            _ => return Err(format!("{at}: sparse indices must be unsigned integers")),
        };
        if json.count.0 == 0 || sparse.count.0 == 0 {
            return Err(format!(
                "{at}: a sparse accessor must have a count of 1 or more"
            ));
        }
        strides.push((Some(sparse.indices.buffer_view.value()), index_size));
        strides.push((Some(sparse.values.buffer_view.value()), size));
    }
    for (view, size) in strides {
        if let Some(view) = view.filter(|&v| short_stride(v, size)) {
            return Err(format!(
                "{at}: buffer view {view}'s byteStride is shorter than an element ({size} bytes)"
            ));
        }
    }
    Ok(())
}

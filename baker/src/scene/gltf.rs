//! glTF 2.0 scenes (`.gltf` with external or data-URI buffers, `.glb`) through the `gltf`
//! crate.
//!
//! The default scene's node hierarchy is flattened to world space: every node's matrix (or
//! TRS) times its parent's; normals go through the inverse transpose; a transform of negative
//! determinant (a mirror) flips the winding so faces keep facing out. Triangle lists, strips
//! and fans are read; points and lines are skipped with a warning. A primitive without
//! NORMAL gets angle-weighted normals, as an OBJ without `vn`. Albedo is baseColorFactor ×
//! baseColorTexture (sRGB, as the specification says); a primitive without a material takes
//! [`DEFAULT_KD`], as an OBJ object without one does.
//!
//! glTF's texture v runs down from the image's top; the scene keeps OBJ's convention (v up
//! from the bottom), so v is stored as 1 − v.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::mesh::Mode;

use super::mesh::{DEFAULT_KD, Material, Mesh};
use super::texture::Texture;
use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;

/// What a glTF file contributes.
pub struct Loaded {
    pub meshes: Vec<Mesh>,
    pub textures: Vec<Texture>,
    /// TEXCOORD_1 of each mesh (v flipped like TEXCOORD_0), where it has one.
    pub lightmap_uvs: Vec<Option<Vec<Vec2>>>,
    /// xxh3 of the JSON, every buffer and every decoded image: the file's whole content.
    pub digest: u64,
    /// Things skipped (points, lines), one sentence each.
    pub warnings: Vec<String>,
}

/// Extensions a file may *require* and still be read correctly. None yet: a required
/// extension changes how data is to be read (Draco, meshopt, quantisation, texture
/// transforms), and reading on without it would bake the wrong scene.
const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] = &[];

pub fn load(path: &Path) -> Result<Loaded> {
    let at = || Location::file(path);
    let fail = |message: String| Error::scene(at(), message);
    let bytes = crate::support::limits::read_file(path)?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|err| fail(format!("not a readable glTF file: {err}")))?;
    let unsupported: Vec<&str> = gltf
        .extensions_required()
        .filter(|e| !SUPPORTED_REQUIRED_EXTENSIONS.contains(e))
        .collect();
    if !unsupported.is_empty() {
        return Err(fail(format!(
            "requires glTF extension{} {} which this reader does not support (re-export without {})",
            if unsupported.len() > 1 { "s" } else { "" },
            unsupported.join(", "),
            if unsupported.len() > 1 { "them" } else { "it" }
        )));
    }
    let gltf::Gltf { document, blob } = gltf;
    let json = document.into_json();
    positions_exist(&json).map_err(fail)?;
    let document =
        gltf::Document::from_json(json).map_err(|err| fail(format!("invalid glTF: {err}")))?;
    let json_bytes = match blob {
        Some(_) => gltf::Glb::from_slice(&bytes)
            .map(|glb| glb.json.into_owned())
            .unwrap_or_default(),
        None => bytes.clone(),
    };
    let folder = AssetFolder::of(path);
    uris_are_readable(document.as_json()).map_err(fail)?;
    let buffers = read_buffers(path, &folder, &document, blob)?;

    let mut digest = xxhash_rust::xxh3::Xxh3::new();
    digest.update(&json_bytes);
    for buffer in &buffers {
        digest.update(&(buffer.len() as u64).to_le_bytes());
        digest.update(buffer);
    }

    // Images are decoded only when a material uses them as its base colour.
    let mut textures = Vec::new();
    let mut texture_of_image: HashMap<usize, usize> = HashMap::new();
    let mut decoded: Option<Vec<gltf::image::Data>> = None;

    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| fail("the file has no scene".into()))?;
    let placed = flatten(&document, &scene).map_err(fail)?;

    let mut loaded = Loaded {
        meshes: Vec::new(),
        textures: Vec::new(),
        lightmap_uvs: Vec::new(),
        digest: 0,
        warnings: Vec::new(),
    };
    for (mesh, world) in placed {
        let mesh_name = mesh
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("mesh {}", mesh.index()));
        let primitive_count = mesh.primitives().len();
        for primitive in mesh.primitives() {
            let name = if primitive_count > 1 {
                format!("{mesh_name}/{}", primitive.index())
            } else {
                mesh_name.clone()
            };
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                loaded.warnings.push(format!(
                    "mesh '{name}': skipped a primitive of {mode:?} (only triangles are baked)"
                ));
                continue;
            }
            let pbr = primitive.material().pbr_metallic_roughness();
            let base_colour = pbr.base_color_texture();
            let uv_set = base_colour.as_ref().map_or(0, |info| info.tex_coord());
            readable_accessors(&document, &primitive, uv_set)
                .map_err(|problem| fail(format!("mesh '{name}': {problem}")))?;
            let reader = primitive.reader(|b| Some(&buffers[b.index()]));
            let Some(positions) = reader.read_positions() else {
                return Err(fail(format!("mesh '{name}': a primitive has no POSITION")));
            };
            let positions: Vec<Vec3> = positions.map(Vec3::from_array).collect();
            let normals: Option<Vec<Vec3>> = reader
                .read_normals()
                .map(|n| n.map(Vec3::from_array).collect());
            let read_uvs = |set: u32| {
                reader.read_tex_coords(set).map(|uv| {
                    uv.into_f32()
                        .map(|[u, v]| Vec2::new(u, 1.0 - v))
                        .collect::<Vec<Vec2>>()
                })
            };
            let indices: Vec<u32> = match reader.read_indices() {
                Some(indices) => indices.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            let mut triangles = assemble(mode, &indices);

            // World space: positions by the matrix, normals by its inverse transpose; a
            // mirror reverses the winding.
            let linear = Mat3::from_mat4(world);
            let normal_matrix = linear.inverse().transpose();
            let positions: Vec<Vec3> = positions
                .iter()
                .map(|p| world.transform_point3(*p))
                .collect();
            let normals = normals.map(|normals| {
                normals
                    .iter()
                    .map(|n| (normal_matrix * *n).normalize_or_zero())
                    .collect()
            });
            if linear.determinant() < 0.0 {
                for t in &mut triangles {
                    t.swap(1, 2);
                }
            }

            let texture = match &base_colour {
                None => None,
                Some(info) => {
                    let image = info.texture().source().index();
                    if let Some(&t) = texture_of_image.get(&image) {
                        Some(t)
                    } else {
                        if decoded.is_none() {
                            images_are_readable(&document, &buffers).map_err(fail)?;
                            let images = read_images(path, &folder, &document, &buffers)?;
                            for image in &images {
                                digest.update(&image.pixels);
                            }
                            decoded = Some(images);
                        }
                        let data = &decoded.as_ref().expect("decoded above")[image];
                        let texture = to_texture(path, image, data)
                            .ok_or_else(|| fail(format!(
                                "image {image}: {:?} pixels cannot be a base colour (8-bit RGB or RGBA needed)",
                                data.format
                            )))?;
                        textures.push(texture);
                        texture_of_image.insert(image, textures.len() - 1);
                        Some(textures.len() - 1)
                    }
                }
            };
            let material = match primitive.material().index() {
                None => Material {
                    name: String::from("default"),
                    kd: DEFAULT_KD,
                    texture: None,
                },
                Some(index) => {
                    let [r, g, b, _] = pbr.base_color_factor();
                    Material {
                        name: primitive
                            .material()
                            .name()
                            .map(str::to_string)
                            .unwrap_or_else(|| format!("material {index}")),
                        kd: Vec3::new(r, g, b),
                        texture,
                    }
                }
            };
            loaded.lightmap_uvs.push(read_uvs(1));
            loaded.meshes.push(Mesh {
                name,
                positions,
                normals,
                uvs: read_uvs(uv_set),
                triangles,
                material,
            });
        }
    }
    if loaded.meshes.is_empty() {
        return Err(fail(
            "no triangles: the default scene has no triangle primitives".into(),
        ));
    }
    loaded.textures = textures;
    loaded.digest = digest.digest();
    Ok(loaded)
}

/// Guards a panic of `gltf-json` 1.4: its validation of a primitive indexes the accessor list
/// with the POSITION index before checking it (found by `baker/tests/fuzz.rs`).
fn positions_exist(json: &gltf::json::Root) -> std::result::Result<(), String> {
    use gltf::json::validation::Checked;
    let position = Checked::Valid(gltf::Semantic::Positions);
    for (m, mesh) in json.meshes.iter().enumerate() {
        for primitive in &mesh.primitives {
            let index = primitive.attributes.get(&position).map(|i| i.value());
            if let Some(index) = index.filter(|&i| i >= json.accessors.len()) {
                return Err(format!(
                    "invalid glTF: mesh {m}: POSITION names accessor {index}, but there are {}",
                    json.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// Guards a panic of `gltf` 1.4's `import_buffers` and `import_images`: they unwrap the
/// percent-decoding of a relative uri, which fails where it does not decode to UTF-8
/// (`%FF.bin`).
fn uris_are_readable(json: &gltf::json::Root) -> std::result::Result<(), String> {
    uris_decode("buffer", json.buffers.iter().map(|b| b.uri.as_deref()))?;
    uris_decode("image", json.images.iter().map(|i| i.uri.as_deref()))
}

/// [`uris_are_readable`] for the uris of one kind of object.
fn uris_decode<'a>(
    what: &str,
    uris: impl Iterator<Item = Option<&'a str>>,
) -> std::result::Result<(), String> {
    for (i, uri) in uris.enumerate() {
        if let Some(uri) = uri
            && let Some(Err(_)) = relative_path(uri)
        {
            return Err(format!(
                "invalid glTF: {what} {i}'s uri {uri:?} is not percent-encoded UTF-8"
            ));
        }
    }
    Ok(())
}

/// A relative uri percent-decoded, as gltf 1.4 reads it (it tells one from a scheme by the
/// colon); `None` for a uri with a scheme.
fn relative_path(
    uri: &str,
) -> Option<std::result::Result<std::borrow::Cow<'_, str>, std::string::FromUtf8Error>> {
    (!uri.contains(':')).then(|| urlencoding::decode(uri))
}

/// Guards panics of `gltf` 1.4's `import_images` (found by `baker/tests/fuzz.rs`): it unwraps
/// an image's `mimeType` where it has a `bufferView`, and its `uri` where it has none, and it
/// slices the view out of its buffer without checking that it fits.
fn images_are_readable(
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> std::result::Result<(), String> {
    let json = document.as_json();
    for (i, image) in json.images.iter().enumerate() {
        let Some(view) = image.buffer_view else {
            if image.uri.is_none() {
                return Err(format!(
                    "invalid glTF: image {i} has neither a uri nor a bufferView"
                ));
            }
            continue;
        };
        if image.mime_type.is_none() {
            return Err(format!(
                "invalid glTF: image {i} has a bufferView but no mimeType"
            ));
        }
        // Indices were validated by `Document::from_json`.
        let view = &json.buffer_views[view.value()];
        let size = buffers[view.buffer.value()].len() as u64;
        let offset = view.byte_offset.map_or(0, |o| o.0);
        if offset
            .checked_add(view.byte_length.0)
            .is_none_or(|end| end > size)
        {
            return Err(format!(
                "cannot read an image: image {i} lies at bytes {offset}..+{} of buffer {}, which has {size}",
                view.byte_length.0,
                view.buffer.value()
            ));
        }
    }
    Ok(())
}

/// The name of one of the file's buffers or images in errors: `scene.gltf#buffer0`.
fn part_name(path: &Path, part: &str) -> std::path::PathBuf {
    path.with_file_name(format!(
        "{}#{part}",
        path.file_name().unwrap_or_default().to_string_lossy()
    ))
}

/// Where a uri's bytes are, as `gltf` 1.4 tells them apart (a colon means a scheme): a
/// `data:` URI's media type and payload, or a file (`file:` or a relative, percent-decoded
/// path).
enum UriSource<'a> {
    Data {
        media_type: Option<&'a str>,
        base64: &'a str,
    },
    File(std::path::PathBuf),
    Unsupported,
}

fn uri_source(uri: &str) -> UriSource<'_> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let mut parts = rest.split(";base64,");
        return match (parts.next(), parts.next()) {
            (media_type, Some(base64)) => UriSource::Data { media_type, base64 },
            _ => UriSource::Data {
                media_type: None,
                base64: rest,
            },
        };
    }
    if let Some(rest) = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        return UriSource::File(rest.into());
    }
    match relative_path(uri) {
        Some(Ok(decoded)) => UriSource::File(decoded.into_owned().into()),
        // Refused by `uris_are_readable` before.
        Some(Err(_)) | None => UriSource::Unsupported,
    }
}

/// Reads a file a uri names, through the input-path policy, at most `bound` (+ 1) bytes.
fn read_uri_file(
    path: &Path,
    folder: &AssetFolder,
    what: &str,
    uri: &str,
    reference: &Path,
    bound: u64,
) -> Result<Vec<u8>> {
    let base = path.parent().unwrap_or(Path::new(""));
    let file = folder.admit(&Location::file(path), what, uri, reference, base)?;
    crate::support::limits::read_regular(&file, bound).map_err(|err| match err {
        Error::Io { source, .. } => Error::scene(
            Location::file(path),
            format!("cannot read {what} {uri:?}: {source}"),
        ),
        other => other,
    })
}

/// The file's buffers, read as `gltf::import_buffers` reads them (padded to 4 bytes), but
/// each checked first against its declared byteLength and the memory limit, and never read
/// past byteLength + 1 bytes: a buffer file longer than declared is cut to its byteLength
/// (the rest is not the buffer's), a shorter one is refused. Files go through the input-path
/// policy ([`AssetFolder::admit`]): `/dev/zero` or `../../etc/passwd` are refused.
fn read_buffers(
    path: &Path,
    folder: &AssetFolder,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>> {
    let fail = |message: String| Error::scene(Location::file(path), message);
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let i = buffer.index();
        let declared = buffer.length() as u64;
        crate::support::limits::check(
            part_name(path, &format!("buffer{i}")).display().to_string(),
            &format!("its declared byteLength of {declared}"),
            Some(declared),
        )?;
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| fail(format!("cannot read a buffer: buffer {i} refers to a binary chunk the file does not have")))?,
            gltf::buffer::Source::Uri(uri) => match uri_source(uri) {
                UriSource::Data { base64, .. } => base64::decode(base64).map_err(|err| {
                    fail(format!("cannot read a buffer: buffer {i}'s data URI: {err}"))
                })?,
                UriSource::File(reference) => {
                    let what = format!("buffer {i}'s uri");
                    let mut bytes = read_uri_file(path, folder, &what, uri, &reference, declared)?;
                    bytes.truncate(declared as usize);
                    bytes
                }
                UriSource::Unsupported => {
                    return Err(fail(format!(
                        "cannot read a buffer: buffer {i}'s uri {uri:?} has a scheme other than data: or file:"
                    )));
                }
            },
        };
        if (data.len() as u64) < declared {
            return Err(fail(format!(
                "cannot read a buffer: buffer {i} has {} bytes, fewer than its byteLength of {declared}",
                data.len()
            )));
        }
        while data.len() % 4 != 0 {
            data.push(0);
        }
        buffers.push(gltf::buffer::Data(data));
    }
    Ok(buffers)
}

/// Every image of the file decoded, as `gltf::import_images` decodes them (PNG or JPEG, by
/// media type or uri extension), but with the bytes read here: files through the input-path
/// policy and no larger than the memory limit, and each image's declared size checked against
/// `--max-memory` before it is decoded (up to 16 bytes a pixel for decoding, the RGBA copy and
/// the kept pixels, as OBJ textures are checked).
fn read_images(
    path: &Path,
    folder: &AssetFolder,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
) -> Result<Vec<gltf::image::Data>> {
    use image::ImageFormat::{Jpeg, Png};
    let fail = |message: String| Error::scene(Location::file(path), message);
    let by_media_type = |media_type: Option<&str>| match media_type {
        Some("image/png") => Some(Png),
        Some("image/jpeg") => Some(Jpeg),
        _ => None,
    };
    let mut images = Vec::new();
    for image in document.images() {
        let i = image.index();
        let unsupported = || {
            fail(format!(
                "cannot read an image: image {i} is neither PNG nor JPEG"
            ))
        };
        let (bytes, format): (std::borrow::Cow<'_, [u8]>, _) = match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                // In bounds: checked by `images_are_readable`.
                let bytes = &buffers[view.buffer().index()].0[view.offset()..][..view.length()];
                let format = by_media_type(Some(mime_type)).ok_or_else(unsupported)?;
                (bytes.into(), format)
            }
            gltf::image::Source::Uri { uri, mime_type } => {
                let by_extension = || match uri.rsplit('.').next() {
                    Some("png") => Some(Png),
                    Some("jpg" | "jpeg") => Some(Jpeg),
                    _ => None,
                };
                match uri_source(uri) {
                    // gltf reads such a payload only by guessing its format, which is off.
                    UriSource::Data {
                        media_type: Some(media_type),
                        ..
                    } if !matches!(media_type, "image/png" | "image/jpeg") => {
                        return Err(unsupported());
                    }
                    UriSource::Data { media_type, base64 } => {
                        let bytes = base64::decode(base64).map_err(|err| {
                            fail(format!("cannot read an image: image {i}'s data URI: {err}"))
                        })?;
                        let format = match media_type {
                            Some(_) => by_media_type(media_type),
                            None if mime_type.is_some() => by_media_type(mime_type),
                            None => by_extension(),
                        };
                        (bytes.into(), format.ok_or_else(unsupported)?)
                    }
                    UriSource::File(reference) => {
                        let what = format!("image {i}'s uri");
                        let limit = crate::support::limits::max_memory();
                        let bytes = read_uri_file(path, folder, &what, uri, &reference, limit)?;
                        let name = part_name(path, &format!("image{i}"));
                        let bytes = crate::support::input_path::within_limit(&name, bytes, limit)?;
                        let format = match mime_type {
                            Some(_) => by_media_type(mime_type),
                            None => by_extension(),
                        };
                        (bytes.into(), format.ok_or_else(unsupported)?)
                    }
                    UriSource::Unsupported => {
                        return Err(fail(format!(
                            "cannot read an image: image {i}'s uri {uri:?} has a scheme other than data: or file:"
                        )));
                    }
                }
            }
        };
        images.push(decode_image(path, i, &bytes, format)?);
    }
    Ok(images)
}

/// One image decoded into gltf's image data (the same formats and bytes as
/// `gltf::image::Data`), its declared size checked against the memory limit first.
fn decode_image(
    path: &Path,
    index: usize,
    bytes: &[u8],
    format: image::ImageFormat,
) -> Result<gltf::image::Data> {
    use gltf::image::Format;
    use image::DynamicImage;
    let fail = |err: &dyn std::fmt::Display| {
        Error::scene(
            Location::file(path),
            format!("cannot read an image: image {index}: {err}"),
        )
    };
    let reader = || image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    let (width, height) = reader().into_dimensions().map_err(|err| fail(&err))?;
    crate::support::limits::check_image(
        &part_name(path, &format!("image{index}")),
        width,
        height,
        16,
    )?;
    let mut reader = reader();
    reader.limits(crate::support::limits::image_limits());
    let decoded = reader.decode().map_err(|err| fail(&err))?;
    let format = match decoded {
        DynamicImage::ImageLuma8(_) => Format::R8,
        DynamicImage::ImageLumaA8(_) => Format::R8G8,
        DynamicImage::ImageRgb8(_) => Format::R8G8B8,
        DynamicImage::ImageRgba8(_) => Format::R8G8B8A8,
        DynamicImage::ImageLuma16(_) => Format::R16,
        DynamicImage::ImageLumaA16(_) => Format::R16G16,
        DynamicImage::ImageRgb16(_) => Format::R16G16B16,
        DynamicImage::ImageRgba16(_) => Format::R16G16B16A16,
        DynamicImage::ImageRgb32F(_) => Format::R32G32B32FLOAT,
        DynamicImage::ImageRgba32F(_) => Format::R32G32B32A32FLOAT,
        _ => return Err(fail(&"an image format gltf does not read")),
    };
    let (width, height) = (decoded.width(), decoded.height());
    Ok(gltf::image::Data {
        pixels: decoded.into_bytes(),
        format,
        width,
        height,
    })
}

/// Guards panics of `gltf` 1.4's typed readers (found by `baker/tests/fuzz.rs`): they reach
/// `unreachable!` on a component type the specification does not allow for the attribute
/// (indices of floats), and slice out of bounds when a view's stride is shorter than an
/// element or a sparse accessor is empty.
fn readable_accessors(
    document: &gltf::Document,
    primitive: &gltf::Primitive,
    uv_set: u32,
) -> std::result::Result<(), String> {
    use gltf::Semantic;
    use gltf::accessor::{DataType, Dimensions};
    use gltf::json::accessor::{ComponentType, IndexComponentType};
    use gltf::json::validation::Checked;
    let float = &[DataType::F32][..];
    let uv = &[DataType::F32, DataType::U8, DataType::U16][..];
    let mut used: Vec<(String, gltf::Accessor, Dimensions, &[DataType])> = Vec::new();
    for (semantic, dimensions, types) in [
        (Semantic::Positions, Dimensions::Vec3, float),
        (Semantic::Normals, Dimensions::Vec3, float),
        (Semantic::TexCoords(uv_set), Dimensions::Vec2, uv),
        (Semantic::TexCoords(1), Dimensions::Vec2, uv),
    ] {
        if let Some(accessor) = primitive.get(&semantic) {
            used.push((semantic.to_string(), accessor, dimensions, types));
        }
    }
    if let Some(accessor) = primitive.indices() {
        let types = &[DataType::U8, DataType::U16, DataType::U32][..];
        used.push(("indices".into(), accessor, Dimensions::Scalar, types));
    }
    let views = &document.as_json().buffer_views;
    let short_stride = |view: usize, size: usize| {
        let stride = views[view].byte_stride.map_or(0, |s| s.0);
        stride != 0 && stride < size
    };
    for (what, accessor, dimensions, types) in used {
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
    }
    Ok(())
}

/// The deepest node hierarchy read: far beyond any real asset (tens of levels), and reached
/// only by a file made to be hostile; the walk is iterative, so this bounds its memory, not
/// the stack.
pub const MAX_NODE_DEPTH: usize = 100_000;

/// Every node of `scene` with a mesh, and its node-to-world matrix, walked without recursion.
/// glTF requires the nodes to form disjoint trees (§3.5.3: no cycles, one parent at most, the
/// scene's nodes roots); a file that breaks this is refused, naming the node: a node that is
/// its own child or ancestor would loop forever (it overflowed the stack of a recursive
/// walk), and a node with two parents repeated below each would make shared subtrees grow
/// exponentially.
fn flatten<'a>(
    document: &'a gltf::Document,
    scene: &gltf::Scene<'a>,
) -> std::result::Result<Vec<(gltf::Mesh<'a>, Mat4)>, String> {
    let json = document.as_json();
    // Indices were validated by `Document::from_json`.
    let mut parent: Vec<Option<usize>> = vec![None; json.nodes.len()];
    for (p, node) in json.nodes.iter().enumerate() {
        for child in node.children.iter().flatten().map(|c| c.value()) {
            if child == p {
                return Err(format!("invalid glTF: node {p} is its own child (a cycle)"));
            }
            if let Some(first) = parent[child] {
                return Err(format!(
                    "invalid glTF: node {child} is a child of both node {first} and node {p} (a node has one parent at most)"
                ));
            }
            parent[child] = Some(p);
        }
    }
    let mut listed = vec![false; json.nodes.len()];
    let mut stack: Vec<(gltf::Node<'a>, Mat4, usize)> = Vec::new();
    for root in scene.nodes() {
        let r = root.index();
        if let Some(p) = parent[r] {
            return Err(match cycle_through(&parent, r) {
                Some(cycle) => {
                    format!("invalid glTF: node {r} is its own ancestor (a cycle: {cycle})")
                }
                None => format!(
                    "invalid glTF: scene {} lists node {r} as a root, but it is a child of node {p}",
                    scene.index()
                ),
            });
        }
        if std::mem::replace(&mut listed[r], true) {
            return Err(format!(
                "invalid glTF: scene {} lists node {r} twice",
                scene.index()
            ));
        }
        stack.push((root, Mat4::IDENTITY, 1));
    }
    // Popped last first: reversed, the meshes come out in the order a recursive walk visits
    // them (which orders the scene's vertices and textures).
    stack.reverse();
    // Every node below a root has exactly one parent and the roots have none, so the walk
    // meets each node once: no cycle is reachable.
    let mut out = Vec::new();
    while let Some((node, parent_world, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node {} is nested {depth} levels deep, deeper than the {MAX_NODE_DEPTH} this reader follows",
                node.index()
            ));
        }
        let world = parent_world * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            out.push((mesh, world));
        }
        // Reversed, for the same order.
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }
    Ok(out)
}

/// The cycle `node` lies on, following parents (`0 → 1 → 0`), if it does.
fn cycle_through(parent: &[Option<usize>], node: usize) -> Option<String> {
    let mut path = vec![node];
    let mut at = node;
    // A cycle through `node` has at most as many nodes as the file.
    for _ in 0..parent.len() {
        at = parent[at]?;
        path.push(at);
        if at == node {
            path.reverse();
            let names: Vec<String> = path.iter().map(usize::to_string).collect();
            return Some(names.join(" → "));
        }
    }
    None
}

/// Triangles of a list, strip or fan (glTF 2.0 §3.7.2.1); degenerate ones (repeated indices,
/// as strips use to restart) are dropped.
fn assemble(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    let triangles: Vec<[u32; 3]> = match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| {
                let [a, b, c] = [indices[i], indices[i + 1], indices[i + 2]];
                if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
            })
            .collect(),
        Mode::TriangleFan => (1..indices.len().saturating_sub(1))
            .map(|i| [indices[i], indices[i + 1], indices[0]])
            .collect(),
        _ => Vec::new(),
    };
    triangles
        .into_iter()
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .collect()
}

/// An 8-bit RGB(A) or grey image as a texture (texels stay sRGB-encoded, as loaded ones).
fn to_texture(path: &Path, index: usize, data: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let pixels = &data.pixels;
    let srgb8: Vec<[u8; 4]> = match data.format {
        Format::R8G8B8A8 => pixels
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect(),
        Format::R8G8B8 => pixels
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        Format::R8 => pixels.iter().map(|&g| [g, g, g, 255]).collect(),
        Format::R8G8 => pixels
            .chunks_exact(2)
            .map(|p| [p[0], p[0], p[0], p[1]])
            .collect(),
        _ => return None,
    };
    if data.width == 0 || data.height == 0 {
        return None;
    }
    Some(Texture {
        path: path.with_file_name(format!(
            "{}#image{index}",
            path.file_name().unwrap_or_default().to_string_lossy()
        )),
        width: data.width,
        height: data.height,
        srgb8,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_triangles_of_one_orientation() {
        // A strip over a quad 0-1-2-3 (zig-zag) and a fan over the same quad.
        assert_eq!(
            assemble(Mode::TriangleStrip, &[0, 1, 2, 3]),
            [[0, 1, 2], [2, 1, 3]]
        );
        assert_eq!(
            assemble(Mode::TriangleFan, &[0, 1, 2, 3]),
            [[1, 2, 0], [2, 3, 0]]
        );
        assert_eq!(assemble(Mode::Triangles, &[0, 1, 2, 2, 2, 3]), [[0, 1, 2]]);
    }
}

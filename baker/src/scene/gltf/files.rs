//! A glTF's buffers and images, read by the baker itself rather than by `gltf`'s import
//! functions: every uri through the input-path policy, every size checked against its declared
//! byteLength and `--max-memory` before a byte is read.

use crate::scene::texture::Texture;
use crate::support::error::{Error, Location, Result};
use crate::support::input_path::AssetFolder;
use std::path::Path;

/// Guards a panic of `gltf` 1.4's `import_buffers` and `import_images`: they unwrap the
/// percent-decoding of a relative uri, which fails where it does not decode to UTF-8
/// (`%FF.bin`).
pub(super) fn uris_are_readable(json: &gltf::json::Root) -> std::result::Result<(), String> {
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
pub(super) fn images_are_readable(
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
pub(super) fn read_buffers(
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
pub(super) fn read_images(
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
        // A file the image came from is named too: a corrupt `bumps.png` says so.
        let decoded =
            decode_image(path, i, &bytes, format).map_err(|err| match (err, image.source()) {
                (Error::Scene { location, message }, gltf::image::Source::Uri { uri, .. })
                    if !uri.starts_with("data:") =>
                {
                    Error::Scene {
                        location,
                        message: format!("{message} (file {uri})"),
                    }
                }
                (err, _) => err,
            })?;
        images.push(decoded);
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

/// An 8-bit RGB(A) or grey image as a texture (texels stay sRGB-encoded, as loaded ones).
pub(super) fn to_texture(path: &Path, index: usize, data: &gltf::image::Data) -> Option<Texture> {
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

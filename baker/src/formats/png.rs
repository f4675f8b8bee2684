//! PNG bytes in memory, for the images the exports embed or write (relit lightmaps, AO,
//! albedo textures). One encoder call, so every PNG is written the same way; callers say in
//! their error what the image was.

/// `pixels` (rows of `width` pixels of `colour`) as a PNG file's bytes.
pub fn encode(
    pixels: &[u8],
    width: u32,
    height: u32,
    colour: image::ExtendedColorType,
) -> Result<Vec<u8>, image::ImageError> {
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        pixels,
        width,
        height,
        colour,
    )?;
    Ok(png)
}

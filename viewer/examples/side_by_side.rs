//! Joins PNG images of one height side by side into one PNG (the frames of
//! docs/images/character-walk.png, scripts/docs/character-walk.sh):
//! `cargo run --release -p prt-viewer --example side_by_side OUT.png A.png B.png …`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [out, inputs @ ..] = &args[..] else {
        return Err("usage: side_by_side OUT.png A.png B.png …".into());
    };
    let images = inputs
        .iter()
        .map(|p| image::open(p).map(|i| i.to_rgb8()))
        .collect::<Result<Vec<_>, _>>()?;
    let height = images.first().ok_or("no input images")?.height();
    if images.iter().any(|i| i.height() != height) {
        return Err("the images must be of one height".into());
    }
    let width = images.iter().map(|i| i.width()).sum();
    let mut joined = image::RgbImage::new(width, height);
    let mut x = 0;
    for i in &images {
        image::imageops::replace(&mut joined, i, i64::from(x), 0);
        x += i.width();
    }
    joined.save(out)?;
    Ok(())
}

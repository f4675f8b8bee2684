//! `bake --probes POINTS.txt`: where transfer probes go, one `x y z` a line in the scene's
//! frame. Blank lines and `#` comments are skipped; anything else is an error naming the line.

use std::path::Path;

use glam::Vec3;

use crate::support::error::{Error, Location, Result};

/// The points of a probe file, in file order.
pub fn read(path: &Path) -> Result<Vec<Vec3>> {
    let bytes = crate::support::limits::read_file(path)?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::scene(Location::file(path), "probe points: not UTF-8 text"))?;
    let points = parse(&text).map_err(|(line, message)| {
        Error::scene(
            Location::line(path, line),
            format!("probe points: {message}"),
        )
    })?;
    if points.is_empty() {
        return Err(Error::scene(
            Location::file(path),
            "probe points: no points (one `x y z` a line)",
        ));
    }
    Ok(points)
}

/// The points of a probe file's text; an error is (1-based line, message).
pub fn parse(text: &str) -> std::result::Result<Vec<Vec3>, (usize, String)> {
    let mut points = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.len() != 3 {
            return Err((
                i + 1,
                format!("{} numbers, expected 3 (x y z)", fields.len()),
            ));
        }
        let mut xyz = [0.0f32; 3];
        for (x, field) in xyz.iter_mut().zip(&fields) {
            *x = match field.parse::<f32>() {
                Ok(v) if v.is_finite() => v,
                _ => return Err((i + 1, format!("`{field}` is not a finite number"))),
            };
        }
        points.push(Vec3::from_array(xyz));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_comments_and_errors() {
        let text = "# probes\n0 0 1\n\n  1.5 -2 3e-1  # the second\n";
        assert_eq!(
            parse(text).unwrap(),
            [Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.5, -2.0, 0.3)]
        );
        assert_eq!(parse("0 0 1\n1 2\n").unwrap_err().0, 2);
        let (line, message) = parse("\n\n1 nan 2").unwrap_err();
        assert_eq!(line, 3);
        assert!(message.contains("`nan`"), "{message}");
    }
}

//! The thesis's scene description: one object per line,
//!
//! ```text
//! # comment
//! "meshes/torus.obj" "textures/marble.tga"
//! floor.obj                       # texture optional, quotes optional without spaces
//! ```
//!
//! Paths are relative to the scene file's folder, and must lie inside it unless
//! `--allow-outside-uris` is given ([`crate::support::input_path`]). Objects are already placed in
//! world space.

use std::path::{Path, PathBuf};

use crate::support::error::{Error, Location, Result};

/// One line of a scene file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneEntry {
    pub obj: PathBuf,
    pub texture: Option<PathBuf>,
    /// 1-based line number, for errors about this entry.
    pub line: usize,
}

pub fn parse_scene_file(path: &Path) -> Result<Vec<SceneEntry>> {
    let bytes = crate::support::limits::read_file(path)?;
    let text = String::from_utf8(bytes).map_err(|_| {
        Error::scene(
            Location::file(path),
            format!(
                "not a text file (invalid UTF-8), so not a scene file; the formats read are {}",
                super::format::FORMATS
            ),
        )
    })?;
    let base = path.parent().unwrap_or(Path::new(""));
    let folder = crate::support::input_path::AssetFolder::of(path);
    let mut entries = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let at = || Location::line(path, index + 1);
        let words = split_words(line).map_err(|message| Error::scene(at(), message))?;
        let admit = |what: &str, word: &str| folder.admit(&at(), what, word, Path::new(word), base);
        match words.as_slice() {
            [] => {}
            [obj] => entries.push(SceneEntry {
                obj: admit("object", obj)?,
                texture: None,
                line: index + 1,
            }),
            [obj, texture] => entries.push(SceneEntry {
                obj: admit("object", obj)?,
                texture: Some(admit("texture", texture)?),
                line: index + 1,
            }),
            more => {
                return Err(Error::scene(
                    at(),
                    format!(
                        "expected \"object.obj\" [\"texture\"], found {} words (quote paths that contain spaces)",
                        more.len()
                    ),
                ));
            }
        }
    }
    if entries.is_empty() {
        return Err(Error::scene(
            Location::file(path),
            "the scene file lists no objects",
        ));
    }
    Ok(entries)
}

/// Splits a line into words: quoted strings (which may hold spaces and `#`) or runs of
/// non-blank characters; an unquoted `#` ends the line.
fn split_words(line: &str) -> std::result::Result<Vec<String>, String> {
    let mut words = Vec::new();
    let mut chars = line.char_indices().peekable();
    while let Some(&(start, c)) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
        } else if c == '#' {
            break;
        } else if c == '"' {
            chars.next();
            let mut word = String::new();
            loop {
                match chars.next() {
                    Some((_, '"')) => break,
                    Some((_, ch)) => word.push(ch),
                    None => {
                        return Err(format!(
                            "unbalanced quote: the string opened at column {} is never closed",
                            start + 1
                        ));
                    }
                }
            }
            if word.is_empty() {
                return Err(format!("empty quoted path at column {}", start + 1));
            }
            words.push(word);
        } else {
            let mut word = String::new();
            while let Some(&(_, ch)) = chars.peek() {
                if ch.is_whitespace() || ch == '#' {
                    break;
                }
                if ch == '"' {
                    return Err(format!(
                        "unexpected quote inside the word starting at column {}",
                        start + 1
                    ));
                }
                word.push(ch);
                chars.next();
            }
            words.push(word);
        }
    }
    Ok(words)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_quotes_and_comments() {
        assert_eq!(
            split_words(r#""a b.obj" "c.tga""#).unwrap(),
            ["a b.obj", "c.tga"]
        );
        assert_eq!(
            split_words("plain.obj  # comment \"x").unwrap(),
            ["plain.obj"]
        );
        assert_eq!(
            split_words(r#""has # hash.obj""#).unwrap(),
            ["has # hash.obj"]
        );
        assert!(split_words("   # only a comment").unwrap().is_empty());
        assert!(
            split_words(r#""open.obj"#)
                .unwrap_err()
                .contains("unbalanced quote")
        );
        assert!(split_words(r#"a"b"#).is_err());
    }
}

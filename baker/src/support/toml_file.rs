//! TOML files whose errors name the file, the line and the key: the light rig
//! (`light/rig.rs`) and the materials file (`scene/materials.rs`) read their tables through
//! this, each adding the keys it knows on top (a newtype that derefs to [`Table`]).

use std::path::Path;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::error::{Error, Location, Result};

/// A file's text and name, for line numbers and messages; `make` builds the error variant
/// of the file's kind (a rig's errors are light errors, a materials file's scene errors).
pub struct Source<'a> {
    pub text: &'a str,
    pub path: &'a Path,
    make: fn(Location, String) -> Error,
}

impl<'a> Source<'a> {
    pub fn new(text: &'a str, path: &'a Path, make: fn(Location, String) -> Error) -> Self {
        Source { text, path, make }
    }

    /// The whole document, or an error at the line where the TOML breaks.
    pub fn parse(&self) -> Result<Spanned<DeTable<'a>>> {
        DeTable::parse(self.text).map_err(|err| {
            let line = err.span().map_or(1, |span| self.line(span.start));
            self.error(line, format!("invalid TOML: {}", err.message()))
        })
    }

    /// 1-based line of a byte offset.
    pub fn line(&self, offset: usize) -> usize {
        1 + self.text[..offset.min(self.text.len())]
            .bytes()
            .filter(|&b| b == b'\n')
            .count()
    }

    pub fn error(&self, line: usize, message: impl Into<String>) -> Error {
        (self.make)(Location::line(self.path, line), message.into())
    }
}

/// One table of the file, with what its errors call it.
pub struct Table<'a> {
    pub source: &'a Source<'a>,
    pub table: &'a DeTable<'a>,
    /// The line of the table's header (for missing keys).
    pub line: usize,
    /// What the table is, as the errors' prefix: "light 2, ", "material `skin`, subsurface, ";
    /// empty at the top level.
    pub what: String,
}

impl Table<'_> {
    pub fn get(&self, key: &str) -> Option<(&Spanned<DeValue<'_>>, usize)> {
        self.table
            .get_key_value(key)
            .map(|(k, v)| (v, self.source.line(k.span().start)))
    }

    /// An error about `key`, at the key's line (the table's where it is absent).
    pub fn key_error(&self, key: &str, message: impl std::fmt::Display) -> Error {
        let line = self.get(key).map_or(self.line, |(_, line)| line);
        self.source
            .error(line, format!("{}key `{key}`: {message}", self.what))
    }

    pub fn type_error(&self, key: &str, expected: &str, found: &DeValue<'_>) -> Error {
        self.key_error(
            key,
            format!("expected {expected}, found a {}", found.type_str()),
        )
    }

    /// A required key that is absent, at the table's line: "light 1: missing key `x` (why)".
    pub fn missing(&self, key: &str, why: &str) -> Error {
        let what = self.what.trim_end_matches(", ");
        let what = if what.is_empty() {
            String::new()
        } else {
            format!("{what}: ")
        };
        self.source
            .error(self.line, format!("{what}missing key `{key}` ({why})"))
    }
}

/// A TOML integer (any radix) or float as f64.
pub fn to_number(value: &DeValue<'_>) -> Option<f64> {
    match value {
        DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
            .ok()
            .map(|i| i as f64),
        DeValue::Float(f) => f.as_str().parse().ok(),
        _ => None,
    }
}

//! Loading RON files into typed, validated values with errors that name file, line and field.

use std::fmt;
use std::path::{Path, PathBuf};

use ron::extensions::Extensions;
use serde::de::DeserializeOwned;

use crate::locate::{locate, parse_path};
use crate::validate::{Validate, Validator};

/// A value read from a file, with where it came from (relative paths inside it resolve
/// against `dir`).
#[derive(Debug, Clone)]
pub struct Loaded<T> {
    pub value: T,
    /// The file's name as given, or `<embedded NAME>` for shipped files.
    pub origin: String,
    /// Directory that relative paths in the file are resolved against; `None` for embedded
    /// files (they resolve against the other shipped files).
    pub dir: Option<PathBuf>,
}

/// One thing wrong with a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// 1-based line and column, when known.
    pub line: Option<usize>,
    pub col: Option<usize>,
    /// Field path (`robot.pivot.min_depth_m`); empty when the file is unreadable as a whole.
    pub field: String,
    pub message: String,
}

/// Why a file could not be used; lists every problem found.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    pub file: String,
    pub problems: Vec<Problem>,
}

impl std::error::Error for ConfigError {}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, p) in self.problems.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}", self.file)?;
            if let Some(line) = p.line {
                write!(f, ":{line}")?;
                if let Some(col) = p.col {
                    write!(f, ":{col}")?;
                }
            }
            if p.field.is_empty() {
                write!(f, ": {}", p.message)?;
            } else {
                write!(f, ": field `{}`: {}", p.field, p.message)?;
            }
        }
        Ok(())
    }
}

impl ConfigError {
    fn single(file: &str, problem: Problem) -> Self {
        Self {
            file: file.to_string(),
            problems: vec![problem],
        }
    }
}

/// The RON dialect every pulsetrack file is read with: `Option` fields may be written bare.
pub fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(Extensions::IMPLICIT_SOME)
}

/// Parse and validate `source`; `origin` names it in errors.
pub fn load_str<T: DeserializeOwned + Validate>(
    origin: &str,
    source: &str,
) -> Result<T, ConfigError> {
    let options = ron_options();
    let mut de = ron::Deserializer::from_str_with_options(source, &options)
        .map_err(|e| ConfigError::single(origin, spanned_problem(&e, String::new())))?;
    let value: T = match serde_path_to_error::deserialize(&mut de) {
        Ok(v) => v,
        Err(e) => {
            let field = clean_path(&e.path().to_string());
            let spanned = de.span_error(e.into_inner());
            return Err(ConfigError::single(
                origin,
                spanned_problem(&spanned, field),
            ));
        }
    };
    if let Err(e) = de.end() {
        let spanned = de.span_error(e);
        return Err(ConfigError::single(
            origin,
            spanned_problem(&spanned, String::new()),
        ));
    }
    let mut v = Validator::new();
    value.validate(&mut v);
    let problems = v.into_problems();
    if problems.is_empty() {
        return Ok(value);
    }
    let problems = problems
        .into_iter()
        .map(|p| {
            let at = locate(source, &parse_path(&p.field));
            Problem {
                line: at.map(|a| a.line),
                col: at.map(|a| a.col),
                field: p.field,
                message: p.message,
            }
        })
        .collect();
    Err(ConfigError {
        file: origin.to_string(),
        problems,
    })
}

/// Read, parse and validate a file.
pub fn load_file<T: DeserializeOwned + Validate>(path: &Path) -> Result<Loaded<T>, ConfigError> {
    let origin = path.display().to_string();
    let source = std::fs::read_to_string(path).map_err(|e| {
        ConfigError::single(
            &origin,
            Problem {
                line: None,
                col: None,
                field: String::new(),
                message: format!("cannot read: {e}"),
            },
        )
    })?;
    let value = load_str(&origin, &source)?;
    let dir = path.parent().map(|d| {
        if d.as_os_str().is_empty() {
            PathBuf::from(".")
        } else {
            d.to_path_buf()
        }
    });
    Ok(Loaded { value, origin, dir })
}

fn spanned_problem(e: &ron::error::SpannedError, field: String) -> Problem {
    Problem {
        line: Some(e.span.start.line),
        col: Some(e.span.start.col),
        field,
        message: e.code.to_string(),
    }
}

/// serde_path_to_error writes `.` for the root and `?` for unknown steps.
fn clean_path(p: &str) -> String {
    if p == "." {
        String::new()
    } else {
        p.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Demo {
        version: u32,
        inner: Inner,
        #[serde(default)]
        step_m: Option<f64>,
    }
    #[derive(Debug, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Inner {
        gain: f64,
    }
    impl Validate for Demo {
        fn validate(&self, v: &mut Validator) {
            v.check(self.version == 1, "version", "unsupported");
            v.at("inner", |v| v.positive("gain", self.inner.gain));
        }
    }

    #[test]
    fn accepts_a_good_file_with_bare_options() {
        let d: Demo =
            load_str("demo.ron", "(version: 1, inner: (gain: 2.0), step_m: 0.01)").unwrap();
        assert_eq!(d.step_m, Some(0.01));
    }

    #[test]
    fn unknown_field_names_line_and_field() {
        let src = "(\n  version: 1,\n  inner: (gain: 2.0, gian: 3.0),\n)";
        let e = load_str::<Demo>("demo.ron", src).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("demo.ron:3:"), "{msg}");
        assert!(msg.contains("gian"), "{msg}");
        assert!(msg.contains("inner"), "{msg}");
    }

    #[test]
    fn validation_error_is_located() {
        let src = "(\n  version: 1,\n  inner: (\n    gain: -2.0,\n  ),\n)";
        let e = load_str::<Demo>("demo.ron", src).unwrap_err();
        assert_eq!(e.problems.len(), 1);
        assert_eq!(e.problems[0].line, Some(4));
        assert_eq!(e.problems[0].field, "inner.gain");
        assert!(
            e.to_string()
                .contains("demo.ron:4:5: field `inner.gain`: must be positive")
        );
    }

    #[test]
    fn syntax_errors_and_trailing_garbage_are_located() {
        let e = load_str::<Demo>("d.ron", "(version: 1, inner: (gain: 2.0)) junk").unwrap_err();
        assert_eq!(e.problems[0].line, Some(1));
        let e = load_str::<Demo>("d.ron", "(version: 1,\n inner: (gain: \"x\"))").unwrap_err();
        assert_eq!(e.problems[0].line, Some(2));
        assert_eq!(e.problems[0].field, "inner.gain");
        let e = load_str::<Demo>("d.ron", "").unwrap_err();
        assert!(!e.problems.is_empty());
    }

    #[test]
    fn unreadable_file_is_named() {
        let e = load_file::<Demo>(Path::new("/nonexistent/x.ron")).unwrap_err();
        assert!(e.to_string().starts_with("/nonexistent/x.ron: cannot read"));
    }
}

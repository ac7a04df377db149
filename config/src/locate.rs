//! Find where a field sits in RON source text.
//!
//! Deserialization errors carry a position from the parser, but validation runs on the typed
//! value and only knows the field's path (`robot.pivot.min_depth_m`, `control.pd.kp[1]`). This
//! module walks the RON tokens, keeping the stack of keys and list indices, and reports the
//! line and column where a path's key (or list element) begins. Enum variant names that serde
//! puts in paths (`backend.Sim.scene`) are matched loosely: a path segment that names no key
//! at that level is skipped.

/// One step of a field path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Segment {
    Key(String),
    Index(usize),
}

/// Parse `a.b[2].c` into segments. Tolerates the `?` and `<..>` serde_path_to_error uses for
/// unknown positions by dropping them.
pub fn parse_path(path: &str) -> Vec<Segment> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut rest = part;
        let key_end = rest.find('[').unwrap_or(rest.len());
        let key = &rest[..key_end];
        if !key.is_empty() && key != "?" && !key.starts_with('<') {
            out.push(Segment::Key(key.to_string()));
        }
        rest = &rest[key_end..];
        while let Some(open) = rest.find('[') {
            let Some(close) = rest[open..].find(']') else {
                break;
            };
            if let Ok(i) = rest[open + 1..open + close].parse::<usize>() {
                out.push(Segment::Index(i));
            }
            rest = &rest[open + close + 1..];
        }
    }
    out
}

/// A 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineCol {
    pub line: usize,
    pub col: usize,
}

#[derive(Debug)]
struct Frame {
    /// Bracket lists count elements; braces hold keys; parens hold keys (a struct) unless no
    /// key has been seen in them (a tuple, which counts elements like a list).
    bracket: bool,
    brace: bool,
    saw_key: bool,
    key: Option<String>,
    index: usize,
    /// The list has seen a value since its last comma (so a trailing comma adds nothing).
    list_has_value: bool,
}

impl Frame {
    fn is_list(&self) -> bool {
        self.bracket || (!self.brace && !self.saw_key)
    }
}

/// Where `path` begins in `source`, or the deepest existing ancestor of it if the field is
/// absent (it took its default). `None` only if not even the first key is present.
pub fn locate(source: &str, path: &[Segment]) -> Option<LineCol> {
    let mut scanner = Scanner::new(source);
    let mut stack: Vec<Frame> = Vec::new();
    let mut best: Option<(usize, LineCol)> = None;
    let mut pending_ident: Option<(String, LineCol)> = None;

    while let Some((tok, at)) = scanner.next_token() {
        match tok {
            Token::Ident(name) => {
                note_list_value(&mut stack, &mut best, path, at);
                pending_ident = Some((name, at));
            }
            Token::Colon => {
                if let (Some((name, at)), Some(frame)) = (pending_ident.take(), stack.last_mut())
                    && !frame.bracket
                {
                    frame.saw_key = true;
                    frame.list_has_value = false;
                    frame.key = Some(name);
                    consider(&stack, &mut best, path, at);
                }
            }
            Token::Open(kind) => {
                if pending_ident.take().is_none() {
                    note_list_value(&mut stack, &mut best, path, at);
                }
                stack.push(Frame {
                    bracket: kind == '[',
                    brace: kind == '{',
                    saw_key: false,
                    key: None,
                    index: 0,
                    list_has_value: false,
                });
            }
            Token::Close => {
                pending_ident = None;
                stack.pop();
            }
            Token::Comma => {
                pending_ident = None;
                if let Some(frame) = stack.last_mut() {
                    if frame.is_list() {
                        if frame.list_has_value {
                            frame.index += 1;
                        }
                        frame.list_has_value = false;
                    } else {
                        frame.key = None;
                    }
                }
            }
            Token::Value => {
                pending_ident = None;
                note_list_value(&mut stack, &mut best, path, at);
            }
        }
    }
    best.map(|(_, at)| at)
}

fn note_list_value(
    stack: &mut [Frame],
    best: &mut Option<(usize, LineCol)>,
    path: &[Segment],
    at: LineCol,
) {
    let first_value = match stack.last_mut() {
        Some(frame) if frame.is_list() && !frame.list_has_value => {
            frame.list_has_value = true;
            true
        }
        _ => false,
    };
    if first_value {
        consider(stack, best, path, at);
    }
}

/// Score how much of `path` the current stack matches and keep the deepest match.
fn consider(stack: &[Frame], best: &mut Option<(usize, LineCol)>, path: &[Segment], at: LineCol) {
    let mut matched = 0;
    for frame in stack {
        let here = if frame.is_list() {
            if !frame.list_has_value {
                break;
            }
            Segment::Index(frame.index)
        } else {
            match &frame.key {
                Some(k) => Segment::Key(k.clone()),
                None => break,
            }
        };
        // Skip path segments (enum variant names) that the source has no key for.
        let mut probe = matched;
        while probe < path.len() && path[probe] != here {
            match &path[probe] {
                Segment::Key(k) if k.starts_with(|c: char| c.is_ascii_uppercase()) => probe += 1,
                _ => return,
            }
        }
        if probe == path.len() {
            return;
        }
        matched = probe + 1;
    }
    if matched > 0 && best.is_none_or(|(m, _)| matched > m) {
        *best = Some((matched, at));
    }
}

#[derive(Debug)]
enum Token {
    Ident(String),
    Colon,
    Open(char),
    Close,
    Comma,
    Value,
}

struct Scanner<'a> {
    chars: std::iter::Peekable<std::str::CharIndices<'a>>,
    line: usize,
    col: usize,
}

impl<'a> Scanner<'a> {
    fn new(source: &'a str) -> Self {
        Self {
            chars: source.char_indices().peekable(),
            line: 1,
            col: 1,
        }
    }

    fn bump(&mut self) -> Option<char> {
        let (_, c) = self.chars.next()?;
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }

    fn peek(&mut self) -> Option<char> {
        self.chars.peek().map(|&(_, c)| c)
    }

    fn next_token(&mut self) -> Option<(Token, LineCol)> {
        loop {
            let c = self.peek()?;
            let at = LineCol {
                line: self.line,
                col: self.col,
            };
            match c {
                c if c.is_whitespace() => {
                    self.bump();
                }
                '/' => {
                    self.bump();
                    match self.peek() {
                        Some('/') => {
                            while let Some(c) = self.bump() {
                                if c == '\n' {
                                    break;
                                }
                            }
                        }
                        Some('*') => {
                            self.bump();
                            self.skip_block_comment();
                        }
                        _ => return Some((Token::Value, at)),
                    }
                }
                '(' | '[' | '{' => {
                    self.bump();
                    return Some((Token::Open(c), at));
                }
                ')' | ']' | '}' => {
                    self.bump();
                    return Some((Token::Close, at));
                }
                ',' => {
                    self.bump();
                    return Some((Token::Comma, at));
                }
                ':' => {
                    self.bump();
                    return Some((Token::Colon, at));
                }
                '"' => {
                    self.bump();
                    self.skip_string();
                    return Some((Token::Value, at));
                }
                '\'' => {
                    self.bump();
                    while let Some(c) = self.bump() {
                        match c {
                            '\\' => {
                                self.bump();
                            }
                            '\'' => break,
                            _ => {}
                        }
                    }
                    return Some((Token::Value, at));
                }
                'r' => {
                    let word = self.word();
                    if word == "r" && matches!(self.peek(), Some('"') | Some('#')) {
                        self.skip_raw_string();
                        return Some((Token::Value, at));
                    }
                    return Some((Token::Ident(word), at));
                }
                c if c.is_alphabetic() || c == '_' => {
                    let word = self.word();
                    return Some((Token::Ident(word), at));
                }
                _ => {
                    // Numbers, signs and anything else are values.
                    while let Some(c) = self.peek() {
                        if c.is_whitespace() || "()[]{},:\"/".contains(c) {
                            break;
                        }
                        self.bump();
                    }
                    return Some((Token::Value, at));
                }
            }
        }
    }

    fn word(&mut self) -> String {
        let mut w = String::new();
        while let Some(c) = self.peek() {
            if c.is_alphanumeric() || c == '_' {
                w.push(c);
                self.bump();
            } else {
                break;
            }
        }
        w
    }

    fn skip_string(&mut self) {
        while let Some(c) = self.bump() {
            match c {
                '\\' => {
                    self.bump();
                }
                '"' => break,
                _ => {}
            }
        }
    }

    fn skip_raw_string(&mut self) {
        let mut hashes = 0;
        while self.peek() == Some('#') {
            self.bump();
            hashes += 1;
        }
        if self.bump() != Some('"') {
            return;
        }
        'outer: while let Some(c) = self.bump() {
            if c == '"' {
                for _ in 0..hashes {
                    if self.peek() != Some('#') {
                        continue 'outer;
                    }
                    self.bump();
                }
                break;
            }
        }
    }

    fn skip_block_comment(&mut self) {
        let mut depth = 1;
        while depth > 0 {
            match self.bump() {
                None => return,
                Some('*') if self.peek() == Some('/') => {
                    self.bump();
                    depth -= 1;
                }
                Some('/') if self.peek() == Some('*') => {
                    self.bump();
                    depth += 1;
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SRC: &str = r#"Config(
    version: 1,
    // a comment with robot: (inside)
    robot: (
        pivot: (min_depth_m: 0.05, max_depth_m: 0.3),
        gains: [1.0, 2.0,
            3.0],
        name: "a \"quoted\" ( string",
    ),
    backend: Sim(scene: "x.ron", seed: 3),
    nested: [[1, 2], [3, 4]],
    tuple: (0.1, (2, 3)),
)"#;

    fn at(path: &str) -> Option<(usize, usize)> {
        locate(SRC, &parse_path(path)).map(|p| (p.line, p.col))
    }

    #[test]
    fn finds_keys_indices_and_variants() {
        assert_eq!(at("version"), Some((2, 5)));
        assert_eq!(at("robot.pivot.max_depth_m"), Some((5, 36)));
        assert_eq!(at("robot.gains[2]"), Some((7, 13)));
        assert_eq!(at("robot.gains[0]"), Some((6, 17)));
        assert_eq!(at("backend.Sim.seed"), Some((10, 34)));
        assert_eq!(at("nested[1][0]"), Some((11, 23)));
        assert_eq!(at("tuple[1][1]"), Some((12, 22)));
        assert_eq!(at("tuple[0]"), Some((12, 13)));
    }

    #[test]
    fn absent_field_points_at_its_deepest_ancestor() {
        assert_eq!(at("robot.pivot.rod_length_m"), Some((5, 9)));
        assert_eq!(at("missing.entirely"), None);
    }

    #[test]
    fn parses_paths() {
        assert_eq!(
            parse_path("a.b[2][3].c"),
            vec![
                Segment::Key("a".into()),
                Segment::Key("b".into()),
                Segment::Index(2),
                Segment::Index(3),
                Segment::Key("c".into())
            ]
        );
        assert_eq!(parse_path("?.x"), vec![Segment::Key("x".into())]);
    }
}

//! Where things are in the manifest text: a lenient scan of the RON source that finds each mask
//! entry and each of its fields, so errors that serde cannot place (semantic checks) and errors it
//! places without naming the field (type and syntax errors) can both name a line, column and field.
//!
//! The scan never fails: on malformed text it recovers at the next plausible token and simply
//! knows less. It understands RON's comments (`//`, nested `/* */`), strings (with escapes, raw
//! `r#"…"#` and byte strings), char literals, optional struct names (`Mask(…)`) and leading
//! `#![enable(…)]` attributes.

/// A place in the text: byte offset plus the 1-based line and column (in `char`s) that ron uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Pos {
    /// Byte offset into the text.
    pub offset: usize,
    /// 1-based line; lines are separated by `\n`.
    pub line: usize,
    /// 1-based column, counted in `char`s.
    pub col: usize,
}

/// One `key: value` pair of a mask entry.
#[derive(Debug)]
pub(crate) struct FieldSource {
    /// The key as written.
    pub name: String,
    /// Start of the key.
    pub key: Pos,
    /// Start of the value (the key's position when the value is missing).
    pub value: Pos,
    /// Just past the value's last token (past the colon when the value is missing).
    pub value_end: Pos,
    /// Byte offset just past the field: past its trailing comma, or the offset of whatever ended
    /// it (the closing parenthesis or the next key), or one past the end of the text.
    pub end: usize,
}

/// One element of the `masks` list.
#[derive(Debug)]
pub(crate) struct MaskSource {
    /// Start of the element (its struct name or opening parenthesis).
    pub start: Pos,
    /// Byte offset just past the element's closing parenthesis (one past the end of the text if
    /// it is unclosed).
    pub end: usize,
    /// Fields in source order.
    pub fields: Vec<FieldSource>,
    /// The `name` field's value when it is a string literal without escapes.
    pub name: Option<String>,
}

impl MaskSource {
    /// The last occurrence of field `name`, if written.
    pub fn field(&self, name: &str) -> Option<&FieldSource> {
        self.fields.iter().rev().find(|f| f.name == name)
    }
}

/// The located mask entries of a manifest text.
#[derive(Debug)]
pub(crate) struct SourceMap {
    /// Elements of the `masks` list, in order.
    pub masks: Vec<MaskSource>,
    /// Start of every line (byte offsets), for converting ron's line/column to offsets.
    line_starts: Vec<usize>,
}

/// What an offset falls in: a mask entry (by index) and possibly one of its fields (by index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Located {
    pub mask: usize,
    pub field: Option<usize>,
}

impl SourceMap {
    /// Scans `text`.
    pub fn scan(text: &str) -> SourceMap {
        let tokens = tokenize(text);
        let mut parser = Parser {
            tokens: &tokens,
            i: 0,
            text_end: end_pos(text),
        };
        SourceMap {
            masks: parser.manifest(),
            line_starts: std::iter::once(0)
                .chain(text.match_indices('\n').map(|(i, _)| i + 1))
                .collect(),
        }
    }

    /// The byte offset of a 1-based line and char column of `text` (clamped to the text).
    pub fn offset_of(&self, text: &str, line: usize, col: usize) -> usize {
        let Some(&start) = self.line_starts.get(line.saturating_sub(1)) else {
            return text.len();
        };
        let line_text = text[start..].split('\n').next().unwrap_or_default();
        start
            + line_text
                .char_indices()
                .nth(col.saturating_sub(1))
                .map_or(line_text.len(), |(i, _)| i)
    }

    /// The position of `offset` (a char boundary of `text`).
    fn pos_of(&self, text: &str, offset: usize) -> Pos {
        let line = self.line_starts.partition_point(|&start| start <= offset);
        let start = self.line_starts[line - 1];
        Pos {
            offset,
            line,
            col: text[start..offset].chars().count() + 1,
        }
    }

    /// The first position at or after `offset` (a char boundary of `text`) that is neither
    /// whitespace nor inside a comment: where the next token starts, or the end of the text.
    pub fn next_token(&self, text: &str, offset: usize) -> Pos {
        let mut cursor = Cursor {
            text,
            pos: self.pos_of(text, offset),
        };
        cursor.skip_blank();
        cursor.pos
    }

    /// The mask entry and field that byte `offset` falls in.
    pub fn locate(&self, offset: usize) -> Option<Located> {
        let (mask, entry) = self
            .masks
            .iter()
            .enumerate()
            .find(|(_, m)| (m.start.offset..m.end).contains(&offset))?;
        let field = entry
            .fields
            .iter()
            .position(|f| (f.key.offset..f.end).contains(&offset));
        Some(Located { mask, field })
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Open(char),
    Close(char),
    Comma,
    Colon,
    Ident(String),
    /// A string literal: `Some(content)` when it has no escapes (or is raw), else `None`.
    Str(Option<String>),
    /// Anything else: numbers, chars, `#`, `!`, unknown characters.
    Other,
}

#[derive(Clone, Debug)]
struct Token {
    kind: Kind,
    pos: Pos,
    /// Just past the token.
    end: Pos,
}

/// A `char` cursor that tracks line and column as ron counts them.
struct Cursor<'a> {
    text: &'a str,
    pos: Pos,
}

impl Cursor<'_> {
    fn peek(&self) -> Option<char> {
        self.text[self.pos.offset..].chars().next()
    }

    fn peek_at(&self, n: usize) -> Option<char> {
        self.text[self.pos.offset..].chars().nth(n)
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.pos.offset += c.len_utf8();
        if c == '\n' {
            self.pos.line += 1;
            self.pos.col = 1;
        } else {
            self.pos.col += 1;
        }
        Some(c)
    }

    fn starts_with(&self, s: &str) -> bool {
        self.text[self.pos.offset..].starts_with(s)
    }

    /// Skips whitespace and comments.
    fn skip_blank(&mut self) {
        loop {
            if self.peek().is_some_and(char::is_whitespace) {
                self.bump();
            } else if self.starts_with("//") {
                while self.peek().is_some_and(|c| c != '\n') {
                    self.bump();
                }
            } else if self.starts_with("/*") {
                self.block_comment();
            } else {
                return;
            }
        }
    }

    /// Skips a `/* … */` comment (nested), the cursor being on its `/`.
    fn block_comment(&mut self) {
        self.bump();
        self.bump();
        let mut depth = 1usize;
        while depth > 0 {
            if self.starts_with("/*") {
                self.bump();
                self.bump();
                depth += 1;
            } else if self.starts_with("*/") {
                self.bump();
                self.bump();
                depth -= 1;
            } else if self.bump().is_none() {
                return;
            }
        }
    }

    /// Reads a `"…"` string with escapes, the cursor being on the opening quote.
    fn quoted(&mut self) -> Option<String> {
        self.bump();
        let start = self.pos.offset;
        let mut escaped = false;
        loop {
            match self.bump() {
                None => return None,
                Some('\\') => {
                    escaped = true;
                    self.bump();
                }
                Some('"') => break,
                Some(_) => {}
            }
        }
        let content = &self.text[start..self.pos.offset - 1];
        (!escaped).then(|| content.to_owned())
    }

    /// Reads a raw string `r#…#"…"#…#`, the cursor being on its first `#` or `"`.
    fn raw(&mut self) -> Option<String> {
        let mut hashes = 0;
        while self.peek() == Some('#') {
            self.bump();
            hashes += 1;
        }
        self.bump(); // the opening quote
        let start = self.pos.offset;
        let terminator: String = std::iter::once('"')
            .chain(std::iter::repeat_n('#', hashes))
            .collect();
        loop {
            if self.starts_with(&terminator) {
                let content = self.text[start..self.pos.offset].to_owned();
                for _ in 0..terminator.len() {
                    self.bump();
                }
                return Some(content);
            }
            self.bump()?;
        }
    }

    /// Skips a `'…'` char literal, the cursor being on the opening quote.
    fn char_literal(&mut self) {
        self.bump();
        loop {
            match self.bump() {
                None | Some('\'') => return,
                Some('\\') => {
                    self.bump();
                }
                Some(_) => {}
            }
        }
    }

    fn ident(&mut self) -> String {
        let start = self.pos.offset;
        while self.peek().is_some_and(is_ident_char) {
            self.bump();
        }
        self.text[start..self.pos.offset].to_owned()
    }
}

fn is_ident_start(c: char) -> bool {
    c == '_' || c.is_alphabetic()
}

fn is_ident_char(c: char) -> bool {
    c == '_' || c.is_alphanumeric()
}

/// Whether the cursor is at a raw string (`r"`, `r#"`, `br"`…), given the prefix length.
fn raw_string_at(cursor: &Cursor<'_>, prefix: usize) -> bool {
    let mut n = prefix;
    while cursor.peek_at(n) == Some('#') {
        n += 1;
    }
    cursor.peek_at(n) == Some('"')
}

fn end_pos(text: &str) -> Pos {
    Pos {
        offset: text.len(),
        line: 1 + text.matches('\n').count(),
        col: 1 + text.rsplit('\n').next().unwrap_or_default().chars().count(),
    }
}

fn tokenize(text: &str) -> Vec<Token> {
    let mut cursor = Cursor {
        text,
        pos: Pos {
            offset: 0,
            line: 1,
            col: 1,
        },
    };
    let mut tokens = Vec::new();
    cursor.skip_blank();
    while let Some(c) = cursor.peek() {
        let pos = cursor.pos;
        let kind = if c == '"' {
            Kind::Str(cursor.quoted())
        } else if c == 'b' && cursor.peek_at(1) == Some('"') {
            cursor.bump();
            Kind::Str(cursor.quoted())
        } else if c == 'r' && raw_string_at(&cursor, 1) {
            cursor.bump();
            Kind::Str(cursor.raw())
        } else if cursor.starts_with("br") && raw_string_at(&cursor, 2) {
            cursor.bump();
            cursor.bump();
            Kind::Str(cursor.raw())
        } else if c == '\'' {
            cursor.char_literal();
            Kind::Other
        } else if c == 'r' && cursor.peek_at(1) == Some('#') {
            // A raw identifier `r#name`.
            cursor.bump();
            cursor.bump();
            Kind::Ident(cursor.ident())
        } else if is_ident_start(c) {
            Kind::Ident(cursor.ident())
        } else {
            cursor.bump();
            match c {
                '(' | '[' | '{' => Kind::Open(c),
                ')' | ']' | '}' => Kind::Close(c),
                ',' => Kind::Comma,
                ':' => Kind::Colon,
                _ => Kind::Other,
            }
        };
        tokens.push(Token {
            kind,
            pos,
            end: cursor.pos,
        });
        cursor.skip_blank();
    }
    tokens
}

struct Parser<'t> {
    tokens: &'t [Token],
    i: usize,
    text_end: Pos,
}

impl Parser<'_> {
    fn kind(&self, i: usize) -> Option<&Kind> {
        self.tokens.get(i).map(|t| &t.kind)
    }

    fn pos(&self, i: usize) -> Pos {
        self.tokens.get(i).map_or(self.text_end, |t| t.pos)
    }

    fn end(&self, i: usize) -> Pos {
        self.tokens.get(i).map_or(self.text_end, |t| t.end)
    }

    /// Whether token `i` starts a `key:` pair.
    fn is_key(&self, i: usize) -> bool {
        matches!(self.kind(i), Some(Kind::Ident(_))) && self.kind(i + 1) == Some(&Kind::Colon)
    }

    /// Skips one value starting at the cursor: up to (not including) the comma, closing bracket
    /// or next `key:` at the current nesting level.
    fn skip_value(&mut self) {
        let mut depth = 0usize;
        while let Some(kind) = self.kind(self.i) {
            match kind {
                Kind::Open(_) => depth += 1,
                Kind::Close(_) if depth == 0 => return,
                Kind::Close(_) => depth -= 1,
                Kind::Comma if depth == 0 => return,
                Kind::Ident(_) if depth == 0 && self.is_key(self.i) => return,
                _ => {}
            }
            self.i += 1;
        }
    }

    /// Consumes an optional struct name and an opening parenthesis; `false` (consuming nothing)
    /// if the cursor is not at a struct.
    fn open_struct(&mut self) -> bool {
        let skip = usize::from(matches!(self.kind(self.i), Some(Kind::Ident(_))));
        if self.kind(self.i + skip) == Some(&Kind::Open('(')) {
            self.i += skip + 1;
            true
        } else {
            false
        }
    }

    /// The fields of a struct whose opening parenthesis has been consumed, and the byte offset
    /// just past its closing parenthesis (one past the end of the text if it has none); leaves
    /// the cursor past the closing parenthesis. `on_field` sees each field with the cursor at its
    /// value and may consume the value itself (it is skipped otherwise).
    fn struct_fields(
        &mut self,
        mut on_field: impl FnMut(&mut Self, &str),
    ) -> (Vec<FieldSource>, usize) {
        let mut fields = Vec::new();
        while let Some(kind) = self.kind(self.i) {
            match kind {
                Kind::Close(_) => {
                    self.i += 1;
                    return (fields, self.pos(self.i - 1).offset + 1);
                }
                Kind::Ident(name) if self.is_key(self.i) => {
                    let name = name.clone();
                    let key = self.pos(self.i);
                    self.i += 2;
                    let value =
                        if matches!(self.kind(self.i), Some(Kind::Comma | Kind::Close(_)) | None) {
                            key
                        } else {
                            self.pos(self.i)
                        };
                    let before = self.i;
                    on_field(self, &name);
                    if self.i == before {
                        self.skip_value();
                    }
                    // The last token of the value, or the colon.
                    let value_end = self.end(self.i - 1);
                    let mut end = self.end_at_cursor();
                    if self.kind(self.i) == Some(&Kind::Comma) {
                        self.i += 1;
                        end = self.pos(self.i - 1).offset + 1;
                    }
                    fields.push(FieldSource {
                        name,
                        key,
                        value,
                        value_end,
                        end,
                    });
                }
                _ => {
                    // Not a `key:` (or a key without its colon): recover at the next comma or key.
                    self.skip_value();
                    if self.kind(self.i) == Some(&Kind::Comma) {
                        self.i += 1;
                    }
                }
            }
        }
        (fields, self.end_at_cursor())
    }

    /// The offset of the token at the cursor, or one past the end of the text at the end (so a
    /// range ending there contains errors ron reports at the very end).
    fn end_at_cursor(&self) -> usize {
        if self.i < self.tokens.len() {
            self.pos(self.i).offset
        } else {
            self.text_end.offset + 1
        }
    }

    /// The top level: attributes, then the manifest struct; returns the `masks` elements.
    fn manifest(&mut self) -> Vec<MaskSource> {
        // `#![enable(…)]` attributes: `#`, `!`, then a bracketed group.
        while self.kind(self.i) == Some(&Kind::Other) {
            self.i += 1;
            if self.kind(self.i) == Some(&Kind::Open('[')) {
                self.i += 1;
                self.skip_value();
                self.i += 1;
            }
        }
        let mut masks = Vec::new();
        if self.open_struct() {
            self.struct_fields(|parser, name| {
                if name == "masks" && parser.kind(parser.i) == Some(&Kind::Open('[')) {
                    parser.i += 1;
                    parser.mask_list(&mut masks);
                }
            });
        }
        masks
    }

    /// The elements of the `masks` list, its `[` consumed; leaves the cursor past the `]`.
    fn mask_list(&mut self, masks: &mut Vec<MaskSource>) {
        while let Some(kind) = self.kind(self.i) {
            match kind {
                Kind::Close(_) => {
                    self.i += 1;
                    return;
                }
                Kind::Comma => self.i += 1,
                _ => {
                    let start = self.pos(self.i);
                    if self.open_struct() {
                        let mut name = None;
                        let (fields, end) = self.struct_fields(|parser, field| {
                            if let (true, Some(Kind::Str(Some(value)))) =
                                (field == "name", parser.kind(parser.i))
                            {
                                name = Some(value.clone());
                            }
                        });
                        masks.push(MaskSource {
                            start,
                            end,
                            fields,
                            name,
                        });
                    } else {
                        self.skip_value();
                        if self.i < self.tokens.len()
                            && !matches!(self.kind(self.i), Some(Kind::Comma | Kind::Close(_)))
                        {
                            self.i += 1;
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r##"#![enable(implicit_some)]
// A comment with (unbalanced [ brackets and "quotes
(
    masks: [
        Mask(
            name: "first", /* nested /* block */ comment ) */
            size: (8, 8, 4),
            sigma: 1.9,
        ),
        (
            name: r#"se"cond"#,
            seed: 3
            kind: Blue2D,
        ),
    ],
)
"##;

    #[test]
    fn finds_masks_and_fields() {
        let map = SourceMap::scan(TEXT);
        assert_eq!(map.masks.len(), 2);
        let first = &map.masks[0];
        assert_eq!(first.name.as_deref(), Some("first"));
        assert_eq!((first.start.line, first.start.col), (5, 9));
        let names: Vec<_> = first.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["name", "size", "sigma"]);
        let size = first.field("size").unwrap();
        assert_eq!((size.key.line, size.key.col), (7, 13));
        assert_eq!((size.value.line, size.value.col), (7, 19));
        assert_eq!((size.value_end.line, size.value_end.col), (7, 28));
        let second = &map.masks[1];
        assert_eq!(second.name.as_deref(), Some("se\"cond"));
        // The missing comma after `seed: 3` still separates the fields.
        let names: Vec<_> = second.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["name", "seed", "kind"]);
        let seed = second.field("seed").unwrap();
        assert_eq!((seed.value_end.line, seed.value_end.col), (12, 20));
        assert_eq!(second.field("kind").unwrap().value.line, 13);
    }

    #[test]
    fn locates_offsets() {
        let map = SourceMap::scan(TEXT);
        let at = |line, col| map.locate(map.offset_of(TEXT, line, col));
        // Inside `(8, 8, 4)`.
        assert_eq!(
            at(7, 23),
            Some(Located {
                mask: 0,
                field: Some(1)
            })
        );
        // On the comma after `sigma: 1.9`.
        assert_eq!(
            at(8, 23),
            Some(Located {
                mask: 0,
                field: Some(2)
            })
        );
        // The second entry's closing parenthesis.
        assert_eq!(
            at(14, 9),
            Some(Located {
                mask: 1,
                field: None
            })
        );
        assert_eq!(at(4, 5), None);
    }

    #[test]
    fn survives_truncated_and_garbage_text() {
        for text in [
            "",
            "(",
            "(masks: [(name: \"a\", size: (1, 2",
            "(masks: [(name: \"unterminated",
            "(masks: [(name: r#\"x",
            "/* open",
            "#![enable(",
            "(masks: [1, (name: \"b\")], other: {\"k\": 1})",
            "))))]]]",
        ] {
            let map = SourceMap::scan(text);
            let _ = map.locate(map.offset_of(text, 1, 1));
        }
        let map = SourceMap::scan("(masks: [1, (name: \"b\")], other: {\"k\": 1})");
        assert_eq!(map.masks.len(), 1);
        assert_eq!(map.masks[0].name.as_deref(), Some("b"));
    }

    #[test]
    fn next_token_skips_blanks_and_comments() {
        let text = "(a:  // c\n /* d\n */ 1)";
        let map = SourceMap::scan(text);
        let pos = map.next_token(text, 3);
        assert_eq!((pos.line, pos.col), (3, 5));
        assert_eq!(&text[pos.offset..], "1)");
        assert_eq!(map.next_token(text, text.len()).offset, text.len());
    }

    #[test]
    fn columns_count_chars() {
        let text = "(masks: [(name: \"é\", seed: 1)])";
        let map = SourceMap::scan(text);
        let seed = map.masks[0].field("seed").unwrap();
        assert_eq!(seed.key.col, 22);
        assert_eq!(map.offset_of(text, 1, 22), seed.key.offset);
    }
}

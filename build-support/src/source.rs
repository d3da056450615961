//! Where things are in the manifest text: a lenient scan of the RON source that finds each mask
//! entry and each of its fields, so errors that serde cannot place (semantic checks) and errors it
//! places without naming the field (type and syntax errors) can both name a line, column and field.
//!
//! The scan never fails: on malformed text it recovers at the next plausible token and simply
//! knows less. It understands RON's comments (`//`, nested `/* */`), strings (with escapes, raw
//! `r#"…"#` and byte strings), char literals, optional struct names (`Mask(…)`) and leading
//! `#![enable(…)]` attributes.
//!
//! Its memory is bounded whatever the text: tokens are produced on demand and only the two around
//! the cursor are kept, at most [`MAX_MASKS_SCANNED`] entries and [`MAX_FIELDS_SCANNED`] fields of
//! each are recorded, and line starts are found by scanning when an error needs them. A manifest
//! of millions of tokens (digits, brackets) costs time proportional to its length, not memory.

use crate::Manifest;

/// Most mask entries the scan records: one past [`Manifest::MAX_MASKS`], so the entry that breaks
/// the limit can be named. Errors past it still carry their line and column.
pub(crate) const MAX_MASKS_SCANNED: usize = Manifest::MAX_MASKS + 1;

/// Most fields recorded per struct. A mask has 20 distinct fields and ron stops at the first
/// unknown or repeated one, so no error it reports lies past the 21st.
pub(crate) const MAX_FIELDS_SCANNED: usize = 64;

/// Most open brackets [`SourceMap::unclosed`] remembers the place of; deeper ones are counted.
const MAX_OPEN_TRACKED: usize = 256;

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
    /// Fields in source order (the first [`MAX_FIELDS_SCANNED`]).
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
    /// Elements of the `masks` list, in order (the first [`MAX_MASKS_SCANNED`]).
    pub masks: Vec<MaskSource>,
    /// Start of the `masks` list's `[`, if there is one.
    pub list_start: Option<Pos>,
}

/// What an offset falls in: a mask entry (by index) and possibly one of its fields (by index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Located {
    pub mask: usize,
    pub field: Option<usize>,
}

/// A bracket that the text opens and never closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Unclosed {
    /// `(`, `[` or `{`.
    pub bracket: char,
    /// Where it is.
    pub pos: Pos,
}

impl SourceMap {
    /// Scans `text`.
    pub fn scan(text: &str) -> SourceMap {
        let mut parser = Parser::new(text);
        let masks = parser.manifest();
        SourceMap {
            masks,
            list_start: parser.list_start,
        }
    }

    /// The byte offset of a 1-based line and char column of `text` (clamped to the text).
    pub fn offset_of(&self, text: &str, line: usize, col: usize) -> usize {
        let start = match line {
            0 | 1 => 0,
            _ => match text.match_indices('\n').nth(line - 2) {
                Some((i, _)) => i + 1,
                None => return text.len(),
            },
        };
        let line_text = text[start..].split('\n').next().unwrap_or_default();
        start
            + line_text
                .char_indices()
                .nth(col.saturating_sub(1))
                .map_or(line_text.len(), |(i, _)| i)
    }

    /// The first position at or after `offset` (a char boundary of `text`) that is neither
    /// whitespace nor inside a comment: where the next token starts, or the end of the text.
    pub fn next_token(&self, text: &str, offset: usize) -> Pos {
        let mut cursor = Cursor {
            text,
            pos: pos_of(text, offset),
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

    /// The innermost bracket `text` leaves open at its end, if any; `None` also when it is nested
    /// deeper than the scan remembers places for.
    pub fn unclosed(text: &str) -> Option<Unclosed> {
        let mut open: Vec<Unclosed> = Vec::new();
        let mut untracked = 0usize;
        for token in Lexer::new(text) {
            match token.kind {
                Kind::Open(bracket) if open.len() < MAX_OPEN_TRACKED => open.push(Unclosed {
                    bracket,
                    pos: token.pos,
                }),
                Kind::Open(_) => untracked += 1,
                Kind::Close(_) if untracked > 0 => untracked -= 1,
                Kind::Close(_) => {
                    open.pop();
                }
                _ => {}
            }
        }
        if untracked > 0 { None } else { open.pop() }
    }
}

/// The position of `offset` (a char boundary of `text`).
fn pos_of(text: &str, offset: usize) -> Pos {
    let before = &text[..offset];
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    Pos {
        offset,
        line: 1 + before.matches('\n').count(),
        col: before[start..].chars().count() + 1,
    }
}

/// A token; identifiers and strings are byte ranges of the text.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Open(char),
    Close(char),
    Comma,
    Colon,
    /// An identifier: the range of its name (without a raw identifier's `r#`).
    Ident(usize, usize),
    /// A string literal: the range of its content when it has no escapes (or is raw), else
    /// `None`.
    Str(Option<(usize, usize)>),
    /// Anything else: numbers, chars, `#`, `!`, unknown characters. A number (`-1.5e-3`,
    /// sixteen million digits) is one token.
    Other,
}

#[derive(Clone, Copy, Debug)]
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
    fn quoted(&mut self) -> Option<(usize, usize)> {
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
        (!escaped).then_some((start, self.pos.offset - 1))
    }

    /// Reads a raw string `r#…#"…"#…#`, the cursor being on its first `#` or `"`.
    fn raw(&mut self) -> Option<(usize, usize)> {
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
                let content = (start, self.pos.offset);
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

    fn ident(&mut self) -> (usize, usize) {
        let start = self.pos.offset;
        while self.peek().is_some_and(is_ident_char) {
            self.bump();
        }
        (start, self.pos.offset)
    }

    /// Skips the rest of a number: digits, `_`, `.`, an exponent's `e` after a digit and its
    /// sign. A letter ends it (a suffix or a key written without a comma after the value is an
    /// identifier of its own).
    fn number_tail(&mut self, first: char) {
        let mut previous = first;
        while let Some(c) = self.peek() {
            let continues = c.is_ascii_digit()
                || c == '_'
                || c == '.'
                || (matches!(c, 'e' | 'E') && previous.is_ascii_digit())
                || (matches!(c, '+' | '-') && matches!(previous, 'e' | 'E'));
            if !continues {
                return;
            }
            self.bump();
            previous = c;
        }
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
    pos_of(text, text.len())
}

/// The tokens of a text, one at a time.
struct Lexer<'a> {
    cursor: Cursor<'a>,
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Lexer<'a> {
        let mut cursor = Cursor {
            text,
            pos: Pos {
                offset: 0,
                line: 1,
                col: 1,
            },
        };
        cursor.skip_blank();
        Lexer { cursor }
    }
}

impl Iterator for Lexer<'_> {
    type Item = Token;

    fn next(&mut self) -> Option<Token> {
        let cursor = &mut self.cursor;
        let c = cursor.peek()?;
        let pos = cursor.pos;
        let kind = if c == '"' {
            Kind::Str(cursor.quoted())
        } else if c == 'b' && cursor.peek_at(1) == Some('"') {
            cursor.bump();
            Kind::Str(cursor.quoted())
        } else if c == 'r' && raw_string_at(cursor, 1) {
            cursor.bump();
            Kind::Str(cursor.raw())
        } else if cursor.starts_with("br") && raw_string_at(cursor, 2) {
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
            let (start, end) = cursor.ident();
            Kind::Ident(start, end)
        } else if is_ident_start(c) {
            let (start, end) = cursor.ident();
            Kind::Ident(start, end)
        } else {
            cursor.bump();
            match c {
                '(' | '[' | '{' => Kind::Open(c),
                ')' | ']' | '}' => Kind::Close(c),
                ',' => Kind::Comma,
                ':' => Kind::Colon,
                '0'..='9' | '-' | '+' | '.' => {
                    cursor.number_tail(c);
                    Kind::Other
                }
                _ => Kind::Other,
            }
        };
        let token = Token {
            kind,
            pos,
            end: cursor.pos,
        };
        cursor.skip_blank();
        Some(token)
    }
}

/// A recursive-descent walk over the tokens. Nothing reads further back than the token before
/// the cursor, so only the tokens from there on are kept.
struct Parser<'a> {
    text: &'a str,
    lexer: Lexer<'a>,
    /// Tokens `first..first + window.len()`.
    window: std::collections::VecDeque<Token>,
    first: usize,
    /// The cursor: index of the current token.
    i: usize,
    text_end: Pos,
    /// Start of the `masks` list's `[`.
    list_start: Option<Pos>,
}

impl<'a> Parser<'a> {
    fn new(text: &'a str) -> Parser<'a> {
        Parser {
            text,
            lexer: Lexer::new(text),
            window: std::collections::VecDeque::new(),
            first: 0,
            i: 0,
            text_end: end_pos(text),
            list_start: None,
        }
    }

    /// Token `i` (at least the one before the cursor), lexing up to it; `None` past the end.
    fn token(&mut self, i: usize) -> Option<Token> {
        let keep_from = self.i.saturating_sub(1).min(i);
        while self.first < keep_from {
            if self.window.pop_front().is_none() && self.lexer.next().is_none() {
                return None;
            }
            self.first += 1;
        }
        while self.first + self.window.len() <= i {
            let token = self.lexer.next()?;
            self.window.push_back(token);
        }
        self.window.get(i.checked_sub(self.first)?).copied()
    }

    fn kind(&mut self, i: usize) -> Option<Kind> {
        self.token(i).map(|t| t.kind)
    }

    fn pos(&mut self, i: usize) -> Pos {
        self.token(i).map_or(self.text_end, |t| t.pos)
    }

    fn end(&mut self, i: usize) -> Pos {
        self.token(i).map_or(self.text_end, |t| t.end)
    }

    /// Whether token `i` starts a `key:` pair.
    fn is_key(&mut self, i: usize) -> bool {
        matches!(self.kind(i), Some(Kind::Ident(..))) && self.kind(i + 1) == Some(Kind::Colon)
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
                Kind::Ident(..) if depth == 0 && self.is_key(self.i) => return,
                _ => {}
            }
            self.i += 1;
        }
    }

    /// Consumes an optional struct name and an opening parenthesis; `false` (consuming nothing)
    /// if the cursor is not at a struct.
    fn open_struct(&mut self) -> bool {
        let skip = usize::from(matches!(self.kind(self.i), Some(Kind::Ident(..))));
        if self.kind(self.i + skip) == Some(Kind::Open('(')) {
            self.i += skip + 1;
            true
        } else {
            false
        }
    }

    /// The fields of a struct whose opening parenthesis has been consumed (the first
    /// [`MAX_FIELDS_SCANNED`]), and the byte offset just past its closing parenthesis (one past
    /// the end of the text if it has none); leaves the cursor past the closing parenthesis.
    /// `on_field` sees each field with the cursor at its value and may consume the value itself
    /// (it is skipped otherwise).
    fn struct_fields(
        &mut self,
        mut on_field: impl FnMut(&mut Self, &str),
    ) -> (Vec<FieldSource>, usize) {
        let mut fields = Vec::new();
        while let Some(kind) = self.kind(self.i) {
            match kind {
                Kind::Close(_) => {
                    self.i += 1;
                    let close = self.pos(self.i - 1);
                    return (fields, close.offset + 1);
                }
                Kind::Ident(start, end) if self.is_key(self.i) => {
                    let text = self.text;
                    let name = &text[start..end];
                    let key = self.pos(self.i);
                    self.i += 2;
                    let value =
                        if matches!(self.kind(self.i), Some(Kind::Comma | Kind::Close(_)) | None) {
                            key
                        } else {
                            self.pos(self.i)
                        };
                    let before = self.i;
                    on_field(self, name);
                    if self.i == before {
                        self.skip_value();
                    }
                    // The last token of the value, or the colon.
                    let value_end = self.end(self.i - 1);
                    let mut end = self.end_at_cursor();
                    if self.kind(self.i) == Some(Kind::Comma) {
                        self.i += 1;
                        end = self.pos(self.i - 1).offset + 1;
                    }
                    if fields.len() < MAX_FIELDS_SCANNED {
                        fields.push(FieldSource {
                            name: name.to_owned(),
                            key,
                            value,
                            value_end,
                            end,
                        });
                    }
                }
                _ => {
                    // Not a `key:` (or a key without its colon): recover at the next comma or key.
                    self.skip_value();
                    if self.kind(self.i) == Some(Kind::Comma) {
                        self.i += 1;
                    }
                }
            }
        }
        (fields, self.end_at_cursor())
    }

    /// The offset of the token at the cursor, or one past the end of the text at the end (so a
    /// range ending there contains errors ron reports at the very end).
    fn end_at_cursor(&mut self) -> usize {
        match self.token(self.i) {
            Some(token) => token.pos.offset,
            None => self.text_end.offset + 1,
        }
    }

    /// The top level: attributes, then the manifest struct; returns the `masks` elements.
    fn manifest(&mut self) -> Vec<MaskSource> {
        // `#![enable(…)]` attributes: `#`, `!`, then a bracketed group.
        while self.kind(self.i) == Some(Kind::Other) {
            self.i += 1;
            if self.kind(self.i) == Some(Kind::Open('[')) {
                self.i += 1;
                self.skip_value();
                self.i += 1;
            }
        }
        let mut masks = Vec::new();
        if self.open_struct() {
            self.struct_fields(|parser, name| {
                if name == "masks" && parser.kind(parser.i) == Some(Kind::Open('[')) {
                    let start = parser.pos(parser.i);
                    parser.list_start.get_or_insert(start);
                    parser.i += 1;
                    parser.mask_list(&mut masks);
                }
            });
        }
        masks
    }

    /// The elements of the `masks` list, its `[` consumed (the first [`MAX_MASKS_SCANNED`]);
    /// leaves the cursor past the `]`.
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
                            if let (true, Some(Kind::Str(Some((from, to))))) =
                                (field == "name", parser.kind(parser.i))
                            {
                                name = Some((from, to));
                            }
                        });
                        if masks.len() < MAX_MASKS_SCANNED {
                            masks.push(MaskSource {
                                start,
                                end,
                                fields,
                                name: name.map(|(from, to)| self.text[from..to].to_owned()),
                            });
                        }
                    } else {
                        self.skip_value();
                        if self.token(self.i).is_some()
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
    fn numbers_are_one_token_and_a_key_after_one_is_still_found() {
        let text = "(masks: [(seed: -1kind: Scalar, sigma: 1.5e-3, size: (1_000, 0x1F, 2))])";
        let map = SourceMap::scan(text);
        let names: Vec<_> = map.masks[0]
            .fields
            .iter()
            .map(|f| f.name.as_str())
            .collect();
        assert_eq!(names, ["seed", "kind", "sigma", "size"]);
        let sigma = map.masks[0].field("sigma").unwrap();
        assert_eq!(&text[sigma.value.offset..sigma.value_end.offset], "1.5e-3");
        let mut lexer = Lexer::new("-12345678901234567890.5e+3,");
        assert_eq!(lexer.next().unwrap().end.offset, 26);
        assert_eq!(lexer.next().unwrap().kind, Kind::Comma);
        assert!(lexer.next().is_none());
    }

    #[test]
    fn what_the_scan_records_is_bounded() {
        let many = format!("(masks: [{}])", "(),".repeat(MAX_MASKS_SCANNED + 500));
        let map = SourceMap::scan(&many);
        assert_eq!(map.masks.len(), MAX_MASKS_SCANNED);
        assert_eq!(map.list_start.map(|p| p.col), Some(9));
        let fields: String = (0..MAX_FIELDS_SCANNED + 10)
            .map(|i| format!("f{i}: {i}, "))
            .collect();
        let wide = format!("(masks: [({fields}), (name: \"b\")])");
        let map = SourceMap::scan(&wide);
        assert_eq!(map.masks[0].fields.len(), MAX_FIELDS_SCANNED);
        assert_eq!(map.masks[1].name.as_deref(), Some("b"));
        // Only the two tokens around the cursor are kept, however long the text.
        let mut parser = Parser::new(&many);
        parser.manifest();
        assert!(parser.window.len() <= 3, "{}", parser.window.len());
    }

    #[test]
    fn the_innermost_open_bracket_is_found() {
        let unclosed = |text: &str| SourceMap::unclosed(text).map(|u| (u.bracket, u.pos.col));
        assert_eq!(unclosed("(masks: ["), Some(('[', 9)));
        assert_eq!(
            unclosed("(masks: [(a: (1, 2), b: \"(\" // (\n"),
            Some(('(', 10))
        );
        assert_eq!(unclosed("(masks: [])"), None);
        assert_eq!(unclosed(""), None);
        // Deeper than the places kept: no claim about which one.
        let deep = "(".repeat(MAX_OPEN_TRACKED + 1);
        assert_eq!(unclosed(&deep), None);
        assert_eq!(unclosed(&format!("{deep})")), Some(('(', MAX_OPEN_TRACKED)));
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

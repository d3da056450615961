//! User input quoted in messages, bounded: a manifest may hold a name, a path or a number of
//! millions of characters, and a message (one `cargo::error=` line of a build script) must not
//! echo it whole. Long input is cut to its first [`MAX_QUOTED_CHARS`] characters, an ellipsis and
//! its length: `"nnnnnnnn…" (15728640 characters)`.

use std::borrow::Cow;

/// Most characters of one piece of input a message shows.
pub(crate) const MAX_QUOTED_CHARS: usize = 64;

/// The first [`MAX_QUOTED_CHARS`] characters of `text` and its length in characters, or `None`
/// when it is short enough to show whole.
fn cut(text: &str) -> Option<(&str, usize)> {
    let (end, _) = text.char_indices().nth(MAX_QUOTED_CHARS)?;
    Some((&text[..end], text.chars().count()))
}

/// `text`, or its start, `…` and its length in characters when it is long.
pub(crate) fn excerpt(text: &str) -> Cow<'_, str> {
    match cut(text) {
        None => Cow::Borrowed(text),
        Some((start, chars)) => Cow::Owned(format!("{start}… ({chars} characters)")),
    }
}

/// `text` quoted and escaped as `{:?}` does, its start only when it is long:
/// `"nnnn…" (15728640 characters)`.
pub(crate) fn quoted(text: &str) -> String {
    match cut(text) {
        None => format!("{text:?}"),
        Some((start, chars)) => {
            let escaped = format!("{start:?}");
            format!("{}…\" ({chars} characters)", &escaped[..escaped.len() - 1])
        }
    }
}

/// `text` between backticks, its start only when it is long: `` `nnnn…` (129 characters) ``.
pub(crate) fn backticked(text: &str) -> String {
    match cut(text) {
        None => format!("`{text}`"),
        Some((start, chars)) => format!("`{start}…` ({chars} characters)"),
    }
}

/// `message` (another library's, which may quote input whole) with every long segment between
/// backticks or double quotes cut as [`backticked`] and [`quoted`] cut them. Escaped quotes
/// (`\"`) inside a double-quoted segment do not end it; an unclosed segment runs to the end.
pub(crate) fn shorten_quoted(message: &str) -> Cow<'_, str> {
    let mut out = String::new();
    let mut copied = 0;
    let mut rest = message.char_indices();
    while let Some((open, delimiter)) = rest.next() {
        if delimiter != '`' && delimiter != '"' {
            continue;
        }
        let content_start = open + 1;
        let mut content_end = message.len();
        let mut close_end = message.len();
        let mut escaped = false;
        for (i, c) in rest.by_ref() {
            if escaped {
                escaped = false;
            } else if c == '\\' && delimiter == '"' {
                escaped = true;
            } else if c == delimiter {
                content_end = i;
                close_end = i + 1;
                break;
            }
        }
        let content = &message[content_start..content_end];
        if let Some((start, chars)) = cut(content) {
            out.push_str(&message[copied..content_start]);
            out.push_str(start);
            out.push('…');
            out.push_str(&message[content_end..close_end]);
            out.push_str(&format!(" ({chars} characters)"));
            copied = close_end;
        }
    }
    if copied == 0 {
        Cow::Borrowed(message)
    } else {
        out.push_str(&message[copied..]);
        Cow::Owned(out)
    }
}

/// `message` (another library's, which prints numbers with `{}`: `1e300` as 301 digits) with every
/// number longer than 17 characters rewritten by `format`. A number is a run of digits, `.`,
/// `e`/`E` and signs (a sign only at the start or after the exponent's `e`) that starts with a
/// digit or a `-` before one and parses as an `f64`; ranges such as `1..=4096` do not parse and
/// stay as they are.
pub(crate) fn compact_numbers(message: &str, format: fn(f64) -> String) -> Cow<'_, str> {
    const LONGEST_KEPT: usize = 17;
    let bytes = message.as_bytes();
    let mut out = String::new();
    let mut copied = 0;
    let mut i = 0;
    while i < bytes.len() {
        let starts_number = bytes[i].is_ascii_digit()
            || (bytes[i] == b'-' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit));
        // Not inside a word (`u32`, `e2`): the run must start after a non-alphanumeric byte.
        let word_start = i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'.');
        if !(starts_number && word_start) {
            i += 1;
            continue;
        }
        let mut end = i + 1;
        while end < bytes.len() {
            let b = bytes[end];
            let sign_after_exponent =
                matches!(b, b'+' | b'-') && matches!(bytes[end - 1], b'e' | b'E');
            if b.is_ascii_digit() || matches!(b, b'.' | b'e' | b'E') || sign_after_exponent {
                end += 1;
            } else {
                break;
            }
        }
        let run = &message[i..end];
        if run.len() > LONGEST_KEPT
            && let Ok(value) = run.parse::<f64>()
        {
            out.push_str(&message[copied..i]);
            out.push_str(&format(value));
            copied = end;
        }
        i = end;
    }
    if copied == 0 {
        Cow::Borrowed(message)
    } else {
        out.push_str(&message[copied..]);
        Cow::Owned(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_input_is_shown_whole() {
        let exactly = "n".repeat(MAX_QUOTED_CHARS);
        assert_eq!(excerpt(&exactly), exactly);
        assert_eq!(quoted("a\"b"), "\"a\\\"b\"");
        assert_eq!(backticked("size"), "`size`");
    }

    #[test]
    fn long_input_is_cut_with_its_length() {
        let long = "n".repeat(MAX_QUOTED_CHARS + 1);
        let start = "n".repeat(MAX_QUOTED_CHARS);
        assert_eq!(excerpt(&long), format!("{start}… (65 characters)"));
        assert_eq!(quoted(&long), format!("\"{start}…\" (65 characters)"));
        assert_eq!(backticked(&long), format!("`{start}…` (65 characters)"));
        // Characters, not bytes: a multi-byte character is never split.
        let wide = "é".repeat(100);
        assert_eq!(
            excerpt(&wide),
            format!("{}… (100 characters)", "é".repeat(MAX_QUOTED_CHARS))
        );
    }

    #[test]
    fn long_quoted_segments_of_a_message_are_cut() {
        let long = "x".repeat(1000);
        let start = "x".repeat(MAX_QUOTED_CHARS);
        assert_eq!(
            shorten_quoted(&format!(
                "Unexpected variant named `{long}` in enum `MaskKind`"
            )),
            format!("Unexpected variant named `{start}…` (1000 characters) in enum `MaskKind`")
        );
        assert_eq!(
            shorten_quoted(&format!("found a string \"{long}\" instead")),
            format!("found a string \"{start}…\" (1000 characters) instead")
        );
        // An escaped quote stays inside; an unclosed segment runs to the end.
        let escaped = format!("\"a\\\"{long}\"");
        assert!(shorten_quoted(&escaped).starts_with("\"a\\\"xxx"));
        assert!(shorten_quoted(&escaped).ends_with("…\" (1003 characters)"));
        assert_eq!(
            shorten_quoted(&format!("`{long}")),
            format!("`{start}… (1000 characters)")
        );
        let short = "expected one of `Unorm8`, `Unorm16`, `F32` (found \"x\")";
        assert!(matches!(shorten_quoted(short), Cow::Borrowed(_)));
    }

    #[test]
    fn long_numbers_of_a_message_are_compacted() {
        let exponent = |v: f64| format!("{v:e}");
        let huge = format!("{}", 1e300);
        assert_eq!(huge.len(), 301);
        assert_eq!(
            compact_numbers(
                &format!("Gaussian sigma is {huge}; it must be finite, > 0 and <= 4096"),
                exponent
            ),
            "Gaussian sigma is 1e300; it must be finite, > 0 and <= 4096"
        );
        let tiny = format!("{}", -1e-300);
        assert_eq!(
            compact_numbers(
                &format!("alpha is {tiny}; it must be in [0.001, 1]"),
                exponent
            ),
            "alpha is -1e-300; it must be in [0.001, 1]"
        );
        // Short numbers, ranges and digits inside words stay as they are.
        for kept in [
            "Box size is 70000; it must be in 1..=65536",
            "id e12345678901234567890 and u123456789012345678901",
            "12345678901234567",
        ] {
            assert_eq!(compact_numbers(kept, exponent), kept);
        }
        assert_eq!(
            compact_numbers("found 123456789012345678901.5, not 1", exponent),
            "found 1.2345678901234568e20, not 1"
        );
    }
}

//! A table of figures written twice: as CSV (every digit an `f64` holds, empty for a missing
//! figure) and as a markdown table (rounded for reading, `n/a` for a missing figure). A column
//! may be in both or in only one of them, so one table can show a figure one way for reading
//! (`64×64×32`) and another for machines (`width`, `height`, `frames`).

use std::path::Path;

use crate::Result;

/// One field: its CSV text and its markdown text.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Exact: shortest round-trip formatting of numbers, empty when missing.
    pub csv: String,
    /// For reading: rounded, `n/a` when missing.
    pub md: String,
}

impl Cell {
    /// The same text in both files.
    pub fn text(text: impl Into<String>) -> Cell {
        let text = text.into();
        Cell {
            csv: text.clone(),
            md: text,
        }
    }

    /// Outside text (a mask's name): exact in CSV (quoted there as needed), [`line_text`] in
    /// markdown.
    pub fn name(text: &str) -> Cell {
        Cell {
            csv: text.to_owned(),
            md: line_text(text),
        }
    }

    /// An integer.
    pub fn int(value: u64) -> Cell {
        Cell {
            csv: value.to_string(),
            md: group_digits(value),
        }
    }

    /// `value` with `decimals` decimals in markdown.
    pub fn fixed(value: f64, decimals: usize) -> Cell {
        Cell {
            csv: format!("{value}"),
            md: format!("{value:.decimals$}"),
        }
    }

    /// `value` with `digits` significant digits in markdown (plain notation between 10⁻³ and
    /// 10⁶, scientific outside).
    pub fn sig(value: f64, digits: usize) -> Cell {
        Cell {
            csv: format!("{value}"),
            md: significant(value, digits),
        }
    }

    /// [`Cell::sig`] of `value`, or a missing figure.
    pub fn opt_sig(value: Option<f64>, digits: usize) -> Cell {
        value.map_or_else(Cell::missing, |v| Cell::sig(v, digits))
    }

    /// [`Cell::fixed`] of `value`, or a missing figure.
    pub fn opt_fixed(value: Option<f64>, decimals: usize) -> Cell {
        value.map_or_else(Cell::missing, |v| Cell::fixed(v, decimals))
    }

    /// A byte count in markdown as MB (10⁶ bytes, one decimal); exact bytes in CSV.
    pub fn megabytes(bytes: Option<u64>) -> Cell {
        bytes.map_or_else(Cell::missing, |b| Cell {
            csv: b.to_string(),
            md: format!("{:.1}", b as f64 / 1e6),
        })
    }

    /// A figure that does not exist or could not be measured.
    pub fn missing() -> Cell {
        Cell {
            csv: String::new(),
            md: "n/a".to_owned(),
        }
    }

    /// `yes` / `no`.
    pub fn yes_no(value: bool) -> Cell {
        Cell::text(if value { "yes" } else { "no" })
    }
}

/// `value` rounded to `digits` significant digits.
pub fn significant(value: f64, digits: usize) -> String {
    if value == 0.0 || !value.is_finite() {
        return format!("{value}");
    }
    let magnitude = value.abs().log10().floor() as i32;
    if !(-3..6).contains(&magnitude) {
        return format!("{value:.prec$e}", prec = digits.saturating_sub(1));
    }
    let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
    format!("{value:.decimals$}")
}

/// `1234567` as `1,234,567`.
fn group_digits(value: u64) -> String {
    let digits = value.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// One column: its CSV name (`snake_case`, with units) and its markdown heading; `None` leaves
/// it out of that format.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// CSV header field.
    csv: Option<String>,
    /// Markdown heading.
    md: Option<String>,
    /// Right-aligned in markdown (numbers).
    numeric: bool,
}

impl Column {
    /// A column of both formats.
    pub fn both(csv: &str, md: &str, numeric: bool) -> Column {
        Column {
            csv: Some(csv.to_owned()),
            md: Some(md.to_owned()),
            numeric,
        }
    }

    /// A column of the CSV file only.
    pub fn csv_only(csv: &str) -> Column {
        Column {
            csv: Some(csv.to_owned()),
            md: None,
            numeric: false,
        }
    }

    /// A column of the markdown table only.
    pub fn markdown_only(md: &str, numeric: bool) -> Column {
        Column {
            csv: None,
            md: Some(md.to_owned()),
            numeric,
        }
    }
}

/// Columns and rows; every row is as long as the columns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// The columns, in order.
    columns: Vec<Column>,
    /// The rows.
    rows: Vec<Vec<Cell>>,
}

impl Table {
    /// A table with `columns` of both formats, given as `(csv name, markdown heading, numeric)`.
    pub fn new(columns: &[(&str, &str, bool)]) -> Table {
        let columns = columns.iter();
        Table::with_columns(columns.map(|&(csv, md, numeric)| Column::both(csv, md, numeric)))
    }

    /// A table of `columns`.
    pub fn with_columns(columns: impl IntoIterator<Item = Column>) -> Table {
        Table {
            columns: columns.into_iter().collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row. Panics if its length differs from the columns'.
    pub fn push(&mut self, row: Vec<Cell>) {
        assert_eq!(row.len(), self.columns.len(), "row length");
        self.rows.push(row);
    }

    /// The CSV header fields, in order.
    pub fn csv_header(&self) -> impl Iterator<Item = &str> {
        self.columns.iter().filter_map(|c| c.csv.as_deref())
    }

    /// The CSV text (RFC 4180: fields quoted when they hold a comma, quote or line break; `\n`
    /// line ends; a header row).
    pub fn csv(&self) -> String {
        let line = |fields: &mut dyn Iterator<Item = &str>| {
            let quoted: Vec<String> = fields.map(quote).collect();
            quoted.join(",") + "\n"
        };
        let mut text = line(&mut self.csv_header());
        for row in &self.rows {
            let cells = self.columns.iter().zip(row);
            let fields = cells.filter(|(c, _)| c.csv.is_some());
            text.push_str(&line(&mut fields.map(|(_, cell)| cell.csv.as_str())));
        }
        text
    }

    /// Writes [`Table::csv`] to `path`.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        super::write_text(path, &self.csv())
    }

    /// The markdown table: every heading and cell through [`cell_text`], so each row is one
    /// line of the table whatever its text holds.
    pub fn markdown(&self) -> String {
        let escape = cell_text;
        let shown: Vec<(&String, usize)> = self
            .columns
            .iter()
            .enumerate()
            .filter_map(|(i, c)| Some((c.md.as_ref()?, i)))
            .collect();
        let headings: Vec<String> = shown.iter().map(|(md, _)| escape(md)).collect();
        let rule: Vec<&str> = shown
            .iter()
            .map(|&(_, i)| {
                if self.columns[i].numeric {
                    "---:"
                } else {
                    "---"
                }
            })
            .collect();
        let mut text = format!("| {} |\n|{}|\n", headings.join(" | "), rule.join("|"));
        for row in &self.rows {
            let cells: Vec<String> = shown.iter().map(|&(_, i)| escape(&row[i].md)).collect();
            text.push_str(&format!("| {} |\n", cells.join(" | ")));
        }
        text
    }
}

/// Most characters of one piece of outside text (a mask's name, which `analyze` takes from any
/// folder name) the markdown of a report or table shows: longer text is cut and ends in `…`.
/// As long as the longest name a manifest accepts, so no generated mask's name is ever cut.
pub const MAX_SHOWN_CHARS: usize = 128;

/// Outside text (a mask's name) as one line of markdown: at most [`MAX_SHOWN_CHARS`]
/// characters (then `…`), control characters written as their escapes ([`escape_controls`]),
/// and backticks as `'`, so the text can sit inside a code span, a heading, a list item or a
/// line of a code block without ending it. In a table, [`Table::markdown`] escapes `|` too.
pub fn line_text(text: &str) -> String {
    let mut shown: String = text.chars().take(MAX_SHOWN_CHARS).collect();
    if text.chars().nth(MAX_SHOWN_CHARS).is_some() {
        shown.pop();
        shown.push('…');
    }
    escape_controls(&shown.replace('`', "'"))
}

/// `text` with every control character (line breaks, tabs, escape sequences) and the Unicode
/// line and paragraph separators written as its Rust escape (`\n`, `\t`, `\u{1b}`), so it
/// stays on one line.
fn escape_controls(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() || matches!(c, '\u{2028}' | '\u{2029}') {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// One cell of a markdown table: control characters escaped ([`escape_controls`]) and `|` as
/// `\|`, so the cell ends neither its row nor itself.
fn cell_text(text: &str) -> String {
    escape_controls(text).replace('|', "\\|")
}

/// `field` as one CSV field: quoted (inner quotes doubled) when it holds a comma, a quote or a
/// line break.
fn quote(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_keep_every_digit_in_csv_and_round_in_markdown() {
        let c = Cell::sig(0.004_389_712, 3);
        assert_eq!((c.csv.as_str(), c.md.as_str()), ("0.004389712", "0.00439"));
        assert_eq!(Cell::sig(1234.5678, 3).md, "1235");
        assert_eq!(Cell::sig(2.5e-5, 2).md, "2.5e-5");
        assert_eq!(Cell::int(1_234_567).md, "1,234,567");
        assert_eq!(Cell::int(1_234_567).csv, "1234567");
        assert_eq!(Cell::megabytes(Some(138_400_000)).md, "138.4");
        let m = Cell::opt_sig(None, 3);
        assert_eq!((m.csv.as_str(), m.md.as_str()), ("", "n/a"));
    }

    #[test]
    fn csv_quotes_and_markdown_escapes() {
        let mut table = Table::new(&[("name", "name", false), ("value_s", "value (s)", true)]);
        table.push(vec![Cell::text("a,b|c"), Cell::fixed(1.5, 2)]);
        assert_eq!(table.csv(), "name,value_s\n\"a,b|c\",1.5\n");
        assert_eq!(
            table.markdown(),
            "| name | value (s) |\n|---|---:|\n| a,b\\|c | 1.50 |\n"
        );
    }

    #[test]
    fn outside_text_is_one_bounded_line_in_markdown() {
        assert_eq!(line_text("plain_name-1"), "plain_name-1");
        assert_eq!(
            line_text("a\nb\r\tc`d\u{1b}e\u{2028}f"),
            "a\\nb\\r\\tc'd\\u{1b}e\\u{2028}f"
        );
        assert_eq!(cell_text("a|`b`\n"), "a\\|`b`\\n");
        let long = "x".repeat(MAX_SHOWN_CHARS);
        assert_eq!(line_text(&long), long);
        let longer = "é".repeat(MAX_SHOWN_CHARS + 1);
        let shown = line_text(&longer);
        assert_eq!(shown.chars().count(), MAX_SHOWN_CHARS);
        assert!(shown.ends_with("é…"), "{shown}");
        // A name with a line break and a pipe stays one row of three cells.
        let mut table = Table::new(&[("mask", "mask", false), ("value", "value", true)]);
        let evil = "evil\n| x | y |\nname";
        table.push(vec![Cell::name(evil), Cell::fixed(0.5, 2)]);
        let text = table.markdown();
        assert_eq!(text.lines().count(), 3, "{text}");
        let row = text.lines().nth(2).unwrap();
        assert_eq!(row, "| evil\\n\\| x \\| y \\|\\nname | 0.50 |");
        // CSV keeps the name exact, quoted.
        assert_eq!(table.csv(), format!("mask,value\n\"{evil}\",0.5\n"));
    }

    #[test]
    fn fields_are_quoted_only_when_needed() {
        assert_eq!(quote("stbn_64"), "stbn_64");
        assert_eq!(quote("a,b"), "\"a,b\"");
        assert_eq!(quote("say \"hi\""), "\"say \"\"hi\"\"\"");
        let mut table = Table::with_columns(["mask", "value"].map(Column::csv_only));
        table.push(vec![Cell::text("a,b"), Cell::fixed(0.5, 2)]);
        assert_eq!(table.csv(), "mask,value\n\"a,b\",0.5\n");
    }

    #[test]
    fn columns_of_one_format_are_left_out_of_the_other() {
        let mut table = Table::with_columns([
            Column::both("mask", "mask", false),
            Column::markdown_only("size", false),
            Column::csv_only("width"),
            Column::csv_only("height"),
            Column::both("seconds", "seconds", true),
        ]);
        table.push(vec![
            Cell::text("a"),
            Cell::text("4×2"),
            Cell::int(4),
            Cell::int(2),
            Cell::opt_fixed(None, 2),
        ]);
        assert_eq!(
            table.csv_header().collect::<Vec<_>>(),
            ["mask", "width", "height", "seconds"]
        );
        assert_eq!(table.csv(), "mask,width,height,seconds\na,4,2,\n");
        assert_eq!(
            table.markdown(),
            "| mask | size | seconds |\n|---|---|---:|\n| a | 4×2 | n/a |\n"
        );
    }
}

//! `stbn-gen analyze`: the report for folders of PNG slices.

use std::path::{Path, PathBuf};

use stbn_gen::export::read_slices_png;

use crate::Result;
use crate::report::{self, Row};

/// Reads every folder of `<name>_<z>.png` slices in `dirs`, prints a summary line per mask and
/// writes `<out>/report.md`.
pub fn run(dirs: &[PathBuf], out: &Path) -> Result<()> {
    let mut rows = Vec::with_capacity(dirs.len());
    for dir in dirs {
        let stack = read_slices_png(dir)?;
        let kind = format!("png {}-bit", stack.bit_depth().bits());
        let row = Row::measure(stack.name(), &kind, None, &stack.field());
        println!("{}", row.summary());
        rows.push(row);
    }
    let folders: Vec<String> = dirs
        .iter()
        .map(|dir| format!("`{}`", dir.display()))
        .collect();
    let intro = format!("PNG slices analysed from {}.", folders.join(", "));
    let path = report::write(out, &intro, &rows)?;
    println!("report: {}", path.display());
    Ok(())
}

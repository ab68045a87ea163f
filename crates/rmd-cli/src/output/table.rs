//! The tables of the human-readable output (scan, status, monitor, bench rate), laid out by
//! `comfy-table`: each column as wide as its widest cell (measured in characters on screen, so
//! `°` counts once), two spaces between columns (or [`gap`](TextTable::gap)), no borders, no
//! trailing spaces.

use comfy_table::{CellAlignment, ColumnConstraint, Table, Width, presets};

/// How a column's cells are aligned.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Align {
    /// Words.
    Left,
    /// Numbers.
    Right,
}

/// A table being filled, row by row.
#[derive(Debug)]
pub(crate) struct TextTable {
    table: Table,
    aligns: Vec<Align>,
    indent: u16,
    gap: u16,
    min_widths: Vec<u16>,
}

impl TextTable {
    /// A table with a header line: `columns` are the titles and alignments.
    pub(crate) fn new(columns: &[(&str, Align)]) -> Self {
        let mut table = Self::without_header(&columns.iter().map(|c| c.1).collect::<Vec<_>>());
        table.table.set_header(columns.iter().map(|c| c.0));
        table
    }

    /// A table without a header line (label-value lists).
    pub(crate) fn without_header(aligns: &[Align]) -> Self {
        let mut table = Table::new();
        table.load_style(presets::NOTHING);
        TextTable {
            table,
            aligns: aligns.to_vec(),
            indent: 0,
            gap: 2,
            min_widths: Vec::new(),
        }
    }

    /// Indents every line by `spaces`.
    pub(crate) fn indent(mut self, spaces: u16) -> Self {
        self.indent = spaces;
        self
    }

    /// Puts `spaces` between columns (2 by default).
    pub(crate) fn gap(mut self, spaces: u16) -> Self {
        self.gap = spaces;
        self
    }

    /// Makes the columns at least `widths` characters wide (in order; a table redrawn in place
    /// keeps its layout while the values change width).
    pub(crate) fn min_widths(mut self, widths: &[u16]) -> Self {
        self.min_widths = widths.to_vec();
        self
    }

    /// Adds a row (missing cells are empty).
    pub(crate) fn row<I, S>(&mut self, cells: I) -> &mut Self
    where
        I: IntoIterator<Item = S>,
        S: Into<String>,
    {
        self.table
            .add_row(cells.into_iter().map(Into::into).collect::<Vec<String>>());
        self
    }

    /// The lines of the table, each without trailing spaces and ending with a newline.
    pub(crate) fn render(mut self) -> String {
        let last = self.aligns.len().saturating_sub(1);
        for (i, align) in self.aligns.iter().enumerate() {
            let Some(column) = self.table.column_mut(i) else {
                break;
            };
            let left = if i == 0 { self.indent } else { 0 };
            let right = if i == last { 0 } else { self.gap };
            column.set_padding((left, right));
            if let Some(&width) = self.min_widths.get(i) {
                column.set_constraint(ColumnConstraint::LowerBoundary(Width::Fixed(
                    width + left + right,
                )));
            }
            column.set_cell_alignment(match align {
                Align::Left => CellAlignment::Left,
                Align::Right => CellAlignment::Right,
            });
        }
        let mut text = self.table.trim_fmt();
        if !text.is_empty() {
            text.push('\n');
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_fit_their_widest_cell_numbers_to_the_right() {
        let mut table = TextTable::new(&[
            ("id", Align::Right),
            ("temp", Align::Right),
            ("errors", Align::Left),
        ]);
        table.row(["1", "25 °C", "none"]);
        table.row(["12", "7 °C", "low voltage"]);
        assert_eq!(
            table.render(),
            "id   temp  errors\n 1  25 °C  none\n12   7 °C  low voltage\n"
        );
    }

    #[test]
    fn label_lists_without_header_and_indented() {
        let mut table = TextTable::without_header(&[Align::Left, Align::Left])
            .indent(2)
            .gap(1);
        table.row(["voltage", "48.0 V"]);
        table.row(["multi-turn angle", "0.00°"]);
        assert_eq!(
            table.render(),
            "  voltage          48.0 V\n  multi-turn angle 0.00°\n"
        );
        assert_eq!(TextTable::without_header(&[Align::Left]).render(), "");
    }

    #[test]
    fn minimum_widths_keep_a_redrawn_layout() {
        let mut table = TextTable::new(&[("id", Align::Right), ("speed", Align::Right)])
            .min_widths(&[3, 9])
            .indent(1);
        table.row(["1", "5"]);
        assert_eq!(table.render(), "  id      speed\n   1          5\n");
    }
}

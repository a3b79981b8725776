//! Diagnostics: one error type for the parser, the checker and the analyses.
//!
//! An error carries a [`proc_macro2::Span`]. Inside the proc-macro that span points into the
//! user's source and `rustc` underlines it; in the CLI the span carries line/column (the
//! `span-locations` feature of proc-macro2) and [`Diag::render`] draws it with a caret.

use proc_macro2::Span;
use std::fmt;

/// A user-facing error: what is wrong, where, and what to do about it.
#[derive(Clone, Debug)]
pub struct Diag {
    /// One-line statement of the problem.
    pub message: String,
    /// Where in the spec.
    pub span: Span,
    /// Short label drawn under the caret.
    pub label: String,
    /// What to do instead.
    pub help: Option<String>,
}

/// Result alias for compiler stages.
pub type Result<T> = std::result::Result<T, Diag>;

impl Diag {
    /// A new error at `span`.
    pub fn new(span: Span, message: impl Into<String>) -> Self {
        let message = message.into();
        Diag {
            label: String::from("here"),
            message,
            span,
            help: None,
        }
    }

    /// Sets the label under the caret.
    pub fn label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// Adds a help text.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    /// The error as `compile_error!` tokens for the proc-macro, spanned at the problem.
    pub fn to_compile_error(&self) -> proc_macro2::TokenStream {
        let mut msg = self.message.clone();
        if let Some(h) = &self.help {
            msg.push_str("\n  = help: ");
            msg.push_str(h);
        }
        syn::Error::new(self.span, msg).to_compile_error()
    }

    /// 1-based line and column of the span start (valid for spans parsed from a string).
    pub fn line_col(&self) -> (usize, usize) {
        let lc = self.span.start();
        (lc.line, lc.column + 1)
    }

    /// Byte range of the span in `src` (for spans parsed from `src`).
    pub fn byte_range(&self, src: &str) -> (usize, usize) {
        let start = offset_of(src, self.span.start());
        let end = offset_of(src, self.span.end()).max(start);
        (start, end)
    }

    /// Plain-text rendering with `file:line:col`, the source line and a caret.
    /// Used where a fancy renderer is not available (tests, the macro's file mode).
    pub fn render(&self, file: &str, src: &str) -> String {
        let (line, col) = self.line_col();
        let text = src.lines().nth(line.saturating_sub(1)).unwrap_or("");
        let (s, e) = self.byte_range(src);
        let width = src.get(s..e).map_or(1, |t| t.chars().count().max(1));
        let width = width.min(text.chars().count().saturating_sub(col - 1).max(1));
        let gutter = line.to_string().len();
        let mut out = format!(
            "error: {}\n{:>g$}--> {file}:{line}:{col}\n{:>g$} |\n{line} | {text}\n{:>g$} | {}{} {}\n",
            self.message,
            "",
            "",
            "",
            " ".repeat(col - 1),
            "^".repeat(width),
            self.label,
            g = gutter
        );
        if let Some(h) = &self.help {
            out.push_str(&format!("{:>g$} = help: {h}\n", "", g = gutter));
        }
        out
    }
}

fn offset_of(src: &str, lc: proc_macro2::LineColumn) -> usize {
    let mut off = 0;
    for (i, line) in src.split_inclusive('\n').enumerate() {
        if i + 1 == lc.line {
            return off
                + line
                    .char_indices()
                    .nth(lc.column)
                    .map_or(line.len(), |(b, _)| b);
        }
        off += line.len();
    }
    src.len()
}

impl fmt::Display for Diag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Diag {}

impl From<syn::Error> for Diag {
    fn from(e: syn::Error) -> Self {
        Diag::new(e.span(), e.to_string()).label("syntax error")
    }
}

//! What a snapshot of generated text holds. Texts up to [`FULL_LIMIT`] bytes are snapshotted
//! whole and reviewed as a code diff. A larger text (the multi-model controller's Rust module
//! is 1.9 MB, its harness module 27 MB) cannot be reviewed that way, so its snapshot is an
//! [`outline`]: its size, its SHA-256 (any change to the text changes the snapshot), and its
//! items by kind, each with a count. Regenerate the text with `qloop gen` to read the change
//! itself.

use sha2::{Digest, Sha256};
use std::fmt::Write;

/// Largest text snapshotted whole, bytes.
pub const FULL_LIMIT: usize = 512 * 1024;

/// The text itself when it is at most [`FULL_LIMIT`] bytes, else its [`outline`].
pub fn snapshot_text(text: &str) -> String {
    if text.len() <= FULL_LIMIT {
        text.to_string()
    } else {
        outline(text)
    }
}

/// Size, SHA-256 and item outline of a generated Rust text: every line that opens an item
/// (`fn`, `struct`, `const`, `static`, `mod`, `impl`, `type`, `macro_rules!`, with or
/// without `pub`), with its digits written `N`, counted and listed in order of first
/// appearance.
pub fn outline(text: &str) -> String {
    let digest = Sha256::digest(text.as_bytes());
    let mut hex = String::new();
    for b in digest {
        let _ = write!(hex, "{b:02x}");
    }
    let mut out = format!(
        "generated text of {} bytes in {} lines, over the {FULL_LIMIT}-byte limit of a whole \
         snapshot\nsha256 {hex}\n\nitems (digits written N), in order of first appearance:\n",
        text.len(),
        text.lines().count()
    );
    let mut order: Vec<String> = Vec::new();
    let mut counts = std::collections::HashMap::<String, usize>::new();
    for line in text.lines() {
        let t = line.trim_start();
        let t = t
            .strip_prefix("pub(crate) ")
            .or_else(|| t.strip_prefix("pub "))
            .unwrap_or(t);
        let opens = [
            "fn ",
            "struct ",
            "const ",
            "static ",
            "mod ",
            "impl",
            "type ",
            "macro_rules!",
        ]
        .iter()
        .any(|k| t.starts_with(k));
        if !opens {
            continue;
        }
        // Digits written `N`, a run of them as one.
        let mut key = String::new();
        for c in line.trim().chars() {
            if !c.is_ascii_digit() {
                key.push(c);
            } else if !key.ends_with('N') {
                key.push('N');
            }
        }
        let n = counts.entry(key.clone()).or_insert(0);
        if *n == 0 {
            order.push(key);
        }
        *n += 1;
    }
    for k in order {
        let _ = writeln!(out, "{:>6} × {k}", counts[&k]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_text_is_kept_whole() {
        assert_eq!(snapshot_text("fn a() {}\n"), "fn a() {}\n");
    }

    #[test]
    fn a_long_text_is_outlined_with_counts_and_digest() {
        let mut text = String::from("pub mod m {\n");
        for i in 0..20_000 {
            text.push_str(&format!("    fn lemma_{i}() {{ let x = {i}; }}\n"));
        }
        text.push_str("    pub const fn new() -> u8 { 0 }\n}\n");
        let o = snapshot_text(&text);
        assert!(o.contains("20000 × fn lemma_N() { let x = N; }"), "{o}");
        assert!(o.contains("1 × pub const fn new() -> uN { N }"), "{o}");
        assert!(o.contains("1 × pub mod m {"), "{o}");
        assert!(o.contains(&format!("of {} bytes", text.len())), "{o}");
        // One changed character changes the digest.
        let changed = text.replacen("x = 7;", "x = 8;", 1);
        assert_ne!(outline(&text), outline(&changed));
    }
}

//! The verdict cache: `unsat` and `sat` answers on disk, one file per key.
//!
//! The key is the SHA-256 of the solver's name, the first line of its `--version` output and
//! the full text sent (each part length-prefixed). Files are written to a temporary name and
//! renamed into place; a file that does not parse, or whose `sat` names differ from the ones
//! asked for, is treated as a miss and replaced by the next verdict. Timeouts, cancellations
//! and errors are never stored.

use super::{Answer, Solver};
use std::fmt::Write as _;
use std::fs;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// First line of every cache file; bump when the format or key derivation changes.
const CACHE_MAGIC: &str = "qloop-smt-verdict v1";

/// The cache key: hex SHA-256 of the solver's name, its version line and the text sent.
pub(super) fn cache_key(solver: Solver, version: &str, text: &str) -> String {
    use sha2::Digest;
    let mut h = sha2::Sha256::new();
    for part in [CACHE_MAGIC, solver.name(), version, text] {
        // Length-prefixed, so the parts cannot run into each other.
        h.update((part.len() as u64).to_be_bytes());
        h.update(part.as_bytes());
    }
    h.finalize()
        .iter()
        .fold(String::with_capacity(64), |mut s, b| {
            let _ = write!(s, "{b:02x}");
            s
        })
}

/// The file holding the verdict for `key`.
fn cache_path(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("{key}.verdict"))
}

/// The cached answer for `key`, if there is a well-formed entry whose names match `want`.
pub(super) fn cache_load(dir: &Path, key: &str, want: &[String]) -> Option<Answer> {
    let text = fs::read_to_string(cache_path(dir, key)).ok()?;
    let answer = decode_entry(key, &text)?;
    if let Answer::Sat(values) = &answer {
        let names_match = values.len() == want.len()
            && values.iter().zip(want).all(|((name, _, _), w)| name == w);
        if !names_match {
            return None;
        }
    }
    Some(answer)
}

/// Writes the entry for `key` atomically (temporary file, then rename).
pub(super) fn cache_store(dir: &Path, key: &str, answer: &Answer) -> io::Result<()> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let Some(entry) = encode_entry(key, answer) else {
        return Ok(());
    };
    fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(
        ".{key}.{}.{}.tmp",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let written = (|| {
        let mut file = fs::File::create(&tmp)?;
        file.write_all(entry.as_bytes())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, cache_path(dir, key))
    })();
    if written.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    written
}

/// The cache file text for a definite answer; `None` for answers that are not cached.
///
/// ```text
/// qloop-smt-verdict v1
/// key <hex>
/// sat <n>                  (or: unsat)
/// <width> <value> <name>   (n lines; name escaped: \\ \n \r)
/// end
/// ```
fn encode_entry(key: &str, answer: &Answer) -> Option<String> {
    let mut out = format!("{CACHE_MAGIC}\nkey {key}\n");
    match answer {
        Answer::Unsat => out.push_str("unsat\n"),
        Answer::Sat(values) => {
            let _ = writeln!(out, "sat {}", values.len());
            for (name, value, width) in values {
                let _ = writeln!(out, "{width} {value} {}", escape_name(name));
            }
        }
        Answer::Timeout | Answer::Cancelled | Answer::Error(_) => return None,
    }
    out.push_str("end\n");
    Some(out)
}

/// Parses a cache file; `None` if it is not a well-formed entry for `key`.
fn decode_entry(key: &str, text: &str) -> Option<Answer> {
    let mut lines = text.split('\n');
    if lines.next()? != CACHE_MAGIC || lines.next()?.strip_prefix("key ")? != key {
        return None;
    }
    let answer = match lines.next()? {
        "unsat" => Answer::Unsat,
        verdict => {
            let count: usize = verdict.strip_prefix("sat ")?.parse().ok()?;
            let mut values = Vec::new();
            for _ in 0..count {
                let mut fields = lines.next()?.splitn(3, ' ');
                let width: u32 = fields.next()?.parse().ok()?;
                let value: u128 = fields.next()?.parse().ok()?;
                let name = unescape_name(fields.next()?)?;
                if !(1..=128).contains(&width) || (width < 128 && value >> width != 0) {
                    return None;
                }
                values.push((name, value, width));
            }
            Answer::Sat(values)
        }
    };
    if lines.next()? != "end" || !lines.next()?.is_empty() || lines.next().is_some() {
        return None;
    }
    Some(answer)
}

/// Escapes `\`, newline and carriage return so a name fits on one line.
fn escape_name(name: &str) -> String {
    name.replace('\\', "\\\\")
        .replace('\n', "\\n")
        .replace('\r', "\\r")
}

/// Inverse of [`escape_name`]; `None` on a malformed escape.
fn unescape_name(text: &str) -> Option<String> {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            out.push(match chars.next()? {
                '\\' => '\\',
                'n' => '\n',
                'r' => '\r',
                _ => return None,
            });
        } else {
            out.push(c);
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::testing::{temp_dir, want};

    #[test]
    fn cache_entries_round_trip_and_reject_damage() {
        let key = "ab".repeat(32);
        let sat = Answer::Sat(vec![
            ("x".into(), 5, 8),
            ("|a\nb\\c|".into(), u128::MAX, 128),
        ]);
        for answer in [Answer::Unsat, sat.clone(), Answer::Sat(vec![])] {
            let text = encode_entry(&key, &answer).expect("cacheable");
            assert_eq!(decode_entry(&key, &text), Some(answer.clone()));
            // Any truncation or wrong key is a miss.
            for cut in 0..text.len() {
                assert_eq!(decode_entry(&key, &text[..cut]), None, "{cut}");
            }
            assert_eq!(decode_entry(&"cd".repeat(32), &text), None);
            assert_eq!(decode_entry(&key, &(text.clone() + "x")), None);
        }
        assert_eq!(encode_entry(&key, &Answer::Timeout), None);
        assert_eq!(encode_entry(&key, &Answer::Error("e".into())), None);
        let bad = format!("{CACHE_MAGIC}\nkey {key}\nsat 1\n8 256 x\nend\n");
        assert_eq!(decode_entry(&key, &bad), None);

        // A stored Sat must match the names asked for.
        let dir = temp_dir("entries");
        cache_store(&dir, &key, &sat).expect("store");
        assert_eq!(
            cache_load(&dir, &key, &want(&["x", "|a\nb\\c|"])),
            Some(sat)
        );
        assert_eq!(cache_load(&dir, &key, &want(&["x"])), None);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn cache_key_depends_on_every_part() {
        let k = cache_key(Solver::Z3, "v1", "text");
        assert_eq!(k.len(), 64);
        assert_eq!(k, cache_key(Solver::Z3, "v1", "text"));
        assert_ne!(k, cache_key(Solver::Cvc5, "v1", "text"));
        assert_ne!(k, cache_key(Solver::Z3, "v2", "text"));
        assert_ne!(k, cache_key(Solver::Z3, "v1", "text "));
        assert_ne!(
            cache_key(Solver::Z3, "ab", "c"),
            cache_key(Solver::Z3, "a", "bc")
        );
    }
}

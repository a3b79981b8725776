//! The S-expressions solvers print, read one at a time.
//!
//! Atoms are kept exactly as written (`#b0101` keeps its four digits, which are the
//! bit-vector's width; `|a b|` keeps its bars), strings are unescaped (`""` as in SMT-LIB 2.6,
//! and `\"` as z3 and cvc5 also print), `;` comments are skipped. Lists are read with an
//! explicit stack and a bounded depth, so no output can overflow the thread's stack.

/// An S-expression as solvers print them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) enum Sexp {
    /// A symbol, keyword or literal, as written (quoted symbols keep their bars).
    Atom(String),
    /// A string literal, unescaped.
    Str(String),
    /// A parenthesised list.
    List(Vec<Sexp>),
}

impl Sexp {
    /// The atom's text, if this is an atom.
    pub(super) fn atom(&self) -> Option<&str> {
        match self {
            Sexp::Atom(a) => Some(a),
            _ => None,
        }
    }
}

/// The deepest list nesting accepted in solver output (get-value responses need 3).
pub(super) const MAX_DEPTH: usize = 256;

/// Reads S-expressions one at a time, so that whatever follows the one needed (say the error
/// for `get-value` after `unsat`) cannot spoil it.
pub(super) struct SexpReader<'a> {
    /// The text being read.
    text: &'a [u8],
    /// Position of the next unread byte.
    pos: usize,
}

impl<'a> SexpReader<'a> {
    /// A reader at the start of `text`.
    pub(super) fn new(text: &'a str) -> Self {
        SexpReader {
            text: text.as_bytes(),
            pos: 0,
        }
    }

    /// Skips whitespace and `;` comments.
    fn skip_blank(&mut self) {
        while let Some(&b) = self.text.get(self.pos) {
            if b.is_ascii_whitespace() {
                self.pos += 1;
            } else if b == b';' {
                while self.text.get(self.pos).is_some_and(|&c| c != b'\n') {
                    self.pos += 1;
                }
            } else {
                break;
            }
        }
    }

    /// The text between two byte positions (always on character boundaries here, since the
    /// delimiters are ASCII).
    fn slice(&self, from: usize, to: usize) -> String {
        String::from_utf8_lossy(&self.text[from..to]).into_owned()
    }

    /// The next top-level S-expression, `None` at the end of the text, or an error for
    /// unbalanced or unterminated input.
    pub(super) fn next_sexp(&mut self) -> Option<Result<Sexp, String>> {
        self.skip_blank();
        if self.pos >= self.text.len() {
            return None;
        }
        Some(self.read())
    }

    /// Reads one S-expression starting at a non-blank byte.
    fn read(&mut self) -> Result<Sexp, String> {
        // Lists are read with an explicit stack, and nesting is bounded, so that no output can
        // overflow the thread's stack (here or when the result is dropped).
        let mut stack: Vec<Vec<Sexp>> = Vec::new();
        loop {
            self.skip_blank();
            let Some(&b) = self.text.get(self.pos) else {
                return Err("output ends inside a parenthesised expression".to_string());
            };
            let item = match b {
                b'(' => {
                    if stack.len() >= MAX_DEPTH {
                        return Err("output nested too deeply".to_string());
                    }
                    self.pos += 1;
                    stack.push(Vec::new());
                    continue;
                }
                b')' => {
                    self.pos += 1;
                    match stack.pop() {
                        Some(items) => Sexp::List(items),
                        None => return Err("unbalanced `)` in output".to_string()),
                    }
                }
                b'"' => self.read_string()?,
                b'|' => {
                    let start = self.pos;
                    self.pos += 1;
                    while self.text.get(self.pos).is_some_and(|&c| c != b'|') {
                        self.pos += 1;
                    }
                    if self.pos >= self.text.len() {
                        return Err("unterminated |quoted symbol| in output".to_string());
                    }
                    self.pos += 1;
                    Sexp::Atom(self.slice(start, self.pos))
                }
                _ => {
                    let start = self.pos;
                    while self.text.get(self.pos).is_some_and(|&c| {
                        !c.is_ascii_whitespace() && !matches!(c, b'(' | b')' | b'"' | b'|' | b';')
                    }) {
                        self.pos += 1;
                    }
                    Sexp::Atom(self.slice(start, self.pos))
                }
            };
            match stack.last_mut() {
                Some(list) => list.push(item),
                None => return Ok(item),
            }
        }
    }

    /// Reads a string literal; `""` (SMT-LIB 2.6) and `\"` both stand for a quote.
    fn read_string(&mut self) -> Result<Sexp, String> {
        let mut bytes = Vec::new();
        self.pos += 1;
        loop {
            match self.text.get(self.pos) {
                None => return Err("unterminated string in output".to_string()),
                Some(b'"') if self.text.get(self.pos + 1) == Some(&b'"') => {
                    bytes.push(b'"');
                    self.pos += 2;
                }
                Some(b'"') => {
                    self.pos += 1;
                    return Ok(Sexp::Str(String::from_utf8_lossy(&bytes).into_owned()));
                }
                Some(b'\\') if matches!(self.text.get(self.pos + 1), Some(b'"' | b'\\')) => {
                    bytes.push(self.text[self.pos + 1]);
                    self.pos += 2;
                }
                Some(&c) => {
                    bytes.push(c);
                    self.pos += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sexp_reader_handles_strings_comments_and_quotes() {
        let mut r = SexpReader::new("; c\n(error \"a \"\"b\"\" \\\" ; (\") |x ) y| z ");
        assert_eq!(
            r.next_sexp(),
            Some(Ok(Sexp::List(vec![
                Sexp::Atom("error".into()),
                Sexp::Str("a \"b\" \" ; (".into())
            ])))
        );
        assert_eq!(r.next_sexp(), Some(Ok(Sexp::Atom("|x ) y|".into()))));
        assert_eq!(r.next_sexp(), Some(Ok(Sexp::Atom("z".into()))));
        assert_eq!(r.next_sexp(), None);
        let nested = |n: usize| "(".repeat(n) + &")".repeat(n);
        assert!(matches!(
            SexpReader::new(&nested(MAX_DEPTH)).next_sexp(),
            Some(Ok(_))
        ));
        let deep = nested(MAX_DEPTH + 1);
        assert!(matches!(SexpReader::new(&deep).next_sexp(), Some(Err(_))));
        assert!(matches!(
            SexpReader::new(&nested(1_000_000)).next_sexp(),
            Some(Err(_))
        ));
    }
}

//! Guards that run before `syn` parses a spec: balanced brackets, and nesting limits that
//! keep every stage of the compiler within its stack.
//!
//! `syn`'s expression parser recurses once per bracket, per prefix operator and per
//! `else if`, and qloop's checker, lowering and emitters recurse once per operator of an
//! expression tree. Without a limit, a spec of a few kilobytes (4,000 nested parentheses,
//! 10,000 unary minuses, a 10,000-term sum) overflows the stack and aborts the process: no
//! error, no location. So two limits are checked on the tokens first, with a located error:
//!
//! * **nesting** ([`MAX_NESTING`]): brackets, runs of prefix operators (`-`, `!`, `*`, `&`)
//!   and `else if` chains, counted along the path from the outermost bracket to a token;
//! * **length** ([`MAX_LENGTH`]): the operators and keywords of one expression or statement
//!   (everything between `;` or `,` separators), summed along the same path, which bounds
//!   the depth of every expression tree qloop builds.
//!
//! Both limits are far above what a controller needs (the seed specs reach nesting 9 and
//! length 65, the multi-model controller's pole-placement check) and low enough that the
//! deepest admitted spec compiles in a 2 MiB thread in a debug build
//! (`deepest_admitted_specs_compile_in_a_small_stack` below).
//!
//! Before lexing, [`brackets`] reads the text itself, so that an unbalanced or truncated spec
//! gets an error naming the bracket and where it was opened, instead of the lexer's "cannot
//! parse string into token stream".

use crate::diag::{Diag, Result};
use proc_macro2::{Delimiter, Span, TokenStream, TokenTree};

/// Deepest nesting of brackets, prefix-operator runs and `else if` chains a spec may have.
pub const MAX_NESTING: usize = 64;

/// Most operators and keywords along any path of one expression or statement.
pub const MAX_LENGTH: usize = 256;

const SPLIT_HELP: &str = "split the expression with `let` bindings; qloop refuses deeper \
nesting so that no stage of the compiler can run out of stack";

/// Checks that every bracket of `src` is closed by its match, that strings and block comments
/// end, and that brackets nest at most [`MAX_NESTING`] deep.
pub fn brackets(src: &str) -> Result<()> {
    let mut open: Vec<(char, usize)> = Vec::new();
    let b = src.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        match c {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                i = src[i..].find('\n').map_or(b.len(), |n| i + n);
                continue;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                i = block_comment_end(b, i).ok_or_else(|| {
                    located(src, i, "unterminated block comment")
                        .label("opened here, never closed")
                        .help("close it with `*/`")
                })?;
                continue;
            }
            b'"' => {
                i = string_end(b, i + 1).ok_or_else(|| unterminated_string(src, i))?;
                continue;
            }
            b'\'' => {
                i = char_end(b, i);
                continue;
            }
            _ if c == b'_' || c.is_ascii_alphabetic() => {
                let start = i;
                while i < b.len() && (b[i] == b'_' || b[i].is_ascii_alphanumeric()) {
                    i += 1;
                }
                let word = &src[start..i];
                let hashes = b[i..].iter().take_while(|&&x| x == b'#').count();
                if matches!(word, "r" | "br") && b.get(i + hashes) == Some(&b'"') {
                    i = raw_string_end(b, i).ok_or_else(|| unterminated_string(src, start))?;
                } else if word == "b" && b.get(i) == Some(&b'"') {
                    i = string_end(b, i + 1).ok_or_else(|| unterminated_string(src, start))?;
                } else if word == "b" && b.get(i) == Some(&b'\'') {
                    i = char_end(b, i);
                }
                continue;
            }
            b'(' | b'[' | b'{' => {
                open.push((c as char, i));
                if open.len() > MAX_NESTING {
                    return Err(located(
                        src,
                        i,
                        format!("brackets nest more than {MAX_NESTING} deep"),
                    )
                    .label("too deep")
                    .help(SPLIT_HELP));
                }
            }
            b')' | b']' | b'}' => {
                let c = c as char;
                match open.pop() {
                    None => {
                        return Err(located(src, i, format!("unexpected `{c}`"))
                            .label("no bracket is open here")
                            .help("remove it, or add the opening bracket it was meant to close"))
                    }
                    Some((o, at)) if closer(o) != c => {
                        let (l, col) = line_col(src, at);
                        return Err(located(
                            src,
                            i,
                            format!("`{c}` does not close the `{o}` opened at {l}:{col}"),
                        )
                        .label(format!("expected `{}`", closer(o)))
                        .help(format!(
                            "close the `{o}` with `{}` first, or remove this `{c}`",
                            closer(o)
                        )));
                    }
                    Some(_) => {}
                }
            }
            _ => {}
        }
        i += 1;
    }
    if let Some(&(o, at)) = open.last() {
        let mut d = located(src, at, format!("unclosed `{o}`")).label("opened here, never closed");
        let outer: Vec<String> = open[..open.len() - 1]
            .iter()
            .rev()
            .map(|&(c, p)| {
                let (l, col) = line_col(src, p);
                format!("`{c}` at {l}:{col}")
            })
            .collect();
        let mut help = format!("close it with `{}`; is the spec cut short?", closer(o));
        if !outer.is_empty() {
            help.push_str(&format!(" Also still open: {}", outer.join(", ")));
        }
        d = d.help(help);
        return Err(d);
    }
    Ok(())
}

fn closer(open: char) -> char {
    match open {
        '(' => ')',
        '[' => ']',
        _ => '}',
    }
}

/// End (exclusive) of a block comment starting at `i` (`/*`), nested as in Rust.
fn block_comment_end(b: &[u8], mut i: usize) -> Option<usize> {
    let mut depth = 0usize;
    while i + 1 < b.len() {
        match (b[i], b[i + 1]) {
            (b'/', b'*') => {
                depth += 1;
                i += 2;
            }
            (b'*', b'/') => {
                depth -= 1;
                i += 2;
                if depth == 0 {
                    return Some(i);
                }
            }
            _ => i += 1,
        }
    }
    None
}

/// End (exclusive) of a string whose body starts at `i` (after the opening `"`).
fn string_end(b: &[u8], mut i: usize) -> Option<usize> {
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return Some(i + 1),
            _ => i += 1,
        }
    }
    None
}

/// End (exclusive) of a raw string whose `#`s or `"` start at `i` (after `r` / `br`).
fn raw_string_end(b: &[u8], i: usize) -> Option<usize> {
    let hashes = b[i..].iter().take_while(|&&x| x == b'#').count();
    if b.get(i + hashes) != Some(&b'"') {
        return None;
    }
    let mut j = i + hashes + 1;
    while j < b.len() {
        if b[j] == b'"'
            && b[j + 1..]
                .iter()
                .take(hashes)
                .filter(|&&x| x == b'#')
                .count()
                == hashes
        {
            return Some(j + 1 + hashes);
        }
        j += 1;
    }
    None
}

/// End (exclusive) of a character literal or lifetime starting at `i` (`'`): `'x'`, `'\n'`,
/// `'\u{..}'`, or a lone quote (a lifetime, which the parser will reject).
fn char_end(b: &[u8], i: usize) -> usize {
    if b.get(i + 1) == Some(&b'\\') {
        let mut j = i + 3;
        while j < b.len() && b[j] != b'\'' && b[j] != b'\n' {
            j += 1;
        }
        return if b.get(j) == Some(&b'\'') {
            j + 1
        } else {
            i + 1
        };
    }
    // One UTF-8 character, then a closing quote.
    let len = match b.get(i + 1) {
        Some(&x) if x < 0x80 => 1,
        Some(&x) if x >= 0xf0 => 4,
        Some(&x) if x >= 0xe0 => 3,
        Some(_) => 2,
        None => return i + 1,
    };
    if b.get(i + 1 + len) == Some(&b'\'') {
        i + 2 + len
    } else {
        i + 1
    }
}

fn unterminated_string(src: &str, at: usize) -> Diag {
    located(src, at, "unterminated string")
        .label("starts here, never ends")
        .help("close it with `\"`; units are written as strings: `input f: [0.0, 5.0] \"kN\";`")
}

/// 1-based line and column (in characters) of byte `at` of `src`.
fn line_col(src: &str, at: usize) -> (usize, usize) {
    let before = &src[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// A diagnostic at byte `at` of `src`, one character wide.
fn located(src: &str, at: usize, msg: impl Into<String>) -> Diag {
    Diag::new(span_at(src, at), msg)
}

/// A span with the line and column of byte `at` in `src`, for text that does not lex: the
/// text before `at` is blanked (newlines kept, one space per character, so columns count
/// alike) and followed by one identifier, whose span is taken.
pub fn span_at(src: &str, at: usize) -> Span {
    let mut text: String = src[..at]
        .chars()
        .map(|c| if c == '\n' { '\n' } else { ' ' })
        .collect();
    text.push('x');
    text.parse::<TokenStream>()
        .ok()
        .and_then(|t| t.into_iter().next())
        .map_or_else(Span::call_site, |t| t.span())
}

/// One level of the token tree being checked by [`nesting`].
struct Level {
    tokens: std::vec::IntoIter<TokenTree>,
    /// Nesting carried in from the enclosing levels.
    nest: usize,
    /// Length carried in from the enclosing levels.
    len: usize,
    /// Operators and keywords since the last separator at this level.
    ops: usize,
    /// Consecutive prefix operators just before the current token.
    prefix: usize,
    /// `else if`s since the last separator at this level.
    else_ifs: usize,
    /// The previous token at this level.
    prev: Prev,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Prev {
    Start,
    Operator,
    Else,
    Operand,
    Block,
}

/// Rust keywords that can start or continue a nested expression.
const KEYWORDS: [&str; 16] = [
    "if", "else", "return", "break", "continue", "let", "loop", "while", "for", "match", "move",
    "unsafe", "async", "await", "yield", "box",
];

/// Checks the nesting and length limits ([`MAX_NESTING`], [`MAX_LENGTH`]) on a token stream,
/// without recursion.
pub fn nesting(tokens: &TokenStream) -> Result<()> {
    measure(tokens).map(|_| ())
}

/// The deepest nesting and the greatest length a token stream reaches (see the module doc),
/// or the error at the first token beyond a limit. Iterative: any input is safe.
pub fn measure(tokens: &TokenStream) -> Result<(usize, usize)> {
    let level = |tokens: TokenStream, nest: usize, len: usize| Level {
        tokens: tokens.into_iter().collect::<Vec<_>>().into_iter(),
        nest,
        len,
        ops: 0,
        prefix: 0,
        else_ifs: 0,
        prev: Prev::Start,
    };
    let mut stack = vec![level(tokens.clone(), 0, 0)];
    let mut deepest = (0, 0);
    while let Some(top) = stack.last_mut() {
        let Some(tt) = top.tokens.next() else {
            stack.pop();
            continue;
        };
        let span = tt.span();
        match &tt {
            // An attribute (`#[q(..)]`, or a doc comment's `#[doc = ".."]`) is no operator
            // of the statement it precedes: skip it whole, so that a long doc comment does
            // not count as a long expression.
            TokenTree::Punct(p) if p.as_char() == '#' => {
                if let Some(TokenTree::Group(g)) = top.tokens.as_slice().first() {
                    if g.delimiter() == Delimiter::Bracket {
                        top.tokens.next();
                    }
                }
            }
            TokenTree::Punct(p) if matches!(p.as_char(), ';' | ',') => {
                top.ops = 0;
                top.prefix = 0;
                top.else_ifs = 0;
                top.prev = Prev::Start;
            }
            TokenTree::Punct(p) => {
                let unary = matches!(p.as_char(), '-' | '!' | '*' | '&')
                    && matches!(top.prev, Prev::Start | Prev::Operator | Prev::Else);
                top.prefix = if unary { top.prefix + 1 } else { 0 };
                top.ops += 1;
                top.prev = Prev::Operator;
            }
            TokenTree::Ident(i) => {
                let word = i.to_string();
                if let Some(plain) = word.strip_prefix("r#") {
                    return Err(Diag::new(span, format!("raw identifier `{word}`"))
                        .label("not allowed in a spec")
                        .help(format!(
                            "write `{plain}` without `r#`; a name that is a Rust keyword \
                             cannot be used: choose another"
                        )));
                }
                if top.prev == Prev::Block && word != "else" && word != "as" {
                    // A new statement after a block (`if .. { .. } y = x;`).
                    top.ops = 0;
                    top.else_ifs = 0;
                }
                if word == "if" && top.prev == Prev::Else {
                    top.else_ifs += 1;
                }
                top.prefix = 0;
                if KEYWORDS.contains(&word.as_str()) {
                    top.ops += 1;
                    top.prev = if word == "else" {
                        Prev::Else
                    } else {
                        Prev::Operator
                    };
                } else {
                    top.prev = Prev::Operand;
                }
            }
            TokenTree::Literal(_) => {
                top.prefix = 0;
                top.prev = Prev::Operand;
            }
            TokenTree::Group(_) => {}
        }
        let nest = top.nest + top.prefix + top.else_ifs;
        let len = top.len + top.ops;
        deepest = (deepest.0.max(nest), deepest.1.max(len));
        if nest > MAX_NESTING {
            return Err(too_deep(span));
        }
        if len > MAX_LENGTH {
            return Err(Diag::new(
                span,
                format!(
                    "this expression is too long: more than {MAX_LENGTH} operators along one \
                     path"
                ),
            )
            .label("too long")
            .help(SPLIT_HELP));
        }
        if let TokenTree::Group(g) = tt {
            let block = g.delimiter() == Delimiter::Brace;
            let (nest, len) = (nest + 1, len + 1);
            top.prefix = 0;
            top.prev = if block { Prev::Block } else { Prev::Operand };
            if nest > MAX_NESTING {
                return Err(too_deep(g.span_open()));
            }
            deepest = (deepest.0.max(nest), deepest.1.max(len));
            stack.push(level(g.stream(), nest, len));
        }
    }
    Ok(deepest)
}

fn too_deep(span: Span) -> Diag {
    Diag::new(
        span,
        format!(
            "this nests more than {MAX_NESTING} deep (brackets, prefix operators and `else if`s, \
             counted together)"
        ),
    )
    .label("too deep")
    .help(SPLIT_HELP)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(src: &str) -> (String, usize, usize, String) {
        let d = brackets(src).expect_err(src);
        let (l, c) = d.line_col();
        (d.message.clone(), l, c, d.help.unwrap_or_default())
    }

    #[test]
    fn unbalanced_brackets_name_the_bracket_and_where_it_opened() {
        let (m, l, c, h) = err("controller x {\n  step {\n    y = min(x, 1.0;\n  }\n}\n");
        assert_eq!(m, "`}` does not close the `(` opened at 3:12");
        assert_eq!((l, c), (4, 3));
        assert!(h.contains("close the `(` with `)` first"), "{h}");
        let (m, l, c, h) = err("controller x {\n  step {\n    y = (x + 1.0\n");
        assert_eq!(m, "unclosed `(`");
        assert_eq!((l, c), (3, 9));
        assert!(h.contains("`{` at 2:8, `{` at 1:14"), "{h}");
        let (m, l, c, _) = err("controller x { }\n}");
        assert_eq!((m.as_str(), l, c), ("unexpected `}`", 2, 1));
        let (m, l, c, _) = err("controller x { input a: [0.0, 1.0] \"kN;\n}");
        assert_eq!((m.as_str(), l, c), ("unterminated string", 1, 36));
        let (m, l, c, _) = err("controller x { /* a /* b */ }");
        assert_eq!((m.as_str(), l, c), ("unterminated block comment", 1, 16));
    }

    #[test]
    fn brackets_in_strings_comments_and_chars_do_not_count() {
        let ok = "controller x { // ( [\n /* { /* } */ ( */ input a: [0.0, 1.0] \"(\\\"\"; \
                  const C: r#\"(\"#; let c = '(' ; let d = '\\''; }";
        brackets(ok).expect("balanced");
    }

    #[test]
    fn nesting_limits_are_located() {
        let deep = format!(
            "y = {}x{};",
            "(".repeat(MAX_NESTING + 1),
            ")".repeat(MAX_NESTING + 1)
        );
        let d = brackets(&deep).expect_err("too deep");
        assert!(d.message.contains("nest more than"), "{}", d.message);
        assert_eq!(d.line_col(), (1, 5 + MAX_NESTING));
        let t = |s: &str| nesting(&s.parse().expect("lexes"));
        let neg = format!("y = {}x;", "-".repeat(MAX_NESTING + 1));
        assert!(t(&neg)
            .expect_err("unary run")
            .message
            .contains("nests more than"));
        t(&format!("y = {}x;", "-".repeat(MAX_NESTING - 1))).expect("within the limit");
        let sum = format!("y = {};", vec!["x"; MAX_LENGTH + 2].join(" + "));
        assert!(t(&sum).expect_err("long sum").message.contains("too long"));
        t(&format!("y = {};", vec!["x"; MAX_LENGTH - 2].join(" + "))).expect("within");
        // Separate statements do not add up.
        let many = format!("{{ {} }}", "y = x + x; ".repeat(1000));
        t(&many).expect("statements are separate");
        let ifs = format!("{{ {} }}", "if x > 0.0 { y = x; } ".repeat(1000));
        t(&ifs).expect("consecutive ifs are separate statements");
        let chain = format!(
            "{{ if x > 0.0 {{ y = x; }} {} else {{ y = x; }} }}",
            "else if x > 0.0 { y = x; } ".repeat(MAX_NESTING + 1)
        );
        assert!(t(&chain)
            .expect_err("else-if chain")
            .message
            .contains("nests more than"));
    }

    #[test]
    fn raw_identifiers_are_refused_where_they_stand() {
        // Found by the fuzzer: `invariant r#x: ..` reached the Kani emitter as the name
        // `inv_r#x`, which is no identifier, and the emitter panicked.
        let src = "controller c {\n  input a: [0.0, 1.0];\n  invariant r#product_at_least_one: a >= 0.0;\n}\n";
        let Err(d) = crate::lang::parse::parse_str(src) else {
            panic!("a raw identifier parsed");
        };
        assert_eq!(d.message, "raw identifier `r#product_at_least_one`");
        assert_eq!(d.line_col(), (3, 13));
        assert!(d
            .help
            .unwrap_or_default()
            .contains("write `product_at_least_one`"));
        let t = |s: &str| nesting(&s.parse().expect("lexes"));
        assert!(t("y = r#x + 1.0;").is_err(), "in an expression too");
        t("y = x + 1.0;").expect("plain names pass");
    }
}

//! A solver's standard output as an [`Answer`].
//!
//! The first S-expression (after any `(warning ...)`) decides: `unsat` is
//! [`Answer::Unsat`]; `sat` is [`Answer::Sat`] once the `get-value` response that follows it
//! has been parsed (values may be `#b...`, `#x...` or `(_ bvN W)`, read as unsigned with their
//! width; integers `N` and `(- N)` of the integer encodings as 128-bit two's complement); z3's
//! `timeout` is [`Answer::Timeout`]; `unknown`, `(error "...")`, no output, truncated output or
//! anything else is an error, whose message says why.

use std::collections::HashMap;

use super::sexp::{Sexp, SexpReader};
use super::Answer;

/// Interprets a solver's standard output; `Err` says why it is not a usable answer.
pub(super) fn parse_output(stdout: &str, want: &[String]) -> Result<Answer, String> {
    let mut reader = SexpReader::new(stdout);
    let verdict = loop {
        match reader.next_sexp() {
            None => return Err("no verdict in output".to_string()),
            Some(Err(e)) => return Err(e),
            Some(Ok(Sexp::List(items)))
                if items.first().and_then(Sexp::atom) == Some("warning") =>
            {
                continue
            }
            Some(Ok(sexp)) => break sexp,
        }
    };
    match &verdict {
        Sexp::Atom(a) if a == "unsat" => Ok(Answer::Unsat),
        Sexp::Atom(a) if a == "sat" => {
            if want.is_empty() {
                return Ok(Answer::Sat(Vec::new()));
            }
            match reader.next_sexp() {
                None => Err("`sat` but no get-value response".to_string()),
                Some(Err(e)) => Err(format!("`sat` but {e}")),
                Some(Ok(values)) => parse_values(&values, want).map(Answer::Sat),
            }
        }
        Sexp::Atom(a) if a == "unknown" => Err("the solver answered `unknown`".to_string()),
        Sexp::Atom(a) if a == "timeout" => Ok(Answer::Timeout),
        other => match error_message(other) {
            Some(msg) => Err(format!("solver error: {msg}")),
            None => Err("unexpected output".to_string()),
        },
    }
}

/// The message of an `(error "...")` response.
fn error_message(sexp: &Sexp) -> Option<String> {
    match sexp {
        Sexp::List(items) if items.first().and_then(Sexp::atom) == Some("error") => {
            Some(match items.get(1) {
                // On one line: cvc5's messages quote the offending source line under a caret.
                Some(Sexp::Str(msg)) => msg.split_whitespace().collect::<Vec<_>>().join(" "),
                _ => "(no message)".to_string(),
            })
        }
        _ => None,
    }
}

/// `|x|` and `x` are the same SMT-LIB symbol.
fn unquote(symbol: &str) -> &str {
    symbol
        .strip_prefix('|')
        .and_then(|s| s.strip_suffix('|'))
        .unwrap_or(symbol)
}

/// Parses a `get-value` response `((v1 val1) (v2 val2) ...)` into the values of `want`, in
/// `want`'s order.
fn parse_values(response: &Sexp, want: &[String]) -> Result<Vec<(String, u128, u32)>, String> {
    if let Some(msg) = error_message(response) {
        return Err(format!("get-value failed: {msg}"));
    }
    let Sexp::List(pairs) = response else {
        return Err("the get-value response is not a list".to_string());
    };
    // By name (the first entry of a name counts): a model of the multi-model controller's
    // step has 13,000 values, and a linear search per wanted name was most of the time spent
    // reading it.
    let mut found: HashMap<&str, (u128, u32)> = HashMap::with_capacity(pairs.len());
    for pair in pairs {
        match pair {
            Sexp::List(kv) if kv.len() == 2 => {
                let name = kv[0]
                    .atom()
                    .ok_or("a get-value entry's name is not a symbol")?;
                let (value, width) =
                    parse_bv_literal(&kv[1]).map_err(|e| format!("value of `{name}`: {e}"))?;
                found.entry(unquote(name)).or_insert((value, width));
            }
            _ => return Err("a get-value entry is not a (name value) pair".to_string()),
        }
    }
    want.iter()
        .map(|w| {
            found
                .get(unquote(w))
                .map(|&(value, width)| (w.clone(), value, width))
                .ok_or_else(|| format!("no value for `{w}` in the get-value response"))
        })
        .collect()
}

/// Reads a bit-vector literal `#b0101`, `#x00ff` or `(_ bv123 16)` as (unsigned value, width),
/// or an integer `123` / `(- 123)` as its two's complement with width 128.
fn parse_bv_literal(sexp: &Sexp) -> Result<(u128, u32), String> {
    let too_wide = |w: usize| format!("{w}-bit value is wider than 128 bits");
    match sexp {
        Sexp::Atom(lit) if lit.starts_with("#b") => {
            let digits = &lit[2..];
            if digits.is_empty() || !digits.bytes().all(|b| b == b'0' || b == b'1') {
                return Err(format!("bad binary literal `{lit}`"));
            }
            if digits.len() > 128 {
                return Err(too_wide(digits.len()));
            }
            let value = digits
                .bytes()
                .fold(0u128, |v, b| (v << 1) | u128::from(b - b'0'));
            Ok((value, digits.len() as u32))
        }
        Sexp::Atom(lit) if lit.starts_with("#x") => {
            let digits = &lit[2..];
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(format!("bad hexadecimal literal `{lit}`"));
            }
            if digits.len() > 32 {
                return Err(too_wide(digits.len() * 4));
            }
            let value = u128::from_str_radix(digits, 16)
                .map_err(|e| format!("bad hexadecimal literal `{lit}`: {e}"))?;
            Ok((value, digits.len() as u32 * 4))
        }
        Sexp::List(items) => {
            let atoms: Option<Vec<&str>> = items.iter().map(Sexp::atom).collect();
            let (value, width) = match atoms.as_deref() {
                Some(["-", digits]) if digits.bytes().all(|b| b.is_ascii_digit()) => {
                    return int_value(digits, true);
                }
                Some(["_", bv, width]) => match bv.strip_prefix("bv") {
                    Some(value) => (value, *width),
                    None => return Err("unexpected indexed term (not `(_ bvN W)`)".to_string()),
                },
                _ => return Err("not a bit-vector literal".to_string()),
            };
            let decimal = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
            if !decimal(value) || !decimal(width) {
                return Err(format!("bad literal `(_ bv{value} {width})`"));
            }
            let width: u32 = match width.parse() {
                Ok(w) if (1..=128).contains(&w) => w,
                Ok(0) => return Err("zero-width bit-vector".to_string()),
                _ => return Err(format!("{width}-bit value is wider than 128 bits")),
            };
            let value: u128 = value
                .parse()
                .map_err(|_| format!("value `{value}` does not fit in 128 bits"))?;
            if width < 128 && value >> width != 0 {
                return Err(format!("value {value} does not fit in {width} bits"));
            }
            Ok((value, width))
        }
        Sexp::Atom(lit) if !lit.is_empty() && lit.bytes().all(|b| b.is_ascii_digit()) => {
            int_value(lit, false)
        }
        _ => Err("not a bit-vector literal".to_string()),
    }
}

/// An integer model value `123` or `(- 123)` (integer encodings), as its 128-bit two's
/// complement with width 128.
fn int_value(digits: &str, negative: bool) -> Result<(u128, u32), String> {
    let v: i128 = digits
        .parse()
        .map_err(|_| format!("integer `{digits}` does not fit in 128 bits"))?;
    Ok(((if negative { -v } else { v }) as u128, 128))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::testing::want;

    #[test]
    fn parses_get_value_forms() {
        let cases = [
            // z3 prints #x when the width is a multiple of 4, #b otherwise.
            ("sat\n((x #x02)\n (y #x0e))\n", vec![("x", 2, 8), ("y", 14, 8)]),
            // cvc5 1.0.3 prints #b.
            (
                "sat\n((x #b00000010) (y #b00001110))\n",
                vec![("x", 2, 8), ("y", 14, 8)],
            ),
            // cvc5 with --bv-print-consts-as-indexed-symbols.
            (
                "sat\n((x (_ bv2 8)) (y (_ bv14 8)))\n",
                vec![("x", 2, 8), ("y", 14, 8)],
            ),
            (
                "  \n sat \n ( ( y\n#b1 ) ( x\t(_\nbv340282366920938463463374607431768211455 128) ) )",
                vec![("x", u128::MAX, 128), ("y", 1, 1)],
            ),
            (
                "sat\n((|a b| #b0000000) (x #xffffffffffffffffffffffffffffffff))",
                vec![("x", u128::MAX, 128), ("|a b|", 0, 7)],
            ),
            // Integer encodings: two's complement at width 128.
            (
                "sat\n((x 12) (y (- 3)))\n",
                vec![("x", 12, 128), ("y", (-3i128) as u128, 128)],
            ),
        ];
        for (out, expect) in cases {
            let names: Vec<&str> = expect.iter().map(|e| e.0).collect();
            let expect: Vec<(String, u128, u32)> = expect
                .iter()
                .map(|&(n, v, w)| (n.to_string(), v, w))
                .collect();
            assert_eq!(
                parse_output(out, &want(&names)),
                Ok(Answer::Sat(expect)),
                "{out}"
            );
        }
        // `x` and `|x|` are one symbol.
        assert_eq!(
            parse_output("sat ((|x| #x7))", &want(&["x"])),
            Ok(Answer::Sat(vec![("x".into(), 7, 4)]))
        );
        // A name given twice: its first value; a name wanted twice: both times.
        assert_eq!(
            parse_output("sat ((x #x1) (|x| #x2))", &want(&["x", "x"])),
            Ok(Answer::Sat(vec![("x".into(), 1, 4), ("x".into(), 1, 4)]))
        );
        assert_eq!(parse_output("sat", &[]), Ok(Answer::Sat(vec![])));
        assert_eq!(
            parse_output("unsat\n(error \"model is not available\")", &want(&["x"])),
            Ok(Answer::Unsat)
        );
        assert_eq!(parse_output("timeout\n", &[]), Ok(Answer::Timeout));
        assert_eq!(
            parse_output("(warning \"w\")\nunsat", &[]),
            Ok(Answer::Unsat)
        );
    }

    #[test]
    fn rejects_bad_output() {
        let x = want(&["x"]);
        for out in [
            "",
            "unknown",
            "(error \"line 3: bad\")\nsat\n((x #x00))",
            "sat",
            "sat\n((x #x0",
            "sat\n((x #x0g))",
            "sat\n((x #x+f))",
            "sat\n((x #b012))",
            "sat\n((x #b))",
            "sat\n((y #x00))",
            "sat\n((x (_ bv256 8)))",
            "sat\n((x (_ bv1 0)))",
            "sat\n((x (_ bv1 129)))",
            "sat\n((x (_ bv+1 8)))",
            "sat\n((x (bvadd #x01 #x02)))",
            "sat\n((x #b0 #b1))",
            "sat\n(x #b0)",
            "sat\n(error \"cannot get value\")",
            "sat\n((x #x000000000000000000000000000000000))",
            "Sat\n((x #x00))",
            ")",
            "\"unterminated",
        ] {
            assert!(parse_output(out, &x).is_err(), "{out:?}");
        }
        // Nesting deep enough to overflow a recursive reader's stack.
        let deep = "(".repeat(1_000_000) + &")".repeat(1_000_000);
        assert!(parse_output(&deep, &[]).is_err());
    }
}

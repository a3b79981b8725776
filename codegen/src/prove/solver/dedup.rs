//! Alpha-equivalent obligations are asked once.
//!
//! A controller with several copies of one block (the seven RLS estimators of the milling
//! multi-model controller, `verified/specs/milling_multimodel.qloop`, are six copies of one
//! five-parameter estimator and a four-parameter one) yields, for each copy, the same
//! obligations over different variables: the scripts differ only in the names of their
//! declared symbols. Renaming a script's declared symbols by any bijection keeps its
//! satisfiability, and maps its models along, so such scripts need one solver run each:
//!
//! * the **key** of a script is its token sequence (comments dropped, whitespace
//!   normalised) with every symbol that the script declares (`declare-fun`, `declare-const`,
//!   `define-fun`) replaced by `#n`, n its order of first occurrence; `want` is renamed by the
//!   same map. `#` followed by digits is no SMT-LIB token (literals are `#b…`, `#x…`), so a
//!   renamed symbol cannot collide with anything left as it was;
//! * two **groups** of queries (the encodings of one obligation) are identical when their
//!   queries' keys and batching flags are equal in order. Only the first such group runs;
//! * each other group takes its answers, query by query: `unsat` as is, a `sat` model with
//!   its names replaced by the group's own `want` names (same position, same canonical name),
//!   so every model is still replayed against its own obligation. Its runs are marked
//!   [`Run::shared`], with no time of their own.
//!
//! Scripts that are alpha-equivalent only up to a different declaration order are not
//! recognised: the key is conservative, never merging scripts that could differ.

use super::{Answer, Query, Run};
use std::collections::HashMap;

/// SMT-LIB tokens of `script`: parentheses, quoted symbols `|…|`, string literals, and
/// whitespace-separated atoms; comments (`;` to the end of the line) are dropped.
fn tokens(script: &str) -> Vec<&str> {
    let bytes = script.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        match c {
            b'(' | b')' => {
                out.push(&script[i..i + 1]);
                i += 1;
            }
            b';' => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'|' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'|' {
                    i += 1;
                }
                i = (i + 1).min(bytes.len());
                out.push(&script[start..i]);
            }
            b'"' => {
                i += 1;
                // `""` inside a string is an escaped quote.
                while i < bytes.len() {
                    if bytes[i] == b'"' {
                        if bytes.get(i + 1) == Some(&b'"') {
                            i += 2;
                            continue;
                        }
                        i += 1;
                        break;
                    }
                    i += 1;
                }
                out.push(&script[start..i]);
            }
            c if c.is_ascii_whitespace() => i += 1,
            _ => {
                while i < bytes.len()
                    && !bytes[i].is_ascii_whitespace()
                    && !matches!(bytes[i], b'(' | b')' | b';' | b'|' | b'"')
                {
                    i += 1;
                }
                out.push(&script[start..i]);
            }
        }
    }
    out
}

/// The key of a query: its script and wanted names with the declared symbols renamed in
/// order of first occurrence (module docs).
pub(super) fn canonical(q: &Query) -> String {
    let toks = tokens(&q.script);
    let declared: std::collections::HashSet<&str> = toks
        .windows(2)
        .filter(|w| matches!(w[0], "declare-fun" | "declare-const" | "define-fun"))
        .map(|w| w[1])
        .collect();
    let mut names: HashMap<String, usize> = HashMap::new();
    let mut key = String::with_capacity(q.script.len());
    let mut rename = |t: &str, key: &mut String| {
        if declared.contains(&t) {
            let n = names.len();
            let n = *names.entry(t.to_string()).or_insert(n);
            key.push('#');
            key.push_str(&n.to_string());
        } else {
            key.push_str(t);
        }
    };
    for t in &toks {
        rename(t, &mut key);
        key.push(' ');
    }
    key.push_str("\nwant:");
    for w in &q.want {
        key.push(' ');
        rename(w.as_str(), &mut key);
    }
    key
}

/// How the queries map onto the ones that run.
pub(super) struct Classes {
    /// The queries that run, as indices into the original list, in order.
    pub runs: Vec<usize>,
    /// For each original query, the index (into `runs`) of the query whose answers it takes.
    pub source: Vec<usize>,
    /// Whether each original query takes its answers from another's run.
    pub shared: Vec<bool>,
}

/// The classes of `queries` in `groups` (module docs): the first group of each key runs.
pub(super) fn classes(queries: &[Query], groups: &[usize], small: &[bool]) -> Classes {
    let group_of = |qi: usize| groups.get(qi).copied().unwrap_or(qi);
    let keys: Vec<String> = queries.iter().map(canonical).collect();
    // The members of each group, in order.
    let mut members: HashMap<usize, Vec<usize>> = HashMap::new();
    for qi in 0..queries.len() {
        members.entry(group_of(qi)).or_default().push(qi);
    }
    let group_key = |g: usize| {
        let mut k = String::new();
        for &qi in &members[&g] {
            k.push_str(if small.get(qi).copied().unwrap_or(false) {
                "small\n"
            } else {
                "single\n"
            });
            k.push_str(&keys[qi]);
            k.push('\u{0}');
        }
        k
    };
    let mut first_group: HashMap<String, usize> = HashMap::new();
    let mut runs = Vec::new();
    let mut source = vec![usize::MAX; queries.len()];
    let mut shared = vec![false; queries.len()];
    for qi in 0..queries.len() {
        let g = group_of(qi);
        if source[qi] != usize::MAX {
            continue;
        }
        let rep = *first_group.entry(group_key(g)).or_insert(g);
        if rep == g {
            for &m in &members[&g] {
                source[m] = runs.len();
                runs.push(m);
            }
        } else {
            for (&m, &r) in members[&g].iter().zip(&members[&rep]) {
                source[m] = source[r];
                shared[m] = true;
            }
        }
    }
    Classes {
        runs,
        source,
        shared,
    }
}

/// The run of `from` as an answer to `to`: a model's names become `to`'s, position by
/// position (their canonical names are equal), and the run is marked shared, with no time.
pub(super) fn share(run: &Run, to: &Query) -> Run {
    let answer = match &run.answer {
        Answer::Sat(values) => Answer::Sat(
            values
                .iter()
                .zip(&to.want)
                .map(|((_, v, w), name)| (name.clone(), *v, *w))
                .collect(),
        ),
        other => other.clone(),
    };
    Run {
        solver: run.solver,
        answer,
        millis: 0,
        cached: run.cached,
        shared: true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prove::solver::testing::query;

    #[test]
    fn renaming_declared_symbols_keeps_the_key() {
        let a = query(
            "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8))\n(define-fun y () (_ BitVec 8) (bvadd x #x01))\n(assert (= y x))",
            &["x"],
        );
        let b = query(
            "; another obligation\n(set-logic QF_BV)\n(declare-fun P_3_1 () (_ BitVec 8))\n(define-fun o7 () (_ BitVec 8)  (bvadd P_3_1 #x01))\n(assert (= o7 P_3_1))",
            &["P_3_1"],
        );
        assert_eq!(canonical(&a), canonical(&b));
    }

    #[test]
    fn anything_but_a_renaming_changes_the_key() {
        let base = "(set-logic QF_BV)\n(declare-fun x () (_ BitVec 8))\n(declare-fun y () (_ BitVec 8))\n(assert (bvult x y))";
        let k = canonical(&query(base, &["x", "y"]));
        // The roles of x and y swapped in the assertion: not the same question.
        let swapped = base.replace("(bvult x y)", "(bvult y x)");
        // A constant, a width, an operator.
        let others = [
            swapped,
            base.replace("(bvult x y)", "(bvult x #x05)"),
            base.replace(
                "(_ BitVec 8))\n(declare-fun y",
                "(_ BitVec 9))\n(declare-fun y",
            ),
            base.replace("bvult", "bvslt"),
        ];
        for o in &others {
            assert_ne!(k, canonical(&query(o, &["x", "y"])), "{o}");
        }
        // The same script wanting other values.
        assert_ne!(k, canonical(&query(base, &["y", "x"])));
        // An undeclared symbol is not renamed: `x` free in one, `z` in the other.
        assert_ne!(
            canonical(&query("(assert (= x #x00))", &[])),
            canonical(&query("(assert (= z #x00))", &[]))
        );
    }

    #[test]
    fn quoted_symbols_strings_and_comments_are_tokens_or_nothing() {
        assert_eq!(
            tokens("(a |b c| \"d \"\"e\"\"\" ; f g\n h)"),
            ["(", "a", "|b c|", "\"d \"\"e\"\"\"", "h", ")"]
        );
    }

    #[test]
    fn only_whole_identical_groups_share() {
        let x = "(declare-fun x () (_ BitVec 8))\n(assert (= x #x01))";
        let y = "(declare-fun y () (_ BitVec 8))\n(assert (= y #x01))";
        let z = "(declare-fun z () (_ BitVec 8))\n(assert (= z #x02))";
        // Groups: {0, 1} = (x, z), {2, 3} = (y, z'), {4, 5} = (y, y): the first two are
        // alike, the third is not (its second encoding differs).
        let qs = [
            query(x, &["x"]),
            query(z, &["z"]),
            query(y, &["y"]),
            query(&z.replace('z', "w"), &["w"]),
            query(y, &["y"]),
            query(y, &["y"]),
        ];
        let c = classes(&qs, &[0, 0, 2, 2, 4, 4], &[]);
        assert_eq!(c.runs, [0, 1, 4, 5]);
        assert_eq!(c.source, [0, 1, 0, 1, 2, 3]);
        assert_eq!(c.shared, [false, false, true, true, false, false]);
        // A model's names are the receiving query's own.
        let run = Run {
            solver: super::super::Solver::Z3,
            answer: Answer::Sat(vec![("x".into(), 1, 8)]),
            millis: 5,
            cached: false,
            shared: false,
        };
        let s = share(&run, &qs[2]);
        assert_eq!(s.answer, Answer::Sat(vec![("y".into(), 1, 8)]));
        assert!(s.shared && s.millis == 0);
    }
}

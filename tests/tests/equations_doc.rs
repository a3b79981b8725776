//! `docs/book/src/appendix/equations.md` agrees with the code: every file it names exists, every `file::item` it
//! names is an item of that file (the last path segment is defined there: `fn`, `struct`,
//! `const`, …, or a spec's `let`/`property`), every `file:line` spec citation is inside the
//! file, and every generated harness it names is one the seed specs generate.

use std::path::Path;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// Backticked spans of the document.
fn code_spans(doc: &str) -> Vec<&str> {
    doc.split('`').skip(1).step_by(2).collect()
}

const DIRS: [&str; 7] = [
    "aco/",
    "codegen/",
    "plant/",
    "tests/",
    "verified/",
    "targets/",
    "docs/",
];

#[test]
fn every_cited_file_and_item_exists() {
    let doc = std::fs::read_to_string(root().join("docs/book/src/appendix/equations.md"))
        .expect("docs/book/src/appendix/equations.md");
    let mut checked = 0;
    let mut missing = Vec::new();
    for span in code_spans(&doc) {
        let Some(first) = span.split_whitespace().next() else {
            continue;
        };
        if !DIRS.iter().any(|d| first.starts_with(d)) {
            continue;
        }
        let (file, item) = match first.split_once("::") {
            Some((f, i)) => (f, Some(i)),
            None => (first, None),
        };
        let (file, line) = match file.rsplit_once(':') {
            Some((f, l)) if l.chars().all(|c| c.is_ascii_digit()) => (f, l.parse::<usize>().ok()),
            _ => (file, None),
        };
        let Ok(text) = std::fs::read_to_string(root().join(file)) else {
            if !root().join(file).exists() {
                missing.push(format!("{first}: no file {file}"));
            }
            checked += 1;
            continue;
        };
        if let Some(l) = line {
            if l == 0 || l > text.lines().count() {
                missing.push(format!("{first}: {file} has no line {l}"));
            }
        }
        if let Some(item) = item {
            let name = item.rsplit("::").next().unwrap_or(item);
            let defined = [
                "fn ",
                "struct ",
                "enum ",
                "const ",
                "static ",
                "type ",
                "mod ",
                "trait ",
                "let ",
                "property ",
                "invariant ",
            ]
            .iter()
            .any(|kw| defines(&text, &format!("{kw}{name}")))
                || (file.ends_with(".c") && text.contains(&format!(" {name}(")));
            if !defined {
                missing.push(format!("{first}: `{name}` is not defined in {file}"));
            }
        }
        checked += 1;
    }
    assert!(
        checked >= 50,
        "only {checked} citations found: did the format change?"
    );
    assert!(
        missing.is_empty(),
        "docs/book/src/appendix/equations.md cites what is not there:\n{}",
        missing.join("\n")
    );
}

#[test]
fn every_cited_harness_is_generated() {
    let doc = std::fs::read_to_string(root().join("docs/book/src/appendix/equations.md"))
        .expect("docs/book/src/appendix/equations.md");
    for span in code_spans(&doc) {
        let Some((module, harness)) = span.split_once("_proofs::") else {
            continue;
        };
        // `name_proofs::…` stands for the module's harnesses in general.
        if !harness
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            continue;
        }
        let spec = root().join(format!("verified/specs/{module}.qloop"));
        let src = std::fs::read_to_string(&spec).unwrap_or_else(|e| panic!("{span}: {e}"));
        let plan = qloop::compile_str(&src, &qloop::Target::default()).expect("seed spec");
        let kani = qloop::gen_kani(&plan);
        assert!(
            kani.contains(&format!("fn {harness}()")),
            "{span}: not generated"
        );
    }
}

/// Whether `text` has `decl` (`fn name`, ...) as a whole word: `fn exp_diff` is not
/// `fn exp_diff2`.
fn defines(text: &str, decl: &str) -> bool {
    text.match_indices(decl).any(|(i, _)| {
        !text[i + decl.len()..]
            .chars()
            .next()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
    })
}

/// The summary's counts are the rows': for each paper, the number of rows and of each status
/// (the last column begins with `implemented`, `partly` or `not yet`), and their totals.
#[test]
fn the_summary_counts_the_rows() {
    let path = "docs/book/src/appendix/equations.md";
    let doc = std::fs::read_to_string(root().join(path)).expect(path);
    let (body, summary) = doc
        .split_once("## Summary")
        .expect("a `## Summary` section");
    let statuses = ["implemented", "partly", "not yet"];
    let cells = |line: &str| -> Vec<String> {
        line.trim()
            .trim_matches('|')
            .split('|')
            .map(|c| c.trim().to_string())
            .collect()
    };
    let is_row = |line: &str| {
        line.starts_with("| ") && !line.starts_with("| paper") && !line.starts_with("|---")
    };
    // paper -> [rows, implemented, partly, not yet]
    let mut counted: Vec<(String, [usize; 4])> = Vec::new();
    for line in body.lines().filter(|l| is_row(l)) {
        let c = cells(line);
        let status = c.last().expect("a status");
        let k = statuses
            .iter()
            .position(|s| status.starts_with(s))
            .unwrap_or_else(|| panic!("{path}: a status that is none of {statuses:?}: {line}"));
        let at = match counted.iter().position(|(p, _)| *p == c[0]) {
            Some(i) => i,
            None => {
                counted.push((c[0].clone(), [0; 4]));
                counted.len() - 1
            }
        };
        counted[at].1[0] += 1;
        counted[at].1[k + 1] += 1;
    }
    let mut all = [0usize; 4];
    for (_, n) in &counted {
        for (a, b) in all.iter_mut().zip(n) {
            *a += b;
        }
    }
    counted.push(("all".to_string(), all));
    let stated: Vec<(String, [usize; 4])> = summary
        .lines()
        .filter(|l| is_row(l))
        .map(|line| {
            let c = cells(line);
            let n: Vec<usize> = c[1..5]
                .iter()
                .map(|v| v.parse().unwrap_or_else(|_| panic!("{path}: {line}")))
                .collect();
            (c[0].clone(), [n[0], n[1], n[2], n[3]])
        })
        .collect();
    assert_eq!(
        stated, counted,
        "{path}: the summary (left) does not count the rows (right)"
    );
}

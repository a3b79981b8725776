//! The book (`docs/book/src`) and the README cannot drift from the code:
//!
//! * every `qloop` code block is a whole spec that compiles; `qloop,prove` blocks are proved by
//!   `qloop prove` (both solvers), and `qloop,refuted=NAME` blocks are refuted on property
//!   `NAME`; an mdBook `{{#include FILE}}` in a block is the file itself, so the book shows the
//!   repository's specs;
//! * every `toml,scenario=PLANT` block is a scenario file that the plant takes;
//! * every `text,qloop-check=SPEC` block is what `qloop check SPEC` prints;
//! * every relative link and image points at a file of the repository, and every `#anchor` at a
//!   heading of its page;
//! * the CLI reference (`reference/cli.md`) is `qloop --help` and every subcommand's help, and
//!   the crate map of `internals/architecture.md` is the workspace's manifests: both are
//!   generated, and `QLOOP_BLESS=1` rewrites them;
//! * a count of the seed specs in the prose (`nine seed specs`) is the number of files in
//!   `verified/specs`;
//! * the book's chapters are all in its `SUMMARY.md`.

use crate::common::{qloop, text};
use pulldown_cmark::{CodeBlockKind, Event, Options, Parser, Tag, TagEnd};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    test_tools::workspace_root()
        .canonicalize()
        .expect("workspace root")
}

fn book() -> PathBuf {
    root().join("docs/book/src")
}

/// The Markdown files checked: the README, the book's chapters and the folder READMEs.
fn pages() -> Vec<PathBuf> {
    let mut v = vec![root().join("README.md"), root().join("tests/README.md")];
    let mut stack = vec![book()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("book folder").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                v.push(p);
            }
        }
    }
    for t in ["avr", "cortex-m", "linuxcnc", "bench"] {
        let p = root().join("targets").join(t).join("README.md");
        if p.exists() {
            v.push(p);
        }
    }
    v.sort();
    v
}

/// A fenced code block: its info string, its text (includes resolved) and its line; and, for
/// a block that is one `{{#include FILE:ANCHOR}}` (an excerpt), the file it is an excerpt of.
struct Block {
    info: String,
    text: String,
    line: usize,
    excerpt_of: Option<PathBuf>,
}

/// A page's fenced code blocks, links (with their lines) and heading anchors.
struct Page {
    path: PathBuf,
    blocks: Vec<Block>,
    links: Vec<(String, usize)>,
    anchors: BTreeSet<String>,
}

/// The anchor mdBook (and GitHub) gives a heading: lower case, spaces to `-`, only
/// alphanumerics, `-` and `_` kept.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn line_of(src: &str, offset: usize) -> usize {
    src[..offset].matches('\n').count() + 1
}

/// `{{#include PATH}}` or `{{#include PATH:ANCHOR}}` lines of a block, replaced by the file
/// (or the lines between `ANCHOR: name` and `ANCHOR_END: name`), as mdBook does.
fn resolve_includes(dir: &Path, text: &str, at: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let t = line.trim();
        let Some(inner) = t
            .strip_prefix("{{#include ")
            .and_then(|r| r.strip_suffix("}}"))
        else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let (file, anchor) = match inner.trim().rsplit_once(':') {
            Some((f, a)) if !a.contains('/') && !a.is_empty() => (f, Some(a)),
            _ => (inner.trim(), None),
        };
        let path = dir.join(file);
        let body = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{at}: {{{{#include {file}}}}}: {e}"));
        match anchor {
            None => out.push_str(&body),
            Some(a) => {
                let start = format!("ANCHOR: {a}");
                let end = format!("ANCHOR_END: {a}");
                let mut inside = false;
                let mut found = false;
                for l in body.lines() {
                    if l.contains(&end) {
                        inside = false;
                    } else if l.contains(&start) {
                        inside = true;
                        found = true;
                    } else if inside && !l.contains("ANCHOR") {
                        out.push_str(l);
                        out.push('\n');
                    }
                }
                assert!(found, "{at}: no `ANCHOR: {a}` in {file}");
            }
        }
    }
    out
}

fn read_page(path: &Path) -> Page {
    let src = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let dir = path.parent().expect("a folder");
    let mut page = Page {
        path: path.to_path_buf(),
        blocks: Vec::new(),
        links: Vec::new(),
        anchors: BTreeSet::new(),
    };
    let mut code: Option<(String, String, usize)> = None;
    let mut heading: Option<String> = None;
    let opts = Options::ENABLE_TABLES | Options::ENABLE_FOOTNOTES | Options::ENABLE_STRIKETHROUGH;
    for (ev, range) in Parser::new_ext(&src, opts).into_offset_iter() {
        match ev {
            Event::Start(Tag::CodeBlock(CodeBlockKind::Fenced(info))) => {
                code = Some((info.to_string(), String::new(), line_of(&src, range.start)));
            }
            Event::End(TagEnd::CodeBlock) => {
                if let Some((info, text, line)) = code.take() {
                    let at = format!("{}:{line}", path.display());
                    let excerpt_of = text
                        .trim()
                        .strip_prefix("{{#include ")
                        .and_then(|r| r.strip_suffix("}}"))
                        .filter(|_| text.trim().lines().count() == 1)
                        .and_then(|inner| inner.trim().rsplit_once(':'))
                        .map(|(f, _)| dir.join(f));
                    page.blocks.push(Block {
                        text: resolve_includes(dir, &text, &at),
                        info,
                        line,
                        excerpt_of,
                    });
                }
            }
            Event::Text(t) | Event::Code(t) => {
                if let Some((_, text, _)) = code.as_mut() {
                    text.push_str(&t);
                } else if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
            }
            Event::Start(Tag::Heading { .. }) => heading = Some(String::new()),
            Event::End(TagEnd::Heading(_)) => {
                if let Some(h) = heading.take() {
                    page.anchors.insert(slug(&h));
                }
            }
            Event::Start(Tag::Link { dest_url, .. })
            | Event::Start(Tag::Image { dest_url, .. }) => {
                page.links
                    .push((dest_url.to_string(), line_of(&src, range.start)));
            }
            _ => {}
        }
    }
    page
}

fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

/// Every `qloop` block compiles; `prove` and `refuted=NAME` blocks are decided by `qloop prove`.
#[test]
fn every_spec_in_the_book_compiles_and_says_what_prove_says() {
    let tmp = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("book-specs");
    std::fs::create_dir_all(&tmp).unwrap();
    let mut checked = 0;
    let solvers = test_tools::tool("z3").is_some() && test_tools::tool("cvc5").is_some();
    for page in pages().iter().map(|p| read_page(p)) {
        for (k, b) in page.blocks.iter().enumerate() {
            let mut words = b.info.split(',').map(str::trim);
            if words.next() != Some("qloop") {
                continue;
            }
            let at = format!("{}:{}", rel(&page.path), b.line);
            // An excerpt stands for its file: the whole file must compile (and prove).
            let spec = match &b.excerpt_of {
                Some(f) => std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{at}: {e}")),
                None => b.text.clone(),
            };
            let plan = qloop::compile_str(&spec, &qloop::Target::default()).unwrap_or_else(|d| {
                panic!(
                    "{at}: the spec does not compile:\n{}",
                    d.render("book", &spec)
                )
            });
            assert!(!plan.prog.signals.is_empty(), "{at}");
            checked += 1;
            for w in words {
                if !solvers {
                    eprintln!(
                        "note: skipped `qloop prove` of {at}: z3 and cvc5 are not both installed"
                    );
                    continue;
                }
                let file = tmp.join(format!(
                    "{}-{k}.qloop",
                    page.path.file_stem().unwrap().to_string_lossy()
                ));
                std::fs::write(&file, &spec).unwrap();
                let o = qloop(&["prove", file.to_str().unwrap()]);
                let out = text(&o.stdout);
                if w == "prove" {
                    assert_eq!(o.status.code(), Some(0), "{at}: not proved:\n{out}");
                } else if let Some(name) = w.strip_prefix("refuted=") {
                    assert_eq!(o.status.code(), Some(1), "{at}: not refuted:\n{out}");
                    assert!(
                        out.contains(&format!("REFUTED: property {name} ")),
                        "{at}: `{name}` is not the refuted property:\n{out}"
                    );
                } else {
                    panic!("{at}: unknown attribute `{w}` of a qloop block (prove, refuted=NAME)");
                }
            }
        }
    }
    assert!(checked >= 10, "only {checked} specs found in the book");
}

/// Every `toml,scenario=PLANT` block is a scenario the plant takes.
#[test]
fn every_scenario_in_the_book_reads() {
    let mut checked = 0;
    for page in pages().iter().map(|p| read_page(p)) {
        for b in &page.blocks {
            let Some(plant) = b.info.strip_prefix("toml,scenario=") else {
                continue;
            };
            let at = format!("{}:{}", rel(&page.path), b.line);
            let sc =
                qloop_plant::Scenario::from_toml(&b.text).unwrap_or_else(|e| panic!("{at}: {e}"));
            let p =
                qloop_plant::catalog::plant_named(plant).unwrap_or_else(|e| panic!("{at}: {e}"));
            let offered: Vec<&str> = p.channels().iter().map(|c| c.name).collect();
            for ch in sc.channels.keys() {
                assert!(
                    offered.contains(&ch.as_str()),
                    "{at}: the {plant} plant has no channel `{ch}` ({offered:?})"
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 1);
}

/// Every `text,qloop-check=SPEC` block is what `qloop check SPEC` prints (run in the page's
/// folder, so that the header names the file as the page does); every line of a
/// `text,qloop-check-lines=SPEC` block is a line of it.
#[test]
fn every_check_report_in_the_book_is_what_check_prints() {
    let mut checked = 0;
    for page in pages().iter().map(|p| read_page(p)) {
        for b in &page.blocks {
            let (spec, whole) = match (
                b.info.strip_prefix("text,qloop-check="),
                b.info.strip_prefix("text,qloop-check-lines="),
            ) {
                (Some(s), _) => (s, true),
                (_, Some(s)) => (s, false),
                _ => continue,
            };
            let at = format!("{}:{}", rel(&page.path), b.line);
            let o = std::process::Command::new(env!("CARGO_BIN_EXE_qloop"))
                .current_dir(page.path.parent().unwrap())
                .args(["check", spec])
                .output()
                .expect("run qloop");
            assert_eq!(o.status.code(), Some(0), "{at}: {}", text(&o.stderr));
            let out = text(&o.stdout);
            if whole {
                assert_eq!(
                    b.text.trim_end(),
                    out.trim_end(),
                    "{at}: the page's report (left) is not what `qloop check {spec}` prints (right)"
                );
            } else {
                for l in b.text.lines().filter(|l| !l.trim().is_empty()) {
                    assert!(
                        out.lines().any(|o| o == l),
                        "{at}: `qloop check {spec}` prints no line\n{l}\nIt prints:\n{out}"
                    );
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 1);
}

/// Every relative link and image exists, and every anchor is a heading of its page.
#[test]
fn every_link_resolves() {
    let pages: Vec<Page> = pages().iter().map(|p| read_page(p)).collect();
    let mut bad = Vec::new();
    let mut checked = 0;
    for page in &pages {
        let dir = page.path.parent().unwrap();
        for (dest, line) in &page.links {
            if dest.contains("://") || dest.starts_with("mailto:") {
                continue;
            }
            let at = format!("{}:{line}", rel(&page.path));
            let (file, anchor) = match dest.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (dest.as_str(), None),
            };
            let target = if file.is_empty() {
                page.path.clone()
            } else {
                dir.join(file)
            };
            checked += 1;
            let Ok(target) = target.canonicalize() else {
                bad.push(format!("{at}: `{dest}`: no such file"));
                continue;
            };
            if !target.starts_with(root()) {
                bad.push(format!("{at}: `{dest}` is outside the repository"));
                continue;
            }
            if let Some(a) = anchor {
                let anchors = match pages.iter().find(|p| p.path == target) {
                    Some(p) => p.anchors.clone(),
                    None if target.extension().is_some_and(|x| x == "md") => {
                        read_page(&target).anchors
                    }
                    None => {
                        bad.push(format!(
                            "{at}: `{dest}`: an anchor into a file that is not a page"
                        ));
                        continue;
                    }
                };
                if !anchors.contains(a) {
                    bad.push(format!(
                        "{at}: `{dest}`: no heading `#{a}` in {}",
                        rel(&target)
                    ));
                }
            }
        }
    }
    assert!(checked >= 50, "only {checked} links found");
    assert!(
        bad.is_empty(),
        "links that do not resolve:\n{}",
        bad.join("\n")
    );
}

/// Every chapter file of the book is in `SUMMARY.md`, and every entry there exists.
#[test]
fn the_summary_lists_every_chapter() {
    let summary = book().join("SUMMARY.md");
    let page = read_page(&summary);
    let listed: BTreeSet<PathBuf> = page
        .links
        .iter()
        .map(|(d, _)| {
            book()
                .join(d)
                .canonicalize()
                .unwrap_or_else(|_| panic!("SUMMARY.md: `{d}` does not exist"))
        })
        .collect();
    for p in pages()
        .into_iter()
        .filter(|p| p.starts_with(book()) && *p != summary)
    {
        assert!(listed.contains(&p), "{} is not in SUMMARY.md", rel(&p));
    }
}

/// The subcommands `qloop help` lists (`Commands:` of a help text), without `help`.
fn subcommands(help: &str) -> Vec<String> {
    let Some((_, rest)) = help.split_once("\nCommands:\n") else {
        return Vec::new();
    };
    rest.lines()
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// The CLI reference: `qloop --help`, then every subcommand's (recursively), each in a block.
fn cli_reference() -> String {
    let mut out = String::from(
        "# Command-line reference\n\n\
         Generated from the binary's own help (`qloop --help` and `qloop COMMAND --help`) by\n\
         `codegen/tests/docs.rs`, which fails when this page and the binary differ;\n\
         `QLOOP_BLESS=1 cargo test -p qloop --test integration docs::` rewrites it. Exit codes and\n\
         conventions: [Install](../guide/install.md#exit-codes).\n",
    );
    let mut todo = vec![Vec::<String>::new()];
    while let Some(path) = todo.pop() {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let o = qloop(&args);
        assert_eq!(o.status.code(), Some(0), "qloop {}", args.join(" "));
        let help = text(&o.stdout);
        let name = if path.is_empty() {
            "qloop".to_string()
        } else {
            format!("qloop {}", path.join(" "))
        };
        out.push_str(&format!(
            "\n## `{name}`\n\n```text\n{}\n```\n",
            help.trim_end()
        ));
        let mut subs: Vec<Vec<String>> = subcommands(&help)
            .into_iter()
            .map(|s| {
                let mut p = path.clone();
                p.push(s);
                p
            })
            .collect();
        subs.reverse();
        todo.extend(subs);
    }
    out
}

/// The crate map: each workspace crate's direct dependencies, from its manifest.
fn crate_map() -> String {
    let manifest: toml::Value =
        toml::from_str(&std::fs::read_to_string(root().join("Cargo.toml")).unwrap()).unwrap();
    let members = manifest["workspace"]["members"].as_array().unwrap();
    let mut out =
        String::from("| crate | path | dependencies | dev-dependencies |\n|---|---|---|---|\n");
    for m in members {
        let dir = m.as_str().unwrap();
        let cargo: toml::Value =
            toml::from_str(&std::fs::read_to_string(root().join(dir).join("Cargo.toml")).unwrap())
                .unwrap();
        let list = |key: &str| -> String {
            let Some(t) = cargo.get(key).and_then(|t| t.as_table()) else {
                return "—".to_string();
            };
            let names: Vec<String> = t
                .iter()
                .map(|(n, v)| {
                    if v.get("optional").and_then(|o| o.as_bool()) == Some(true) {
                        format!("`{n}` (optional)")
                    } else {
                        format!("`{n}`")
                    }
                })
                .collect();
            if names.is_empty() {
                "—".to_string()
            } else {
                names.join(", ")
            }
        };
        out.push_str(&format!(
            "| `{}` | `{dir}/` | {} | {} |\n",
            cargo["package"]["name"].as_str().unwrap(),
            list("dependencies"),
            list("dev-dependencies")
        ));
    }
    out
}

/// Compares a generated text with a committed one, or writes it under `QLOOP_BLESS=1`.
fn generated(path: &Path, want: &str) {
    let bless = std::env::var_os("QLOOP_BLESS").is_some_and(|v| v == "1");
    let have = std::fs::read_to_string(path).unwrap_or_default();
    if bless && have != want {
        let tmp = path.with_extension("md.tmp");
        std::fs::write(&tmp, want).unwrap();
        std::fs::rename(&tmp, path).unwrap();
        return;
    }
    assert!(
        have == want,
        "{} is stale: rerun with QLOOP_BLESS=1 and review the diff (first difference at line {})",
        rel(path),
        have.lines()
            .zip(want.lines())
            .position(|(a, b)| a != b)
            .map_or(have.lines().count().min(want.lines().count()) + 1, |i| i
                + 1)
    );
}

#[test]
fn the_cli_reference_is_the_binarys_help() {
    generated(&book().join("reference/cli.md"), &cli_reference());
}

/// The crate map between the markers of `internals/architecture.md`.
#[test]
fn the_crate_map_is_the_manifests() {
    let path = book().join("internals/architecture.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let (begin, end) = (
        "<!-- crate-map: generated -->\n",
        "<!-- crate-map: end -->\n",
    );
    let i = page.find(begin).expect("the crate map's begin marker") + begin.len();
    let j = page.find(end).expect("the crate map's end marker");
    let want = format!("{}{}{}", &page[..i], crate_map(), &page[j..]);
    generated(&path, &want);
}

/// Number words and numerals up to twenty.
fn number(word: &str) -> Option<usize> {
    const WORDS: [&str; 21] = [
        "zero",
        "one",
        "two",
        "three",
        "four",
        "five",
        "six",
        "seven",
        "eight",
        "nine",
        "ten",
        "eleven",
        "twelve",
        "thirteen",
        "fourteen",
        "fifteen",
        "sixteen",
        "seventeen",
        "eighteen",
        "nineteen",
        "twenty",
    ];
    let w = word.to_lowercase();
    WORDS
        .iter()
        .position(|x| *x == w)
        .or_else(|| w.parse().ok())
}

/// "N seed specs" and "N seed controllers" in prose are the number of `verified/specs` files.
#[test]
fn counts_of_the_seed_specs_are_the_seed_specs() {
    let seeds = test_tools::spec_stems_in("verified/specs").len();
    let mut found = 0;
    let mut bad = Vec::new();
    for p in pages() {
        let src = std::fs::read_to_string(&p).unwrap();
        for (n, line) in src.lines().enumerate() {
            let words: Vec<&str> = line
                .split(|c: char| !c.is_alphanumeric())
                .filter(|w| !w.is_empty())
                .collect();
            for w in words.windows(3) {
                if w[1] == "seed" && (w[2] == "specs" || w[2] == "controllers") {
                    if let Some(k) = number(w[0]) {
                        found += 1;
                        if k != seeds {
                            bad.push(format!(
                                "{}:{}: `{} seed {}`, but verified/specs holds {seeds}",
                                rel(&p),
                                n + 1,
                                w[0],
                                w[2]
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(found >= 1, "no count of the seed specs found");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

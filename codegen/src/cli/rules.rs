//! `qloop rules`: the safety-rule libraries a spec can `use`.

use super::error::{CliError, CliResult};
use qloop_core::lang::rules::{library_names, library_rules, LIBRARIES};

/// Prints the text of every library, of one library, or of one rule (by name).
pub fn run(name: Option<&str>) -> CliResult {
    let Some(name) = name else {
        for (lib, text) in LIBRARIES {
            println!("// use {lib};\n{text}");
        }
        return Ok(());
    };
    if let Some((lib, text)) = LIBRARIES.iter().find(|(l, _)| *l == name) {
        println!("// use {lib};\n{text}");
        return Ok(());
    }
    for (lib, text) in LIBRARIES {
        let rules = library_rules(lib)
            .expect("listed")
            .map_err(|d| CliError::tool(format!("rules library `{lib}`: {}", d.message)))?;
        if rules.iter().any(|r| r.name == name) {
            // The rule's text: from its doc comment to the next rule's.
            let at = format!("rule {name}(");
            let start = text.find(&at).unwrap_or(0);
            let doc = text[..start].rfind("\n\n").map_or(0, |k| k + 2);
            let end = text[start..]
                .find("\n\n///")
                .map_or(text.len(), |k| start + k + 1);
            println!("// use {lib};\n{}", &text[doc..end]);
            return Ok(());
        }
    }
    Err(CliError::Input {
        msg: format!("no rules library or rule named `{name}`"),
        help: Some(format!(
            "the libraries are {}; `qloop rules` prints them all",
            library_names()
        )),
    })
}

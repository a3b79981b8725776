//! HAL and halcompile naming rules for the LinuxCNC component, and text escaping for its
//! doc strings.
//!
//! In the `.comp`'s C, halcompile turns every pin, param and variable into a macro of its bare
//! name and defines a few file-scope symbols of its own; the RTAPI headers and GCC predefine
//! more. A HAL name must therefore be a plain lower-case C identifier that none of these use,
//! and its full HAL name (`PREFIX.0.NAME`, `_` shown as `-`) must fit `HAL_NAME_LEN`.
//!
//! A vector's element is a pin of its own, named after the element's generated name
//! (`theta_0`, `p_1_0`; HAL `theta-0`, `p-1-0`): the name halcompile gives the pins of its
//! own arrays (`pin in float in-#[2]` is `in-0`, `in-1`), and the same identifier in C as
//! the pin's macro, so one uniqueness check in C covers HAL too.

/// `HAL_NAME_LEN` of LinuxCNC's `hal.h`: the longest pin, param or function name.
pub const HAL_NAME_LEN: usize = 47;

/// Names a pin or param cannot have, each for a reason:
/// * halcompile's own reserved list, file-scope symbols of the C it writes (`export`, `count`,
///   `default_count`, `names`), the function argument `period` and the macro `data`
///   (`option data`);
/// * the pin and params HAL adds for every function (`NAME.time`, `.tmax`, `.tmax-increased`);
/// * halcompile keywords (its scanner may read an exact keyword as the keyword);
/// * C keywords and GNU C's (a pin is a field of the instance struct);
/// * object-like macros that GCC or the RTAPI/HAL headers predefine in lower case (the
///   instance struct is compiled with them in force).
const RESERVED: &[&str] = &[
    // halcompile
    "comp_id",
    "fperiod",
    "rtapi_app_main",
    "rtapi_app_exit",
    "extra_setup",
    "extra_cleanup",
    "export",
    "count",
    "default_count",
    "names",
    "period",
    "data",
    "personality",
    // HAL, per function
    "time",
    "tmax",
    "tmax_increased",
    // halcompile keywords
    "component",
    "pin",
    "param",
    "function",
    "variable",
    "option",
    "include",
    "modparam",
    "license",
    "author",
    "description",
    "notes",
    "examples",
    "see_also",
    "if",
    "in",
    "out",
    "io",
    "r",
    "rw",
    "float",
    "bit",
    "signed",
    "unsigned",
    "s32",
    "u32",
    "fp",
    "nofp",
    "yes",
    "no",
    "true",
    "false",
    // GNU C keywords (C99's: `c::C99_KEYWORDS`)
    "asm",
    "typeof",
    // predefined lower-case object-like macros (gcc -dM -E with halcompile's flags and headers)
    "linux",
    "unix",
    "realtime",
    "errno",
    "bool",
    "sched_priority",
];

/// Prefixes a pin or param cannot have: C's reserved leading underscore (and halcompile's
/// `__comp_*`), the component's own `qloop_` glue, and the RTAPI and HAL APIs.
const RESERVED_PREFIXES: &[&str] = &["_", "qloop_", "rtapi_", "hal_"];

/// The HAL name of a spec name: the name in lower case. `None` if it is not a plain ASCII
/// C identifier.
pub fn hal_name(spec_name: &str) -> Option<String> {
    let ok = spec_name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && spec_name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_');
    ok.then(|| spec_name.to_ascii_lowercase())
}

/// Why `name` cannot be a pin or param of component `comp`, if it cannot.
pub fn reserved(name: &str, spec: &str) -> Option<String> {
    if RESERVED.contains(&name) || crate::emit::c::C99_KEYWORDS.contains(&name) {
        return Some(format!(
            "`{name}` is reserved in a halcompile component (a halcompile, HAL or C name)"
        ));
    }
    let own = format!("{spec}_");
    RESERVED_PREFIXES
        .iter()
        .copied()
        .chain(std::iter::once(own.as_str()))
        .find(|p| name.starts_with(p))
        .map(|p| {
            format!("`{name}` starts with `{p}`, reserved for the component's C and its libraries")
        })
}

/// Why halcompile would give the pin or param `name` another name than `name` in C or than
/// [`dashed`] in HAL, if it would: it merges a run of underscores into one in C (`x__0` is the
/// macro `x_0`) and drops a trailing one in HAL (`x_` is `x`). A vector `x_[2]` has such
/// elements (`x__0`).
pub fn changed_by_halcompile(name: &str) -> Option<String> {
    (name.contains("__") || name.ends_with('_')).then(|| {
        format!(
            "halcompile would rename `{name}` (it merges repeated underscores and drops a \
             trailing one)"
        )
    })
}

/// A name as HAL shows it: `_` becomes `-`.
pub fn dashed(name: &str) -> String {
    name.replace('_', "-")
}

/// A one-line halcompile string (`"..."`, read by Python's `eval`, shown in the man page):
/// line breaks as spaces, a backslash as troff's `\e` and a double quote as troff's `\(dq`
/// (halcompile's scanner admits no `"` inside a string, escaped or not).
pub fn string(text: &str) -> String {
    let one_line = text.split_whitespace().collect::<Vec<_>>().join(" ");
    format!("\"{}\"", escape(&one_line))
}

/// A paragraph for a halcompile `"""..."""` section (troff): escaped as in [`string`] (so no
/// `"` can end the section early), and a line that would start with a troff control character
/// (`.` or `'`), or be halcompile's `;;` separator, protected by `\&`.
pub fn troff(text: &str) -> String {
    text.lines()
        .map(|l| {
            let e = escape(l.trim_end());
            if e.starts_with('.') || e.starts_with('\'') || e == ";;" {
                format!("\\\\&{e}")
            } else {
                e
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn escape(s: &str) -> String {
    s.replace('\\', "\\\\e").replace('"', "\\\\(dq")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(hal_name("K_LOOP").as_deref(), Some("k_loop"));
        assert_eq!(hal_name("fc2").as_deref(), Some("fc2"));
        assert_eq!(hal_name("ω"), None);
        assert!(reserved("period", "x").is_some());
        assert!(reserved("tmax_increased", "x").is_some());
        assert!(reserved("qloop_in", "x").is_some());
        assert!(reserved("x_state", "x").is_some());
        assert!(reserved("_a", "x").is_some());
        assert!(reserved("feed", "x").is_none());
        assert_eq!(dashed("k_loop"), "k-loop");
        assert!(changed_by_halcompile("x__0").is_some());
        assert!(changed_by_halcompile("x_").is_some());
        assert!(changed_by_halcompile("p_1_0_raw").is_none());
    }

    #[test]
    fn escaping() {
        assert_eq!(string("a \"b\"\n  c\\d"), r#""a \\(dqb\\(dq c\\ed""#);
        assert_eq!(troff(".x\n'y\nz.\n;;"), "\\\\&.x\n\\\\&'y\nz.\n\\\\&;;");
    }
}

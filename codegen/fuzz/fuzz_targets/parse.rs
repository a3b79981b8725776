//! The spec parser on arbitrary text: it returns a spec or a located error, and never panics,
//! overflows the stack or hangs.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(src) = std::str::from_utf8(data) {
        if let Err(d) = qloop::spec::parse::parse_str(src) {
            let (line, col) = d.line_col();
            assert!(line >= 1 && col >= 1, "error without a place: {}", d.message);
        }
    }
});
